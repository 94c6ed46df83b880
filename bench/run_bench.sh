#!/bin/sh
# run_bench.sh: `make bench`: runs the benchmark on the shipped scenes and prints its figures.
cd "$(dirname "$0")/.." || exit 1
for scene in scenes/cornell-box.gltf scenes/caustic.gltf; do
    build/rel/bench_pm "$scene" || exit 1
done
# the photon pass against raw Embree on its own rays, every shipped scene
for scene in scenes/*.gltf; do
    build/rel/photon_ceiling "$scene" || exit 1
done
# what clipped estimates cost, every shipped scene: time, and error at equal time
sh bench/clip_bench.sh || exit 1
build/rel/texture_footprint || exit 1
build/rel/json_load || exit 1
sh bench/window_room_bench.sh || exit 1
sh bench/default_vs_pathtrace.sh || exit 1
sh bench/lambert_bench.sh || exit 1
sh bench/cluster_bench.sh || exit 1
sh bench/window_bench.sh || exit 1
sh bench/instancing_bench.sh || exit 1
sh bench/window_motion_bench.sh
sh bench/memory_table.sh || exit 1

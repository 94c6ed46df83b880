#!/bin/sh
# eye_passes.sh: equal-time relMSE of the shipped scenes at 64x64 against their Mitsuba references, for each --eye-passes setting.
#
# Usage: sh bench/eye_passes.sh [SECONDS [SEEDS [SETTINGS]]]   (defaults: 16, "1 2", "1 2 4 8 auto")
# One line per run: scene, seed, setting, relMSE, photon passes and samples. Runs alternate the
# settings within a scene and seed, so a machine's drift over the runs falls on all of them alike.
cd "$(dirname "$0")/.." || exit 1
seconds=${1:-16}
seeds=${2:-"1 2"}
settings=${3:-"1 2 4 8 auto"}
for pair in cornell-box:cornell_path_64 caustic:caustic_floor_64 glossy-spheres:glossy_path_64 \
            mirror-caustic:mirror_path_64 point-room:point_room_path_64; do
    scene=${pair%%:*}
    ref=${pair##*:}
    for seed in $seeds; do
        for k in $settings; do
            out=$(./pmview "scenes/$scene.gltf" --sky none --width 64 --height 64 --time "$seconds" --threads 2 \
                  --seed "$seed" --eye-passes "$k" --reference "tests/ref/$ref.exr" --stats \
                  --snapshot "${TMPDIR:-/tmp}/eye_passes.exr" 2>&1) || { echo "$scene: pmview failed"; exit 1; }
            relmse=$(echo "$out" | sed -n 's/^stat error .*relmse=\([0-9.e+-]*\).*/\1/p')
            passes=$(echo "$out" | sed -n 's/^stat progressive .*photon_passes=\([0-9]*\).*/\1/p')
            samples=$(echo "$out" | sed -n 's/^stat progressive iterations=\([0-9]*\).*/\1/p')
            echo "$scene seed=$seed eye_passes=$k relmse=$relmse photon_passes=$passes samples=$samples"
        done
    done
done

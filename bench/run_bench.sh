#!/bin/sh
# run_bench.sh: `make bench`: runs every benchmark once, keeps their lines in build/bench/bench.log and writes docs/benchmarks.md from that one run (tools/bench_report.py).
#
# Every step's output goes to the terminal and to the log; the log's `run` lines record the commit,
# the machine (nproc, load average at the start and the end) and each step's seconds, which the
# report prints beside the figures. A step that fails is named in the report's header and makes
# `make bench` fail; the others still run. Knobs (the defaults make the complete run):
#   BENCH_SECONDS      wall time of each equal-time render (the scripts' own defaults: 10, MPI 5)
#   BENCH_SEEDS        seeds of the equal-time comparisons (default 1; MPI 1 to 5)
#   BENCH_STEPS        the steps to run, by name (default all; a partial run writes no report)
#   BENCH_REPORT       where the report goes (default docs/benchmarks.md; - for none)
cd "$(dirname "$0")/.." || exit 1
mkdir -p build/bench
log=build/bench/bench.log
report=${BENCH_REPORT:-docs/benchmarks.md}
steps_all="ray_throughput photon_ceiling default_vs_pathtrace clip window_room cluster window window_motion first_image instancing memory texture_footprint json_load"
steps=${BENCH_STEPS:-$steps_all}
[ "$steps" = "$steps_all" ] || report=-
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
now() { date +%s.%N; }
loadavg() { cut -d' ' -f1-3 /proc/loadavg | tr ' ' ','; }
dirty=0
[ -n "$(git status --porcelain --untracked-files=no 2>/dev/null)" ] && dirty=1
start=$(now)
failed=""
{
    echo "run start commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown) dirty=$dirty date=$(date -u +%Y-%m-%dT%H:%M:%SZ) nproc=$(nproc) load_start=$(loadavg) command=make_bench"
    echo "run host cpu=$(sed -n 's/^model name[^:]*: //p' /proc/cpuinfo | head -n 1 | tr ' ' '_') mem_gb=$(awk '/MemTotal/ { printf "%.1f", $2 / 1048576 }' /proc/meminfo)"
} | tee "$log"

# step NAME COMMAND...: runs it, its output to the terminal and the log, then a `run step` line
step() {
    name=$1; shift
    case " $steps " in *" $name "*) ;; *) return 0 ;; esac
    t0=$(now)
    { "$@"; echo $? >"$tmp/rc"; } 2>&1 | tee -a "$log"
    rc=$(cat "$tmp/rc")
    [ "$rc" = 0 ] || failed="$failed $name"
    echo "run step name=$name status=$rc seconds=$(awk -v a="$t0" -v b="$(now)" 'BEGIN { printf "%.1f", b - a }') load=$(loadavg)" | tee -a "$log"
}
ray_throughput() { for s in scenes/cornell-box.gltf scenes/caustic.gltf; do build/rel/bench_pm "$s" || return 1; done; }
# the shipped scenes, then a mesh far larger than the caches (bench/big_scene.py's height field of a
# million triangles, with shared vertices as exported meshes have): where the pass prefetches its hits;
# a grid of 10,000 placements of one small mesh, where every hit is located among the placements; and a
# room lit by an emissive sphere of 200,000 triangles, where each photon's emitter is prefetched
photon_ceiling() {
    for s in scenes/*.gltf; do build/rel/photon_ceiling "$s" || return 1; done
    python3 bench/instanced_scene.py "$tmp/placements-10k.glb" --placements 10000 --triangles 200 >/dev/null || return 1
    build/rel/photon_ceiling "$tmp/placements-10k.glb" || return 1
    python3 bench/emissive_scene.py "$tmp/emissive-sphere-200k.glb" 200000 >/dev/null || return 1
    build/rel/photon_ceiling "$tmp/emissive-sphere-200k.glb" || return 1
    py=python3
    python3 -c "import numpy" 2>/dev/null || py=/usr/bin/python3
    if $py -c "import numpy" 2>/dev/null; then
        $py bench/big_scene.py "$tmp/height-field-1m.glb" 1 --smooth >/dev/null || return 1
        build/rel/photon_ceiling "$tmp/height-field-1m.glb" || return 1
    else
        echo "bench photon_ceiling: the height field skipped (python3 numpy missing)"
    fi
    # textured models by others (where the pass prefetches its hits' texels), when they are at hand
    models=${PMVIEW_REAL_MODELS:-../shared/real-models}
    for m in LightsPunctualLamp/LightsPunctualLamp.gltf MultiUVTest/MultiUVTest.gltf; do
        if [ -f "$models/$m" ]; then build/rel/photon_ceiling "$models/$m" || return 1
        else echo "bench photon_ceiling: $m skipped (not in $models; set PMVIEW_REAL_MODELS)"; fi
    done
}
first_image() { sh bench/first_image.sh "${BENCH_ROUNDS:-5}" ./pmview | sed -n 's/^\.\/pmview /bench first_image /p'; }

step ray_throughput ray_throughput
step photon_ceiling photon_ceiling
step default_vs_pathtrace sh bench/default_vs_pathtrace.sh
step clip sh bench/clip_bench.sh
step window_room sh bench/window_room_bench.sh
step cluster sh bench/cluster_bench.sh
step window sh bench/window_bench.sh
step window_motion sh bench/window_motion_bench.sh
step first_image first_image
step instancing sh bench/instancing_bench.sh
step memory sh bench/memory_table.sh
step texture_footprint build/rel/texture_footprint
step json_load build/rel/json_load

seconds=$(awk -v a="$start" -v b="$(now)" 'BEGIN { printf "%.0f", b - a }')
echo "run end seconds=$seconds load_end=$(loadavg) failed=$(echo $failed | tr ' ' ',')" | tee -a "$log"
echo "make bench: $seconds s ($((seconds / 60)) min $((seconds % 60)) s)${failed:+, failed:$failed}"
if [ "$report" != - ]; then
    python3 tools/bench_report.py "$log" >"$tmp/report.md" && cp "$tmp/report.md" "$report" &&
        echo "make bench: wrote $report from $log" || { echo "make bench: tools/bench_report.py failed"; exit 1; }
fi
[ -z "$failed" ]

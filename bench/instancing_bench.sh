#!/bin/sh
# instancing_bench.sh: issue 30's instancing figures ("bench instancing" lines): peak memory, load and BVH build times of a generated file placing one mesh many times, instanced against flattened, and the image difference between the two at the same seed.
#
# bench/instanced_scene.py writes the files: a torus of TRIANGLES (default 20000) triangles placed
# PLACEMENTS (default 2000) times, and a PLACEMENTS_FLAT (default 100) placement pair, instanced
# and --flat (each node its own mesh), small enough to flatten. Each render is a 256x256
# snapshot on 2 threads; peak RSS is pmview's `stat memory peak_rss_bytes`. The image line
# measures the instanced render against the flat one at seed 1 (relmse_same_seed) and the flat
# one at seed 2 against it (relmse_other_seed): the first must be far below the second.
cd "$(dirname "$0")/.." || exit 1
tris=${TRIANGLES:-20000}
placements=${PLACEMENTS:-2000}
flat_placements=${PLACEMENTS_FLAT:-100}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
field() { sed -n "s/.*[ ]$1=\([^ ]*\).*/\1/p" "$2" | tail -n 1; }
run() { # label file extra-args...
    label=$1 file=$2
    shift 2
    ./pmview "$file" --snapshot "$tmp/$label.exr" --width 256 --iterations 4 --threads 2 --stats --quiet "$@" >"$tmp/$label.log" 2>&1 ||
        { echo "bench instancing: $label failed"; cat "$tmp/$label.log"; exit 1; }
    echo "bench instancing case=$label placements=$(field placements "$tmp/$label.log") placed_triangles=$(field placed_triangles "$tmp/$label.log") unique_triangles=$(field unique_triangles "$tmp/$label.log") load_seconds=$(sed -n 's/^stat load seconds=\([^ ]*\).*/\1/p' "$tmp/$label.log") bvh_seconds=$(sed -n 's/^stat bvh seconds=\([^ ]*\).*/\1/p' "$tmp/$label.log") peak_rss_mb=$(( $(field peak_rss_bytes "$tmp/$label.log") / 1048576 ))"
}
python3 bench/instanced_scene.py "$tmp/big.glb" --placements "$placements" --triangles "$tris" || exit 1
python3 bench/instanced_scene.py "$tmp/small.glb" --placements "$flat_placements" --triangles "$tris" || exit 1
python3 bench/instanced_scene.py "$tmp/small_flat.glb" --placements "$flat_placements" --triangles "$tris" --flat || exit 1
run instanced_$placements "$tmp/big.glb"
run instanced_$flat_placements "$tmp/small.glb"
run flat_$flat_placements "$tmp/small_flat.glb"
run flattened_option_$flat_placements "$tmp/small.glb" --flatten-instances
./pmview "$tmp/small.glb" --snapshot "$tmp/a.exr" --width 256 --iterations 16 --threads 2 --seed 1 --quiet >/dev/null 2>&1 &&
./pmview "$tmp/small_flat.glb" --snapshot "$tmp/f1.exr" --width 256 --iterations 16 --threads 2 --seed 1 --quiet >/dev/null 2>&1 || exit 1
same=$(./pmview "$tmp/small.glb" --snapshot "$tmp/x.exr" --width 256 --iterations 16 --threads 2 --seed 1 --quiet --stats --reference "$tmp/f1.exr" 2>&1 | sed -n 's/^stat error .* relmse=\([^ ]*\).*/\1/p')
other=$(./pmview "$tmp/small_flat.glb" --snapshot "$tmp/x.exr" --width 256 --iterations 16 --threads 2 --seed 2 --quiet --stats --reference "$tmp/f1.exr" 2>&1 | sed -n 's/^stat error .* relmse=\([^ ]*\).*/\1/p')
echo "bench instancing image placements=$flat_placements relmse_same_seed=$same relmse_other_seed=$other"

#!/bin/sh
# test_gpu_instancing.sh: EXT_mesh_gpu_instancing places a mesh as the same transforms written as nodes do (the same image, the same memory), 10^6 instances load within the memory forecast, and broken attributes are refused in one line or warned as node transforms are.
cd "$(dirname "$0")/.." || exit 1
. tests/cli_setup.sh
checks=0; fails=0
fail() { fails=$((fails + 1)); echo "FAIL: $*"; sed 's/^/    /' "$tmp/err" | head -5; }
scene() { python3 tests/gpu_instancing_scene.py "$@" || { echo "FAIL: tests/gpu_instancing_scene.py $*"; exit 1; }; }
stat_of() { awk -v s="$1" -v k="$2" '$1 == "stat" && $2 == s { for (i = 3; i <= NF; i++) { split($i, kv, "="); if (kv[1] == k) print kv[2] } }' "$tmp/out"; }

# 400 boxes under a moved and turned parent: by the extension, and by 400 child nodes with the same
# translation, rotation and scale. The node form is itself instanced (one mesh, many nodes).
scene "$tmp/gpu.glb" --instances 400
scene "$tmp/nodes.glb" --instances 400 --form nodes
render() { # FILE OUT SEED [more]
    f=$1; out=$2; seed=$3; shift 3
    ./pmview "$f" --width 96 --iterations 8 --seed "$seed" --quiet --stats --snapshot "$out" "$@" >"$tmp/out" 2>"$tmp/err"
}
checks=$((checks + 1))
render "$tmp/nodes.glb" "$tmp/nodes.exr" 1 || fail "the node form: exit $?"
nodes_bvh=$(stat_of bvh bytes); nodes_tris=$(stat_of load triangles)
render "$tmp/nodes.glb" "$tmp/nodes2.exr" 2 --reference "$tmp/nodes.exr"
noise=$(stat_of error relmse)
checks=$((checks + 1))
render "$tmp/gpu.glb" "$tmp/gpu.exr" 1 --reference "$tmp/nodes.exr" || fail "the extension's form: exit $?"
same=$(stat_of error relmse); ratio=$(stat_of error mean_ratio_g)
gpu_bvh=$(stat_of bvh bytes); gpu_tris=$(stat_of load triangles)
echo "400 instances: relMSE against the node form $same (seed 1), between seeds 1 and 2 of the node form $noise;" \
     "mean ratio $ratio; stored triangles $gpu_tris and $nodes_tris, BVH bytes $gpu_bvh and $nodes_bvh"
checks=$((checks + 1))
awk -v a="$same" -v n="$noise" -v r="$ratio" 'BEGIN { exit !(a != "" && n > 0 && a <= 0.1 * n && r > 0.99 && r < 1.01) }' ||
    fail "the extension must render the node form's image within noise (relMSE $same against $noise between seeds, mean ratio $ratio)"
checks=$((checks + 1))
[ -n "$gpu_tris" ] && [ "$gpu_tris" = "$nodes_tris" ] && [ "$gpu_bvh" = "$nodes_bvh" ] && [ "$gpu_tris" -lt 100 ] ||
    fail "the extension must store the box once, as the node form does (triangles $gpu_tris and $nodes_tris, BVH $gpu_bvh and $nodes_bvh bytes)"

# 10^6 instances of the 12-triangle box: loaded, built and rendered within the memory forecast
# (optimised build: ASan's shadow memory is not in the forecast)
scene "$tmp/million.glb" --instances 1000000
checks=$((checks + 1))
./pmview "$tmp/million.glb" --width 64 --iterations 1 --quiet --stats --snapshot "$tmp/m.png" >"$tmp/out" 2>"$tmp/err" ||
    fail "10^6 instances: exit $?"
over=$(stat_of memory peak_over_estimate)
echo "10^6 instances: stored triangles $(stat_of load triangles), peak RSS $(stat_of memory peak_rss_bytes) bytes, peak / forecast $over," \
     "load $(stat_of load seconds) s, BVH $(stat_of bvh seconds) s"
checks=$((checks + 1))
awk -v r="$over" 'BEGIN { exit !(r != "" && r >= 0.75 && r <= 1.25) }' || fail "10^6 instances: peak / forecast $over outside 0.75-1.25"
checks=$((checks + 1))
[ "$(stat_of load triangles)" = 14 ] || fail "10^6 instances must store 14 triangles (the box and the floor), not $(stat_of load triangles)"

# broken attributes: one error line naming the node and what is wrong, as a node's transform is refused
refused() { # KIND EXPECTED
    scene "$tmp/bad.glb" --instances 16 --bad "$1"
    checks=$((checks + 1))
    $bin "$tmp/bad.glb" --width 16 --iterations 1 --snapshot "$tmp/x.exr" >"$tmp/out" 2>"$tmp/err"
    rc=$?
    if [ $rc -ne 1 ] || [ "$(wc -l < "$tmp/err")" -ne 1 ] || ! grep -q "^pmview: error: $tmp/bad.glb: $2" "$tmp/err"; then
        fail "--bad $1: want exit 1 and one line \"$2\", got exit $rc"
    else
        echo "--bad $1: $(cat "$tmp/err")"
    fi
}
refused type "TRANSLATION must be a float VEC3 (accessor 5, node 4 EXT_mesh_gpu_instancing)"
refused count "SCALE count 15 differs from the other attributes' 16 (node 4 EXT_mesh_gpu_instancing)"
refused nan "non-finite TRANSLATION at instance 8 (accessor 5, node 4 EXT_mesh_gpu_instancing)"
refused rotation "ROTATION quaternion has zero length at instance 1 (node 4 EXT_mesh_gpu_instancing)"
refused missing "no TRANSLATION, ROTATION or SCALE attribute (node 4 EXT_mesh_gpu_instancing)"
# a zero scale makes nothing to render: that instance is left out with one warning, the rest render
scene "$tmp/zero.glb" --instances 16 --bad zero-scale
checks=$((checks + 1))
$bin "$tmp/zero.glb" --width 16 --iterations 1 --stats --snapshot "$tmp/x.exr" >"$tmp/out" 2>"$tmp/err"
rc=$?
{ [ $rc -eq 0 ] && [ "$(wc -l < "$tmp/err")" -eq 1 ] &&
  grep -q "warning: $tmp/zero.glb: left out 1 EXT_mesh_gpu_instancing instance(s) with a zero SCALE component (first: instance 1, node 4 EXT_mesh_gpu_instancing)" "$tmp/err"; } ||
    fail "a zero scale: want exit 0 and one warning naming instance 1 (exit $rc)"
echo "test_gpu_instancing: $checks checks, $fails failed"
[ "$fails" -eq 0 ]

#!/bin/sh
# test_robust.sh: out of memory is one error line and exit 1, never a crash (every allocation of a small render failed in turn, --max-memory refusing each large structure); overflowing emission warned about; a closed albedo-1 room warned about and bounded in time and memory.
cd "$(dirname "$0")/.." || exit 1
bin=./pmview
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
checks=0; fails=0
fail() { fails=$((fails + 1)); echo "FAIL: $*"; }
# one_oom_line NAME RC: exit 1 and exactly one stderr line "pmview: error: ... out of memory (what, N bytes...)"
one_oom_line() {
    checks=$((checks + 1))
    if [ "$2" -ne 1 ] || [ "$(wc -l < "$tmp/err")" -ne 1 ] || ! grep -q "^pmview: error: .*out of memory (.*[0-9] bytes" "$tmp/err"; then
        fail "$1: want exit 1 and one 'out of memory (what, N bytes)' line, got exit $2:"; cat "$tmp/err"
    fi
}
python3 tests/white_room.py "$tmp/room.gltf"

# --max-memory refuses each large structure before it is allocated (criterion: exit 1, one line naming it)
# (--gather photons: the default path-traces a room without mirrors or glass until it has measured
# what the photons would give, and an iteration of that allocates no photon records)
for case in "1K 64 scenes/cornell-box.gltf scene geometry" "100M 4096 scenes/cornell-box.gltf film" "4M 32 $tmp/room.gltf photon records"; do
    set -- $case
    $bin "$3" --quiet --width "$2" --iterations 1 --gather photons --max-memory "$1" --snapshot "$tmp/x.exr" >"$tmp/out" 2>"$tmp/err"
    one_oom_line "--max-memory $1 (${4} ${5:-})" $?
    checks=$((checks + 1))
    grep -q "(${4}${5:+ $5}" "$tmp/err" && grep -q -- "--max-memory" "$tmp/err" || fail "--max-memory $1 must name the $4 ${5:-} and --max-memory"
done
$bin scenes/cornell-box.gltf --max-memory lots --snapshot "$tmp/x.exr" 2>"$tmp/err"
rc=$?; checks=$((checks + 1)); [ $rc -eq 2 ] || fail "a bad --max-memory is a usage error (exit $rc)"
# a large --photons in the albedo-1 room under a 64 MiB limit: refused within seconds, not traced for minutes
start=$(date +%s)
$bin "$tmp/room.gltf" --quiet --width 16 --iterations 1 --photons 50000000 --gather photons --max-memory 64M --snapshot "$tmp/x.exr" >"$tmp/out" 2>"$tmp/err"
rc=$?
one_oom_line "50M photons under --max-memory 64M" $rc
checks=$((checks + 1)); [ $(( $(date +%s) - start )) -le 10 ] || fail "the refused photon pass took more than 10 s"

# every checked allocation of a small render (progressive, its photons measured and forced, and
# classic) made to fail in turn (PMVIEW_FAIL_ALLOC=N): criterion: exit 1 with one out-of-memory line
# each time, no signal; or, for the failures pmview handles (the clip cache, whose absence only
# costs BVH searches with the same answers), exit 0, silent, and the same image bit for bit
for mode in "progressive --gather auto" "progressive --gather photons" "classic"; do
    # shellcheck disable=SC2086 # mode is a fixed word list
    $bin "$tmp/room.gltf" --quiet --mode $mode --width 8 --iterations 2 --photons 1000 --threads 2 --stats --snapshot "$tmp/whole.exr" >"$tmp/out" 2>"$tmp/err"
    count=$(sed -n 's/^stat memory .*checked_allocations=\([0-9]*\).*/\1/p' "$tmp/out")
    checks=$((checks + 1)); [ "${count:-0}" -ge 10 ] || { fail "$mode: stat memory checked_allocations missing or small (${count:-none})"; continue; }
    n=1; handled=0
    while [ $n -le "$count" ]; do
        # shellcheck disable=SC2086
        PMVIEW_FAIL_ALLOC=$n $bin "$tmp/room.gltf" --quiet --mode $mode --width 8 --iterations 2 --photons 1000 --threads 2 --stats --snapshot "$tmp/x.exr" >"$tmp/out" 2>"$tmp/err"
        rc=$?
        if [ $rc -eq 0 ]; then
            checks=$((checks + 1)); handled=$((handled + 1))
            { [ ! -s "$tmp/err" ] && cmp -s "$tmp/x.exr" "$tmp/whole.exr"; } ||
                fail "$mode, allocation $n of $count failed: exit 0 must mean a handled failure, silent and the same image ($(head -c 200 "$tmp/err"))"
        else
            one_oom_line "$mode, allocation $n of $count failed" $rc
        fi
        n=$((n + 1))
    done
    echo "$mode: each of $count checked allocations failed in turn: exit 1 and one out-of-memory line, or ($handled) handled with the same image"
done

# emission beyond what a float film can sum: clamped with a warning naming the material, the image finite
python3 - "$tmp/bright.gltf" <<'PY'
import json, sys
g = json.load(open("scenes/cornell-box.gltf"))
for m in g["materials"]:
    if max(m.get("emissiveFactor", [0, 0, 0])) > 0:
        m.setdefault("extensions", {})["KHR_materials_emissive_strength"] = {"emissiveStrength": 3.0e38}
g.setdefault("extensionsUsed", []).append("KHR_materials_emissive_strength")
for b in g.get("buffers", []):
    if "uri" in b and not b["uri"].startswith("data:"):
        b["uri"] = __import__("os").path.abspath("scenes/" + b["uri"])
json.dump(g, open(sys.argv[1], "w"))
PY
$bin "$tmp/bright.gltf" --width 16 --iterations 4 --stats --snapshot "$tmp/b.exr" >"$tmp/out" 2>"$tmp/err"
rc=$?; checks=$((checks + 1))
{ [ $rc -eq 0 ] && grep -q "material [0-9]* (.*) emission 3e+38 (emissiveFactor x emissiveStrength 3e+38) clamped to 1e+20 (PM_MAX_EMISSION: a float film could not sum more), hue kept" "$tmp/err"; } ||
    { fail "emission 3e38: want exit 0 and the clamp warning naming the material (exit $rc)"; cat "$tmp/err"; }
# criterion: the image measured against itself is finite (a NaN or Inf anywhere makes relmse nan)
$bin "$tmp/bright.gltf" --width 16 --iterations 4 --quiet --reference "$tmp/b.exr" --snapshot "$tmp/b2.exr" >"$tmp/out" 2>"$tmp/err"
checks=$((checks + 1))
grep -q "^stat error .*relmse=[0-9]" "$tmp/out" && ! grep -qi "nan\|inf" "$tmp/out" || { fail "the bright image is not finite"; cat "$tmp/out"; }

# a closed albedo-1 room: the warning, and bounded memory and time (criterion: 16 iterations in
# under 30 s, peak RSS under 400 MB, at most 100 records a photon plus noise)
start=$(date +%s)
$bin "$tmp/room.gltf" --width 32 --iterations 16 --stats --snapshot "$tmp/r.exr" >"$tmp/out" 2>"$tmp/err"
rc=$?; secs=$(( $(date +%s) - start ))
rss=$(sed -n 's/^stat memory peak_rss_bytes=\([0-9]*\).*/\1/p' "$tmp/out")
per=$(awk '/^stat photons/ { for (i = 1; i <= NF; i++) { split($i, kv, "="); v[kv[1]] = kv[2] } print v["global"] / v["emitted"] }' "$tmp/out")
echo "albedo-1 room: exit $rc, $secs s, peak RSS ${rss:-?} bytes, ${per:-?} records a photon"
checks=$((checks + 1))
{ [ $rc -eq 0 ] && grep -q "conserves energy" "$tmp/err"; } || { fail "the albedo-1 room must render with the energy warning"; cat "$tmp/err"; }
checks=$((checks + 1))
[ $secs -le 30 ] && [ "${rss:-999999999999}" -le 400000000 ] && awk -v p="${per:-999}" 'BEGIN { exit !(p <= 110) }' ||
    fail "albedo-1 room not bounded: $secs s, RSS ${rss:-?}, ${per:-?} records a photon"
echo "test_robust: $checks checks, $fails failed"
[ "$fails" -eq 0 ]

#!/bin/sh
# test_outputs.sh: outputs never damage inputs: an output naming an input (or another output) is refused before any work, a read-only EXR target is refused, SIGINT/SIGTERM during an EXR write leave no temporary file (exit 130/143), and a file-size limit is one write error line (EFBIG, not SIGXFSZ).
cd "$(dirname "$0")/.." || exit 1
. tests/cli_setup.sh
checks=0; fails=0
fail() { fails=$((fails + 1)); echo "FAIL: $*"; }
# refused DESCRIPTION CAUSE FILE ORIGINAL command...: exit 1, one "pmview: error:" line holding CAUSE, FILE the same bytes as ORIGINAL
refused() {
    desc=$1; cause=$2; file=$3; original=$4; shift 4
    checks=$((checks + 1))
    "$@" >"$tmp/out" 2>"$tmp/err"
    rc=$?
    if [ $rc -ne 1 ] || [ "$(wc -l < "$tmp/err")" -ne 1 ] || ! grep -q "^pmview: error: .*$cause" "$tmp/err"; then
        fail "$desc: want exit 1 and one line with \"$cause\", got exit $rc:"; cat "$tmp/err"
    fi
    checks=$((checks + 1))
    cmp -s "$file" "$original" || { fail "$desc: $file was changed"; cp "$original" "$file"; }
}

# the inputs: a scene, a reference and a sky map, each a copy whose bytes are known
cp scenes/caustic.gltf "$tmp/scene.gltf"
./pmview "$tmp/scene.gltf" --width 16 --height 16 --iterations 1 --quiet --snapshot "$tmp/ref.exr" || fail "making the reference"
cp "$tmp/ref.exr" "$tmp/sky.exr"
mkdir "$tmp/sub" "$tmp/orig"
cp "$tmp/scene.gltf" "$tmp/ref.exr" "$tmp/sky.exr" "$tmp/orig/"
scene=$tmp/orig/scene.gltf; ref=$tmp/orig/ref.exr; sky=$tmp/orig/sky.exr

refused "--log naming the scene" "--log would overwrite the scene file, an input" "$tmp/scene.gltf" "$scene" \
    $bin "$tmp/scene.gltf" --width 16 --height 16 --iterations 1 --log "$tmp/scene.gltf" --snapshot "$tmp/x.exr"
refused "--log naming the reference" "--log would overwrite the --reference image, an input" "$tmp/ref.exr" "$ref" \
    $bin "$tmp/scene.gltf" --width 16 --height 16 --iterations 1 --reference "$tmp/ref.exr" --log "$tmp/ref.exr" --snapshot "$tmp/x.exr"
refused "--snapshot naming the reference in other words" "--snapshot would overwrite the --reference image, an input" "$tmp/ref.exr" "$ref" \
    $bin "$tmp/scene.gltf" --width 16 --height 16 --iterations 1 --reference "$tmp/ref.exr" --snapshot "$tmp/sub/../ref.exr"
refused "--snapshot naming the sky map" "--snapshot would overwrite the --sky map, an input" "$tmp/sky.exr" "$sky" \
    $bin "$tmp/scene.gltf" --width 16 --height 16 --iterations 1 --sky "$tmp/sky.exr" --snapshot "$tmp/sky.exr"
ln -s scene.gltf "$tmp/link.csv"
refused "--log naming a link to the scene" "--log would overwrite the scene file, an input" "$tmp/scene.gltf" "$scene" \
    $bin "$tmp/scene.gltf" --width 16 --height 16 --iterations 1 --log "$tmp/link.csv" --snapshot "$tmp/x.exr"
refused "--log and --snapshot naming one new file" "--snapshot and --log name the same file" "$tmp/scene.gltf" "$scene" \
    $bin "$tmp/scene.gltf" --width 16 --height 16 --iterations 1 --log "$tmp/./out.exr" --snapshot "$tmp/sub/../out.exr"
checks=$((checks + 1))
[ ! -e "$tmp/out.exr" ] && [ ! -e "$tmp/x.exr" ] || fail "a refused run wrote a file"
# and a run whose outputs are all distinct from its inputs goes ahead
$bin "$tmp/scene.gltf" --width 16 --height 16 --iterations 2 --quiet --reference "$tmp/ref.exr" --log "$tmp/run.csv" --snapshot "$tmp/run.exr" >"$tmp/out" 2>"$tmp/err"
rc=$?; checks=$((checks + 1))
[ $rc -eq 0 ] && [ -s "$tmp/run.csv" ] && [ -s "$tmp/run.exr" ] || { fail "distinct outputs: exit $rc"; cat "$tmp/err"; }

# a read-only EXR target is refused before any work (a rename would replace it although its owner protected it); root may
# write anything, so as root the run is made as nobody
mkdir "$tmp/locked"; chmod 777 "$tmp/locked"; chmod 711 "$tmp"
printf 'keep' > "$tmp/locked/r.exr"; chmod 444 "$tmp/locked/r.exr"; printf 'keep' > "$tmp/orig/keep"
as_user=""
[ "$(id -u)" -eq 0 ] && as_user="setpriv --reuid=65534 --regid=65534 --clear-groups"
if [ -n "$as_user" ] && ! $as_user true 2>/dev/null; then
    echo "read-only EXR target: cannot become nobody; not checked"
else
    refused "a read-only EXR target" "r.exr: cannot write the file (Permission denied)" "$tmp/locked/r.exr" "$tmp/orig/keep" \
        $as_user $bin scenes/cornell-box.gltf --width 16 --iterations 1 --snapshot "$tmp/locked/r.exr"
fi

# SIGINT and SIGTERM while the EXR is being written (pmview holds an unnamed file of the folder
# open, "/folder/#NNN (deleted)" in /proc/PID/fd): nothing is left of it, the previous file stays
# as it was, the exit status is 130 or 143
mkdir "$tmp/sig"
for signal in INT:130 TERM:143; do
    printf 'previous' > "$tmp/sig/s.exr"
    ./pmview scenes/cornell-box.gltf --width 1448 --height 1448 --iterations 1 --no-photons --quiet --snapshot "$tmp/sig/s.exr" >"$tmp/out" 2>"$tmp/err" &
    pid=$!
    caught=0
    while kill -0 $pid 2>/dev/null; do
        if ls -l "/proc/$pid/fd" 2>/dev/null | grep -q -- "-> $tmp/sig/#[0-9]* (deleted)"; then kill -"${signal%:*}" $pid; caught=1; break; fi
        sleep 0.01
    done
    wait $pid; rc=$?
    left=$(ls -A "$tmp/sig" | grep -v -x s.exr)
    echo "SIG${signal%:*} during the EXR write: exit $rc, left behind: ${left:-nothing}"
    checks=$((checks + 1))
    if [ $caught -eq 0 ]; then fail "SIG${signal%:*}: the write ended before it was seen"; continue; fi
    [ $rc -eq "${signal#*:}" ] || { fail "SIG${signal%:*} during the write: exit $rc, want ${signal#*:}"; cat "$tmp/err"; }
    checks=$((checks + 1))
    [ -z "$left" ] || fail "SIG${signal%:*} during the write left $left behind"
    checks=$((checks + 1))
    [ "$(cat "$tmp/sig/s.exr")" = previous ] || fail "SIG${signal%:*} during the write changed the previous file"
done
# Under a file-size limit (as a full quota gives), a write past it fails with EFBIG rather than
# SIGXFSZ killing the process: one error line naming the file and the cause, exit 1, no hidden
# temporary file, a previous EXR untouched. Limit: 4 blocks (2-4 KB) for the 128-pixel images,
# 1 block (512 B-1 KB) for the log of 1000 iterations (over 1 KB), which the 8x8 PNG beside it fits. Before, the shell reported "File size limit
# exceeded" (exit 153) with no pmview line, and the EXR's temporary file stayed behind.
mkdir "$tmp/quota"
echo previous > "$tmp/quota/kept.exr"
for v in "4 kept.exr --width 128" "4 new.png --width 128" "1 small.png --width 8 --iterations 1000 --log $tmp/quota/log.csv"; do
    set -- $v
    blocks=$1; name=$2; shift 2
    checks=$((checks + 1))
    (ulimit -f "$blocks"; exec $bin "$tmp/scene.gltf" --iterations 1 --quiet --snapshot "$tmp/quota/$name" "$@") >"$tmp/out" 2>"$tmp/err"
    rc=$?
    [ "$name" = small.png ] && what="$tmp/quota/log.csv" || what="$tmp/quota/$name"
    if [ $rc -ne 1 ] || [ "$(wc -l < "$tmp/err")" -ne 1 ] || ! grep -q "^pmview: error: $what: .*File too large" "$tmp/err"; then
        fail "over the file-size limit ($name): want exit 1 and one line naming $what with \"File too large\", got exit $rc:"; cat "$tmp/err"
    fi
    checks=$((checks + 1))
    leftover=$(find "$tmp/quota" -name '.*' -type f)
    [ -z "$leftover" ] || fail "over the file-size limit ($name): temporary file left: $leftover"
done
checks=$((checks + 1))
[ "$(cat "$tmp/quota/kept.exr")" = previous ] || fail "over the file-size limit: the previous EXR was changed"
checks=$((checks + 1))
[ ! -e "$tmp/quota/new.png" ] || fail "over the file-size limit: a truncated new.png was left"
echo "test_outputs: $checks checks, $fails failed"
[ "$fails" -eq 0 ]

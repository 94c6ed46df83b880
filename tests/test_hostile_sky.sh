#!/bin/sh
# test_hostile_sky.sh: hostile --sky maps and --reference images from the command line: texels past the float range clamped with a warning and rendered exactly; cut, mislabelled, non-regular and oversized files refused in one line before the scene is loaded, and fast.
cd "$(dirname "$0")/.." || exit 1
. tests/cli_setup.sh
checks=0; fails=0
fail() { fails=$((fails + 1)); echo "FAIL: $*"; sed 's/^/    /' "$tmp/err" | head -5; }
files() { python3 tests/sky_files.py "$@" || { echo "FAIL: tests/sky_files.py $*"; exit 1; }; }
stat_of() { awk -v s="$1" -v k="$2" '$1 == "stat" && $2 == s { for (i = 3; i <= NF; i++) { split($i, kv, "="); if (kv[1] == k) print kv[2] } }' "$tmp/out"; }
# ratio A B TOL: |A/B - 1| <= TOL
near() { awk -v a="$1" -v b="$2" -v t="$3" 'BEGIN { exit !(a != "" && b > 0 && (a / b - 1) <= t && (1 - a / b) <= t) }'; }

files plane "$tmp/plane.gltf" 0.5
# a grey plane (albedo 0.5) under a map of radiance 1 with one texel at 3e38 above the horizon
# (row 2 of 16: 22.5 to 33.75 degrees from the zenith): clamped to 1e20, the plane's radiance is
# 0.5/pi x (pi + 1e20 x the texel's projected solid angle) = 2.5346e17 everywhere. Before: the
# texel's channel sum overflowed the sampling cdf, and the map lit nothing (no shadow ray).
files exr "$tmp/hot.exr" 32 16 1 5 2 3e38
want=$(python3 -c "import math; t0, t1 = math.pi * 2 / 16, math.pi * 3 / 16
print(0.5 / math.pi * (math.pi + 1e20 * 2 * math.pi / 32 * 0.5 * (math.sin(t1) ** 2 - math.sin(t0) ** 2)))")
files exr "$tmp/hot_ref.exr" 32 32 "$want"
$bin "$tmp/plane.gltf" --sky "$tmp/hot.exr" --width 32 --height 32 --iterations 8 --stats --reference "$tmp/hot_ref.exr" \
    --snapshot "$tmp/x.exr" >"$tmp/out" 2>"$tmp/err"
rc=$?; checks=$((checks + 1))
{ [ $rc -eq 0 ] && [ "$(wc -l < "$tmp/err")" -eq 1 ] &&
  grep -q "^pmview: warning: $tmp/hot.exr: 1 of 512 texels above 1e+20 or not finite clamped" "$tmp/err"; } ||
    fail "one hot texel: want exit 0 and the one-line clamp warning naming the file and 1 texel (exit $rc)"
checks=$((checks + 1))
ratio=$(stat_of error mean_ratio_g)
near "$ratio" 1 0.01 && [ "$(stat_of eye dropped_samples)" = 0 ] && [ "$(stat_of eye shadow_rays)" -gt 0 ] &&
    [ "$(stat_of sky clamped_texels)" = 1 ] ||
    fail "one hot texel: mean ratio ${ratio:-?} to the exact plane (want 1 +- 1%), dropped $(stat_of eye dropped_samples), shadow rays $(stat_of eye shadow_rays)"
echo "one texel at 3e38: mean ratio $ratio to the exact answer, warning: $(cut -c1-80 "$tmp/err")..."
# photons from that map: traced, none dropped (unclamped, the map's NaN cdf would emit none)
$bin scenes/caustic.gltf --sky "$tmp/hot.exr" --width 16 --iterations 2 --stats --quiet --snapshot "$tmp/x.exr" >"$tmp/out" 2>"$tmp/err"
rc=$?; checks=$((checks + 1))
{ [ $rc -eq 0 ] && [ "$(stat_of photons emitted)" -gt 0 ] && [ "$(stat_of photons dropped)" = 0 ] && [ "$(stat_of eye dropped_samples)" = 0 ]; } ||
    fail "photons from the clamped map: exit $rc, emitted $(stat_of photons emitted), dropped $(stat_of photons dropped)"

# 1e38 everywhere: a uniform map of 1e20, the plane at 0.5e20 (unclamped, L / pdf overflows:
# most samples would be dropped as infinite and the image 10x too dark)
files exr "$tmp/bright.exr" 32 16 1e38
files exr "$tmp/bright_ref.exr" 32 32 0.5e20
$bin "$tmp/plane.gltf" --sky "$tmp/bright.exr" --width 32 --height 32 --iterations 8 --stats --reference "$tmp/bright_ref.exr" \
    --snapshot "$tmp/x.exr" >"$tmp/out" 2>"$tmp/err"
rc=$?; checks=$((checks + 1))
ratio=$(stat_of error mean_ratio_r)
{ [ $rc -eq 0 ] && grep -q "warning: $tmp/bright.exr: 512 of 512 texels above 1e+20" "$tmp/err" && near "$ratio" 1 0.01 &&
  [ "$(stat_of eye dropped_samples)" = 0 ]; } ||
    fail "1e38 everywhere: want the warning, mean ratio 1 +- 1% to 0.5e20 (got ${ratio:-?}), nothing dropped (got $(stat_of eye dropped_samples))"
echo "1e38 everywhere: mean ratio $ratio to 0.5e20"

# refused_early NAME WANT ARGS...: exit 1, one line "pmview: error: FILE: ..." holding WANT, within
# 2 seconds, and before the scene is loaded (no `stat load` line)
refused_early() {
    name=$1; want=$2; shift 2
    checks=$((checks + 1))
    start=$(date +%s)
    timeout 20 $bin scenes/cornell-box.gltf --width 16 --iterations 1 --stats "$@" --snapshot "$tmp/x.exr" >"$tmp/out" 2>"$tmp/err"
    rc=$?; secs=$(( $(date +%s) - start ))
    if [ $rc -ne 1 ] || [ "$(wc -l < "$tmp/err")" -ne 1 ] || ! grep -q "^pmview: error: .*$want" "$tmp/err" ||
       grep -q "^stat load" "$tmp/out" || [ $secs -gt 2 ]; then
        fail "$name: want exit 1, one error line with \"$want\" before the scene is loaded, within 2 s; got exit $rc in $secs s"
    else
        echo "$name: $(cat "$tmp/err")"
    fi
}
files hdr "$tmp/full.hdr" 64 32 1
size=$(wc -c < "$tmp/full.hdr")
head -c $((size / 2)) "$tmp/full.hdr" > "$tmp/half.hdr"
refused_early "a .hdr cut at half its bytes" "half.hdr: the file ends in row [0-9]* of 32 (truncated)" --sky "$tmp/half.hdr"
files hdr-header "$tmp/empty.hdr" 64 32
refused_early "a .hdr header with no pixels" "empty.hdr: the file ends after its header: no pixels" --sky "$tmp/empty.hdr"
printf '\211PNG\r\n\032\n\0\0\0\rIHDR\0\0\0\1\0\0\0\1\10\2\0\0\0' > "$tmp/photo.hdr"
refused_early "a PNG named .hdr" "photo.hdr: not a Radiance .hdr file" --sky "$tmp/photo.hdr"
for name in fifo.exr fifo.hdr; do
    mkfifo "$tmp/$name"
    refused_early "a FIFO as the sky ($name)" "$name: is a FIFO, not a regular file" --sky "$tmp/$name"
done
mkdir "$tmp/folder.hdr"
refused_early "a directory as the sky" "folder.hdr: is a directory, not a regular file" --sky "$tmp/folder.hdr"
expect_ok() { checks=$((checks + 1)); "$@" >"$tmp/out" 2>"$tmp/err" || fail "exit $? from: $*"; }
expect_ok $bin scenes/caustic.gltf --sky "$tmp/full.hdr" --width 16 --iterations 1 --snapshot "$tmp/x.exr"

# memory from the header, before a pixel is decoded (decoding first would let a 1.6 MB
# 16384x16384 EXR take 7.2 GB under --max-memory 1G, and a 30000x30000 one decode for 86 s): tiny files claiming huge maps
files exr-header "$tmp/huge.exr" 16384 16384
refused_early "a 16384x16384 EXR under --max-memory 1G" \
    "huge.exr: out of memory (sky map of 16384x16384 texels, [0-9]* bytes, with [0-9]* bytes already committed, over the limit of 1073741824 bytes; see --max-memory)" \
    --sky "$tmp/huge.exr" --max-memory 1G
files exr-header "$tmp/vast.exr" 30000 30000
refused_early "a 30000x30000 EXR under --max-memory 1G" "vast.exr: out of memory (sky map of 30000x30000 texels" \
    --sky "$tmp/vast.exr" --max-memory 1G
# above the texel cap (2^28) and within the limit: refused by the cap, from the header too
refused_early "a 30000x30000 EXR under --max-memory 1T" "vast.exr: an environment map of 30000x30000 texels is too large" \
    --sky "$tmp/vast.exr" --max-memory 1T
files hdr-header "$tmp/vast.hdr" 30000 30000
printf '\2\2\165\60' >> "$tmp/vast.hdr" # the first row's start: pixels follow the header
refused_early "a 30000x30000 .hdr under --max-memory 1G" "vast.hdr: out of memory (sky map of 30000x30000 texels" \
    --sky "$tmp/vast.hdr" --max-memory 1G
files exr-header "$tmp/wide.exr" 4096 2048
refused_early "a 4096x2048 EXR under --max-memory 1M" "wide.exr: out of memory (sky map of 4096x2048 texels" \
    --sky "$tmp/wide.exr" --max-memory 1M

# a reference of the wrong size, from its header, before the scene (checked after the render, the
# refusal would come after minutes and gigabytes); the image's height comes from the camera, then the check runs again
files exr "$tmp/ref64.exr" 64 64 0.5
refused_early "a 64x64 reference for a 16-wide image" "ref64.exr: the reference is 64x64 but the image is 16 wide" \
    --reference "$tmp/ref64.exr" --log "$tmp/l.csv"
files exr-header "$tmp/ref_huge.exr" 16384 16384
refused_early "a 16384x16384 reference" "ref_huge.exr: the reference is 16384x16384 but the image is 16 wide" \
    --reference "$tmp/ref_huge.exr" --log "$tmp/l.csv"
checks=$((checks + 1))
$bin "$tmp/plane.gltf" --width 64 --height 32 --iterations 1 --stats --reference "$tmp/ref64.exr" --snapshot "$tmp/x.exr" >"$tmp/out" 2>"$tmp/err"
rc=$?
{ [ $rc -eq 1 ] && grep -q "the reference is 64x64 but the image is 64x32" "$tmp/err" && ! grep -q "^stat bvh" "$tmp/out"; } ||
    fail "a 64x64 reference for a 64x32 image: want exit 1 before the BVH (exit $rc)"
checks=$((checks + 1))
$bin "$tmp/plane.gltf" --width 64 --iterations 1 --quiet --reference "$tmp/ref64.exr" --snapshot "$tmp/x.exr" >"$tmp/out" 2>"$tmp/err"
rc=$?
{ [ $rc -eq 0 ] && grep -q "^stat error " "$tmp/out"; } || fail "a 64x64 reference for the square camera's 64-wide image: exit $rc"
mkfifo "$tmp/fifo_ref.exr"
refused_early "a FIFO as the reference" "fifo_ref.exr: is a FIFO, not a regular file" --reference "$tmp/fifo_ref.exr"
echo "test_hostile_sky: $checks checks, $fails failed"
[ "$fails" -eq 0 ]

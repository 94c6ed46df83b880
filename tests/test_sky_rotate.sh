#!/bin/sh
# test_sky_rotate.sh: --sky-rotate turns the environment about +Y: 360 (and -360) render the unturned image bit for bit, -270 the 90 one, and a sun on the horizon moves across the image where the turn puts it.
cd "$(dirname "$0")/.." || exit 1
. tests/cli_setup.sh
checks=0; fails=0
fail() { fails=$((fails + 1)); echo "FAIL: $*"; sed 's/^/    /' "$tmp/err" | head -5; }
files() { python3 tests/sky_files.py "$@" || { echo "FAIL: tests/sky_files.py $*"; exit 1; }; }

# a level camera over grey ground (horizontal field of view 2 atan(2 tan 0.5) = 95.3 degrees) and a
# map of 0.5 with a sun of 1000 in texel (32, 14) of 64x32: azimuth 2.8 degrees right of -Z,
# 6 to 11 degrees above the horizon
files horizon "$tmp/horizon.gltf" 0.5
files exr "$tmp/sun.exr" 64 32 0.5 32 14 1000
render() { # OUT.png DEGREES
    checks=$((checks + 1))
    $bin "$tmp/horizon.gltf" --sky "$tmp/sun.exr" --sky-rotate "$2" --width 128 --iterations 2 --quiet --snapshot "$1" \
        >"$tmp/out" 2>"$tmp/err" || fail "--sky-rotate $2: exit $?"
}
render "$tmp/r0.png" 0
render "$tmp/r360.png" 360
render "$tmp/rm360.png" -360
render "$tmp/r30.png" 30
render "$tmp/r90.png" 90
render "$tmp/rm270.png" -270
for pair in "r0 r360" "r0 rm360" "r90 rm270"; do
    set -- $pair
    checks=$((checks + 1))
    cmp -s "$tmp/$1.png" "$tmp/$2.png" || fail "$1.png and $2.png must be the same image bit for bit (angles modulo 360)"
done
checks=$((checks + 1))
cmp -s "$tmp/r0.png" "$tmp/r90.png" && fail "--sky-rotate 90 must change the image"
# where the sun is: the column of the brightest sky pixels (the top half), as a share of the width.
# Expected: x = 1/2 + tan(azimuth) / (2 x 1.0926), the azimuth 2.8 degrees (0.52) turned by 30
# degrees counter-clockwise seen from above: -27.2 degrees (0.265); turned by 90 it is behind the
# camera's left edge (47.6 degrees), and the brightest sky pixel is far dimmer.
sun_at() {
    python3 - "$1" <<'PY'
import sys
sys.path.insert(0, "tests")
from png_compare import read_png
w, h, px = read_png(sys.argv[1])
lum = lambda x, y: sum(px[y * w + x])
top = [(lum(x, y), x) for y in range(h // 2) for x in range(w)]
peak = max(v for v, _ in top)
xs = [x for v, x in top if v >= 0.9 * peak]
print("%.4f %d" % ((sum(xs) / len(xs) + 0.5) / w, peak))
PY
}
set -- $(sun_at "$tmp/r0.png"); x0=$1; peak0=$2
set -- $(sun_at "$tmp/r30.png"); x30=$1; peak30=$2
set -- $(sun_at "$tmp/r90.png"); peak90=$2
echo "sun at x = $x0 (turn 0; want 0.52), $x30 (turn 30; want 0.265); brightest sky $peak0, $peak30, $peak90 (turn 90)"
checks=$((checks + 1))
awk -v a="$x0" -v b="$x30" 'BEGIN { exit !(a > 0.49 && a < 0.55 && b > 0.235 && b < 0.295) }' ||
    fail "the sun must sit at 0.52 of the width unturned and at 0.265 turned by 30 degrees (got $x0, $x30)"
checks=$((checks + 1))
[ "$peak90" -lt $((peak0 * 4 / 5)) ] && [ "$peak30" -ge $((peak0 * 9 / 10)) ] ||
    fail "turned by 90 the sun must leave the view (brightest sky $peak90 against $peak0)"
echo "test_sky_rotate: $checks checks, $fails failed"
[ "$fails" -eq 0 ]

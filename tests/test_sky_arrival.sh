#!/bin/sh
# test_sky_arrival.sh: the sky's arrival guide (arrival.h) in the default mode: learned in the window rooms, it keeps the image's means (against the same samples with --guide off, under the white sky and under the gradient map with connections, where four ways to the sky share it) and lowers the error at equal samples; an open scene spends almost nothing on it.
#
# The guide's sample and the surface's own ray (and the sky map's sample, and a connection to a
# sky light vertex) find the same sky, shared by power heuristic weights that sum to one; what can
# go wrong is a density that is not the sample's (a bin's probability over the wrong solid angle,
# a cell looked up on the other side) or a weight missing from one of the ways, and either moves
# the means. 512 samples at 64x64, seed 1, --gather path (the choice of the path tracer's light
# made, as the default makes it in these rooms):
#   - the solid window room (scenes/window-room.gltf) under the white sky, --connect off: every
#     channel's mean within 0.15% of the run with --guide off, and the relMSE against Mitsuba's
#     reference at most 0.85 times that run's (seeds 1-3: 0.805, 0.805, 0.791; the direct
#     light's noise falls fivefold, and the guide's rays are 7% more);
#   - the hollow window room (scenes/window-hollow.gltf) under its sun and the gradient sky map,
#     --connect on: every channel's mean within 0.15% of the run with --guide off (seeds 1-3: within
#     0.13%, 0.04%, 0.00%; at 1,024 samples on independent seeds within 0.08%).
# With the guide's density left out of the own ray's weight (the sky counted twice where both find
# it) the white sky's means read 4-6% bright.
# The glossy spheres under the gradient sky (no walls: most points see most of the sky, and the
# guide's cells are used only where the sky is seen in a narrow cone, as under a sphere near the
# floor) spend under 1% more eye rays with the guide (measured 0.01%).
cd "$(dirname "$0")/.." || exit 1
. tests/stat_setup.sh
run() { # out, scene, options...
    out=$1; scene=$2; shift 2
    "$bin" "$scene" --width 64 --height 64 --stats --quiet --seed 1 --snapshot "$tmp/$out.exr" "$@" >"$tmp/$out" 2>&1 ||
        { echo "FAIL: pmview $out: $(tail -n 1 "$tmp/$out")"; exit 1; }
}
cells() { value progressive sky_arrival_cells "$tmp/$1"; }
ref=tests/ref/window_room_64.exr
if [ -f "$ref" ]; then
    run white_off scenes/window-room.gltf --sky white --gather path --connect off --iterations 512 --guide off --reference "$ref"
    run white_on scenes/window-room.gltf --sky white --gather path --connect off --iterations 512 --reference "$tmp/white_off.exr"
    run white_ref scenes/window-room.gltf --sky white --gather path --connect off --iterations 512 --reference "$ref"
    # shellcheck disable=SC2046 # the means are three words
    check "white sky: the guide learned cells (none with --guide off), every channel's mean within 0.15% of the samples' without it" \
        "on > 0 and off == 0 and all(abs(m - 1) < 0.0015 for m in (r, g, b))" on="$(cells white_on)" off="$(cells white_off)" $(means_of white_on)
    check "white sky: relMSE at most 0.85 times the samples' without the guide" "on <= 0.85 * off" \
        on="$(value error relmse "$tmp/white_ref")" off="$(value error relmse "$tmp/white_off")"
else
    echo "SKIP: $ref is missing"
fi
run map_off scenes/window-hollow.gltf --sky gradient --gather path --connect on --iterations 512 --guide off
run map_on scenes/window-hollow.gltf --sky gradient --gather path --connect on --iterations 512 --reference "$tmp/map_off.exr"
# shellcheck disable=SC2046
check "sky map, sun and connections: the guide learned cells, every channel's mean within 0.15% of the samples' without it" \
    "on > 0 and all(abs(m - 1) < 0.0015 for m in (r, g, b))" on="$(cells map_on)" $(means_of map_on)
run open_on scenes/glossy-spheres.gltf --sky gradient --iterations 128
run open_off scenes/glossy-spheres.gltf --sky gradient --iterations 128 --guide off
check "an open scene under the sky: the guide's samples add under 1% to the eye pass's rays" "on <= 1.01 * off" \
    on="$(value eye rays "$tmp/open_on")" off="$(value eye rays "$tmp/open_off")"
echo "test_sky_arrival: $checks checks, $fails failed"
[ "$fails" -eq 0 ]

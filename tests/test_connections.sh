#!/bin/sh
# test_connections.sh: the path tracer's samples joined to light vertices of point and spot lights and of the sky (eye.h, connections; forced with --gather path --connect on) keep the image's means, against Mitsuba's reference and against the samples that join none, and lower the error at equal samples.
#
# The connections and the path tracer's own way to the same light share it by MIS weights that
# sum to one whatever stand-in density the weights use; what can go wrong is a connection's
# estimate (its flux over the keeping, the pass's scale) or its support (weights given where no
# light vertex can be, or none where one can), and either moves the means. The point-lit room
# (scenes/point-room.gltf) at 384 samples, seed 1: every channel's mean within 1% of
# tests/ref/point_room_path_64.exr (measured 0.9995-0.9997 at 600 samples), and the relMSE at
# least 1.5 times lower than without connections at the same samples (measured 0.000572 against
# 0.001164 at 600). The same room with its light made a spot (a cone of 35 degrees down the room,
# falloff from 25: a light vertex outside the cone has no density, inside it the cone's mapping
# turned back), 512 samples with and without connections: every channel's mean within 1% of each
# other's (both estimate the same image). The hollow window room (scenes/window-hollow.gltf) under
# its sun and the gradient sky map, whose photons make light vertices too (the density turned back
# through the disc the sky's photons start on and the map's sampling): 512 samples with and without
# connections, every channel's mean within 0.15% of each other's (seeds 1-3 within 0.07%; with the
# sky's connections left out of the weights of the path's own ways to the sky, the light they
# share counted twice, 0.25-0.34% too bright).
cd "$(dirname "$0")/.." || exit 1
. tests/stat_setup.sh
run() { # out, scene, options...
    out=$1; scene=$2; shift 2
    "$bin" "$scene" --width 64 --height 64 --gather path --stats --quiet --seed 1 --snapshot "$tmp/$out.exr" "$@" >"$tmp/$out" 2>&1 ||
        { echo "FAIL: pmview $out: $(tail -n 1 "$tmp/$out")"; exit 1; }
}
ref=tests/ref/point_room_path_64.exr
if [ -f "$ref" ]; then
    run on scenes/point-room.gltf --iterations 384 --connect on --reference "$ref"
    run off scenes/point-room.gltf --iterations 384 --connect off --reference "$ref"
    # shellcheck disable=SC2046 # the means are three words
    check "point light: the connections joined, every channel's mean within 1% of Mitsuba's" \
        "joins > 0 and all(abs(m - 1) < 0.01 for m in (r, g, b))" joins="$(value eye connections "$tmp/on")" $(means_of on)
    check "point light: relMSE at least 1.5 times lower with connections at the same 384 samples" "on * 1.5 <= off" \
        on="$(value error relmse "$tmp/on")" off="$(value error relmse "$tmp/off")"
else
    echo "SKIP: $ref is missing"
fi
# the spot: the room's light made a spot looking down the room (a node's light looks down its -Z;
# a quarter turn about X turns that to -Y)
python3 -c 'import json, sys
scene = json.load(open(sys.argv[1]))
scene["extensions"]["KHR_lights_punctual"]["lights"][0] = {
    "type": "spot", "color": [1.0, 0.9, 0.8], "intensity": 4.0, "spot": {"innerConeAngle": 0.436, "outerConeAngle": 0.611}}
for node in scene["nodes"]:
    if "KHR_lights_punctual" in node.get("extensions", {}):
        node["rotation"] = [-0.7071068, 0.0, 0.0, 0.7071068]
json.dump(scene, open(sys.argv[2], "w"))' scenes/point-room.gltf "$tmp/spot.gltf"
run spot_off "$tmp/spot.gltf" --iterations 512 --connect off
run spot_on "$tmp/spot.gltf" --iterations 512 --connect on --reference "$tmp/spot_off.exr"
# shellcheck disable=SC2046
check "spot light: the connections joined, every channel's mean within 1% of the samples' without" \
    "joins > 0 and all(abs(m - 1) < 0.01 for m in (r, g, b))" joins="$(value eye connections "$tmp/spot_on")" $(means_of spot_on)
# the sky's light vertices, from the gradient map
run sky_off scenes/window-hollow.gltf --sky gradient --iterations 512 --connect off
run sky_on scenes/window-hollow.gltf --sky gradient --iterations 512 --connect on --reference "$tmp/sky_off.exr"
# shellcheck disable=SC2046
check "sky map and sun: the connections joined, every channel's mean within 0.15% of the samples' without" \
    "joins > 0 and all(abs(m - 1) < 0.0015 for m in (r, g, b))" joins="$(value eye connections "$tmp/sky_on")" $(means_of sky_on)
echo "test_connections: $checks checks, $fails failed"
[ "$fails" -eq 0 ]

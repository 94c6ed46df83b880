#!/bin/sh
# test_scale.sh: hard case of scale: the Cornell box moved 1e5 from the origin and scaled by 1e-3 and 1e3, and scaled by 1e-12 and 1e30, and a room lit by a point light scaled by 1e30 and 1e-30, render the same image within noise.
#
# Each variant wraps the scene's root nodes (camera included) in one node that translates and
# scales them, so the picture must not change. Criterion, against the original rendered with the
# same seed: relMSE below 0.01 (a 10% rms difference per pixel) and below the relMSE between two
# seeds of the original (its noise, about 0.06 here), and each channel's mean within 1%. Today's main refused the 1e5 / 1e-3, 1e-12 and 1e30 boxes
# ("nothing to render": float precision and float cross products dropped every triangle).
cd "$(dirname "$0")/.." || exit 1
bin=./pmview
[ -x "$bin" ] || bin=build/asan/pmview
command -v python3 >/dev/null 2>&1 || { echo "skip: no python3"; exit 0; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0; checks=0
render() { # name scene [seed]
    $bin "$2" --width 48 --iterations 16 --threads 2 --seed "${3:-1}" --quiet --stats --snapshot "$tmp/$1.exr" \
        ${REF:+--reference "$REF"} >"$tmp/$1.out" 2>"$tmp/$1.err"
}
field() { sed -n "s/^stat error .*$2=\([0-9.e+-]*\).*/\1/p" "$tmp/$1.out"; }
wrap() { # out offset scale
    python3 - scenes/cornell-box.gltf "$tmp/$1.gltf" "$2" "$3" <<'PY'
import json, sys
src, dst, offset, scale = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4])
d = json.load(open(src))
scene = d["scenes"][d.get("scene", 0)]
d["nodes"].append({"children": scene["nodes"], "translation": [offset] * 3, "scale": [scale] * 3})
scene["nodes"] = [len(d["nodes"]) - 1]
json.dump(d, open(dst, "w"))
PY
}
# same_within_noise NAME DESCRIPTION WHAT: renders $tmp/NAME.gltf against the reference, whose
# relMSE must stay below the seed-to-seed $noise (and 0.01) and whose channel means within 1%
same_within_noise() {
    checks=$((checks + 1))
    if ! render "$1" "$tmp/$1.gltf"; then
        fails=$((fails + 1)); echo "FAIL: $2 does not render: $(head -n 1 "$tmp/$1.err")"; return
    fi
    relmse=$(field "$1" relmse)
    r=$(field "$1" mean_ratio_r); g=$(field "$1" mean_ratio_g); b=$(field "$1" mean_ratio_b)
    echo "$2: relMSE $relmse, mean ratios $r $g $b"
    if ! python3 -c "import sys; n, e, *m = map(float, sys.argv[1:]); sys.exit(0 if e < min(0.01, n) and all(abs(x - 1) < 0.01 for x in m) else 1)" \
        "$noise" "$relmse" "$r" "$g" "$b"; then
        fails=$((fails + 1)); echo "FAIL: $2: not $3 within noise (relMSE $relmse, noise $noise, means $r $g $b)"
    fi
}
render ref scenes/cornell-box.gltf || { echo "FAIL: the original does not render"; cat "$tmp/ref.err"; exit 1; }
REF="$tmp/ref.exr"
render seed2 scenes/cornell-box.gltf 2
noise=$(field seed2 relmse)
echo "noise: relMSE between seeds 1 and 2 = $noise"
for v in "far_small 1e5 1e-3" "far_large 1e5 1e3" "tiny 0 1e-12" "huge 0 1e30"; do
    set -- $v
    wrap "$1" "$2" "$3"
    same_within_noise "$1" "offset $2 scale $3" "the same image"
done

# A closed room (a cube of 8 shared corners, 12 triangles) lit by a point light at 5 W/sr, and the
# same scaled by 1e30 with the intensity 5e60 (and by 1e-30 with 5e-60): the irradiance at every
# wall is the same, so is the image. Today's main made the intensity a float before the scene's
# unit rescale (2^-100, squared for an intensity): 5e60 became FLT_MAX and the huge room rendered
# 1e-22 of the unit one; 5e-60 became 0 and the tiny room rendered black.
room() { # out scale intensity
    python3 - "$tmp/$1.gltf" "$2" "$3" <<'PY'
import base64, json, struct, sys
out, scale, intensity = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
corners = [(x, y, z) for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)]
faces = [(1, 3, 2, 0), (6, 7, 5, 4), (4, 5, 1, 0), (3, 7, 6, 2), (2, 6, 4, 0), (5, 7, 3, 1)]  # seen from inside
indices = [i for a, b, c, d in faces for i in (a, b, c, a, c, d)]
data = b"".join(struct.pack("<3f", *p) for p in corners) + struct.pack("<36H", *indices)
json.dump({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [3]}],
           "nodes": [{"mesh": 0}, {"camera": 0, "translation": [0.2, 0.1, 0.9]},
                     {"translation": [0, 0.3, 0], "extensions": {"KHR_lights_punctual": {"light": 0}}},
                     {"children": [0, 1, 2], "scale": [scale] * 3}],
           "cameras": [{"type": "perspective", "perspective": {"yfov": 1.2, "znear": 0.01}}],
           "extensionsUsed": ["KHR_lights_punctual"],
           "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": intensity}]}},
           "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0}}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
           "buffers": [{"byteLength": len(data), "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
           "bufferViews": [{"buffer": 0, "byteLength": 96}, {"buffer": 0, "byteOffset": 96, "byteLength": 72}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3"},
                         {"bufferView": 1, "componentType": 5123, "count": 36, "type": "SCALAR"}]}, open(out, "w"))
PY
}
room room 1 5
REF=
render room_ref "$tmp/room.gltf" || { echo "FAIL: the unit room does not render"; cat "$tmp/room_ref.err"; exit 1; }
REF="$tmp/room_ref.exr"
render room_seed2 "$tmp/room.gltf" 2
noise=$(field room_seed2 relmse)
echo "room noise: relMSE between seeds 1 and 2 = $noise"
for v in "room_huge 1e30 5e60" "room_tiny 1e-30 5e-60"; do
    set -- $v
    room "$1" "$2" "$3"
    same_within_noise "$1" "room at scale $2, intensity $3" "the unit room's image"
done
echo "test_scale: $checks checks, $fails failed"
[ "$fails" -eq 0 ]

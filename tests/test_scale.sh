#!/bin/sh
# test_scale.sh: hard case of scale: the Cornell box moved 1e5 from the origin and scaled by 1e-3 and 1e3, and scaled by 1e-12 and 1e30, and a room lit by a point light scaled by 1e30 and 1e-30, render the same image within noise; so do scenes with small strays out of view from 1e2 to 1.5e18 away, and a placement reaching 1e38 is refused.
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
# Far strays: small cubes (0.01 to 0.5 wide, grey) placed out of view at random distances from
# 1e2 to 1.5e18 (log-uniform, three a file, six files a scene), in the open Cornell box (out of
# view: more than 60 degrees off its camera's axis), in the closed room (anywhere outside it) and
# in the box without its camera (pmview frames it; the strays must not be framed). Each renders
# the stray-free image within noise. Before, a 0.2 cube at 1e4 made the box 5% brighter, at 1e5
# far brighter, and the scene's size-derived steps made the room black from 1e6 on.
strays() { # src dst seed [nocamera]
    python3 - "$1" "$2" "$3" "${4:-}" <<'PY'
import base64, json, math, random, struct, sys
src, dst, seed, nocamera = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4] == "nocamera"
rng = random.Random(seed)
d = json.load(open(src))
scene = d["scenes"][d.get("scene", 0)]
if nocamera:
    scene["nodes"] = [n for n in scene["nodes"] if "camera" not in d["nodes"][n]]
corners = [(a, b, c) for c in (-0.5, 0.5) for b in (-0.5, 0.5) for a in (-0.5, 0.5)]
faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
data = b"".join(struct.pack("<3f", *p) for p in corners) + struct.pack("<36H", *[i for a, b, c, e in faces for i in (a, b, c, a, c, e)])
d["buffers"].append({"byteLength": len(data), "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()})
d["bufferViews"] += [{"buffer": len(d["buffers"]) - 1, "byteLength": 96}, {"buffer": len(d["buffers"]) - 1, "byteOffset": 96, "byteLength": 72}]
d["accessors"] += [{"bufferView": len(d["bufferViews"]) - 2, "componentType": 5126, "count": 8, "type": "VEC3", "min": [-0.5] * 3, "max": [0.5] * 3},
                   {"bufferView": len(d["bufferViews"]) - 1, "componentType": 5123, "count": 36, "type": "SCALAR"}]
d["meshes"].append({"primitives": [{"attributes": {"POSITION": len(d["accessors"]) - 2}, "indices": len(d["accessors"]) - 1}]})
placed = []
for _ in range(3):
    while True:  # a direction more than 60 degrees off the view axis (-z)
        z = rng.uniform(-1, 1); phi = rng.uniform(0, 2 * math.pi); r = math.sqrt(1 - z * z)
        if -z < 0.5: break
    distance = 10 ** rng.uniform(2, math.log10(1.5e18))
    d["nodes"].append({"mesh": len(d["meshes"]) - 1, "scale": [rng.uniform(0.01, 0.5)] * 3,
                       "translation": [distance * r * math.cos(phi), distance * r * math.sin(phi), distance * z]})
    scene["nodes"].append(len(d["nodes"]) - 1)
    placed.append("%.2g" % distance)
json.dump(d, open(dst, "w"))
print(" ".join(placed))
PY
}
room room 1 5
python3 - "$tmp/room.gltf" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))  # buffers and bufferViews as lists strays() can extend
json.dump(d, open(sys.argv[1], "w"))
PY
for base in "box scenes/cornell-box.gltf" "room $tmp/room.gltf" "auto scenes/cornell-box.gltf nocamera"; do
    set -- $base
    name=$1; src=$2; how=${3:-}
    if [ -n "$how" ]; then strays "$src" "$tmp/${name}0.gltf" 0 "$how" >/dev/null; src="$tmp/${name}0.gltf"
        python3 - "$src" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
s = d["scenes"][d.get("scene", 0)]
s["nodes"] = s["nodes"][:-3]  # the camera-less scene without its strays
json.dump(d, open(sys.argv[1], "w"))
PY
    fi
    REF=
    render "${name}_ref" "$src" || { fails=$((fails + 1)); echo "FAIL: $name does not render"; cat "$tmp/${name}_ref.err"; continue; }
    REF="$tmp/${name}_ref.exr"
    render "${name}_seed2" "$src" 2
    noise=$(field "${name}_seed2" relmse)
    for seed in 1 2 3 4 5 6; do
        far=$(strays "$2" "$tmp/${name}_far$seed.gltf" "$seed" "$how")
        same_within_noise "${name}_far$seed" "$name with strays at $far" "the stray-free image"
    done
done

# A placement reaching 1e38 (the mirror ball scaled by 1e38 out of view) is refused in one line:
# no frame keeps both it and the box within float's range. Before, the frame shrank the box to
# dust: black, exit 0. A small stray past 1.8e18 is refused as beyond Embree's reach.
python3 - scenes/cornell-box.gltf "$tmp/huge_stray.gltf" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
d["nodes"].append({"mesh": 6, "matrix": [1e38, 0, 0, 0, 0, 1e38, 0, 0, 0, 0, 1e38, 0, 0, 0, 2e38, 1]})
d["scenes"][0]["nodes"].append(len(d["nodes"]) - 1)
json.dump(d, open(sys.argv[2], "w"))
PY
checks=$((checks + 1))
REF=
render huge_stray "$tmp/huge_stray.gltf"
rc=$?
if [ $rc -ne 1 ] || [ "$(wc -l < "$tmp/huge_stray.err")" -ne 1 ] || ! grep -q "^pmview: error: .*sizes span more than float can render" "$tmp/huge_stray.err"; then
    fails=$((fails + 1)); echo "FAIL: a placement reaching 1e38: want exit 1 and one line naming the span, got exit $rc:"; cat "$tmp/huge_stray.err"
fi
python3 - scenes/cornell-box.gltf "$tmp/far_stray.gltf" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
d["nodes"].append({"mesh": 6, "translation": [0, 0, 2.5e18], "scale": [0.1, 0.1, 0.1]})
d["scenes"][0]["nodes"].append(len(d["nodes"]) - 1)
json.dump(d, open(sys.argv[2], "w"))
PY
checks=$((checks + 1))
render far_stray "$tmp/far_stray.gltf"
rc=$?
if [ $rc -ne 1 ] || [ "$(wc -l < "$tmp/far_stray.err")" -ne 1 ] || ! grep -q "^pmview: error: .*reaches 2.5e+18 from the origin, beyond the 1.8e+18 Embree can trace" "$tmp/far_stray.err"; then
    fails=$((fails + 1)); echo "FAIL: a stray at 2.5e18: want exit 1 and one line naming the reach, got exit $rc:"; cat "$tmp/far_stray.err"
fi
echo "test_scale: $checks checks, $fails failed"
[ "$fails" -eq 0 ]

#!/bin/sh
# test_gather_choice.sh: where the default's final gathering learns its light's source and where it keeps the photons: glass under an area lamp is learned, glass with a punctual light too (the path tracer's gathers read the photons of the light it cannot find), a bright caustic seen by gather points keeps the photons; where the path tracer gathers, the caustic photons earn their cost, and the caustic trial keeps them where the loop's caustic is rare bright samples; where photons have nothing to carry (no caustic or indirect light possible, or broad light alone), the default is the path tracer.
#
# Scenes: scenes/dielectric-spheres.gltf with its black sphere made a small solid glass ball
# (radius 0.1, KHR_materials_volume), lit by its area lamp alone, then with a point light added;
# and scenes/cornell-box.gltf (an area lamp over a large glass ball). Read from `stat progressive`:
# gather_source, choice_iterations (learning iterations before the choice, 0 when kept without
# learning) and choice_caustic_share (of the light the photons' measuring iterations gathered, the
# share that came off a mirror or glass last: 1% or more keeps the photons).
# Where the path tracer gathers, the caustic photons still carry the light mirrors, glass and sharp
# lobes bring to the visible points (docs/design.md, "The caustic photons stay where the path tracer
# gathers"): the shipped dielectric spheres choose the path tracer and keep their caustic pass
# (photons_per_iteration, the caustic photons alone there), and on the glossy spheres, whose sharp
# coats reflect the lamp onto the floor, --gather path (the caustic photons) against --mode
# pathtrace (the same continuation counting those paths itself) at the same 256 samples must read
# at most 0.75 of the path tracer's relMSE (measured 0.48-0.53 at 400 samples, seeds 1 and 2): a
# change that stops the caustic pass, or counts the caustics twice or never, fails it.
# Where the photons have nothing to carry, the default runs the path tracer's own loop from the
# first iteration, and its image at 16 samples is --mode pathtrace's bit for bit with --guide off
# (every sample counted in path_only_samples, no photon traced; under a sky the default's guide
# adds samples of the sky where it learned it is seen through a narrow opening, arrival.h, which
# the plain path tracer does not): where neither a caustic nor indirect light is
# possible (a lone square under the sky), and under broad light alone (light_diffuse=1): the
# dielectric spheres with their lamp off under --sky white, whose coats make caustics, and the
# Cornell box's mirror and glass balls under a lamp as wide as its ceiling. A sky map with a sun in
# it (one texel 2000 times the rest) is no broad light: there the photons are traced. Nor is a
# square whose emissive texture is dark but for one texel in 256, its factor 256 (the same mean
# radiance as the untextured square of factor 1, which is broad light): a texel, not a triangle's
# mean, is what a path meets.
cd "$(dirname "$0")/.." || exit 1
bin=./pmview
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0
python3 - "$tmp" <<'EOF2' || { echo "FAIL: the scene script"; exit 1; }
import json, sys
d = sys.argv[1]
doc = json.load(open("scenes/dielectric-spheres.gltf"))
glass = [i for i, m in enumerate(doc["materials"]) if m.get("pbrMetallicRoughness", {}).get("roughnessFactor") == 0.05][0]
doc["materials"][glass] = {"name": "glass", "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0, "roughnessFactor": 0.0},
                           "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.5},
                                          "KHR_materials_volume": {"thicknessFactor": 1.0}}}
doc["extensionsUsed"] = sorted(set(doc["extensionsUsed"]) | {"KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume"})
ball = [n for n in doc["nodes"] if n.get("name") == "black_plastic"][0]
ball["scale"] = [0.1, 0.1, 0.1]
ball["translation"] = [-1.1, 0.1, 0.8]
json.dump(doc, open(d + "/glass_area.gltf", "w"))
doc["extensions"] = {"KHR_lights_punctual": {"lights": [{"type": "point", "color": [1, 1, 1], "intensity": 2.0}]}}
doc["extensionsUsed"].append("KHR_lights_punctual")
doc["nodes"].append({"name": "point", "translation": [0.8, 2.0, 0.5], "extensions": {"KHR_lights_punctual": {"light": 0}}})
doc["scenes"][doc.get("scene", 0)]["nodes"].append(len(doc["nodes"]) - 1)
json.dump(doc, open(d + "/glass_point.gltf", "w"))
import base64, struct
corners = [(-1, 0, -1), (1, 0, -1), (1, 0, 1), (-1, 0, 1)]
data = b"".join(struct.pack("<3f", *c) for c in corners) + struct.pack("<6H", 0, 2, 1, 0, 3, 2)
square = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0, 1]}],
          "nodes": [{"mesh": 0}, {"camera": 0, "translation": [0, 1.5, 2.5], "rotation": [-0.2588, 0, 0, 0.9659]}],
          "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.01}}],
          "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
          "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.6, 0.5, 1], "metallicFactor": 0, "roughnessFactor": 0.8}}],
          "buffers": [{"byteLength": len(data), "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
          "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48}, {"buffer": 0, "byteOffset": 48, "byteLength": 12}],
          "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, 0, -1], "max": [1, 0, 1]},
                        {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}]}
json.dump(square, open(d + "/square.gltf", "w"))
dark = json.load(open("scenes/dielectric-spheres.gltf"))
for m in dark["materials"]:
    m.pop("emissiveFactor", None)
    m.get("extensions", {}).pop("KHR_materials_emissive_strength", None)
json.dump(dark, open(d + "/sky_spheres.gltf", "w"))
plastic = json.load(open("scenes/glossy-spheres.gltf"))
for m in plastic["materials"]:
    if m["name"] == "emitter":
        m["emissiveFactor"] = [0, 0, 0]
    if m["name"] == "metal":
        m["pbrMetallicRoughness"].update({"metallicFactor": 0.0, "roughnessFactor": 0.25, "baseColorFactor": [0.5, 0.5, 0.5, 1]})
json.dump(plastic, open(d + "/plastic_spheres.gltf", "w"))
sys.path.insert(0, "scenes")
import make_scenes
json.dump(make_scenes.to_gltf(make_scenes.cornell_box(segments=16, light_strength=2.0, light_size=2.0)), open(d + "/panel_box.gltf", "w"))
import zlib
def png_chunk(kind, data):
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
rows = b"".join(b"\0" + b"".join(bytes((255, 255, 255) if (x, y) == (5, 9) else (0, 0, 0)) for x in range(16)) for y in range(16))
spot = (b"\x89PNG\r\n\x1a\n" + png_chunk(b"IHDR", struct.pack(">IIBBBBB", 16, 16, 8, 2, 0, 0, 0)) +
        png_chunk(b"IDAT", zlib.compress(rows)) + png_chunk(b"IEND", b""))
uv = struct.pack("<8f", 0, 0, 1, 0, 1, 1, 0, 1)
for name, textured in (("glow", False), ("spot", True)):
    lamp = json.loads(json.dumps(square))
    lamp["nodes"].append({"mesh": 1, "translation": [0, 1.5, 0], "rotation": [1, 0, 0, 0]})
    lamp["scenes"][0]["nodes"].append(2)
    lamp["meshes"].append({"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 2}, "indices": 1, "material": 1}]})
    lamp["buffers"].append({"byteLength": len(uv), "uri": "data:application/octet-stream;base64," + base64.b64encode(uv).decode()})
    lamp["bufferViews"].append({"buffer": 1, "byteOffset": 0, "byteLength": len(uv)})
    lamp["accessors"].append({"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"})
    glow = {"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]}, "emissiveFactor": [1, 1, 1]}
    if textured:
        glow["emissiveTexture"] = {"index": 0}
        glow["extensions"] = {"KHR_materials_emissive_strength": {"emissiveStrength": 256.0}}
        lamp["extensionsUsed"] = ["KHR_materials_emissive_strength"]
        lamp["textures"] = [{"source": 0}]
        lamp["images"] = [{"uri": "data:image/png;base64," + base64.b64encode(spot).decode()}]
    lamp["materials"].append(glow)
    json.dump(lamp, open(d + "/square_" + name + ".gltf", "w"))
EOF2
python3 tests/sky_files.py exr "$tmp/sun.exr" 32 16 1 5 3 2000 || { echo "FAIL: tests/sky_files.py"; exit 1; }
python3 tests/sky_files.py exr "$tmp/patch.exr" 64 32 1 40 8 3000 || { echo "FAIL: tests/sky_files.py"; exit 1; }
run() { # name, scene[, iterations]
    "$bin" "$2" --width 64 --height 64 --iterations "${3:-24}" --seed 1 --quiet --stats --snapshot "$tmp/$1.exr" >"$tmp/$1" 2>&1 ||
        echo "pmview failed on $1: $(tail -n 1 "$tmp/$1")"
}
value() { sed -n "s/^stat progressive .*[ ]$1=\([^ ]*\).*/\1/p" "$2"; }
check() { # description, condition (python over source, learned, share)
    if python3 -c "import sys; source, learned, share = sys.argv[1], int(sys.argv[2] or -1), float(sys.argv[3] or 'nan'); sys.exit(0 if ($2) else 1)" \
        "$source" "$learned" "$share"; then
        echo "ok: $1 (gather_source=$source choice_iterations=$learned choice_caustic_share=$share)"
    else
        fails=$((fails + 1)); echo "FAIL: $1 (gather_source=${source:-none} choice_iterations=${learned:-none} choice_caustic_share=${share:-none})"
    fi
}
read_choice() { source=$(value gather_source "$tmp/$1"); learned=$(value choice_iterations "$tmp/$1"); share=$(value choice_caustic_share "$tmp/$1"); }
run glass_area "$tmp/glass_area.gltf"
read_choice glass_area
check "solid glass under an area lamp: the source is learned, and the path tracer's chosen (little light off the glass)" \
    "source == 'path' and learned >= 4 and 0 < share < 0.01"
# the point's light through the glass is no path the path tracer finds: its gathers read those photons
# (PM_PATH_PUNCTUAL_SPECULAR), so the source is learned here too (16 learning iterations at seed 1)
run glass_point "$tmp/glass_point.gltf" 48
read_choice glass_point
check "the same glass with a point light: the source is learned too (the path tracer's gathers read the photons of the point through the glass)" \
    "source in ('path', 'photons') and learned >= 4"
run cornell scenes/cornell-box.gltf
read_choice cornell
check "the Cornell box's glass ball under its lamp: learned, and the photons kept for the light off the glass" \
    "source == 'photons' and learned >= 2 and share >= 0.01"
run dielectric scenes/dielectric-spheres.gltf
read_choice dielectric
per_iteration=$(value photons_per_iteration "$tmp/dielectric")
if [ "$source" = path ] && [ "${per_iteration:-0}" -gt 0 ]; then
    echo "ok: the dielectric spheres gather by the path tracer and keep their caustic pass (photons_per_iteration=$per_iteration)"
else
    fails=$((fails + 1)); echo "FAIL: the dielectric spheres: gather_source=${source:-none} photons_per_iteration=${per_iteration:-none} (path and a caustic pass expected)"
fi
ref=tests/ref/glossy_path_64.exr
if [ -f "$ref" ]; then
    for mode in "--gather path" "--mode pathtrace"; do
        name=$(echo "$mode" | tr -d ' -')
        # shellcheck disable=SC2086 # the mode is two words
        "$bin" scenes/glossy-spheres.gltf $mode --sky none --width 64 --height 64 --iterations 256 --seed 1 --quiet --stats \
            --reference "$ref" --snapshot "$tmp/$name.exr" >"$tmp/$name" 2>&1 || echo "pmview failed on glossy ($mode): $(tail -n 1 "$tmp/$name")"
    done
    photons=$(sed -n 's/^stat error .*relmse=\([^ ]*\).*/\1/p' "$tmp/gatherpath"); path=$(sed -n 's/^stat error .*relmse=\([^ ]*\).*/\1/p' "$tmp/modepathtrace")
    if python3 -c "import sys; a, b = float(sys.argv[1] or 'nan'), float(sys.argv[2] or 'nan'); sys.exit(0 if a <= 0.75 * b else 1)" "$photons" "$path"; then
        echo "ok: the glossy spheres' caustic photons at 256 samples: relMSE $photons against the path tracer's $path"
    else
        fails=$((fails + 1)); echo "FAIL: the glossy spheres' caustic photons at 256 samples: relMSE ${photons:-none} against the path tracer's ${path:-none} (at most 0.75 of it)"
    fi
else
    fails=$((fails + 1)); echo "FAIL: $ref is missing"
fi
# the caustic trial keeps the photons where the loop's caustic is rare bright samples: the glossy
# spheres under their small lamp, and spheres of Fresnel-lobed plastic under a sky map whose one
# texel (5.6 degrees across) is 3,000 times the rest (their caustic photons' relMSE 0.44-0.54 of the
# path tracer's at equal time, docs/design.md)
for case in "glossy scenes/glossy-spheres.gltf none 64" "plastic $tmp/plastic_spheres.gltf $tmp/patch.exr 128"; do
    set -- $case
    "$bin" "$2" --sky "$3" --width "$4" --height "$4" --iterations 96 --seed 1 --quiet --stats --snapshot "$tmp/trial_$1.exr" \
        >"$tmp/trial_$1" 2>&1 || echo "pmview failed on the trial's $1: $(tail -n 1 "$tmp/trial_$1")"
    trial=$(value caustic_trial "$tmp/trial_$1"); per_iteration=$(value photons_per_iteration "$tmp/trial_$1")
    if [ "$trial" = 0 ] && [ "${per_iteration:-0}" -gt 0 ]; then
        echo "ok: the $1 spheres: the caustic trial keeps the photons (caustic_trial=$trial, photons_per_iteration=$per_iteration)"
    else
        fails=$((fails + 1)); echo "FAIL: the $1 spheres: caustic_trial=${trial:-none} (0 expected), photons_per_iteration=${per_iteration:-none}"
    fi
done
path_tracer_alone() { # name, scene, what, sky
    for mode in "progressive --guide off" pathtrace; do
        # shellcheck disable=SC2086 # the mode and its option are two words
        "$bin" "$2" --sky "$4" --mode $mode --width 48 --height 48 --iterations 16 --seed 1 --quiet --stats \
            --snapshot "$tmp/$1_${mode%% *}.exr" >"$tmp/$1_${mode%% *}" 2>&1 || echo "pmview failed on $1 ($mode): $(tail -n 1 "$tmp/$1_${mode%% *}")"
    done
    path_only=$(value path_only_samples "$tmp/$1_progressive"); traced=$(sed -n 's/^stat photons emitted=\([0-9]*\).*/\1/p' "$tmp/$1_progressive")
    if [ -s "$tmp/$1_pathtrace.exr" ] && cmp -s "$tmp/$1_progressive.exr" "$tmp/$1_pathtrace.exr" && [ "$path_only" = 16 ] && [ "${traced:-1}" = 0 ]; then
        echo "ok: $3: the default (--guide off) is the path tracer, bit for bit (path_only_samples=$path_only, photons emitted=$traced)"
    else
        fails=$((fails + 1)); echo "FAIL: $3: the default's image differs from --mode pathtrace's, or path_only_samples=${path_only:-none} (16 expected), photons emitted=${traced:-none} (0 expected)"
    fi
}
path_tracer_alone square "$tmp/square.gltf" "a lone square under the sky" gradient
path_tracer_alone sky_spheres "$tmp/sky_spheres.gltf" "the dielectric spheres under a white sky alone" white
path_tracer_alone panel_box "$tmp/panel_box.gltf" "the Cornell box under a lamp as wide as its ceiling" none
"$bin" "$tmp/sky_spheres.gltf" --sky "$tmp/sun.exr" --width 48 --height 48 --iterations 16 --seed 1 --quiet --stats \
    --snapshot "$tmp/sun_spheres.exr" >"$tmp/sun_spheres" 2>&1 || echo "pmview failed on the spheres under the sun map: $(tail -n 1 "$tmp/sun_spheres")"
diffuse=$(sed -n 's/^stat analysis .*light_diffuse=\([01]\).*/\1/p' "$tmp/sun_spheres"); traced=$(sed -n 's/^stat photons emitted=\([0-9]*\).*/\1/p' "$tmp/sun_spheres")
if [ "$diffuse" = 0 ] && [ "${traced:-0}" -gt 0 ]; then
    echo "ok: the same spheres under a sky map with a sun: no broad light, the photons traced (emitted=$traced)"
else
    fails=$((fails + 1)); echo "FAIL: the same spheres under a sky map with a sun: light_diffuse=${diffuse:-none} (0 expected), photons emitted=${traced:-none}"
fi
for name in glow spot; do
    "$bin" "$tmp/square_$name.gltf" --sky none --width 16 --height 16 --iterations 1 --quiet --stats --snapshot "$tmp/square_$name.exr" \
        >"$tmp/square_$name" 2>&1 || echo "pmview failed on square_$name: $(tail -n 1 "$tmp/square_$name")"
done
glow=$(sed -n 's/^stat analysis .*light_diffuse=\([01]\).*/\1/p' "$tmp/square_glow"); spot=$(sed -n 's/^stat analysis .*light_diffuse=\([01]\).*/\1/p' "$tmp/square_spot")
if [ "$glow" = 1 ] && [ "$spot" = 0 ]; then
    echo "ok: a lamp square over the square is broad light, the same mean from one texel in 256 is not"
else
    fails=$((fails + 1)); echo "FAIL: light_diffuse=${glow:-none} for the plain lamp (1 expected), ${spot:-none} for its one bright texel (0 expected)"
fi
if [ "$fails" -eq 0 ]; then echo "test_gather_choice: all 12 checks passed"; else echo "test_gather_choice: $fails of 12 checks failed"; exit 1; fi

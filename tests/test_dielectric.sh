#!/bin/sh
# test_dielectric.sh: glTF's dielectric specular lobe and Schlick metals against the analytic image of a sphere under a uniform white sky (tests/ref/dielectric_sphere_64.exr); specularFactor 0 turns the lobe off.
#
# The reference (tools/dielectric_sphere_reference.py) is Schlick's F(cos) = 0.04 + 0.96 (1 - cos)^5
# per pixel for a smooth black dielectric, the pixels off the sphere NaN. The same sphere as a
# smooth metal of base colour 0.5 must read 0.5 + 0.5 (ref - 0.04) / 0.96 (Schlick from 0.5,
# brightening toward grazing), 1.6% above a constant 0.5 over these pixels. With a window behind
# the camera (an emitter of radiance 1, no sky) the sphere's middle (tests/ref/dielectric_middle_mask_64.exr:
# 1 within radius 0.15, NaN elsewhere, so the mean ratio is the mean there) reflects it at F0 = 0.04
# when smooth, a little less at roughness 0.3 (the lobe blurs past the window's edges), nothing with
# specularFactor 0.
cd "$(dirname "$0")/.." || exit 1
bin=./pmview
ref=tests/ref/dielectric_sphere_64.exr
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0; checks=0
if [ ! -f "$ref" ]; then echo "SKIP: $ref is missing"; exit 0; fi
python3 tools/dielectric_sphere_reference.py --gltf "$tmp/black.gltf" || { echo "FAIL: the scene script"; exit 1; }
python3 tools/dielectric_sphere_reference.py --gltf "$tmp/window0.gltf" --window || exit 1
python3 tools/dielectric_sphere_reference.py --gltf "$tmp/window3.gltf" --window --roughness 0.3 || exit 1
python3 - "$tmp" <<'EOF2'
import json, sys
d = sys.argv[1]
doc = json.load(open(d + "/black.gltf"))
off = json.loads(json.dumps(doc))
off["materials"][0]["extensions"] = {"KHR_materials_specular": {"specularFactor": 0.0}}
off["extensionsUsed"] = ["KHR_materials_specular"]
json.dump(off, open(d + "/off.gltf", "w"))
metal = json.loads(json.dumps(doc))
metal["materials"][0]["pbrMetallicRoughness"].update(baseColorFactor=[0.5, 0.5, 0.5, 1.0], metallicFactor=1.0)
json.dump(metal, open(d + "/metal.gltf", "w"))
EOF2
# the reference's mean over its pixels, and what a Schlick metal of 0.5 reads relative to it
ref_mean=0.055224
metal_ratio=$(python3 -c "m=$ref_mean; print((0.5 + 0.5 * (m - 0.04) / 0.96) / m)")
constant_ratio=$(python3 -c "print(0.5 / $ref_mean)")
check() { # description, scene, mode, low, high[, sky, reference]
    checks=$((checks + 1))
    out="$tmp/$2_$3"
    "$bin" "$tmp/$2.gltf" --sky "${6:-white}" --width 64 --height 64 --reference "${7:-$ref}" --stats --quiet --iterations 64 \
        --mode "$3" --snapshot "$out.exr" >"$out" 2>&1 || echo "pmview failed: $(tail -n 1 "$out")"
    r=$(sed -n 's/^stat error .*mean_ratio_g=\([0-9.]*\).*/\1/p' "$out")
    if python3 -c "import sys; sys.exit(0 if $4 <= float('${r:-nan}') <= $5 else 1)"; then
        echo "ok: $1: mean ratio $r"
    else
        fails=$((fails + 1)); echo "FAIL: $1: mean ratio ${r:-none}, want within [$4, $5]"; tail -n 3 "$out"
    fi
}
check "black dielectric, progressive: the Fresnel curve within 2%" black progressive 0.98 1.02
check "black dielectric, path tracer: the Fresnel curve within 2%" black pathtrace 0.98 1.02
check "smooth metal 0.5, progressive: Schlick within 0.5% (a constant 0.5 would read $constant_ratio)" metal progressive \
    "$metal_ratio * 0.995" "$metal_ratio * 1.005"
check "specularFactor 0: the black sphere reflects nothing" off progressive 0 1e-6
mask=tests/ref/dielectric_middle_mask_64.exr
check "smooth black dielectric: the window behind the camera at F0 = 0.04 within 1%" window0 progressive 0.0396 0.0404 none "$mask"
check "roughness 0.3: the window's reflection shows, blurred a little past its edges" window3 progressive 0.030 0.0396 none "$mask"
check "roughness 0.3, path tracer: the same" window3 pathtrace 0.030 0.0396 none "$mask"
python3 - "$tmp" <<'EOF2'
import json, sys
d = sys.argv[1]
doc = json.load(open(d + "/window3.gltf"))
doc["materials"][0]["extensions"] = {"KHR_materials_specular": {"specularFactor": 0.0}}
json.dump(doc, open(d + "/window_off.gltf", "w"))
EOF2
check "specularFactor 0: no window in the sphere" window_off progressive 0 1e-6 none "$mask"
checks=$((checks + 1))
if grep -q "^stat analysis .* glossy=0 " "$tmp/off_progressive"; then echo "ok: specularFactor 0: stat analysis glossy=0"
else fails=$((fails + 1)); echo "FAIL: specularFactor 0 must say glossy=0: $(grep '^stat analysis' "$tmp/off_progressive")"; fi
checks=$((checks + 1))
if grep -q "^stat analysis .* glossy=1 " "$tmp/black_progressive"; then echo "ok: a plain dielectric: glossy=1"
else fails=$((fails + 1)); echo "FAIL: a plain dielectric must say glossy=1"; fi
echo "test_dielectric: $checks checks, $fails failed"
[ "$fails" -eq 0 ]

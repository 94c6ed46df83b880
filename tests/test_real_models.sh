#!/bin/sh
# test_real_models.sh: the public sample models in ../shared/real-models (when present) render as their README says they should.
cd "$(dirname "$0")/.." || exit 1
root=${PMVIEW_REAL_MODELS:-../shared/real-models}
if [ ! -d "$root" ]; then
    echo "SKIP: no sample models at $root (set PMVIEW_REAL_MODELS)"
    echo "test_real_models: skipped"
    exit 0
fi
bin=./pmview
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0; checks=0
check() { # description, shell condition
    checks=$((checks + 1))
    if ! eval "$2"; then fails=$((fails + 1)); echo "FAIL: $1"; sed 's/^/    /' "$tmp/err" | head -5; fi
}
render() { # model, extra options...
    model=$1; shift
    $bin "$root/$model" --width 96 --iterations 8 --stats --snapshot "$tmp/out.png" "$@" >"$tmp/out" 2>"$tmp/err"
}
stat() { # STAGE KEY: the value printed
    sed -n "s/^stat $1 \(.* \)\{0,1\}$2=\([^ ]*\).*/\2/p" "$tmp/out" | head -n 1
}
# python: pixel statistics of the PNG (standard library only, through png_compare's reader)
pixels() {
    python3 -c "
import sys; sys.path.insert(0, 'tests'); import png_compare as p
w, h, px = p.read_png('$tmp/out.png')
$1"
}

render MultiUVTest/MultiUVTest.gltf
check "MultiUVTest loads" '[ -s "$tmp/out.png" ]'
check "MultiUVTest reads its emissive logo through TEXCOORD_1, no ignored input" '[ "$(stat load ignored_inputs)" = 0 ]'
# a cube with a glowing logo, not a uniformly glowing white cube: few white pixels, some green ones
check "MultiUVTest: not a white silhouette, the green logo glows" 'pixels "
white = green = 0
for i in range(w * h):
    r, g, b = px[i]
    white += r > 240 and g > 240 and b > 240
    green += g > r + 40 and g > b + 40
print(white, green, w * h)
sys.exit(0 if white < 0.02 * w * h and green > 0.003 * w * h else 1)"'

render AlphaBlendModeTest/AlphaBlendModeTest.glb
check "AlphaBlendModeTest: MASK and BLEND triangles go behind the alpha filter" '[ "$(stat bvh alpha_tested_triangles)" -gt 0 ] && [ "$(stat analysis non_opaque)" = 1 ]'

render Cameras/Cameras.gltf --camera 1
check "Cameras: both cameras load (one orthographic)" '[ "$(stat load cameras)" = 2 ]'
check "Cameras: no light in the file, the default gradient sky" '[ "$(stat sky kind)" = gradient ] && grep -q "default gradient sky" "$tmp/err"'
# the plane stands out from the background (the horizon band, seen by parallel rays). It has no
# material: glTF's default is a white metal of roughness 1, which the specification's single-
# scattering GGX makes reflect only about 38% at this angle, so the margin is small but steady
check "Cameras (orthographic): the plane stands out from the background" 'pixels "
def block(x0, x1, y0, y1):
    v = [sum(px[y * w + x]) / 3 for y in range(y0, y1) for x in range(x0, x1)]
    return sum(v) / len(v)
plane = block(w // 2 - 8, w // 2 + 8, h // 2 + 4, h // 2 + 16); background = block(0, 6, 0, h)
print(plane, background)
sys.exit(0 if plane > background + 5 else 1)"'

render TextureTransformTest/TextureTransformTest.gltf
check "TextureTransformTest: KHR_texture_transform honoured, nothing ignored" '[ "$(stat load ignored_inputs)" = 0 ] && [ "$(stat load textures)" -gt 0 ]'

render LightsPunctualLamp/LightsPunctualLamp.gltf
check "LightsPunctualLamp: its 5 punctual lights, and so no default sky" '[ "$(stat load lights)" = 5 ] && [ "$(stat sky kind)" = none ]'
check "LightsPunctualLamp: emissive shade from its texture, glossy metal, glass" '[ "$(stat load emissive_triangles)" -gt 0 ] && [ "$(stat analysis glossy)" = 1 ] && [ "$(stat analysis glass)" = 1 ]'
check "LightsPunctualLamp: no white silhouette" 'pixels "
white = sum(1 for q in px if min(q) > 240)
print(white, w * h)
sys.exit(0 if white < 0.05 * w * h else 1)"'

render OrientationTest/OrientationTest.glb
check "OrientationTest loads and renders lit" '[ -s "$tmp/out.png" ] && [ "$(stat sky kind)" = gradient ]'

echo "test_real_models: $checks checks, $fails failed"
[ "$fails" -eq 0 ]

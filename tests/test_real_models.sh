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
    rm -f "$tmp/out.png"
    $bin "$root/$model" --width 96 --iterations 8 --stats --snapshot "$tmp/out.png" "$@" >"$tmp/out" 2>"$tmp/err"
}
stat() { # STAGE KEY: the value printed
    sed -n "s/^stat $1 \(.* \)\{0,1\}$2=\([^ ]*\).*/\2/p" "$tmp/out" | head -n 1
}
# python: pixel statistics of the PNG (standard library only, through png_compare's reader). The
# snippet sees w, h, px (rows from the top, (r, g, b) 0-255), box(x0, x1, y0, y1) (the pixels of a
# rectangle given in fractions of the image), mean(pixels) (per channel) and ok(condition, values...)
# (prints the values measured and exits 0 or 1)
pixels() {
    python3 -c "
import sys, math; sys.path.insert(0, 'tests'); import png_compare as p
w, h, px = p.read_png('$tmp/out.png')
px = [q[:3] for q in px]
def box(x0, x1, y0, y1):
    return [px[y * w + x] for y in range(int(y0 * h), int(y1 * h)) for x in range(int(x0 * w), int(x1 * w))]
def mean(v):
    return [sum(q[c] for q in v) / len(v) for c in range(3)]
def ok(condition, *values):
    print(*[round(v, 3) if isinstance(v, float) else v for v in values])
    sys.exit(0 if condition else 1)
$1"
}

render MultiUVTest/MultiUVTest.gltf
check "MultiUVTest loads" '[ -s "$tmp/out.png" ]'
check "MultiUVTest reads its emissive logo through TEXCOORD_1, no ignored input" '[ "$(stat load ignored_inputs)" = 0 ]'
# a cube with a glowing logo, not a uniformly glowing white cube: few white pixels, some green ones
check "MultiUVTest: not a white silhouette, the green logo glows" 'pixels "
white = sum(1 for r, g, b in px if r > 240 and g > 240 and b > 240)
green = sum(1 for r, g, b in px if g > r + 40 and g > b + 40)
ok(white < 0.02 * w * h and green > 0.003 * w * h, white, green, w * h)"'

# five panels over a stone bed, left to right: OPAQUE, BLEND, MASK at cutoffs 0.25, 0.5 (the
# default) and 0.75. Their texture's alpha falls linearly up the panel, so a MASK panel keeps
# its colour (blue and yellow stripes, saturated where the stone is not) on the lower 1 - cutoff
# of its height, the stone showing above; the BLEND panel fades into the stone upward
render AlphaBlendModeTest/AlphaBlendModeTest.glb --width 192 --iterations 16
check "AlphaBlendModeTest: MASK and BLEND triangles go behind the alpha filter" '[ "$(stat bvh alpha_tested_triangles)" -gt 0 ] && [ "$(stat analysis non_opaque)" = 1 ]'
check "AlphaBlendModeTest: MASK panels cut out above 1 - cutoff of their height, BLEND fades, OPAQUE whole" 'pixels "
def coloured_rows(centre):
    x0, x1 = int((centre - 0.04) * w), int((centre + 0.04) * w) + 1
    y0, y1 = int(0.43 * h), int(0.585 * h) + 1
    rows = [sum(1 for x in range(x0, x1) if max(px[y * w + x]) - min(px[y * w + x]) > 60) / (x1 - x0) for y in range(y0, y1)]
    return rows
panels = [coloured_rows(c) for c in (0.19, 0.35, 0.52, 0.68, 0.84)]
kept = [sum(1 for r in rows if r > 0.3) / len(rows) for rows in panels]
quarter = len(panels[1]) // 4
blend_top, blend_bottom = sum(panels[1][:quarter]) / quarter, sum(panels[1][-quarter:]) / quarter
ok(kept[0] > 0.9 and all(abs(kept[2 + i] - (1 - cut)) < 0.12 for i, cut in enumerate((0.25, 0.5, 0.75)))
   and blend_top < 0.5 * blend_bottom and blend_bottom > 0.3,
   \"rows kept: opaque\", kept[0], \"mask 0.25/0.5/0.75\", kept[2], kept[3], kept[4], \"blend top\", blend_top, \"bottom\", blend_bottom)"'

# a unit square tilted 45 degrees back, seen from (0.5, 0.5, 3): through the perspective camera
# its far (top) edge is 3 / 3.707 = 0.81 of its near edge's width; through the orthographic one
# (xmag = ymag = 1) both edges span half the image's width and it covers rows 0.40 to 0.75
plane_extent='
def lum(x, y): return sum(px[y * w + x]) / 3
def background(y): return sum(lum(i, y) for i in range(4)) / 4
rows = [y for y in range(h) if sum(abs(lum(x, y) - background(y)) for x in range(w)) / w > 3] or [0, 1]
def width(y0, y1):
    cols = [x for x in range(w) if sum(abs(lum(x, y) - background(y)) for y in range(y0, y1)) / (y1 - y0) > 10]
    return max(cols) - min(cols) + 1 if cols else 0
top, bottom = rows[0], rows[-1] + 1
band = max(2, (bottom - top) // 5)
far, near = width(top, top + band), width(bottom - band, bottom)
'
render Cameras/Cameras.gltf --camera 0
check "Cameras (perspective): the plane, its far edge foreshortened to 0.81 of its near one" 'pixels "$plane_extent
ok(near > 0.3 * w and abs(far / near - 0.81) < 0.07, far, near, far / near)"'
render Cameras/Cameras.gltf --camera 1
check "Cameras: both cameras load (one orthographic)" '[ "$(stat load cameras)" = 2 ]'
check "Cameras: no light in the file, the default gradient sky" '[ "$(stat sky kind)" = gradient ] && grep -q "default gradient sky" "$tmp/err"'
check "Cameras (orthographic): the plane half the image wide at both edges, rows 0.40 to 0.75" 'pixels "$plane_extent
ok(abs(far / near - 1) < 0.06 and abs(near / w - 0.5) < 0.05 and abs(top / h - 0.40) < 0.04 and abs(bottom / h - 0.75) < 0.04,
   far, near, top / h, bottom / h)"'

# the top row offsets the UV grid texture (four coloured quadrants) by half in U, in V and in
# both: each tile then shows one quadrant whole, green, blue and cyan; without the transform
# each would show all four
render TextureTransformTest/TextureTransformTest.gltf
check "TextureTransformTest: KHR_texture_transform honoured, nothing ignored" '[ "$(stat load ignored_inputs)" = 0 ] && [ "$(stat load textures)" -gt 0 ]'
check "TextureTransformTest: the offset tiles show the green, blue and cyan quadrants whole" 'pixels "
tiles = [mean(box(c - 0.08, c + 0.08, 0.22, 0.38)) for c in (0.18, 0.5, 0.82)]
(r0, g0, b0), (r1, g1, b1), (r2, g2, b2) = tiles
ok(g0 > 2 * max(r0, b0) and b1 > 2 * max(r1, g1) and min(g2, b2) > 2 * r2, *[round(v) for t in tiles for v in t])"'

# lit by its own lights only (no sky): the background black, the shade glowing in the pattern
# of its emissive texture (bright and dark parts, brighter than the whole), the brass stand lit
render LightsPunctualLamp/LightsPunctualLamp.gltf
check "LightsPunctualLamp: its 5 punctual lights, and so no default sky" '[ "$(stat load lights)" = 5 ] && [ "$(stat sky kind)" = none ]'
check "LightsPunctualLamp: emissive shade from its texture, glossy metal, glass (thin: no KHR_materials_volume)" '[ "$(stat load emissive_triangles)" -gt 0 ] && [ "$(stat analysis glossy)" = 1 ] && [ "$(stat analysis glass)" = 1 ] && [ "$(stat analysis thin_glass)" = 1 ]'
check "LightsPunctualLamp: no white silhouette" 'pixels "
white = sum(1 for q in px if min(q) > 240)
ok(white < 0.05 * w * h, white, w * h)"'
check "LightsPunctualLamp: black background, the shade glowing in a pattern, the stand lit" 'pixels "
corners = max(mean(box(0, 0.15, 0, 0.15) + box(0.85, 1, 0, 0.15)))
shade = box(0.33, 0.48, 0.28, 0.46)
bright = sum(1 for q in shade if sum(q) / 3 > 150) / len(shade)
dark = sum(1 for q in shade if sum(q) / 3 < 40) / len(shade)
stand = sum(1 for q in box(0.55, 0.8, 0.2, 0.6) if max(q) > 60) / (0.25 * 0.4 * w * h)
whole = sum(mean(px)) / 3
ok(corners < 3 and sum(mean(shade)) / 3 > 4 * whole and bright > 0.2 and dark > 0.1 and stand > 0.05,
   \"corners\", corners, \"shade\", sum(mean(shade)) / 3, \"image\", whole, \"bright\", bright, \"dark\", dark, \"stand\", stand)"'

# seen from +Z, framed on the base cube's Z face: the blue Z arrow, translated 5 along Z (its
# node's translation), stands in front of the face's centre; left at the origin it would be hidden
# inside the cube
render OrientationTest/OrientationTest.glb
check "OrientationTest loads and renders lit" '[ -s "$tmp/out.png" ] && [ "$(stat sky kind)" = gradient ]'
check "OrientationTest: the Z arrow in front of the Z face, at its centre" 'pixels "
blue = [(x, y) for y in range(h) for x in range(w) if px[y * w + x][2] > max(px[y * w + x][:2]) + 80]
n = max(len(blue), 1); mx = sum(x for x, y in blue) / n / w; my = sum(y for x, y in blue) / n / h
face = mean(box(0.2, 0.35, 0.6, 0.8))
ok(len(blue) > 0.01 * w * h and abs(mx - 0.5) < 0.1 and abs(my - 0.5) < 0.1 and min(face) > 60, len(blue), mx, my, *face)"'

# OrientationTest under a sky map whose one texel (5.6 degrees across) is 3,000 times the rest: its
# lobes' caustics are the path tracer's loop's to find, and the caustic photons' splats are the
# noisier: the default's caustic trial gives them up (caustic_trial=1, the iterations after it the
# loop's alone, path_only_samples), and its image at 96 samples errs no more than 1.5 times another
# seed of --mode pathtrace's against a third (both about 0.004; a fold that lost the photons'
# statistics, or light counted twice, reads more)
python3 tests/sky_files.py exr "$tmp/patch.exr" 64 32 1 40 8 3000 >"$tmp/err" 2>&1
for run in "ref --mode pathtrace --seed 3" "path --mode pathtrace --seed 1" "default --seed 1"; do
    set -- $run; name=$1; shift
    $bin "$root/OrientationTest/OrientationTest.glb" --sky "$tmp/patch.exr" --width 64 --height 64 --iterations 96 --stats "$@" \
        $( [ "$name" = ref ] || echo "--reference $tmp/ref.exr" ) --snapshot "$tmp/$name.exr" >"$tmp/$name.out" 2>"$tmp/err"
done
trial=$(sed -n 's/^stat progressive .* caustic_trial=\([^ ]*\).*/\1/p' "$tmp/default.out")
loop=$(sed -n 's/^stat progressive .* path_only_samples=\([^ ]*\).*/\1/p' "$tmp/default.out")
errs="$(sed -n 's/^stat error .* relmse=\([^ ]*\).*/\1/p' "$tmp/default.out") $(sed -n 's/^stat error .* relmse=\([^ ]*\).*/\1/p' "$tmp/path.out")"
echo "OrientationTest under a bright patch: caustic_trial=$trial path_only_samples=$loop relMSE default, path tracer: $errs"
check "OrientationTest under a bright patch: the caustic trial gives the photons up for the loop (caustic_trial=$trial, path_only_samples=$loop)" \
    '[ "$trial" = 1 ] && [ "${loop:-0}" -gt 0 ]'
check "OrientationTest under a bright patch: relMSE default, path tracer $errs (the default at most 1.5 times)" \
    'python3 -c "import sys; a, b = map(float, sys.argv[1:3]); sys.exit(0 if 0 < a <= 1.5 * b else 1)" $errs'

# the plain duck renders yellow (about 5% of the image, framed whole), and so does its Draco-compressed copy
for duck in Duck/glTF/Duck.gltf Duck/glTF-Draco/Duck.gltf; do
    render $duck
    check "$duck: a yellow duck" 'pixels "
yellow = sum(1 for r, g, b in px if r > 150 and g > 110 and b < 0.6 * g)
ok(yellow > 0.02 * w * h, yellow, w * h)"'
done

echo "test_real_models: $checks checks, $fails failed"
[ "$fails" -eq 0 ]

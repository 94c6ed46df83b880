#!/bin/sh
# test_window_variants.sh: the window's M key under Xvfb cycles a file's KHR_materials_variants (each, then the file's default materials), each rendered from scratch with the camera kept; a file without variants changes nothing and says so.
cd "$(dirname "$0")/.." || exit 1
. tests/xvfb_inner.sh
need_tools test_window_variants xvfb-run xdotool python3
start_temp

# the Cornell box whose red (left) wall has two variants: "blue wall" and "yellow"
python3 - "$tmp/variants.gltf" <<'EOF' || { echo "FAIL: the variant scene"; exit 1; }
import json, sys
doc = json.load(open("scenes/cornell-box.gltf"))
red = doc["materials"][3]
for name, colour in (("blue", [0.05, 0.1, 0.7, 1.0]), ("yellow", [0.7, 0.6, 0.05, 1.0])):
    m = json.loads(json.dumps(red))
    m["name"] = name
    m["pbrMetallicRoughness"]["baseColorFactor"] = colour
    doc["materials"].append(m)
n = len(doc["materials"])
doc.setdefault("extensions", {})["KHR_materials_variants"] = {"variants": [{"name": "blue wall"}, {"name": "yellow"}]}
doc["extensionsUsed"].append("KHR_materials_variants")
for mesh in doc["meshes"]:
    for prim in mesh["primitives"]:
        if prim["material"] == 3:
            prim["extensions"] = {"KHR_materials_variants": {"mappings": [{"material": n - 2, "variants": [0]},
                                                                          {"material": n - 1, "variants": [1]}]}}
json.dump(doc, open(sys.argv[1], "w"))
EOF
args="--width 96 --height 96 --iterations 4 --seed 7 --threads 2"

cat >"$tmp/inner.sh" <<'EOF'
tmp=$1; scene=$2; name=$3; shift 3
log="$tmp/$name.log"
. tests/window_inner.sh
shot() { # NAME: P, then the screenshot kept as NAME.png
    n=$(count "pmview: saved")
    press p
    wait_for "pmview: saved" $((n + 1)) 20
    cp "$tmp/shot.png" "$tmp/$1.png" || fail "no screenshot for $1"
}
title() { xdotool getwindowname "$wid"; }
./pmview "$scene" "$@" --screenshot "$tmp/shot.png" >"$log" 2>&1 &
pid=$!
wait_for "pmview: iterations done" 1 60
focus_window pmview
shot "${name}_first"
if [ "$name" = variants ]; then
    # the camera moved first (one step right), so that a reload that took the file's camera would show
    press d
    sleep 0.5
    # "iterations done" is said once a load: the title's count says the moved image is done
    i=0
    until title | grep -q "^pmview 4 it "; do
        i=$((i + 1)); [ "$i" -gt 600 ] && fail "the moved camera's 4 iterations never showed in the title: $(title)"
        sleep 0.1
    done
    shot moved_default
    press m
    wait_for "pmview: material variant blue wall (1 of 2)" 1 60
    wait_for "pmview: iterations done" 2 60
    title > "$tmp/title_blue.txt"
    shot moved_blue
    press m
    wait_for "pmview: material variant yellow (2 of 2)" 1 60
    wait_for "pmview: iterations done" 3 60
    shot moved_yellow
    press m
    wait_for "pmview: the file's default materials" 1 60
    wait_for "pmview: iterations done" 4 60
    title > "$tmp/title_default.txt"
    shot moved_default_again
else
    press m
    wait_for "has no material variants" 1 20
    sleep 0.5
    title > "$tmp/title_none.txt"
    shot plain_after
fi
press Escape
wait_exit 20
[ "$rc" -eq 0 ] || fail "pmview exited with $rc after Escape"
echo "inner: ok"
EOF

# shellcheck disable=SC2086
run_inner test_window_variants 300 "$tmp/inner.sh" "$tmp" "$tmp/variants.gltf" variants $args
# shellcheck disable=SC2086
run_inner test_window_variants 120 "$tmp/inner.sh" "$tmp" scenes/cornell-box.gltf plain $args
fails=0; checks=0
fail() { fails=$((fails + 1)); echo "FAIL: $*"; }
same() { checks=$((checks + 1)); python3 tests/png_compare.py same "$1" "$2" 1 >/dev/null || fail "$3"; }
differ() { checks=$((checks + 1)); python3 tests/png_compare.py same "$1" "$2" 8 >/dev/null && fail "$3"; }
# the left wall's mean colour (the strip png_compare.py's cornell check reads): which channel leads
wall() { # IMAGE WANT(blue|yellow|red)
    checks=$((checks + 1))
    python3 - "$1" "$2" <<'EOF' || fail "$1: the left wall is not $2"
import sys
sys.path.insert(0, "tests")
import png_compare as pc
w, h, px = pc.read_png(sys.argv[1])
r, g, b = pc.region_mean(w, px, w // 40, h // 3, w // 10, 2 * h // 3)
want = sys.argv[2]
ok = {"blue": b > 2 * r and b > g, "yellow": r > 2 * b and g > 2 * b, "red": r > 2 * g and r > 2 * b}[want]
print("left wall of %s: %.0f %.0f %.0f, want %s" % (sys.argv[1].rsplit("/", 1)[-1], r, g, b, want))
sys.exit(0 if ok else 1)
EOF
}
checks=$((checks + 1))
./pmview "$tmp/variants.gltf" $args --quiet --snapshot "$tmp/ref_first.png" >"$tmp/snap.log" 2>&1 || fail "snapshot: $(tail -n 1 "$tmp/snap.log")"
same "$tmp/variants_first.png" "$tmp/ref_first.png" "the first image is not the file's default materials"
differ "$tmp/variants_first.png" "$tmp/moved_default.png" "the camera step must change the image"
wall "$tmp/moved_default.png" red
wall "$tmp/moved_blue.png" blue
wall "$tmp/moved_yellow.png" yellow
same "$tmp/moved_default_again.png" "$tmp/moved_default.png" \
    "after the last variant M must bring back the default materials, rendered from scratch from the camera the window had"
checks=$((checks + 1))
grep -q "variant blue wall" "$tmp/title_blue.txt" || fail "the title must name the variant: $(cat "$tmp/title_blue.txt")"
checks=$((checks + 1))
grep -q "variant" "$tmp/title_default.txt" && fail "the default materials' title must name no variant: $(cat "$tmp/title_default.txt")"
# without variants: M says so and reloads nothing
same "$tmp/plain_after.png" "$tmp/plain_first.png" "M on a file without variants must change nothing shown"
checks=$((checks + 1))
grep -q "has no material variants" "$tmp/title_none.txt" || fail "the title must say the file has no variants: $(cat "$tmp/title_none.txt")"
checks=$((checks + 1))
grep -q "pmview: loaded\|pmview: reloaded" "$tmp/plain.log" && fail "M on a file without variants must not reload it"
echo "titles: $(cut -c1-80 "$tmp/title_blue.txt") | $(cut -c1-80 "$tmp/title_none.txt")"
echo "test_window_variants: $checks checks, $fails failed"
[ "$fails" -eq 0 ]

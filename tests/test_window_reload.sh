#!/bin/sh
# test_window_reload.sh: the window under Xvfb keeps up with its files: --watch reloads a scene rewritten in place and by rename within 2 s with the camera kept, a broken save keeps the image and names the error; a dropped scene and sky (through the drop handler) replace what is shown, a bad drop only the title; --reference puts a falling relMSE in the title and V shows the error.
cd "$(dirname "$0")/.." || exit 1
. tests/xvfb_inner.sh
need_tools test_window_reload xvfb-run xdotool xwd python3
start_temp

# the scene in a folder of its own; its edits: the red wall blue (camera moved in the file, which
# the window must not follow), then the green wall yellow (by rename), then a save cut short
mkdir -p "$tmp/scene"
cp scenes/cornell-box.gltf "$tmp/scene/room.gltf"
edit() { python3 tests/window_edit.py "$@" || { echo "FAIL: tests/window_edit.py $*"; exit 1; }; }
edit scenes/cornell-box.gltf "$tmp/blue.gltf" --colour 3 0.05 0.1 0.7 --camera-shift 0.6 0.3 0
edit scenes/cornell-box.gltf "$tmp/blue_same_camera.gltf" --colour 3 0.05 0.1 0.7
edit "$tmp/blue.gltf" "$tmp/yellow.gltf" --colour 4 0.7 0.6 0.05
edit "$tmp/blue_same_camera.gltf" "$tmp/yellow_same_camera.gltf" --colour 4 0.7 0.6 0.05
edit "$tmp/yellow.gltf" "$tmp/broken.gltf" --broken
python3 tests/sky_files.py hdr "$tmp/sky.hdr" 16 8 2 || exit 1
printf 'not a scene\n' > "$tmp/notes.txt"
args="--width 96 --height 96 --iterations 4 --seed 7 --threads 2"

cat >"$tmp/inner.sh" <<'EOF'
tmp=$1; shift
log="$tmp/pmview.log"
. tests/window_inner.sh
shot() { # NAME: P, then the screenshot kept as NAME.png
    n=$(count "pmview: saved")
    press p
    wait_for "pmview: saved" $((n + 1)) 20
    cp "$tmp/shot.png" "$tmp/$1.png" || fail "no screenshot for $1"
}
# within2 PATTERN N: the Nth PATTERN line within 2 s of now, printed as the delay
within2() {
    t0=$(now_ms)
    wait_for "$1" "$2" 10
    dt=$(( $(now_ms) - t0 ))
    echo "inner: '$1' ($2) after $dt ms"
    [ "$dt" -le 2000 ] || fail "'$1' came after $dt ms, more than 2 s"
}
title() { xdotool getwindowname "$wid"; }

PMVIEW_TEST_DROP="$tmp/drop" ./pmview "$tmp/scene/room.gltf" --watch "$@" --screenshot "$tmp/shot.png" >"$log" 2>&1 &
pid=$!
wait_for "pmview: iterations done" 1 60
focus_window pmview
shot first
# in place: the file truncated and written again
cat "$tmp/blue.gltf" > "$tmp/scene/room.gltf"
within2 "pmview: reloaded" 1
wait_for "pmview: iterations done" 2 60
shot blue
# an editor's save: a temporary file renamed over the scene
cp "$tmp/yellow.gltf" "$tmp/scene/.room.gltf.tmp" && mv "$tmp/scene/.room.gltf.tmp" "$tmp/scene/room.gltf"
within2 "pmview: reloaded" 2
wait_for "pmview: iterations done" 3 60
shot yellow
# rapid saves coalesce: five writes 20 ms apart are one reload
for k in 1 2 3 4 5; do cat "$tmp/yellow.gltf" > "$tmp/scene/room.gltf"; sleep 0.02; done
within2 "pmview: reloaded" 3
sleep 1
[ "$(count "pmview: reloaded")" -eq 3 ] || fail "five saves 20 ms apart made $(($(count "pmview: reloaded") - 2)) reloads, want 1"
wait_for "pmview: iterations done" 4 60
# a broken save: the image stays, stderr and the title say why
cat "$tmp/broken.gltf" > "$tmp/scene/room.gltf"
within2 "pmview: error: .*room.gltf" 1
sleep 0.3
title > "$tmp/title_broken.txt"
shot after_broken
# the next good save loads
cat "$tmp/yellow.gltf" > "$tmp/scene/room.gltf"
within2 "pmview: reloaded" 4
wait_for "pmview: iterations done" 5 60
# drops, through the drop handler: a scene, a sky, then files that cannot be used
drop() { echo "$1" > "$tmp/drop.tmp" && mv "$tmp/drop.tmp" "$tmp/drop"; }
drop "$PWD/scenes/caustic.gltf"
within2 "pmview: loaded .*caustic.gltf" 1
wait_for "pmview: iterations done" 6 60
shot dropped_scene
drop "$tmp/sky.hdr"
within2 "pmview: loaded .*sky.hdr" 1
wait_for "pmview: iterations done" 7 60
shot dropped_sky
drop "$tmp/notes.txt"
within2 "pmview: error: .*notes.txt" 1
sleep 0.3
title > "$tmp/title_notes.txt"
drop "$tmp/broken.gltf"
within2 "pmview: error: .*broken.gltf" 1
sleep 0.5
title > "$tmp/title_bad_drop.txt"
shot after_bad_drop
press Escape
wait_exit 20
[ "$rc" -eq 0 ] || fail "pmview exited with $rc after Escape"
cp "$log" "$tmp/window.log"
echo "inner: ok"
EOF

# shellcheck disable=SC2086
run_inner test_window_reload 300 "$tmp/inner.sh" "$tmp" $args
fails=0; checks=0
fail() { fails=$((fails + 1)); echo "FAIL: $*"; }
snap() { # OUT.png SCENE [more]: the offscreen image the window must show
    out=$1; shift
    # shellcheck disable=SC2086
    ./pmview "$@" $args --quiet --snapshot "$out" >"$tmp/snap.log" 2>&1 || { cat "$tmp/snap.log"; fail "snapshot of $*"; }
}
same() { checks=$((checks + 1)); python3 tests/png_compare.py same "$1" "$2" 1 >/dev/null || fail "$3"; }
differ() { checks=$((checks + 1)); python3 tests/png_compare.py same "$1" "$2" 8 >/dev/null && fail "$3"; }
snap "$tmp/ref_first.png" scenes/cornell-box.gltf
snap "$tmp/ref_blue.png" "$tmp/blue_same_camera.gltf"
snap "$tmp/ref_yellow.png" "$tmp/yellow_same_camera.gltf"
snap "$tmp/ref_caustic.png" scenes/caustic.gltf
snap "$tmp/ref_caustic_sky.png" scenes/caustic.gltf --sky "$tmp/sky.hdr"
same "$tmp/first.png" "$tmp/ref_first.png" "the first image is not the scene's"
same "$tmp/blue.png" "$tmp/ref_blue.png" "rewritten in place: the window must show the blue wall from the camera it had (not the file's moved one)"
same "$tmp/yellow.png" "$tmp/ref_yellow.png" "saved by rename: the window must show the yellow wall from the camera it had"
differ "$tmp/first.png" "$tmp/blue.png" "the reload must change the image"
same "$tmp/after_broken.png" "$tmp/yellow.png" "a broken save must keep the image"
checks=$((checks + 1))
grep -q "reload failed: .*room.gltf" "$tmp/title_broken.txt" || fail "the title must name the broken save's error: $(cat "$tmp/title_broken.txt")"
checks=$((checks + 1))
[ "$(grep -c "pmview: error: .*room.gltf" "$tmp/window.log")" -eq 1 ] || fail "the broken save must print one error line"
same "$tmp/dropped_scene.png" "$tmp/ref_caustic.png" "a dropped scene must be shown from its own camera"
same "$tmp/dropped_sky.png" "$tmp/ref_caustic_sky.png" "a dropped sky must light the scene as --sky does"
same "$tmp/after_bad_drop.png" "$tmp/dropped_sky.png" "a bad drop must change nothing shown"
checks=$((checks + 1))
grep -q "notes.txt is not a .gltf" "$tmp/title_notes.txt" || fail "the title must say why notes.txt was not opened: $(cat "$tmp/title_notes.txt")"
checks=$((checks + 1))
grep -q "drop failed: .*broken.gltf" "$tmp/title_bad_drop.txt" || fail "the title must name the bad drop's error: $(cat "$tmp/title_bad_drop.txt")"
echo "titles: $(cut -c1-90 "$tmp/title_broken.txt") | $(cut -c1-90 "$tmp/title_bad_drop.txt")"
# --reference: the title's relMSE against the converged Cornell box falls as the window converges,
# and V reaches the false-colour error view
cat >"$tmp/inner_ref.sh" <<'EOF'
tmp=$1; shift
log="$tmp/ref.log"
. tests/window_inner.sh
# relmse_after N: the title's iterations and relMSE once it shows N iterations or more
relmse_after() {
    i=0
    while :; do
        t=$(xdotool getwindowname "$wid")
        it=$(echo "$t" | sed -n 's/^pmview \([0-9]*\) it .*/\1/p')
        r=$(echo "$t" | sed -n 's/.*relMSE \([0-9.e+-]*\) .*/\1/p')
        [ -n "$it" ] && [ -n "$r" ] && [ "$it" -ge "$1" ] && { echo "$it $r"; return; }
        i=$((i + 1)); [ "$i" -gt 600 ] && fail "the title never showed $1 iterations with a relMSE: $t"
        sleep 0.1
    done
}
./pmview scenes/cornell-box.gltf "$@" --screenshot "$tmp/shot.png" >"$log" 2>&1 &
pid=$!
focus_window pmview
relmse_after 2 > "$tmp/relmse_early"
# eight times the iterations of the first reading (on an idle machine the title's first relMSE may
# already come after a hundred iterations of so small an image)
read -r first _ < "$tmp/relmse_early"
relmse_after $((first * 8 > 64 ? first * 8 : 64)) > "$tmp/relmse_late"
xdotool getwindowname "$wid" > "$tmp/title_ref.txt"
for k in 1 2 3 4; do
    [ "$(count "view: relative error")" -ge 1 ] && break
    press v; sleep 0.3
done
[ "$(count "view: relative error")" -ge 1 ] || fail "V never reached the relative-error view"
sleep 0.5
# what X shows (P saves the shaded layers, drawn offscreen)
xwd -id "$wid" -silent >"$tmp/error_view.xwd" || fail "xwd could not dump the window"
# and V once more goes back to the shaded image
n=$(count "view: shaded")
press v
wait_for "view: shaded" $((n + 1)) 10
press Escape
wait_exit 20
echo "inner: ok"
EOF
run_inner test_window_reload 300 "$tmp/inner_ref.sh" "$tmp" --reference tests/ref/cornell_path_64.exr --width 64 --height 64 --threads 2
read -r it1 r1 < "$tmp/relmse_early"
read -r it2 r2 < "$tmp/relmse_late"
echo "--reference in the title: relMSE $r1 at $it1 iterations, $r2 at $it2 ($(cut -c1-100 "$tmp/title_ref.txt"))"
checks=$((checks + 1))
awk -v a="$r1" -v b="$r2" 'BEGIN { exit !(a > 0 && b > 0 && b < 0.7 * a) }' || fail "the title's relMSE must fall (from $r1 to $r2)"
# the error view is false colour: most pixels far from grey
checks=$((checks + 1))
python3 - "$tmp/error_view.xwd" <<'PY' || fail "the error view is not false colour"
import sys
sys.path.insert(0, "tests")
from png_compare import read_xwd
w, h, px = read_xwd(sys.argv[1])
coloured = sum(1 for p in px if max(p) - min(p) > 60) / len(px)
print("error view: %.0f%% of the pixels coloured" % (100 * coloured))
sys.exit(0 if coloured > 0.8 else 1)
PY
echo "test_window_reload: $checks checks, $fails failed"
[ "$fails" -eq 0 ]

#!/bin/sh
# test_window.sh: the real window under Xvfb, driven by xdotool: what it shows (xwd) and what P saves equal the offscreen snapshot, 4 toggles indirect, Esc quits.
#
# pmview runs inside xvfb-run through an inner script (xvfb-run makes its own display, so the
# keys must be sent from inside it). The window's contents as the X server holds them (xwd) and
# its P screenshot must both equal an offscreen --snapshot of the same render within 1 per
# channel; after '4' (indirect off) the next screenshot must be darker.
# xvfb-run and everything under it run in their own session, killed as a group on any exit.
cd "$(dirname "$0")/.." || exit 1

. tests/xvfb_inner.sh
need_tools test_window xvfb-run xdotool xwd python3
start_temp

args="scenes/cornell-box.gltf --width 96 --height 96 --iterations 4 --seed 7 --threads 2"

cat >"$tmp/inner.sh" <<'EOF'
# runs under xvfb-run: start pmview, wait, send keys; "$1" is the temp folder, the rest pmview's arguments
tmp=$1; shift
log="$tmp/pmview.log"
. tests/window_inner.sh
./pmview "$@" --screenshot "$tmp/shot.png" >"$log" 2>&1 &
pid=$!
wait_for "pmview: iterations done" 1 60
focus_window pmview
press p
wait_for "pmview: saved" 1 20
cp "$tmp/shot.png" "$tmp/first.png" || fail "no screenshot file"
# the frame that P saved has been drawn and swapped by now: dump the window as X shows it
xwd -id "$wid" -silent >"$tmp/window.xwd" || fail "xwd could not dump the window"
press 4
press p
wait_for "pmview: saved" 2 20
cp "$tmp/shot.png" "$tmp/no-indirect.png" || fail "no second screenshot file"
press Escape
wait_exit 20
[ "$rc" -eq 0 ] || fail "pmview exited with $rc after Escape"
echo "inner: ok"
EOF

# shellcheck disable=SC2086 # args is a fixed word list
run_inner test_window 180 "$tmp/inner.sh" "$tmp" $args

# shellcheck disable=SC2086
if ! ./pmview $args --snapshot "$tmp/snapshot.png" >"$tmp/snapshot.log" 2>&1; then
    cat "$tmp/snapshot.log"; echo "test_window: FAILED: the offscreen snapshot failed"; exit 1
fi
fails=0
python3 tests/png_compare.py same "$tmp/window.xwd" "$tmp/snapshot.png" 1 ||
    { fails=$((fails + 1)); echo "FAIL: what the window shows differs from the offscreen snapshot"; }
python3 tests/png_compare.py same "$tmp/first.png" "$tmp/snapshot.png" 1 ||
    { fails=$((fails + 1)); echo "FAIL: the window's screenshot differs from the offscreen snapshot"; }
python3 tests/png_compare.py darker "$tmp/first.png" "$tmp/no-indirect.png" ||
    { fails=$((fails + 1)); echo "FAIL: the screenshot after '4' (indirect off) is not darker"; }
echo "test_window: window session ok (render, xwd, P, 4, Esc); 3 comparisons, $fails failed"
[ "$fails" -eq 0 ]

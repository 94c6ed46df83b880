#!/bin/sh
# test_window.sh: the real window under Xvfb, driven by xdotool: what it shows (xwd) and what P saves equal the offscreen snapshot, 4 toggles indirect, Esc quits.
#
# pmview runs inside xvfb-run through an inner script (xvfb-run makes its own display, so the
# keys must be sent from inside it). The window's contents as the X server holds them (xwd) and
# its P screenshot must both equal an offscreen --snapshot of the same render within 1 per
# channel; after '4' (indirect off) the next screenshot must be darker.
# xvfb-run and everything under it run in their own session, killed as a group on any exit.
cd "$(dirname "$0")/.." || exit 1

have_tools() { for t in xvfb-run xdotool xwd python3; do command -v $t >/dev/null 2>&1 || return 1; done; }
if ! have_tools; then
    # only when installing cannot stop at a password prompt
    if [ "$(id -u)" = 0 ] || sudo -n true 2>/dev/null; then sh tools/install-deps.sh </dev/null >/dev/null 2>&1; fi
    if ! have_tools; then
        echo "SKIP: xvfb-run, xdotool, xwd or python3 missing and tools/install-deps.sh could not install them"
        exit 0
    fi
fi
[ -x ./pmview ] || { echo "test_window: FAILED: ./pmview is not built"; exit 1; }

tmp=$(mktemp -d) || exit 1
group=""
cleanup() {
    # the group's leader is xvfb-run; Xvfb, the inner script and pmview are its members
    [ -n "$group" ] && kill -TERM -- "-$group" 2>/dev/null
    rm -rf "$tmp"
}
trap cleanup EXIT
trap 'exit 1' INT TERM HUP
. tests/xvfb_inner.sh

args="scenes/cornell-box.gltf --width 96 --height 96 --iterations 4 --seed 7 --threads 2"

cat >"$tmp/inner.sh" <<'EOF'
# runs under xvfb-run: start pmview, wait, send keys; "$1" is the temp folder, the rest pmview's arguments
tmp=$1; shift
log="$tmp/pmview.log"
fail() { echo "inner: $*"; [ -n "$pid" ] && kill "$pid" 2>/dev/null; echo "--- pmview log:"; cat "$log"; exit 1; }
# wait_for PATTERN COUNT SECONDS: until the log has COUNT lines matching PATTERN
# (before pmview has written a line the log may not exist: grep then prints nothing, and a
# bare [ on an empty string would end the wait at once)
count() { c=$(grep -c "$1" "$log" 2>/dev/null); echo "${c:-0}"; }
wait_for() {
    i=0
    while [ "$(count "$1")" -lt "$2" ]; do
        kill -0 "$pid" 2>/dev/null || fail "pmview exited before '$1'"
        i=$((i + 1)); [ "$i" -gt $(($3 * 10)) ] && fail "no '$1' after $3 s"
        sleep 0.1
    done
}
press() {
    xdotool key --clearmodifiers "$1" || fail "xdotool key $1 failed"
}
./pmview "$@" --screenshot "$tmp/shot.png" >"$log" 2>&1 &
pid=$!
wait_for "pmview: iterations done" 1 60
wid=$(timeout 30 xdotool search --sync --name pmview | head -n 1)
[ -n "$wid" ] || fail "no window named pmview"
# no window manager under Xvfb: give the window the keyboard focus directly
xdotool windowfocus --sync "$wid" || fail "cannot focus the window"
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
i=0
while kill -0 "$pid" 2>/dev/null; do
    i=$((i + 1)); [ "$i" -gt 200 ] && fail "pmview still running 20 s after Escape"
    sleep 0.1
done
wait "$pid"; rc=$?
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

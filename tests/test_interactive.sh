#!/bin/sh
# test_interactive.sh: the window as a person uses it, under Xvfb with xdotool: a first frame at once, a drag restarts the accumulation and moves the view, Space pauses, Esc quits in the middle of a long photon pass and in a window made 8192x8192.
#
# Checked from outside the process only: the window title (iterations, "paused"), X's own copy
# of the window (xwd) and how long pmview takes to exit.
cd "$(dirname "$0")/.." || exit 1
. tests/xvfb_inner.sh
need_tools test_interactive xvfb-run xdotool xwd python3
start_temp

cat >"$tmp/inner.sh" <<'EOF'
tmp=$1
log="$tmp/pmview.log"
. tests/window_inner.sh
iterations() { xdotool getwindowname "$wid" 2>/dev/null | sed -n 's/.* \([0-9][0-9]*\) it .*/\1/p'; }
wait_window() {
    i=0; wid=""
    while [ -z "$wid" ]; do
        wid=$(xdotool search --name '^pmview' 2>/dev/null | head -n 1)
        i=$((i + 1)); [ $i -gt 300 ] && fail "no window after 30 s"
        kill -0 "$pid" 2>/dev/null || fail "pmview exited"
        sleep 0.1
    done
}
wait_iterations() { # at least N, within S seconds
    i=0
    while [ "$(iterations)" = "" ] || [ "$(iterations)" -lt "$1" ]; do
        i=$((i + 1)); [ $i -gt $(($2 * 20)) ] && fail "fewer than $1 iterations after $2 s (title: $(xdotool getwindowname "$wid"))"
        sleep 0.05
    done
}

# 1. a first frame at once, not black
./pmview scenes/cornell-box.gltf --width 160 --height 160 --threads 2 --screenshot "$tmp/shot.png" >"$log" 2>&1 &
pid=$!
wait_window
t0=$(now_ms)
sleep 0.3
xwd -id "$wid" -silent >"$tmp/first.xwd" || fail "xwd"
python3 tests/png_compare.py lit "$tmp/first.xwd" || fail "the first frame is black"
echo "inner: first frame lit 0.3 s after the window appeared"
xdotool windowfocus --sync "$wid" || fail "focus"

# 2. a drag restarts the accumulation (the title's count drops) and moves the view
wait_iterations 6 60
before=$(iterations)
xwd -id "$wid" -silent >"$tmp/before.xwd"
# a person's drag: press, move, release, each its own event
xdotool mousemove --window "$wid" 60 80 && xdotool mousedown 1 && sleep 0.05 &&
    xdotool mousemove --window "$wid" 100 80 && sleep 0.05 && xdotool mouseup 1 || fail "drag"
sleep 0.25
after=$(iterations)
[ -n "$after" ] && [ "$after" -lt "$before" ] || fail "the drag did not restart: $before iterations before, '$after' after"
echo "inner: drag restarted the accumulation ($before iterations -> $after)"
wait_iterations 2 30
xwd -id "$wid" -silent >"$tmp/after.xwd"
python3 tests/png_compare.py differ "$tmp/before.xwd" "$tmp/after.xwd" || fail "the drag did not change the view"

# 3. a resize renders at the new size
xdotool windowsize "$wid" 200 120 || fail "windowsize"
i=0; while ! grep -q "rendering at 200x120" "$log"; do i=$((i + 1)); [ $i -gt 100 ] && fail "no re-render at 200x120"; sleep 0.05; done
wait_iterations 2 30
xwd -id "$wid" -silent >"$tmp/resized.xwd"
python3 tests/png_compare.py lit "$tmp/resized.xwd" || fail "black after the resize"
echo "inner: resized to 200x120 and rendering at that size"

# 4. Space pauses: the count stops, the title says so
xdotool key --clearmodifiers space
sleep 0.5
p1=$(iterations); sleep 0.6; p2=$(iterations)
xdotool getwindowname "$wid" | grep -q paused || fail "no 'paused' in the title"
[ "$p1" = "$p2" ] || fail "iterations went on while paused ($p1 -> $p2)"
echo "inner: Space paused at $p1 iterations"
xdotool key --clearmodifiers space
sleep 0.5

# 5. V shows the radius and density maps (false colour), a different picture
xwd -id "$wid" -silent >"$tmp/shaded.xwd"
xdotool key --clearmodifiers v
i=0; while ! grep -q "view: photon density" "$log"; do i=$((i + 1)); [ $i -gt 100 ] && fail "V did not switch the view"; sleep 0.05; done
sleep 1.5
xwd -id "$wid" -silent >"$tmp/density.xwd"
python3 tests/png_compare.py differ "$tmp/shaded.xwd" "$tmp/density.xwd" || fail "the density view looks like the shaded one"
echo "inner: V shows the photon density map"
xdotool key --clearmodifiers Escape
i=0; while kill -0 "$pid" 2>/dev/null; do i=$((i + 1)); [ $i -gt 50 ] && fail "still running 5 s after Escape"; sleep 0.1; done
wait "$pid" || fail "exit status $? after Escape"

# 6. Esc in the middle of a long photon pass: answered at once
./pmview scenes/cornell-box.gltf --width 64 --height 64 --photons 40000000 --threads 2 >"$log" 2>&1 &
pid=$!
wait_window
xdotool windowfocus --sync "$wid" || fail "focus"
sleep 1
t0=$(now_ms)
xdotool key --clearmodifiers Escape
i=0; while kill -0 "$pid" 2>/dev/null; do i=$((i + 1)); [ $i -gt 100 ] && fail "still running 10 s after Escape"; sleep 0.02; done
wait "$pid" || fail "exit status $? after Escape"
t1=$(now_ms)
echo "inner: Esc during a 40-million-photon pass: exited after $((t1 - t0)) ms"
[ $((t1 - t0)) -lt 1000 ] || fail "Esc took $((t1 - t0)) ms during a photon pass"

# 7. a window made 8192x8192 on this 1024x768 screen: it renders what the screen can show (the
# shape kept), the title goes on, and Esc is answered at once (it once took 10 s of uploading and
# scaling 67 million pixels in a software OpenGL while the title froze)
./pmview scenes/cornell-box.gltf --width 160 --height 160 --threads 2 >"$log" 2>&1 &
pid=$!
wait_window
wait_iterations 2 30
xdotool windowsize "$wid" 8192 8192 || fail "windowsize 8192"
i=0; while ! grep -q "rendering at 768x768" "$log"; do i=$((i + 1)); [ $i -gt 100 ] && fail "no re-render at 768x768 (the screen's height)"; sleep 0.05; done
sleep 2
wait_iterations 1 30
xdotool windowfocus --sync "$wid" || fail "focus"
t0=$(now_ms)
xdotool key --clearmodifiers Escape
i=0; while kill -0 "$pid" 2>/dev/null; do i=$((i + 1)); [ $i -gt 500 ] && fail "still running 10 s after Escape"; sleep 0.02; done
wait "$pid" || fail "exit status $? after Escape"
t1=$(now_ms)
echo "inner: Esc in a window resized to 8192x8192 (rendering at 768x768): exited after $((t1 - t0)) ms"
[ $((t1 - t0)) -lt 1000 ] || fail "Esc took $((t1 - t0)) ms in an 8192x8192 window"
echo "inner: ok"
EOF

# run_inner ends the test at a failure; a passed session counts its "inner:" lines as checks
run_inner test_interactive 180 "$tmp/inner.sh" "$tmp"
echo "test_interactive: $(grep -c "^inner: " "$tmp/xvfb.log") checks, 0 failed"

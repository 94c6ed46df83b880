#!/bin/sh
# test_window_loading.sh: the window opens before a large scene is loaded, its title shows the set-up's stage, keys answer meanwhile, and Esc during the load ends pmview within 0.2 s with status 0; a scene that fails to load with the window open is one error line and exit 1.
#
# The scene is an 8M-triangle height field from bench/big_scene.py, written at test time: its
# load and BVH build take several seconds here, and Esc ends it long before they are done. pmview prints `stat load` once the file is
# loaded and `stat film` once the session exists (--stats), so the log tells which stage a key
# met. xvfb-run and everything under it run in their own session, killed as a group on any exit.
cd "$(dirname "$0")/.." || exit 1

. tests/xvfb_inner.sh
need_tools test_window_loading xvfb-run xdotool python3
# the first python3 with numpy (tools/install-deps.sh installs Debian's): a user's pyenv may shadow it
py=python3
python3 -c "import numpy" 2>/dev/null || py=/usr/bin/python3
$py -c "import numpy" 2>/dev/null || { echo "SKIP: python3 numpy missing (bench/big_scene.py needs it)"; exit 0; }
start_temp

$py bench/big_scene.py "$tmp/big.glb" 8 >/dev/null || { echo "test_window_loading: FAILED: bench/big_scene.py"; exit 1; }

cat >"$tmp/inner.sh" <<'EOF'
# runs under xvfb-run; "$1" is the temp folder
tmp=$1
log="$tmp/pmview.log"
. tests/window_inner.sh
alive() { kill -0 "$pid" 2>/dev/null; }

./pmview "$tmp/big.glb" --width 320 --height 240 --threads 2 --stats >"$log" 2>&1 &
pid=$!
# the window, titled with the loading stage, while the file is still being read
wid=""; i=0
while [ -z "$wid" ]; do
    alive || fail "pmview exited before its window opened"
    i=$((i + 1)); [ "$i" -gt 200 ] && fail "no window after 10 s"
    wid=$(xdotool search --name '^pmview' 2>/dev/null | head -n 1)
    [ -z "$wid" ] && sleep 0.05
done
title=""; i=0
while ! echo "$title" | grep -q "loading big.glb"; do
    i=$((i + 1)); [ "$i" -gt 100 ] && fail "the title never showed 'loading big.glb' (last: '$title')"
    title=$(xdotool getwindowname "$wid" 2>/dev/null)
    grep -q "^stat load" "$log" && fail "the file was loaded before the title showed it loading (title '$title')"
    sleep 0.02
done
echo "inner: title while loading: $title"
xdotool windowfocus --sync "$wid" || fail "cannot focus the window"
# a key answers during the set-up: H prints the key help
xdotool key --clearmodifiers h || fail "xdotool key h failed"
i=0
while ! grep -q "^pmview keys:" "$log"; do
    i=$((i + 1)); [ "$i" -gt 100 ] && fail "H printed no help within 2 s"
    sleep 0.02
done
grep -q "^stat film" "$log" && fail "the set-up ended before H was answered: the scene is too small to test this"
# Esc while the scene is still being set up: time from the key to the process's end
t0=$(now_ms)
xdotool key --clearmodifiers Escape || fail "xdotool key Escape failed"
wait "$pid"; rc=$?; t1=$(now_ms)
pid=""
grep -q "^stat film" "$log" && fail "the session was set up before Esc: Esc did not come during the set-up"
[ "$rc" -eq 0 ] || fail "pmview exited with $rc after Escape during the set-up"
grep -q "error" "$log" && fail "an error line after Escape during the set-up"
echo "inner: Escape during the set-up ($(grep -c '^stat load' "$log") of 1 stat load line printed): exit 0 after $((t1 - t0)) ms"
[ $((t1 - t0)) -le 200 ] || fail "pmview took $((t1 - t0)) ms from Escape to its exit (limit 200)"

# a file that cannot be loaded, with the window open: one error line, exit 1
./pmview "$tmp/missing.glb" >"$tmp/missing.log" 2>&1; rc=$?
[ "$rc" -eq 1 ] || { cat "$tmp/missing.log"; fail "a missing scene exited with $rc, not 1"; }
[ "$(wc -l <"$tmp/missing.log")" -eq 1 ] && grep -q "^pmview: error: .*missing.glb" "$tmp/missing.log" ||
    { cat "$tmp/missing.log"; fail "a missing scene did not print one error line"; }
echo "inner: ok"
EOF

run_inner test_window_loading 60 "$tmp/inner.sh" "$tmp"
echo "test_window_loading: ok (window while loading, title, H, Esc during the set-up, a missing scene)"

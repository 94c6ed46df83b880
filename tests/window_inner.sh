# window_inner.sh: sourced by the window tests' inner scripts under xvfb-run: waiting on pmview's log, keys, finding and focusing the window.
#
# The caller sets $log (where pmview, or mpirun, writes) and $pid once it runs.
pid=""
fail() { echo "inner: FAIL: $*"; [ -n "$pid" ] && kill "$pid" 2>/dev/null; echo "--- log:"; cat "$log" 2>/dev/null; exit 1; }
# count PATTERN: lines of the log matching PATTERN (0 before the log exists)
count() { c=$(grep -c "$1" "$log" 2>/dev/null); echo "${c:-0}"; }
# wait_for PATTERN COUNT SECONDS: until the log has COUNT lines matching PATTERN
wait_for() {
    i=0
    while [ "$(count "$1")" -lt "$2" ]; do
        kill -0 "$pid" 2>/dev/null || fail "pmview exited before '$1'"
        i=$((i + 1)); [ "$i" -gt $(($3 * 10)) ] && fail "no '$1' after $3 s"
        sleep 0.1
    done
}
press() { xdotool key --clearmodifiers "$1" || fail "xdotool key $1 failed"; }
now_ms() { date +%s%3N; }
# focus_window NAME_PATTERN: waits up to 30 s for the window and gives it the keyboard focus
# (no window manager under Xvfb does); sets $wid
focus_window() {
    wid=$(timeout 30 xdotool search --sync --name "$1" | head -n 1)
    [ -n "$wid" ] || fail "no window named '$1' after 30 s"
    xdotool windowfocus --sync "$wid" || fail "cannot focus the window"
}
# wait_exit SECONDS: the process ends within SECONDS (after Esc); sets $rc to its status
wait_exit() {
    i=0
    while kill -0 "$pid" 2>/dev/null; do
        i=$((i + 1)); [ "$i" -gt $(($1 * 10)) ] && { xdotool keyup Escape; fail "still running $1 s after Escape"; }
        sleep 0.1
    done
    xdotool keyup Escape
    wait "$pid"; rc=$?
}

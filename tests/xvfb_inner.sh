# xvfb_inner.sh: sourced by the window tests: their tools, their temporary folder, and their inner script run under xvfb-run in a process group of its own, bounded in time.
#
# need_tools NAME TOOL...: installs what is missing when that cannot stop at a password prompt;
# when a tool is still missing, says SKIP and ends the test (status 0, counted as skipped).
need_tools() {
    name=$1; shift
    if ! have_all "$@"; then
        if [ "$(id -u)" = 0 ] || sudo -n true 2>/dev/null; then sh tools/install-deps.sh </dev/null >/dev/null 2>&1; fi
        have_all "$@" || { echo "SKIP: $name needs $*, and tools/install-deps.sh could not install them"; exit 0; }
    fi
    [ -x ./pmview ] || { echo "$name: FAILED: ./pmview is not built"; exit 1; }
}
have_all() { for t in "$@"; do command -v "$t" >/dev/null 2>&1 || return 1; done; }

# start_temp: a temporary folder in $tmp; on any exit the xvfb-run group is killed, the caller's
# cleanup_more run (when it defines one) and the folder removed
start_temp() {
    tmp=$(mktemp -d) || exit 1
    group=""
    trap end_temp EXIT
    trap 'exit 1' INT TERM HUP
}
end_temp() {
    # the group's leader is xvfb-run; Xvfb, the inner script and pmview (or mpirun) are its members
    [ -n "$group" ] && kill -TERM "-$group" 2>/dev/null
    if command -v cleanup_more >/dev/null 2>&1; then cleanup_more; fi
    rm -rf "$tmp"
}
#
# run_inner NAME LIMIT_SECONDS SCRIPT ARGS...: xvfb-run makes its own display, so the keys must be
# sent from a script inside it; the script ends by printing "inner: ok". Prints its output; exits
# the test (1) when it ran over LIMIT_SECONDS or did not say ok. Sets and clears `group` (the
# process group the caller's cleanup kills) and uses "$tmp".
#
# xvfb-run -a takes the first display number without a lock file in /tmp, but a lock file is not
# the whole story: an X server in another container that shares the network namespace holds the
# abstract socket of that number unseen, and the client reaches it first and is refused. So the
# display is proved (xdotool asks it its size) before the script starts, and an unusable one is
# given up for another, starting from a number few others use. -noreset: by default an X server
# resets when its last client leaves, and a client connecting meanwhile is refused (the check's own
# connection, or one pmview's exit before the next one starts).
run_inner() {
    name=$1; limit=$2; shift 2
    attempt=1
    while :; do
        start_display=$(( 200 + ($$ * 7 + attempt * 101) % 700 ))
        xvfb_session "$start_display" "$@"
        grep -q "^inner: no display" "$tmp/xvfb.log" || break
        [ "$attempt" -lt 3 ] || break
        attempt=$((attempt + 1))
    done
    cat "$tmp/xvfb.log"
    if [ "$rc" -ne 0 ] || ! grep -q "^inner: ok" "$tmp/xvfb.log"; then
        echo "$name: FAILED: the window session failed (exit $rc)"
        exit 1
    fi
}
# xvfb_session FIRST_DISPLAY SCRIPT ARGS...: one xvfb-run session, bounded by $limit; sets rc
xvfb_session() {
    first=$1; shift
    # the new session keeps the caller's priority: where the kernel groups processes by session for
    # scheduling (autogroup), its group gets the caller's nice value (run_tests.sh runs some tests
    # at nice 19 beside the ones that time what a person would see)
    setsid sh -c 'echo "$(nice)" >/proc/self/autogroup 2>/dev/null; first=$1; shift
        exec xvfb-run -a -n "$first" -s "-screen 0 1024x768x24 -noreset" sh -c "
            xdotool getdisplaygeometry >/dev/null 2>&1 || { echo \"inner: no display (\$DISPLAY refused us)\"; exit 1; }
            exec sh \"\$@\"" inner "$@"' \
        run_inner "$first" "$@" >"$tmp/xvfb.log" 2>&1 &
    xpid=$!
    # setsid made xvfb-run a session (and group) leader; never take our own group by mistake
    g=$(ps -o pgid= -p "$xpid" 2>/dev/null | tr -d ' ')
    [ -n "$g" ] && [ "$g" != "$(ps -o pgid= -p $$ | tr -d ' ')" ] && group=$g
    # the inner script bounds each of its waits; this bounds the whole in case Xvfb itself hangs
    i=0
    while kill -0 "$xpid" 2>/dev/null; do
        i=$((i + 1))
        if [ "$i" -gt $((limit * 10)) ]; then
            echo "$name: FAILED: xvfb-run still running after $limit s"; cat "$tmp/xvfb.log"; exit 1
        fi
        sleep 0.1
    done
    wait "$xpid"; rc=$?
    group=""
}

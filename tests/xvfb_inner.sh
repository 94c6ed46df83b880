# xvfb_inner.sh: sourced by the window tests: runs their inner script under xvfb-run, in a process group of its own that their cleanup kills, bounded in time.
#
# run_inner NAME LIMIT_SECONDS SCRIPT ARGS...: xvfb-run makes its own display, so the keys must be
# sent from a script inside it; the script ends by printing "inner: ok". Prints its output; exits
# the test (1) when it ran over LIMIT_SECONDS or did not say ok. Sets and clears `group` (the
# process group the caller's cleanup kills) and uses "$tmp".
run_inner() {
    name=$1; limit=$2; shift 2
    setsid xvfb-run -a -s "-screen 0 1024x768x24" sh "$@" >"$tmp/xvfb.log" 2>&1 &
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
    cat "$tmp/xvfb.log"
    if [ "$rc" -ne 0 ] || ! grep -q "^inner: ok" "$tmp/xvfb.log"; then
        echo "$name: FAILED: the window session failed (exit $rc)"
        exit 1
    fi
    group=""
}

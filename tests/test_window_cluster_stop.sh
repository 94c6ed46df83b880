#!/bin/sh
# test_window_cluster_stop.sh: the window under mpirun with 2 ranks, rank 1 stopped (SIGSTOP) while the image converges: Esc, and in a second job a resize, each end the job within PM_CLUSTER_QUIT_SECONDS (5 s) and a few more, with one line naming rank 1, and no process left.
#
# A stopped rank answers nothing: Esc and a resize each wait for the merge under way to end, and
# Esc also for every rank's word that it quit (then MPI_Finalize waits for every rank). Every process of the job carries PMVIEW_TEST_JOB,
# so finding rank 1 and the check that none is left touch no other pmview.
cd "$(dirname "$0")/.." || exit 1

have_tools() { for t in xvfb-run xdotool mpirun; do command -v $t >/dev/null 2>&1 || return 1; done; }
if ! have_tools; then
    # only when installing cannot stop at a password prompt
    if [ "$(id -u)" = 0 ] || sudo -n true 2>/dev/null; then sh tools/install-deps.sh </dev/null >/dev/null 2>&1; fi
    if ! have_tools; then
        echo "SKIP: xvfb-run, xdotool or mpirun missing and tools/install-deps.sh could not install them"
        exit 0
    fi
fi
[ -x ./pmview ] || { echo "test_window_cluster_stop: FAILED: ./pmview is not built"; exit 1; }

export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export PMVIEW_TEST_JOB="test_window_cluster_stop.$$"
tmp=$(mktemp -d) || exit 1
group=""
. tests/job_processes.sh
cleanup() {
    [ -n "$group" ] && kill -TERM "-$group" 2>/dev/null
    for p in $(job_processes any); do kill -KILL "$p" 2>/dev/null; done
    rm -rf "$tmp"
}
trap cleanup EXIT
trap 'exit 1' INT TERM HUP
. tests/xvfb_inner.sh

cat >"$tmp/inner.sh" <<'EOF'
# runs under xvfb-run: twice, start the 2-rank job, wait for the merged image, stop rank 1, then Esc
# or a resize; "$1" is the temp folder
tmp=$1
. tests/job_processes.sh
log="$tmp/pmview.log"
fail() { echo "inner: $*"; [ -n "$rank1" ] && kill -CONT "$rank1" 2>/dev/null; [ -n "$pid" ] && kill "$pid" 2>/dev/null; echo "--- mpirun's log:"; cat "$log"; exit 1; }
# stopped_case WHAT: WHAT (Esc or resize) with rank 1 stopped ends the job within 10 s, exit
# non-zero, with one line naming rank 1 as silent within 5 s of the quit or the resize, and no
# process left
stopped_case() {
    what=$1; rank1=""
    mpirun --oversubscribe -np 2 ./pmview scenes/cornell-box.gltf --width 96 --threads 1 </dev/null >"$log" 2>&1 &
    pid=$!
    wid=$(timeout 30 xdotool search --sync --name '^pmview \(2 ranks\)' | head -n 1)
    [ -n "$wid" ] || fail "no window named 'pmview (2 ranks)' after 30 s"
    # the merged image shows ("2 ranks  N it" in the title): both ranks answer merges
    i=0
    until xdotool getwindowname "$wid" 2>/dev/null | grep -q ' 2 ranks  [0-9]* it '; do
        kill -0 "$pid" 2>/dev/null || fail "mpirun exited before a merged image showed"
        i=$((i + 1)); [ "$i" -gt 300 ] && fail "no merged image in 30 s"
        sleep 0.1
    done
    rank1=$(job_processes 1)
    [ -n "$rank1" ] || fail "no rank 1 found"
    kill -STOP "$rank1"
    sleep 0.5  # a merge is asked of the stopped rank meanwhile (one every PM_CLUSTER_MERGE_SECONDS, 0.25 s)
    if [ "$what" = Esc ]; then
        xdotool windowfocus --sync "$wid" || fail "cannot focus the window"
        xdotool key --clearmodifiers Escape || fail "xdotool key Escape failed"
        event=quit
    else
        # a new size ends the merge under way first (it is of the old size)
        xdotool windowsize "$wid" 120 96 || fail "xdotool windowsize failed"
        event=resize
    fi
    i=0
    while kill -0 "$pid" 2>/dev/null; do
        i=$((i + 1))
        if [ "$i" -gt 150 ]; then
            [ "$what" = Esc ] && xdotool keyup Escape
            fail "mpirun still running 15 s after the $event with rank 1 stopped"
        fi
        sleep 0.1
    done
    [ "$what" = Esc ] && xdotool keyup Escape
    wait "$pid"; rc=$?
    kill -CONT "$rank1" 2>/dev/null
    echo "inner: $what: mpirun ended $((i / 10)).$((i % 10)) s after it, exit $rc, $(grep '^pmview: error' "$log" | head -n 1)"
    [ "$i" -le 100 ] || fail "mpirun ended $((i / 10)).$((i % 10)) s after the $event, want within 10 s (5 s of patience)"
    [ "$rc" -ne 0 ] || fail "mpirun exited 0 although rank 1 never answered the $event"
    [ "$(grep -c "^pmview: error: rank 1 gave no .* within 5 s of the $event (stopped or hung)" "$log")" -eq 1 ] ||
        fail "not one line naming rank 1 as silent at the $event"
    # every process gone within a second of the job's end (looked for every 0.1 s, not waited for)
    i=0
    while left=$(job_processes any) && [ -n "$left" ] && [ "$i" -lt 10 ]; do sleep 0.1; i=$((i + 1)); done
    [ -z "$left" ] || fail "pmview processes left after the $event: $left"
}
stopped_case Esc
stopped_case resize
echo "inner: ok"
EOF

start=$(date +%s)
run_inner test_window_cluster_stop 150 "$tmp/inner.sh" "$tmp"
# every process gone within a second of the job's end (looked for every 0.1 s, not waited for)
i=0
while left=$(job_processes any) && [ -n "$left" ] && [ "$i" -lt 10 ]; do sleep 0.1; i=$((i + 1)); done
if [ -n "$left" ]; then
    echo "test_window_cluster_stop: FAILED: pmview processes left: $left"
    exit 1
fi
echo "test_window_cluster_stop: rank 1 stopped, Esc and a resize each ended the job naming it ($(($(date +%s) - start)) s)"

#!/bin/sh
# run_tests.sh: runs every test program (ASan/UBSan build) and the script tests, JOBS at a time; prints a line per test and the summary line.
#
# PMVIEW_CHECK=1 (make check): the OPTIMISED tests run under ASan/UBSan too, the threaded tests
# run again under TSan, and the valgrind test is added.
# JOBS (default 2): how many tests run side by side. First the tests that bound their own wall time
# (TIMED below) run JOBS at a time. Then the tests that time what a person would see (windows,
# signals, cluster ranks: ALONE below) run one at a time while the rest run JOBS at a time beside
# them at the lowest priority (nice 19, in a scheduling group of their own), so they take only the
# processor time the ALONE test leaves idle. Last, the QUIET tests (windows, signals during a large
# write) run one at a time, with only BESIDE_QUIET's tests beside them at the lowest priority.
# Each test's output is kept in build/test-logs/NAME.log, its result in build/test-logs/NAME.result.
# With names (run_tests.sh test_film_sums test_cancel), only those tests run.
cd "$(dirname "$0")/.." || exit 1
logs=build/test-logs

# `run_tests.sh --one NAME COMMAND...`: runs one test, records its result and prints its line
if [ "$1" = --one ]; then
    name=$2; shift 2
    log="$logs/$name.log"
    start=$(date +%s)
    # the processor time it took, which a loaded machine does not stretch as it does the wall time
    timer=""
    [ -x /usr/bin/time ] && timer="/usr/bin/time -o $logs/$name.cpu -f %U+%S"
    if $timer "$@" >"$log" 2>&1; then
        # a test that could not run says so on its last line: it is a skip, never a pass
        if tail -n 1 "$log" | grep -qi "skip"; then status=SKIPPED; else status=ok; fi
    else
        status=FAILED
    fi
    secs=$(( $(date +%s) - start ))
    cpu=$(cat "$logs/$name.cpu" 2>/dev/null | tail -n 1 | awk -F+ '{ printf "%d", $1 + $2 + 0.5 }')
    echo "$status $secs ${cpu:-0}" >"$logs/$name.result"
    # one write per test, so lines of tests running side by side do not interleave
    out=$(printf '%-28s %-7s %3ss %4ss cpu  %s' "$name" "$status" "$secs" "${cpu:-?}" "$(tail -n 1 "$log")")
    [ "$status" = FAILED ] && out="$out
$(sed 's/^/    | /' "$log" | tail -n 30)"
    printf '%s\n' "$out"
    exit 0
fi

rm -rf "$logs"; mkdir -p "$logs"
began=$(date +%s)
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=0
export LSAN_OPTIONS=suppressions=$(pwd)/tests/lsan.supp:print_suppressions=0
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
# make check sets PMVIEW_CHECK=1: the OPTIMISED tests below run under ASan/UBSan too
check=${PMVIEW_CHECK:-0}
jobs=${JOBS:-2}
# the tests that render on several threads, run again under TSan by make check
TSAN_TESTS="test_threads test_texture_threads"
export PMVIEW_CORPUS="${PMVIEW_CORPUS:-../shared/gltf-corpus}"
# The scripts' python3 is Debian's, which tools/install-deps.sh installs with numpy: a version
# manager's shim ahead of it in PATH (pyenv's) takes 0.1 s of processor time a start against 0.02 s,
# and the tests start python3 some 180 times.
if [ -x /usr/bin/python3 ]; then
    mkdir -p build/python && ln -sf /usr/bin/python3 build/python/python3 && PATH="$(pwd)/build/python:$PATH" && export PATH
fi
# Convergence tests run hundreds of iterations, test_progressive_long 10^4 iterations and a search of
# up to 40 runs, test_photons millions of photons, test_pathtrace
# hundreds of paths per pixel, test_hard_energy an albedo-0.99 furnace of 100-bounce photon paths,
# test_glossy, test_reference and test_splats long renders against Mitsuba, test_leaks three scenes
# in up to three modes: they run optimised (processor time: test_photons 45 s against 136 s,
# test_glossy 15 s against 31 s, test_leaks 17 s against 34 s, test_splats 8 s against 16 s,
# test_reference 8 s against 13 s); the code they drive runs under ASan/UBSan in test_progressive,
# test_volume, test_brdf, test_layers, the classic runs of test_cli and the path-traced runs of
# test_log (build/asan/pmview), and (make check) under TSan in test_threads.
OPTIMISED="test_convergence test_progressive_long test_photons test_pathtrace test_hard_energy test_mirror_box test_glossy test_leaks test_reference test_splats"
# Tests that measure what a person would see in seconds (a window's first frame, an answer to a key
# or a signal, ranks exchanging iterations) or render for a set time (--time): another test beside
# them could push them past their bounds. (test_window_room renders a set number of iterations and
# checks only what they converge to, so it runs beside the others.)
ALONE="test_cluster test_hangs test_convergence_report"
# Of those, the ones whose timing a test at the lowest priority beside them still upsets (a window
# server's session, a 100 MB write within mpirun's 1 s while other tests write their files: each
# failed once so) run last, one at a time, with nothing beside them but BESIDE_QUIET's tests, which
# write no files and take only the processor time left idle.
QUIET="test_window test_window_cluster test_window_cluster_stop test_signal_writes test_window_loading test_interactive"
# Tests that only compute (no file written, no clock read, no window, no process of their own
# beyond their threads), kept for last: JOBS at a time at the lowest priority beside the QUIET
# tests, in one scheduling group of nice 19 (whose weight is the group's, however many run in it),
# they take the processor those leave idle (the QUIET tests keep about one of two busy); run one
# at a time, the second would wait for the first and end after the QUIET tests.
BESIDE_QUIET="test_convergence test_photons test_glossy test_progressive_long"
# Tests that bound their own wall time (a refusal within 1-10 s, a timeout of 20 s, a reload within
# 2 s, a SIGINT 1.5 s after the start, a deadline of a share of a measured pass): at the lowest
# priority an ALONE test using both cores could hold them past those bounds, so they run first, JOBS
# at a time, at the usual priority. Every other test has no clock in its checks (at most a
# generous guard against a hang) and runs beside the ALONE tests.
TIMED="test_cli test_hostile_sky test_memory test_robust test_window_reload test_window_variants test_real_models test_gpu_instancing test_compressed test_threads test_fuzz_regressions test_cut test_session_errors"
# The longest tests start first (by their processor time), so the last one to end is a short one.
FIRST="test_convergence test_progressive_long test_progressive test_window_room test_leaks test_glossy test_photons test_memory test_window_default test_splats test_reference test_accel test_cli test_guide test_mirror_box test_robust test_memory_failures test_brdf test_kdtree test_threads test_log"

list=$(mktemp) || exit 1
alone=$(mktemp) || exit 1
timed=$(mktemp) || exit 1
quiet=$(mktemp) || exit 1
beside=$(mktemp) || exit 1
background=""
trap 'rm -f "$list" "$alone" "$timed" "$quiet" "$beside"; [ -n "$background" ] && kill -TERM "-$background" 2>/dev/null' EXIT
trap 'exit 1' INT TERM HUP
add() { # name command...: queue a test in its list: run alone, timed, or the rest
    base=${1%%\[*}
    case " $QUIET " in *" $base "*) echo "$*" >>"$quiet"; return ;; esac
    case " $ALONE " in *" $base "*) echo "$*" >>"$alone"; return ;; esac
    case " $TIMED " in *" $base "*) echo "$*" >>"$timed"; return ;; esac
    case " $BESIDE_QUIET " in *" $base "*) echo "$*" >>"$beside"; return ;; esac
    echo "$*" >>"$list"
}
entries=$(mktemp) || exit 1
# every test program, from its source: make test builds the OPTIMISED ones only optimised
for src in tests/test_*.c; do
    name=$(basename "$src" .c)
    if [ "$check" = 0 ] && case " $OPTIMISED " in *" $name "*) true ;; *) false ;; esac; then
        [ -x "build/rel/tests/$name" ] && echo "$name[optimised] build/rel/tests/$name"
    else
        [ -x "build/asan/tests/$name" ] && echo "$name build/asan/tests/$name"
    fi
done >"$entries"
for t in $TSAN_TESTS; do
    [ "$check" = 1 ] && [ -x "build/tsan/tests/$t" ] && echo "$t[tsan] env TSAN_OPTIONS=halt_on_error=1 build/tsan/tests/$t"
done >>"$entries"
for s in tests/test_*.sh; do
    [ -f "$s" ] && echo "$(basename "$s" .sh) sh $s"
done >>"$entries"
if [ "$check" = 1 ]; then
    for s in tests/check_*.sh; do
        [ -f "$s" ] && echo "$(basename "$s" .sh) sh $s"
    done >>"$entries"
fi
# `run_tests.sh NAME...`: only those tests (any of their runs: test_threads is also test_threads[tsan])
if [ $# -gt 0 ]; then
    only=$(mktemp) || exit 1
    for n in "$@"; do grep "^$n[[ ]" "$entries"; done >"$only"
    mv "$only" "$entries"
fi
for f in $FIRST; do
    grep "^$f[[ ]" "$entries" | while read -r line; do add $line; done
done
grep -v -E "^($(echo $FIRST | tr ' ' '|'))[[ ]" "$entries" | while read -r line; do add $line; done
rm -f "$entries"

xargs -r -P "$jobs" -L 1 sh tests/run_tests.sh --one <"$timed"
# The rest at the lowest priority beside the ALONE tests. setsid gives them a process group (killed
# on an early exit) and, where the kernel groups processes by session for scheduling (autogroup),
# a group of their own, whose weight is set to nice 19 as well: otherwise an ALONE test in another
# session (xvfb-run's) would get only half the processors against them. The window tests among them
# carry their nice value into their own sessions (tests/xvfb_inner.sh).
setsid -w sh -c 'echo 19 >/proc/self/autogroup 2>/dev/null; exec nice -n 19 xargs -r -P "$1" -L 1 sh tests/run_tests.sh --one' \
    background "$jobs" <"$list" &
background=$!
xargs -r -P 1 -L 1 sh tests/run_tests.sh --one <"$alone"
# the ALONE tests are over: the rest's group gets the usual weight again, which a loaded machine
# shared with other work needs (a lowered value needs no privilege as long as it is not negative;
# the kernel takes one change a tenth of a second). With no ALONE test to run this comes at once,
# so it waits first for the rest's own change to nice 19 (at most 5 s), which would otherwise undo it.
i=0
while [ -r "/proc/$background/autogroup" ] && ! grep -q "nice 19" "/proc/$background/autogroup" 2>/dev/null && [ "$i" -lt 50 ]; do
    i=$((i + 1)); sleep 0.1
done
i=0
while [ -w "/proc/$background/autogroup" ] && ! echo 0 >"/proc/$background/autogroup" 2>/dev/null && [ "$i" -lt 20 ]; do
    i=$((i + 1)); sleep 0.1
done
wait "$background"
background=""
setsid -w sh -c 'echo 19 >/proc/self/autogroup 2>/dev/null; exec nice -n 19 xargs -r -P "$1" -L 1 sh tests/run_tests.sh --one' \
    beside "$jobs" <"$beside" &
background=$!
xargs -r -P 1 -L 1 sh tests/run_tests.sh --one <"$quiet"
wait "$background"
background=""

passed=0; failed=0; skipped=0; failed_names=""; total=0; total_cpu=0
for r in "$logs"/*.result; do
    [ -f "$r" ] || continue
    name=$(basename "$r" .result)
    read -r status secs cpu <"$r"
    total=$((total + secs)); total_cpu=$((total_cpu + ${cpu:-0}))
    case $status in
        ok) passed=$((passed + 1)) ;;
        SKIPPED) skipped=$((skipped + 1)) ;;
        *) failed=$((failed + 1)); failed_names="$failed_names $name" ;;
    esac
done
queued=$(cat "$list" "$alone" "$timed" "$quiet" "$beside" | wc -l)
missing=$((queued - passed - failed - skipped))
[ "$missing" -gt 0 ] && { failed=$((failed + missing)); failed_names="$failed_names (${missing} left no result)"; }
echo "tests ran in $(( $(date +%s) - began )) s, $jobs at a time; their own times add up to $total s, their processor times to $total_cpu s"
[ -n "$failed_names" ] && echo "failed:$failed_names"
echo "$passed passed, $failed failed, $skipped skipped"
[ "$failed" -eq 0 ]

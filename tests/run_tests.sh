#!/bin/sh
# run_tests.sh: runs every test program (ASan/UBSan build), the threaded tests under TSan and the script tests; prints the summary line.
#
# PMVIEW_CHECK=1 (make check): the OPTIMISED tests run under ASan/UBSan too, and the valgrind test is added.
cd "$(dirname "$0")/.." || exit 1
passed=0; failed=0; skipped=0; failed_names=""
run() { # name command...
    name=$1; shift
    log="build/test-logs/$name.log"
    mkdir -p build/test-logs
    start=$(date +%s)
    if "$@" >"$log" 2>&1; then
        # a test that could not run says so on its last line: it is a skip, never a pass
        if tail -n 1 "$log" | grep -qi "skip"; then
            skipped=$((skipped + 1)); status=SKIPPED
        else
            passed=$((passed + 1)); status=ok
        fi
    else
        failed=$((failed + 1)); status=FAILED; failed_names="$failed_names $name"
    fi
    printf '%-28s %-6s %3ss  %s\n' "$name" "$status" "$(( $(date +%s) - start ))" "$(tail -n 1 "$log")"
    [ "$status" = FAILED ] && sed 's/^/    | /' "$log" | tail -n 30
}
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=0
export LSAN_OPTIONS=suppressions=$(pwd)/tests/lsan.supp:print_suppressions=0
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
# make check sets PMVIEW_CHECK=1: the OPTIMISED tests below run under ASan/UBSan too
check=${PMVIEW_CHECK:-0}
# the tests that render on several threads, run again under TSan
TSAN_TESTS="test_threads test_texture_threads"
export PMVIEW_CORPUS="${PMVIEW_CORPUS:-../shared/gltf-corpus}"
# Convergence tests run hundreds of iterations, test_photons millions of photons, test_pathtrace
# hundreds of paths per pixel, test_hard_energy an albedo-0.99 furnace of 100-bounce photon paths:
# they run optimised (test_photons 45 s against 136 s); the code they drive runs under ASan/UBSan
# in test_progressive, test_glossy, test_volume, the classic runs of test_cli and the path-traced
# runs of test_log (build/asan/pmview), and under TSan in test_threads.
OPTIMISED="test_convergence test_photons test_pathtrace test_hard_energy test_mirror_box"
for t in build/asan/tests/test_*; do
    name=$(basename "$t")
    [ "$check" = 0 ] && case " $OPTIMISED " in *" $name "*) run "$name[optimised]" "build/rel/tests/$name"; continue ;; esac
    run "$name" "$t"
done
for t in $TSAN_TESTS; do
    [ -x "build/tsan/tests/$t" ] && run "$t[tsan]" env TSAN_OPTIONS=halt_on_error=1 "build/tsan/tests/$t"
done
for s in tests/test_*.sh; do
    [ -f "$s" ] && run "$(basename "$s" .sh)" sh "$s"
done
if [ "$check" = 1 ]; then
    for s in tests/check_*.sh; do
        [ -f "$s" ] && run "$(basename "$s" .sh)" sh "$s"
    done
fi
[ -n "$failed_names" ] && echo "failed:$failed_names"
echo "$passed passed, $failed failed, $skipped skipped"
[ "$failed" -eq 0 ]

#!/bin/sh
# run-fuzz.sh: runs build/fuzz/fuzz_gltf for SECONDS (make fuzz), seeded from ../shared and scenes/, and files every crash, hang or out-of-memory input under tests/fuzz/regressions/.
#
#   sh tools/run-fuzz.sh [SECONDS]     (default 600; FUZZ_NICE=19 runs it niced)
#
# libFuzzer stops at its first finding; the loop saves it and starts again on the grown corpus
# until the time is used (libFuzzer's fork mode does the same but re-reads the corpus every few
# seconds, at under one execution per second here). The working corpus (build/fuzz/corpus) is
# kept between runs; the seeds are rebuilt every time (external buffers and images embedded).
cd "$(dirname "$0")/.." || exit 1
seconds=${1:-600}
fuzzer=build/fuzz/fuzz_gltf
[ -x "$fuzzer" ] || { echo "run-fuzz: $fuzzer is missing (make fuzz builds it)"; exit 1; }
mkdir -p build/fuzz/corpus build/fuzz/artifacts tests/fuzz/regressions
# a rebuild during the run must not change the binary under it
running=build/fuzz/fuzz_gltf.running.$$
cp "$fuzzer" "$running" || exit 1
rm -rf build/fuzz/seeds
python3 tools/fuzz_seeds.py build/fuzz/seeds ../shared/gltf-corpus ../shared/real-models scenes || exit 1
export ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1
export LSAN_OPTIONS=suppressions=$(pwd)/tests/lsan.supp:print_suppressions=0
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
log=build/fuzz/fuzz.log
: >"$log"
echo "run-fuzz: $seconds s, log in $log"
end=$(( $(date +%s) + seconds ))
segments=0
while [ "$(date +%s)" -lt "$end" ] && [ "$segments" -lt 100 ]; do
    segments=$((segments + 1))
    left=$(( end - $(date +%s) ))
    echo "run-fuzz: segment $segments, $left s left" >>"$log"
    # -timeout: 30 s for one input on an 8x8 image with 256 photons is a run-away;
    # -rss_limit_mb / -malloc_limit_mb: 2 GiB in one allocation or in the process is an out-of-memory finding;
    # -max_len: larger inputs (embedded images) cost seconds each and teach the mutator little
    nice -n "${FUZZ_NICE:-0}" "$running" build/fuzz/corpus build/fuzz/seeds tests/fuzz/regressions \
        -dict=tests/fuzz/gltf.dict -max_total_time="$left" -timeout=30 -rss_limit_mb=2048 -malloc_limit_mb=2048 \
        -max_len=163840 -artifact_prefix=build/fuzz/artifacts/ -print_final_stats=1 >>"$log" 2>&1 && break
done
rm -f "$running"
executions=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | awk '{s += $1} END {print s + 0}')
echo "run-fuzz: $segments segment(s), $executions executions; last coverage line:"
grep -E '^#[0-9]+' "$log" | grep 'cov:' | tail -n 1
found=0
for f in build/fuzz/artifacts/crash-* build/fuzz/artifacts/timeout-* build/fuzz/artifacts/oom-* build/fuzz/artifacts/leak-*; do
    [ -f "$f" ] || continue
    dest="tests/fuzz/regressions/$(basename "$f")"
    [ -f "$dest" ] && continue
    cp "$f" "$dest"
    echo "run-fuzz: new finding filed as $dest"
    found=$((found + 1))
done
echo "run-fuzz: $found new finding(s) filed in tests/fuzz/regressions/ (slow inputs, not findings: build/fuzz/artifacts/slow-unit-*)"
[ "$found" -eq 0 ]

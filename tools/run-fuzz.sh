#!/bin/sh
# run-fuzz.sh: runs build/fuzz/fuzz_gltf for SECONDS (make fuzz), seeded from ../shared and scenes/, and files every crash, hang or out-of-memory input under tests/fuzz/regressions/.
#
#   sh tools/run-fuzz.sh [SECONDS]     (default 600; FUZZ_NICE=19 runs it niced)
#
# libFuzzer runs in fork mode with one job, so a crash, timeout or out-of-memory input is saved
# and the run goes on to the end of its time. The working corpus (build/fuzz/corpus) is kept
# between runs; the seeds are rebuilt every time (external buffers and images embedded).
cd "$(dirname "$0")/.." || exit 1
seconds=${1:-600}
fuzzer=build/fuzz/fuzz_gltf
[ -x "$fuzzer" ] || { echo "run-fuzz: $fuzzer is missing (make fuzz builds it)"; exit 1; }
mkdir -p build/fuzz/corpus build/fuzz/artifacts
# fork mode starts the binary again for every job: a copy keeps a rebuild during the run harmless
running=build/fuzz/fuzz_gltf.running.$$
cp "$fuzzer" "$running" || exit 1
rm -rf build/fuzz/seeds
python3 tools/fuzz_seeds.py build/fuzz/seeds ../shared/gltf-corpus ../shared/real-models scenes || exit 1
before=$(ls build/fuzz/artifacts | wc -l)
export ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1
export LSAN_OPTIONS=suppressions=$(pwd)/tests/lsan.supp:print_suppressions=0
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
log=build/fuzz/fuzz.log
echo "run-fuzz: $seconds s, log in $log"
# -timeout: an input that takes 30 s on an 8x8 image with 256 photons has run away;
# -rss_limit_mb / -malloc_limit_mb: a single allocation or a process above 2 GiB is an out-of-memory finding
nice -n "${FUZZ_NICE:-0}" "$running" build/fuzz/corpus build/fuzz/seeds tests/fuzz/regressions \
    -dict=tests/fuzz/gltf.dict -max_total_time="$seconds" -timeout=30 -rss_limit_mb=2048 -malloc_limit_mb=2048 \
    -fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1 -artifact_prefix=build/fuzz/artifacts/ \
    -print_final_stats=1 >"$log" 2>&1
status=$?
rm -f "$running"
grep -E '^#[0-9]+: cov' "$log" | tail -n 1
found=0
for f in build/fuzz/artifacts/*; do
    [ -f "$f" ] || continue
    dest="tests/fuzz/regressions/$(basename "$f")"
    [ -f "$dest" ] && continue
    cp "$f" "$dest"
    echo "run-fuzz: new finding filed as $dest"
    found=$((found + 1))
done
echo "run-fuzz: status $status, $found new finding(s) ($(ls build/fuzz/artifacts | wc -l) artifacts, $before before this run)"
[ "$found" -eq 0 ]

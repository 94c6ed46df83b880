#!/bin/sh
# run-fuzz.sh: runs the fuzz targets for SECONDS each (make fuzz): build/fuzz/fuzz_gltf seeded from ../shared and scenes/, then build/fuzz/fuzz_inputs (sky maps, references, the writers) seeded from small EXR and HDR files, then build/fuzz/fuzz_compressed (the Draco and meshopt decoders) seeded from the ducks' streams; files every crash, hang or out-of-memory input under tests/fuzz/regressions/, regressions-inputs/ or regressions-compressed/.
#
#   sh tools/run-fuzz.sh [SECONDS] [gltf] [inputs] [compressed]   (default 600, every target; FUZZ_NICE=19 runs them niced)
#
# libFuzzer stops at its first finding; the loop saves it and starts again on the grown corpus
# until the time is used (libFuzzer's fork mode does the same but re-reads the corpus every few
# seconds, at under one execution per second here). The working corpora (build/fuzz/corpus,
# build/fuzz/corpus-inputs) are kept between runs; the seeds are rebuilt every time.
cd "$(dirname "$0")/.." || exit 1
seconds=${1:-600}
[ $# -gt 0 ] && shift
targets=${*:-gltf inputs compressed}
export ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1
export LSAN_OPTIONS=suppressions=$(pwd)/tests/lsan.supp:print_suppressions=0
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
found=0

# fuzz NAME: one target for $seconds, its findings filed
fuzz() {
    name=$1
    case $name in
        gltf) fuzzer=build/fuzz/fuzz_gltf; corpus=build/fuzz/corpus; seeds=build/fuzz/seeds
              regressions=tests/fuzz/regressions; dict="-dict=tests/fuzz/gltf.dict"; artifacts=build/fuzz/artifacts ;;
        inputs) fuzzer=build/fuzz/fuzz_inputs; corpus=build/fuzz/corpus-inputs; seeds=build/fuzz/seeds-inputs
              regressions=tests/fuzz/regressions-inputs; dict=""; artifacts=build/fuzz/artifacts-inputs ;;
        compressed) fuzzer=build/fuzz/fuzz_compressed; corpus=build/fuzz/corpus-compressed; seeds=build/fuzz/seeds-compressed
              regressions=tests/fuzz/regressions-compressed; dict=""; artifacts=build/fuzz/artifacts-compressed ;;
        *) echo "run-fuzz: no target $name (gltf, inputs, compressed)"; return 1 ;;
    esac
    [ -x "$fuzzer" ] || { echo "run-fuzz: $fuzzer is missing (make fuzz builds it)"; return 1; }
    mkdir -p "$corpus" "$artifacts" "$regressions"
    # a rebuild during the run must not change the binary under it
    running=$fuzzer.running.$$
    cp "$fuzzer" "$running" || return 1
    rm -rf "$seeds"
    if [ "$name" = gltf ]; then
        python3 tools/fuzz_seeds.py "$seeds" ../shared/gltf-corpus ../shared/real-models scenes tests/models || return 1
    elif [ "$name" = compressed ]; then
        python3 tools/fuzz_seeds.py --compressed "$seeds" tests/models/duck || return 1
    else
        python3 tools/fuzz_seeds.py --inputs "$seeds" tests/ref || return 1
    fi
    log=build/fuzz/fuzz-$name.log
    : >"$log"
    echo "run-fuzz: $name, $seconds s, log in $log"
    end=$(( $(date +%s) + seconds ))
    segments=0
    while [ "$(date +%s)" -lt "$end" ] && [ "$segments" -lt 100 ]; do
        segments=$((segments + 1))
        left=$(( end - $(date +%s) ))
        echo "run-fuzz: segment $segments, $left s left" >>"$log"
        # -timeout: 30 s for one input on an 8x8 image with 256 photons (or one small file) is a run-away;
        # -rss_limit_mb / -malloc_limit_mb: 2 GiB in one allocation or in the process is an out-of-memory finding;
        # -max_len: larger inputs (embedded images) cost seconds each and teach the mutator little
        # shellcheck disable=SC2086
        nice -n "${FUZZ_NICE:-0}" "$running" "$corpus" "$seeds" "$regressions" $dict \
            -max_total_time="$left" -timeout=30 -rss_limit_mb=2048 -malloc_limit_mb=2048 \
            -max_len=163840 -artifact_prefix="$artifacts/" -print_final_stats=1 >>"$log" 2>&1 && break
    done
    rm -f "$running"
    executions=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | awk '{s += $1} END {print s + 0}')
    echo "run-fuzz: $name: $segments segment(s), $executions executions; last coverage line:"
    grep -E '^#[0-9]+' "$log" | grep 'cov:' | tail -n 1
    for f in "$artifacts"/crash-* "$artifacts"/timeout-* "$artifacts"/oom-* "$artifacts"/leak-*; do
        [ -f "$f" ] || continue
        dest="$regressions/$(basename "$f")"
        [ -f "$dest" ] && continue
        cp "$f" "$dest"
        echo "run-fuzz: new finding filed as $dest"
        found=$((found + 1))
    done
}

for t in $targets; do fuzz "$t" || exit 1; done
echo "run-fuzz: $found new finding(s) filed in tests/fuzz/regressions*/ (slow inputs, not findings: build/fuzz/artifacts*/slow-unit-*)"
[ "$found" -eq 0 ]

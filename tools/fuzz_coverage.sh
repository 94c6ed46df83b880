#!/bin/sh
# fuzz_coverage.sh: replays a fuzz corpus once (libFuzzer -runs=0 -print_coverage=1) and prints, per source file of pmview, the edges its inputs reached.
#
#   sh tools/fuzz_coverage.sh [CORPUS_DIR]     (default build/fuzz/corpus)
cd "$(dirname "$0")/.." || exit 1
corpus=${1:-build/fuzz/corpus}
[ -x build/fuzz/fuzz_gltf ] || { echo "fuzz_coverage: build/fuzz/fuzz_gltf is missing (make fuzz builds it)"; exit 1; }
ASAN_OPTIONS=detect_leaks=0:allocator_may_return_null=1 nice -n "${FUZZ_NICE:-0}" build/fuzz/fuzz_gltf -runs=0 -print_coverage=1 \
    -timeout=30 -rss_limit_mb=2048 -malloc_limit_mb=2048 "$corpus" 2>&1 |
    awk '/^(UN)?COVERED_FUNC: .* \/.*\/src\// {
            split($5, e, "/"); file = $NF; sub(/:[0-9]+$/, "", file); sub(/.*\/src\//, "src/", file);
            reached[file] += e[1]; edges[file] += e[2]; funcs[file]++; if ($1 == "COVERED_FUNC:") hit[file]++
         }
         END {
            for (f in edges) { printf "%-24s %4d/%-4d %7d/%-7d %3.0f%%\n", f, hit[f], funcs[f], reached[f], edges[f], 100 * reached[f] / edges[f];
                               R += reached[f]; E += edges[f] }
            if (E) printf "~%-23s %9s %7d/%-7d %3.0f%%\n", "all of src/", "", R, E, 100 * R / E
         }' | sort | sed 's/^~/ /' | { printf '%-24s %9s %15s\n' file functions "edges reached"; cat; }

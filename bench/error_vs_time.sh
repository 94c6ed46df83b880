#!/bin/sh
# error_vs_time.sh: error against time, progressive (alpha 1/2, 2/3, 0.9; gather and photons) and classic, on the shipped scenes (docs/convergence.md holds the current figures).
#
#   sh bench/error_vs_time.sh [SECONDS...]      default: 1 4 16 60
#
# Every point is its own run with --time T, so each method spends its budget as a user's run
# would (the classic mode sizes its photon maps from --time). The Cornell box is measured over
# the whole 64x64 image against tests/ref/cornell_path_64.exr; the caustic scene over the floor
# in the point light's full shadow (bench/caustic_error) against tests/ref/caustic_ptracer_64.exr.
# Prints one line per run: scene method seconds iterations relmse mean_ratio.
cd "$(dirname "$0")/.." || exit 1
times=${*:-1 4 16 60}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
[ -x ./pmview ] && [ -x build/rel/caustic_error ] || { echo "error_vs_time: run 'make pmview build/rel/caustic_error' first" >&2; exit 1; }
methods="progressive-gather-a0.5:--alpha,0.5 progressive-gather-a0.667: progressive-gather-a0.9:--alpha,0.9 progressive-photons-a0.667:--indirect,photons classic:--mode,classic"
printf '%-8s %-28s %8s %10s %10s %10s\n' scene method seconds iterations relmse mean_ratio
for scene in cornell caustic; do
    for m in $methods; do
        name=${m%%:*}; args=$(echo "${m#*:}" | tr ',' ' ')
        for t in $times; do
            if [ $scene = cornell ]; then
                line=$(./pmview scenes/cornell-box.gltf $args --width 64 --height 64 --time "$t" --snapshot "$out/x.exr" \
                       --reference tests/ref/cornell_path_64.exr --stats | grep '^stat error')
                it=$(echo "$line" | sed 's/.*iterations=\([0-9]*\).*/\1/')
                e=$(echo "$line" | sed 's/.*relmse=\([0-9.e-]*\).*/\1/')
                r=$(echo "$line" | sed 's/.*mean_ratio_g=\([0-9.]*\).*/\1/')
            else
                it=$(./pmview scenes/caustic.gltf $args --width 64 --height 64 --time "$t" --snapshot "$out/x.exr" |
                     sed -n 's/.*, \([0-9]*\) iterations.*/\1/p')
                line=$(build/rel/caustic_error "$out/x.exr" tests/ref/caustic_ptracer_64.exr)
                e=$(echo "$line" | sed 's/.*relmse=\([0-9.e-]*\).*/\1/')
                r=$(echo "$line" | sed 's/.* ratio=\([0-9.]*\).*/\1/')
            fi
            printf '%-8s %-28s %8s %10s %10s %10s\n' $scene "$name" "$t" "$it" "$e" "$r"
        done
    done
done

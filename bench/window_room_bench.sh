#!/bin/sh
# window_room_bench.sh: the room lit by sun and sky through a window (scenes/window-room.gltf) at equal time against Mitsuba 3's reference: error, channel means and the share of useful photons before (no clipping, no guiding) and after, as ratios of one run ("bench window_room" lines).
#
# Each configuration renders 64x64 for the same wall time on all cores, one after another; the
# ratio line divides the old configuration's relMSE by each other's (above 1: lower error at
# equal time). BENCH_SECONDS sets the time (default 10).
cd "$(dirname "$0")/.." || exit 1
seconds=${BENCH_SECONDS:-10}
ref=tests/ref/window_room_64.exr
[ -f "$ref" ] || { echo "bench window_room: skipped ($ref missing)"; exit 0; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
field() { sed -n "s/.*$1=\([^ ]*\).*/\1/p" "$2" | tail -n 1; }
for config in "before:--clip off --guide off" "clipped:--clip on --guide off" "after:--clip on --guide on"; do
    name=${config%%:*}; opts=${config#*:}
    # shellcheck disable=SC2086
    ./pmview scenes/window-room.gltf --sky white --width 64 --height 64 --photons 40000 --time "$seconds" --quiet \
        --reference "$ref" --stats --snapshot "$tmp/$name.exr" $opts >"$tmp/$name" 2>&1 || { echo "bench window_room: pmview failed"; exit 1; }
    grep '^stat error' "$tmp/$name" | tail -n 1 >"$tmp/$name.error"
    grep '^stat progressive ' "$tmp/$name" >"$tmp/$name.progressive"
    printf 'bench window_room config=%s seconds=%s iterations=%s relmse=%s mean_ratio_r=%s mean_ratio_g=%s mean_ratio_b=%s useful_share=%s useful_photons_per_second=%s clip_rays=%s\n' \
        "$name" "$seconds" "$(field iterations "$tmp/$name.error")" "$(field relmse "$tmp/$name.error")" \
        "$(field mean_ratio_r "$tmp/$name.error")" "$(field mean_ratio_g "$tmp/$name.error")" "$(field mean_ratio_b "$tmp/$name.error")" \
        "$(field useful_share "$tmp/$name.progressive")" "$(field useful_photons_per_second "$tmp/$name.progressive")" \
        "$(field clip_rays "$tmp/$name.progressive")"
done
python3 - "$(field relmse "$tmp/before.error")" "$(field relmse "$tmp/clipped.error")" "$(field relmse "$tmp/after.error")" \
    "$(field useful_share "$tmp/before.progressive")" "$(field useful_share "$tmp/after.progressive")" <<'EOF'
import sys
before, clipped, after, share_before, share_after = map(float, sys.argv[1:])
print("bench window_room_ratios relmse_before_over_clipped=%.2f relmse_before_over_after=%.2f useful_share_after_over_before=%.1f"
      % (before / clipped, before / after, share_after / max(share_before, 1e-9)))
EOF

#!/bin/sh
# window_room_bench.sh: the room lit by sun and sky through a window (scenes/window-room.gltf) at equal time against Mitsuba 3's reference: error, channel means and the share of useful photons unclipped and unguided, clipped, and with the defaults (clipped and guided), as ratios of one run ("bench window_room" lines).
#
# Each configuration renders 64x64 for the same wall time on all cores, one after another; the
# ratio line divides the unclipped, unguided configuration's relMSE by each other's (above 1: lower error at
# equal time). BENCH_SECONDS sets the time (default 10). Final gathering reads the photons in every
# configuration (--gather photons): their estimates are what is measured (the default's own choice
# on this room is bench/default_vs_pathtrace.sh's).
cd "$(dirname "$0")/.." || exit 1
seconds=${BENCH_SECONDS:-10}
ref=tests/ref/window_room_64.exr
[ -f "$ref" ] || { echo "bench window_room: skipped ($ref missing)"; exit 0; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
field() { sed -n "s/.*$1=\([^ ]*\).*/\1/p" "$2" | tail -n 1; }
for config in "unclipped:--clip off --guide off" "clipped:--clip on --guide off" "default:--clip on --guide on"; do
    name=${config%%:*}; opts=${config#*:}
    # shellcheck disable=SC2086
    ./pmview scenes/window-room.gltf --sky white --width 64 --height 64 --photons 40000 --gather photons --time "$seconds" --quiet \
        --reference "$ref" --stats --snapshot "$tmp/$name.exr" $opts >"$tmp/$name" 2>&1 || { echo "bench window_room: pmview failed"; exit 1; }
    grep '^stat error' "$tmp/$name" | tail -n 1 >"$tmp/$name.error"
    grep '^stat progressive ' "$tmp/$name" >"$tmp/$name.progressive"
    printf 'bench window_room config=%s seconds=%s iterations=%s relmse=%s mean_ratio_r=%s mean_ratio_g=%s mean_ratio_b=%s useful_share=%s useful_photons_per_second=%s clip_rays=%s\n' \
        "$name" "$seconds" "$(field iterations "$tmp/$name.error")" "$(field relmse "$tmp/$name.error")" \
        "$(field mean_ratio_r "$tmp/$name.error")" "$(field mean_ratio_g "$tmp/$name.error")" "$(field mean_ratio_b "$tmp/$name.error")" \
        "$(field useful_share "$tmp/$name.progressive")" "$(field useful_photons_per_second "$tmp/$name.progressive")" \
        "$(field clip_rays "$tmp/$name.progressive")"
done
python3 - "$(field relmse "$tmp/unclipped.error")" "$(field relmse "$tmp/clipped.error")" "$(field relmse "$tmp/default.error")" \
    "$(field useful_share "$tmp/unclipped.progressive")" "$(field useful_share "$tmp/default.progressive")" <<'EOF'
import sys
unclipped, clipped, default, share_unclipped, share_default = map(float, sys.argv[1:])
print("bench window_room_ratios relmse_unclipped_over_clipped=%.2f relmse_unclipped_over_default=%.2f useful_share_default_over_unclipped=%.1f"
      % (unclipped / clipped, unclipped / default, share_default / max(share_unclipped, 1e-9)))
EOF

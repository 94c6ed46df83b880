#!/bin/sh
# first_image.sh: the window's first rendered image of the default scene, timed from the moment the process is started, for one or more pmview binaries run alternately under one Xvfb.
#
#   sh bench/first_image.sh [ROUNDS] [BINARY...]     (default: 10 rounds of ./pmview)
#
# Each run: the shell notes the wall clock, starts `BINARY --iterations 2 --threads 2 --stats`,
# waits for the render to finish and presses Esc; pmview's `stat window first_image_realtime`
# (the wall clock at the first image) minus the start is the figure, and `first_frame_seconds`
# plus the same offset the window's; `first_image_cpu_seconds` is the process's processor time then
# (every thread, the dynamic loading included). Prints each run and, per binary, the median and range.
cd "$(dirname "$0")/.." || exit 1
rounds=${1:-10}; [ $# -gt 0 ] && shift
[ $# -eq 0 ] && set -- ./pmview
command -v xvfb-run >/dev/null && command -v xdotool >/dev/null || { echo "first_image.sh needs xvfb-run and xdotool"; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cat >"$tmp/inner.sh" <<'INNER'
tmp=$1; rounds=$2; shift 2
for r in $(seq 1 "$rounds"); do
    for bin in "$@"; do
        log="$tmp/run.log"
        t0=$(date +%s.%N)
        timeout 30 "$bin" --iterations 2 --threads 2 --stats >"$log" 2>&1 &
        pid=$!
        i=0
        while ! grep -q "iterations done" "$log" 2>/dev/null && [ $i -lt 300 ]; do sleep 0.05; i=$((i + 1)); done
        # Esc to the window, focused first (no window manager); the tests' way
        for wid in $(xdotool search --name '^pmview' 2>/dev/null); do
            xdotool windowfocus --sync "$wid" 2>/dev/null && xdotool key Escape 2>/dev/null && xdotool keyup Escape 2>/dev/null
        done
        wait "$pid"
        # (a binary without first_image_realtime gives only the times from main())
        awk -v t0="$t0" -v bin="$bin" '$1 == "stat" && $2 == "window" {
            for (i = 3; i <= NF; i++) { split($i, kv, "="); v[kv[1]] = kv[2] }
            printf "%s image_ms=%s window_from_main_ms=%.0f image_from_main_ms=%.0f cpu_ms=%s\n", bin,
                   v["first_image_realtime"] ? sprintf("%.0f", (v["first_image_realtime"] - t0) * 1000) : "-",
                   v["first_frame_seconds"] * 1000, v["first_image_seconds"] * 1000,
                   v["first_image_cpu_seconds"] ? sprintf("%.0f", v["first_image_cpu_seconds"] * 1000) : "-" }' "$log"
    done
done
INNER
xvfb-run -a -s "-screen 0 1024x768x24 -noreset" sh "$tmp/inner.sh" "$tmp" "$rounds" "$@" | tee "$tmp/all.txt"
median() { sort -n | awk '{ v[NR] = $1 } END { if (NR) printf "%d ms (median of %d; %d-%d)", v[int((NR + 1) / 2)], NR, v[1], v[NR]; else printf "-" }'; }
for bin in "$@"; do
    echo "$bin: first image $(grep "^$bin " "$tmp/all.txt" | sed -n 's/.* image_ms=\([0-9]*\) .*/\1/p' | median) after the process started;" \
         "after main(): window $(grep "^$bin " "$tmp/all.txt" | sed -n 's/.*window_from_main_ms=\([0-9]*\).*/\1/p' | median)," \
         "first image $(grep "^$bin " "$tmp/all.txt" | sed -n 's/.*image_from_main_ms=\([0-9]*\).*/\1/p' | median);" \
         "processor time to the first image $(grep "^$bin " "$tmp/all.txt" | sed -n 's/.*cpu_ms=\([0-9]*\).*/\1/p' | median)"
done

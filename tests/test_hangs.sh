#!/bin/sh
# test_hangs.sh: hostile numbers never hang (radii past float's range refused, every option's extremes end in seconds), SIGINT/SIGTERM are answered within a second mid-pass, and --time holds at any image size with an unbiased image.
cd "$(dirname "$0")/.." || exit 1
bin=./pmview
[ -x "$bin" ] || { echo "test_hangs: FAILED: ./pmview is not built"; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
checks=0; fails=0
fail() { fails=$((fails + 1)); echo "FAIL: $*"; }
check() { checks=$((checks + 1)); }
now_ms() { echo $(( $(date +%s%N) / 1000000 )); }
python3 tests/white_room.py "$tmp/room.gltf"
cornell=scenes/cornell-box.gltf

# 1. a radius whose square overflows float (the disc planner looped for ever over 2e9 cells a side):
# a usage error naming the range; the largest accepted radius renders in seconds
for opt in --radius --max-radius; do
    mode=""; [ "$opt" = --max-radius ] && mode="--mode classic"
    timeout -s KILL 20 $bin $cornell $mode $opt 2e19 --width 16 --iterations 1 --snapshot "$tmp/x.exr" >"$tmp/out" 2>"$tmp/err"
    rc=$?; check
    { [ $rc -eq 2 ] && head -n 1 "$tmp/err" | grep -q "^pmview: bad $opt '2e19' (1e-18 to 1e18"; } ||
        { fail "$opt 2e19: want exit 2 and one 'bad $opt' line, got exit $rc:"; head -n 2 "$tmp/err"; }
    for r in 1e18 1e-18; do
        start=$(now_ms)
        timeout -s KILL 30 $bin $cornell $mode $opt $r --width 32 --iterations 2 --quiet --snapshot "$tmp/x.exr" >"$tmp/out" 2>"$tmp/err"
        rc=$?; check
        [ $rc -eq 0 ] && [ -s "$tmp/x.exr" ] || { fail "$opt $r: exit $rc (137: still running after 30 s)"; head -n 3 "$tmp/err"; }
        echo "$opt $r: exit $rc after $(( $(now_ms) - start )) ms"
    done
done

# 2. every numeric option at the ends of its range, each within a time limit (exit 0, or 1 with
# one out-of-memory line where the film cannot fit): what the options accept, the code computes
while IFS='|' read -r limit want args; do
    [ -n "$limit" ] || continue
    start=$(now_ms)
    # shellcheck disable=SC2086
    timeout -s KILL "$limit" $bin $args --quiet --snapshot "$tmp/x.exr" >"$tmp/out" 2>"$tmp/err"
    rc=$?; check
    if [ $rc -ne "$want" ] || { [ "$want" -eq 1 ] && [ "$(wc -l < "$tmp/err")" -ne 1 ]; }; then
        fail "$args: exit $rc, want $want within $limit s"; head -n 3 "$tmp/err"
    fi
    echo "exit $rc after $(( $(now_ms) - start )) ms: $args"
done <<EOF
20|0|$cornell --width 32 --iterations 4 --alpha 0.001
20|0|$cornell --width 32 --iterations 4 --alpha 0.999
20|0|$cornell --width 32 --iterations 2 --photons 0
20|0|$cornell --width 32 --time 0.5 --photons 2000000000
20|0|$cornell --width 32 --time 0.5 --iterations 1000000000
20|0|$cornell --width 32 --time 10000000 --iterations 1
20|0|$cornell --width 32 --iterations 2 --exposure 64
20|0|$cornell --width 32 --iterations 2 --exposure -64
20|0|$cornell --width 32 --iterations 2 --eye-passes 4096
20|0|$cornell --width 16384 --height 1 --iterations 1
20|1|$cornell --width 16384 --height 16384 --iterations 1
30|0|$cornell --width 16 --iterations 1 --mode classic --k 2048
30|0|$cornell --width 4 --iterations 1 --mode classic --gather-rays 4096
EOF

# 3. signals in the middle of a pass: SIGINT and SIGTERM end the run within a second with 130 and
# 143, and the image so far is written. A 2-million-photon pass in the closed albedo-1 room (its
# paths bounce 50 times: 30 s of tracing and sorting); 20 million photons under a limit they
# would cross in a few seconds (out of memory must not replace the signal's exit); a path-traced
# eye pass in that room (100-bounce paths: seconds a pass at 256x256). --gather photons: the default
# path-traces a room without mirrors or glass until it has measured what the photons would give.
signal_case() { # description, signal, delay (s) into the render, want exit, pmview arguments...
    desc=$1; sig=$2; delay=$3; want=$4; shift 4
    rm -f "$tmp/s.exr" "$tmp/out" # not the last case's output: the redirection below happens in the background
    # --foreground: timeout passes the signal to pmview alone; without it, it sends it to pmview and
    # then to its whole process group, and the second copy can come after the render stopped, while
    # the image is written, where a second signal means abandon the file (as a second Ctrl-C does)
    timeout --foreground -s KILL 60 $bin "$@" --stats --snapshot "$tmp/s.exr" >"$tmp/out" 2>"$tmp/err" &
    pid=$!
    # the render starts after "stat film" (a signal while loading just ends the process)
    i=0; while ! grep -qs "^stat film" "$tmp/out" && [ $i -lt 200 ]; do sleep 0.05; i=$((i + 1)); done
    sleep "$delay"
    # the pid is timeout's: it passes the signal on to pmview
    t0=$(now_ms)
    kill -"$sig" "$pid"
    wait "$pid"; rc=$?
    ms=$(( $(now_ms) - t0 )); check
    echo "$desc: SIG$sig after $delay s answered in $ms ms, exit $rc"
    { [ $rc -eq "$want" ] && [ $ms -le 1000 ] && [ -s "$tmp/s.exr" ] && grep -q "interrupted: the image so far" "$tmp/out"; } ||
        { fail "$desc: want exit $want within 1000 ms and the image so far written, got exit $rc after $ms ms"; cat "$tmp/out" "$tmp/err" | grep -v "^stat" | head -n 5; }
}
# Each signal comes half a second into the render: any moment of a pass that lasts seconds is
# mid-pass, and each half second longer costs two processors' half second.
signal_case "2M photons, albedo-1 room" INT 0.5 130 "$tmp/room.gltf" --width 64 --height 64 --photons 2000000 --gather photons --iterations 4
signal_case "2M photons, albedo-1 room" TERM 0.5 143 "$tmp/room.gltf" --width 64 --height 64 --photons 2000000 --gather photons --iterations 4
signal_case "20M photons under --max-memory 1G" TERM 0.5 143 "$tmp/room.gltf" --width 64 --height 64 --photons 20000000 --gather photons --iterations 4 --max-memory 1G
signal_case "path-traced eye pass, albedo-1 room" INT 0.5 130 "$tmp/room.gltf" --width 256 --height 256 --mode pathtrace --iterations 64

# 4. --time at a size where a pass does not fit in the time left: the run ends at the budget (not
# a pass past it, nor a pass short of it), a pass cut between tiles leaves some pixels a sample
# ahead, and the image's mean is the untimed run's (each pixel divided by its own count). The
# budget is one and a half first iterations, measured here.
size=512
timeout -s KILL 60 $bin $cornell --width $size --height $size --iterations 1 --snapshot "$tmp/one.exr" >"$tmp/out" 2>"$tmp/err"
w1=$(sed -n 's/.*, 1 iterations, \([0-9.]*\) s).*/\1/p' "$tmp/out")
timeout -s KILL 60 $bin $cornell --width $size --height $size --iterations 2 --quiet --snapshot "$tmp/ref.exr" >"$tmp/out" 2>"$tmp/err"
check
if [ -z "$w1" ] || [ ! -s "$tmp/ref.exr" ]; then
    fail "could not measure the first iteration or write the reference"; cat "$tmp/err"
else
    share=1.5; ahead=0; attempt=0
    while [ $attempt -lt 4 ]; do
        budget=$(awk -v w="$w1" -v s="$share" 'BEGIN { printf "%.3f", w * s }')
        timeout -s KILL 60 $bin $cornell --width $size --height $size --time "$budget" --stats --reference "$tmp/ref.exr" --snapshot "$tmp/t.exr" >"$tmp/out" 2>"$tmp/err"
        took=$(sed -n 's/.*iterations, \([0-9.]*\) s).*/\1/p' "$tmp/out")
        ahead=$(sed -n 's/^stat eye .*pixels_ahead=\([0-9]*\).*/\1/p' "$tmp/out")
        ratios=$(sed -n 's/^stat error .*mean_ratio_r=\([0-9.]*\) mean_ratio_g=\([0-9.]*\) mean_ratio_b=\([0-9.]*\).*/\1 \2 \3/p' "$tmp/out")
        echo "--time $budget (first iteration $w1 s) at ${size}x$size: $took s, $(sed -n 's/^pmview: wrote .*, \([0-9]* iterations\),.*/\1/p' "$tmp/out") and ${ahead:-?} pixels a sample ahead, mean ratios to 2 iterations: $ratios"
        [ "${ahead:-0}" -gt 0 ] && [ "$ahead" -lt $((size * size)) ] && break
        share=$(awk -v s="$share" 'BEGIN { print s + 0.4 }'); attempt=$((attempt + 1))
    done
    check
    [ "${ahead:-0}" -gt 0 ] && [ "$ahead" -lt $((size * size)) ] || fail "no budget cut a pass part way (pixels_ahead ${ahead:-missing})"
    check
    awk -v t="${took:-999}" -v b="$budget" -v w="$w1" 'BEGIN { exit !(t <= b + 0.1 * w + 0.25) }' ||
        fail "--time $budget took ${took:-?} s: more than the budget plus a tenth of an iteration and 0.25 s"
    check # and the budget is used: a pass that would not fit is started and cut, not skipped
    awk -v t="${took:-0}" -v b="$budget" -v w="$w1" 'BEGIN { exit !(t >= b - 0.1 * w - 0.02) }' ||
        fail "--time $budget took only ${took:-?} s: it stopped more than a tenth of an iteration short"
    check
    echo "$ratios" | awk '{ for (i = 1; i <= 3; i++) if (!($i > 0.97 && $i < 1.03)) exit 1; exit NF != 3 }' ||
        fail "the cut run's mean is not the untimed run's within 3%: ratios '$ratios'"
fi
# a budget shorter than the first pass: that pass is finished (one iteration), and pmview says so
timeout -s KILL 60 $bin $cornell --width $size --height $size --time 0.01 --snapshot "$tmp/t.exr" >"$tmp/out" 2>"$tmp/err"
rc=$?; check
{ [ $rc -eq 0 ] && grep -q "(${size}x$size, 1 iterations," "$tmp/out" && grep -q "^pmview: note: --time 0.01 s is shorter than the first iteration" "$tmp/err"; } ||
    { fail "--time 0.01: want one whole iteration and the note, got exit $rc:"; cat "$tmp/out" "$tmp/err"; }

echo "test_hangs: $checks checks, $fails failed"
[ "$fails" -eq 0 ]

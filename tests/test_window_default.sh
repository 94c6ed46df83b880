#!/bin/sh
# test_window_default.sh: the default mode on the room lit by sun and sky through a window (scenes/window-room.gltf) against Mitsuba 3's reference: final gathering chooses the path tracer's light there, every channel's mean holds, and the error is the path tracer's at equal work.
#
# Work is counted, never timed: the rays each run cast (eye rays with their shadow rays, photon
# rays, the clips' probes), from the stat lines. The default renders 512 samples per pixel (its
# learning iterations included in its rays); the path tracer renders as many samples as the same
# rays buy it. On this room the photons' estimate is biased by wide discs and costs twice the
# path tracer's per sample, so the default must choose the path tracer and then match its error:
# within 5%, the share of the rays its learning iterations cost (the photons' measured ones
# leave the image as it was). With the photons forced (--gather photons) the same work errs
# 1.5 times as much or more (about twice), so the checks can fail. And the choice, made from
# the film and ray counts, gives the same image on 1 and 2 threads.
cd "$(dirname "$0")/.." || exit 1
bin=./pmview
ref=tests/ref/window_room_64.exr
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
if [ ! -f "$ref" ]; then echo "SKIP: $ref is missing"; exit 0; fi
fails=0; checks=0
run() { # name, options...
    name=$1; shift
    "$bin" scenes/window-room.gltf --sky white --width 64 --height 64 --reference "$ref" --stats --quiet --seed 1 \
        --snapshot "$tmp/$name.exr" "$@" >"$tmp/$name" 2>&1 || { echo "FAIL: pmview $name: $(tail -n 1 "$tmp/$name")"; exit 1; }
}
# a stat line's key: stat STAGE key
value() { sed -n "s/^stat $1 .*[ ]$2=\([^ ]*\).*/\1/p" "$3" | tail -n 1; }
# the rays a run cast: eye (shadow rays included), photons, the clips' probes
rays() { python3 -c "import sys; print(sum(float(x or 0) for x in sys.argv[1:]))" \
         "$(value eye rays "$1")" "$(value photons rays "$1")" "$(value progressive clip_rays "$1")"; }
check() { # description, python condition over d (default), t (path tracer) and f (photons forced): dicts of error and rays
    checks=$((checks + 1))
    if python3 - "$2" "$(value error relmse "$tmp/default")" "$(rays "$tmp/default")" "$(value error relmse "$tmp/path")" \
        "$(rays "$tmp/path")" "$(value error relmse "$tmp/photons")" "$(rays "$tmp/photons")" \
        "$(value error mean_ratio_r "$tmp/default")" "$(value error mean_ratio_g "$tmp/default")" \
        "$(value error mean_ratio_b "$tmp/default")" >"$tmp/py" 2>&1 <<'EOF'
import sys
a = [float(x) for x in sys.argv[2:]]
d = {"relmse": a[0], "rays": a[1], "means": a[6:9]}
t = {"relmse": a[2], "rays": a[3]}
f = {"relmse": a[4], "rays": a[5]}
print("default relmse %.6f rays %.0f means %s; path tracer relmse %.6f rays %.0f; photons forced relmse %.6f rays %.0f"
      % (d["relmse"], d["rays"], d["means"], t["relmse"], t["rays"], f["relmse"], f["rays"]))
sys.exit(0 if eval(sys.argv[1]) else 1)
EOF
    then echo "ok: $1: $(tail -n 1 "$tmp/py")"
    else fails=$((fails + 1)); echo "FAIL: $1: $(tail -n 1 "$tmp/py")"
    fi
}
run default --iterations 512
run path1 --mode pathtrace --iterations 64
# the path tracer's samples for the default's rays (its rays per sample from a short run of the same seed)
samples=$(python3 -c "import sys; print(max(1, round(64 * float(sys.argv[1]) / float(sys.argv[2]))))" \
          "$(rays "$tmp/default")" "$(rays "$tmp/path1")")
run path --mode pathtrace --iterations "$samples"
# the photons forced, for about the same rays (compared as relMSE x rays, which variance keeps constant)
run photons_short --gather photons --iterations 64
photon_samples=$(python3 -c "import sys; print(max(1, round(64 * float(sys.argv[1]) / float(sys.argv[2]))))" \
                 "$(rays "$tmp/default")" "$(rays "$tmp/photons_short")")
run photons --gather photons --iterations "$photon_samples"
source=$(value progressive gather_source "$tmp/default")
checks=$((checks + 1))
if [ "$source" = path ]; then echo "ok: the default's final gathering chose the path tracer's light (gather_source=$source)"
else fails=$((fails + 1)); echo "FAIL: the default's final gathering chose '$source', not path"; fi
check "every channel's mean within 0.5% of the reference" "all(abs(m - 1) < 0.005 for m in d['means'])"
check "the default's relMSE within 5% of the path tracer's at equal rays" "d['relmse'] <= 1.05 * t['relmse']"
check "the photons forced err 1.5 times as much at about equal rays (the choice matters)" \
    "f['relmse'] * f['rays'] >= 1.5 * d['relmse'] * d['rays']"
# the choice reads the film and ray counts only: the same seed makes the same image at any thread count
run threads1 --iterations 40 --threads 1
run threads2 --iterations 40 --threads 2
checks=$((checks + 1))
if cmp -s "$tmp/threads1.exr" "$tmp/threads2.exr" && [ "$(value progressive gather_source "$tmp/threads1")" = path ]; then
    echo "ok: 40 iterations, through the choice, bit for bit the same on 1 and 2 threads"
else fails=$((fails + 1)); echo "FAIL: 40 iterations differ between 1 and 2 threads (or chose no path tracer)"; fi
echo "test_window_default: $checks checks, $fails failed"
[ "$fails" -eq 0 ]

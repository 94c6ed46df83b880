#!/bin/sh
# test_window_default.sh: the default mode on both window rooms lit by sun and sky (solid slabs, scenes/window-room.gltf; single-sided faces with hollow walls and a ground under the floor, scenes/window-hollow.gltf) against Mitsuba 3's references: the choice of the path tracer's light, its image then --mode pathtrace's bit for bit, every channel's mean, and the error at most the path tracer's at equal work.
#
# Work is counted, never timed: the rays each run cast (eye rays with their shadow rays, photon
# rays, the clips' probes), from the stat lines. The default renders 512 samples per pixel at
# 64x64 with its default settings (its learning iterations included in its rays); the path
# tracer renders as many samples as the same rays buy it. On these rooms the photons' estimate is
# biased by wide discs and costs more than a path-traced sample, so the default must choose the
# path tracer, whose samples it then takes with the path tracer's own random numbers: the two
# images differ only by the samples the learning's rays would have bought. The learning (photon
# passes, and eye passes at the noise probe's pixels alone) costs about 0.6% of the rays here, so
# the check is relMSE at most 1.02 times the path tracer's: the learning's share with room to
# spare, and one standard deviation of what the seed alone changes (the path tracer's relMSE at
# 512 samples over seeds 1-6 spreads by 1.9% of its mean on the solid room and 1.6% on the
# hollow one, so an equal-time comparison of independent runs could not tell 2% apart). Seeds 1-6
# read 1.0023 to 1.0095 times the path tracer's on both rooms. The learning's share is checked on
# its own (below 2% of the path tracer's rays; seeds 1-6: 0.54% to 0.57%). The means: within 0.5%
# of the reference, where the seed moves them by 0.09% (standard deviation over seeds 1-6, all
# between 0.9985 and 1.0011). With the photons forced (--gather photons) the same work errs more
# on the solid room (relMSE x rays against the default's; seeds 1-6: 1.95 1.12 1.56 2.10 1.34
# 1.17), checked at 1.05 there, as the control that the choice matters and the checks can fail; on
# the hollow room the forced photons' error lies as often below the default's as above (seeds 1-6:
# 1.41 1.17 1.97 0.95 0.96 0.90), so no control runs there.
# And the choice, made from the film and counts, gives the same image on 1 and 2 threads (on the
# solid room).
cd "$(dirname "$0")/.." || exit 1
bin=./pmview
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0; checks=0
# a stat line's key: stat STAGE key
value() { sed -n "s/^stat $1 .*[ ]$2=\([^ ]*\).*/\1/p" "$3" | tail -n 1; }
# the rays a run cast: eye (shadow rays included), photons, the clips' probes, and a shadow test the
# shadow photons decided as the ray it saved (whether they are built is measured in seconds: under
# load one run may build them and the next not). Summed by awk: a python3 start costs some 0.1 s of
# processor time, and the rays are asked for a dozen times.
rays() { awk -v e="$(value eye rays "$1")" -v s="$(value eye shadow_rays_saved "$1")" -v p="$(value photons rays "$1")" \
         -v c="$(value progressive clip_rays "$1")" 'BEGIN { printf "%.0f\n", e + s + p + c }'; }
# the iterations that buy the rays wanted, from the rays a run of n iterations cast: n, wanted, cast
scaled() { awk -v n="$1" -v want="$2" -v got="$3" 'BEGIN { x = n * want / got; printf "%d\n", x < 1 ? 1 : x + 0.5 }'; }
for room in window-room:window_room_64 window-hollow:window_hollow_64; do
    scene=scenes/${room%%:*}.gltf; ref=tests/ref/${room#*:}.exr; name=${room%%:*}
    if [ ! -f "$ref" ]; then echo "SKIP: $ref is missing"; continue; fi
    run() { # name, options...
        out=$1; shift
        "$bin" "$scene" --sky white --width 64 --height 64 --reference "$ref" --stats --quiet --seed 1 \
            --snapshot "$tmp/$out.exr" "$@" >"$tmp/$out" 2>&1 || { echo "FAIL: pmview $name $out: $(tail -n 1 "$tmp/$out")"; exit 1; }
    }
    run default --iterations 512
    # the path tracer's samples for the default's rays, its rays per sample from the 40-sample run of
    # the same seed that the bit-for-bit check below reads
    run path40 --mode pathtrace --iterations 40
    samples=$(scaled 40 "$(rays "$tmp/default")" "$(rays "$tmp/path40")")
    run path --mode pathtrace --iterations "$samples"
    # the photons forced, for about the same rays (compared as relMSE x rays, which variance keeps
    # constant), on the solid room only (see above)
    rm -f "$tmp/photons_short" "$tmp/photons"
    if [ "$name" = window-room ]; then
        run photons_short --gather photons --iterations 64
        run photons --gather photons --iterations "$(scaled 64 "$(rays "$tmp/default")" "$(rays "$tmp/photons_short")")"
    fi
    source=$(value progressive gather_source "$tmp/default")
    checks=$((checks + 1))
    if [ "$source" = path ]; then echo "ok: $name: the default's final gathering chose the path tracer's light (gather_source=$source)"
    else fails=$((fails + 1)); echo "FAIL: $name: the default's final gathering chose '$source', not path"; fi
    # the checks, pairs of a description and a python condition over d (default), t (path tracer) and
    # f (photons forced), dicts of error and rays: all of a room's in one python3
    set -- "every channel's mean within 0.5% of the reference after 512 samples" "all(abs(m - 1) < 0.005 for m in d['means'])" \
        "the learning costs under 2% of the path tracer's rays for the same 512 samples" "0 <= d['learning'] < 0.02" \
        "the default's relMSE at most the path tracer's at equal rays (1.02: see above)" "d['relmse'] <= 1.02 * t['relmse']"
    if [ "$name" = window-room ]; then
        set -- "$@" "the photons forced err 1.05 times as much at about equal rays (the choice matters)" \
            "f['relmse'] * f['rays'] >= 1.05 * d['relmse'] * d['rays']"
    fi
    python3 - "$name" "$(value error relmse "$tmp/default")" "$(rays "$tmp/default")" "$(value error relmse "$tmp/path")" \
        "$(rays "$tmp/path")" "$(value error relmse "$tmp/photons" 2>/dev/null)" "$(rays "$tmp/photons" 2>/dev/null)" \
        "$(value error mean_ratio_r "$tmp/default")" "$(value error mean_ratio_g "$tmp/default")" \
        "$(value error mean_ratio_b "$tmp/default")" "$samples" "$@" >"$tmp/py" 2>&1 <<'EOF'
import sys
name = sys.argv[1]
a = [float(x or "nan") for x in sys.argv[2:12]]  # (no photons forced on the hollow room: nan)
# the learning's share: the default's rays against the path tracer's for 512 samples, from its run
# of a[9] samples (the same seed: the same paths, so the scaling errs only by the last few samples'
# share of a path's average rays, well under 0.1%)
d = {"relmse": a[0], "rays": a[1], "means": a[6:9], "learning": a[1] / (a[3] * 512 / a[9]) - 1}
t = {"relmse": a[2], "rays": a[3]}
f = {"relmse": a[4], "rays": a[5]}
summary = ("default relmse %.6f rays %.0f means %s learning +%.2f%% rays; path tracer relmse %.6f rays %.0f; photons forced relmse %.6f rays %.0f"
           % (d["relmse"], d["rays"], d["means"], 100 * d["learning"], t["relmse"], t["rays"], f["relmse"], f["rays"]))
failed = 0
for description, condition in zip(sys.argv[12::2], sys.argv[13::2]):
    try:
        ok, why = eval(condition), summary
    except Exception as e:
        ok, why = False, "%s (%s)" % (summary, e)
    failed += not ok
    print("%s: %s: %s: %s" % ("ok" if ok else "FAIL", name, description, why))
sys.exit(1 if failed else 0)
EOF
    status=$?
    cat "$tmp/py"
    checks=$((checks + $# / 2))
    failed=$(grep -c '^FAIL: ' "$tmp/py")
    # a python3 that stopped before its verdicts fails every check it left unwritten
    [ "$status" -eq 0 ] || [ "$failed" -gt 0 ] || failed=$(($# / 2 - $(grep -c '^ok: ' "$tmp/py")))
    fails=$((fails + failed))
    # once the path tracer's light is chosen (no caustic possible here), each iteration is the path
    # tracer's own eye pass: the image after 40 samples is --mode pathtrace's bit for bit, and the
    # samples after the choice were taken that way (path_only_samples). Two threads named: the run is
    # also the two-thread side of the thread check below, whatever the machine's cores.
    run default40 --iterations 40 --threads 2
    checks=$((checks + 1))
    path_only=$(value progressive path_only_samples "$tmp/default40")
    if cmp -s "$tmp/default40.exr" "$tmp/path40.exr" && [ "${path_only:-0}" -ge 20 ]; then
        echo "ok: $name: 40 samples bit for bit --mode pathtrace's, $path_only of them as its eye pass alone"
    else fails=$((fails + 1)); echo "FAIL: $name: 40 samples differ from --mode pathtrace's, or only '${path_only}' taken as its eye pass alone"; fi
    # the choice reads the film and counts only: the same seed makes the same image at any thread
    # count (a property of the code, not of the room: checked on the first room only)
    [ "$name" = window-room ] || continue
    run threads1 --iterations 40 --threads 1
    checks=$((checks + 1))
    if cmp -s "$tmp/threads1.exr" "$tmp/default40.exr" && [ "$(value progressive gather_source "$tmp/threads1")" = path ]; then
        echo "ok: $name: 40 iterations, through the choice, bit for bit the same on 1 and 2 threads"
    else fails=$((fails + 1)); echo "FAIL: $name: 40 iterations differ between 1 and 2 threads (or chose no path tracer)"; fi
done
echo "test_window_default: $checks checks, $fails failed"
[ "$fails" -eq 0 ]

#!/bin/sh
# test_window_default.sh: the default mode in rooms lit through a window (solid slabs, scenes/window-room.gltf; single-sided faces with hollow walls and a ground under the floor, scenes/window-hollow.gltf) against Mitsuba 3's references: the choice of the path tracer's light, the connections' trial (on in the hollow room under sun and sky and under the sun alone, off in the solid room under sun and sky), every channel's mean, and the error against the path tracer's at equal work.
#
# Work is counted, never timed: the rays each run cast (eye rays with their shadow rays and its
# connections', photon rays, the clips' probes), from the stat lines. The default renders 1,536
# samples per pixel at 64x64 with its default settings (its learning and trial iterations
# included in its rays: by 512 samples the trial has barely decided); the path tracer renders as
# many samples as the same rays buy it.
#
# Under sun and sky (--sky white, both rooms): the photons' estimate is biased by wide discs and
# costs more than a path-traced sample, so the default must choose the path tracer's light. Its
# direct light samples the sky where the sky's arrival guide learned it is seen from (arrival.h:
# through the window), which the path tracer (--mode pathtrace, nothing learned) does not. The
# connections' trial then keeps connections in the hollow room, where sun and sky light vertices
# enter through the window (relMSE at equal rays 0.683, 0.711, 0.686 of the path tracer's over
# seeds 1-3, checked at 0.80), and leaves them off in the solid room, where they bring less than
# they cost; there the relMSE at equal rays is 0.880, 0.898, 0.861 of the path tracer's, checked
# at 0.96 (one standard deviation of what the seed alone changes is about 2%). What the default
# pays there besides the guide's own samples (`stat eye sky_arrival_samples`, paid for in its
# error) is the learning and the trial's iterations with connections: 5.9% of the rays (seeds
# 1-3), checked below 8%. The means: within 0.5% of the reference. With the photons forced
# (--gather photons) the same work errs more on the solid room (relMSE x rays against the
# default's: 1.62, 1.32, 1.24 over seeds 1-3; the photons forced get the guide too), checked at 1.05 there, as the control that the
# choice matters and the checks can fail.
#
# Under the sun alone (the hollow room, --sky none, against tests/ref/window_hollow_sun_64.exr):
# the path tracer finds the sunlit patch's light only where a bounce happens to land on it, and
# the connections join it from every diffuse vertex: the trial keeps them, and the default's
# relMSE at equal rays is checked at most 0.80 times the path tracer's (seeds 1-3: 0.645, 0.694,
# 0.653; the trial's iterations without connections and its warm-up included).
#
# And the choice and the trial, made from the film and counts, give the same image on 1 and 2
# threads (on the solid room, 40 iterations: through the choice and into the trial's warm-up,
# sun and sky light vertices joined).
cd "$(dirname "$0")/.." || exit 1
. tests/stat_setup.sh
# the rays a run cast: eye (shadow rays and connections' included), photons, the clips' probes, and
# a shadow test the shadow photons decided as the ray it saved (whether they are built is measured
# in seconds: under load one run may build them and the next not). Summed by awk: a python3 start
# costs some 0.1 s of processor time, and the rays are asked for a dozen times.
rays() { awk -v e="$(value eye rays "$1")" -v s="$(value eye shadow_rays_saved "$1")" -v p="$(value photons rays "$1")" \
         -v c="$(value progressive clip_rays "$1")" 'BEGIN { printf "%.0f\n", e + s + p + c }'; }
# the iterations that buy the rays wanted, from the rays a run of n iterations cast: n, wanted, cast
scaled() { awk -v n="$1" -v want="$2" -v got="$3" 'BEGIN { x = n * want / got; printf "%d\n", x < 1 ? 1 : x + 0.5 }'; }
# room:reference:sky:the trial's verdict:the default's relMSE over the path tracer's at most
default_samples=1536
for room in window-room:window_room_64:white:0:0.96 window-hollow:window_hollow_64:white:1:0.80 \
            window-hollow:window_hollow_sun_64:none:1:0.80; do
    scene=scenes/${room%%:*}.gltf; rest=${room#*:}; ref=tests/ref/${rest%%:*}.exr; rest=${rest#*:}
    sky=${rest%%:*}; rest=${rest#*:}; verdict=${rest%%:*}; bound=${rest#*:}
    name="${room%%:*} (--sky $sky)"
    if [ ! -f "$ref" ]; then echo "SKIP: $ref is missing"; continue; fi
    run() { # name, options...
        out=$1; shift
        "$bin" "$scene" --sky "$sky" --width 64 --height 64 --reference "$ref" --stats --quiet --seed 1 \
            --snapshot "$tmp/$out.exr" "$@" >"$tmp/$out" 2>&1 || { echo "FAIL: pmview $name $out: $(tail -n 1 "$tmp/$out")"; exit 1; }
    }
    run default --iterations $default_samples
    # the path tracer's samples for the default's rays, its rays per sample from a 40-sample run
    run path40 --mode pathtrace --iterations 40
    samples=$(scaled 40 "$(rays "$tmp/default")" "$(rays "$tmp/path40")")
    run path --mode pathtrace --iterations "$samples"
    # the photons forced, for about the same rays (compared as relMSE x rays, which variance keeps
    # constant), on the solid room only (see above)
    rm -f "$tmp/photons_short" "$tmp/photons"
    if [ "$scene" = scenes/window-room.gltf ]; then
        run photons_short --gather photons --iterations 64
        run photons --gather photons --iterations "$(scaled 64 "$(rays "$tmp/default")" "$(rays "$tmp/photons_short")")"
    fi
    source=$(value progressive gather_source "$tmp/default")
    trial=$(value progressive connect_trial "$tmp/default")
    checks=$((checks + 2))
    if [ "$source" = path ]; then echo "ok: $name: the default's final gathering chose the path tracer's light (gather_source=$source)"
    else fails=$((fails + 1)); echo "FAIL: $name: the default's final gathering chose '$source', not path"; fi
    if [ "$trial" = "$verdict" ]; then echo "ok: $name: the connections' trial decided connect_trial=$trial"
    else fails=$((fails + 1)); echo "FAIL: $name: the connections' trial decided connect_trial='$trial', not $verdict"; fi
    # the checks, pairs of a description and a python condition over d (default), t (path tracer) and
    # f (photons forced), dicts of error and rays: all of a room's in one python3
    set -- "every channel's mean within 0.5% of the reference after $default_samples samples" "all(abs(m - 1) < 0.005 for m in d['means'])" \
        "the default's relMSE at most $bound times the path tracer's at equal rays" "d['relmse'] <= $bound * t['relmse']"
    if [ "$verdict" = 0 ]; then
        set -- "$@" "the learning and the trial cost under 8% of the path tracer's rays for the same $default_samples samples" "0 <= d['learning'] < 0.08"
    fi
    if [ "$scene" = scenes/window-room.gltf ]; then
        set -- "$@" "the photons forced err 1.05 times as much at about equal rays (the choice matters)" \
            "f['relmse'] * f['rays'] >= 1.05 * d['relmse'] * d['rays']"
    fi
    python3 - "$name" "$(value error relmse "$tmp/default")" "$(rays "$tmp/default")" "$(value error relmse "$tmp/path")" \
        "$(rays "$tmp/path")" "$(value error relmse "$tmp/photons" 2>/dev/null)" "$(rays "$tmp/photons" 2>/dev/null)" \
        "$(value error mean_ratio_r "$tmp/default")" "$(value error mean_ratio_g "$tmp/default")" \
        "$(value error mean_ratio_b "$tmp/default")" "$samples" "$default_samples" "$(value eye sky_arrival_samples "$tmp/default")" \
        "$@" >"$tmp/py" 2>&1 <<'EOF'
import sys
name = sys.argv[1]
a = [float(x or "nan") for x in sys.argv[2:14]]  # (no photons forced on the hollow room: nan)
# the learning's share: the default's rays against the path tracer's for as many samples (a[10]), from its run
# of a[9] samples (the same seed: the same paths, so the scaling errs only by the last few samples'
# share of a path's average rays, well under 0.1%), the sky's samples from its arrival guide (a[11])
# apart: those are its sampling, paid for in its error
d = {"relmse": a[0], "rays": a[1], "means": a[6:9], "learning": (a[1] - a[11]) / (a[3] * a[10] / a[9]) - 1}
t = {"relmse": a[2], "rays": a[3]}
f = {"relmse": a[4], "rays": a[5]}
summary = ("default relmse %.6f rays %.0f means %s learning +%.2f%% rays; path tracer relmse %.6f rays %.0f (ratio %.3f); photons forced relmse %.6f rays %.0f"
           % (d["relmse"], d["rays"], d["means"], 100 * d["learning"], t["relmse"], t["rays"], d["relmse"] / t["relmse"], f["relmse"], f["rays"]))
failed = 0
for description, condition in zip(sys.argv[14::2], sys.argv[15::2]):
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
    # the choice and the trial read the film and counts only: the same seed makes the same image at
    # any thread count (a property of the code, not of the room: checked on the first room only)
    [ "$scene" = scenes/window-room.gltf ] && [ "$sky" = white ] || continue
    run threads2 --iterations 40 --threads 2
    run threads1 --iterations 40 --threads 1
    checks=$((checks + 1))
    joined=$(value eye connections "$tmp/threads2")
    if cmp -s "$tmp/threads1.exr" "$tmp/threads2.exr" && [ "$(value progressive gather_source "$tmp/threads1")" = path ] && [ "${joined:-0}" -gt 0 ]; then
        echo "ok: $name: 40 iterations, through the choice and into the trial's warm-up ($joined connections), bit for bit the same on 1 and 2 threads"
    else fails=$((fails + 1)); echo "FAIL: $name: 40 iterations differ between 1 and 2 threads (or chose no path tracer, or joined '$joined' light vertices)"; fi
done
echo "test_window_default: $checks checks, $fails failed"
[ "$fails" -eq 0 ]

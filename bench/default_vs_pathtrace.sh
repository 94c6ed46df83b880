#!/bin/sh
# default_vs_pathtrace.sh: the default (progressive) mode's relMSE over the path tracer's at equal time, on every shipped scene that has a reference, glossy dielectrics included ("bench default_vs_pathtrace" lines).
#
# Usage: sh bench/default_vs_pathtrace.sh   (BENCH_SECONDS per run, default 10; BENCH_SEEDS, default "1";
# BENCH_SCENES, the scenes to run, default all of the list below)
# Each scene renders at its reference's size (64x64; the hollow window room also 128x128) on all cores for the same wall time, the default and then --mode
# pathtrace, alternating per seed, so a machine's drift over the runs falls on both alike. ratio =
# relmse_default / relmse_pathtrace: below 1 the default is ahead. ratio_equal_cpu weighs each
# relMSE by the processor seconds (user + system) its run got, relmse x cpu over relmse x cpu: where
# the error falls as 1 / time that is the ratio at equal processor time, steadier than the wall-time
# ratio on a machine other work shares (a run that got less of the processors errs more). gather_source is what the
# default's final gathering chose (photons, path; none where nothing is gathered).
cd "$(dirname "$0")/.." || exit 1
seconds=${BENCH_SECONDS:-10}
seeds=${BENCH_SEEDS:-1}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
field() { sed -n "s/.*[ ]$1=\([^ ]*\).*/\1/p" "$2" | tail -n 1; }
# scene:reference:sky:size (the references' environments: none but the window rooms' constant white
# sky; the hollow room also under its sun alone, where the connections' trial keeps them)
for entry in cornell-box:cornell_path_64:none:64 caustic:caustic_floor_64:none:64 glossy-spheres:glossy_path_64:none:64 \
             mirror-caustic:mirror_path_64:none:64 point-room:point_room_path_64:none:64 window-room:window_room_64:white:64 \
             window-hollow:window_hollow_64:white:64 window-hollow:window_hollow_128:white:128 \
             window-hollow:window_hollow_sun_64:none:64 \
             dielectric-spheres:dielectric_spheres_path_64:none:64; do
    scene=${entry%%:*}; rest=${entry#*:}; ref=tests/ref/${rest%%:*}.exr; rest=${rest#*:}; sky=${rest%%:*}; size=${rest#*:}
    case " ${BENCH_SCENES:-$scene} " in *" $scene "*) ;; *) continue ;; esac
    [ -f "$ref" ] || { echo "bench default_vs_pathtrace scene=$scene skipped ($ref missing)"; continue; }
    for seed in $seeds; do
        for mode in progressive pathtrace; do
            /usr/bin/time -f '%U %S' -o "$tmp/$mode.cpu" ./pmview "scenes/$scene.gltf" --sky "$sky" --width "$size" --height "$size" --time "$seconds" --seed "$seed" --quiet \
                --mode "$mode" --reference "$ref" --stats --snapshot "$tmp/$mode.exr" >"$tmp/$mode" 2>&1 ||
                { echo "bench default_vs_pathtrace: pmview failed on $scene ($mode)"; cat "$tmp/$mode"; exit 1; }
            grep '^stat error' "$tmp/$mode" | tail -n 1 >"$tmp/$mode.error"
        done
        grep '^stat progressive ' "$tmp/progressive" >"$tmp/progressive.stats"
        d=$(field relmse "$tmp/progressive.error"); p=$(field relmse "$tmp/pathtrace.error")
        source=$(field gather_source "$tmp/progressive.stats"); trial=$(field connect_trial "$tmp/progressive.stats")
        cd_=$(awk '{ printf "%.2f", $1 + $2 }' "$tmp/progressive.cpu"); cp_=$(awk '{ printf "%.2f", $1 + $2 }' "$tmp/pathtrace.cpu")
        printf 'bench default_vs_pathtrace scene=%s sky=%s connect_trial=%s size=%s seed=%s seconds=%s relmse_default=%s relmse_pathtrace=%s ratio=%s iterations_default=%s iterations_pathtrace=%s gather_source=%s cpu_default=%s cpu_pathtrace=%s ratio_equal_cpu=%s\n' \
            "$scene" "$sky" "${trial:--1}" "$size" "$seed" "$seconds" "$d" "$p" "$(python3 -c "import sys; a, b = float(sys.argv[1] or 0), float(sys.argv[2] or 0); print(\"%.3f\" % (a / b if b > 0 else 0))" "$d" "$p")" \
            "$(field iterations "$tmp/progressive.error")" "$(field iterations "$tmp/pathtrace.error")" "${source:-none}" "$cd_" "$cp_" \
            "$(python3 -c "import sys; a, b = [float(x or 0) for x in sys.argv[1:3]], [float(x or 0) for x in sys.argv[3:5]]; print(\"%.3f\" % (a[0] * a[1] / (b[0] * b[1]) if b[0] * b[1] > 0 else 0))" "$d" "$cd_" "$p" "$cp_")"
    done
done

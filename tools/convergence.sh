#!/bin/sh
# convergence.sh: renders the shipped scenes with every method for a fixed time, logging error against time, and writes the report docs/convergence.md (`make convergence`).
#
#   make convergence            every method on the four scenes, 64 s each (about 75 minutes)
#   make convergence QUICK=1    four methods, 12 s each (about 3 minutes)
#
# Each run is one pmview process with --time T --log run.csv --reference REF.exr: the log has a
# row per iteration (per doubling past 64), so one run gives the whole curve from its first
# iteration to T, and its last image is the equal-time image of the grid. The runs go one after
# another on all cores (a second run beside one would halve both). Settings from the environment
# (for tests and partial runs): CONV_SCENES, CONV_METHODS, CONV_SECONDS, CONV_OUT (folder that
# receives convergence.md and convergence/), CONV_THREADS, CONV_COMMAND (the command the report
# names as the one that made it).
cd "$(dirname "$0")/.." || exit 1

all_methods="ppm-a0.5-gather ppm-a0.67-gather ppm-a0.9-gather ppm-a0.5-photons ppm-a0.67-photons ppm-a0.9-photons ppm-unguided ppm-unclipped-unguided
 classic-100k-gather-disc classic-100k-gather-cone classic-100k-photons-disc classic-100k-photons-cone
 classic-1M-gather-disc classic-1M-gather-cone classic-1M-photons-disc classic-1M-photons-cone pt"
if [ "$QUICK" = 1 ]; then
    methods=${CONV_METHODS:-ppm-a0.67-gather ppm-a0.67-photons classic-100k-gather-disc pt}
    seconds=${CONV_SECONDS:-12}
    command=${CONV_COMMAND:-make convergence QUICK=1}
else
    methods=${CONV_METHODS:-$all_methods}
    seconds=${CONV_SECONDS:-64}
    command=${CONV_COMMAND:-make convergence}
fi
scenes=${CONV_SCENES:-cornell caustic mirror window}
out=${CONV_OUT:-docs}
threads=${CONV_THREADS:-$(nproc)}
pmview=${PMVIEW:-./pmview}
error_map=${ERROR_MAP:-build/rel/error_map}

die() { echo "convergence: error: $*" >&2; exit 1; }
[ -x "$pmview" ] || die "$pmview is missing (make pmview)"
[ -x "$error_map" ] || die "$error_map is missing (make build/rel/error_map)"
command -v gnuplot >/dev/null || die "gnuplot is missing (sh tools/install-deps.sh convergence)"

# scene name -> file and reference (64x64, every one made by Mitsuba 3: tests/ref/README.md)
scene_file() {
    case $1 in
        cornell) echo scenes/cornell-box.gltf ;;
        caustic) echo scenes/caustic.gltf ;;
        mirror) echo scenes/mirror-caustic.gltf ;;
        window) echo scenes/window-room.gltf ;;
        *) return 1 ;;
    esac
}
scene_ref() {
    case $1 in
        cornell) echo tests/ref/cornell_path_64.exr ;;
        caustic) echo tests/ref/caustic_floor_64.exr ;;
        mirror) echo tests/ref/mirror_path_64.exr ;;
        window) echo tests/ref/window_room_64.exr ;;
        *) return 1 ;;
    esac
}
# scene name -> exposure of the grid's images in stops (the caustic scene's lit floor is far above 1)
scene_ev() {
    case $1 in
        caustic) echo -3 ;;
        *) echo 0 ;;
    esac
}
# scene name -> its environment (the window room's reference has Mitsuba's constant sky of radiance 1)
scene_sky() {
    case $1 in
        window) echo white ;;
        *) echo none ;;
    esac
}
# method name -> pmview options (alpha 2/3 is the default; the classic maps hold a fixed number of
# photons, so the curve is the eye pass's convergence over maps built once)
method_args() {
    case $1 in
        ppm-a0.5-gather) echo "--alpha 0.5 --indirect gather" ;;
        ppm-a0.67-gather) echo "--indirect gather" ;;
        ppm-a0.9-gather) echo "--alpha 0.9 --indirect gather" ;;
        ppm-a0.5-photons) echo "--alpha 0.5 --indirect photons" ;;
        ppm-a0.67-photons) echo "--indirect photons" ;;
        ppm-a0.9-photons) echo "--alpha 0.9 --indirect photons" ;;
        ppm-unguided) echo "--guide off" ;;
        ppm-unclipped-unguided) echo "--clip off --guide off" ;;
        classic-100k-*|classic-1M-*)
            n=$(echo "$1" | cut -d- -f2); ind=$(echo "$1" | cut -d- -f3); kernel=$(echo "$1" | cut -d- -f4)
            case $n in 100k) n=100000 ;; 1M) n=1000000 ;; esac
            case $ind in gather|photons) ;; *) return 1 ;; esac
            case $kernel in disc|cone) ;; *) return 1 ;; esac
            echo "--mode classic --photons $n --indirect $ind --kernel $kernel" ;;
        pt) echo "--mode pathtrace" ;;
        *) return 1 ;;
    esac
}
for s in $scenes; do
    f=$(scene_file "$s") || die "unknown scene $s"
    r=$(scene_ref "$s") || die "unknown scene $s"
    [ -f "$f" ] && [ -f "$r" ] || die "$f or $r is missing"
done
for m in $methods; do method_args "$m" >/dev/null || die "unknown method $m"; done

dir=$out/convergence
mkdir -p "$dir/data" || die "cannot create $dir"
rm -f "$dir"/*.png "$dir"/data/*.csv "$dir"/*.gp "$dir"/runs.tsv
tmp=$(mktemp -d) || die "mktemp"
trap 'rm -rf "$tmp"' EXIT
runs=$dir/runs.tsv
printf 'scene\tmethod\toptions\tbudget\titerations\twall\tload\tev\n' >"$runs"
count=0; total=$(( $(echo $scenes | wc -w) * $(echo $methods | wc -w) ))
started=$(date -u '+%Y-%m-%d %H:%M UTC')
"$error_map" --colorbar "$dir/colorbar.png" || die "error_map failed"
for s in $scenes; do
    file=$(scene_file "$s"); ref=$(scene_ref "$s")
    ev=$(scene_ev "$s")
    "$error_map" --image "$ref" "$dir/${s}_reference.png" 3 "$ev" || die "error_map failed on $ref"
    for m in $methods; do
        count=$((count + 1))
        args=$(method_args "$m")
        load=$(cut -d' ' -f1 /proc/loadavg)
        t0=$(date +%s)
        # the environment the reference has (none but the window room's; the defaults agree, this makes sure)
        # shellcheck disable=SC2086
        "$pmview" "$file" $args --sky "$(scene_sky "$s")" --width 64 --height 64 --time "$seconds" --threads "$threads" --seed 1 --quiet \
            --snapshot "$tmp/$s-$m.exr" --reference "$ref" --log "$dir/data/$s-$m.csv" >"$tmp/out" 2>"$tmp/err" ||
            { cat "$tmp/err" >&2; die "pmview failed: $file $args"; }
        wall=$(( $(date +%s) - t0 ))
        it=$(sed -n 's/^stat error iterations=\([0-9]*\).*/\1/p' "$tmp/out")
        "$error_map" "$tmp/$s-$m.exr" "$ref" "$dir/$s-$m.png" "$dir/$s-$m-error.png" 3 "$ev" >"$tmp/em" || die "error_map failed"
        printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$s" "$m" "$args" "$seconds" "$it" "$wall" "$load" "$ev" >>"$runs"
        printf 'convergence: %d/%d %-8s %-26s %5s iterations, %s\n' "$count" "$total" "$s" "$m" "$it" "$(cat "$tmp/em")"
    done
done
python3 tools/convergence_report.py --dir "$dir" --report "$out/convergence.md" --seconds "$seconds" \
    --command "$command" --cores "$(nproc)" --threads "$threads" --started "$started" \
    --finished "$(date -u '+%Y-%m-%d %H:%M UTC')" || die "the report failed"
echo "convergence: wrote $out/convergence.md"

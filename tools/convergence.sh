#!/bin/sh
# convergence.sh: renders the reference scenes with each method for a fixed time at 64x64 and 128x128, logging error against time, and writes the report docs/convergence.md (`make convergence`).
#
#   make convergence            5 methods on 6 scenes at 64x64 and 128x128, 24 s a run: 60 runs,
#                               24 min of rendering, about 26 min with each run's start and images
#   make convergence QUICK=1    the default and the path tracer, 64x64, 8 s a run (about 2 minutes)
#   CONV_METHODS=all make convergence   every method below (20 methods: about 1 h 45 min at 24 s)
#
# Each run is one pmview process with --time T --log run.csv --reference REF.exr: the log has a
# row per iteration (per doubling past 64), so one run gives the whole curve from its first
# iteration to T, and its last image is the equal-time image of the grid. The runs go one after
# another on all cores (a second run beside one would halve both). A scene without a reference at
# a size is left out at that size (the report says so). Settings from the environment (for tests
# and partial runs): CONV_SCENES, CONV_METHODS (names, or all), CONV_SIZES (default "64 128"),
# CONV_SECONDS, CONV_OUT (folder that receives convergence.md and convergence/), CONV_THREADS,
# CONV_COMMAND (the command the report names as the one that made it).
cd "$(dirname "$0")/.." || exit 1

lean_methods="default ppm-photons ppm-direct classic-1M-gather-disc pt"
all_methods="default ppm-photons ppm-direct ppm-a0.5-gather ppm-a0.67-gather ppm-a0.9-gather ppm-a0.5-photons ppm-a0.67-photons
 ppm-a0.9-photons ppm-unguided ppm-unclipped-unguided classic-100k-gather-disc classic-100k-gather-cone
 classic-100k-photons-disc classic-100k-photons-cone classic-1M-gather-disc classic-1M-gather-cone
 classic-1M-photons-disc classic-1M-photons-cone pt"
if [ "$QUICK" = 1 ]; then
    methods=${CONV_METHODS:-default pt}
    sizes=${CONV_SIZES:-64}
    seconds=${CONV_SECONDS:-8}
    command=${CONV_COMMAND:-make convergence QUICK=1}
else
    methods=${CONV_METHODS:-$lean_methods}
    sizes=${CONV_SIZES:-64 128}
    seconds=${CONV_SECONDS:-24}
    command=${CONV_COMMAND:-make convergence}
fi
[ "$methods" = all ] && methods=$all_methods
scenes=${CONV_SCENES:-cornell caustic mirror window window-hollow point-room}
out=${CONV_OUT:-docs}
threads=${CONV_THREADS:-$(nproc)}
pmview=${PMVIEW:-./pmview}
error_map=${ERROR_MAP:-build/rel/error_map}

die() { echo "convergence: error: $*" >&2; exit 1; }
[ -x "$pmview" ] || die "$pmview is missing (make pmview)"
[ -x "$error_map" ] || die "$error_map is missing (make build/rel/error_map)"
command -v gnuplot >/dev/null || die "gnuplot is missing (sh tools/install-deps.sh convergence)"

# scene name -> file, and its reference at a size (every one made by Mitsuba 3: tests/ref/README.md)
scene_file() {
    case $1 in
        cornell) echo scenes/cornell-box.gltf ;;
        caustic) echo scenes/caustic.gltf ;;
        mirror) echo scenes/mirror-caustic.gltf ;;
        window) echo scenes/window-room.gltf ;;
        window-hollow) echo scenes/window-hollow.gltf ;;
        point-room) echo scenes/point-room.gltf ;;
        *) return 1 ;;
    esac
}
scene_ref() {
    case $1 in
        cornell) echo tests/ref/cornell_path_$2.exr ;;
        caustic) echo tests/ref/caustic_floor_$2.exr ;;
        mirror) echo tests/ref/mirror_path_$2.exr ;;
        window) echo tests/ref/window_room_$2.exr ;;
        window-hollow) echo tests/ref/window_hollow_$2.exr ;;
        point-room) echo tests/ref/point_room_path_$2.exr ;;
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
# scene name -> its environment (the window rooms' references have Mitsuba's constant sky of radiance 1)
scene_sky() {
    case $1 in
        window|window-hollow) echo white ;;
        *) echo none ;;
    esac
}
# method name -> pmview options (default: none at all, so the program's own choices, the final
# gather's source among them, are what is measured; alpha 2/3 is the default; the classic maps hold
# a fixed number of photons, so the curve is the eye pass's convergence over maps built once)
method_args() {
    case $1 in
        default) echo "" ;;
        ppm-photons) echo "--gather photons" ;;
        ppm-direct) echo "--indirect photons" ;;
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
    [ -f "$f" ] || die "$f is missing"
done
for m in $methods; do method_args "$m" >/dev/null || die "unknown method $m"; done
for z in $sizes; do
    case $z in ''|*[!0-9]*) die "size $z is not a number" ;; esac
done

dir=$out/convergence
mkdir -p "$dir" || die "cannot create $dir"
# what an earlier run wrote, in this layout (a folder a size) and the one before (one folder)
rm -f "$dir"/*.png "$dir"/data/*.csv "$dir"/*.gp "$dir"/runs.tsv
for z in "$dir"/[0-9]*; do
    [ -f "$z/runs.tsv" ] && rm -rf "$z"
done
rmdir "$dir/data" 2>/dev/null
tmp=$(mktemp -d) || die "mktemp"
trap 'rm -rf "$tmp"' EXIT
count=0; total=0
for z in $sizes; do
    for s in $scenes; do [ -f "$(scene_ref "$s" "$z")" ] && total=$((total + $(echo $methods | wc -w))); done
done
started=$(date -u '+%Y-%m-%d %H:%M UTC')
"$error_map" --colorbar "$dir/colorbar.png" || die "error_map failed"
for z in $sizes; do
    zdir=$dir/$z
    mkdir -p "$zdir/data" || die "cannot create $zdir"
    runs=$zdir/runs.tsv
    printf 'scene\tmethod\toptions\tbudget\titerations\twall\tload\tev\treference\n' >"$runs"
    for s in $scenes; do
        file=$(scene_file "$s"); ref=$(scene_ref "$s" "$z")
        if [ ! -f "$ref" ]; then
            echo "convergence: $s left out at ${z}x$z: no reference $ref"
            printf '%s\t-\t-\t-\t-\t-\t-\t-\t%s\n' "$s" "$ref" >>"$runs"
            continue
        fi
        ev=$(scene_ev "$s")
        "$error_map" --image "$ref" "$zdir/${s}_reference.png" 3 "$ev" || die "error_map failed on $ref"
        for m in $methods; do
            count=$((count + 1))
            args=$(method_args "$m")
            load=$(cut -d' ' -f1 /proc/loadavg)
            t0=$(date +%s)
            # the environment the reference has (white for the window rooms; the defaults agree, this makes sure)
            # shellcheck disable=SC2086
            "$pmview" "$file" $args --sky "$(scene_sky "$s")" --width "$z" --height "$z" --time "$seconds" --threads "$threads" \
                --seed 1 --quiet --snapshot "$tmp/$s-$m.exr" --reference "$ref" --log "$zdir/data/$s-$m.csv" >"$tmp/out" 2>"$tmp/err" ||
                { cat "$tmp/err" >&2; die "pmview failed: $file $args at ${z}x$z"; }
            wall=$(( $(date +%s) - t0 ))
            it=$(sed -n 's/^stat error iterations=\([0-9]*\).*/\1/p' "$tmp/out")
            "$error_map" "$tmp/$s-$m.exr" "$ref" "$zdir/$s-$m.png" "$zdir/$s-$m-error.png" 3 "$ev" >"$tmp/em" ||
                die "error_map failed"
            printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$s" "$m" "$args" "$seconds" "$it" "$wall" "$load" "$ev" "$ref" >>"$runs"
            printf 'convergence: %d/%d %4s %-13s %-23s %5s iterations, %s\n' "$count" "$total" "${z}px" "$s" "$m" "$it" "$(cat "$tmp/em")"
        done
    done
done
# shellcheck disable=SC2086
python3 tools/convergence_report.py --dir "$dir" --sizes $sizes --report "$out/convergence.md" --seconds "$seconds" \
    --command "$command" --cores "$(nproc)" --threads "$threads" --started "$started" \
    --finished "$(date -u '+%Y-%m-%d %H:%M UTC')" || die "the report failed"
echo "convergence: wrote $out/convergence.md"

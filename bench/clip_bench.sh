#!/bin/sh
# clip_bench.sh: what clipped estimates (clip.h) cost on every shipped scene: time for a fixed number of iterations and equal-time error against the scene's reference, clip on over clip off, as ratios of one run ("bench clip" lines).
#
# Time: each scene renders ITERATIONS iterations at 256x256 (and `make run`'s scene, the Cornell
# box, 64 iterations at its default 512x512) with --clip on and --clip off, alternating, twice;
# the line gives each run's seconds (the snapshot's own figure: set-up, photons, eye passes and
# gather, not the file), gather_seconds and clip_rays, and time_on_over_off from the sums; and
# the CPU seconds each whole run took (user + system, /usr/bin/time), cpu_on_over_off from their
# sums: on a shared machine the steadier of the two.
# Error: each scene with a reference in tests/ref renders 64x64 for the same wall time
# (BENCH_SECONDS, default 10) both ways; relmse_on_over_off above 1 means clipping costs error
# at equal time (on scenes where discs meet walls it may also mend a bias). Every figure was
# taken on the same machine in the same run: read the ratios, not the seconds.
cd "$(dirname "$0")/.." || exit 1
seconds=${BENCH_SECONDS:-10}
iterations=${BENCH_ITERATIONS:-16}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
field() { sed -n "s/.*$1=\([^ ]*\).*/\1/p" "$2" | tail -n 1; }
# the seconds pmview reports for its snapshot ("wrote FILE (WxH, N iterations, S s)")
# user + system CPU seconds /usr/bin/time wrote: on a loaded machine the CPU a run took moves far less than its wall time
cpu() { awk '{print $1 + $2}' "$1" 2>/dev/null; }
render_seconds() { sed -n 's/.*iterations, \([0-9.]*\) s).*/\1/p' "$1" | tail -n 1; }

# scene, extra options, reference (or -)
# (the references have no sky but the window rooms', Mitsuba's constant sky of radiance 1)
scenes="scenes/cornell-box.gltf:--sky none:tests/ref/cornell_path_64.exr
scenes/caustic.gltf:--sky none:tests/ref/caustic_floor_64.exr
scenes/glossy-spheres.gltf:--sky none:tests/ref/glossy_path_64.exr
scenes/mirror-caustic.gltf:--sky none:tests/ref/mirror_path_64.exr
scenes/point-room.gltf:--sky none:tests/ref/point_room_path_64.exr
scenes/window-room.gltf:--sky white:tests/ref/window_room_64.exr
scenes/window-hollow.gltf:--sky white:tests/ref/window_hollow_64.exr
scenes/dielectric-spheres.gltf:--sky none:tests/ref/dielectric_spheres_path_64.exr
scenes/layered-spheres.gltf::-"

timing() { # name scene size iterations extra
    name=$1 scene=$2 size=$3 count=$4 extra=$5
    for c in on off; do : >"$tmp/$c.sum"; done
    for round in 1 2; do
        for c in on off; do
            # shellcheck disable=SC2086
            /usr/bin/time -f "%U %S" -o "$tmp/$c.$round.cpu" ./pmview "$scene" $extra --width "$size" --height "$size" --iterations "$count" --clip $c --stats \
                --snapshot "$tmp/t.png" >"$tmp/$c.$round" 2>&1 || { echo "bench clip: pmview failed on $scene"; cat "$tmp/$c.$round"; exit 1; }
        done
    done
    python3 - "$name" "$scene" "$size" "$count" \
        "$(render_seconds "$tmp/on.1")" "$(render_seconds "$tmp/on.2")" "$(render_seconds "$tmp/off.1")" "$(render_seconds "$tmp/off.2")" \
        "$(field gather_seconds "$tmp/on.1")" "$(field gather_seconds "$tmp/on.2")" "$(field gather_seconds "$tmp/off.1")" "$(field gather_seconds "$tmp/off.2")" \
        "$(field clip_rays "$tmp/on.1")" "$(cpu "$tmp/on.1.cpu")" "$(cpu "$tmp/on.2.cpu")" "$(cpu "$tmp/off.1.cpu")" "$(cpu "$tmp/off.2.cpu")" <<'EOF'
import sys
name, scene, size, count = sys.argv[1:5]
on1, on2, off1, off2, gon1, gon2, goff1, goff2 = (float(x or 0) for x in sys.argv[5:13])
rays = sys.argv[13] or "0"
con1, con2, coff1, coff2 = (float(x or 0) for x in sys.argv[14:18])
print("bench clip_time case=%s scene=%s size=%s iterations=%s seconds_on=%.2f,%.2f seconds_off=%.2f,%.2f gather_seconds_on=%.2f,%.2f gather_seconds_off=%.2f,%.2f clip_rays=%s time_on_over_off=%.3f gather_on_over_off=%.2f cpu_seconds_on=%.2f,%.2f cpu_seconds_off=%.2f,%.2f cpu_on_over_off=%.3f"
      % (name, scene, size, count, on1, on2, off1, off2, gon1, gon2, goff1, goff2, rays,
         (on1 + on2) / max(off1 + off2, 1e-9), (gon1 + gon2) / max(goff1 + goff2, 1e-9),
         con1, con2, coff1, coff2, (con1 + con2) / max(coff1 + coff2, 1e-9)))
EOF
}

timing make_run scenes/cornell-box.gltf 512 64 ""
echo "$scenes" | while IFS=: read -r scene extra ref; do
    timing "$(basename "$scene" .gltf)" "$scene" 256 "$iterations" "$extra"
    [ "$ref" = - ] || [ ! -f "$ref" ] && continue
    for c in on off; do
        # shellcheck disable=SC2086
        ./pmview "$scene" $extra --width 64 --height 64 --time "$seconds" --clip $c --quiet --reference "$ref" --stats \
            --snapshot "$tmp/e.exr" >"$tmp/e.$c" 2>&1 || { echo "bench clip: pmview failed on $scene"; exit 1; }
        grep '^stat error' "$tmp/e.$c" | tail -n 1 >"$tmp/e.$c.error"
    done
    python3 - "$(basename "$scene" .gltf)" "$seconds" "$(field iterations "$tmp/e.on.error")" "$(field iterations "$tmp/e.off.error")" \
        "$(field relmse "$tmp/e.on.error")" "$(field relmse "$tmp/e.off.error")" <<'EOF'
import sys
name, seconds, it_on, it_off = sys.argv[1:5]
on, off = float(sys.argv[5]), float(sys.argv[6])
print("bench clip_error scene=%s seconds=%s iterations_on=%s iterations_off=%s relmse_on=%.5f relmse_off=%.5f relmse_on_over_off=%.2f"
      % (name, seconds, it_on, it_off, on, off, on / max(off, 1e-12)))
EOF
done

#!/bin/sh
# window_motion_bench.sh: large scenes under Xvfb at 640x480: process start to first frame and first image (default scene), new images per second during a camera drag (1M triangles), load, BVH, first frame and first image of an 8M-triangle scene.
#
# The scenes come from bench/big_scene.py into a temp folder. A drag is one xdotool command:
# the button held and the pointer moved 3 pixels every 20 ms for 3 s, as a hand drags; pmview's
# `stat window motion_images_per_second` counts the new images of a moved camera that reached the
# screen meanwhile (frames_per_second counts redraws of old ones too).
cd "$(dirname "$0")/.." || exit 1
# PMVIEW: the binary measured (another build's, for a before-and-after)
PMVIEW=${PMVIEW:-./pmview}
export PMVIEW
for t in xvfb-run xdotool python3; do command -v $t >/dev/null 2>&1 || { echo "bench window_motion: skipped ($t missing)"; exit 0; }; done
# the first python3 with numpy: a user's pyenv may shadow Debian's
py=python3
python3 -c "import numpy" 2>/dev/null || py=/usr/bin/python3
$py -c "import numpy" 2>/dev/null || { echo "bench window_motion: skipped (python3 numpy missing)"; exit 0; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# one drag: 150 steps of 3 pixels, 20 ms apart
drag=""
i=0
while [ $i -lt 150 ]; do drag="$drag mousemove_relative -- 3 0 sleep 0.02"; i=$((i + 1)); done
cat >"$tmp/inner.sh" <<EOF
# under xvfb-run: "\$1" the scene, "\$2" the log, "\$3" drags to make (0: Esc once the first image is up)
"\$PMVIEW" "\$1" --width 640 --height 480 --threads 2 --stats >"\$2" 2>&1 &
pid=\$!
wid=""; i=0
while [ -z "\$wid" ] && [ \$i -lt 1200 ]; do wid=\$(xdotool search --name '^pmview' 2>/dev/null | head -n 1); i=\$((i + 1)); sleep 0.05; done
# the first full iteration is on screen once the status line has left the preview
i=0
while [ \$i -lt 1200 ] && kill -0 \$pid 2>/dev/null; do
    xdotool getwindowname "\$wid" 2>/dev/null | grep -q ' it ' && ! xdotool getwindowname "\$wid" | grep -q preview && break
    i=\$((i + 1)); sleep 0.05
done
k=0
while [ \$k -lt "\$3" ]; do
    xdotool mousemove --window "\$wid" 100 240 mousedown 1 $drag mouseup 1
    sleep 1
    k=\$((k + 1))
done
xdotool windowfocus --sync "\$wid"; xdotool key Escape
wait \$pid
EOF
run() { timeout 180 xvfb-run -a -s "-screen 0 1024x768x24 -noreset" sh "$tmp/inner.sh" "$1" "$tmp/log" "$2" >/dev/null 2>&1; }
field() { awk -v stage="$1" -v key="$2" '$1 == "stat" && $2 == stage { for (i = 3; i <= NF; i++) if (index($i, key "=") == 1) { print substr($i, length(key) + 2); exit } }' "$tmp/log"; }

# process start to the first frame (the window, cleared, its title showing the set-up's stage)
# and to the first image (the session's first preview on screen), each the best of 3 (the first
# run also pays for cold caches)
best=""; best_image=""; best_setup=""
smaller() { [ -z "$2" ] || awk "BEGIN { exit !($1 < $2) }"; }
for k in 1 2 3; do
    run scenes/cornell-box.gltf 0
    f=$(field window first_frame_seconds); g=$(field window first_image_seconds); h=$(field window setup_seconds)
    smaller "$f" "$best" && best=$f
    smaller "$g" "$best_image" && best_image=$g
    smaller "$h" "$best_setup" && best_setup=$h
done
# first_frame_seconds counts from main(); what comes before it (exec, the dynamic loader
# relocating libOSMesa's LLVM, libmpi, Embree; static constructors) and the exit after it are
# what `pmview --help` costs, best of 7
startup=$(python3 -c '
import os, subprocess, time
best = 1e9
for _ in range(7):
    t = time.perf_counter()
    subprocess.run([os.environ["PMVIEW"], "--help"], stdout=subprocess.DEVNULL)
    best = min(best, time.perf_counter() - t)
print("%.4f" % best)')
echo "bench window_motion scene=scenes/cornell-box.gltf first_frame_seconds=$best goal_seconds=0.100 exec_to_exit_of_help_seconds=$startup first_frame_from_exec_seconds=$(awk "BEGIN { printf \"%.4f\", $best + $startup }") load_seconds=$(field load seconds) bvh_seconds=$(field bvh seconds) first_image_seconds=$best_image setup_seconds=$best_setup"

$py bench/big_scene.py "$tmp/big1.glb" 1 >/dev/null || exit 1
run "$tmp/big1.glb" 2
echo "bench window_motion scene=heightfield-1M triangles=$(field load triangles) size=640x480 motion_images_per_second=$(field window motion_images_per_second) goal=24 motion_seconds=$(field window motion_seconds) frames_per_second=$(field window frames_per_second) restart_to_image_seconds=$(field window restart_to_image_seconds)"
rm -f "$tmp/big1.glb"

# 8M triangles take about 2 GB resident; 4M where the machine has less than 4 GB available
millions=8
avail=$(awk '/MemAvailable/ {print int($2 / 1048576)}' /proc/meminfo 2>/dev/null)
[ -n "$avail" ] && [ "$avail" -lt 4 ] && millions=4
$py bench/big_scene.py "$tmp/big.glb" $millions >/dev/null || exit 1
run "$tmp/big.glb" 0
echo "bench window_motion scene=heightfield-${millions}M triangles=$(field load triangles) load_seconds=$(field load seconds) bvh_seconds=$(field bvh seconds) first_frame_seconds=$(field window first_frame_seconds) setup_seconds=$(field window setup_seconds) first_image_seconds=$(field window first_image_seconds) first_image_seconds_per_million_triangles=$(awk -v s="$(field window first_image_seconds)" -v t="$(field load triangles)" 'BEGIN { if (t > 0) printf "%.3f", s / (t / 1e6) }') peak_rss_bytes=$(field memory peak_rss_bytes)"

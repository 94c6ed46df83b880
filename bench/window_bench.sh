#!/bin/sh
# window_bench.sh: the window's responsiveness under Xvfb at 640x480: time from process start to the first frame and the first image, UI loop and frame rates while rendering, time from a camera drag to the first new image ("stat window" line).
cd "$(dirname "$0")/.." || exit 1
for t in xvfb-run xdotool; do command -v $t >/dev/null 2>&1 || { echo "bench window: skipped ($t missing)"; exit 0; }; done
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cat >"$tmp/inner.sh" <<'EOF'
./pmview "$1" --width 640 --height 480 --threads 2 --stats >"$2" 2>&1 &
pid=$!
wid=""; i=0
while [ -z "$wid" ] && [ $i -lt 300 ]; do wid=$(xdotool search --name '^pmview' 2>/dev/null | head -n 1); i=$((i + 1)); sleep 0.05; done
sleep 3
for k in 1 2 3 4 5; do
    xdotool mousemove --window "$wid" 200 200; xdotool mousedown 1; sleep 0.05
    xdotool mousemove --window "$wid" 230 200; sleep 0.05; xdotool mouseup 1; sleep 1
done
xdotool windowfocus --sync "$wid"; xdotool key Escape
wait $pid
EOF
for scene in scenes/cornell-box.gltf scenes/caustic.gltf; do
    timeout 120 xvfb-run -a -s "-screen 0 1024x768x24 -noreset" sh "$tmp/inner.sh" "$scene" "$tmp/log" >/dev/null 2>&1
    line=$(grep '^stat window' "$tmp/log")
    echo "bench window scene=$scene ${line#stat window }"
done

#!/bin/sh
# run-default.sh: what `make run` does after building: a window when DISPLAY is set, else an offscreen snapshot whose path it prints.
scene=${1:-scenes/cornell-box.gltf}
if [ -n "$DISPLAY" ]; then
    exec ./pmview "$scene"
fi
mkdir -p build
out="build/$(basename "$scene" | sed 's/\.[^.]*$//').png"
./pmview "$scene" --snapshot "$out" || exit $?
echo "snapshot: $(pwd)/$out"

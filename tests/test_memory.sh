#!/bin/sh
# test_memory.sh: the progressive mode runs in constant memory (peak RSS after 2,000 iterations within 5% of 100), and --max-memory bounds the whole run: textures, film and output buffers together, refused before they are spent; a file of 10^5 lights is refused by its JSON document's size; the peak forecast holds within 25% (optimised build: ASan's quarantine would hide the growth measured).
cd "$(dirname "$0")/.." || exit 1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
checks=0; fails=0
fail() { fails=$((fails + 1)); echo "FAIL: $*"; }

# 2,000 photons a pass: what must stay flat is the per-iteration structures, whatever their size.
# 16x16 pixels: the eye passes take most of the time, and the 2,000 iterations hold as many photon
# passes (about 260) as at 32x32, at a third of the processor time
rss() { # iterations -> peak RSS bytes
    ./pmview scenes/cornell-box.gltf --width 16 --height 16 --photons 2000 --iterations "$1" --snapshot "$tmp/m.exr" --stats |
        sed -n 's/^stat memory peak_rss_bytes=\([0-9]*\).*/\1/p'
}
a=$(rss 100)
b=$(rss 2000)
echo "peak RSS: $a bytes after 100 iterations, $b after 2000"
checks=$((checks + 1))
if [ -z "$a" ] || [ -z "$b" ]; then fail "no stat memory line"
elif [ "$b" -gt $((a + a / 20)) ]; then fail "peak RSS grew by more than 5% from 100 to 2000 iterations"; fi

# run LIMIT ARGS...: pmview under --max-memory LIMIT (MiB); $rc, $kb (peak RSS, KiB), $tmp/err
run() {
    limit=$1; shift
    /usr/bin/time -f %M -o "$tmp/rss" ./pmview "$@" --quiet --max-memory "${limit}M" >"$tmp/out" 2>"$tmp/err"
    rc=$?
    kb=$(tail -n 1 "$tmp/rss")
}
# refused DESCRIPTION PATTERN: exit 1 and one error line matching PATTERN that names what was already committed and --max-memory
refused() {
    checks=$((checks + 1))
    if [ "$rc" -ne 1 ] || [ "$(wc -l < "$tmp/err")" -ne 1 ] || ! grep -q "^pmview: error: .*out of memory ($2" "$tmp/err" ||
       ! grep -q "bytes already committed, over the limit of [0-9]* bytes; see --max-memory" "$tmp/err"; then
        fail "$1: want exit 1 and one line \"out of memory ($2...\" with the committed bytes and --max-memory, got exit $rc:"
        cat "$tmp/err"
    fi
}
# within DESCRIPTION LIMIT: the run's peak RSS above the process's own (a tiny run's) is within LIMIT MiB
within() {
    checks=$((checks + 1))
    above=$(( (kb - base_kb) / 1024 ))
    echo "$1: exit $rc, peak RSS $((kb / 1024)) MiB, $above MiB above a tiny run's, under --max-memory ${2}M"
    [ "$above" -le "$2" ] || fail "$1: $above MiB above a tiny run's, more than --max-memory ${2}M"
}

# textures: the limit covers their sum (each fits alone, three do not), and an image is refused
# from its header before its decoding is spent: a real 2048-square one (16 MiB decoded, 32 while
# stb's copy is made) and one whose header alone claims 16384 x 16384
# (texture_scene.py's writer, the five scenes from one Python, whose start costs more than writing one)
python3 -B - "$tmp" <<'PY'
import sys
sys.path.insert(0, "tests")
from texture_scene import write
for name, sizes in (("one", [1024]), ("three", [1024] * 3), ("tiny", [64]), ("big", [2048]), ("claims", ["claim:16384"]),
                    ("deep", ["deep:1024"] * 3)):
    write("%s/%s.gltf" % (sys.argv[1], name), sizes)
PY
run 18 "$tmp/tiny.gltf" --width 8 --iterations 1 --snapshot "$tmp/x.exr"
base_kb=$kb
checks=$((checks + 1)); [ "$rc" -eq 0 ] || { fail "a 64-square texture: exit $rc"; cat "$tmp/err"; }
run 18 "$tmp/one.gltf" --width 8 --iterations 1 --snapshot "$tmp/x.exr"
checks=$((checks + 1)); [ "$rc" -eq 0 ] || { fail "one 1024-square texture under 18 MiB: exit $rc"; cat "$tmp/err"; }
run 18 "$tmp/three.gltf" --width 8 --iterations 1 --snapshot "$tmp/x.exr"
refused "three 1024-square textures under 18 MiB" "texture, 4194304 bytes, with "
run 64 "$tmp/three.gltf" --width 8 --iterations 1 --snapshot "$tmp/x.exr"
checks=$((checks + 1)); [ "$rc" -eq 0 ] || { fail "three 1024-square textures under 64 MiB: exit $rc"; cat "$tmp/err"; }
run 16 "$tmp/big.gltf" --width 8 --iterations 1 --snapshot "$tmp/x.exr"
refused "a 2048-square texture under 16 MiB" "decoded image, 33554432 bytes, with "
within "a 2048-square texture refused" 16
# images decode side by side, each holding a second copy of its texels until it is done: three of
# 16-bit channels (8 MiB each, 16 while decoded, then ignored) at once would need 48 MiB, one after
# another 32; under 36 MiB those waiting are decoded first and the third admitted after them, and
# under 30 the refusal is the third's after the first two (16 MiB committed), as one at a time
run 36 "$tmp/deep.gltf" --width 8 --iterations 1 --snapshot "$tmp/x.exr"
checks=$((checks + 1)); [ "$rc" -eq 0 ] || { fail "three 16-bit 1024-square images under 36 MiB: exit $rc"; cat "$tmp/err"; }
run 30 "$tmp/deep.gltf" --width 8 --iterations 1 --snapshot "$tmp/x.exr"
refused "three 16-bit 1024-square images under 30 MiB" "decoded image, 16777216 bytes, with 16777216 bytes already committed"
start=$(date +%s)
run 256 "$tmp/claims.gltf" --width 8 --iterations 1 --snapshot "$tmp/x.exr"
refused "a PNG header claiming 16384 x 16384 under 256 MiB" "decoded image, 2147483648 bytes, with "
within "a PNG header claiming 16384 x 16384" 256
checks=$((checks + 1)); [ $(( $(date +%s) - start )) -le 5 ] || fail "the claimed 16384-square image took more than 5 s to refuse"

# the snapshot's output buffers are part of the estimate, before the render: 1024 x 1024 of
# direct and specular light is a 37 MiB film (a float and 16 low bits a channel: 18 bytes a pixel a
# component, and the ahead byte) and 36 MiB of room for the copy a cancel restores; the EXR writer
# takes 72 MiB beside them, the PNG's layers, offscreen view and encoder 118. The written ones'
# --stats serve the forecast's check below, where these buffers dominate.
for case in "exr 128 refused" "exr 192 written" "png 160 refused" "png 256 written"; do
    set -- $case
    start=$(date +%s)
    run "$2" scenes/cornell-box.gltf --width 1024 --height 1024 --iterations 1 --no-photons --snapshot "$tmp/out.$1" --stats
    if [ "$3" = refused ]; then
        [ "$1" = exr ] && what="EXR" || what="PNG"
        refused "a 1024-square $1 under $2 MiB" "$what output buffers, [0-9]* bytes, with "
        checks=$((checks + 1)); [ ! -e "$tmp/out.$1" ] && [ $(( $(date +%s) - start )) -le 1 ] ||
            fail "a 1024-square $1 under $2 MiB must be refused before rendering"
    else
        checks=$((checks + 1)); [ "$rc" -eq 0 ] && [ -s "$tmp/out.$1" ] || { fail "a 1024-square $1 under $2 MiB: exit $rc"; cat "$tmp/err"; }
        cp "$tmp/out" "$tmp/stats.$1"
    fi
    within "a 1024-square $1, $3" "$2"
done
# an emissive mesh placed 400 times: 2 million emitting triangles, whose 56 MB table is admitted
# against the limit like the geometry, though the file stores 5,000 triangles
python3 bench/instanced_scene.py "$tmp/glow.glb" --placements 400 --triangles 5000 --emissive >/dev/null
run 48 "$tmp/glow.glb" --iterations 1 --snapshot "$tmp/glow.exr"
refused "2 million placed emitters under 48 MiB" "emitter distribution, [0-9]* bytes, with "

# The forecast (--stats estimate_bytes) holds the measured peak within 25%, whatever dominates:
# the scene, the film, photon records of either mode, the PNG's offscreen context
holds() { # description, a file of pmview's --stats lines
    ratio=$(sed -n 's/^stat memory .*peak_over_estimate=\([0-9.]*\).*/\1/p' "$2")
    checks=$((checks + 1))
    echo "forecast: $1: peak / estimate = $ratio"
    awk -v r="$ratio" 'BEGIN { exit !(r != "" && r >= 0.75 && r <= 1.25) }' || fail "$1: peak / estimate $ratio outside 0.75-1.25"
}
forecast() { # description, pmview arguments...
    what=$1; shift
    ./pmview "$@" --stats --quiet >"$tmp/stats"
    holds "$what" "$tmp/stats"
}
forecast "Cornell box, EXR" scenes/cornell-box.gltf --iterations 2 --snapshot "$tmp/f.exr"
forecast "Cornell box, classic, PNG" scenes/cornell-box.gltf --mode classic --iterations 1 --snapshot "$tmp/f.png"
# (one iteration: the path tracer's later ones allocate nothing more, its peak / estimate 0.998 after 1 or 2)
forecast "point room, path traced, PNG" scenes/point-room.gltf --mode pathtrace --iterations 1 --snapshot "$tmp/f.png"
# a mesh of 2,000 triangles placed 100 times, kept instanced and written flat
python3 bench/instanced_scene.py "$tmp/inst.glb" --placements 100 --triangles 2000 >/dev/null
python3 bench/instanced_scene.py "$tmp/flat.glb" --placements 100 --triangles 2000 --flat >/dev/null
forecast "2x10^5 triangles, instanced" "$tmp/inst.glb" --iterations 1 --snapshot "$tmp/f.exr"
forecast "2x10^5 triangles, flat" "$tmp/flat.glb" --iterations 1 --snapshot "$tmp/f.exr"
holds "Cornell box, 1024-square EXR" "$tmp/stats.exr"
holds "Cornell box, 1024-square PNG" "$tmp/stats.png"

# 10^5 punctual lights (a 17 MB JSON) under --max-memory 64M: the parsed document is admitted
# while it lives, so the file is refused at once, its peak RSS within the limit plus the process's
# own. Before, 10^6 lights took 1.8-3.4 GB under 64M.
python3 - "$tmp/lights.gltf" <<'PY'
import json, sys
d = json.load(open("scenes/point-room.gltf"))
light = d["extensions"]["KHR_lights_punctual"]["lights"][0]
n = 100000
d["extensions"]["KHR_lights_punctual"]["lights"] = [dict(light) for _ in range(n)]
roots = d["scenes"][d.get("scene", 0)]["nodes"]
for i in range(n):
    d["nodes"].append({"translation": [0.001 * (i % 100), 1, 0.001 * (i // 100 % 100)], "extensions": {"KHR_lights_punctual": {"light": i}}})
    roots.append(len(d["nodes"]) - 1)
open(sys.argv[1], "w").write(json.dumps(d))  # dumps encodes in C, json.dump in Python (1 s more)
PY
run 64 "$tmp/lights.gltf" --width 32 --iterations 1 --snapshot "$tmp/l.exr"
refused "10^5 lights under 64 MB" "JSON document"
checks=$((checks + 1))
[ $(( (kb - base_kb) / 1024 )) -le 64 ] || fail "10^5 lights under 64 MB: peak RSS $((kb / 1024)) MiB, $(( (kb - base_kb) / 1024 )) above the process's own"
echo "10^5 lights under 64 MB: refused, peak RSS $((kb / 1024)) MiB"

echo "test_memory: $checks checks, $fails failed"
[ "$fails" -eq 0 ]

#!/bin/sh
# test_memory.sh: the progressive mode runs in constant memory: peak RSS after 2,000 iterations within 5% of 100 (optimised build; ASan's quarantine would hide a leak's growth in its own). 2,000 photons a pass: what must stay flat is the per-iteration structures, whatever their size.
cd "$(dirname "$0")/.." || exit 1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
rss() { # iterations -> peak RSS bytes
    ./pmview scenes/cornell-box.gltf --width 32 --height 32 --photons 2000 --iterations "$1" --snapshot "$tmp/m.exr" --stats |
        sed -n 's/^stat memory peak_rss_bytes=\([0-9]*\).*/\1/p'
}
a=$(rss 100)
b=$(rss 2000)
echo "peak RSS: $a bytes after 100 iterations, $b after 2000"
if [ -z "$a" ] || [ -z "$b" ]; then echo "test_memory: 1 checks, 1 failed (no stat memory line)"; exit 1; fi
if [ "$b" -le $((a + a / 20)) ]; then echo "test_memory: 1 checks, 0 failed"; exit 0; fi
echo "FAIL: peak RSS grew by more than 5% from 100 to 2000 iterations"
echo "test_memory: 1 checks, 1 failed"
exit 1

#!/bin/sh
# check_valgrind.sh: an 8x8 render of the Cornell box by the release ./pmview (load, accel, photon and eye passes, EXR writer) is clean under valgrind's memcheck; run by make check only (about 8 s of CPU, 20 s on a busy machine).
cd "$(dirname "$0")/.." || exit 1
command -v valgrind >/dev/null 2>&1 || { echo "valgrind is not installed (make check installs it): skip"; exit 0; }
[ -x ./pmview ] || { echo "FAIL: ./pmview is not built"; exit 1; }
out=build/test-logs/check_valgrind.exr
rm -f "$out"
echo "criterion: memcheck reports no invalid access, no use of uninitialised values and no definite leak (valgrind --error-exitcode=1), and the image is written"
# definite leaks only: Mesa, Embree's task system and the C++ runtime keep reachable allocations for the process lifetime
valgrind --error-exitcode=1 --leak-check=full --errors-for-leak-kinds=definite --show-leak-kinds=definite -q \
    ./pmview scenes/cornell-box.gltf --snapshot "$out" --width 8 --height 8 --iterations 1 --photons 500 --threads 2 --quiet --stats \
    >build/test-logs/check_valgrind.stats
status=$?
grep -E '^stat (eye|photons) ' build/test-logs/check_valgrind.stats
[ "$status" -eq 0 ] || { echo "FAIL: valgrind exit status $status"; exit 1; }
[ -s "$out" ] || { echo "FAIL: $out was not written"; exit 1; }
grep -q '^stat eye iterations=1 ' build/test-logs/check_valgrind.stats || { echo "FAIL: no 'stat eye iterations=1' line"; exit 1; }
echo "check_valgrind: memcheck clean"

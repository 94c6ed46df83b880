#!/bin/sh
# test_cli.sh: the command line as a user meets it: usage errors exit 2, bad files exit 1 with one error line, outputs appear.
cd "$(dirname "$0")/.." || exit 1
. tests/cli_setup.sh
fails=0; checks=0
expect() { # description, expected exit code, command...
    desc=$1; want=$2; shift 2
    checks=$((checks + 1))
    "$@" >"$tmp/out" 2>"$tmp/err"
    got=$?
    if [ "$got" != "$want" ]; then
        fails=$((fails + 1)); echo "FAIL: $desc: exit $got, want $want"; sed 's/^/    /' "$tmp/err" | head -5
    fi
}
expect "help" 0 $bin --help
expect "unknown flag" 2 $bin --frobnicate
expect "bad width" 2 $bin --width -3 --snapshot "$tmp/x.png"
expect "bad snapshot extension" 2 $bin --snapshot "$tmp/x.jpg"
expect "missing value" 2 $bin --iterations
expect "bad kernel" 2 $bin --kernel box --snapshot "$tmp/x.exr"
expect "a classic-only option in the progressive mode" 2 $bin --k 10 --snapshot "$tmp/x.exr"
expect "alpha out of range" 2 $bin --alpha 1.5 --snapshot "$tmp/x.exr"
expect "unknown mode" 2 $bin --mode fast --snapshot "$tmp/x.exr"
expect "eye passes out of range" 2 $bin --eye-passes 0 --snapshot "$tmp/x.exr"
expect "eye passes in the classic mode" 2 $bin --mode classic --eye-passes 2 --snapshot "$tmp/x.exr"
expect "eye passes in the path-tracing mode" 2 $bin --mode pathtrace --eye-passes 2 --snapshot "$tmp/x.exr"
expect "a progressive-only option in the classic mode" 2 $bin --mode classic --radius 0.1 --snapshot "$tmp/x.exr"
expect "two scenes" 2 $bin a.gltf b.gltf --snapshot "$tmp/x.exr"
expect "missing scene file" 1 $bin "$tmp/nope.gltf" --snapshot "$tmp/x.exr"
checks=$((checks + 1))
if ! grep -q "nope.gltf" "$tmp/err" || [ "$(wc -l < "$tmp/err")" -ne 1 ]; then
    fails=$((fails + 1)); echo "FAIL: a missing file must give exactly one error line naming it:"; cat "$tmp/err"
fi
printf '{"asset":{"version":"2.0"},"scenes":[{"nodes":[0]}],"nodes":[{"mesh":5}],"meshes":[]}' > "$tmp/bad.gltf"
expect "node with a missing mesh" 1 $bin "$tmp/bad.gltf" --snapshot "$tmp/x.exr"
checks=$((checks + 1))
[ "$(wc -l < "$tmp/err")" -eq 1 ] || { fails=$((fails + 1)); echo "FAIL: more than one error line:"; cat "$tmp/err"; }
expect "camera index past the scene's cameras" 1 $bin scenes/cornell-box.gltf --camera 7 --snapshot "$tmp/x.exr"
expect "EXR snapshot" 0 $bin scenes/cornell-box.gltf --width 32 --iterations 2 --photons 20000 --snapshot "$tmp/c.exr" --stats
checks=$((checks + 1))
[ -s "$tmp/c.exr" ] || { fails=$((fails + 1)); echo "FAIL: no EXR written"; }
for stage in load analysis bvh photons film eye memory progressive; do
    checks=$((checks + 1))
    grep -q "^stat $stage " "$tmp/out" || { fails=$((fails + 1)); echo "FAIL: no 'stat $stage' line (progressive mode)"; }
done
checks=$((checks + 1))
grep -q "^stat progressive iterations=2 photons_per_iteration=40000 alpha=0.6667 radius_initial=[0-9.e-]* radius_mean=" "$tmp/out" ||
    { fails=$((fails + 1)); echo "FAIL: stat progressive line:"; grep "^stat progressive" "$tmp/out"; }
checks=$((checks + 1))
grep -Eq "^stat progressive iterations=2 .* photon_passes=[12] eye_passes_next=[1-8]( |$)" "$tmp/out" ||
    { fails=$((fails + 1)); echo "FAIL: stat progressive lacks photon_passes and eye_passes_next:"; grep "^stat progressive" "$tmp/out"; }
# a fixed count: 10 samples of 3 eye passes a photon pass are 3 + 3 + 3 + 1
expect "fixed eye passes" 0 $bin scenes/cornell-box.gltf --width 16 --iterations 10 --eye-passes 3 --snapshot "$tmp/e.exr" --stats
checks=$((checks + 1))
grep -Eq "^stat progressive iterations=10 .* photon_passes=4 eye_passes_next=3( |$)" "$tmp/out" ||
    { fails=$((fails + 1)); echo "FAIL: 10 samples at 3 eye passes a photon pass:"; grep "^stat progressive" "$tmp/out"; }
checks=$((checks + 1))
grep -q "^stat load .*triangles=[1-9]" "$tmp/out" || { fails=$((fails + 1)); echo "FAIL: stat load lacks triangles"; }
checks=$((checks + 1))
grep -q "^stat eye .*dropped_samples=0" "$tmp/out" || { fails=$((fails + 1)); echo "FAIL: stat eye lacks dropped_samples=0"; }
expect "classic EXR snapshot" 0 $bin scenes/cornell-box.gltf --mode classic --width 32 --iterations 2 --photons 20000 --snapshot "$tmp/k.exr" --stats
for stage in photons kdtree irradiance film eye; do
    checks=$((checks + 1))
    grep -q "^stat $stage " "$tmp/out" || { fails=$((fails + 1)); echo "FAIL: no 'stat $stage' line (classic mode)"; }
done
expect "a time budget shorter than the photon pass" 0 $bin scenes/cornell-box.gltf --width 16 --time 0.001 --snapshot "$tmp/t.exr"
checks=$((checks + 1))
grep -q "(16x16, 1 iterations" "$tmp/out" || { fails=$((fails + 1)); echo "FAIL: --time 0.001 must still render one iteration:"; cat "$tmp/out"; }
expect "PNG snapshot (offscreen, through the display shaders)" 0 $bin scenes/cornell-box.gltf --width 64 --iterations 4 --photons 20000 --snapshot "$tmp/c.png"
expect "the PNG shows the Cornell box: red left, green right, lit floor" 0 python3 tests/png_compare.py cornell "$tmp/c.png"
expect "no display without snapshot" 2 env -u DISPLAY $bin scenes/cornell-box.gltf
expect "unknown component" 2 $bin --components direct,glow --snapshot "$tmp/x.png"
expect "PNG of the direct component only" 0 $bin scenes/cornell-box.gltf --width 64 --iterations 2 --components direct --snapshot "$tmp/d.png"
expect "the direct-only PNG is darker than the full one" 0 python3 tests/png_compare.py darker "$tmp/c.png" "$tmp/d.png"
# Ctrl-C during a snapshot: the image so far is written, complete, and the exit status is 130
checks=$((checks + 1))
$bin scenes/cornell-box.gltf --width 48 --iterations 1000000 --snapshot "$tmp/int.exr" >"$tmp/out" 2>"$tmp/err" &
spid=$!
i=0
while ! [ -s "$tmp/int.exr" ] && [ $i -lt 40 ] && kill -0 $spid 2>/dev/null; do
    i=$((i + 1)); sleep 0.1
    [ $i -eq 15 ] && kill -INT $spid
done
wait $spid; rc=$?
if [ "$rc" -ne 130 ] || ! grep -q "interrupted" "$tmp/out" || ! [ -s "$tmp/int.exr" ]; then
    fails=$((fails + 1)); echo "FAIL: SIGINT during a snapshot: exit $rc (want 130), output:"; cat "$tmp/out" "$tmp/err"
fi
checks=$((checks + 1))
iters=$(sed -n 's/.*(48x48, \([0-9]*\) iterations.*/\1/p' "$tmp/out")
[ "${iters:-0}" -ge 1 ] || { fails=$((fails + 1)); echo "FAIL: the interrupted snapshot holds no iteration"; }
# --time held on a closed room of albedo-1 walls (Russian roulette alone never ends its photon
# paths), with the default photon count and with a pass far longer than the budget: the render
# ends within 5% of the budget (optimised build: the clock, not the sanitizer, is under test)
python3 tests/white_room.py "$tmp/room.gltf"
for photons in auto 5000000; do
    flag=""; [ "$photons" = auto ] || flag="--photons $photons"
    expect "albedo-1 room, --time 3, photons $photons" 0 ./pmview "$tmp/room.gltf" --width 64 --time 3 $flag --snapshot "$tmp/room.exr"
    checks=$((checks + 1))
    secs=$(sed -n 's/.*iterations, \([0-9.]*\) s).*/\1/p' "$tmp/out")
    awk -v s="${secs:-0}" 'BEGIN { exit !(s >= 2.85 && s <= 3.15) }' ||
        { fails=$((fails + 1)); echo "FAIL: --time 3 on the albedo-1 room (photons $photons) took ${secs:-?} s, want 3 +- 5%"; cat "$tmp/out"; }
done
# environments: a bad --sky is a usage error, a missing map one error line, an EXR that pmview
# wrote is a usable map; a file without lights gets the gradient with a warning, a closed room
# with no light inside a warning that it will be dark
expect "unknown --sky" 2 $bin --sky purple --snapshot "$tmp/x.exr"
expect "missing environment map" 1 $bin scenes/caustic.gltf --sky "$tmp/none.exr" --width 16 --iterations 1 --snapshot "$tmp/x.exr"
checks=$((checks + 1))
{ [ "$(wc -l < "$tmp/err")" -eq 1 ] && grep -q "none.exr" "$tmp/err"; } || { fails=$((fails + 1)); echo "FAIL: a missing map must give one error line naming it:"; cat "$tmp/err"; }
expect "an EXR pmview wrote, as the sky" 0 $bin scenes/caustic.gltf --sky "$tmp/c.exr" --width 16 --iterations 2 --stats --snapshot "$tmp/x.exr"
checks=$((checks + 1))
grep -q "^stat sky kind=map " "$tmp/out" || { fails=$((fails + 1)); echo "FAIL: --sky FILE.exr must say stat sky kind=map"; grep "stat sky" "$tmp/out"; }
printf '#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 2\n\200\200\200\201\200\200\200\201\200\200\200\200\200\200\200\200' > "$tmp/sky.hdr"
expect "a Radiance .hdr map (bright top row, dim bottom)" 0 $bin scenes/caustic.gltf --sky "$tmp/sky.hdr" --width 16 --iterations 2 --stats --snapshot "$tmp/x.exr"
checks=$((checks + 1))
grep -q "^stat sky kind=map " "$tmp/out" || { fails=$((fails + 1)); echo "FAIL: --sky FILE.hdr must say stat sky kind=map"; cat "$tmp/err"; }
python3 tests/white_room.py "$tmp/dark.gltf" 0.5 dark
expect "a closed room with no light" 0 $bin "$tmp/dark.gltf" --width 16 --iterations 1 --stats --snapshot "$tmp/x.exr"
checks=$((checks + 1))
{ grep -q "shut in" "$tmp/err" && grep -q "^stat sky kind=gradient " "$tmp/out"; } ||
    { fails=$((fails + 1)); echo "FAIL: a closed dark room must get the default sky and the shut-in warning:"; cat "$tmp/err"; }
expect "the open Cornell box lit by its lamp" 0 $bin scenes/cornell-box.gltf --width 16 --iterations 1 --stats --snapshot "$tmp/x.exr"
checks=$((checks + 1))
{ grep -q "^stat sky kind=none " "$tmp/out" && ! grep -q "warning" "$tmp/err"; } ||
    { fails=$((fails + 1)); echo "FAIL: the Cornell box's emitters enclose its view: no sky, no warning"; cat "$tmp/err"; }
# snapshot paths that cannot be written are refused before any work, naming the cause, and no
# temporary file is left behind (checked only at the end, a run would render all its iterations
# before failing to rename onto a directory, and leave tmp.PID<name> beside it)
mkdir -p "$tmp/out dir/taken.exr" "$tmp/out dir/taken.png"
: > "$tmp/out dir/plain"
for target in "taken.exr|is a directory" "taken.png|is a directory" "missing/x.exr|cannot create a file in the folder" \
              "missing/x.png|cannot create a file in the folder" "plain/x.exr|Not a directory"; do
    path="$tmp/out dir/${target%%|*}"; cause=${target#*|}
    expect "snapshot to $path" 1 timeout 20 $bin scenes/cornell-box.gltf --width 64 --iterations 1000000 --snapshot "$path"
    checks=$((checks + 1))
    { [ "$(wc -l < "$tmp/err")" -eq 1 ] && grep -q "$cause" "$tmp/err" && grep -q "${target%%|*}" "$tmp/err"; } ||
        { fails=$((fails + 1)); echo "FAIL: snapshot to ${target%%|*}: want one line naming it and \"$cause\":"; cat "$tmp/err"; }
done
expect "EXR snapshot into a folder with a space" 0 $bin scenes/cornell-box.gltf --width 16 --iterations 1 --snapshot "$tmp/out dir/ok.exr"
checks=$((checks + 1))
left=$(cd "$tmp/out dir" && ls -A | grep -v -x -e taken.exr -e taken.png -e plain -e ok.exr)
[ -z "$left" ] && [ -s "$tmp/out dir/ok.exr" ] ||
    { fails=$((fails + 1)); echo "FAIL: files left behind beside the snapshots: $left"; }
expect "bad --shadow-photons" 2 $bin --shadow-photons maybe --snapshot "$tmp/x.exr"
expect "shadow photons forced on" 0 $bin scenes/caustic.gltf --width 16 --iterations 2 --photons 0 --shadow-photons on --stats --snapshot "$tmp/x.exr"
checks=$((checks + 1))
{ grep -q "^stat shadow_photons built=1 reason=none lights=1 photons=65536 " "$tmp/out" &&
  grep -q "^stat eye .*dropped_samples=0 shadow_rays=[0-9]* shadow_rays_saved=[1-9]" "$tmp/out"; } ||
    { fails=$((fails + 1)); echo "FAIL: --shadow-photons on must build a map and save rays:"; grep "^stat \(eye\|shadow\)" "$tmp/out"; }
expect "shadow photons by default on a render too short to pay" 0 $bin scenes/caustic.gltf --width 16 --iterations 2 --photons 0 --stats --snapshot "$tmp/x.exr"
checks=$((checks + 1))
{ grep -q "^stat shadow_photons built=0 reason=would_not_pay " "$tmp/out" && grep -q "^stat eye .*shadow_rays_saved=0" "$tmp/out"; } ||
    { fails=$((fails + 1)); echo "FAIL: a 16x16, 2-iteration render gets no shadow photons:"; grep "^stat \(eye\|shadow\)" "$tmp/out"; }
echo "test_cli: $checks checks, $fails failed"
[ "$fails" -eq 0 ]

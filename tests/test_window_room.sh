#!/bin/sh
# test_window_room.sh: a room lit by sun and sky through a window in a 120 m landscape against Mitsuba 3's reference (tests/ref/window_room_64.exr): channel means, the error falling at the theory's slope, photons sent where the camera looks.
#
# Progressive photon mapping's error falls as N^(-2/3) for alpha = 2/3 (variance and squared
# bias both; Knaus and Zwicker 2011): the relMSE from about 512 to 2048 iterations must fall with
# a log-log slope of -0.45 or steeper. One eye pass per photon pass, so that the radii shrink at
# every iteration (the automatic choice reads a pass up to 8 times on so small an image). The
# release binary: 2048 iterations of 50,000 photons take some 25 s on 2 cores. The photons are
# what is tested here, so final gathering reads them (--gather photons; the default's choice on
# this room is tests/test_window_default.sh's).
cd "$(dirname "$0")/.." || exit 1
bin=./pmview
ref=tests/ref/window_room_64.exr
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0; checks=0
check() { # description, python condition over the parsed stats (s: dict of the final stat lines, p: progress rows)
    checks=$((checks + 1))
    if ! python3 - "$tmp/$3" "$2" >"$tmp/py" 2>&1 <<'EOF'
import math, re, sys
text = open(sys.argv[1]).read()
s = {}
for line in text.splitlines():
    if line.startswith("stat ") and not line.startswith("stat progress "):
        stage, *pairs = line.split()[1:]
        s[stage] = {k: float(v) if re.fullmatch(r"[-+0-9.eE]+", v) else v for k, v in (p.split("=", 1) for p in pairs)}
p = [{k: float(v) for k, v in (x.split("=", 1) for x in line.split()[2:])}
     for line in text.splitlines() if line.startswith("stat progress ")]
ok = eval(sys.argv[2])
print(s.get("error"), [(r["iterations"], r["relmse"]) for r in p][-5:], s.get("progressive", {}).get("useful_share"))
sys.exit(0 if ok else 1)
EOF
    then
        fails=$((fails + 1)); echo "FAIL: $1"; sed 's/^/    /' "$tmp/py" | tail -3
    else
        echo "ok: $1: $(tail -n 1 "$tmp/py")"
    fi
}
if [ ! -f "$ref" ]; then echo "SKIP: $ref is missing"; exit 0; fi
run() { # name, options...
    name=$1; shift
    "$bin" scenes/window-room.gltf --sky white --width 64 --height 64 --reference "$ref" --stats --quiet \
        --gather photons --snapshot "$tmp/$name.exr" "$@" >"$tmp/$name" 2>&1 || echo "pmview failed: $(tail -n 1 "$tmp/$name")"
}
run guided --photons 50000 --iterations 2048 --eye-passes 1
check "every channel's mean within 0.5% of the reference after 2048 iterations" \
    "all(abs(s['error']['mean_ratio_' + c] - 1) < 0.005 for c in 'rgb')" guided
check "the relMSE falls from about 512 to 2048 iterations with a log-log slope of -0.45 or steeper (theory -2/3)" \
    "(lambda a, b: math.log(b['relmse'] / a['relmse']) / math.log(b['iterations'] / a['iterations']) <= -0.45)(min((r for r in p if r['iterations'] >= 512), key=lambda r: r['iterations']), p[-1])" guided
check "the estimates are clipped at the walls (stat progressive clip_rays > 0)" "s['progressive']['clip_rays'] > 0" guided
run unguided --photons 40000 --iterations 64 --guide off
run guided_short --photons 40000 --iterations 64
check "unguided, almost every photon lands where no camera point reads it (useful_share < 0.01)" \
    "s['progressive']['useful_share'] < 0.01" unguided
unguided_share=$(sed -n 's/.*useful_share=\([0-9.]*\).*/\1/p' "$tmp/unguided")
check "guided, five times the unguided share of useful photons within 64 iterations" \
    "s['progressive']['useful_share'] > 5 * ${unguided_share:-1}" guided_short
echo "test_window_room: $checks checks, $fails failed"
[ "$fails" -eq 0 ]

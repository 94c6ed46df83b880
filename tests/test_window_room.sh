#!/bin/sh
# test_window_room.sh: a room lit by sun and sky through a window in a 120 m landscape against Mitsuba 3's reference (tests/ref/window_room_64.exr): channel means, the error falling with the iterations (a log-log slope from 64 to 1024 iterations), photons sent where the camera looks.
#
# Progressive photon mapping's error falls as N^(-2/3) for alpha = 2/3 (variance and squared
# bias both; Knaus and Zwicker 2011). On this room the relMSE is bumpy (a pass's rare bright
# photons lift it for a while: seed 4 reads 0.0037 at 256 iterations and 0.0045 at 512), so over a
# short span its slope says little; from 64 to 1024 iterations it must fall with a log-log slope of
# -0.25 or steeper. Seeds 1-6 read -0.91, -0.67, -0.88, -0.51, -0.77, -0.40 (the worst ends with a
# relMSE 1.5 times below what the bound allows); radii that shrink too fast (--alpha 0.2) read
# +0.52. Radii that do not shrink (--alpha 0.99) fall fast enough but stay biased, which the means
# catch (+0.8%). The channel means after 1024 iterations, seeds 1-6, lie between 0.9976 and 1.0033
# (seed 1: 0.9976 0.9978 0.9979; seed 2, the farthest: 1.0015 1.0021 1.0033), checked at 0.5%;
# photons carrying 5% too much flux read 1.0108 1.0089 1.0072 (seed 1). One eye pass per photon
# pass, so that the radii shrink at every iteration (the automatic choice reads a pass up to 8
# times on so small an image). The release binary: 1024 iterations of 50,000 photons take some 24 s
# of processor time. The photons are what is tested here, so final gathering reads them (--gather
# photons; the default's choice on this room is tests/test_window_default.sh's). The share of
# useful photons after 32 iterations, seeds 1-6: unguided 0.0042, 0.0037, 0.0032, 0.0039, 0.0038,
# 0.0035 (checked below 0.01), guided 14 to 37 times as much (checked at 5).
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
run guided --photons 50000 --iterations 1024 --eye-passes 1
check "every channel's mean within 0.5% of the reference after 1024 iterations" \
    "all(abs(s['error']['mean_ratio_' + c] - 1) < 0.005 for c in 'rgb')" guided
check "the relMSE falls from 64 to 1024 iterations with a log-log slope of -0.25 or steeper (theory -2/3: see above)" \
    "(lambda a, b: math.log(b['relmse'] / a['relmse']) / math.log(b['iterations'] / a['iterations']) <= -0.25)(min((r for r in p if r['iterations'] >= 64), key=lambda r: r['iterations']), p[-1])" guided
check "the estimates are clipped at the walls (stat progressive clip_rays > 0)" "s['progressive']['clip_rays'] > 0" guided
run unguided --photons 40000 --iterations 32 --guide off
run guided_short --photons 40000 --iterations 32
check "unguided, almost every photon lands where no camera point reads it (useful_share < 0.01)" \
    "s['progressive']['useful_share'] < 0.01" unguided
unguided_share=$(sed -n 's/.*useful_share=\([0-9.]*\).*/\1/p' "$tmp/unguided")
check "guided, five times the unguided share of useful photons within 32 iterations" \
    "s['progressive']['useful_share'] > 5 * ${unguided_share:-1}" guided_short
echo "test_window_room: $checks checks, $fails failed"
[ "$fails" -eq 0 ]

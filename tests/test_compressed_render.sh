#!/bin/sh
# test_compressed_render.sh: the Draco and meshopt ducks in tests/models/duck render like the plain one: their difference from it is no larger than the plain duck's own seed-to-seed difference.
cd "$(dirname "$0")/.." || exit 1
. tests/cli_setup.sh
checks=0; fails=0
render() { # model seed out
    $bin "tests/models/duck/$1" --width 128 --iterations 16 --seed "$2" --quiet --snapshot "$tmp/$3.png" 2>"$tmp/err" ||
        { fails=$((fails + 1)); echo "FAIL: rendering $1"; cat "$tmp/err"; }
}
render duck.glb 1 plain
render duck.glb 2 plain2
render duck-draco.glb 1 draco
render duck-meshopt.glb 1 meshopt
# mean absolute difference per channel value over the image, and over the duck's pixels alone
compare() { # NAME: against the plain duck, with the seed-to-seed difference as the yardstick
    checks=$((checks + 1))
    python3 - "$tmp" "$1" <<'PY' || fails=$((fails + 1))
import sys
sys.path.insert(0, "tests")
import png_compare as p
tmp, name = sys.argv[1], sys.argv[2]
def read(n):
    w, h, px = p.read_png("%s/%s.png" % (tmp, n))
    return [q[:3] for q in px]
plain, seed, other = read("plain"), read("plain2"), read(name)
duck = [i for i, q in enumerate(plain) if q[0] > 150 and q[1] > 110 and q[2] < 0.6 * q[1]]
def diff(a, b, pixels):
    return sum(abs(a[i][c] - b[i][c]) for i in pixels for c in range(3)) / (3 * len(pixels))
everything = range(len(plain))
d_seed, d_other = diff(plain, seed, everything), diff(plain, other, everything)
duck_seed, duck_other = diff(plain, seed, duck), diff(plain, other, duck)
yellow = sum(1 for q in other if q[0] > 150 and q[1] > 110 and q[2] < 0.6 * q[1])
print("%s: mean |difference| from the plain duck %.3f (duck pixels %.3f); plain seed 1 vs 2: %.3f (%.3f); yellow pixels %d, plain %d"
      % (name, d_other, duck_other, d_seed, duck_seed, yellow, len(duck)))
ok = len(duck) > 0.02 * len(plain) and abs(yellow - len(duck)) < 0.05 * len(duck) and d_other <= 0.5 * d_seed \
    and duck_other <= 0.5 * duck_seed
print("ok" if ok else "FAIL: %s differs from the plain duck more than its seed-to-seed noise" % name)
sys.exit(0 if ok else 1)
PY
}
compare draco
compare meshopt
echo "test_compressed_render: $checks checks, $fails failed"
[ "$fails" -eq 0 ]

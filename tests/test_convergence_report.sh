#!/bin/sh
# test_convergence_report.sh: a tiny `make convergence` (the Cornell box, three methods, 2 s each) writes its report with plots, slopes, tables and the image grid, and its numbers agree with the logs.
cd "$(dirname "$0")/.." || exit 1
command -v gnuplot >/dev/null || { echo "skip: gnuplot is not installed (sh tools/install-deps.sh convergence)"; exit 0; }
[ -x ./pmview ] && [ -x build/rel/error_map ] || { echo "FAIL: build ./pmview and build/rel/error_map first"; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
methods="ppm-a0.67-gather classic-100k-photons-cone pt"
if ! CONV_OUT="$tmp" CONV_SIZES=64 CONV_SCENES=cornell CONV_METHODS="$methods" CONV_SECONDS=2 CONV_COMMAND="tiny test" \
     sh tools/convergence.sh >"$tmp/out" 2>&1; then
    sed 's/^/    /' "$tmp/out"; echo "FAIL: tools/convergence.sh failed"; exit 1
fi
# The caustic reference leaves the pixels the glass ball touches unknown (NaN): pmview and error_map
# must both skip them, and agree; against the particle tracer's raw image (ball pixels black) the
# same render is far worse, so the skipped pixels are really the ball's.
./pmview scenes/caustic.gltf --sky none --width 64 --height 64 --iterations 8 --threads 2 --quiet --snapshot "$tmp/c.exr" \
    --reference tests/ref/caustic_floor_64.exr --log "$tmp/c.csv" >"$tmp/c.out" 2>&1 || { cat "$tmp/c.out"; echo "FAIL: caustic run"; exit 1; }
masked=$(sed -n 's/^stat error .*relmse=\([^ ]*\).*/\1/p' "$tmp/c.out")
mapped=$(build/rel/error_map "$tmp/c.exr" tests/ref/caustic_floor_64.exr "$tmp/c.png" "$tmp/ce.png" | sed 's/relmse=//')
raw=$(./pmview scenes/caustic.gltf --sky none --width 64 --height 64 --iterations 8 --threads 2 --quiet --snapshot "$tmp/c.exr" \
    --reference tests/ref/caustic_ptracer_64.exr | sed -n 's/^stat error .*relmse=\([^ ]*\).*/\1/p')
python3 -c "
import sys, csv
m, e, r = float('$masked'), float('$mapped'), float('$raw')
last = float(list(csv.DictReader(open('$tmp/c.csv')))[-1]['total_relmse'])
assert 0 < m < 0.2, 'relMSE over the known pixels %g' % m
assert abs(e / m - 1) < 2e-3 and abs(last / m - 1) < 2e-3, 'pmview %g, its log %g, error_map %g' % (m, last, e)
assert r > 10 * m, 'against the unmasked particle tracer %g, masked %g' % (r, m)
print('NaN reference pixels skipped: relMSE %g (error_map %g), unmasked %g' % (m, e, r))
" || { echo "FAIL: NaN pixels of a reference"; exit 1; }
python3 - "$tmp" "$methods" <<'EOF' || exit 1
import csv, os, re, sys
tmp, methods = sys.argv[1], sys.argv[2].split()
d = os.path.join(tmp, "convergence", "64")
fails = []
def check(ok, what):
    if not ok:
        fails.append(what)
def png(path):
    try:
        with open(path, "rb") as f:
            head = f.read(24)
    except OSError:
        return None
    if head[:8] != b"\x89PNG\r\n\x1a\n":
        return None
    return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")
report = open(os.path.join(tmp, "convergence.md")).read()
check(png(os.path.join(d, "cornell.png")) == (900, 720), "the plot cornell.png is not a 900x720 PNG")
check("(convergence/64/cornell.png)" in report, "the report does not show the plot")
check(png(os.path.join(d, "cornell_reference.png")) == (192, 192), "no reference image")
check("`tiny test`" in report and re.search(r"with 2 cores|with \d+ cores", report), "command or core count missing")
check(re.search(r"at pmview commit [0-9a-f?]+", report), "no commit")
# the log's last relMSE (pmview) against error_map's own computation from the final EXR (printed in the run)
out = open(os.path.join(tmp, "out")).read()
slope_rows = re.findall(r"^\| ([^|]+) \| (\d+) \| [^|]+ \| ([0-9.e+-]+) \| (-?[0-9.]+|-) \| (-?[0-9.]+|-) \| (-?[0-9.]+) \| "
                        r"(-?[0-9.]+|-) \| (-?[0-9.]+|-) \| ([+-][0-9.]+)% \|$", report, re.M)
check(len(slope_rows) == len(methods), "slope table: %d rows, want %d" % (len(slope_rows), len(methods)))
for m, row in zip(methods, slope_rows):
    check(png(os.path.join(d, "cornell-%s.png" % m)) == (192, 192), "%s: no image" % m)
    check(png(os.path.join(d, "cornell-%s-error.png" % m)) == (192, 192), "%s: no error map" % m)
    check("(convergence/64/cornell-%s-error.png)" % m in report, "%s: error map not in the grid" % m)
    with open(os.path.join(d, "data", "cornell-%s.csv" % m)) as f:
        rows = [r for r in csv.DictReader(f)]
    first, last = float(rows[0]["total_relmse"]), float(rows[-1]["total_relmse"])
    check(last < first, "%s: relMSE did not fall over the run (%g -> %g)" % (m, first, last))
    em = re.search(r"cornell +%s +\d+ iterations, relmse=([0-9.e+-]+)" % re.escape(m), out)
    check(em and abs(float(em.group(1)) / last - 1) < 1e-3, "%s: error_map's relMSE %s, the log's %g" % (m, em and em.group(1), last))
    check(abs(float(row[2]) / last - 1) < 0.01, "%s: report's end relMSE %s, the log's %g" % (m, row[2], last))
    fit_n = row[3]
    check(fit_n != "-" and float(fit_n) < 0, "%s: fitted slope in N %r is not negative" % (m, fit_n))
    check(row[6] != "-" or m.startswith("classic"), "%s: no slope in seconds" % m)
    check(row[6] == "-" or float(row[6]) < 0, "%s: slope in seconds %s is not negative" % (m, row[6]))
    check(abs(float(row[8])) < 5, "%s: bias %s%% beyond 5%%" % (m, row[8]))
times = re.search(r"^\| method \| relMSE at 1 s \| relMSE at 2 s \| time to 0.03 \| time to 0.01 \| time to 0.003 \|$", report, re.M)
check(times, "no error-at-times table")
ppm = times and re.search(r"^\| PPM a=2/3, indirect gather \| ([0-9.e+-]+) \| ([0-9.e+-]+) \|", report[times.end():], re.M)
check(ppm and float(ppm.group(2)) < float(ppm.group(1)), "PPM's error at 2 s is not below its error at 1 s")
for f in fails:
    print("FAIL: " + f)
if fails:
    sys.exit(1)
print("ok: report, plot, %d images and error maps, slopes negative, end errors agree with error_map" % (2 * len(methods)))
EOF

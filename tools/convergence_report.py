#!/usr/bin/env python3
# convergence_report.py: turns tools/convergence.sh's run logs into docs/convergence.md: gnuplot plots, fitted slopes, error tables and the equal-time image grid, a section a size (standard library only).
"""Reads DIR/SIZE/runs.tsv and DIR/SIZE/data/SCENE-METHOD.csv (pmview --log files against a
reference) for every SIZE, writes DIR/SIZE/SCENE.gp and DIR/SIZE/SCENE.png (relMSE against seconds,
log-log, one line per method, drawn by gnuplot) and the markdown report. Every number in the
report comes from those logs."""
import argparse
import csv
import math
import os
import subprocess
import sys

# scene -> (file, what makes it hard)
SCENES = {
    "cornell": ("scenes/cornell-box.gltf",
                "area lamp, mirror ball and glass ball in a closed box: diffuse interreflection and the glass ball's caustic"),
    "caustic": ("scenes/caustic.gltf",
                "a point light's caustic through a glass ball on a floor: no path from the eye can find it"),
    "mirror": ("scenes/mirror-caustic.gltf",
               "a small spherical lamp's caustic through a glass ball, seen directly and in a mirror wall: "
               "eye -> mirror -> floor -> glass -> lamp, the path tracer's hard case"),
    "window": ("scenes/window-room.gltf",
               "a room with solid walls lit by the sun and a white sky through one window, inside a 120 m landscape "
               "(--sky white): leaks through walls and photons wasted outside"),
    "window-hollow": ("scenes/window-hollow.gltf",
                      "the window room built as architectural exports are: single-sided faces, hollow walls, a ground "
                      "under the floor, the sun and a white sky (--sky white)"),
    "point-room": ("scenes/point-room.gltf",
                   "a closed room lit by a point light: diffuse interreflection only, where photons are easy"),
}
# (scene, size) -> how its reference was made, and the reference's own noise: its expected relMSE
# against the converged image, from two independent halves (tests/ref/README.md). A method's measured
# relMSE is about its own plus this, so values near it say only "as good as the reference".
REFERENCES = {
    ("cornell", 64): ("Mitsuba 3 path tracer, 204800 spp (the 320x320 image averaged over 5x5 blocks)", 2e-5),
    ("caustic", 64): ("Mitsuba 3 particle tracer, 65536 light paths per pixel; the 332 of 4096 pixels the glass ball "
                      "touches are unknown to it (it cannot see through glass) and left out of every measure (NaN in "
                      "the file, grey in the grid; tools/mitsuba_caustic_reference.py)", 4.3e-4),
    ("mirror", 64): ("Mitsuba 3 path tracer, 65536 spp", 4.8e-4),
    ("window", 64): ("Mitsuba 3 path tracer, 65536 spp, constant sky of radiance 1", 2.4e-5),
    ("window-hollow", 64): ("Mitsuba 3 path tracer, 65536 spp, constant sky of radiance 1", 3.7e-5),
    ("point-room", 64): ("Mitsuba 3 path tracer, 32768 spp", 2.6e-5),
    ("window-hollow", 128): ("Mitsuba 3 path tracer, 8192 spp, constant sky of radiance 1", 3.1e-4),
    ("cornell", 128): ("Mitsuba 3 path tracer, 3328 spp", 1.3e-3),
    ("caustic", 128): ("Mitsuba 3 particle tracer, 24576 light paths per pixel; the 1254 of 16384 pixels the glass "
                       "ball touches left out, as at 64x64", 1.05e-3),
    ("mirror", 128): ("Mitsuba 3 path tracer, 7936 spp", 4.0e-3),
    ("window", 128): ("Mitsuba 3 path tracer, 3072 spp, constant sky of radiance 1", 5.2e-4),
    ("point-room", 128): ("Mitsuba 3 path tracer, 2560 spp", 3.3e-4),
}


def reference_noise(s, z):
    return REFERENCES[(s, z)][1] if (s, z) in REFERENCES else None


TARGETS = (0.03, 0.01, 0.003)
TABLE_SECONDS = (1, 4, 16, 64)


def method_label(m):
    """A short human name: ppm-a0.67-gather -> 'PPM a=2/3 gather'."""
    if m == "pt":
        return "path tracing"
    if m == "default":
        return "default (no options)"
    if m == "ppm-photons":
        return "PPM, final gather read from photons (--gather photons)"
    if m == "ppm-direct":
        return "PPM, photons read at the visible point (--indirect photons)"
    if m == "ppm-unguided":
        return "PPM a=2/3, gather, photons not guided (--guide off)"
    if m == "ppm-unclipped-unguided":
        return "PPM a=2/3, gather, estimates unclipped, photons not guided (--clip off --guide off)"
    parts = m.split("-")
    if parts[0] == "ppm":
        a = {"a0.5": "1/2", "a0.67": "2/3", "a0.9": "0.9"}.get(parts[1], parts[1])
        return "PPM a=%s, indirect %s" % (a, parts[2])
    if parts[0] == "classic":
        return "classic %s, %s, %s" % (parts[1], "final gather" if parts[2] == "gather" else "photons read directly", parts[3])
    return m


def theory(m):
    """The asymptotic slope of MSE against N (iterations) and why."""
    if m == "pt":
        return -1.0, "-1 (unbiased Monte Carlo)"
    if m == "default":
        return -2.0 / 3.0, "-0.67 (PPM a=2/3; where the gather is path-traced, that part -1)"
    if m in ("ppm-photons", "ppm-direct"):
        return -2.0 / 3.0, "-0.67 (variance N^-a, a=2/3)"
    if m.startswith("ppm"):
        a = {"a0.5": 0.5, "a0.67": 2.0 / 3.0, "a0.9": 0.9}.get(m.split("-")[1], 2.0 / 3.0)
        s = -min(a, 2.0 * (1.0 - a))
        why = "variance N^-a" if a <= 2.0 / 3.0 + 1e-9 else "bias^2 N^-2(1-a)"
        return s, "%.2f (%s)" % (s, why)
    return 0.0, "0 (maps built once: -1 until the maps' own error shows, then flat)"


def read_log(path):
    rows = []
    with open(path) as f:
        for r in csv.DictReader(f):
            if r["total_relmse"] == "":
                continue
            rows.append({"seconds": float(r["seconds"]), "iterations": int(float(r["iterations"])),
                         "photons": float(r["photons"] or 0), "relmse": float(r["total_relmse"]),
                         "bias": float(r["total_rel_bias"])})
    return rows


def fit_slope(rows, key, lo, hi, samples=33):
    """Slope of log relMSE against log rows[key] (seconds or iterations), fitted by least squares
    to the log-log curve resampled at points evenly spaced in log key over [lo, hi] within the run:
    the log is dense over its first 64 iterations and sparse after, and an unweighted fit of its
    rows would see mostly the start. None when the run covers less than a factor of 2 there."""
    pts = [(math.log(r[key]), math.log(r["relmse"])) for r in rows if r[key] > 0 and r["relmse"] > 0]
    if len(pts) < 2:
        return None
    a, b = max(math.log(lo), pts[0][0]), min(math.log(hi), pts[-1][0])
    if b - a < math.log(2.0):
        return None
    xs, ys = [], []
    for k in range(samples):
        x = a + (b - a) * k / (samples - 1)
        for p, q in zip(pts, pts[1:]):
            if p[0] <= x <= q[0]:
                w = 0.0 if q[0] == p[0] else (x - p[0]) / (q[0] - p[0])
                xs.append(x)
                ys.append(p[1] * (1 - w) + q[1] * w)
                break
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    sxx = sum((x - mx) ** 2 for x in xs)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sxx if sxx > 0 else None


def fit_window(rows, lo, hi):
    """The iterations that the time window [lo, hi] covers: from the first row at or after lo."""
    inside = [r["iterations"] for r in rows if r["seconds"] >= lo]
    return (inside[0], rows[-1]["iterations"]) if inside else (rows[-1]["iterations"], rows[-1]["iterations"])


def error_at(rows, t):
    """relMSE at t seconds, interpolated log-log between the logged rows; None outside them
    (before the first iteration ended, or past the run's end by more than 5%)."""
    if not rows or t < rows[0]["seconds"] or t > rows[-1]["seconds"] * 1.05:
        return None
    if t >= rows[-1]["seconds"]:
        return rows[-1]["relmse"]
    for a, b in zip(rows, rows[1:]):
        if a["seconds"] <= t <= b["seconds"]:
            if b["seconds"] == a["seconds"]:
                return b["relmse"]
            w = math.log(t / a["seconds"]) / math.log(b["seconds"] / a["seconds"])
            return math.exp(math.log(a["relmse"]) * (1 - w) + math.log(b["relmse"]) * w)
    return None


def time_to(rows, target):
    """The time from which relMSE stays at or below target until the end of the run (log-log
    interpolation into the crossing); None if the last row is above it."""
    if not rows or rows[-1]["relmse"] > target:
        return None
    last_above = None
    for i, r in enumerate(rows):
        if r["relmse"] > target:
            last_above = i
    if last_above is None:
        return rows[0]["seconds"]
    a, b = rows[last_above], rows[last_above + 1]
    w = math.log(target / a["relmse"]) / math.log(b["relmse"] / a["relmse"])
    return math.exp(math.log(a["seconds"]) * (1 - w) + math.log(b["seconds"]) * w)


def fmt(x, digits=3):
    return "-" if x is None else "%.*g" % (digits, x)


def fmt_s(x):
    if x is None:
        return "-"
    return "%.2g s" % x if x < 10 else "%.0f s" % x


STYLE = {"gather": 1, "photons": 2}
COLOURS = {"ppm-a0.5": "#1f77b4", "ppm-a0.67": "#2ca02c", "ppm-a0.9": "#9467bd",
           "classic-100k-gather": "#ff7f0e", "classic-100k-photons": "#d62728",
           "classic-1M-gather": "#8c564b", "classic-1M-photons": "#e377c2", "pt": "#000000"}


def line_style(m):
    if m == "pt":
        return 'lc rgb "#000000" lw 3 dt 1'
    if m == "default":
        return 'lc rgb "#d62728" lw 3 dt 1'
    if m == "ppm-photons":
        return 'lc rgb "#2ca02c" lw 2 dt 1'
    if m == "ppm-direct":
        return 'lc rgb "#1f77b4" lw 2 dt 2'
    if m == "ppm-unguided":
        return 'lc rgb "#bcbd22" lw 2 dt 1'
    if m == "ppm-unclipped-unguided":
        return 'lc rgb "#7f7f7f" lw 2 dt 1'
    p = m.split("-")
    if p[0] == "ppm":
        return 'lc rgb "%s" lw 2 dt %d' % (COLOURS["-".join(p[:2])], STYLE[p[2]])
    return 'lc rgb "%s" lw 1.5 dt %d' % (COLOURS["-".join(p[:3])], 3 if p[3] == "disc" else 4)


def plot(dirname, scene, runs, seconds, size):
    gp = os.path.join(dirname, "%s.gp" % scene)
    png = "%s.png" % scene
    lines = ['set terminal pngcairo size 900,720 font ",11"', 'set output "%s"' % png,
             'set datafile separator ","', "set logscale xy", "set grid xtics ytics mxtics mytics lc rgb '#dddddd'",
             'set xlabel "seconds (%s)"' % "rendering time, photon passes and map building included",
             'set ylabel "relMSE against the reference"',
             'set title "%s: relMSE against time, %dx%d"' % (SCENES[scene][0], size, size),
             "set key outside below maxrows 6 font ',9'", "set xrange [0.05:%g]" % (seconds * 1.3)]
    plots = []
    for m in runs:
        plots.append("'data/%s-%s.csv' every ::1 using 1:5 with lines %s title '%s'"
                     % (scene, m, line_style(m), method_label(m).replace("'", "")))
    # guides: slopes -1 and -2/3 through the path tracer's (or the first method's) value at 1 s
    anchor = None
    for m in (["pt"] if "pt" in runs else []) + list(runs):
        anchor = error_at(runs[m], 1.0) or (runs[m][0]["relmse"] if runs[m] else None)
        if anchor:
            break
    if anchor:
        plots.append("%g*x**-1 with lines lc rgb '#aaaaaa' dt 2 title 'slope -1'" % (anchor * 3))
        plots.append("%g*x**(-2./3) with lines lc rgb '#aaaaaa' dt 3 title 'slope -2/3'" % (anchor * 3))
    lines.append("plot " + ", \\\n     ".join(plots))
    with open(gp, "w") as f:
        f.write("# %s.gp: written by tools/convergence_report.py; gnuplot %s.gp (in this folder) redraws %s\n"
                % (scene, scene, png))
        f.write("\n".join(lines) + "\n")
    subprocess.run(["gnuplot", "%s.gp" % scene], cwd=dirname, check=True)
    return png


def read_size(dirname):
    """One size's runs: the scenes in order, the methods in order, each (scene, method)'s log and
    runs.tsv row, each scene's reference, and the scenes left out (no reference at this size)."""
    with open(os.path.join(dirname, "runs.tsv")) as f:
        runs = list(csv.DictReader(f, delimiter="\t"))
    size = {"scenes": [], "methods": [], "logs": {}, "info": {}, "refs": {}, "missing": {}, "loads": []}
    for r in runs:
        s, m = r["scene"], r["method"]
        if m == "-":
            size["missing"][s] = r["reference"]
            continue
        if s not in size["scenes"]:
            size["scenes"].append(s)
        if m not in size["methods"]:
            size["methods"].append(m)
        size["logs"][(s, m)] = read_log(os.path.join(dirname, "data", "%s-%s.csv" % (s, m)))
        size["info"][(s, m)] = r
        size["refs"][s] = r["reference"]
        size["loads"].append(float(r["load"]))
        if not size["logs"][(s, m)]:
            sys.exit("convergence_report: %s-%s.csv has no error rows" % (s, m))
    return size


def summary(w, z, size, T):
    """Per scene at one size: the best method, the default's and the path tracer's errors at T."""
    w("### %dx%d" % (z, z))
    w("")
    w("| scene | best method at %g s | its relMSE | default's relMSE | path tracing's relMSE | default / path tracing "
      "| reference's own noise |" % T)
    w("|---|---|---|---|---|---|---|")
    for s in size["scenes"]:
        finals = {m: size["logs"][(s, m)][-1]["relmse"] for m in size["methods"] if (s, m) in size["logs"]}
        best = min(finals, key=finals.get)
        d, pt = finals.get("default"), finals.get("pt")
        w("| %s | %s | %s | %s | %s | %s | %s |" % (s, method_label(best), fmt(finals[best]), fmt(d), fmt(pt),
                                                    "%.2f" % (d / pt) if d is not None and pt else "-",
                                                    fmt(reference_noise(s, z), 2)))
    for s, ref in size["missing"].items():
        w("| %s | left out: no reference `%s` | | | | | |" % (s, ref))
    w("")


def scene_section(w, args, rel, z, size, s, T):
    """One scene at one size: the plot, the slope table, errors at set times and the image grid."""
    fit_lo, late_lo = T / 64.0, T / 8.0
    zrel = "%s/%d" % (rel, z)
    ms = [m for m in size["methods"] if (s, m) in size["logs"]]
    runs_s = {m: size["logs"][(s, m)] for m in ms}
    png = plot(os.path.join(args.dir, str(z)), s, runs_s, T, z)
    w("### %s at %dx%d (`%s`)" % (s, z, z, SCENES[s][0]))
    w("")
    w("![relMSE against seconds on %s at %dx%d](%s/%s)" % (s, z, z, zrel, png))
    w("")
    w("Slopes of log relMSE against log iterations N (theory's terms) and against log seconds, fitted by "
      "least squares to the logged curve from %g s to the end at %g s (\"fit\") and over its last factor "
      "of 8 in time, from %g s (\"late\"); \"bias\" is the last image's relative bias: the sum of the "
      "image over the reference's sum, minus 1. A classic curve against seconds starts after the maps are "
      "built, which steepens its slope in seconds: its slope in N is the one to read." % (fit_lo, T, late_lo))
    w("")
    w("| method | iterations | photons | relMSE at end | slope in N: fit | late | theory | slope in seconds: fit | late | bias at end |")
    w("|---|---|---|---|---|---|---|---|---|---|")
    for m in ms:
        rows = runs_s[m]
        slopes = [fit_slope(rows, "iterations", *fit_window(rows, fit_lo, T * 2)),
                  fit_slope(rows, "iterations", *fit_window(rows, late_lo, T * 2)),
                  fit_slope(rows, "seconds", fit_lo, T * 2), fit_slope(rows, "seconds", late_lo, T * 2)]
        sl = ["%.2f" % x if x is not None else "-" for x in slopes]
        w("| %s | %d | %s | %s | %s | %s | %.2f | %s | %s | %+.2f%% |" % (
            method_label(m), rows[-1]["iterations"], "%.3g" % rows[-1]["photons"] if rows[-1]["photons"] else "-",
            fmt(rows[-1]["relmse"]), sl[0], sl[1], theory(m)[0], sl[2], sl[3], 100.0 * rows[-1]["bias"]))
    w("")
    cols = [t for t in TABLE_SECONDS if t <= T * 1.001]
    if T not in cols:
        cols.append(T)
    w("Error reached at given times (\"-\": the first iteration had not ended), and the time from which the "
      "error stays at or below a set value (\"-\": not within %g s):" % T)
    w("")
    w("| method | " + " | ".join("relMSE at %g s" % t for t in cols) + " | "
      + " | ".join("time to %g" % e for e in TARGETS) + " |")
    w("|---|" + "---|" * (len(cols) + len(TARGETS)))
    for m in ms:
        rows = runs_s[m]
        w("| %s | " % method_label(m) + " | ".join(fmt(error_at(rows, t)) for t in cols) + " | "
          + " | ".join(fmt_s(time_to(rows, e)) for e in TARGETS) + " |")
    w("")
    ev = float(next(size["info"][k].get("ev") or 0 for k in size["info"] if k[0] == s))
    w("Equal time, %g s: each method's last image (clamped and sRGB-encoded as the display does, at exposure "
      "%+g stops) and its error per pixel, (x-r)^2/(r^2+0.01) averaged over the channels, on a log scale from "
      "1e-4 to 1:" % (T, ev))
    w("")
    w("![false-colour scale: 1e-4 (left) to 1 (right), each tenth of the bar a factor of 2.5](%s/colorbar.png)" % rel)
    w("")
    w("| method | image | error | relMSE |")
    w("|---|---|---|---|")
    w("| reference | ![reference](%s/%s_reference.png) | | |" % (zrel, s))
    for m in ms:
        w("| %s | ![%s](%s/%s-%s.png) | ![%s error](%s/%s-%s-error.png) | %s |" % (
            method_label(m), m, zrel, s, m, m, zrel, s, m, fmt(runs_s[m][-1]["relmse"])))
    w("")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dir", required=True)
    ap.add_argument("--sizes", type=int, nargs="+", required=True)
    ap.add_argument("--report", required=True)
    ap.add_argument("--seconds", type=float, required=True)
    ap.add_argument("--command", required=True)
    ap.add_argument("--cores", required=True)
    ap.add_argument("--threads", required=True)
    ap.add_argument("--started", required=True)
    ap.add_argument("--finished", required=True)
    args = ap.parse_args()
    T = args.seconds
    rel = os.path.relpath(args.dir, os.path.dirname(os.path.abspath(args.report)) or ".")
    sizes = {z: read_size(os.path.join(args.dir, str(z))) for z in args.sizes}
    loads = [x for z in sizes.values() for x in z["loads"]]
    if not loads:
        sys.exit("convergence_report: no runs (no scene has a reference at the sizes asked)")
    methods = []
    for z in sizes.values():
        methods += [m for m in z["methods"] if m not in methods]
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    except OSError:
        commit = ""
    size_words = " and ".join("%dx%d" % (z, z) for z in args.sizes)

    out = []
    w = out.append
    w("# Convergence: error against time for each method on the reference scenes, at %s" % size_words)
    w("")
    # the commit identifies the figures; the run's dates are left out (git log has the history)
    w("Made by `%s` (tools/convergence.sh, tools/convergence_report.py, tools/error_map.c) at "
      "pmview commit %s, on a machine with %s cores (`nproc`), every run with `--threads %s`, one run at a time. "
      "The 1-minute load average when each run started was %.1f to %.1f "
      "(other work shared the machine, so every time here is wall-clock time under that load)."
      % (args.command, commit or "?", args.cores, args.threads, min(loads), max(loads)))
    w("")
    w("Each curve is one pmview run: `pmview SCENE OPTIONS --sky SKY --width S --height S --time %g "
      "--threads %s --seed 1 --snapshot run.exr --reference REF.exr --log run.csv`, S the size (%s), SKY the "
      "environment the reference has (white for the window rooms, none elsewhere). The log holds a row per "
      "iteration (then per doubling past 64) with the seconds so far and the relMSE of the image at that "
      "point, mean over pixels and channels of (x-r)^2/(r^2+0.01), against an independent reference. Its last "
      "image is the equal-time image below. The logs are in %s (a folder a size)." % (
          T, args.threads, ", ".join(str(z) for z in args.sizes),
          ", ".join("[%s/%d/data/](%s/%d/data/)" % (rel, z, rel, z) for z in args.sizes)))
    w("")
    w("\"default\" is pmview with no options: progressive photon mapping whose final gather reads photons or "
      "traces paths from the visible point, whichever it measures to have less error per ray (`--gather auto`). "
      "The program must never lose to its own path tracer at equal time: the last column of the summary is "
      "that ratio, below 1 where the default is ahead. `CONV_METHODS=all make convergence` runs every method "
      "tools/convergence.sh knows (the PPM radius exponents, guiding and clipping off, the classic maps' sizes "
      "and kernels).")
    w("")
    w("## Summary at %g s" % T)
    w("")
    for z, size in sizes.items():
        summary(w, z, size, T)
    w("## Scenes and references")
    w("")
    w("| scene | file | what makes it hard | " + " | ".join("reference at %dx%d" % (z, z) for z in args.sizes) + " |")
    w("|---|---|---|" + "---|" * len(args.sizes))
    scenes = []
    for z in sizes.values():
        scenes += [s for s in z["scenes"] + list(z["missing"]) if s not in scenes]
    for s in scenes:
        f, what = SCENES[s]
        cells = []
        for z, size in sizes.items():
            if s in size["refs"]:
                how, noise = REFERENCES.get((s, z), ("see tests/ref/README.md", None))
                cells.append("`%s`: %s%s" % (size["refs"][s], how, "; noise %s" % fmt(noise, 2) if noise else ""))
            elif s in size["missing"]:
                cells.append("none (`%s` missing): left out" % size["missing"][s])
            else:
                cells.append("not run")
        w("| %s | `%s` | %s | %s |" % (s, f, what, " | ".join(cells)))
    w("")
    w("The noise is the reference's own expected relMSE against the converged image (two independent halves); "
      "a method's measured relMSE is about its own plus that, so a relMSE near a reference's noise means nothing "
      "more than \"as good as the reference\". The "
      "references never come from pmview, so no method is compared with itself (tests/ref/README.md has "
      "their commands, samples and noise).")
    w("")
    w("## Methods")
    w("")
    w("| method | pmview options | theory: slope of MSE against iterations |")
    w("|---|---|---|")
    for m in methods:
        opts = next(z["info"][k]["options"] for z in sizes.values() for k in z["info"] if k[1] == m)
        w("| %s | %s | %s |" % (method_label(m), "`%s`" % opts if opts else "(none)", theory(m)[1]))
    w("")
    w("PPM's theory: the pixel radius shrinks as R_N^2 ~ N^(a-1), so the estimate's variance falls as N^-a "
      "and its bias as R^2, its square as N^-2(1-a); the MSE falls as N^-min(a, 2(1-a)), fastest at a = 2/3 "
      "(Knaus and Zwicker). The direct light of every photon method is Monte Carlo (slope -1). "
      "The plots are against seconds, not iterations: where an iteration's cost stays constant the slopes are "
      "the same; the classic mode spends its first seconds building the maps, so its curve starts late. "
      "relMSE weighs every pixel by its relative error, so one firefly in a dark pixel (a rare path of high "
      "weight: a gather ray through the glass onto a focused caustic, a path-traced ray that finds the lamp "
      "through the ball) can lift a whole curve at once and fall back slowly; the error maps show where.")
    w("")
    for z, size in sizes.items():
        w("## %dx%d" % (z, z))
        w("")
        for s in size["scenes"]:
            scene_section(w, args, rel, z, size, s, T)
    w("## What the numbers cannot show")
    w("")
    w("- Every run is %s, where a progressive iteration's fixed costs weigh more than at a user's size: the "
      "photon passes do not shrink below 10000 photons. Ratios between methods at other sizes will differ; "
      "the two sizes show which way they move." % size_words)
    w("- One run per method, scene and size (seed 1): the slopes and crossing times carry that run's noise, and "
      "a curve's firefly jumps fall where that seed puts them; no second seed was run.")
    w("- The 128x128 references hold 2560 to 8192 samples a pixel (tests/ref/README.md): their noise, in the "
      "summary's last column, is a large share of a good method's error there (the Cornell box's 1.3e-3, the "
      "mirror's 4.0e-3), so at 128x128 a ratio between two methods understates the better one's lead.")
    w("- The caustic scene is measured on the floor only (the pixels the glass ball does not touch): what the "
      "ball shows is unknown to every independent renderer at hand (tests/ref/README.md).")
    w("- The mirror scene's lamp (radius 0.2) is as small as Mitsuba's path tracer could converge; with it, "
      "the lamp's direct light on the floor, sampled alike by every method, is a large part of every method's "
      "error, and path tracing, which draws more samples per second, stays close to the photon mappers there.")
    w("")
    with open(args.report, "w") as f:
        f.write("\n".join(out))
    print("convergence_report: %d sizes, %d scenes, %d methods" % (len(sizes), len(scenes), len(methods)))


if __name__ == "__main__":
    main()

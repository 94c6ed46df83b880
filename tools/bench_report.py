#!/usr/bin/env python3
"""bench_report.py: turns one `make bench` run's log (its `run`, `bench` and `stat` lines) into docs/benchmarks.md.

Usage: python3 tools/bench_report.py build/bench/bench.log > docs/benchmarks.md

Every figure printed comes from the log given; the paragraphs are fixed text saying what each
table measures and how to read it. A figure the run did not produce prints as "-".
"""
import os
import sys


def parse(path):
    """The log's lines as (kind, name, fields, text); bench_pm's unnamed lines get the scene they follow."""
    records, notes = [], []
    scene = None
    with open(path, errors="replace") as f:
        for text in f:
            words = text.split()
            if len(words) < 2 or words[0] not in ("run", "bench", "stat"):
                continue
            kind, rest = words[0], words[1:]
            name = ""
            if "=" not in rest[0]:
                name, rest = rest[0], rest[1:]
            if name.endswith(":"):
                notes.append(text.strip())
                continue
            fields = {}
            for w in rest:
                if "=" in w:
                    k, v = w.split("=", 1)
                    fields[k] = v
            if kind == "bench" and name == "" and "scene" in fields and "triangles" in fields:
                scene = fields["scene"]
            if kind == "bench" and "scene" not in fields and scene is not None and name in BENCH_PM_LINES:
                fields["scene"] = scene
            if "skipped" in rest or "skipped" in text.split("(")[0].split():
                notes.append(text.strip())
            records.append((kind, name, fields, text.strip()))
    return records, notes


BENCH_PM_LINES = {"raw", "eye", "photons", "photons_paired", "progressive", "progressive_phases", "first_iteration",
                  "gather", "kdtree", "knn"}


def select(records, kind, name, **match):
    out = []
    for k, n, f, _ in records:
        if k == kind and n == name and all(f.get(a) == b for a, b in match.items()):
            out.append(f)
    return out


def first(records, kind, name, **match):
    rows = select(records, kind, name, **match)
    return rows[0] if rows else {}


def num(value, digits=3):
    """A figure as the log gave it, shortened: '-' when missing."""
    if value is None or value == "":
        return "-"
    try:
        x = float(value)
    except ValueError:
        return value
    if x != x:
        return "-"
    if x == 0:
        return "0"
    if abs(x) >= 1e6:
        return "%.2f M" % (x / 1e6)
    if abs(x) >= 1e4:
        return "%.0f k" % (x / 1e3)
    if abs(x) >= 100:
        return "%.0f" % x
    return "%.*g" % (digits, x)


def ratio(a, b, digits=3):
    try:
        a, b = float(a), float(b)
    except (TypeError, ValueError):
        return "-"
    return "%.*g" % (digits, a / b) if b else "-"


def table(head, rows):
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        lines.append("| " + " | ".join(str(c) for c in r) + " |")
    return "\n".join(lines)


def short(scene):
    return os.path.basename(scene or "-").rsplit(".", 1)[0]


def pair(value):
    return (value or "-").replace(",", ", ")


class Report:
    def __init__(self, records, notes):
        self.r, self.notes, self.out = records, notes, []

    def add(self, *parts):
        self.out.extend(parts)

    def section(self, title, command, paragraph):
        self.add("", "## " + title, "", "    " + command, "", paragraph.strip(), "")

    def step_seconds(self, name):
        row = first(self.r, "run", "step", name=name)
        return row.get("seconds")

    def header(self):
        start = first(self.r, "run", "start")
        end = first(self.r, "run", "end")
        host = first(self.r, "run", "host")
        commit = start.get("commit", "unknown") + (" + local changes" if start.get("dirty") == "1" else "")
        seconds = float(end.get("seconds", 0) or 0)
        failed = end.get("failed", "")
        self.add("# pmview: benchmark figures",
                 "",
                 "Written by `make bench` (bench/run_bench.sh, then tools/bench_report.py) from one run; do not edit by hand:",
                 "run `make bench` again. Every figure below comes from that run.",
                 "",
                 table(["run", ""], [
                     ["commit", commit],
                     ["date (UTC)", start.get("date", "-")],
                     ["command", "`make bench`"],
                     ["cores (`nproc`)", start.get("nproc", "-")],
                     ["processor", host.get("cpu", "-").replace("_", " ")],
                     ["memory", "%s GB" % host.get("mem_gb", "-")],
                     ["load average (1, 5, 15 min) at the start", pair(start.get("load_start"))],
                     ["load average at the end", pair(end.get("load_end"))],
                     ["duration", "%d min %02d s" % (seconds // 60, seconds % 60) if seconds else "-"],
                     ["failed steps", failed.replace(",", ", ") if failed else "none"],
                 ]),
                 "",
                 "**How to read it.** The machine may be shared: a load average above the number of cores means",
                 "other work took processor time during the run, and absolute rates and seconds then fall and",
                 "vary from run to run. The figures to compare are **ratios measured within this run**:",
                 "a pass against raw Embree on the same rays, one setting against another alternated, the",
                 "default against the path tracer at equal wall time. Error against time for each method is in",
                 "docs/convergence.md; the algorithms measured here are described in docs/design.md. Each",
                 "section names the command that makes its lines alone (run from the repository root after",
                 "`make bench` has built the programs); relMSE is the mean over pixels and channels of",
                 "(x - r)^2 / (r^2 + 0.01) against the scene's reference in tests/ref.")
        loads = [float(x.split(",")[0]) for x in [start.get("load_start", ""), end.get("load_end", "")] +
                 [f.get("load", "") for f in select(self.r, "run", "step")] if x]
        cores = float(start.get("nproc", 0) or 0)
        if loads and cores:
            self.add("", "In this run the 1-minute load average read %.1f to %.1f on %d cores%s." % (
                min(loads), max(loads), cores,
                ": other work shared the machine throughout, so read the ratios, not the rates" if min(loads) > cores else
                (": other work shared the machine for part of it" if max(loads) > cores else "")))
        if self.notes:
            self.add("", "Lines the run printed besides its figures:", "")
            self.add(*["- `%s`" % n for n in self.notes])

    def throughput(self):
        self.section("Ray throughput against raw Embree", "build/rel/bench_pm SCENE", """
`bench_pm` first times Embree alone (`rtcIntersect1` in a bare loop) on rays like the passes cast:
eye-like rays (camera rays and one cosine bounce) and scattered rays (chains of cosine bounces, as
photons make). Each pass is then timed on the same scene and divided by that raw rate: the eye pass
(direct light and specular), the classic photon pass (over threads x the one-thread raw rate; the
median of 9 pairs of a pass and a raw replay right after it is the steadier figure), a whole
progressive iteration at 512x512 and its phases, and the first iteration at 640x480 over one
without photons (what a user waits for after a camera move). A ratio near 1 means the pass spends
its time in Embree; the rest is shading, sampling, the film and the gather. Two-thread speed-ups
read below 2 whenever other work took processor time during the run.""")
        scenes = [f["scene"] for f in select(self.r, "bench", "") if "triangles" in f]
        if not scenes:
            self.add("(no `bench_pm` lines in this run)")
            return
        def get(name, key, scene, **m):
            return first(self.r, "bench", name, scene=scene, **m).get(key)
        rows = []
        def row(label, fn):
            rows.append([label] + [fn(s) for s in scenes])
        row("triangles", lambda s: "{:,}".format(int(get("", "triangles", s) or 0)))
        row("load, BVH build seconds", lambda s: "%s, %s" % (num(get("", "load_seconds", s)), num(get("", "bvh_seconds", s))))
        row("raw eye-like / scattered rays per second, 1 thread",
            lambda s: "%s / %s" % (num(get("raw", "eye_like_rays_per_second", s, threads="1")), num(get("raw", "scattered_rays_per_second", s, threads="1"))))
        row("raw scattered rays, 2 threads over 1", lambda s: num(get("raw", "speedup", s, threads="2")))
        row("eye pass over raw, 1 thread", lambda s: num(get("eye", "ratio_to_raw", s, threads="1")))
        row("eye pass, 2 threads over 1", lambda s: num(get("eye", "speedup", s, threads="2")))
        row("classic photon pass over raw scattered rays, 1 thread", lambda s: num(get("photons", "ratio_to_raw_scattered", s, threads="1")))
        row("the same, median of 9 pairs (quartiles)",
            lambda s: "%s (%s)" % (num(get("photons_paired", "ratio_to_raw_scattered", s)), pair(get("photons_paired", "ratio_quartiles", s)).replace(", ", "-")))
        row("photons per second, 1 thread", lambda s: num(get("photons", "photons_per_second", s, threads="1")))
        row("progressive iteration at 512x512, seconds, 1 / 2 threads",
            lambda s: "%s / %s" % (num(get("progressive", "seconds_per_iteration", s, threads="1")), num(get("progressive", "seconds_per_iteration", s, threads="2"))))
        row("its rays per second over raw, 1 thread", lambda s: num(get("progressive", "ratio_to_raw", s, threads="1")))
        row("its phases, 2 threads: photons, eye, gather seconds",
            lambda s: ", ".join(num(get("progressive_phases", k, s)) for k in ("photon_seconds", "eye_seconds", "gather_seconds")))
        row("its rays; their time at the raw rate (seconds)",
            lambda s: "%s; %s" % (num(get("progressive_phases", "rays_per_iteration", s)), num(get("progressive_phases", "raw_ray_floor_seconds", s))))
        row("first iteration at 640x480 over one without photons", lambda s: num(get("first_iteration", "ratio", s)))
        self.add(table(["figure"] + [short(s) for s in scenes], rows))

    def photon_ceiling(self):
        self.section("The photon pass against its own rays, every shipped scene, a large mesh, many placements and many emitters",
                     "for s in scenes/*.gltf; do build/rel/photon_ceiling $s; done; python3 bench/big_scene.py "
                     "height-field-1m.glb 1 --smooth; build/rel/photon_ceiling height-field-1m.glb; python3 bench/instanced_scene.py "
                     "placements-10k.glb --placements 10000 --triangles 200; build/rel/photon_ceiling placements-10k.glb; "
                     "python3 bench/emissive_scene.py emissive-sphere-200k.glb 200000; build/rel/photon_ceiling emissive-sphere-200k.glb; "
                     "build/rel/photon_ceiling ../shared/real-models/LightsPunctualLamp/LightsPunctualLamp.gltf (and MultiUVTest)", """
`photon_ceiling` records the rays the progressive mode's photon passes cast (the link wraps
`pm_accel_intersect` and `pm_accel_intersect_packets` for that program only; the renderer's code is
unchanged), then traces the same rays again in a bare `rtcIntersect1` loop: the speed the pass would
reach if pmview's own work cost nothing. One thread, 15 pairs of a pass and its replay; the
ratio is the median pair's (the target is 0.7 or more), the quartiles its spread, for the global
and caustic passes together and each alone. The packets column replays the pass's own packets with `rtcIntersect8`: about the share of
the pass's time that is Embree's. Scenes whose photons mostly leave into the open (a low hit
fraction) read lower: their rays cost Embree little, so the work per ray around them weighs more.
height-field-1m is a bumpy height field of a million triangles under a sun (bench/big_scene.py,
generated for the run), whose mesh is far larger than the caches: there the pass prefetches its
hits' triangles (docs/design.md, large meshes). placements-10k is one torus of 200 triangles placed
10,000 times on a grid under a sun (bench/instanced_scene.py): every hit is located among the
placements (docs/design.md, Instancing), and Embree's rays cross two levels of its hierarchy.
emissive-sphere-200k is a room lit by an emissive sphere of 200,000 triangles (bench/emissive_scene.py),
whose emitter tables are larger than the caches: there each photon's emitter is prefetched ahead of
its start (docs/design.md, picks by cut points). LightsPunctualLamp (four 2048 x 2048 textures, five
point lights) and MultiUVTest (an emissive cube alone in the void) are public glTF samples with
textures larger than the caches, whose texels the pass prefetches; they are measured when
../shared/real-models is at hand. Emission is the share of the pass's time that starting its
photons takes (the same passes with no bounce at all): our own work that is no bounce.""")
        rows = []
        for f in select(self.r, "bench", "photon_ceiling", **{"pass": "both"}):
            scene = f.get("scene")
            alone = {p: first(self.r, "bench", "photon_ceiling", scene=scene, **{"pass": p}).get("ratio_to_raw_own_rays")
                     for p in ("global", "caustic")}
            rows.append([short(scene), num(f.get("rays")), num(f.get("hit_fraction")),
                         "**%s** (%s)" % (num(f.get("ratio_to_raw_own_rays")), pair(f.get("ratio_quartiles")).replace(", ", "-")),
                         num(alone["global"]), num(alone["caustic"]), num(f.get("ratio_to_raw_packets")),
                         num(f.get("emission_share")), num(f.get("photon_rays_per_second")), num(f.get("raw_own_rays_per_second"))])
        self.add(table(["scene", "rays", "hit fraction", "both passes over raw (quartiles)", "global pass alone", "caustic pass alone",
                        "over raw packets", "emission", "pass rays/s", "raw rays/s"], rows) if rows else "(no lines in this run)")
        both = [float(f["ratio_to_raw_own_rays"]) for f in select(self.r, "bench", "photon_ceiling", **{"pass": "both"})
                if f.get("ratio_to_raw_own_rays")]
        if both:
            self.add("", "In this run %d of %d scenes reach 0.7 with both passes (median over scenes %.3f)."
                     % (sum(x >= 0.7 for x in both), len(both), sorted(both)[(len(both) - 1) // 2]))

    def default_vs_pathtrace(self):
        self.section("The default against the path tracer, every scene with a reference", "sh bench/default_vs_pathtrace.sh", """
Every shipped scene that has a reference in tests/ref renders at the reference's size for the
same wall time (`BENCH_SECONDS`, 10 s by default) on all cores, the default mode and then `--mode
pathtrace`, alternating per seed (`BENCH_SEEDS`). The ratio is the default's relMSE over the path
tracer's: **below 1 the default is ahead**, and the default must never lose (one seed's pair
carries the noise of two short runs: more seeds narrow it). `gather source` is what the default's final
gathering chose (`stat progressive gather_source`: photons, or the path tracer's own light), and
`connections` what the connections' trial decided where that light was chosen (`stat progressive
connect_trial`: kept, left off; - where no trial ran). The window rooms render under the
references' constant white sky (`--sky white`), and the hollow one also under its sun alone
(against tests/ref/window_hollow_sun_64.exr); the others without a sky. layered-spheres has no reference and is not in this table. `at equal processor time` weighs
each relMSE by the processor seconds its run got (relMSE x seconds, default over path tracer):
where the error falls as one over time this is the ratio at equal processor time, which other work
on the machine does not tilt the way it tilts the wall-time ratio.""")
        rows = []
        for f in select(self.r, "bench", "default_vs_pathtrace"):
            trial = {"1": "kept", "0": "left off"}.get(f.get("connect_trial", "-1"), "-")
            rows.append([f.get("scene", "-"), f.get("sky", "-"), "%sx%s" % (f.get("size", "64"), f.get("size", "64")), f.get("seed", "-"),
                         f.get("gather_source", "-"), trial, "%s / %s" % (f.get("iterations_default", "-"), f.get("iterations_pathtrace", "-")),
                         num(f.get("relmse_default")), num(f.get("relmse_pathtrace")), "**%s**" % num(f.get("ratio")),
                         "%s (%s / %s s)" % (num(f.get("ratio_equal_cpu")), f.get("cpu_default", "-"), f.get("cpu_pathtrace", "-"))])
        self.add(table(["scene", "sky", "size", "seed", "gather source", "connections", "iterations, default / path tracer", "relMSE default",
                        "relMSE path tracer", "ratio", "at equal processor time (processor seconds)"], rows) if rows else "(no lines in this run)")
        runs = [(float(f["ratio"]), f.get("scene", "-"), f.get("size", "64"), f.get("sky", "-"))
                for f in select(self.r, "bench", "default_vs_pathtrace") if f.get("ratio") and float(f["ratio"]) > 0]
        if runs:
            behind = ["%s (sky %s) at %sx%s (%.2f)" % (n, k, z, z, r) for r, n, z, k in runs if r > 1]
            self.add("", "In this run the default is ahead on %d of %d; behind on %s." % (len(runs) - len(behind), len(runs),
                     ", ".join(behind) if behind else "none"))

    def clip(self):
        self.section("What clipping costs, every shipped scene", "sh bench/clip_bench.sh", """
Clipped estimates (docs/design.md, "Estimates stay on their side of the geometry") keep a
photon disc from reading light through a wall. `clip_bench.sh` renders each shipped scene with
`--clip on` and `--clip off`, alternating, twice: 16 iterations at 256x256 (`BENCH_ITERATIONS`),
and `make run`'s scene (the Cornell box, 64 iterations at 512x512). Time is the seconds each
snapshot reports, summed over the two rounds; CPU is user + system seconds of the whole process,
steadier than wall time on a shared machine; gather is `gather_seconds` summed over threads;
`clip rays` the probe rays of one clipped run. The error column renders 64x64 for the same wall
time (`BENCH_SECONDS`, 10 s) both ways against the scene's reference: above 1 is error clipping
costs at equal time, below 1 bias it mends (light read through walls). The targets: `make run`'s
scene within 1.15 of its unclipped time, and within 1.10 of the unclipped error where discs meet no
other surface.""")
        errors = {f.get("scene"): f for f in select(self.r, "bench", "clip_error")}
        rows = []
        for f in select(self.r, "bench", "clip_time"):
            name = f.get("case", "-")
            e = errors.get(name, {}) if name != "make_run" else {}
            label = "cornell-box, `make run` (512x512, 64 iterations)" if name == "make_run" else name
            err = "-" if not e else "%s (%s / %s)" % (num(e.get("relmse_on_over_off")), num(e.get("relmse_on")), num(e.get("relmse_off")))
            its = "-" if not e else "%s / %s" % (e.get("iterations_on", "-"), e.get("iterations_off", "-"))
            rows.append([label, num(f.get("time_on_over_off")), num(f.get("cpu_on_over_off")), num(f.get("gather_on_over_off")),
                         num(f.get("clip_rays")), err, its])
        self.add(table(["scene", "time on / off", "CPU on / off", "gather on / off", "clip rays", "relMSE on / off at equal time",
                        "iterations on / off"], rows) if rows else "(no lines in this run)")

    def window_room(self):
        self.section("The window-lit room: leaks and wasted photons", "sh bench/window_room_bench.sh", """
scenes/window-room.gltf under a white sky, 64x64, 40,000 photons a pass, final gathering reading
the photons (`--gather photons`, so that the photons' estimates are what is measured), for the same
wall time (`BENCH_SECONDS`, 10 s) in three configurations one after another, against the Mitsuba
reference. The means are the image's channel means over the reference's (1 is unbiased); the useful
share is the fraction of stored photons the camera's estimates read. Clipping should lower the error
(the unclipped estimates read the sunlit ground through the walls), guiding should raise the useful
share.""")
        rows = []
        for f in select(self.r, "bench", "window_room"):
            rows.append([f.get("config", "-"), f.get("iterations", "-"), num(f.get("relmse")),
                         ", ".join(num(f.get("mean_ratio_" + c), 4) for c in "rgb"), num(f.get("useful_share")),
                         num(f.get("useful_photons_per_second")), num(f.get("clip_rays"))])
        if rows:
            self.add(table(["configuration", "iterations", "relMSE", "mean R, G, B", "useful share", "useful photons/s", "clip rays"], rows))
            q = first(self.r, "bench", "window_room_ratios")
            self.add("", "relMSE unclipped over clipped **%s**, unclipped over the default **%s**; useful share, default over unclipped **%s**."
                     % (num(q.get("relmse_unclipped_over_clipped")), num(q.get("relmse_unclipped_over_default")),
                        num(q.get("useful_share_default_over_unclipped"))))
        else:
            self.add("(no lines in this run)")

    def gathering(self):
        self.section("Gathering: photon lookups, projection maps and shadow photons", "build/rel/bench_pm SCENE", """
The same photons and queries through the kd-tree and the hash grid (`same photons` 1 when both find
exactly the same photons; the grid's queries per second over the tree's is the speed-up), the
kd-tree's build rate and its k-nearest queries (k = 50), the caustic photons' projection maps with
64 point lights added, and the eye pass with and without shadow photons (direct light and specular,
256x256, 4 iterations, one thread, best of three): with the scene as shipped, with point lights
added up to 8, and with 20,000 (where no map is built and both columns do the same work, so that
row's speed-up shows the run's noise).""")
        scenes = [f["scene"] for f in select(self.r, "bench", "") if "triangles" in f]
        rows = []
        for s in scenes:
            g = first(self.r, "bench", "gather", scene=s)
            k1 = first(self.r, "bench", "kdtree", scene=s, threads="1")
            knn = first(self.r, "bench", "knn", scene=s)
            rows.append([short(s), num(g.get("photons")), num(g.get("kdtree_queries_per_second")), num(g.get("grid_queries_per_second")),
                         num(g.get("grid_speedup")), "%s / %s" % (num(g.get("kdtree_build_seconds")), num(g.get("grid_build_seconds"))),
                         g.get("same_photons", "-"), num(k1.get("build_photons_per_second")), num(knn.get("queries_per_second"))])
        if rows:
            self.add(table(["scene", "photons", "kd-tree queries/s", "grid queries/s", "grid over kd-tree", "build s, kd-tree / grid",
                            "same photons", "kd-tree build photons/s, 1 thread", "k-nearest queries/s"], rows))
        rows = []
        for f in select(self.r, "bench", "projection_maps"):
            rows.append([short(f.get("scene")), f.get("lights", "-"), num(f.get("seconds_1_thread")), num(f.get("seconds_2_threads")),
                         num(f.get("projection_fraction"))])
        if rows:
            self.add("", table(["scene", "lights", "projection maps, seconds, 1 thread", "2 threads", "projection fraction"], rows))
        rows = []
        for f in select(self.r, "bench", "shadow_photons"):
            built = f.get("built") == "1"
            rows.append([short(f.get("scene")), f.get("lights", "-"), "yes" if built else "no (%s)" % f.get("reason", "-"),
                         num(f.get("shadow_rays_saved_fraction")) if built else "-", num(f.get("probe_lookup_ns")) if built else "-",
                         num(f.get("probe_ray_ns")) if built else "-", num(f.get("speedup")),
                         "%s, %s" % (num(f.get("map_seconds")), num(f.get("map_bytes"))) if built else "-"])
        if rows:
            self.add("", table(["scene", "lights", "map built", "shadow rays saved", "lookup ns", "shadow ray ns",
                                "eye pass speed-up", "map seconds, bytes"], rows))

    def memory(self):
        self.section("Memory: the forecast against the peak", "sh bench/memory_table.sh   # FULL=1 adds 5x10^7 triangles", """
`--stats` prints `stat memory estimate_bytes=` (the peak forecast from the structures' sizes,
docs/design.md) beside `peak_rss_bytes=`. The script generates each scene and renders a 256x256 EXR
of one iteration: flat, bench/big_scene.py's height field with smooth normals; instanced,
bench/instanced_scene.py's 1,000 placements of one mesh of a thousandth of the triangles. The step
fails when a ratio leaves 0.75-1.25.""")
        rows = [["{:,}".format(int(f.get("triangles", 0) or 0)), f.get("kind", "-"), num(int(f.get("file_bytes", 0) or 0) / 1048576.0) + " MB",
                 f.get("estimate_mb", "-") + " MB", f.get("peak_mb", "-") + " MB", num(f.get("peak_over_estimate"))]
                for f in select(self.r, "bench", "memory_table")]
        self.add(table(["triangles", "kind", "file", "estimate", "peak RSS", "peak / estimate"], rows) if rows else "(no lines in this run)")

    def instancing(self):
        self.section("Instancing", "sh bench/instancing_bench.sh   # TRIANGLES, PLACEMENTS, PLACEMENTS_FLAT set the sizes", """
A mesh several nodes place is built once and placed with Embree instances. bench/instanced_scene.py
writes a torus of 20,000 triangles placed 2,000 times, and 100 times both instanced and as a flat
file (every node its own mesh, which pmview cannot share); `--flatten-instances` flattens the
instanced file at load. 256x256 snapshots of 4 iterations on 2 threads. The image check renders the
100-placement file instanced and flat at the same seed: their relMSE must be far below that of two
seeds of the flat file (the noise).""")
        rows = [[f.get("case", "-"), num(f.get("placed_triangles")), num(f.get("unique_triangles")), num(f.get("load_seconds")),
                 num(f.get("bvh_seconds")), f.get("peak_rss_mb", "-") + " MB"] for f in select(self.r, "bench", "instancing")
                if "case" in f]
        if rows:
            self.add(table(["file", "triangles placed", "stored", "load s", "BVH s", "peak RSS"], rows))
            img = next((f for f in select(self.r, "bench", "instancing") if "relmse_same_seed" in f), {})
            self.add("", "Instanced against flat at the same seed: relMSE **%s**; flat at seeds 1 and 2: **%s**."
                     % (num(img.get("relmse_same_seed")), num(img.get("relmse_other_seed"))))
        else:
            self.add("(no lines in this run)")

    def window(self):
        self.section("The window: responsiveness, first image, big scenes", "sh bench/window_bench.sh; sh bench/window_motion_bench.sh; sh bench/first_image.sh 5 ./pmview", """
Under Xvfb (Mesa's software OpenGL) at 640x480 on 2 threads. `window_bench.sh`: five left-drags a
second apart, then Esc; the figures are pmview's own `stat window` line: from main() to the first
frame (the window, its title naming the set-up's stage) and to the first image, the UI loop's
rate (it polls at 60 Hz and never waits for rendering), frames drawn per second and the time from a
camera drag to the next image. `first_image.sh`: the default scene's first image timed from the
process's start (dynamic loading included) by the wall clock, and the processor time every thread
had used by then: on a loaded machine the wall time is mostly waiting for a core, the processor
time is what the start costs. `window_motion_bench.sh`: the default scene's first frame (best of
3; the goal is 0.1 s), new images per second while dragging over 1M triangles (a 3-s drag, 3
pixels every 20 ms; the goal is 24), and an 8M-triangle scene's load, BVH, first frame and first
image (4M where less than 4 GB is free).""")
        rows = []
        for f in select(self.r, "bench", "window"):
            rows.append([short(f.get("scene")), num(f.get("first_frame_seconds")), num(f.get("first_image_seconds")),
                         num(f.get("ui_loops_per_second")), num(f.get("frames_per_second")), num(f.get("restart_to_image_seconds"))])
        if rows:
            self.add(table(["scene", "main() to first frame, s", "to first image, s", "UI loops/s", "frames drawn/s",
                            "camera drag to new image, s"], rows))
        runs = select(self.r, "bench", "first_image")
        if runs:
            def median(key):
                xs = sorted(float(f[key]) for f in runs if f.get(key, "-") not in ("-", ""))
                if not xs:
                    return "-"
                return "%.0f ms (%.0f-%.0f)" % (xs[(len(xs) - 1) // 2], xs[0], xs[-1])
            self.add("", table(["default scene, %d runs: median (range)" % len(runs), ""], [
                ["first image, from the process's start", median("image_ms")],
                ["first image, from main()", median("image_from_main_ms")],
                ["window on screen, from main()", median("window_from_main_ms")],
                ["processor time at the first image", median("cpu_ms")]]))
        motion = select(self.r, "bench", "window_motion")
        if motion:
            d = next((f for f in motion if "exec_to_exit_of_help_seconds" in f), {})
            m = next((f for f in motion if "motion_images_per_second" in f), {})
            b = next((f for f in motion if "first_image_seconds_per_million_triangles" in f), {})
            self.add("", table(["figure", "value"], [
                ["default scene: main() to first frame, best of 3 (goal 0.1 s)", num(d.get("first_frame_seconds")) + " s"],
                ["default scene: `pmview --help` exec to exit", num(d.get("exec_to_exit_of_help_seconds")) + " s"],
                ["default scene: main() to first image, best of 3", num(d.get("first_image_seconds")) + " s"],
                ["1M triangles: new images per second during a drag (goal 24)", num(m.get("motion_images_per_second"))],
                ["1M triangles: frames drawn per second during the run", num(m.get("frames_per_second"))],
                ["%s: load, BVH seconds" % b.get("scene", "big scene"), "%s, %s" % (num(b.get("load_seconds")), num(b.get("bvh_seconds")))],
                ["%s: first frame, first image seconds" % b.get("scene", "big scene"),
                 "%s, %s" % (num(b.get("first_frame_seconds")), num(b.get("first_image_seconds")))],
                ["%s: first image seconds per million triangles" % b.get("scene", "big scene"), num(b.get("first_image_seconds_per_million_triangles"))],
                ["%s: peak RSS" % b.get("scene", "big scene"), num(int(b.get("peak_rss_bytes", 0) or 0) / 1048576.0) + " MB"],
            ]))

    def loading(self):
        self.section("Loading: large JSON and textures", "build/rel/json_load; build/rel/texture_footprint", """
`json_load` builds two glTF files in memory whose JSON is large (100,000 nodes placing one
triangle; 50,000 meshes, each with its own bufferView and accessor) and loads each three times
through the loader, the best run printed beside the time of its one JSON parse: `load over parse` is
the load in parses of its own text. `texture_footprint` renders a plane filling a 640x480 view, its
random texture repeated 8 times, with an 8192^2 texture against a 1024^2 one (eye passes in
processor time, best of five interleaved runs): with levels chosen by the pixel footprint the 8K
texture should cost about what the 1K one does, and reading level 0 only (as photons and gather rays
do) shows what the levels save; the shimmer is the mean difference between two first iterations.""")
        rows = [[f.get("scene", "-"), num(f.get("json_mb")) + " MB", num(f.get("triangles")), num(f.get("load_seconds")),
                 num(f.get("parse_seconds")), num(f.get("load_over_parse"))] for f in select(self.r, "bench", "json_load")]
        if rows:
            self.add(table(["file", "JSON", "triangles", "load s", "one parse s", "load over parse"], rows))
        t = first(self.r, "bench", "texture_footprint")
        sh = first(self.r, "bench", "texture_shimmer")
        if t:
            self.add("", table(["texture levels", "8K over 1K eye-pass CPU", "shimmer between two first iterations (8K)"], [
                ["by the pixel footprint", num(t.get("ratio_8k_1k")), num(sh.get("first_iteration_difference"))],
                ["level 0 only", num(t.get("ratio_8k_1k_level0")), num(sh.get("level0"))]]),
                "", "Building the 8K texture's levels took %s s (the 1K's %s s), on one thread."
                % (num(t.get("levels_seconds_8k")), num(t.get("levels_seconds_1k"))))

    def cluster(self):
        self.section("MPI: two ranks against one process", "sh bench/cluster_bench.sh   # BENCH_SECONDS (5), BENCH_SEEDS (1 2 3 4 5)", """
The Cornell box at 64x64 against its reference, each seed rendered for the same wall time as one
process of one thread and as `mpirun -np 2` with one thread a rank. The ratio divides the mean
relMSE over the seeds (the target is 0.6 or less on 2 free cores; 0.5 is ideal where the error is
all variance). `iterations 2 over 1` says how much of a second core the ranks found (2: all of
it); `relMSE x iterations` near 1 says an iteration of either is worth the same, so the error ratio
then follows 1 / iterations. Then the bytes each rank other than 0 sends to merges: a plain
snapshot (one merge at the end), one with `--log` (a merge per log row), at 64x64 and 512x512, and
the window at 128x128.""")
        q = first(self.r, "bench", "cluster_ratio")
        if q:
            self.add(table(["seeds", "relMSE, 1 process", "relMSE, 2 ranks", "ratio (target <= 0.6)", "per seed",
                            "iterations, 2 ranks over 1", "relMSE x iterations, 2 over 1"], [
                [q.get("seeds", "-"), num(q.get("relmse_1_process")), num(q.get("relmse_2_ranks")), "**%s**" % num(q.get("relmse_ratio")),
                 "%s-%s" % (num(q.get("ratio_min")), num(q.get("ratio_max"))), num(q.get("iterations_ratio")),
                 num(q.get("relmse_times_iterations_ratio"))]]))
        rows = [[f.get("kind", "-"), "%sx%s" % (f.get("width", "-"), f.get("height", "-")), num(f.get("seconds")), f.get("merges", "-"),
                 num(f.get("bytes_per_merge")), num(f.get("bytes_per_pixel")), num(f.get("bytes_per_second_per_rank"))]
                for f in select(self.r, "bench", "cluster_bytes")]
        if rows:
            self.add("", table(["run", "size", "seconds", "merges", "bytes a merge", "bytes a pixel", "bytes a second a rank"], rows))
        if not q and not rows:
            self.add("(no lines in this run)")

    def steps(self):
        self.add("", "## The run's steps", "",
                 "Each step of bench/run_bench.sh, its wall time and the load average (1, 5, 15 min) when it ended.",
                 "`BENCH_STEPS=\"NAME ...\" sh bench/run_bench.sh` runs some alone (and then writes no report).", "")
        rows = [[f.get("name", "-"), "ok" if f.get("status") == "0" else "failed (%s)" % f.get("status"), num(f.get("seconds")),
                 pair(f.get("load"))] for f in select(self.r, "run", "step")]
        self.add(table(["step", "status", "seconds", "load at its end"], rows))

    def text(self):
        self.header()
        self.throughput()
        self.photon_ceiling()
        self.default_vs_pathtrace()
        self.clip()
        self.window_room()
        self.gathering()
        self.memory()
        self.instancing()
        self.window()
        self.loading()
        self.cluster()
        self.steps()
        return "\n".join(self.out).rstrip() + "\n"


def main():
    if len(sys.argv) != 2:
        sys.stderr.write("usage: bench_report.py BENCH_LOG\n")
        return 2
    try:
        records, notes = parse(sys.argv[1])
    except OSError as e:
        sys.stderr.write("bench_report.py: cannot read %s: %s\n" % (sys.argv[1], e.strerror))
        return 1
    if not first(records, "run", "start"):
        sys.stderr.write("bench_report.py: %s has no `run start` line (not a make bench log)\n" % sys.argv[1])
        return 1
    sys.stdout.write(Report(records, notes).text())
    return 0


if __name__ == "__main__":
    sys.exit(main())

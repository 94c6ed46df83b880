/* main.c: the pmview command line: parse flags, run load -> accel -> passes -> film -> view/files, print stats.
 *
 * Exit codes: 0 success, 1 a file could not be loaded, rendered or written, 2 a usage error.
 */
#include <errno.h>
#include <math.h>
#include <signal.h>
#include <unistd.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>

#include "accel.h"
#include "clock.h"
#include "defaults.h"
#include "eye.h"
#include "film.h"
#include "image_io.h"
#include "loader.h"
#include "memory.h"
#include "parallel.h"
#include "progressive.h"
#include "report.h"
#include "runlog.h"
#include "scene.h"
#include "session.h"
#include "sky_choice.h"
#include "camera_control.h"
#include "view.h"

typedef struct {
    const char *scene_path;
    const char *snapshot;
    const char *screenshot;
    int width, height;
    long iterations;      /* 0 = the mode's default */
    double time_limit;    /* 0 = none */
    int threads;
    uint64_t seed;
    int camera;           /* -1 = first */
    float exposure_ev;
    bool stats, no_default_light, quiet;
    /* photon mapping; 0 / -1 = choose from the scene and the image */
    long photons, caustic_photons;
    int k, gather_rays, irradiance_stride;
    const char *reference;  /* EXR to measure the error against */
    uint64_t max_memory;    /* --max-memory: bytes the admitted structures may take together (0 = the default) */
    double max_radius;
    pm_kernel kernel;
    pm_indirect_mode indirect;
    bool view_photons, no_photons;
    pm_shadow_mode shadow_photons; /* --shadow-photons on|off; default: where they pay */
    bool caustic_statistics;       /* --caustic-splats off */
    bool unclipped;                /* --clip off */
    bool unguided;                 /* --guide off */
    bool classic;         /* --mode classic; else progressive (or pathtrace) */
    bool pathtrace;       /* --mode pathtrace */
    const char *log;      /* --log: CSV of the run, one row per logged iteration */
    double alpha, radius; /* progressive: radius reduction, initial radius (0 = from the scene) */
    int eye_passes;       /* progressive: per photon pass (0 = automatic) */
    bool components_given, components[PM_COMPONENT_COUNT]; /* --components: what a PNG (and the window) shows */
    const char *sky;      /* --sky: none, white, gradient or an .exr/.hdr file; NULL = the default policy */
} options;

static const char usage_text[] =
    "usage: pmview [SCENE.gltf|.glb] [options]\n"
    "  --snapshot FILE      render offscreen and write FILE (.png: what the display shows, .exr: linear layers)\n"
    "  --width W --height H image size (default " "512" " wide, height from the camera's aspect ratio)\n"
    "  --iterations N       samples per pixel (default 64 for snapshots; the window runs until closed)\n"
    "  --time SECONDS       stop after this much rendering time, photon pass included\n"
    "  --threads N          worker threads (default: all cores)\n"
    "  --seed S             random seed (default 1); the image does not depend on --threads\n"
    "  --camera I           use the scene's I-th camera (default 0; automatic framing when there is none)\n"
    "  --exposure EV        display exposure in stops (PNG and window)\n"
    "  --screenshot FILE    where the window's P key saves a PNG and the layers as .exr (default pmview-screenshot.png)\n"
    "  --sky none|white|gradient|FILE.exr|FILE.hdr  the environment around the scene (default: the gradient\n"
    "                       for files without punctual lights whose emitters do not enclose the view, else none);\n"
    "                       a FILE is an equirectangular map, its middle along -Z, +Y up\n"
    "  --no-default-light   no default environment (the same as --sky none unless --sky is given)\n"
    "  --mode progressive|classic|pathtrace  progressive: fresh photons every iteration, radii shrinking (default);\n"
    "                       classic: two-pass photon mapping, maps built once, eye pass repeated;\n"
    "                       pathtrace: unbiased path tracing (light sampling and MIS), the same four components\n"
    "  --photons N          progressive: global photons per iteration (default: pixels/8, 10k to 1M);\n"
    "                       classic: photons for the global map (default: from the image size and --time)\n"
    "  --caustic-photons N  caustic photons per iteration / for the caustic map (default: as many as --photons)\n"
    "  --alpha A            progressive: radius reduction per iteration, 0 < A < 1 (default 2/3)\n"
    "  --eye-passes N|auto  progressive: eye passes (samples per pixel) reading each photon pass (default auto:\n"
    "                       1 to 8, more where a photon pass costs more rays than an eye pass, as on small images)\n"
    "  --radius R           progressive: initial radius in scene units (default: from the pixel footprint\n"
    "                       and the photon density of one iteration)\n"
    "  --k N                photons per radiance estimate (default 64)\n"
    "  --max-radius R       largest estimate radius in scene units (default: a fraction of the scene size)\n"
    "  --kernel disc|gaussian|cone  radiance estimate filter (default disc)\n"
    "  --indirect gather|photons    indirect light by one final-gather bounce (default) or photons at the visible point\n"
    "  --gather-rays N      final-gather rays per eye sample (default 1)\n"
    "  --precompute N       gather from irradiance precomputed at every N-th global photon (default 4; 0 = full estimates)\n"
    "  --view photons       show the photon maps' estimates at the first diffuse hit\n"
    "  --no-photons         direct and specular only (no photon pass)\n"
    "  --shadow-photons on|off  shadow photons decide where direct light needs no shadow ray\n"
    "                       (default: on for point, spot and directional lights where they pay)\n"
    "  --caustic-splats on|off  progressive: the caustic seen directly by connecting caustic photons to\n"
    "                       the camera (light tracing; default on), or off: from visible-point statistics\n"
    "  --clip on|off        photon estimates stay on their side of walls (default on; off only to measure the leak)\n"
    "  --guide on|off       progressive: photons sent where the camera reads them, learned (default on)\n"
    "  --reference REF.exr  measure the total against REF's R,G,B (same size): relMSE and mean ratios;\n"
    "                       with --stats also at iterations 1, 2, 4, 8, ... (an error-against-time curve)\n"
    "  --log FILE.csv       with --snapshot: one CSV row per iteration (then per doubling past 64): seconds,\n"
    "                       iterations, photons, mean radius, and with --reference each layer's relMSE, RMSE, bias\n"
    "  --components LIST    what a PNG snapshot and the window show at first: direct,specular,caustic,indirect (default all)\n"
    "  --stats              print 'stat STAGE key=value ...' lines\n"
    "  --max-memory SIZE    refuse a structure (scene, texture, sky map, film, photon records, output buffers) whose\n"
    "                       estimate would take all of them together above SIZE bytes (K, M, G, T suffixes; default\n"
    "                       half the physical memory)\n"
    "  --quiet              no warnings\n"
    "  --help               this text\n"
    "window: left drag orbit, right/middle drag pan, wheel dolly, double click pivot, W A S D Q E fly (Shift faster),\n"
    "  F frame, C next camera, Home start camera, 1-4 components, +/- exposure, 0 reset, T tonemap, G gathering,\n"
    "  V views, Space pause, R restart, P/F12 save PNG+EXR, H help, Esc quit\n";

static int usage_error(const char *fmt, const char *arg) {
    fprintf(stderr, "pmview: ");
    fprintf(stderr, fmt, arg);
    fprintf(stderr, "\n%s", usage_text);
    return 2;
}

static bool parse_long(const char *s, long lo, long hi, long *out) {
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi) return false;
    *out = v;
    return true;
}

static bool parse_double(const char *s, double lo, double hi, double *out) {
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (errno || end == s || *end || !(v >= lo && v <= hi)) return false;
    *out = v;
    return true;
}

/* Returns -1 on success, else the exit code. */
static int parse_options(int argc, char **argv, options *o) {
    memset(o, 0, sizeof *o);
    o->scene_path = PM_DEFAULT_SCENE;
    o->screenshot = "pmview-screenshot.png";
    o->threads = pm_cpu_count();
    o->seed = PM_DEFAULT_SEED;
    o->camera = -1;
    o->exposure_ev = PM_DEFAULT_EXPOSURE_EV;
    o->photons = o->caustic_photons = -1;
    o->gather_rays = PM_DEFAULT_GATHER_RAYS;
    o->irradiance_stride = PM_DEFAULT_IRRADIANCE_STRIDE;
    o->alpha = PM_DEFAULT_ALPHA;
    o->indirect = PM_INDIRECT_GATHER;
    bool have_scene = false;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (a[0] != '-' || a[1] == 0) {
            if (have_scene) return usage_error("more than one scene given: '%s'", a);
            o->scene_path = a;
            have_scene = true;
            continue;
        }
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) { fputs(usage_text, stdout); return 0; }
        if (!strcmp(a, "--stats")) { o->stats = true; continue; }
        if (!strcmp(a, "--no-default-light")) { o->no_default_light = true; continue; }
        if (!strcmp(a, "--quiet")) { o->quiet = true; continue; }
        if (!strcmp(a, "--no-photons")) { o->no_photons = true; continue; }
        static const char *const valued[] = {"--snapshot", "--width", "--height", "--iterations", "--time", "--threads",
                                             "--seed", "--camera", "--exposure", "--screenshot", "--mode", "--photons",
                                             "--caustic-photons", "--k", "--max-radius", "--kernel", "--indirect",
                                             "--gather-rays", "--view", "--precompute", "--reference", "--alpha",
                                             "--radius", "--components", "--sky", "--log", "--shadow-photons", "--max-memory",
                                             "--caustic-splats", "--eye-passes", "--clip", "--guide"};
        int which = -1;
        for (int k = 0; k < (int)(sizeof valued / sizeof *valued); k++)
            if (!strcmp(a, valued[k])) which = k;
        if (which < 0) return usage_error("unknown option '%s'", a);
        if (i + 1 >= argc) return usage_error("option '%s' needs a value", a);
        const char *v = argv[++i];
        long n;
        double x;
        switch (which) {
        case 0:
            if (!pm_has_extension(v, ".png") && !pm_has_extension(v, ".exr"))
                return usage_error("--snapshot needs a .png or .exr file name, not '%s'", v);
            o->snapshot = v;
            break;
        case 1: if (!parse_long(v, 1, PM_MAX_IMAGE_SIDE, &n)) return usage_error("bad --width '%s' (1 to 16384)", v); o->width = (int)n; break;
        case 2: if (!parse_long(v, 1, PM_MAX_IMAGE_SIDE, &n)) return usage_error("bad --height '%s' (1 to 16384)", v); o->height = (int)n; break;
        case 3: if (!parse_long(v, 1, 1000000000L, &n)) return usage_error("bad --iterations '%s' (a positive whole number)", v); o->iterations = n; break;
        case 4: if (!parse_double(v, 1e-3, 1e7, &x)) return usage_error("bad --time '%s' (seconds, > 0)", v); o->time_limit = x; break;
        case 5: if (!parse_long(v, 1, 256, &n)) return usage_error("bad --threads '%s' (1 to 256)", v); o->threads = (int)n; break;
        case 6: if (!parse_long(v, 0, 0x7fffffffL, &n)) return usage_error("bad --seed '%s' (0 to 2147483647)", v); o->seed = (uint64_t)n; break;
        case 7: if (!parse_long(v, 0, 1000000, &n)) return usage_error("bad --camera '%s' (an index from 0)", v); o->camera = (int)n; break;
        case 8: if (!parse_double(v, -64, 64, &x)) return usage_error("bad --exposure '%s' (stops, -64 to 64)", v); o->exposure_ev = (float)x; break;
        case 9: if (!pm_has_extension(v, ".png")) return usage_error("--screenshot needs a .png file name, not '%s'", v); o->screenshot = v; break;
        case 10:
            o->classic = o->pathtrace = false;
            if (!strcmp(v, "classic")) o->classic = true;
            else if (!strcmp(v, "pathtrace")) o->pathtrace = true;
            else if (strcmp(v, "progressive")) return usage_error("unknown --mode '%s' (progressive, classic, pathtrace)", v);
            break;
        case 11: if (!parse_long(v, 0, 2000000000L, &n)) return usage_error("bad --photons '%s'", v); o->photons = n; break;
        case 12: if (!parse_long(v, 0, 2000000000L, &n)) return usage_error("bad --caustic-photons '%s'", v); o->caustic_photons = n; break;
        case 13: if (!parse_long(v, 1, 2048, &n)) return usage_error("bad --k '%s' (1 to 2048)", v); o->k = (int)n; break;
        case 14: if (!parse_double(v, PM_MIN_RADIUS, PM_MAX_RADIUS, &x)) return usage_error("bad --max-radius '%s' (1e-18 to 1e18)", v); o->max_radius = x; break;
        case 15:
            if (!strcmp(v, "disc")) o->kernel = PM_KERNEL_DISC;
            else if (!strcmp(v, "gaussian")) o->kernel = PM_KERNEL_GAUSSIAN;
            else if (!strcmp(v, "cone")) o->kernel = PM_KERNEL_CONE;
            else return usage_error("unknown --kernel '%s' (disc, gaussian, cone)", v);
            break;
        case 16:
            if (!strcmp(v, "gather")) o->indirect = PM_INDIRECT_GATHER;
            else if (!strcmp(v, "photons")) o->indirect = PM_INDIRECT_PHOTONS;
            else return usage_error("unknown --indirect '%s' (gather, photons)", v);
            break;
        case 17: if (!parse_long(v, 0, 4096, &n)) return usage_error("bad --gather-rays '%s' (0 to 4096)", v); o->gather_rays = (int)n; break;
        case 19: if (!parse_long(v, 0, 1000000, &n)) return usage_error("bad --precompute '%s' (0 to 1000000)", v); o->irradiance_stride = (int)n; break;
        case 20: if (!pm_has_extension(v, ".exr")) return usage_error("--reference needs an .exr file, not '%s'", v); o->reference = v; break;
        case 24:
            if (strcmp(v, "none") && strcmp(v, "white") && strcmp(v, "gradient") && !pm_has_extension(v, ".exr") &&
                !pm_has_extension(v, ".hdr"))
                return usage_error("unknown --sky '%s' (none, white, gradient, or an .exr or .hdr environment map)", v);
            o->sky = v;
            break;
        case 25: o->log = v; break;
        case 26:
            if (!strcmp(v, "on")) o->shadow_photons = PM_SHADOW_ON;
            else if (!strcmp(v, "off")) o->shadow_photons = PM_SHADOW_OFF;
            else return usage_error("unknown --shadow-photons '%s' (on, off)", v);
            break;
        case 18: if (strcmp(v, "photons")) return usage_error("unknown --view '%s' (photons)", v); o->view_photons = true; break;
        case 21: if (!parse_double(v, 1e-3, 0.999, &x)) return usage_error("bad --alpha '%s' (0.001 to 0.999)", v); o->alpha = x; break;
        case 22: if (!parse_double(v, PM_MIN_RADIUS, PM_MAX_RADIUS, &x)) return usage_error("bad --radius '%s' (1e-18 to 1e18 scene units)", v); o->radius = x; break;
        case 28:
            if (!strcmp(v, "on")) o->caustic_statistics = false;
            else if (!strcmp(v, "off")) o->caustic_statistics = true;
            else return usage_error("unknown --caustic-splats '%s' (on, off)", v);
            break;
        case 30:
        case 31: {
            bool *off = which == 30 ? &o->unclipped : &o->unguided;
            if (!strcmp(v, "on")) *off = false;
            else if (!strcmp(v, "off")) *off = true;
            else return usage_error(which == 30 ? "unknown --clip '%s' (on, off)" : "unknown --guide '%s' (on, off)", v);
            break;
        }
        case 29:
            if (!strcmp(v, "auto")) o->eye_passes = 0;
            else if (!parse_long(v, 1, 4096, &n)) return usage_error("bad --eye-passes '%s' (1 to 4096, or auto)", v);
            else o->eye_passes = (int)n;
            break;
        case 27: if (!pm_memory_parse_size(v, &o->max_memory)) return usage_error("bad --max-memory '%s' (bytes, or with K, M, G, T)", v); break;
        case 23: {
            o->components_given = true;
            memset(o->components, 0, sizeof o->components);
            char list[256];
            snprintf(list, sizeof list, "%s", v);
            for (char *save = NULL, *name = strtok_r(list, ",", &save); name; name = strtok_r(NULL, ",", &save)) {
                int found = -1;
                for (int c = 0; c < PM_COMPONENT_COUNT; c++)
                    if (!strcmp(name, pm_component_names[c])) found = c;
                if (found < 0) return usage_error("unknown component in --components '%s' (direct, specular, caustic, indirect)", v);
                o->components[found] = true;
            }
            break;
        }
        }
    }
    /* options that belong to some modes only: elsewhere a usage error, the first rule first */
    static const char *const classic_only[] = {"--k", "--max-radius", "--kernel", "--gather-rays", "--precompute", "--view", NULL};
    static const char *const photon_only[] = {"--alpha", "--radius", "--photons", "--caustic-photons", "--indirect", "--no-photons", "--clip", NULL};
    static const char *const shrinking_only[] = {"--alpha", "--radius", NULL};
    static const char *const per_pass_only[] = {"--eye-passes", "--guide", NULL};
    const struct { bool refused; const char *const *options; const char *why; } mode_rules[] = {
        {!o->classic, classic_only, "%s belongs to --mode classic (the other modes have no k-nearest estimates)"},
        {o->pathtrace, photon_only, "%s belongs to the photon-mapping modes (the path tracer has no photons)"},
        {o->classic, shrinking_only, "%s belongs to --mode progressive (the classic mode's radii do not shrink)"},
        {o->classic || o->pathtrace, per_pass_only, "%s belongs to --mode progressive (the other modes trace no photon pass per iteration)"},
    };
    for (size_t r = 0; r < sizeof mode_rules / sizeof *mode_rules; r++)
        for (int i = 1; mode_rules[r].refused && i < argc; i++)
            for (const char *const *opt = mode_rules[r].options; *opt; opt++)
                if (!strcmp(argv[i], *opt)) return usage_error(mode_rules[r].why, argv[i]);
    if (o->log && !o->snapshot) return usage_error("--log '%s' needs --snapshot (the window restarts its runs)", o->log);
    return -1;
}

/* Everything the chosen mode needs, from the options and the scene; the classic mode's photon
 * counts may come from a pilot pass when a time budget is given. */
static bool configure(const options *opt, const pm_scene *scene, const pm_accel *accel, int width, int height,
                      pm_session_config *config) {
    memset(config, 0, sizeof *config);
    config->width = width;
    config->height = height;
    if (!opt->snapshot && opt->iterations) config->max_iterations = (uint32_t)opt->iterations;
    config->shadow.mode = opt->shadow_photons;
    config->shadow.photons_per_light = pm_shadow_default_photons(width, height);
    config->shadow.threads = opt->threads;
    /* how many points direct light will shade, when a snapshot's iterations say so */
    if (opt->snapshot && !(opt->time_limit > 0))
        config->shadow.expected_samples = (double)width * height * (opt->iterations ? opt->iterations : PM_DEFAULT_SNAPSHOT_ITERATIONS);
    pm_progressive_settings *pp = &config->progressive;
    pp->seed = opt->seed;
    pp->threads = opt->threads;
    pp->max_specular_depth = PM_DEFAULT_MAX_SPECULAR_DEPTH;
    pp->max_photon_bounces = PM_DEFAULT_MAX_PHOTON_BOUNCES;
    if (opt->pathtrace) {
        config->mode = PM_MODE_PATHTRACE;
        config->classic_eye.seed = opt->seed;
        config->classic_eye.threads = opt->threads;
        config->classic_eye.max_specular_depth = PM_DEFAULT_MAX_SPECULAR_DEPTH;
        config->classic_eye.path_trace = true;
        return true;
    }
    if (!opt->classic) {
        config->mode = PM_MODE_PROGRESSIVE;
        uint64_t photons = opt->no_photons ? 0 : (opt->photons >= 0 ? (uint64_t)opt->photons : pm_progressive_default_photons(width, height));
        pp->photons = photons;
        pp->caustic_photons = opt->no_photons ? 0 : (opt->caustic_photons >= 0 ? (uint64_t)opt->caustic_photons : photons);
        pp->alpha = opt->alpha;
        pp->eye_passes = opt->eye_passes;
        pp->initial_radius = opt->radius;
        pp->indirect = opt->indirect;
        pp->caustic_by_statistics = opt->caustic_statistics;
        pp->unclipped = opt->unclipped;
        pp->unguided = opt->unguided;
        if (opt->stats)
            printf("stat progressive_setup photon_pass=%d caustic_photons=%llu global_photons=%llu indirect=%s caustic_splats=%d\n",
                   (scene->analysis.component_possible[PM_CAUSTIC] && pp->caustic_photons) ||
                       (scene->analysis.component_possible[PM_INDIRECT] && pp->photons),
                   (unsigned long long)pp->caustic_photons, (unsigned long long)pp->photons,
                   opt->indirect == PM_INDIRECT_GATHER ? "gather" : "photons",
                   scene->analysis.component_possible[PM_CAUSTIC] && pp->caustic_photons && !opt->caustic_statistics);
        return true;
    }
    config->mode = PM_MODE_CLASSIC;
    pm_eye_settings *eye = &config->classic_eye;
    eye->seed = opt->seed;
    eye->threads = opt->threads;
    eye->max_specular_depth = PM_DEFAULT_MAX_SPECULAR_DEPTH;
    config->classic_photon_pass = !opt->no_photons && (scene->analysis.component_possible[PM_CAUSTIC] ||
                                                       scene->analysis.component_possible[PM_INDIRECT]);
    if (!config->classic_photon_pass) return true;
    pm_photon_settings *ps = &config->classic_photons;
    ps->seed = opt->seed;
    ps->threads = opt->threads;
    ps->max_bounces = PM_DEFAULT_MAX_PHOTON_BOUNCES;
    ps->projection_maps = true;
    ps->unclipped = eye->unclipped = opt->unclipped;
    float extent = scene->ray_scale;
    eye->global_estimate.kernel = eye->caustic_estimate.kernel = opt->kernel;
    eye->global_estimate.k = opt->k ? opt->k : PM_DEFAULT_K_GLOBAL;
    eye->caustic_estimate.k = opt->k ? opt->k : PM_DEFAULT_K_CAUSTIC;
    eye->global_estimate.max_radius = opt->max_radius > 0 ? (float)opt->max_radius : PM_DEFAULT_GLOBAL_RADIUS * extent;
    eye->caustic_estimate.max_radius = opt->max_radius > 0 ? (float)opt->max_radius : PM_DEFAULT_CAUSTIC_RADIUS * extent;
    eye->global_estimate.path_mask = eye->caustic_estimate.path_mask = 7u;
    if (opt->indirect == PM_INDIRECT_GATHER && !opt->view_photons) {
        ps->irradiance_stride = opt->irradiance_stride;
        ps->irradiance_estimate = eye->global_estimate;
    }
    double n = (double)width * height * PM_DEFAULT_PHOTONS_PER_PIXEL;
    if (opt->time_limit > 0 && opt->photons < 0) {
        /* A pilot run measures photon speed here, so the pass gets its share of the budget. */
        pm_photon_settings pilot = *ps;
        pilot.global_photons = pilot.caustic_photons = 20000;
        pm_photon_stats pilot_stats;
        pm_photon_maps pilot_maps;
        if (pm_photon_maps_build(scene, accel, &pilot, &pilot_maps, &pilot_stats) && pilot_stats.seconds > 0)
            n = PM_TIME_SHARE_PHOTONS * opt->time_limit * (double)pilot_stats.emitted / pilot_stats.seconds / 2.0;
        pm_photon_maps_free(&pilot_maps);
    }
    if (n < PM_MIN_DEFAULT_PHOTONS) n = PM_MIN_DEFAULT_PHOTONS;
    if (n > PM_MAX_DEFAULT_PHOTONS) n = PM_MAX_DEFAULT_PHOTONS;
    ps->global_photons = scene->analysis.component_possible[PM_INDIRECT] ? (uint64_t)(opt->photons >= 0 ? opt->photons : n) : 0;
    ps->caustic_photons = scene->analysis.component_possible[PM_CAUSTIC]
                              ? (uint64_t)(opt->caustic_photons >= 0 ? opt->caustic_photons : (opt->photons >= 0 ? opt->photons : n))
                              : 0;
    eye->indirect = opt->indirect;
    eye->gather_rays = opt->gather_rays;
    eye->view_photons = opt->view_photons;
    return true;
}

/* ---- outputs and inputs ---- */

/* No output may be an input (the scene, the reference, the sky map) or another output: --log
 * naming the scene used to overwrite it with CSV. One error line, before any work. */
static bool outputs_spare_inputs(const options *o, bool window) {
    char screenshot_exr[4096] = "";
    if (window) snprintf(screenshot_exr, sizeof screenshot_exr, "%.*s.exr", (int)strlen(o->screenshot) - 4, o->screenshot);
    bool sky_file = o->sky && (pm_has_extension(o->sky, ".exr") || pm_has_extension(o->sky, ".hdr"));
    const struct { const char *path, *what; } inputs[] = {
        {o->scene_path, "the scene file"}, {o->reference, "the --reference image"}, {sky_file ? o->sky : NULL, "the --sky map"}};
    const struct { const char *path, *flag; } outputs[] = {
        {o->snapshot, "--snapshot"}, {o->log, "--log"}, {window ? o->screenshot : NULL, "--screenshot"},
        {window ? screenshot_exr : NULL, "--screenshot's EXR"}};
    const int n_in = sizeof inputs / sizeof *inputs, n_out = sizeof outputs / sizeof *outputs;
    for (int i = 0; i < n_out; i++) {
        if (!outputs[i].path) continue;
        for (int k = 0; k < n_in; k++)
            if (inputs[k].path && pm_same_file(outputs[i].path, inputs[k].path)) {
                fprintf(stderr, "pmview: error: %s: %s would overwrite %s, an input\n", outputs[i].path, outputs[i].flag,
                        inputs[k].what);
                return false;
            }
        for (int k = i + 1; k < n_out; k++)
            if (outputs[k].path && pm_same_file(outputs[i].path, outputs[k].path)) {
                fprintf(stderr, "pmview: error: %s: %s and %s name the same file\n", outputs[i].path, outputs[i].flag,
                        outputs[k].flag);
                return false;
            }
    }
    return true;
}

/* ---- snapshots ---- */

static double process_start; /* for the window's time to its first frame */

static volatile sig_atomic_t interrupted_by;
static pm_session *volatile signalled_session; /* its passes stop at the signal, not at the end of the iteration */

static void on_signal(int sig) {
    interrupted_by = sig;
    if (signalled_session) pm_session_cancel(signalled_session);
}

/* Where no render loop is left to notice a flag (a snapshot being written, the window, which a
 * signal ends outright): the file under way goes with the process (an EXR's hidden temporary
 * file stayed behind), and the exit status is an interrupted run's. */
static void on_signal_while_writing(int sig) {
    pm_remove_partial_output();
    _exit(sig == SIGINT ? 130 : 143);
}

/* The offscreen view's share of a PNG: its RGBA8 target, OSMesa's buffer, four RGB float
 * component textures (16 bytes a texel: a driver may pad them to RGBA) and the RGBA8 copy read
 * back. */
static uint64_t png_view_bytes(int width, int height) { return (4 + 4 + 4 * 16 + 4) * (uint64_t)width * height; }

/* Everything writing the snapshot takes beside the film: admitted before the render, so a run
 * that could not write its file is refused at once, not after the render. A PNG also resolves
 * each component the film has into a layer of its own. */
static uint64_t snapshot_output_bytes(const char *path, const pm_film *film) {
    if (!pm_has_extension(path, ".png")) return pm_exr_write_bytes(film->width, film->height);
    uint64_t layers = 0;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++)
        if (film->sum[c]) layers += 3 * sizeof(float) * (uint64_t)film->width * film->height;
    return layers + png_view_bytes(film->width, film->height) + pm_png_write_bytes(film->width, film->height);
}

/* The snapshot's progress: a bar redrawn on a terminal, nothing otherwise (one summary at the end). */
static void show_progress(bool tty, uint32_t done, long target, double elapsed, double budget, uint64_t photons) {
    if (!tty) return;
    double fraction = budget > 0 ? elapsed / budget : (target > 0 ? (double)done / target : 0);
    if (fraction > 1) fraction = 1;
    char bar[31];
    int filled = (int)(fraction * 30);
    for (int i = 0; i < 30; i++) bar[i] = i < filled ? '#' : '.';
    bar[30] = 0;
    double left = fraction > 0 ? elapsed / fraction - elapsed : 0;
    fprintf(stderr, "\r[%s] %u it  %.2f Mphotons/s  %.1f s  %.1f s left ", bar, done,
            elapsed > 0 ? photons / elapsed * 1e-6 : 0.0, elapsed, left);
    fflush(stderr);
}

static bool write_png_from_layers(const float *const layers[PM_COMPONENT_COUNT], int width, int height,
                                  const pm_display *display, const char *path, char *err, size_t err_size) {
    uint64_t view_bytes = png_view_bytes(width, height);
    if (!pm_memory_admit(view_bytes, "PNG offscreen view")) {
        snprintf(err, err_size, "%s: out of memory (%s)", path, pm_memory_failure());
        return false;
    }
    pm_view *view = pm_view_create_offscreen(width, height, err, err_size);
    bool ok = false;
    if (view) {
        pm_view_upload_layers(view, width, height, layers);
        pm_view_draw(view, display);
        uint8_t *rgba = pm_malloc(4 * (size_t)width * height, "PNG offscreen view");
        if (!rgba) snprintf(err, err_size, "%s: out of memory (%s)", path, pm_memory_failure());
        else {
            pm_view_read_rgba8(view, rgba);
            ok = pm_write_png(path, width, height, rgba, err, err_size);
        }
        free(rgba);
        pm_view_destroy(view);
    }
    pm_memory_release(view_bytes);
    return ok;
}

static void initial_display(const options *opt, pm_display *display) {
    memset(display, 0, sizeof *display);
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) display->enabled[c] = opt->components_given ? opt->components[c] : true;
    display->exposure_ev = opt->exposure_ev;
}

static uint64_t session_photons(pm_session *session) {
    pm_progressive *p = pm_session_progressive(session);
    return p ? pm_progressive_get_stats(p)->photons.emitted : pm_session_classic_photon_stats(session)->emitted;
}

/* Renders to --iterations or --time, then writes the file; SIGINT and SIGTERM cut the iteration
 * under way short (at its next photon chunk or eye tile), and the image so far is written before
 * exiting 130 or 143, whatever that iteration ran into. */
static int run_snapshot(const options *opt, pm_session *session, const pm_reference_image *reference,
                        uint64_t *reserved) {
    char err[1024];
    signalled_session = session;
    signal(SIGINT, on_signal);
    signal(SIGTERM, on_signal);
    bool tty = isatty(2) && !opt->quiet;
    long target = opt->iterations ? opt->iterations : (opt->time_limit > 0 ? 1000000000L : PM_DEFAULT_SNAPSHOT_ITERATIONS);
    const pm_film *film = pm_session_film(session);
    size_t n = (size_t)film->width * film->height;
    float *scratch = reference->rgb[0] ? malloc(sizeof(float) * 3 * n) : NULL;
    if (reference->rgb[0] && !scratch) { fprintf(stderr, "pmview: error: out of memory (reference comparison)\n"); return 1; }
    FILE *log = NULL;
    if (opt->log) {
        log = fopen(opt->log, "w");
        if (!log) {
            fprintf(stderr, "pmview: error: %s: cannot write the log (%s)\n", opt->log, strerror(errno));
            free(scratch);
            return 1;
        }
        pm_log_header(log);
    }
    /* the log's seconds: time inside the iterations, the log's own measuring left out */
    double rendered = 0.0;
    uint32_t logged = 0;
    /* --time and the reported render time count from here: the photon pass is part of what a
     * budget buys. A budget spent before the first iteration still gets that iteration. */
    double start = pm_now_seconds(), first_iteration = 0.0;
    uint64_t next_progress = 1;
    if (opt->time_limit > 0) pm_session_set_budget(session, start, opt->time_limit);
    while ((long)film->samples < target && !interrupted_by) {
        /* --time: the session shares the budget out (a first iteration of one sample, then as
         * many as fit, none when the next would overshoot more than stopping falls short) */
        uint32_t limit = pm_session_plan_samples(session, (uint32_t)(target - (long)film->samples));
        if (!limit) break;
        double iteration_start = pm_now_seconds();
        bool iterated = pm_session_iterate(session, limit);
        rendered += pm_now_seconds() - iteration_start;
        if (first_iteration == 0.0) first_iteration = pm_now_seconds() - start;
        if (!iterated && !interrupted_by) {
            fprintf(stderr, "%spmview: error: %s: out of memory (%s) in iteration %u\n", tty ? "\n" : "", opt->scene_path,
                    pm_memory_failure() ? pm_memory_failure() : "unknown", film->samples + 1);
            free(scratch);
            if (log) fclose(log);
            return 1;
        }
        if (log && pm_log_wanted(logged, film->samples)) {
            pm_log_row(log, session, session_photons(session), reference, scratch, rendered);
            logged = film->samples;
        }
        if (scratch && opt->stats && film->samples >= next_progress) {
            /* at 1, 2, 4, 8, ... samples, or the first count past each when an iteration adds several */
            double ratio[3], e = pm_reference_relmse(film, reference, scratch, ratio);
            printf("stat progress iterations=%u seconds=%.4f relmse=%.6f\n", film->samples, pm_now_seconds() - start, e);
            while (next_progress <= film->samples) next_progress *= 2;
        }
        show_progress(tty, film->samples, opt->iterations ? opt->iterations : 0, pm_now_seconds() - start, opt->time_limit,
                      session_photons(session));
    }
    double seconds = pm_now_seconds() - start;
    if (log && logged != film->samples && film->samples) pm_log_row(log, session, session_photons(session), reference, scratch, rendered);
    if (log) {
        bool written = !ferror(log);
        if (fclose(log) != 0) written = false;
        if (!written) {
            fprintf(stderr, "%spmview: error: %s: cannot write the log\n", tty ? "\n" : "", opt->log);
            free(scratch);
            return 1;
        }
    }
    if (tty) fputc('\n', stderr);
    if (opt->time_limit > 0 && first_iteration > opt->time_limit && !interrupted_by && !opt->quiet)
        fprintf(stderr, "pmview: note: --time %g s is shorter than the first iteration (%.2f s): a first pass over every pixel is always finished\n",
                opt->time_limit, first_iteration);
    signalled_session = NULL;
    signal(SIGINT, on_signal_while_writing);
    signal(SIGTERM, on_signal_while_writing);
    /* the writers admit what they take themselves: the room kept for them since before the render is theirs now */
    pm_memory_release(*reserved);
    *reserved = 0;
    bool ok;
    if (pm_has_extension(opt->snapshot, ".png")) {
        pm_display display;
        initial_display(opt, &display);
        float *layers[PM_COMPONENT_COUNT] = {NULL, NULL, NULL, NULL};
        uint64_t layer_bytes = 0;
        for (int c = 0; c < PM_COMPONENT_COUNT; c++) layer_bytes += film->sum[c] ? sizeof(float) * 3 * n : 0;
        const bool admitted = pm_memory_admit(layer_bytes, "PNG output layers");
        ok = admitted;
        if (!ok) snprintf(err, sizeof err, "%s: out of memory (%s)", opt->snapshot, pm_memory_failure());
        for (int c = 0; c < PM_COMPONENT_COUNT && ok; c++) {
            if (!film->sum[c]) continue;
            layers[c] = pm_malloc(sizeof(float) * 3 * n, "PNG output layers");
            if (!layers[c]) { snprintf(err, sizeof err, "%s: out of memory (%s)", opt->snapshot, pm_memory_failure()); ok = false; break; }
            pm_film_resolve(film, (pm_component)c, layers[c]);
        }
        if (ok) ok = write_png_from_layers((const float *const *)layers, film->width, film->height, &display, opt->snapshot, err, sizeof err);
        for (int c = 0; c < PM_COMPONENT_COUNT; c++) free(layers[c]);
        if (admitted) pm_memory_release(layer_bytes);
    } else {
        ok = pm_write_exr(opt->snapshot, film, err, sizeof err);
    }
    if (!ok) { fprintf(stderr, "pmview: error: %s\n", err); free(scratch); return 1; }
    if (!opt->quiet) printf("pmview: wrote %s (%dx%d, %u iterations, %.2f s)%s\n", opt->snapshot, film->width, film->height,
                            film->samples, seconds, interrupted_by ? ", interrupted: the image so far" : "");
    if (scratch) {
        double ratio[3], e = pm_reference_relmse(film, reference, scratch, ratio);
        printf("stat error iterations=%u seconds=%.4f relmse=%.6f mean_ratio_r=%.4f mean_ratio_g=%.4f mean_ratio_b=%.4f\n",
               film->samples, seconds, e, ratio[0], ratio[1], ratio[2]);
    }
    free(scratch);
    if (interrupted_by) return interrupted_by == SIGINT ? 130 : 143;
    return 0;
}

/* ---- the window ---- */

static const char window_help[] =
    "pmview keys: left drag orbit, right/middle drag pan, wheel dolly, double click: orbit about that point\n"
    "  W A S D / Q E fly (Shift faster), F frame the scene, C next camera, Home starting camera\n"
    "  1 2 3 4 direct/specular/caustic/indirect, + - exposure, 0 reset, T tonemap, G final gathering on/off\n"
    "  V views: shaded, photon density, radius; Space pause, R restart, P or F12 save PNG and EXR, H this help, Esc quit\n";

static void save_from_window(const options *opt, const float *const layers[PM_COMPONENT_COUNT], int width, int height,
                             const pm_display *display) {
    char err[1024], exr_path[1024];
    snprintf(exr_path, sizeof exr_path, "%.*s.exr", (int)(strlen(opt->screenshot) - 4), opt->screenshot);
    if (!write_png_from_layers(layers, width, height, display, opt->screenshot, err, sizeof err)) {
        fprintf(stderr, "pmview: error: %s\n", err);
        return;
    }
    /* the published layers as a film of one sample: the EXR writer reads it through pm_film_resolve */
    pm_film snapshot;
    memset(&snapshot, 0, sizeof snapshot);
    snapshot.width = width;
    snapshot.height = height;
    snapshot.samples = 1;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) snapshot.sum[c] = (float *)layers[c];
    if (!pm_write_exr(exr_path, &snapshot, err, sizeof err)) { fprintf(stderr, "pmview: error: %s\n", err); return; }
    printf("pmview: saved %s and %s\n", opt->screenshot, exr_path);
}

static int run_window(const options *opt, const pm_scene *scene, const pm_accel *accel, pm_session **session_io,
                      const pm_session_config *config_in, const pm_camera *start_camera) {
    char err[1024];
    /* Ctrl-C in the terminal during a P save: the half-written file goes with the process */
    signal(SIGINT, on_signal_while_writing);
    signal(SIGTERM, on_signal_while_writing);
    pm_session *session = *session_io;
    pm_session_config config = *config_in;
    const pm_film *film = pm_session_film(session);
    int width = film->width, height = film->height;
    pm_view *view = pm_view_create_window(width, height, "pmview", err, sizeof err);
    if (!view) { fprintf(stderr, "pmview: error: %s\n", err); return 1; }
    pm_display display;
    initial_display(opt, &display);
    /* a first frame before any photon: the background colour of an empty image */
    pm_view_draw(view, &display);
    double first_frame = pm_now_seconds() - process_start, first_image = 0, restart_requested = 0, restart_to_image = 0;
    uint64_t loops = 0, frames = 1, restarts = 0;
    double loop_start = pm_now_seconds();
    if (!pm_session_start(session, err, sizeof err)) {
        fprintf(stderr, "pmview: error: %s\n", err);
        pm_view_destroy(view);
        return 1;
    }
    pm_camera camera = *start_camera;
    vec3 pivot = scene->center;
    float step = 0.05f * (scene->radius > 0.f ? scene->radius : 1.f);
    uint32_t camera_index = opt->camera >= 0 ? (uint32_t)opt->camera : 0;
    uint64_t version = 0;
    bool finished_said = false, paused = false;
    int view_mode = PM_VIEW_SHADED;
    int indirect = opt->indirect; /* the G key's setting */
    for (;;) {
        pm_view_events ev = pm_view_poll(view, &display, true, 1.0 / 60.0);
        if (ev.quit) break;
        bool moved = false;
        pm_camera before = camera;
        if (ev.orbit_dx != 0 || ev.orbit_dy != 0)
            camera = pm_camera_orbit(camera, pivot, (float)(-ev.orbit_dx * 0.01), (float)(-ev.orbit_dy * 0.01));
        if (ev.pan_dx != 0 || ev.pan_dy != 0) camera = pm_camera_pan(camera, &pivot, (float)ev.pan_dx, (float)ev.pan_dy, height);
        if (ev.dolly != 0) camera = pm_camera_dolly(camera, pivot, (float)ev.dolly);
        if (ev.fly[0] != 0 || ev.fly[1] != 0 || ev.fly[2] != 0) camera = pm_camera_fly(camera, &pivot, ev.fly, ev.fast ? 5.f * step : step);
        if (ev.frame) { camera = pm_camera_frame(scene, camera, (float)width / height); pivot = scene->center; }
        if (ev.home) { camera = *start_camera; pivot = scene->center; }
        if (ev.next_camera && scene->camera_count) {
            camera_index = (camera_index + 1) % scene->camera_count;
            camera = scene->cameras[camera_index];
            pivot = scene->center;
        }
        if (ev.pick) {
            vec3 o, d;
            pm_hit h;
            pm_camera_ray(&camera, width, height, (float)ev.pick_x, (float)ev.pick_y, &o, &d);
            if (pm_accel_intersect(accel, o, d, INFINITY, &h)) pivot = v3_madd(o, d, h.t);
        }
        moved = memcmp(&before, &camera, sizeof camera) != 0;
        if (moved || ev.restart) {
            pm_session_request_restart(session, moved ? &camera : NULL, -1);
            if (restart_requested == 0) restart_requested = pm_now_seconds();
        }
        if (ev.toggle_gather && !opt->classic && !opt->pathtrace) {
            indirect = indirect == PM_INDIRECT_GATHER ? PM_INDIRECT_PHOTONS : PM_INDIRECT_GATHER;
            pm_session_request_restart(session, NULL, indirect);
            printf("pmview: indirect light by %s\n", indirect == PM_INDIRECT_GATHER ? "final gathering" : "photons at the visible point");
        }
        if (ev.pause) {
            paused = !paused;
            pm_session_pause(session, paused);
        }
        if (ev.help) fputs(window_help, stdout);
        if (ev.cycle_view) {
            static const char *const names[PM_VIEW_COUNT] = {"shaded", "photon density (false colour, log scale)",
                                                             "radius (false colour, log scale)"};
            view_mode = (view_mode + 1) % PM_VIEW_COUNT;
            if (pm_session_set_view(session, (pm_session_view)view_mode)) printf("pmview: view: %s\n", names[view_mode]);
            else { view_mode = PM_VIEW_SHADED; printf("pmview: the photon density and radius views need the progressive mode\n"); }
        }
        if (ev.resized_width && (ev.resized_width != width || ev.resized_height != height)) {
            /* a new size is a new film: a new session at that size, with the camera as it is */
            pm_session_stop(session);
            pm_session_config resized = config;
            resized.width = ev.resized_width;
            resized.height = ev.resized_height;
            pm_session *next = pm_session_create(scene, accel, &camera, &resized, err, sizeof err);
            if (!next || !pm_session_start(next, err, sizeof err)) {
                fprintf(stderr, "pmview: error: %s (window resized to %dx%d); keeping %dx%d\n", err, resized.width,
                        resized.height, width, height);
                pm_session_destroy(next);
                pm_session_start(session, err, sizeof err);
            } else {
                pm_session_destroy(session);
                session = *session_io = next;
                pm_session_set_view(session, (pm_session_view)view_mode);
                config = resized;
                width = resized.width;
                height = resized.height;
                version = 0;
                if (paused) pm_session_pause(session, true);
                printf("pmview: rendering at %dx%d\n", width, height);
            }
        }
        pm_session_progress progress;
        const float *const *layers = pm_session_lock_latest(session, &version, &progress);
        bool redraw = ev.display_changed;
        loops++;
        if (layers) {
            double t = pm_now_seconds();
            if (first_image == 0) first_image = t - process_start;
            if (restart_requested > 0 && progress.preview) {
                restart_to_image += t - restart_requested;
                restarts++;
                restart_requested = 0;
            }
            pm_view_upload_layers(view, width, height, layers);
            if (ev.save_png) save_from_window(opt, layers, width, height, &display);
            ev.save_png = false;
            pm_session_unlock_latest(session);
            redraw = true;
            char status[192];
            snprintf(status, sizeof status, "%s%u it  %.2f Mphotons  %.1f Mphotons/s  %.1f s  r %.3g%s", progress.preview ? "preview  " : "",
                     progress.iterations, progress.photons * 1e-6, progress.seconds > 0 ? progress.photons / progress.seconds * 1e-6 : 0.0,
                     progress.seconds, progress.mean_radius, paused ? "  paused" : "");
            pm_view_set_status(view, status);
            if (progress.finished && !finished_said) { printf("pmview: iterations done (%u)\n", progress.iterations); finished_said = true; }
        }
        if (ev.save_png) {
            /* nothing newer was published: save the image on screen */
            uint64_t any = 0;
            const float *const *shown = pm_session_lock_latest(session, &any, NULL);
            if (shown) {
                save_from_window(opt, shown, width, height, &display);
                pm_session_unlock_latest(session);
            }
        }
        if (redraw) { pm_view_draw(view, &display); frames++; }
    }
    double seconds = pm_now_seconds() - loop_start;
    if (opt->stats)
        printf("stat window first_frame_seconds=%.4f first_image_seconds=%.4f ui_loops_per_second=%.1f frames_per_second=%.1f restarts=%llu restart_to_image_seconds=%.4f\n",
               first_frame, first_image, seconds > 0 ? loops / seconds : 0.0, seconds > 0 ? frames / seconds : 0.0,
               (unsigned long long)restarts, restarts ? restart_to_image / restarts : 0.0);
    pm_session_stop(session);
    pm_view_destroy(view);
    return 0;
}

int main(int argc, char **argv) {
    process_start = pm_now_seconds();
    options opt;
    int code = parse_options(argc, argv, &opt);
    if (code >= 0) return code;
    setvbuf(stdout, NULL, _IOLBF, 0);
    if (opt.max_memory) pm_memory_set_limit(opt.max_memory);

    bool window = !opt.snapshot;
    if (window && !getenv("DISPLAY")) {
        fprintf(stderr, "pmview: no DISPLAY for a window; use --snapshot FILE.png|FILE.exr to render offscreen\n");
        return 2;
    }

    char err[1024] = "";
    if (!outputs_spare_inputs(&opt, window)) return 1;
    /* before any work: a snapshot that cannot be written would waste the whole render */
    if (opt.snapshot && !pm_check_output_path(opt.snapshot, err, sizeof err)) {
        fprintf(stderr, "pmview: error: %s\n", err);
        return 1;
    }
    /* before the scene too: a sky map or a reference that cannot be used costs no load and no BVH
     * build (the reference's height is compared once the camera gives the image's) */
    pm_sky_request sky = {.sky = opt.sky, .no_default_light = opt.no_default_light, .scene_path = opt.scene_path,
                          .quiet = opt.quiet, .stats = opt.stats};
    if (!pm_sky_prepare(&sky)) return 1;
    int width = opt.width ? opt.width : PM_DEFAULT_WIDTH, height = opt.height;
    if (opt.reference && !pm_reference_check(opt.reference, width, height, err, sizeof err)) {
        fprintf(stderr, "pmview: error: %s\n", err);
        pm_sky_release(&sky);
        return 1;
    }
    pm_scene scene;
    pm_load_report report;
    if (!pm_load_gltf(opt.scene_path, opt.quiet, &scene, &report, err, sizeof err)) {
        fprintf(stderr, "pmview: error: %s\n", err);
        pm_sky_release(&sky);
        return 1;
    }
    pm_scene_finalize(&scene, false, NULL);
    if (scene.clamped_emission && !opt.quiet)
        fprintf(stderr, "pmview: warning: %s: %u emission or light value(s) above %g (or not a number) clamped: a float film could not sum them\n",
                opt.scene_path, scene.clamped_emission, (double)PM_MAX_EMISSION);
    if (scene.emitter_alloc_failed) {
        fprintf(stderr, "pmview: error: %s: out of memory (%s)\n", opt.scene_path,
                pm_memory_failure() ? pm_memory_failure() : "emitter distribution");
        pm_scene_free(&scene);
        pm_sky_release(&sky);
        return 1;
    }
    if (opt.stats) pm_print_load_stats(&report, &scene);
    /* the options' lengths are in the file's units; the loader may have rescaled the scene */
    opt.radius *= report.unit_scale;
    opt.max_radius *= report.unit_scale;
    if (opt.radius > PM_MAX_RADIUS || opt.max_radius > PM_MAX_RADIUS || (opt.radius > 0 && opt.radius < PM_MIN_RADIUS) ||
        (opt.max_radius > 0 && opt.max_radius < PM_MIN_RADIUS)) {
        fprintf(stderr, "pmview: %s: the file's units are scaled by %g: --radius or --max-radius is then outside 1e-18 to 1e18 scene units\n",
                opt.scene_path, report.unit_scale);
        pm_scene_free(&scene);
        return 2;
    }

    int exit_code = 0;
    uint64_t output_reserved = 0; /* the snapshot writers' room, admitted before the render */
    pm_accel *accel = NULL;
    pm_session *session = NULL;
    pm_reference_image reference;
    memset(&reference, 0, sizeof reference);

    pm_camera camera;
    if (opt.camera >= 0 && (uint32_t)opt.camera >= scene.camera_count) {
        fprintf(stderr, "pmview: error: %s: --camera %d but the scene has %u perspective camera(s)\n", opt.scene_path,
                opt.camera, scene.camera_count);
        exit_code = 1;
        goto done;
    }
    if (scene.camera_count) {
        camera = scene.cameras[opt.camera >= 0 ? opt.camera : 0];
        if (!height) height = camera.aspect > 0.f ? (int)lroundf(width / camera.aspect) : width;
    } else {
        if (!height) height = width;
        camera = pm_scene_auto_camera(&scene, (float)width / height);
    }
    if (height < 1) height = 1;
    if (height > PM_MAX_IMAGE_SIDE) height = PM_MAX_IMAGE_SIDE;
    if (opt.reference && !opt.height && !pm_reference_check(opt.reference, width, height, err, sizeof err)) {
        fprintf(stderr, "pmview: error: %s\n", err);
        exit_code = 1;
        goto done;
    }

    accel = pm_accel_create(&scene, err, sizeof err);
    if (!accel) { fprintf(stderr, "pmview: error: %s: %s\n", opt.scene_path, err); exit_code = 1; goto done; }
    if (opt.stats) pm_print_bvh_stats(accel);
    if (!pm_choose_sky(&sky, &scene, accel, &camera, (float)width / height)) { exit_code = 1; goto done; }
    if (opt.stats) pm_print_analysis_stats(&scene);

    pm_session_config config;
    if (!configure(&opt, &scene, accel, width, height, &config)) { exit_code = 1; goto done; }
    session = pm_session_create(&scene, accel, &camera, &config, err, sizeof err);
    if (!session) { fprintf(stderr, "pmview: error: %s: %s\n", opt.scene_path, err); exit_code = 1; goto done; }
    if (opt.snapshot) {
        /* from here a signal is the snapshot's: the image so far (none yet) is written, 130 or 143;
         * before, it ends the process at once */
        signalled_session = session;
        signal(SIGINT, on_signal);
        signal(SIGTERM, on_signal);
    }
    if (opt.stats) {
        pm_print_film_stats(pm_session_film(session));
        fflush(stdout); /* a script waiting for the render to start sees it */
    }
    if (opt.snapshot) {
        uint64_t bytes = snapshot_output_bytes(opt.snapshot, pm_session_film(session));
        if (!pm_memory_admit(bytes, pm_has_extension(opt.snapshot, ".png") ? "PNG output buffers" : "EXR output buffers")) {
            fprintf(stderr, "pmview: error: %s: out of memory (%s)\n", opt.snapshot, pm_memory_failure());
            exit_code = 1;
            goto done;
        }
        output_reserved = bytes;
    }
    if (opt.reference) {
        if (!pm_reference_load(opt.reference, opt.log != NULL, &reference, err, sizeof err)) {
            fprintf(stderr, "pmview: error: %s\n", err);
            exit_code = 1;
            goto done;
        }
        if (reference.width != width || reference.height != height) {
            fprintf(stderr, "pmview: error: %s: the reference is %dx%d but the image is %dx%d (use --width/--height)\n",
                    opt.reference, reference.width, reference.height, width, height);
            exit_code = 1;
            goto done;
        }
    }
    exit_code = window ? run_window(&opt, &scene, accel, &session, &config, &camera) : run_snapshot(&opt, session, &reference, &output_reserved);
    if (exit_code == 1) goto done;
    if (opt.stats) pm_print_final_stats(session, accel, opt.threads, opt.alpha, opt.pathtrace);

done:
    pm_sky_release(&sky);
    pm_memory_release(output_reserved);
    pm_reference_free(&reference);
    pm_session_destroy(session);
    pm_accel_destroy(accel);
    pm_scene_free(&scene);
    return exit_code;
}

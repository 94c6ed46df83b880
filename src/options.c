/* options.c: the table of pmview's options and what comes from it: parsing, range checks, mode rules, the usage text; and the session configuration the options ask for. */
#include "options.h"

#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "defaults.h"
#include "image_io.h"
#include "memory.h"
#include "parallel.h"

typedef enum {
    KIND_FLAG,   /* bool, no value */
    KIND_WHOLE,  /* long in [lo, hi]; `words` may name one word that stores 0 ("auto") */
    KIND_REAL,   /* double in [lo, hi] */
    KIND_WORD,   /* int: the value of the word given, one of `words` */
    KIND_TEXT,   /* const char *: a file name with one of the extensions in `words` (".png"), or one of its plain words */
    KIND_SIZE,   /* uint64_t bytes, with K, M, G, T */
    KIND_COMPONENTS,
} option_kind;

/* Options that belong to some modes only: elsewhere a usage error, the first rule first. */
enum { RULE_CLASSIC_ONLY = 1, RULE_PHOTON_ONLY = 2, RULE_SHRINKING_ONLY = 4, RULE_PER_PASS_ONLY = 8 };
static const struct {
    unsigned rule;
    const char *why;
} mode_rules[] = {
    {RULE_CLASSIC_ONLY, "%s belongs to --mode classic (the other modes have no k-nearest estimates)"},
    {RULE_PHOTON_ONLY, "%s belongs to the photon-mapping modes (the path tracer has no photons)"},
    {RULE_SHRINKING_ONLY, "%s belongs to --mode progressive (the classic mode's radii do not shrink)"},
    {RULE_PER_PASS_ONLY, "%s belongs to --mode progressive (the other modes trace no photon pass per iteration)"},
};

static bool rule_refuses(unsigned rule, int mode) {
    switch (rule) {
    case RULE_CLASSIC_ONLY: return mode != PM_MODE_CLASSIC;
    case RULE_PHOTON_ONLY: return mode == PM_MODE_PATHTRACE;
    case RULE_SHRINKING_ONLY: return mode == PM_MODE_CLASSIC;
    default: return mode != PM_MODE_PROGRESSIVE;
    }
}

typedef struct {
    const char *name;
    const char *value;        /* the value's name in the usage text; NULL for a flag */
    option_kind kind;
    size_t field;             /* offset in pm_options */
    double lo, hi;            /* KIND_WHOLE, KIND_REAL */
    const char *words;        /* "a|b|c" (see option_kind) */
    int values[4];            /* KIND_WORD: what each word stores */
    const char *before, *after; /* a bad number's message: "bad NAME 'V' (BEFORE lo to hi AFTER)" */
    const char *refusal;      /* instead of the generated message: a format for the value */
    unsigned rules;
    const char *help;         /* a format of up to four doubles, `shown` (defaults.h's values) */
    double shown[4];
} option;

#define FIELD(f) offsetof(pm_options, f)

static const option options_table[] = {
    {"--snapshot", "FILE", KIND_TEXT, FIELD(snapshot), 0, 0, ".png|.exr", {0}, NULL, NULL,
     "--snapshot needs a .png or .exr file name, not '%s'", 0,
     "render offscreen and write FILE (.png: what the display shows, .exr: linear layers)", {0}},
    {"--width", "W", KIND_WHOLE, FIELD(width), 1, PM_MAX_IMAGE_SIDE, NULL, {0}, "", "", NULL, 0,
     "image width (default %g)", {PM_DEFAULT_WIDTH}},
    {"--height", "H", KIND_WHOLE, FIELD(height), 1, PM_MAX_IMAGE_SIDE, NULL, {0}, "", "", NULL, 0,
     "image height (default: from the camera's aspect ratio)", {0}},
    {"--iterations", "N", KIND_WHOLE, FIELD(iterations), 1, 1000000000L, NULL, {0}, NULL, NULL,
     "bad --iterations '%s' (a positive whole number)", 0,
     "samples per pixel (default %g for snapshots; the window runs until closed)", {PM_DEFAULT_SNAPSHOT_ITERATIONS}},
    {"--time", "SECONDS", KIND_REAL, FIELD(time_limit), 1e-3, 1e7, NULL, {0}, NULL, NULL, "bad --time '%s' (seconds, > 0)", 0,
     "stop after this much rendering time, photon pass included", {0}},
    {"--checkpoint", "SECONDS", KIND_REAL, FIELD(checkpoint), 1e-3, 1e7, NULL, {0}, NULL, NULL,
     "bad --checkpoint '%s' (seconds, > 0)", 0,
     "snapshots: write the image so far to the --snapshot file every SECONDS\n"
     "(replaced whole each time: a killed run leaves the last one)", {0}},
    {"--threads", "N", KIND_WHOLE, FIELD(threads), 1, PM_MAX_THREADS, NULL, {0}, "", "", NULL, 0,
     "worker threads (default: all cores)", {0}},
    {"--seed", "S", KIND_WHOLE, FIELD(seed), 0, 0x7fffffffL, NULL, {0}, "", "", NULL, 0,
     "random seed (default %g); the image does not depend on --threads", {PM_DEFAULT_SEED}},
    {"--camera", "I", KIND_WHOLE, FIELD(camera), 0, 1000000, NULL, {0}, NULL, NULL, "bad --camera '%s' (an index from 0)", 0,
     "use the scene's I-th camera (default: the first; automatic framing when there is none)", {0}},
    {"--exposure", "EV", KIND_REAL, FIELD(exposure_ev), -64, 64, NULL, {0}, "stops, ", "", NULL, 0,
     "display exposure in stops (PNG and window; default %g)", {PM_DEFAULT_EXPOSURE_EV}},
    {"--watch", NULL, KIND_FLAG, FIELD(watch), 0, 0, NULL, {0}, NULL, NULL, NULL, 0,
     "the window reloads the scene when its file, or a .bin or image file beside it, changes\n"
     "(camera, size, layers, exposure and view kept; a failed reload keeps the scene shown)", {0}},
    {"--screenshot", "FILE", KIND_TEXT, FIELD(screenshot), 0, 0, ".png", {0}, NULL, NULL,
     "--screenshot needs a .png file name, not '%s'", 0,
     "where the window's P key saves a PNG and the layers as .exr (default " PM_DEFAULT_SCREENSHOT ")", {0}},
    {"--sky", "none|white|gradient|FILE.exr|FILE.hdr", KIND_TEXT, FIELD(sky), 0, 0, "none|white|gradient|.exr|.hdr", {0}, NULL,
     NULL, "unknown --sky '%s' (none, white, gradient, or an .exr or .hdr environment map)", 0,
     "the environment around the scene (default: the gradient\n"
     "for files without punctual lights whose emitters do not enclose the view, else none);\n"
     "a FILE is an equirectangular map, its middle along -Z, +Y up", {0}},
    {"--sky-rotate", "DEGREES", KIND_REAL, FIELD(sky_rotate), -PM_MAX_SKY_ROTATE_DEGREES, PM_MAX_SKY_ROTATE_DEGREES, NULL, {0}, "",
     " degrees", NULL, 0,
     "turn the environment map about +Y (photons, direct light, background; modulo 360,\n"
     "90 puts what lay along -Z along -X; default %g)", {PM_DEFAULT_SKY_ROTATE_DEGREES}},
    {"--no-default-light", NULL, KIND_FLAG, FIELD(no_default_light), 0, 0, NULL, {0}, NULL, NULL, NULL, 0,
     "no default environment (the same as --sky none unless --sky is given)", {0}},
    {"--mode", "progressive|classic|pathtrace", KIND_WORD, FIELD(mode), 0, 0, "progressive|classic|pathtrace",
     {PM_MODE_PROGRESSIVE, PM_MODE_CLASSIC, PM_MODE_PATHTRACE}, NULL, NULL, NULL, 0,
     "progressive: fresh photons every iteration, radii shrinking (default);\n"
     "classic: two-pass photon mapping, maps built once, eye pass repeated;\n"
     "pathtrace: unbiased path tracing (light sampling and MIS), the same four components", {0}},
    {"--photons", "N", KIND_WHOLE, FIELD(photons), 0, 2000000000L, NULL, {0}, NULL, NULL, "bad --photons '%s'", RULE_PHOTON_ONLY,
     "progressive: global photons per iteration (default: pixels x %g, %.0f to %.0f);\n"
     "classic: photons for the global map (default: pixels x %g, or from --time)",
     {PM_PPM_PHOTONS_PER_PIXEL, PM_PPM_MIN_PHOTONS, PM_PPM_MAX_PHOTONS, PM_DEFAULT_PHOTONS_PER_PIXEL}},
    {"--caustic-photons", "N", KIND_WHOLE, FIELD(caustic_photons), 0, 2000000000L, NULL, {0}, NULL, NULL,
     "bad --caustic-photons '%s'", RULE_PHOTON_ONLY,
     "caustic photons per iteration / for the caustic map (default: as many as --photons)", {0}},
    {"--alpha", "A", KIND_REAL, FIELD(alpha), 1e-3, 0.999, NULL, {0}, "", "", NULL, RULE_PHOTON_ONLY | RULE_SHRINKING_ONLY,
     "progressive: radius reduction per iteration, 0 < A < 1 (default %.4g)", {PM_DEFAULT_ALPHA}},
    {"--eye-passes", "N|auto", KIND_WHOLE, FIELD(eye_passes), 1, 4096, "auto", {0}, "", ", or auto", NULL, RULE_PER_PASS_ONLY,
     "progressive: eye passes (samples per pixel) reading each photon pass (default auto:\n"
     "1 to %g, more where a photon pass costs more rays than an eye pass, as on small images)", {PM_PPM_MAX_EYE_PASSES}},
    {"--radius", "R", KIND_REAL, FIELD(radius), PM_MIN_RADIUS, PM_MAX_RADIUS, NULL, {0}, "", " scene units", NULL,
     RULE_PHOTON_ONLY | RULE_SHRINKING_ONLY,
     "progressive: initial radius in scene units (default: from the pixel footprint\n"
     "and the photon density of one iteration)", {0}},
    {"--k", "N", KIND_WHOLE, FIELD(k), 1, 2048, NULL, {0}, "", "", NULL, RULE_CLASSIC_ONLY,
     "photons per radiance estimate (default %g)", {PM_DEFAULT_K_GLOBAL}},
    {"--max-radius", "R", KIND_REAL, FIELD(max_radius), PM_MIN_RADIUS, PM_MAX_RADIUS, NULL, {0}, "", "", NULL, RULE_CLASSIC_ONLY,
     "largest estimate radius in scene units (default: %g of the scene size, %g for caustics)",
     {PM_DEFAULT_GLOBAL_RADIUS, PM_DEFAULT_CAUSTIC_RADIUS}},
    {"--kernel", "disc|gaussian|cone", KIND_WORD, FIELD(kernel), 0, 0, "disc|gaussian|cone",
     {PM_KERNEL_DISC, PM_KERNEL_GAUSSIAN, PM_KERNEL_CONE}, NULL, NULL, NULL, RULE_CLASSIC_ONLY,
     "radiance estimate filter (default disc)", {0}},
    {"--indirect", "gather|photons", KIND_WORD, FIELD(indirect), 0, 0, "gather|photons", {PM_INDIRECT_GATHER, PM_INDIRECT_PHOTONS},
     NULL, NULL, NULL, RULE_PHOTON_ONLY,
     "indirect light by one final-gather bounce (default) or photons at the visible point", {0}},
    {"--gather", "auto|photons|path", KIND_WORD, FIELD(gather), 0, 0, "auto|photons|path",
     {PM_GATHER_AUTO, PM_GATHER_FORCE_PHOTONS, PM_GATHER_FORCE_PATH}, NULL, NULL, NULL, RULE_PER_PASS_ONLY,
     "progressive: final gathering's light from auto (default: both measured, the one\n"
     "with less error per ray kept), photons where the gather ray lands, or path: the path\n"
     "tracer from the visible point on", {0}},
    {"--gather-rays", "N", KIND_WHOLE, FIELD(gather_rays), 0, 4096, NULL, {0}, "", "", NULL, RULE_CLASSIC_ONLY,
     "final-gather rays per eye sample (default %g)", {PM_DEFAULT_GATHER_RAYS}},
    {"--precompute", "N", KIND_WHOLE, FIELD(irradiance_stride), 0, 1000000, NULL, {0}, "", "", NULL, RULE_CLASSIC_ONLY,
     "gather from irradiance precomputed at every N-th global photon (default %g; 0 = full estimates)",
     {PM_DEFAULT_IRRADIANCE_STRIDE}},
    {"--view", "photons", KIND_WORD, FIELD(view_photons), 0, 0, "photons", {1}, NULL, NULL, NULL, RULE_CLASSIC_ONLY,
     "show the photon maps' estimates at the first diffuse hit", {0}},
    {"--no-photons", NULL, KIND_FLAG, FIELD(no_photons), 0, 0, NULL, {0}, NULL, NULL, NULL, RULE_PHOTON_ONLY,
     "direct and specular only (no photon pass)", {0}},
    {"--shadow-photons", "on|off", KIND_WORD, FIELD(shadow_photons), 0, 0, "on|off", {PM_SHADOW_ON, PM_SHADOW_OFF}, NULL, NULL,
     NULL, 0,
     "shadow photons decide where direct light needs no shadow ray\n"
     "(default: on for point, spot and directional lights where they pay)", {0}},
    {"--caustic-splats", "on|off", KIND_WORD, FIELD(caustic_statistics), 0, 0, "on|off", {0, 1}, NULL, NULL, NULL, 0,
     "progressive: the caustic seen directly by connecting caustic photons to\n"
     "the camera (light tracing; default on), or off: from visible-point statistics", {0}},
    {"--clip", "on|off", KIND_WORD, FIELD(unclipped), 0, 0, "on|off", {0, 1}, NULL, NULL, NULL, RULE_PHOTON_ONLY,
     "photon estimates stay on their side of walls (default on; off only to measure the leak)", {0}},
    {"--guide", "on|off", KIND_WORD, FIELD(unguided), 0, 0, "on|off", {0, 1}, NULL, NULL, NULL, RULE_PER_PASS_ONLY,
     "progressive: photons sent where the camera reads them, and the sky sampled from the\n"
     "directions it is seen from, learned (default on; off only to measure what they gain)", {0}},
    {"--connect", "auto|on|off", KIND_WORD, FIELD(connect), 0, 0, "auto|on|off", {PM_CONNECT_AUTO, PM_CONNECT_FORCE_ON, PM_CONNECT_FORCE_OFF},
     NULL, NULL, NULL, RULE_PER_PASS_ONLY,
     "progressive: where the path tracer's light is chosen, its samples joined to first hits of\n"
     "point, spot and directional lights' photons: auto (default: with and without measured, the\n"
     "one with less error per ray kept), on or off", {0}},
    {"--reference", "REF.exr", KIND_TEXT, FIELD(reference), 0, 0, ".exr", {0}, NULL, NULL,
     "--reference needs an .exr file, not '%s'", 0,
     "measure the total against REF's R,G,B (same size): relMSE and mean ratios;\n"
     "with --stats also at iterations 1, 2, 4, 8, ... (an error-against-time curve)", {0}},
    {"--log", "FILE.csv", KIND_TEXT, FIELD(log), 0, 0, NULL, {0}, NULL, NULL, NULL, 0,
     "with --snapshot: one CSV row per iteration (then per doubling past %g): seconds,\n"
     "iterations, photons, mean radius, and with --reference each layer's relMSE, RMSE, bias (- : standard output)", {PM_LOG_EVERY_ITERATION_UNTIL}},
    {"--components", "LIST", KIND_COMPONENTS, FIELD(components), 0, 0, NULL, {0}, NULL, NULL,
     "unknown component in --components '%s' (direct, specular, caustic, indirect)", 0,
     "what a PNG snapshot and the window show at first: direct,specular,caustic,indirect (default all)", {0}},
    {"--stats", NULL, KIND_FLAG, FIELD(stats), 0, 0, NULL, {0}, NULL, NULL, NULL, 0, "print 'stat STAGE key=value ...' lines", {0}},
    {"--max-memory", "SIZE", KIND_SIZE, FIELD(max_memory), 0, 0, NULL, {0}, NULL, NULL,
     "bad --max-memory '%s' (bytes, or with K, M, G, T)", 0,
     "refuse a structure (scene, texture, sky map, film, photon records, output buffers) whose\n"
     "estimate would take all of them together above SIZE bytes (K, M, G, T suffixes; default\n"
     "%g%% of the physical memory)", {100 * PM_DEFAULT_MEMORY_SHARE}},
    {"--variant", "NAME", KIND_TEXT, FIELD(variant), 0, 0, NULL, {0}, NULL, NULL, NULL, 0,
     "the materials of variant NAME (KHR_materials_variants; default: the file's own)", {0}},
    {"--flatten-instances", NULL, KIND_FLAG, FIELD(flatten_instances), 0, 0, NULL, {0}, NULL, NULL, NULL, 0,
     "copy every placement of a shared mesh into world space (the flat equivalent of the file)", {0}},
    {"--quiet", NULL, KIND_FLAG, FIELD(quiet), 0, 0, NULL, {0}, NULL, NULL, NULL, 0, "no warnings", {0}},
    {"--help", NULL, KIND_FLAG, 0, 0, 0, NULL, {0}, NULL, NULL, NULL, 0, "this text", {0}},
};
enum { OPTION_COUNT = sizeof options_table / sizeof *options_table, HELP_COLUMN = 23 };

static const char window_keys[] =
    "window: left drag orbit, right/middle drag pan, wheel dolly, double click pivot, W A S D Q E fly (Shift faster),\n"
    "  F frame, C next camera, Home start camera, 1-4 components, +/- exposure, 0 reset, T tonemap, G gathering,\n"
    "  V views (with --reference: the relative error), Space pause, R restart, P/F12 save PNG+EXR, H help, Esc quit;\n"
    "  a .gltf/.glb dropped on the window opens it, an .hdr/.exr becomes the sky\n";

void pm_options_usage(FILE *f) {
    fputs("usage: pmview [SCENE.gltf|.glb] [options]\n", f);
    for (int i = 0; i < OPTION_COUNT; i++) {
        const option *o = &options_table[i];
        char left[96], help[1024];
        snprintf(left, sizeof left, "%s%s%s", o->name, o->value ? " " : "", o->value ? o->value : "");
        snprintf(help, sizeof help, o->help, o->shown[0], o->shown[1], o->shown[2], o->shown[3]);
        int column = fprintf(f, "  %s", left);
        fprintf(f, "%*s", column < HELP_COLUMN - 1 ? HELP_COLUMN - column : 2, "");
        for (const char *c = help; *c; c++) {
            fputc(*c, f);
            if (*c == '\n') fprintf(f, "%*s", HELP_COLUMN, "");
        }
        fputc('\n', f);
    }
    fputs(window_keys, f);
}

int pm_options_usage_error(const char *format, const char *argument) {
    fprintf(stderr, "pmview: ");
    fprintf(stderr, format, argument);
    fputc('\n', stderr);
    pm_options_usage(stderr);
    return 2;
}

/* A range's end as a person writes it: whole numbers in full, others short ("1e18", not "1e+18"). */
static void format_bound(double x, char *out, size_t size) {
    if (x == floor(x) && fabs(x) < 1e15) { snprintf(out, size, "%.0f", x); return; }
    char text[64];
    snprintf(text, sizeof text, "%g", x);
    char *plus = strstr(text, "e+");
    if (plus) memmove(plus + 1, plus + 2, strlen(plus + 2) + 1);
    snprintf(out, size, "%s", text);
}

static int bad_value(const option *o, const char *v) {
    if (o->refusal) return pm_options_usage_error(o->refusal, v);
    char lo[64], hi[64], line[256];
    format_bound(o->lo, lo, sizeof lo);
    format_bound(o->hi, hi, sizeof hi);
    snprintf(line, sizeof line, "bad %s '%%s' (%s%s to %s%s)", o->name, o->before, lo, hi, o->after);
    return pm_options_usage_error(line, v);
}

/* The index of v in "a|b|c" (whole words), or -1. */
static int word_index(const char *words, const char *v) {
    size_t n = strlen(v);
    int index = 0;
    for (const char *w = words; w && *w; index++) {
        const char *end = strchr(w, '|');
        size_t len = end ? (size_t)(end - w) : strlen(w);
        if (len == n && !strncmp(w, v, n)) return index;
        w = end ? end + 1 : NULL;
    }
    return -1;
}

/* TEXT: one of the plain words, or a name ending in one of the extensions (".exr"). */
static bool text_accepted(const char *words, const char *v) {
    if (!words) return true;
    for (const char *w = words; w && *w;) {
        const char *end = strchr(w, '|');
        char item[32];
        snprintf(item, sizeof item, "%.*s", (int)(end ? end - w : (long)strlen(w)), w);
        if (item[0] == '.' ? pm_has_extension(v, item) : !strcmp(item, v)) return true;
        w = end ? end + 1 : NULL;
    }
    return false;
}

/* -1 when stored; else the exit code of a usage error. */
static int store(const option *o, const char *v, pm_options *opts) {
    char *field = (char *)opts + o->field;
    char *end;
    errno = 0;
    switch (o->kind) {
    case KIND_WHOLE: {
        if (o->words && word_index(o->words, v) == 0) { *(long *)field = 0; return -1; }
        long n = strtol(v, &end, 10);
        if (errno || end == v || *end || n < o->lo || n > o->hi) return bad_value(o, v);
        *(long *)field = n;
        return -1;
    }
    case KIND_REAL: {
        double x = strtod(v, &end);
        if (errno || end == v || *end || !(x >= o->lo && x <= o->hi)) return bad_value(o, v);
        *(double *)field = x;
        return -1;
    }
    case KIND_WORD: {
        int w = word_index(o->words, v);
        if (w < 0) {
            char line[256], list[128];
            snprintf(list, sizeof list, "%s", o->words);
            for (char *c = list; *c; c++)
                if (*c == '|') *c = ',';
            char spaced[192] = "";
            for (char *save = NULL, *name = strtok_r(list, ",", &save); name; name = strtok_r(NULL, ",", &save))
                snprintf(spaced + strlen(spaced), sizeof spaced - strlen(spaced), "%s%s", spaced[0] ? ", " : "", name);
            snprintf(line, sizeof line, "unknown %s '%%s' (%s)", o->name, spaced);
            return pm_options_usage_error(line, v);
        }
        *(int *)field = o->values[w];
        return -1;
    }
    case KIND_TEXT:
        if (!text_accepted(o->words, v)) return pm_options_usage_error(o->refusal, v);
        *(const char **)field = v;
        return -1;
    case KIND_SIZE:
        if (!pm_memory_parse_size(v, (uint64_t *)field)) return bad_value(o, v);
        return -1;
    case KIND_COMPONENTS: {
        opts->components_given = true;
        memset(opts->components, 0, sizeof opts->components);
        char list[256];
        snprintf(list, sizeof list, "%s", v);
        for (char *save = NULL, *name = strtok_r(list, ",", &save); name; name = strtok_r(NULL, ",", &save)) {
            int found = -1;
            for (int c = 0; c < PM_COMPONENT_COUNT; c++)
                if (!strcmp(name, pm_component_names[c])) found = c;
            if (found < 0) return pm_options_usage_error(o->refusal, v);
            opts->components[found] = true;
        }
        return -1;
    }
    default: return -1;
    }
}

static const option *find_option(const char *name) {
    for (int i = 0; i < OPTION_COUNT; i++)
        if (!strcmp(name, options_table[i].name)) return &options_table[i];
    return NULL;
}

int pm_options_parse(int argc, char **argv, pm_options *o) {
    memset(o, 0, sizeof *o);
    o->scene_path = PM_DEFAULT_SCENE;
    o->screenshot = PM_DEFAULT_SCREENSHOT;
    o->threads = pm_cpu_count();
    o->seed = PM_DEFAULT_SEED;
    o->camera = -1;
    o->exposure_ev = PM_DEFAULT_EXPOSURE_EV;
    o->sky_rotate = PM_DEFAULT_SKY_ROTATE_DEGREES;
    o->photons = o->caustic_photons = -1;
    o->gather_rays = PM_DEFAULT_GATHER_RAYS;
    o->irradiance_stride = PM_DEFAULT_IRRADIANCE_STRIDE;
    o->alpha = PM_DEFAULT_ALPHA;
    o->indirect = PM_INDIRECT_GATHER;
    o->mode = PM_MODE_PROGRESSIVE;
    bool have_scene = false;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (a[0] != '-' || a[1] == 0) {
            if (have_scene) return pm_options_usage_error("more than one scene given: '%s'", a);
            o->scene_path = a;
            have_scene = true;
            continue;
        }
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) { pm_options_usage(stdout); return 0; }
        const option *opt = find_option(a);
        if (!opt) return pm_options_usage_error("unknown option '%s'", a);
        if (opt->kind == KIND_FLAG) { *(bool *)((char *)o + opt->field) = true; continue; }
        if (i + 1 >= argc) return pm_options_usage_error("option '%s' needs a value", a);
        int code = store(opt, argv[++i], o);
        if (code >= 0) return code;
    }
    for (size_t r = 0; r < sizeof mode_rules / sizeof *mode_rules; r++) {
        if (!rule_refuses(mode_rules[r].rule, o->mode)) continue;
        for (int i = 1; i < argc; i++) {
            const option *opt = find_option(argv[i]);
            if (opt && (opt->rules & mode_rules[r].rule)) return pm_options_usage_error(mode_rules[r].why, argv[i]);
        }
    }
    if (o->checkpoint > 0 && !o->snapshot)
        return pm_options_usage_error("--checkpoint needs --snapshot (the file it writes)%s", "");
    if (o->log && !o->snapshot) return pm_options_usage_error("--log '%s' needs --snapshot (the window restarts its runs)", o->log);
    return -1;
}

void pm_options_session_config(const pm_options *o, const pm_scene *scene, int width, int height, pm_session_config *config) {
    pm_session_config_defaults(config, (pm_mode)o->mode, width, height, (uint64_t)o->seed, (int)o->threads);
    if (!o->snapshot && o->iterations) config->max_iterations = (uint32_t)o->iterations;
    config->time_budget = o->time_limit;
    config->shadow.mode = (pm_shadow_mode)o->shadow_photons;
    /* how many points direct light will shade, when a snapshot's iterations say so */
    if (o->snapshot && !(o->time_limit > 0))
        config->shadow.expected_samples = (double)width * height * (o->iterations ? o->iterations : PM_DEFAULT_SNAPSHOT_ITERATIONS);
    if (o->mode == PM_MODE_PATHTRACE) return;
    if (o->mode == PM_MODE_PROGRESSIVE) {
        pm_progressive_settings *pp = &config->progressive;
        uint64_t photons = o->no_photons ? 0 : (o->photons >= 0 ? (uint64_t)o->photons : pm_progressive_default_photons(width, height));
        pp->photons = photons;
        pp->caustic_photons = o->no_photons ? 0 : (o->caustic_photons >= 0 ? (uint64_t)o->caustic_photons : photons);
        pp->alpha = o->alpha;
        pp->eye_passes = (int)o->eye_passes;
        pp->initial_radius = o->radius;
        pp->indirect = (pm_indirect_mode)o->indirect;
        pp->gather = (pm_gather_choice)o->gather;
        pp->caustic_by_statistics = o->caustic_statistics;
        pp->unclipped = o->unclipped;
        pp->unguided = o->unguided;
        pp->connect = (pm_connect_choice)o->connect;
        if (o->stats)
            printf("stat progressive_setup photon_pass=%d caustic_photons=%llu global_photons=%llu indirect=%s caustic_splats=%d gather=%s\n",
                   (scene->analysis.component_possible[PM_CAUSTIC] && pp->caustic_photons) ||
                       (scene->analysis.component_possible[PM_INDIRECT] && pp->photons),
                   (unsigned long long)pp->caustic_photons, (unsigned long long)pp->photons,
                   o->indirect == PM_INDIRECT_GATHER ? "gather" : "photons",
                   scene->analysis.component_possible[PM_CAUSTIC] && pp->caustic_photons && !o->caustic_statistics,
                   o->gather == PM_GATHER_FORCE_PHOTONS ? "photons" : (o->gather == PM_GATHER_FORCE_PATH ? "path" : "auto"));
        return;
    }
    pm_eye_settings *eye = &config->eye;
    config->classic_photon_pass = !o->no_photons && (scene->analysis.component_possible[PM_CAUSTIC] ||
                                                     scene->analysis.component_possible[PM_INDIRECT]);
    if (!config->classic_photon_pass) return;
    pm_photon_settings *ps = &config->classic_photons;
    ps->unclipped = eye->unclipped = o->unclipped;
    float extent = scene->ray_scale;
    eye->global_estimate.kernel = eye->caustic_estimate.kernel = (pm_kernel)o->kernel;
    eye->global_estimate.k = o->k ? (int)o->k : PM_DEFAULT_K_GLOBAL;
    eye->caustic_estimate.k = o->k ? (int)o->k : PM_DEFAULT_K_CAUSTIC;
    eye->global_estimate.max_radius = o->max_radius > 0 ? (float)o->max_radius : PM_DEFAULT_GLOBAL_RADIUS * extent;
    eye->caustic_estimate.max_radius = o->max_radius > 0 ? (float)o->max_radius : PM_DEFAULT_CAUSTIC_RADIUS * extent;
    eye->global_estimate.path_mask = eye->caustic_estimate.path_mask = 7u;
    if (o->indirect == PM_INDIRECT_GATHER && !o->view_photons) {
        ps->irradiance_stride = (int)o->irradiance_stride;
        ps->irradiance_estimate = eye->global_estimate;
    }
    ps->global_photons = scene->analysis.component_possible[PM_INDIRECT] ? (o->photons >= 0 ? (uint64_t)o->photons : PM_PHOTONS_AUTO) : 0;
    ps->caustic_photons = !scene->analysis.component_possible[PM_CAUSTIC] ? 0
                          : o->caustic_photons >= 0                      ? (uint64_t)o->caustic_photons
                          : o->photons >= 0                              ? (uint64_t)o->photons
                                                                         : PM_PHOTONS_AUTO;
    eye->indirect = (pm_indirect_mode)o->indirect;
    eye->gather_rays = (int)o->gather_rays;
    eye->view_photons = o->view_photons;
}

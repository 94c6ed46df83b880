/* progressive.c: stochastic progressive photon mapping: the iteration's phases, initial radii from the scene, per-pixel statistics, eye passes per photon pass.
 *
 * An iteration traces its photons first and sorts them into hash grids; then the eye pass finds
 * each pixel's visible point (and gather point) and hands every finished tile to gather_tile,
 * which queries the grids on the same thread while the points are still in cache, so no per-pixel
 * point array is ever stored. The gather loops over pixels, not photons: no two threads ever
 * write the same statistics and the image is the same at any thread count (a grid over visible
 * points, filled by photons as pbrt-v4 does, would need atomic float adds whose order changes the
 * sums). The grid's cell is three times the mean radius its queries used the iteration before;
 * docs/benchmarks.md (`bench gather`) has the measurement against a kd-tree. Where a photon pass costs more than
 * an eye pass (small images, whose photon passes have a floor) and eye noise dominates, several
 * eye passes read the same photons: the noise probe below chooses how many.
 */
#include "progressive.h"
#include "clock.h"
#include "memory.h"

#include <assert.h>
#include <float.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "defaults.h"
#include "parallel.h"
#include "photongrid.h"
#include "rng.h"
#include "vertex.h"

#define MAX_THREADS PM_MAX_THREADS

enum { KIND_CAUSTIC = 0, KIND_INDIRECT = 1, KIND_COUNT = 2 };
/* the caustic trial's arms */
enum { TRIAL_PHOTONS = 0, TRIAL_LOOP = 1 };
enum { SEEN_GRID = 32, SEEN_POINTS = SEEN_GRID * SEEN_GRID };

/* The noise of a sparse grid of pixels, split into the part eye passes can average away and the
 * part only new photons can (see choose_eye_passes). A probed pixel's sample is its total over the
 * components and channels: what its eye pass added to the film's sums, plus what the iteration's
 * photons added for all its eye passes alike (the splats, at their share of one eye pass, and the
 * statistics' estimate from this photon pass alone, Phi / (pi R^2) at the radius it was gathered
 * with). Relative, as relMSE: each variance over (mean^2 + 0.01). Only the first two samples of an
 * iteration are probed, and only in iterations that have two. */
enum { PROBE_KEPT = 11, PROBE_ARRAYS = 8 + 2 * PROBE_KEPT };
typedef struct {
    size_t count;                /* pixels probed */
    size_t *pixel;               /* which: a grid over the image */
    double *total;               /* a probed pixel's sums so far */
    double *statistics;          /* its statistics' tau / (pi R^2) summed over slots (passes x their estimate) */
    double *shared;              /* this iteration's photons' share of each of its samples */
    double *first;               /* its first sample of this iteration */
    /* PROBE_KEPT arrays, one after another, kept over iterations: */
    double *mean, *m2;           /* Welford's running mean and squared deviations of the pair's mean over iterations */
    double *within;              /* the sum over iterations of (first - second)^2 / 2 */
    double *source_mean[2], *source_m2[2]; /* the same as mean and m2 over the learning iterations of each gather source */
    /* the same over the caustic trial's iterations of each arm (TRIAL_*), of a pair less its
     * caustic part (the caustic photons' share, or what the loop met there) */
    double *trial_mean[2], *trial_m2[2];
    double *saved;               /* the kept arrays at the start of the running iteration, for a cancel to put back */
    double *gathered[2];         /* a photon measuring iteration's light at its gather points: all, and off a
                                    mirror or glass last (written by the pixel's own thread, summed in order) */
    double *caustic_total;       /* a probed pixel's caustic sums so far, and its first sample's caustic part, */
    double *caustic_first;       /* in the caustic trial's loop iterations */
    uint8_t *only;               /* one byte a pixel of the image, 1 at the probed ones: the photons' measuring
                                    iterations trace these alone (pm_eye_settings.only_pixels) */
    uint32_t pairs;              /* iterations probed */
    int columns;                 /* the grid's: pixel[y * columns + x] */
} noise_probe;
static void probe_free(noise_probe *pr);

/* The radii and counts an iteration moves on: one value, so that a cancel puts them back whole. */
typedef struct {
    /* initial radius from the photon density of the first iteration with photons, per kind of
     * photon (0 until known); the final-gather radius shrinks per iteration from its own start */
    double density_r2[KIND_COUNT];
    double gather_r2;
    bool seen_measured;                  /* the radii above were measured where the camera looks */
    double initial_radius_sum;
    uint64_t initial_radius_count;
    double query_radius[KIND_COUNT];     /* mean radius gathered with last iteration: sets the grid's cell */
    uint32_t eye_passes;                 /* per photon pass in the next iteration (settings, or from the probe) */
    /* the final gather's source (choose_gather): the two alternate until each has been probed
     * PM_PPM_CHOICE_ITERATIONS times, then the one predicted to err less is kept */
    pm_gather_source gather_source;      /* once chosen */
    bool gather_chosen;                  /* choose_gather has decided, or there is nothing to choose */
    uint32_t learn_step;                 /* learning iterations run (the path tracer's at even steps) */
    uint32_t learned[2];                 /* learning iterations probed, per source */
    double learn_cost[2];                /* their summed cost per pair of eye passes, in rays */
    double gathered_light[2];            /* the photons' measuring iterations' light at the probed pixels' gather
                                          * points: all of it, and what came off a mirror or glass last (keep_photons) */
    /* the caustic trial (caustic_trial_due): its arms take turns, the caustic photons' iterations
     * at even steps, the path tracer's loop's at odd ones */
    bool caustic_decided;                /* the trial has decided, or none is run */
    bool caustics_dropped;               /* the loop carries the caustics: no caustic photon is traced */
    uint32_t trial_step;
    uint32_t trial_learned[2];           /* probed iterations of each arm (TRIAL_PHOTONS, TRIAL_LOOP) */
    double trial_cost[2];                /* their summed cost per pair of eye passes, in rays */
    /* the connections' trial (connection_trial_due): with connections at even steps, without at odd */
    bool connect_decided;                /* the trial has decided, or none is run */
    bool connect_on;                     /* its decision: the path tracer's samples join light vertices */
    bool connect_warm;                   /* its warm-up is over (connection_trial_arm) */
    uint32_t connect_warmup_steps, connect_step; /* its iterations in the warm-up, and measured since */
    double connect_warmup_photons;       /* the light vertex passes' photons in the warm-up */
    double connect_cost[2];              /* the arms' summed work per iteration, in rays (CONNECT_ON, CONNECT_OFF) */
} radius_state;

struct pm_progressive {
    const pm_scene *scene;
    const pm_accel *accel;
    pm_clip_cache *clip_cache;   /* per-triangle clearance grids (clip.h) */
    pm_camera camera;
    pm_progressive_settings settings;
    pm_eye_settings eye;
    pm_photon_tracer *tracer;
    bool trace_caustic, trace_global;    /* which photon passes the scene can use */
    bool caustic_surfaces;               /* some mirror or glass makes caustics (scene_has_caustic_surfaces) */
    /* a scene lit by broad light alone (scene.h, light_diffuse), whose light the path tracer's
     * gathers would take: every iteration is the path tracer's loop, and no photon is traced */
    bool path_alone;
    /* gathering where the path tracer cannot find some light (path_finds_all_light): its gathers
     * read that light's photons (PM_PATH_PUNCTUAL_SPECULAR), traced in every iteration */
    bool punctual_specular;
    bool slot_used[PM_SLOT_COUNT];
    bool gathering;                      /* final gathering at gather points */
    bool splatting;                      /* the caustic seen directly by camera splats */
    pm_splat_buffer splats;              /* this iteration's, reused */
    size_t pixels;
    double diffuse_area;                 /* photons land here: their density sets initial radii */
    double pixel_angle;                  /* radians per pixel, vertically (0 for an orthographic camera) */
    double pixel_width;                  /* scene units per pixel at the camera (orthographic only) */
    double probe_footprint;              /* mean first radius of a sparse grid of camera rays: the first grid's cell */
    /* where the camera's points will be: the diffuse or glossy first hits of a sparse grid of camera
     * rays (seen[0]) and one cosine bounce from each (seen[1], where gather points will be); the
     * first photon pass's density there sets the initial and shared radii (seen_density) */
    struct { vec3 p, n; uint32_t tri; } seen[2][SEEN_POINTS];
    int seen_count[2];
    double seen_density[SEEN_POINTS];    /* seen_density_radius2's, per point */
    radius_state radii;                  /* what an iteration changes besides the film, the probe and the guide */
    /* the caustic trial's measure of the caustic part (allocated while it runs), over a grid of
     * up to PM_PPM_TRIAL_PIXELS pixels (pixel[], marked in `only` with the probe's): each one's
     * relMSE weight, its caustic sums and statistics before the iteration, and the sum of its
     * caustic part per arm; the weighted squares per arm */
    struct {
        size_t count, *pixel;
        uint8_t *only;
        size_t traced;                   /* pixels marked in only */
        double *before_sum, *before_stats; /* doubles: an iteration's part is small against the sums */
        float *weight, *sum[2];
        double square[2];
    } trial_grid;
    noise_probe probe;                   /* automatic eye passes only */
    pm_photon_buffer buffer[KIND_COUNT]; /* this iteration's photons, reused */
    pm_photon_grid grid[KIND_COUNT];
    /* photons sent where the camera looks (guide.h): the eye passes mark where global photons are
     * read, the next global pass learns from them */
    bool guiding;
    pm_marks marks;                      /* the last whole iteration's: the next global pass learns from them */
    pm_marks marks_next;                 /* the running iteration's, swapped in when it is whole (a cancel drops them) */
    pm_guide guide;
    pm_guide guide_saved;                /* the guide before the running iteration learned, for a cancel to put back */
    /* the path tracer's connections to the punctual lights' light vertices (eye.h): each path
     * iteration's pass of them, and the photons and vertices of the passes before it, from which
     * the connections' density is set */
    bool connecting;
    pm_light_vertex_buffer light_vertices;
    pm_connections connections;
    double history_photons, history_vertices; /* the earlier passes', each faded by PM_CONNECT_HISTORY_FADE per pass since */
    float worth_unit;                    /* set from the first pass (connection_worth_unit) */
    /* what connections to each cell's light vertices brought (connection_cell): a pass keeps light
     * vertices in proportion (pm_light_vertex_keep); the running iteration's connections add to
     * worth_next (a table per eye thread), merged into worth when it is whole */
    pm_cell_values worth, *worth_next;
    int worth_tables;
    bool worth_sized;
    /* where the sky is seen from, per cell (arrival.h), for direct light's sky samples: its
     * cells sized from the camera's distances at each restart (connection_cell) */
    pm_arrival_guide arrival;
    /* the connections' trial's grid (connection_trial_due): its pixels, each one's film total
     * before the running iteration, and per arm the sums of an iteration's light and its square */
    struct {
        size_t count, *pixel;
        uint8_t *only;                   /* a byte a pixel of the image, 1 at the grid's: the arm with connections joins there alone */
        double *before, *mean, *sum[2], *square[2]; /* one allocation, before's */
    } connect_grid;
    pm_progressive_stats stats;
};

/* What an iteration changes outside the film's buffers, as it was before the iteration: a cancel
 * puts it back, so that the next iteration is the one cancelled and ends as it would have. */
typedef struct {
    uint32_t samples, photon_passes;     /* the film's counts */
    radius_state radii;
    uint32_t probe_pairs;
    pm_progressive_stats stats;
    bool kept_probe_and_guide;           /* an iteration that may change them kept them (keep_start) */
} iteration_start;

uint64_t pm_progressive_default_photons(int width, int height) {
    double n = (double)width * height * PM_PPM_PHOTONS_PER_PIXEL;
    return (uint64_t)(n < PM_PPM_MIN_PHOTONS ? PM_PPM_MIN_PHOTONS : (n > PM_PPM_MAX_PHOTONS ? PM_PPM_MAX_PHOTONS : n));
}

static float sky_luminance(const void *scene, vec3 w) { return v3_luminance(pm_scene_sky(scene, w)); }

pm_progressive *pm_progressive_create(const pm_scene *s, const pm_accel *a, const pm_camera *camera,
                                      const pm_progressive_settings *settings, char *err, size_t err_size) {
    assert(settings->alpha > 0.0 && settings->alpha < 1.0);
    uint64_t mark = pm_memory_failure_mark();
    pm_progressive *p = pm_calloc(1, sizeof *p, "progressive state");
    if (!p) { snprintf(err, err_size, "out of memory (progressive state, %zu bytes)", sizeof *p); return NULL; }
    p->scene = s;
    p->accel = a;
    p->clip_cache = pm_clip_cache_create(s, a); /* none: each disc searches the BVH */
    p->camera = *camera;
    p->settings = *settings;
    p->eye.seed = settings->seed;
    p->eye.threads = settings->threads;
    p->eye.max_specular_depth = settings->max_specular_depth;
    p->eye.indirect = settings->indirect;
    const pm_scene_analysis *an = &s->analysis;
    /* Under broad light alone (a sky, or emitting surfaces, none brighter than a few times the
     * mean light; no point, spot or sun) every sample of the path tracer, through any mirrors,
     * glass and lobes, meets at most that bounded radiance: its paths find caustics and indirect
     * light alike with bounded variance, while the photons add their passes, their radius's bias
     * and the learning. So where the program chooses the gather's light, it takes the path
     * tracer's at once (measured in docs/design.md: the choice left to itself kept caustic
     * photons or all photons there at up to 1.6 times the path tracer's error, 120 on a mirror room). */
    p->path_alone = settings->gather == PM_GATHER_AUTO && settings->indirect == PM_INDIRECT_GATHER && an->light_diffuse;
    bool want_caustic = !p->path_alone && an->component_possible[PM_CAUSTIC] && settings->caustic_photons > 0;
    bool want_global = !p->path_alone && an->component_possible[PM_INDIRECT] && settings->photons > 0;
    if (want_caustic || want_global) {
        pm_photon_settings ps;
        memset(&ps, 0, sizeof ps);
        ps.seed = settings->seed;
        ps.threads = settings->threads;
        ps.max_bounces = settings->max_photon_bounces;
        ps.projection_maps = true;
        p->tracer = pm_photon_tracer_create(s, a, &ps);
        if (!p->tracer) {
            const char *why = pm_memory_failure_since(mark);
            snprintf(err, err_size, "out of memory (%s)", why ? why : "photon tracer");
            pm_clip_cache_destroy(p->clip_cache);
            free(p);
            return NULL;
        }
        p->trace_caustic = want_caustic && pm_photon_tracer_can_trace(p->tracer, true);
        p->trace_global = want_global && pm_photon_tracer_can_trace(p->tracer, false);
    }
    bool specular = an->component_possible[PM_SPECULAR];
    p->gathering = p->trace_global && settings->indirect == PM_INDIRECT_GATHER;
    /* gather points trace the punctual lights' direct light: their first hits are not stored */
    if (p->tracer) pm_photon_tracer_skip_punctual_first_hits(p->tracer, p->gathering);
    p->splatting = p->trace_caustic && !settings->caustic_by_statistics;
    p->slot_used[PM_SLOT_CAUSTIC] = p->trace_caustic && !p->splatting;
    p->slot_used[PM_SLOT_SPECULAR_CAUSTIC] = p->trace_caustic && specular;
    p->slot_used[PM_SLOT_INDIRECT] = p->trace_global && !p->gathering;
    p->slot_used[PM_SLOT_SPECULAR_INDIRECT] = p->trace_global && !p->gathering && specular;
    p->diffuse_area = s->analysis.receiving_area;
    uint32_t guided = p->trace_global && !settings->unguided ? pm_photon_tracer_guided_sources(p->tracer) : 0;
    if (guided) {
        p->guiding = true;
        if (!pm_marks_init(&p->marks) || !pm_marks_init(&p->marks_next) || !pm_guide_init(&p->guide, guided) ||
            !pm_guide_init(&p->guide_saved, guided) ||
            !pm_photon_tracer_set_guide(p->tracer, &p->guide, &p->marks)) {
            const char *why = pm_memory_failure_since(mark);
            snprintf(err, err_size, "out of memory (%s)", why ? why : "photon guide");
            pm_progressive_destroy(p);
            return NULL;
        }
    }
    /* light vertices to join where the path tracer's light may be chosen: the punctual lights'
     * light reflected once more is what its samples find only by chance (a sunlit patch) */
    p->connecting = p->gathering && settings->connect != PM_CONNECT_FORCE_OFF && s->light_count > 0 &&
                    settings->gather != PM_GATHER_FORCE_PHOTONS;
    /* the sky's arrival guide where a sky lights the scene (and guides are wanted) */
    if (s->sky && !settings->unguided && !pm_arrival_init(&p->arrival, 1.f, sky_luminance, s)) {
        const char *why = pm_memory_failure_since(mark);
        snprintf(err, err_size, "out of memory (%s)", why ? why : "sky arrival guide");
        pm_progressive_destroy(p);
        return NULL;
    }
    if (p->connecting) {
        p->worth_tables = pm_thread_count(settings->threads);
        p->worth_next = pm_calloc((size_t)p->worth_tables, sizeof *p->worth_next, "cell values");
        bool made = p->worth_next && pm_cell_values_init(&p->worth);
        for (int t = 0; made && t < p->worth_tables; t++) made = pm_cell_values_init(&p->worth_next[t]);
        if (!made) {
            const char *why = pm_memory_failure_since(mark);
            snprintf(err, err_size, "out of memory (%s)", why ? why : "light vertices");
            pm_progressive_destroy(p);
            return NULL;
        }
    }
    return p;
}

void pm_progressive_destroy(pm_progressive *p) {
    if (!p) return;
    pm_photon_tracer_destroy(p->tracer);
    pm_clip_cache_destroy(p->clip_cache);
    for (int k = 0; k < KIND_COUNT; k++) {
        free(p->buffer[k].data);
        pm_photon_grid_free(&p->grid[k]);
    }
    free(p->splats.data);
    free(p->trial_grid.pixel);
    probe_free(&p->probe);
    pm_marks_free(&p->marks);
    pm_marks_free(&p->marks_next);
    pm_guide_free(&p->guide);
    pm_guide_free(&p->guide_saved);
    free(p->light_vertices.data);
    pm_cell_values_free(&p->worth);
    pm_arrival_free(&p->arrival);
    for (int t = 0; p->worth_next && t < p->worth_tables; t++) pm_cell_values_free(&p->worth_next[t]);
    free(p->worth_next);
    free(p->connect_grid.pixel);
    free(p->connect_grid.only);
    free(p->connect_grid.before); /* with mean, sum and square */
    free(p);
}

bool pm_progressive_uses_photons(const pm_progressive *p) { return p->trace_caustic || p->trace_global; }

/* Whether an iteration whose gather reads from `source` traces global photons: all of them but
 * where the path tracer gathers, which reads only those of the light it cannot find, if any. */
static bool traces_global(const pm_progressive *p, pm_gather_source source) {
    return p->trace_global && !(p->gathering && source == PM_GATHER_PATH && !p->punctual_specular);
}

uint64_t pm_progressive_photons_per_iteration(const pm_progressive *p) {
    pm_gather_source source = p->radii.gather_chosen ? p->radii.gather_source : PM_GATHER_PHOTONS;
    bool caustic = p->trace_caustic && !p->radii.caustics_dropped;
    return (caustic ? p->settings.caustic_photons : 0) + (traces_global(p, source) ? p->settings.photons : 0);
}

uint32_t pm_progressive_eye_passes(const pm_progressive *p) { return p->radii.eye_passes; }

double pm_progressive_projection_fraction(const pm_progressive *p) {
    return p->tracer ? pm_photon_tracer_projection_fraction(p->tracer) : 0.0;
}

void pm_progressive_components(const pm_progressive *p, bool enabled[PM_COMPONENT_COUNT]) {
    const pm_scene_analysis *an = &p->scene->analysis;
    enabled[PM_DIRECT] = an->component_possible[PM_DIRECT];
    enabled[PM_SPECULAR] = an->component_possible[PM_SPECULAR];
    /* the path tracer's loop writes every component the scene can make */
    enabled[PM_CAUSTIC] = p->trace_caustic || (p->path_alone && an->component_possible[PM_CAUSTIC]);
    enabled[PM_INDIRECT] = p->trace_global || (p->path_alone && an->component_possible[PM_INDIRECT]);
}

/* ---- eye passes per photon pass ---- */

/* A pixel's sums of one component so far, the mean of its channels (relMSE's 0.01 is per channel). */
static double probed_component(const pm_film *film, size_t pixel, pm_component c) {
    double t = 0.0;
    if (film->sum[c])
        for (int ch = 0; ch < 3; ch++) t += pm_film_sum_at(film, c, 3 * pixel + ch);
    return t / 3.0;
}

/* ... and over the components. */
static double probed_total(const pm_film *film, size_t pixel) {
    double t = 0.0;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) t += probed_component(film, pixel, (pm_component)c);
    return t;
}

/* Welford's step: x, the (n + 1)-th value, into a running mean and sum of squared deviations. */
static void running_add(double *mean, double *m2, double x, double n) {
    double d = x - *mean;
    *mean += d / (n + 1.0);
    *m2 += d * (x - *mean);
}

/* A pixel's statistics as a sum over photon passes: tau / (pi R^2) over the slots in `slots` (a mask
 * of 1 << pm_ppm_slot), the mean of its channels. */
enum { ALL_SLOTS = (1 << PM_SLOT_COUNT) - 1, CAUSTIC_SLOTS = 1 << PM_SLOT_CAUSTIC | 1 << PM_SLOT_SPECULAR_CAUSTIC };
static double probed_statistics(const pm_film *film, size_t pixel, unsigned slots) {
    double t = 0.0;
    for (int k = 0; k < PM_SLOT_COUNT; k++) {
        const pm_ppm_stat *st = film->ppm[k] && (slots >> k & 1u) ? &film->ppm[k][pixel] : NULL;
        if (st && st->r2 > 0.0) t += (st->tau[0] + st->tau[1] + st->tau[2]) / (PM_PI * st->r2);
    }
    return t / 3.0;
}

/* A grid of about `target` pixels, evenly over the image's width and height: nx x ny of them, the
 * (x, y)-th at grid_pixel. */
static void grid_size(int width, int height, int target, int *nx, int *ny) {
    int x = (int)fmax(1.0, floor(sqrt((double)target * width / height) + 0.5));
    x = x < width ? x : width;
    int y = (int)fmax(1.0, floor((double)target / x + 0.5));
    y = y < height ? y : height;
    if (x > target / y) x = target / y > 1 ? target / y : 1; /* a very wide image */
    *nx = x;
    *ny = y;
}
static size_t grid_pixel(int width, int height, int nx, int ny, int x, int y) {
    return (size_t)((2 * y + 1) * height / (2 * ny)) * width + (size_t)((2 * x + 1) * width / (2 * nx));
}

/* The noise probe: a grid of about PM_PPM_PROBE_PIXELS pixels. */
static bool probe_alloc(noise_probe *pr, int width, int height) {
    int nx, ny;
    grid_size(width, height, PM_PPM_PROBE_PIXELS, &nx, &ny);
    pr->count = (size_t)nx * ny;
    pr->columns = nx;
    pr->pixel = pm_malloc(pr->count * sizeof(size_t), "noise probe");
    pr->total = pm_calloc(PROBE_ARRAYS * pr->count, sizeof(double), "noise probe");
    pr->only = pm_calloc((size_t)width * height, 1, "noise probe");
    if (!pr->pixel || !pr->total || !pr->only) return false;
    for (int y = 0; y < ny; y++)
        for (int x = 0; x < nx; x++) {
            size_t pixel = grid_pixel(width, height, nx, ny, x, y);
            pr->pixel[(size_t)y * nx + x] = pixel;
            pr->only[pixel] = 1;
        }
    pr->statistics = pr->total + pr->count;
    pr->shared = pr->statistics + pr->count;
    pr->first = pr->shared + pr->count;
    pr->mean = pr->first + pr->count;
    pr->m2 = pr->mean + pr->count;
    pr->within = pr->m2 + pr->count;
    pr->source_mean[0] = pr->within + pr->count;
    pr->source_mean[1] = pr->source_mean[0] + pr->count;
    pr->source_m2[0] = pr->source_mean[1] + pr->count;
    pr->source_m2[1] = pr->source_m2[0] + pr->count;
    for (int arm = 0; arm < 2; arm++) {
        pr->trial_mean[arm] = (arm ? pr->trial_m2[0] : pr->source_m2[1]) + pr->count;
        pr->trial_m2[arm] = pr->trial_mean[arm] + pr->count;
    }
    pr->saved = pr->trial_m2[1] + pr->count; /* PROBE_KEPT arrays from mean on */
    pr->gathered[0] = pr->saved + PROBE_KEPT * pr->count;
    pr->gathered[1] = pr->gathered[0] + pr->count;
    pr->caustic_total = pr->gathered[1] + pr->count;
    pr->caustic_first = pr->caustic_total + pr->count;
    return true;
}

static void probe_free(noise_probe *pr) {
    free(pr->pixel);
    free(pr->total);
    free(pr->only);
    memset(pr, 0, sizeof *pr);
}

static void probe_reset(noise_probe *pr) {
    if (pr->total) memset(pr->total, 0, PROBE_ARRAYS * pr->count * sizeof(double));
    pr->pairs = 0;
}

/* Before an iteration's splats: where each probed pixel's sums and statistics stand. */
static void probe_begin(noise_probe *pr, const pm_film *film) {
    for (size_t i = 0; i < pr->count; i++) {
        pr->total[i] = probed_total(film, pr->pixel[i]);
        pr->statistics[i] = probed_statistics(film, pr->pixel[i], ALL_SLOTS);
        pr->caustic_total[i] = probed_component(film, pr->pixel[i], PM_CAUSTIC);
    }
}

static int compare_pixels(const void *a, const void *b) {
    size_t x = *(const size_t *)a, y = *(const size_t *)b;
    return (x > y) - (x < y);
}

/* Before the eye passes: the splats' share of each eye pass's sample at each probed pixel (the
 * film gets them after the eye passes, weighed by the samples each pixel got). The probed pixels
 * are in increasing order. */
static void probe_splats(noise_probe *pr, const pm_film *film, const pm_splat_buffer *splats) {
    memset(pr->shared, 0, pr->count * sizeof *pr->shared);
    if (!film->sum[PM_CAUSTIC]) return;
    for (size_t k = 0; k < splats->count; k++) {
        size_t pixel = splats->data[k].pixel;
        const size_t *at = bsearch(&pixel, pr->pixel, pr->count, sizeof *pr->pixel, compare_pixels);
        const float *rgb = splats->data[k].rgb;
        if (at) pr->shared[at - pr->pixel] += ((double)rgb[0] + rgb[1] + rgb[2]) / 3.0;
    }
}

/* After each of the first two eye passes of an iteration: the pair's mean goes into the running
 * variance over iterations (Vp + Ve / 2: what photons and eye passes leave together), their
 * difference into the variance within an iteration (Ve: what eye passes leave, the photons being
 * the same). Both from the same samples, so that a rare bright sample weighs in both alike. In the
 * caustic trial's photon iterations (trial: the arm's iterations probed so far, else -1) the
 * pair less the caustic photons' share (their splats and statistics, the same for both samples)
 * is kept apart too. */
static void probe_eye_pass(noise_probe *pr, const pm_film *film, uint32_t pass, int learning, uint32_t learned, int trial) {
    for (size_t i = 0; i < pr->count; i++) {
        if (pass == 0) /* the statistics were updated by this eye pass, once for the iteration */
            pr->shared[i] += probed_statistics(film, pr->pixel[i], ALL_SLOTS) - pr->statistics[i];
        double now = probed_total(film, pr->pixel[i]), y = pr->shared[i] + (now - pr->total[i]);
        pr->total[i] = now;
        if (pass == 0) {
            pr->first[i] = y;
            continue;
        }
        double pair = 0.5 * (pr->first[i] + y), d = pr->first[i] - y;
        running_add(&pr->mean[i], &pr->m2[i], pair, pr->pairs);
        pr->within[i] += 0.5 * d * d;
        if (learning >= 0) /* the pair as an estimate by this gather source */
            running_add(&pr->source_mean[learning][i], &pr->source_m2[learning][i], pair, learned);
        if (trial >= 0) running_add(&pr->trial_mean[TRIAL_PHOTONS][i], &pr->trial_m2[TRIAL_PHOTONS][i], pair - pr->shared[i], trial);
    }
    if (pass == 1) pr->pairs++;
}

/* After each of the first two eye passes of the caustic trial's loop iterations (the path
 * tracer's loop, which puts what the caustic photons would carry into the caustic component,
 * pm_eye_settings.caustic_apart): the pair less its caustic part, as the photons' arm's. */
static void probe_trial_loop_pass(noise_probe *pr, const pm_film *film, uint32_t pass, uint32_t learned) {
    for (size_t i = 0; i < pr->count; i++) {
        double now = probed_total(film, pr->pixel[i]), caustic_now = probed_component(film, pr->pixel[i], PM_CAUSTIC);
        double y = now - pr->total[i], caustic = caustic_now - pr->caustic_total[i];
        pr->total[i] = now;
        pr->caustic_total[i] = caustic_now;
        if (pass == 0) {
            pr->first[i] = y;
            pr->caustic_first[i] = caustic;
            continue;
        }
        double pair = 0.5 * (pr->first[i] + y), pair_caustic = 0.5 * (pr->caustic_first[i] + caustic);
        running_add(&pr->trial_mean[TRIAL_LOOP][i], &pr->trial_m2[TRIAL_LOOP][i], pair - pair_caustic, learned);
    }
}

/* Eye passes per photon pass for the next iteration. One iteration of K eye passes has variance
 * Vp + Ve / K (Vp what only new photons average away, Ve what eye passes do: a gather direction, a
 * pixel's jitter) and costs Cp + K Ce; their product is least at K = sqrt(Ve Cp / (Vp Ce)). The
 * probe measures Ve and Vp over the first two eye passes of iterations, the costs are rays (an
 * eye ray, with the gathering it leads to, costing PM_PPM_EYE_RAY_COST photon rays): counts, not
 * seconds, so the choice and the image are the same at any thread count and on any machine.
 * The first iteration has one eye pass (the first image waits for nothing); then two until the
 * probe has PM_PPM_PROBE_ITERATIONS pairs, and at least two every PM_PPM_PROBE_ITERATIONS-th
 * iteration after, so that it goes on measuring. Where photons cost little against pixels (large
 * images) K is 1 or 2; on small images at the photon floor it grows where eye noise dominates (a
 * room lit by bounces) and stays low where photon noise does (a caustic seen directly). */
static uint32_t choose_eye_passes(const noise_probe *pr, uint32_t photon_passes, double photon_rays, double eye_rays) {
    if (pr->pairs < PM_PPM_PROBE_ITERATIONS) return photon_passes ? 2 : 1;
    double pair = 0.0, eye = 0.0;
    for (size_t i = 0; i < pr->count; i++) {
        double scale = 1.0 / (pr->mean[i] * pr->mean[i] + 0.01);
        pair += pr->m2[i] / (pr->pairs - 1.0) * scale;
        eye += pr->within[i] / pr->pairs * scale;
    }
    /* the pair's mean has Vp + Ve / 2; a share of it is photon noise at the least (two estimates of
     * a difference can cross) */
    double photon = fmax(pair - 0.5 * eye, 0.02 * pair);
    uint32_t k = 1;
    if (eye > 0.0 && photon > 0.0 && eye_rays > 0.0) {
        double best = floor(sqrt(eye / photon * photon_rays / (PM_PPM_EYE_RAY_COST * eye_rays)) + 0.5);
        k = best < 1.0 ? 1 : (best > PM_PPM_MAX_EYE_PASSES ? PM_PPM_MAX_EYE_PASSES : (uint32_t)best);
    }
    return k < 2 && photon_passes % PM_PPM_PROBE_ITERATIONS == 0 ? 2 : k;
}

/* Whether the photons are kept without waiting for the prediction: where mirrors or glass send at
 * least PM_PPM_CHOICE_CAUSTIC_SHARE of the light the photons bring to the probed pixels' gather
 * points off a specular surface last. That light reaches the path tracer's continuation only
 * where a direction sampled at a diffuse vertex happens to find the lamp through the specular
 * chain: rare, bright samples, whose variance a few probed iterations underestimate many times
 * over (the Cornell box's glass ball: the path tracer predicted 1.5 to 2.5 times ahead, measured 5
 * to 8 times behind), while the photons carry that light by construction. Measured by the
 * photons' measuring iterations themselves (their global photons, as gathered), so it costs one
 * more count query per probed gather point. */
static bool keep_photons(pm_progressive *p) {
    const radius_state *rs = &p->radii;
    double share = rs->gathered_light[0] > 0.0 ? rs->gathered_light[1] / rs->gathered_light[0] : 0.0;
    p->stats.choice_caustic_share = share;
    if (!(share >= PM_PPM_CHOICE_CAUSTIC_SHARE)) return false;
    p->radii.gather_source = PM_GATHER_PHOTONS;
    p->radii.gather_chosen = true;
    p->stats.gather_source = PM_GATHER_PHOTONS;
    p->stats.choice_iterations = rs->learned[0] + rs->learned[1];
    return true;
}

/* The final gather's source for the rest of the run, from the learning iterations, in which the
 * two sources alternated: after n probed pairs of each, once one's prediction is below the
 * other's by a factor 1 + PM_PPM_CHOICE_MARGIN / n (2 after 2, 1.5 after 4), and after
 * PM_PPM_CHOICE_ITERATIONS whatever the factor (the photons' learning iterations are spent, and
 * the predicted ratio's spread over seeds is about a quarter at n = 2; false while undecided). Each is an
 * estimate of the same pixels: the photons' biased by the shared radius, the path tracer's not.
 * Per probed pixel and relative to (mean^2 + 0.01) as relMSE weighs it: V_s, the variance of a
 * pair of eye passes over iterations (photon noise included); and the photons' squared bias, the
 * squared mean difference of the two over blocks of 4 x 4 probed pixels (bias is smooth in the
 * image, noise is not) less what their own variances put into it. Costs are counts: the rays of
 * the photon pass, of two eye passes and of the clips' probes, every photon within a disc's
 * radius (tested, counted or not) at PM_PPM_EXAMINED_COST rays and every disc queried at
 * PM_PPM_QUERY_COST; a measuring iteration's eye passes, traced at the probed pixels alone, are
 * counted at the whole image's. The prediction is for a run that
 * spends PM_PPM_CHOICE_HORIZON photon iterations' cost: V_s c_s / budget, plus for the photons
 * the squared bias, which falls with the shared radius's square (r^2 ~ N^(alpha - 1)) from the
 * learning iterations' to the horizon's. The lower wins. Counts and the film only: the same
 * choice at any thread count. */
static bool choose_gather(pm_progressive *p) {
    const noise_probe *pr = &p->probe;
    const radius_state *rs = &p->radii;
    enum { BLOCK = 4 };
    double n[2] = {rs->learned[0], rs->learned[1]}, var[2] = {0.0, 0.0}, bias2 = 0.0;
    size_t rows = pr->count / (size_t)pr->columns, blocks = 0;
    for (size_t by = 0; by < rows; by += BLOCK)
        for (size_t bx = 0; bx < (size_t)pr->columns; bx += BLOCK) {
            double d_sum = 0.0, noise_sum = 0.0;
            int k = 0;
            for (size_t y = by; y < by + BLOCK && y < rows; y++)
                for (size_t x = bx; x < bx + BLOCK && x < (size_t)pr->columns; x++, k++) {
                    size_t i = y * (size_t)pr->columns + x;
                    double m = 0.5 * (pr->source_mean[0][i] + pr->source_mean[1][i]), scale = 1.0 / (m * m + 0.01);
                    double v0 = pr->source_m2[0][i] / (n[0] - 1.0) * scale, v1 = pr->source_m2[1][i] / (n[1] - 1.0) * scale;
                    var[0] += v0;
                    var[1] += v1;
                    d_sum += (pr->source_mean[0][i] - pr->source_mean[1][i]) * sqrt(scale);
                    noise_sum += v0 / n[0] + v1 / n[1];
                }
            /* the block's mean difference, less the share of it its pixels' noise makes */
            double d = d_sum / k;
            bias2 += d * d - noise_sum / ((double)k * k);
            blocks++;
        }
    double count = pr->count ? (double)pr->count : 1.0;
    var[0] /= count;
    var[1] /= count;
    bias2 = blocks ? fmax(bias2 / (double)blocks, 0.0) : 0.0;
    double cost[2] = {rs->learn_cost[0] / n[0], rs->learn_cost[1] / n[1]};
    double budget = PM_PPM_CHOICE_HORIZON * cost[0];
    double shrink = pow((n[0] + n[1]) / PM_PPM_CHOICE_HORIZON, 2.0 * (1.0 - p->settings.alpha));
    double err[2] = {var[0] * cost[0] / budget + bias2 * shrink, var[1] * cost[1] / budget};
    double least = fmin(n[0], n[1]);
    if (least < PM_PPM_CHOICE_ITERATIONS && fmax(err[0], err[1]) < (1.0 + PM_PPM_CHOICE_MARGIN / least) * fmin(err[0], err[1]))
        return false;
    p->radii.gather_source = err[PM_GATHER_PATH] < err[PM_GATHER_PHOTONS] ? PM_GATHER_PATH : PM_GATHER_PHOTONS;
    p->radii.gather_chosen = true;
    p->stats.gather_source = (int)p->radii.gather_source;
    for (int k = 0; k < 2; k++) {
        p->stats.choice_relmse[k] = err[k];
        p->stats.choice_cost[k] = cost[k];
    }
    p->stats.choice_bias2 = bias2 * shrink;
    p->stats.choice_iterations = rs->learned[0] + rs->learned[1];
    return true;
}

static void trial_grid_free(pm_progressive *p) {
    free(p->trial_grid.pixel);
    memset(&p->trial_grid, 0, sizeof p->trial_grid);
}

/* The trial's grid, its buffers (one block) and each pixel's relMSE weight, from the image so far. */
static bool trial_grid_begin(pm_progressive *p, const pm_film *film) {
    if (p->trial_grid.pixel) return true;
    int nx, ny;
    grid_size(film->width, film->height, PM_PPM_TRIAL_PIXELS, &nx, &ny);
    size_t n = (size_t)nx * ny;
    p->trial_grid.pixel = pm_calloc(1, n * (sizeof(size_t) + 2 * sizeof(double) + 3 * sizeof(float)) + p->pixels, "caustic trial");
    if (!p->trial_grid.pixel) return false;
    p->trial_grid.count = n;
    p->trial_grid.before_sum = (double *)(p->trial_grid.pixel + n);
    p->trial_grid.before_stats = p->trial_grid.before_sum + n;
    p->trial_grid.weight = (float *)(p->trial_grid.before_stats + n);
    p->trial_grid.sum[0] = p->trial_grid.weight + n;
    p->trial_grid.sum[1] = p->trial_grid.sum[0] + n;
    p->trial_grid.only = (uint8_t *)(p->trial_grid.sum[1] + n);
    for (int y = 0; y < ny; y++)
        for (int x = 0; x < nx; x++) p->trial_grid.pixel[(size_t)y * nx + x] = grid_pixel(film->width, film->height, nx, ny, x, y);
    /* the loop's iterations trace these and the probe's pixels, whose rest it measures */
    memcpy(p->trial_grid.only, p->probe.only, p->pixels);
    p->trial_grid.traced = p->probe.count;
    for (size_t i = 0; i < n; i++) {
        size_t px = p->trial_grid.pixel[i];
        p->trial_grid.traced += !p->trial_grid.only[px];
        p->trial_grid.only[px] = 1;
        double m = probed_total(film, px) / (film->samples ? film->samples : 1u) + probed_statistics(film, px, ALL_SLOTS) / (film->photon_passes ? film->photon_passes : 1u);
        p->trial_grid.weight[i] = (float)(1.0 / (m * m + 0.01));
    }
    return true;
}

static void trial_grid_before(pm_progressive *p, const pm_film *film) {
    for (size_t i = 0; i < p->trial_grid.count; i++) {
        p->trial_grid.before_sum[i] = probed_component(film, p->trial_grid.pixel[i], PM_CAUSTIC);
        p->trial_grid.before_stats[i] = probed_statistics(film, p->trial_grid.pixel[i], CAUSTIC_SLOTS);
    }
}

/* After a trial iteration of K eye passes: each pixel's caustic part of the iteration's mean sample. */
static void trial_grid_after(pm_progressive *p, const pm_film *film, int arm, uint32_t passes) {
    double square = 0.0;
    for (size_t i = 0; i < p->trial_grid.count; i++) {
        size_t px = p->trial_grid.pixel[i];
        double x = (probed_component(film, px, PM_CAUSTIC) - p->trial_grid.before_sum[i]) / passes +
                   (probed_statistics(film, px, CAUSTIC_SLOTS) - p->trial_grid.before_stats[i]);
        square += p->trial_grid.weight[i] * x * x;
        p->trial_grid.sum[arm][i] += (float)x;
    }
    p->trial_grid.square[arm] += square;
}

/* Whether the caustic trial runs now: the path tracer's light chosen by the measurement, caustic
 * photons traced beside it for the light its continuation leaves them, and nothing else that
 * needs photons (reset_state rules out what never changes in a run). */
static bool caustic_trial_due(const pm_progressive *p) {
    const radius_state *rs = &p->radii;
    return !rs->caustic_decided && rs->gather_chosen && rs->gather_source == PM_GATHER_PATH;
}

/* The caustic trial's decision, after PM_PPM_TRIAL_ITERATIONS measured iterations of each arm:
 * whether the caustic photons go on carrying the light that mirrors, glass and sharp lobes bring
 * to visible points, or the path tracer's loop takes it too (its continuation then adds what the
 * photons did: --mode pathtrace's samples). Both arms estimate the same pixels with the same
 * direct light and continuation and differ in that light alone, so a pair's variance is split:
 * - the rest of the pair (its total less its caustic part), at the probed pixels, pooled over both
 *   arms;
 * - the caustic part over a grid of up to PM_PPM_TRIAL_PIXELS pixels (trial_grid_after): the photons'
 *   splats and statistics, or what the loop met there (pm_eye_settings.caustic_apart). Either is
 *   rare bright samples in some scenes (the loop's cosine bounce finding a small light through a
 *   sharp lobe, the photons' splats through one), which a few iterations at the probe's thousand
 *   pixels miss and the grid's many thousands do not, though they still see them less often than
 *   they come: each arm's is weighed PM_PPM_TRIAL_TAIL times.
 * Relative as relMSE (each pixel over mean^2 + 0.01), each arm's error for a pair of eye passes
 * times its cost in rays (the photons' arm with its caustic pass). Given up, the caustic
 * statistics the film holds are folded into its sums (pm_film_fold_statistics), so the image
 * keeps what they gathered, and every iteration after is the loop's. */
static void choose_caustics(pm_progressive *p, pm_film *film) {
    const noise_probe *pr = &p->probe;
    radius_state *rs = &p->radii;
    double n[2] = {rs->trial_learned[TRIAL_PHOTONS], rs->trial_learned[TRIAL_LOOP]};
    double rest = 0.0, caustic[2];
    for (size_t i = 0; i < pr->count; i++) {
        double m = 0.5 * (pr->trial_mean[TRIAL_PHOTONS][i] + pr->trial_mean[TRIAL_LOOP][i]);
        for (int arm = 0; arm < 2; arm++) rest += 0.5 * pr->trial_m2[arm][i] / (n[arm] - 1.0) / (m * m + 0.01);
    }
    rest /= pr->count ? (double)pr->count : 1.0;
    for (int arm = 0; arm < 2; arm++) {
        double means = 0.0;
        for (size_t i = 0; i < p->trial_grid.count; i++) means += p->trial_grid.weight[i] * (double)p->trial_grid.sum[arm][i] * p->trial_grid.sum[arm][i];
        caustic[arm] = fmax(p->trial_grid.square[arm] - means / n[arm], 0.0) / (n[arm] - 1.0) / (double)p->trial_grid.count;
    }
    trial_grid_free(p);
    double cost[2], err[2];
    for (int arm = 0; arm < 2; arm++) {
        cost[arm] = rs->trial_cost[arm] / n[arm];
        err[arm] = (rest + PM_PPM_TRIAL_TAIL * caustic[arm]) * cost[arm];
        p->stats.caustic_trial_error[arm] = err[arm];
        p->stats.caustic_trial_cost[arm] = cost[arm];
    }
    rs->caustic_decided = true;
    rs->caustics_dropped = err[TRIAL_LOOP] < err[TRIAL_PHOTONS];
    p->stats.caustic_trial = rs->caustics_dropped ? 1 : 0;
    if (rs->caustics_dropped) {
        pm_film_fold_statistics(film, PM_SLOT_CAUSTIC);
        pm_film_fold_statistics(film, PM_SLOT_SPECULAR_CAUSTIC);
    }
}

/* ---- restarts ---- */

/* The mean pixel footprint (the first radius of a visible point seen directly) over a sparse grid
 * of camera rays: before any visible point exists, the first grid's cell follows it. Only the
 * grid's speed depends on it, never the image. The rays' non-specular hits, and one bounce of
 * their non-specular part from each, are kept as the points whose photon density sets the first radii. */
static double probe_footprint(pm_progressive *p, const pm_film *film) {
    const pm_scene *s = p->scene;
    double sum = 0.0;
    int hits = 0;
    p->seen_count[0] = p->seen_count[1] = 0;
    for (int j = 0; j < SEEN_GRID; j++)
        for (int i = 0; i < SEEN_GRID; i++) {
            vec3 o, d;
            pm_camera_ray(&p->camera, film->width, film->height, (i + 0.5f) * film->width / SEEN_GRID,
                          (j + 0.5f) * film->height / SEEN_GRID, &o, &d);
            pm_hit h;
            if (!pm_accel_intersect(p->accel, o, d, INFINITY, &h)) continue;
            sum += PM_PPM_FOOTPRINT_PIXELS * ((double)h.t * p->pixel_angle + p->pixel_width);
            hits++;
            pm_rng rng = pm_rng_for(p->settings.seed, 0x5ee17, (uint64_t)j * SEEN_GRID + i);
            for (int bounce = 0; bounce < 2; bounce++) {
                pm_surface sf;
                pm_scene_surface(s, h.tri, h.b1, h.b2, &sf);
                if (!pm_vertex_has_nonspecular(&sf)) break;
                vec3 n = v3_dot(sf.ng, d) < 0.f ? sf.ng : v3_neg(sf.ng);
                int k = p->seen_count[bounce]++;
                p->seen[bounce][k].p = sf.p;
                p->seen[bounce][k].n = n;
                p->seen[bounce][k].tri = h.tri;
                if (bounce) break;
                pm_vertex_ray bounce_ray; /* the bounce a visible point's gather ray takes (vertex.h) */
                if (!pm_vertex_sample_part(&sf, PM_LOBE_NONSPECULAR, v3_neg(d), &rng, s->ray_scale, &bounce_ray)) break;
                d = bounce_ray.direction;
                o = bounce_ray.origin;
                if (!pm_accel_intersect(p->accel, o, d, INFINITY, &h)) break;
            }
        }
    return hits ? sum / hits : 0.0;
}

/* A thin wall whose roughness factor reaches rough transmission somewhere (its texture only
 * lowers it): light across it scatters (scatter.h), as through solid glass. */
static bool thin_may_be_rough(const pm_material *m) { return pm_glass_alpha_at(m->roughness) > 0.f; }

/* Whether some surface makes caustics: a mirror, or glass that is not smooth and thin-walled (smooth
 * thin glass lets light straight through, and direct light's rays cross it). */
static bool scene_has_caustic_surfaces(const pm_scene *s) {
    for (uint32_t i = 0; i < s->material_count; i++)
        if (s->materials[i].may_mirror || (s->materials[i].may_glass && (!s->materials[i].thin_walled || thin_may_be_rough(&s->materials[i]))))
            return true;
    return false;
}

/* Whether the path tracer's continuation can find all of a visible point's indirect light. Not
 * where a punctual light (point, spot, directional: a delta in position or direction) shines
 * and a mirror or glass makes caustics: light from a delta light through a specular bounce
 * onto the second vertex is no path the path tracer samples (its light sample cannot cross the
 * specular surface, its BSDF sample never hits a point or one direction), while the global
 * photons carry it by construction. Emitting surfaces and the environment seen through the same
 * surfaces are found by the continuation's BSDF samples (rarely for a small lamp: bright samples
 * whose variance the choice's prediction weighs, see choose_gather). Where it cannot, the global
 * passes tag that light's photons and the continuation's gather point reads them
 * (PM_PATH_PUNCTUAL_SPECULAR): the light is split by its first segments. */
static bool path_finds_all_light(const pm_scene *s) {
    bool delta_light = false;
    for (uint32_t i = 0; i < s->light_count; i++)
        delta_light |= s->lights[i].intensity.x > 0.f || s->lights[i].intensity.y > 0.f || s->lights[i].intensity.z > 0.f;
    return !(delta_light && scene_has_caustic_surfaces(s));
}

static float connection_cell(const pm_progressive *p);

static void reset_state(pm_progressive *p, const pm_film *film) {
    p->radii.density_r2[KIND_CAUSTIC] = p->radii.density_r2[KIND_INDIRECT] = 0.0;
    p->radii.gather_r2 = 0.0;
    p->radii.seen_measured = false;
    if (p->guiding) {
        pm_guide_reset(&p->guide);
        pm_marks_clear(&p->marks, 1.f);
        pm_marks_clear(&p->marks_next, 1.f);
    }
    if (p->connecting) {
        p->history_photons = p->history_vertices = 0.0;
        p->worth_unit = 0.f;
        p->worth_sized = false;
    }
    p->radii.query_radius[KIND_CAUSTIC] = p->radii.query_radius[KIND_INDIRECT] = 0.0;
    p->radii.initial_radius_sum = 0.0;
    p->radii.initial_radius_count = 0;
    p->pixel_angle = p->camera.orthographic ? 0.0 : pm_camera_pixel_size(&p->camera, film->height, 1.f);
    p->pixel_width = p->camera.orthographic ? pm_camera_pixel_size(&p->camera, film->height, 0.f) : 0.0;
    /* the sparse grid's points also size the sky's arrival guide, photons or none */
    double footprint = pm_progressive_uses_photons(p) || p->arrival.counts ? probe_footprint(p, film) : 0.0;
    p->probe_footprint = pm_progressive_uses_photons(p) ? footprint : 0.0;
    if (p->arrival.counts) {
        pm_arrival_clear(&p->arrival, connection_cell(p) * (float)PM_ARRIVAL_CELL);
        p->eye.sky_arrival = &p->arrival;
    }
    p->radii.eye_passes = p->settings.eye_passes > 0 ? (uint32_t)p->settings.eye_passes : 1;
    probe_reset(&p->probe);
    memset(&p->stats, 0, sizeof p->stats);
    /* where the path tracer cannot find some light (a punctual light through a mirror or glass,
     * see path_finds_all_light) its gathers read that light's photons */
    p->caustic_surfaces = scene_has_caustic_surfaces(p->scene);
    p->punctual_specular = p->gathering && p->trace_global && !path_finds_all_light(p->scene);
    pm_gather_choice forced = p->settings.gather;
    p->radii.gather_source = forced == PM_GATHER_FORCE_PATH ? PM_GATHER_PATH : PM_GATHER_PHOTONS;
    p->radii.gather_chosen = forced != PM_GATHER_AUTO || !(p->gathering && p->probe.total);
    p->radii.learned[0] = p->radii.learned[1] = 0;
    p->radii.learn_step = 0;
    p->radii.learn_cost[0] = p->radii.learn_cost[1] = 0.0;
    p->radii.gathered_light[0] = p->radii.gathered_light[1] = 0.0;
    p->stats.gather_source = p->radii.gather_chosen ? (p->gathering ? (int)p->radii.gather_source : -1) : -2;
    if (p->path_alone) p->stats.gather_source = PM_GATHER_PATH;
    /* the caustic trial, where the path tracer's light may be chosen beside caustic photons that
     * nothing else needs (caustic_trial_due) */
    p->radii.caustic_decided = !(forced == PM_GATHER_AUTO && p->gathering && p->probe.total && p->trace_caustic &&
                                 !p->punctual_specular && !p->settings.caustics_kept);
    p->radii.caustics_dropped = false;
    p->radii.trial_step = 0;
    p->radii.trial_learned[0] = p->radii.trial_learned[1] = 0;
    p->radii.trial_cost[0] = p->radii.trial_cost[1] = 0.0;
    p->stats.caustic_trial = -1;
    p->radii.connect_decided = !(p->connecting && p->settings.connect == PM_CONNECT_AUTO);
    p->radii.connect_on = p->connecting && p->settings.connect == PM_CONNECT_FORCE_ON;
    p->radii.connect_warm = false;
    p->radii.connect_warmup_steps = p->radii.connect_step = 0;
    p->radii.connect_warmup_photons = 0.0;
    p->radii.connect_cost[0] = p->radii.connect_cost[1] = 0.0;
    p->stats.connect_trial = -1;
    for (int arm = 0; arm < 2 && p->connect_grid.count; arm++) {
        memset(p->connect_grid.sum[arm], 0, p->connect_grid.count * sizeof(double));
        memset(p->connect_grid.square[arm], 0, p->connect_grid.count * sizeof(double));
    }
    trial_grid_free(p);
}

bool pm_progressive_bind(pm_progressive *p, pm_film *film, char *err, size_t err_size) {
    uint64_t mark = pm_memory_failure_mark();
    p->pixels = (size_t)film->width * film->height;
    if (!pm_film_enable_ppm(film, p->slot_used)) {
        const char *why = pm_memory_failure_since(mark);
        if (why) { snprintf(err, err_size, "out of memory (%s) for %dx%d pixels", why, film->width, film->height); return false; }
        snprintf(err, err_size, "out of memory (progressive state for %dx%d pixels, %zu bytes)", film->width,
                 film->height, p->pixels * sizeof(pm_ppm_stat) * PM_SLOT_COUNT);
        return false;
    }
    /* the automatic eye passes' noise probe: only where there are photon passes to weigh them against */
    probe_free(&p->probe); /* a film of another size: another grid */
    if (p->settings.eye_passes <= 0 && pm_progressive_uses_photons(p) && !probe_alloc(&p->probe, film->width, film->height)) {
        snprintf(err, err_size, "out of memory (noise probe, %zu bytes)", (PROBE_ARRAYS * sizeof(double) + sizeof(size_t)) * p->probe.count);
        probe_free(&p->probe);
        return false;
    }
    reset_state(p, film);
    return true;
}

void pm_progressive_restart(pm_progressive *p, pm_film *film, const pm_camera *camera) {
    if (camera) p->camera = *camera;
    pm_film_clear(film);
    reset_state(p, film);
}

/* ---- gather ---- */

typedef struct {
    pm_progressive *p;
    pm_film *film;
    const pm_photon_grid *caustic, *global;
    bool statistics;             /* this eye pass updates the visible points' statistics (the first after a photon pass) */
    uint32_t sample;             /* the film's sample this eye pass adds: the clips' probes follow it */
    double gather_r2;
    unsigned gather_paths;       /* the path tags gather points read: all, or with the path tracer's light those it cannot find */
    double to_whole[KIND_COUNT]; /* a whole iteration's photons over those this one asked for (the first asks fewer) */
    bool measure_caustic;        /* a photon measuring iteration: the gather points' light off a mirror or glass
                                  * is summed apart too, per probed pixel (noise_probe.gathered) */
    struct {
        double radius_sum;                   /* initial radii set in this iteration */
        uint64_t radius_count, found, dropped;
        uint64_t inside;                     /* photons within the discs' radii, tested (pm_grid_result.inside) */
        uint64_t queries;                    /* discs queried */
        double query_sum[KIND_COUNT];        /* radii gathered with, for the next grid's cell */
        uint64_t query_count[KIND_COUNT];
        double seconds;                      /* spent gathering, on this thread */
        uint64_t clip_rays;                  /* probes of the clips (clip.h) */
        char pad[56];
    } counters[MAX_THREADS];
} gather_job;

/* The radius of curvature of triangle tri by its shading normals: the edge along which they turn
 * the most, its length over that angle (INFINITY where they do not turn: a flat-shaded face). */
static double curvature_radius(const pm_scene *s, uint32_t tri) {
    vec3 p[3], n[3];
    pm_scene_triangle_corners(s, tri, p);
    for (int k = 0; k < 3; k++) n[k] = pm_scene_triangle_vertex_normal(s, tri, k);
    double turn = 0.0; /* radians per unit length */
    for (int e = 0; e < 3; e++) {
        int i = e, j = (e + 1) % 3;
        double len = v3_length(v3_sub(p[i], p[j]));
        double c = fmax(-1.0, fmin(1.0, (double)v3_dot(n[i], n[j])));
        if (len > 0.0) turn = fmax(turn, acos(c) / len);
    }
    return turn > 0.0 ? 1.0 / turn : INFINITY;
}

/* A pixel's radius before its first query: the footprint, and for indirect photons at least the
 * density radius (or --radius), but at most PM_PPM_CURVED_RADIUS radii of the surface's curvature:
 * on a curved surface a wider disc reaches photons whose normals fail the 25-degree test while it
 * still divides by its whole area (on a sphere of radius 0.5 under a point light, a first radius
 * of 0.99 left its indirect light 17% dark after 1,024 iterations). START_NONE when there is
 * nothing to start from yet (no photons and a zero footprint); START_FRESH when the radius was set
 * here, and may still be narrowed to the photon density of its first disc (narrow_start). */
enum { START_NONE, START_KEPT, START_FRESH };
static int start_radius(gather_job *job, pm_ppm_stat *st, const pm_visible_point *vp, int kind) {
    const pm_progressive *p = job->p;
    if (st->r2 > 0.0) return START_KEPT;
    double r;
    if (p->settings.initial_radius > 0.0) {
        r = p->settings.initial_radius;
    } else {
        double footprint = PM_PPM_FOOTPRINT_PIXELS * ((double)vp->path_length * p->pixel_angle + p->pixel_width);
        r = kind == KIND_CAUSTIC ? footprint : fmax(footprint, sqrt(p->radii.density_r2[kind]));
        r = fmin(r, PM_PPM_CURVED_RADIUS * curvature_radius(p->scene, vp->tri));
    }
    if (!(r > 0.0)) return START_NONE;
    st->r2 = (float)fmin(r * r, FLT_MAX); /* the photon grid reads a float radius anyway */
    return START_FRESH;
}

/* Where the first disc already holds more than PM_PPM_INITIAL_PHOTONS photons of a whole
 * iteration (a focused caustic seen by a wide pixel, a bright corner), the radius starts where it
 * would hold that many, and the disc is read again: the first radius follows the photon density as
 * well as the footprint, so dense light starts with the small bias its photons allow instead of
 * blurring for hundreds of iterations (a radius shrinks only as N^((alpha - 1) / 2)). A --radius
 * is kept as given. */
static void narrow_start(gather_job *job, pm_ppm_stat *st, const pm_photon_grid *grid, pm_grid_query *q,
                         pm_grid_result *r, int kind) {
    double found = (double)r->found * job->to_whole[kind];
    if (job->p->settings.initial_radius > 0.0 || found <= PM_PPM_INITIAL_PHOTONS) return;
    st->r2 *= PM_PPM_INITIAL_PHOTONS / found;
    q->radius2 = (float)st->r2;
    pm_photon_grid_sum_many(grid, q, 1, r);
}

/* Hachisuka and Jensen's update of one pixel's statistics with the m photons of this iteration
 * its disc found, of summed power `power` (glossy: already weighted by the lobe). */
static void update_statistics(gather_job *job, pm_ppm_stat *st, const pm_visible_point *vp, uint32_t m, vec3 power,
                              int kind, int thread) {
    const pm_progressive *p = job->p;
    job->counters[thread].query_sum[kind] += sqrt(st->r2);
    job->counters[thread].query_count[kind]++;
    if (!m) return;
    job->counters[thread].found += m;
    vec3 phi = v3_mul(vp->weight, power); /* Lambert: kd/pi x power; glossy: the lobe is in power already */
    if (!v3_is_finite(phi)) { job->counters[thread].dropped++; return; }
    double alpha = p->settings.alpha, n = st->n, r2_new = st->r2;
    /* under mpirun each of the job's ranks finds about m photons in its own iteration: the job as a
     * whole made radius_steps such updates */
    for (uint32_t step = 0; step < (p->settings.radius_steps > 1 ? p->settings.radius_steps : 1u); step++) {
        r2_new *= (n + alpha * m) / (n + m);
        n += alpha * m;
    }
    /* A radius far below float resolution of the scene gathers nothing new: stop shrinking there. */
    double floor = (double)p->scene->ray_scale * 1e-7;
    if (r2_new < floor * floor) r2_new = fmin(st->r2, floor * floor);
    double ratio = r2_new / st->r2;
    /* in double, rounded once to the statistics' floats; a flux past float's range is dropped */
    double tau[3] = {((double)st->tau[0] + phi.x) * ratio, ((double)st->tau[1] + phi.y) * ratio,
                     ((double)st->tau[2] + phi.z) * ratio};
    if (!(fmax(tau[0], fmax(tau[1], tau[2])) <= FLT_MAX)) { job->counters[thread].dropped++; return; }
    for (int ch = 0; ch < 3; ch++) st->tau[ch] = (float)tau[ch];
    st->n = (float)n;
    st->r2 = fmaxf((float)r2_new, FLT_MIN); /* never 0: that is a pixel without statistics */
    assert(st->r2 > 0.0 && st->n >= 0.0);
}

static uint64_t clip_seed(const gather_job *job, size_t pixel, int kind) {
    return job->p->settings.seed ^ pm_hash64(((uint64_t)job->sample << 32 | (uint64_t)kind << 28) ^ (uint64_t)pixel * 0x9e3779b97f4a7c15ULL);
}

/* A disc query at a point, clipped to its side of the geometry (clip.h) where the settings ask
 * and the disc may find photons at all; clip is filled (an open clip otherwise) and the rays its
 * probes cast are counted. seed: the pixel, the iteration and the kind, so the probes do not
 * depend on the threads. */
static pm_grid_query disc_query(gather_job *job, const pm_photon_grid *grid, const pm_visible_point *vp, double r2,
                                unsigned path_mask, uint64_t seed, pm_clip *clip, pm_clip_bound *bound, int thread) {
    pm_grid_query q = {vp->p, vp->n, (float)r2, path_mask, vp->glossy ? &vp->brdf : NULL, vp->ns, vp->wo, NULL};
    const pm_progressive *p = job->p;
    pm_clip_known known = PM_CLEAR_OPEN;
    float r = (float)sqrt(r2);
    /* the clearance grid's cell first (read once per point: bound->low is NAN until then): most
     * discs are open there, and the disc's photon cells need planning (pm_photon_grid_may_find,
     * as costly again) only for those that are not */
    if (!p->settings.unclipped && isnan(bound->low)) pm_clip_cache_bound(p->clip_cache, vp->tri, vp->p, r, bound);
    if (!p->settings.unclipped && (known = pm_clip_bound_known(bound, p->scene, vp->p, r)) != PM_CLEAR_OPEN &&
        pm_photon_grid_may_find(grid, vp->p, (float)r2)) {
        pm_clip_make_known(clip, p->scene, p->accel, vp->p, vp->n, vp->tri, r, seed, &job->counters[thread].clip_rays, known);
        q.clip = pm_clip_is_open(clip) ? NULL : clip; /* nothing to test photons against */
    } else {
        pm_clip_open(clip, vp->p, vp->n);
    }
    return q;
}

/* A photon sum over the disc it was found in, scaled to the whole disc: divided by the share of
 * it the clip keeps (the estimate divides by pi r^2). */
static vec3 whole_disc(const pm_clip *clip, double r2, vec3 power) {
    if (power.x == 0.f && power.y == 0.f && power.z == 0.f) return power; /* no photon: no share to count */
    return v3_scale(power, 1.f / pm_clip_area_fraction(clip, (float)sqrt(r2)));
}

/* The eye pass's visit: one tile's visible and gather points, on the thread that found them. The
 * discs of a kind are queried together (pm_photon_grid_sum_many overlaps their cache misses). */
static void gather_tile(void *ctx, const size_t *pixels, const pm_visible_point *visible, const pm_visible_point *gathered,
                        size_t count, int thread) {
    enum { BATCH = 64 };
    gather_job *job = ctx;
    pm_film *film = job->film;
    double t0 = pm_now_seconds();
    pm_grid_query query[BATCH];
    pm_grid_result result[BATCH];
    pm_clip clip[BATCH];
    pm_clip_bound bound[BATCH]; /* what each point's clearance grid cell shows, read by its first disc */
    pm_ppm_stat *target[BATCH];
    size_t point[BATCH];
    bool fresh[BATCH];
    if (job->p->guiding) {
        /* where global photons are read: the next global pass's guide learns from these marks */
        const pm_visible_point *readers = job->p->gathering ? gathered : visible;
        for (size_t k = 0; readers && k < count; k++)
            if (readers[k].valid) pm_marks_set(&job->p->marks_next, readers[k].p, readers[k].n);
    }
    for (size_t base = 0; base < count; base += BATCH) {
        size_t end = count - base < BATCH ? count : base + BATCH;
        /* statistics at visible points: caustic photons, and indirect ones without final gathering;
         * once per photon pass, since N and tau count the photons a pixel has seen */
        /* the clearance grids' cells first, so that their cache misses overlap */
        for (size_t k = base; k < end && job->statistics && !job->p->settings.unclipped; k++) {
            bound[k - base].low = NAN;
            if (visible[k].valid) pm_clip_cache_prefetch(job->p->clip_cache, visible[k].tri, visible[k].p);
        }
        for (int kind = 0; kind < KIND_COUNT && job->statistics; kind++) {
            const pm_photon_grid *grid = kind == KIND_CAUSTIC ? job->caustic : job->global;
            if (!grid) continue;
            size_t n = 0;
            for (size_t k = base; k < end; k++) {
                const pm_visible_point *vp = &visible[k];
                if (!vp->valid) continue;
                int slot = kind == KIND_CAUSTIC ? (vp->seen_directly ? PM_SLOT_CAUSTIC : PM_SLOT_SPECULAR_CAUSTIC)
                                                : (vp->seen_directly ? PM_SLOT_INDIRECT : PM_SLOT_SPECULAR_INDIRECT);
                if (!film->ppm[slot]) continue;
                pm_ppm_stat *st = &film->ppm[slot][pixels[k]];
                int start = start_radius(job, st, vp, kind);
                if (start == START_NONE) continue;
                query[n] = disc_query(job, grid, vp, st->r2, 1u << (kind == KIND_CAUSTIC ? PM_PATH_CAUSTIC : PM_PATH_INDIRECT),
                                      clip_seed(job, pixels[k], kind), &clip[n], &bound[k - base], thread);
                target[n] = st;
                fresh[n] = start == START_FRESH;
                point[n++] = k;
            }
            pm_photon_grid_sum_many(grid, query, n, result);
            job->counters[thread].queries += n;
            for (size_t j = 0; j < n; j++) {
                job->counters[thread].inside += result[j].inside;
                if (fresh[j]) {
                    narrow_start(job, target[j], grid, &query[j], &result[j], kind);
                    job->counters[thread].radius_sum += sqrt(target[j]->r2);
                    job->counters[thread].radius_count++;
                }
                update_statistics(job, target[j], &visible[point[j]], result[j].found,
                                  whole_disc(&clip[j], target[j]->r2, result[j].power), kind, thread);
            }
        }
        /* estimates at gather points: every photon stored there (the punctual lights' direct light
         * was traced by the eye pass, and their first hits were not stored), or where the path
         * tracer goes on from the visible point, the photons of light it cannot find */
        if (!gathered || !job->global || !(job->gather_r2 > 0.0)) continue;
        size_t n = 0;
        for (size_t k = base; k < end && !job->p->settings.unclipped; k++) {
            bound[k - base].low = NAN;
            if (gathered[k].valid) pm_clip_cache_prefetch(job->p->clip_cache, gathered[k].tri, gathered[k].p);
        }
        for (size_t k = base; k < end; k++)
            if (gathered[k].valid) {
                query[n] = disc_query(job, job->global, &gathered[k], job->gather_r2, job->gather_paths, clip_seed(job, pixels[k], KIND_COUNT),
                                      &clip[n], &bound[k - base], thread);
                point[n++] = k;
            }
        pm_photon_grid_sum_many(job->global, query, n, result);
        job->counters[thread].queries += n;
        if (job->measure_caustic) {
            /* the same discs, photons whose last bounce was specular alone: a measurement only */
            pm_grid_query only_caustic[BATCH];
            pm_grid_result caustic_result[BATCH];
            for (size_t j = 0; j < n; j++) {
                only_caustic[j] = query[j];
                only_caustic[j].path_mask = 1u << PM_PATH_CAUSTIC;
            }
            pm_photon_grid_sum_many(job->global, only_caustic, n, caustic_result);
            noise_probe *pr = &job->p->probe;
            for (size_t j = 0; j < n; j++) {
                size_t pixel = pixels[point[j]];
                const size_t *at = bsearch(&pixel, pr->pixel, pr->count, sizeof *pr->pixel, compare_pixels);
                if (!at) continue;
                vec3 w = gathered[point[j]].weight;
                pr->gathered[0][at - pr->pixel] += v3_luminance(v3_mul(w, result[j].power));
                pr->gathered[1][at - pr->pixel] += v3_luminance(v3_mul(w, caustic_result[j].power));
            }
        }
        for (size_t j = 0; j < n; j++) {
            const pm_visible_point *gp = &gathered[point[j]];
            size_t i = pixels[point[j]];
            uint32_t m = result[j].found;
            job->counters[thread].found += m;
            job->counters[thread].inside += result[j].inside;
            vec3 power = whole_disc(&clip[j], job->gather_r2, result[j].power);
            vec3 l = v3_scale(v3_mul(gp->weight, power), (float)(1.0 / (PM_PI * job->gather_r2)));
            pm_component c = gp->seen_directly ? PM_INDIRECT : PM_SPECULAR;
            if (m && film->sum[c] && !pm_film_add(film, c, i, l)) job->counters[thread].dropped++;
        }
    }
    job->counters[thread].seconds += pm_now_seconds() - t0;
}

/* r^2 at which a disc holds PM_PPM_INITIAL_PHOTONS photons where a whole iteration's photons
 * spread evenly over the diffuse surfaces: the start that follows the photon density, whatever the
 * scale. The first iteration emits fewer photons by design; to_whole scales what it stored up to
 * a whole iteration's. (A deadline that cuts a pass is not scaled away: where the budget cuts the
 * first pass it cuts the others too, and the radius follows the photons really traced.) */
static double density_radius2(const pm_progressive *p, size_t stored, double to_whole) {
    if (!stored || !(p->diffuse_area > 0.0)) return 0.0;
    return PM_PPM_INITIAL_PHOTONS * p->diffuse_area / (PM_PI * (double)stored * to_whole);
}

/* A whole iteration's photons over those this iteration asks for (1 after the first). */
static double whole_over_asked(uint64_t per_iteration, uint64_t asked) {
    return asked ? (double)per_iteration / (double)asked : 1.0;
}

/* Photons to emit this iteration: the first after a start or a restart emits
 * PM_PPM_FIRST_PHOTON_FRACTION of them. It is the iteration a user waits for (the first image, the
 * first after a camera move), and half the photons cost about half its photon pass and gather;
 * its estimate is as unbiased as any other (each photon carries flux / photons emitted) and only
 * noisier, which averaging over the iterations that follow dilutes at once. */
static uint64_t photons_to_emit(const pm_progressive_settings *set, uint64_t per_iteration, uint32_t iteration) {
    if (iteration > 0 || !per_iteration) return per_iteration;
    double fraction = set->first_photon_fraction > 0.0 ? fmin(set->first_photon_fraction, 1.0) : PM_PPM_FIRST_PHOTON_FRACTION;
    uint64_t n = (uint64_t)((double)per_iteration * fraction);
    return n ? n : 1;
}

/* This iteration's camera splats into the film's caustic sums, in photon order, after its eye
 * passes, each times the samples they gave its pixel: the sums are divided by each pixel's
 * samples, and a splat is one photon pass's estimate. Those are the whole passes, and one more
 * where a pass cut short (cut) reached the pixel: a splat is never counted for a sample that
 * was not taken. */
static void add_splats(pm_progressive *p, pm_film *film, uint32_t whole_passes, bool cut) {
    if (!film->sum[PM_CAUSTIC]) return;
    for (size_t i = 0; i < p->splats.count; i++) {
        const pm_camera_splat *sp = &p->splats.data[i];
        uint32_t samples = whole_passes + (cut && film->ahead && (film->ahead[sp->pixel] & PM_FILM_AHEAD_SAMPLE) ? 1u : 0u);
        if (!samples) continue;
        vec3 l = v3_scale(v3(sp->rgb[0], sp->rgb[1], sp->rgb[2]), (float)samples);
        if (!pm_film_add(film, PM_CAUSTIC, sp->pixel, l)) p->stats.eye.dropped_samples++;
    }
    p->stats.splats += p->splats.count;
}

/* Keeps the photons whose path tag is in paths (a mask of 1 << PM_PATH_...), in order. */
static void keep_tagged(pm_photon_buffer *b, unsigned paths) {
    size_t kept = 0;
    for (size_t i = 0; i < b->count; i++)
        if (paths >> pm_photon_path(&b->data[i]) & 1u) b->data[kept++] = b->data[i];
    b->count = kept;
}

/* The radius the visible points will start from, on average: before any query has run, the
 * grid's cell follows it (the density radius alone would be far too large for caustics, whose
 * photons crowd into a small part of the diffuse area). */
static double mean_initial_radius(const pm_progressive *p, int kind) {
    if (p->settings.initial_radius > 0.0) return p->settings.initial_radius;
    return kind == KIND_CAUSTIC ? p->probe_footprint : fmax(p->probe_footprint, sqrt(p->radii.density_r2[kind]));
}

/* Sorts a kind's photons into its grid, the cell three times the radius its queries are expected
 * to use (radii vary per pixel around that mean). */
static bool build_grid(pm_progressive *p, int kind) {
    double r = p->radii.query_radius[kind] > 0.0 ? p->radii.query_radius[kind] : mean_initial_radius(p, kind);
    if (!(r > 0.0)) r = sqrt(p->radii.density_r2[kind]);
    if (kind == KIND_INDIRECT && p->gathering) r = sqrt(p->radii.gather_r2);
    if (!(r > 0.0)) r = 1e-3 * (double)p->scene->ray_scale;
    if (!p->buffer[kind].count) { p->grid[kind].count = 0; return true; }
    return pm_photon_grid_build(&p->grid[kind], p->buffer[kind].data, p->buffer[kind].count, (float)(3.0 * r));
}

/* r^2 at which a disc holds `photons` of a whole iteration's photons where the camera's points
 * are (seen[which]): each point's disc, clipped to its side of the geometry, grows from the
 * radius of the scene's mean density until it holds PM_PPM_INITIAL_PHOTONS of this pass's
 * photons (or is four times as wide); the density is the mean over the points that found any
 * (the median left the shared gather radius so wide that the dense places near a sunlit patch
 * held hundreds of photons a disc: slow, and blurred). A room lit by a lamp inside a large dark landscape thus starts with a radius
 * fitting the room's light, not the landscape's mean. 0 when too few points found photons. The
 * caller keeps the mean's radius where the seen light is sparser: a wider disc would blur more
 * than the mean's did, and only more photons where the camera looks can make it denser. */
enum { SEEN_STEPS = 5, SEEN_CHUNK = 32, SEEN_TASKS = (SEEN_POINTS + SEEN_CHUNK - 1) / SEEN_CHUNK };

/* The measurement's work, shared out over the threads in chunks of points: each point's density
 * (-1: it found none) and each chunk's probe rays, read in order afterwards, so the result is the
 * one point-by-point order gives at any thread count. */
typedef struct {
    pm_progressive *p;
    const pm_photon_grid *grid;
    int which;
    double mean_r2, to_whole;
    uint64_t clip_rays[SEEN_TASKS];
} seen_job;

static void seen_chunk(void *ctx, size_t task, int thread) {
    seen_job *job = ctx;
    pm_progressive *p = job->p;
    const pm_photon_grid *grid = job->grid;
    int which = job->which, end = (int)((task + 1) * SEEN_CHUNK);
    if (end > p->seen_count[which]) end = p->seen_count[which];
    for (int k = (int)(task * SEEN_CHUNK); k < end; k++) {
        p->seen_density[k] = -1.0; /* found none */
        double r2 = job->mean_r2 / 4.0;
        for (int step = 0; step < SEEN_STEPS; step++, r2 *= 4.0) {
            /* the clip keeps a subset of the whole disc's photons: a step whose whole disc holds
             * too few would fail clipped too, and is passed without probing */
            if (step < SEEN_STEPS - 1) {
                pm_grid_query whole = {p->seen[which][k].p, p->seen[which][k].n, (float)r2, PM_PATH_ALL, NULL, v3s(0.f), v3s(0.f), NULL};
                pm_grid_result w;
                pm_photon_grid_sum_many(grid, &whole, 1, &w);
                if (w.found < PM_PPM_INITIAL_PHOTONS) continue;
            }
            pm_clip clip;
            pm_clip_make(&clip, p->scene, p->accel, p->seen[which][k].p, p->seen[which][k].n, p->seen[which][k].tri,
                         (float)sqrt(r2), pm_hash64((uint64_t)which << 32 | (uint64_t)k), &job->clip_rays[task]);
            pm_grid_query q = {p->seen[which][k].p, p->seen[which][k].n, (float)r2, PM_PATH_ALL, NULL, v3s(0.f), v3s(0.f), &clip};
            pm_grid_result r;
            pm_photon_grid_sum_many(grid, &q, 1, &r);
            if (r.found >= PM_PPM_INITIAL_PHOTONS || step == SEEN_STEPS - 1) {
                if (r.found)
                    p->seen_density[k] = r.found * job->to_whole / (PM_PI * r2 * pm_clip_area_fraction(&clip, (float)sqrt(r2)));
                break;
            }
        }
    }
}

static double seen_density_radius2(pm_progressive *p, const pm_photon_grid *grid, int which, double mean_r2,
                                   double photons, double to_whole) {
    enum { MIN_POINTS = 16 };
    if (!grid->count || !(mean_r2 > 0.0)) return 0.0;
    seen_job job = {p, grid, which, mean_r2, to_whole, {0}};
    size_t tasks = ((size_t)p->seen_count[which] + SEEN_CHUNK - 1) / SEEN_CHUNK;
    /* the measurement is the run's once, never cut: the iteration it belongs to is taken back whole
     * on a cancel (its radii with it) */
    const atomic_bool *cancel = pm_parallel_get_cancel();
    pm_parallel_set_cancel(NULL);
    pm_parallel_for(pm_thread_count(p->settings.threads), tasks, seen_chunk, &job);
    pm_parallel_set_cancel(cancel);
    for (size_t t = 0; t < tasks; t++) p->stats.clip_rays += job.clip_rays[t];
    /* the mean over the points that found photons, in the points' order */
    int known = 0;
    for (int k = 0; k < p->seen_count[which]; k++)
        if (p->seen_density[k] != -1.0) known++;
    double r2 = 0.0;
    if (known >= MIN_POINTS) {
        double mean = 0.0;
        for (int k = 0; k < p->seen_count[which]; k++)
            if (p->seen_density[k] != -1.0) mean += p->seen_density[k] / known;
        r2 = photons / (PM_PI * mean);
    }
    return r2;
}

/* Keeps what the iteration about to run may change outside the film's buffers (see iteration_start).
 * An iteration that traces no photon and runs no probe (path_only) changes neither the probe nor
 * the guide: copying them would be its largest serial work. */
static void keep_start(pm_progressive *p, const pm_film *film, bool path_only, iteration_start *st) {
    st->samples = film->samples;
    st->photon_passes = film->photon_passes;
    st->radii = p->radii;
    st->probe_pairs = p->probe.pairs;
    st->stats = p->stats;
    st->kept_probe_and_guide = !path_only;
    if (path_only) return;
    if (p->probe.total) memcpy(p->probe.saved, p->probe.mean, PROBE_KEPT * p->probe.count * sizeof(double));
    if (p->guiding) pm_guide_copy(&p->guide_saved, &p->guide);
}

/* A cancel, or a failure before the film was written: everything as before the iteration (the
 * film's buffers are put back by whoever saved them, see pm_eye_visible_points). True: a cancel
 * is no failure (a failure returns its negation). */
static bool take_back(pm_progressive *p, pm_film *film, const iteration_start *st) {
    film->samples = st->samples;
    film->photon_passes = st->photon_passes;
    p->radii = st->radii;
    p->probe.pairs = st->probe_pairs;
    p->stats = st->stats;
    for (int t = 0; p->worth_sized && t < p->worth_tables; t++) pm_cell_values_drop(&p->worth_next[t]);
    if (!st->kept_probe_and_guide) return true;
    if (p->probe.total) memcpy(p->probe.mean, p->probe.saved, PROBE_KEPT * p->probe.count * sizeof(double));
    if (p->guiding) pm_guide_copy(&p->guide, &p->guide_saved);
    return true;
}

static bool iterate(pm_progressive *p, pm_film *film, uint32_t max_samples);

bool pm_progressive_iterate(pm_progressive *p, pm_film *film, uint32_t max_samples) {
    /* the copy a cancel puts back lives only while a cancellable iteration runs (a pass over a
     * ragged film is never cancelled) */
    bool copy = pm_parallel_get_cancel() && !film->ragged;
    if (copy && !pm_film_open_copy(film)) return false;
    bool ok = iterate(p, film, max_samples);
    pm_film_close_copy(film);
    return ok;
}

/* ---- the iteration ---- */

/* One iteration as its phases hand it on: what begin_iteration decided, and the counts each
 * phase leaves for the next (iterate runs them in order; pbrt-v4's SPPM integrator has the same
 * shape). Kept in one value so that no phase takes a dozen parameters. */
typedef struct {
    uint32_t iteration;                  /* the film's photon passes when it began */
    uint32_t eye_passes;                 /* asked of this iteration */
    bool learning;                       /* one of the gather source's learning iterations (begin_iteration) */
    bool measure_only;                   /* the photons' learning iteration (the probe's pixels alone), or the caustic
                                          * trial's loop iteration (its grid's and the probe's): the film put back */
    bool connect_trial;                  /* one of the connections' trial's iterations (connection_trial_due) */
    bool connecting;                     /* the path tracer's samples join light vertices (trace_light_vertices) */
    bool trial;                          /* one of the caustic trial's iterations (caustic_trial_due) ... */
    bool trial_loop;                     /* ... its path tracer's loop arm */
    bool probing;                        /* the noise probe runs (automatic eye passes) */
    bool path_only;                      /* the path tracer's light chosen and no photon to trace: the
                                          * eye passes alone, as --mode pathtrace's (begin_iteration) */
    pm_gather_source source;             /* the final gather's source in this iteration */
    double deadline;                     /* the eye passes', which a measuring iteration lifts while it runs */
    double to_whole[KIND_COUNT];         /* a whole iteration's photons over those asked (whole_over_asked) */
    iteration_start start;               /* what a cancel or a failure puts back */
    /* the run's counters when the iteration began: what they gained is its cost */
    uint64_t photon_rays_before, eye_rays_before, saved_before, connections_before, connection_rays_before;
    uint64_t clip_rays_before, examined_before, queries_before;
    double t0, t_grid;                   /* when the photon pass and the grids' sort began */
    double photon_rays;                  /* a whole photon pass's rays, for the next iteration's eye passes */
    double eye_scale;                    /* the measuring iteration's eye cost over the whole image's */
    uint32_t whole_passes;               /* eye passes that ran to their end */
    bool cut, failed;                    /* the last eye pass was cut by the deadline, or failed after whole ones */
} iteration_run;

/* How a phase ended: on anything but PHASE_DONE the iteration is taken back (give_up). */
typedef enum { PHASE_DONE, PHASE_CANCELLED, PHASE_FAILED } phase_result;

/* A cancel (a restart, a stop, a signal) or a failure: the state as the iteration found it. True
 * for a cancel, which is no failure. */
static bool give_up(pm_progressive *p, pm_film *film, const iteration_run *it, phase_result r) {
    return take_back(p, film, &it->start) && r == PHASE_CANCELLED;
}

/* the connections' trial (below, connection_trial_due) */
enum { CONNECT_ON, CONNECT_OFF };
static bool connection_trial_due(const pm_progressive *p);
static int connection_trial_arm(const pm_progressive *p);
static bool connection_grid_ready(pm_progressive *p, const pm_film *film);

/* Decides what the iteration does and keeps what a cancel puts back. The final gather's source:
 * until it is chosen, the image is the path tracer's (the first image too), and from the second
 * iteration on the path tracer and the photons take turns, each with a probed pair of eye passes.
 * The photons' learning iterations are measurements only: they trace the probe's pixels alone
 * and the film is put back after them (their early estimates carry the bias of wide radii and an
 * unlearned guide, which the image would keep), so a scene that ends with the path tracer has
 * spent on photons no more than their passes and the probed pixels' gathers, and its image holds
 * the path tracer's samples alone. Such an iteration is never cut by the deadline (a cut pass
 * marks pixels ahead). */
static void begin_iteration(pm_progressive *p, pm_film *film, uint32_t max_samples, iteration_run *it) {
    memset(it, 0, sizeof *it);
    it->iteration = film->photon_passes;
    it->eye_passes = max_samples && p->radii.eye_passes > max_samples ? max_samples : p->radii.eye_passes;
    bool chosen = p->radii.gather_chosen;
    it->learning = !chosen && it->iteration > 0 && !(max_samples && max_samples < 2);
    it->source = chosen ? p->radii.gather_source
                        : (it->learning && p->radii.learn_step % 2 ? PM_GATHER_PHOTONS : PM_GATHER_PATH);
    it->trial = caustic_trial_due(p) && !(max_samples && max_samples < 2);
    if (it->trial && !trial_grid_begin(p, film)) { /* out of memory: the photons stay */
        it->trial = false;
        p->radii.caustic_decided = true;
    }
    if (it->trial) trial_grid_before(p, film);
    it->trial_loop = it->trial && p->radii.trial_step % 2 == 1;
    it->measure_only = (it->learning && it->source == PM_GATHER_PHOTONS) || it->trial_loop;
    it->deadline = p->eye.deadline;
    p->eye.gather_source = it->source;
    p->eye.gather_punctual_specular = p->punctual_specular;
    if (it->learning && it->eye_passes < 2) it->eye_passes = 2;
    if (it->trial) it->eye_passes = 2; /* each arm measured by pairs (choose_caustics) */
    it->t0 = pm_now_seconds();
    it->photon_rays_before = p->stats.photons.rays;
    it->eye_rays_before = p->stats.eye.rays;
    it->connections_before = p->stats.eye.connections;
    it->connection_rays_before = p->stats.eye.connection_rays;
    it->saved_before = p->stats.eye.shadow_rays_saved;
    /* Once the path tracer's light is chosen on a scene that traces no caustic photons, nothing
     * the probe weighs is left: eye passes per photon pass weigh eye noise against photon noise,
     * and there are no photons. Such an iteration is the path tracer's samples alone, and runs
     * without the probe and the guide's copies (serial work that, with the eye passes' threads
     * waiting on it, cost a tenth of the iterations on two cores). The samples, and so the image,
     * are the same at any eye passes an iteration (each sample's random numbers follow its index),
     * and each is traced by the path tracer's own loop from the camera: with no caustic possible,
     * the visible point's continuation adds exactly what it adds, so the image is --mode
     * pathtrace's bit for bit, without the visible point's record. The same holds from the first
     * iteration on a scene where neither a caustic nor indirect light is possible (a single object
     * or plane under the sky): no photon pass exists to read, and past the first diffuse vertex
     * the path tracer finds only what direct light's MIS already weighs, so its loop is the eye
     * pass at the path tracer's speed. So is every iteration under broad light alone, where no
     * photon is traced (path_alone). */
    const pm_scene_analysis *an = &p->scene->analysis;
    bool nothing_for_photons = !an->component_possible[PM_CAUSTIC] && !an->component_possible[PM_INDIRECT];
    it->path_only = p->path_alone || nothing_for_photons || p->radii.caustics_dropped || it->trial_loop ||
                    (chosen && it->source == PM_GATHER_PATH && p->gathering && !an->component_possible[PM_CAUSTIC] &&
                     !p->punctual_specular);
    p->eye.path_trace = it->path_only;
    p->eye.caustic_apart = it->trial_loop;
    it->probing = p->probe.total != NULL && (!it->path_only || it->trial_loop);
    it->connect_trial = connection_trial_due(p) && !it->trial && connection_grid_ready(p, film);
    bool connect = it->connect_trial ? connection_trial_arm(p) == CONNECT_ON : p->radii.connect_on;
    it->connecting = p->connecting && connect && chosen && it->source == PM_GATHER_PATH && !it->trial_loop;
    keep_start(p, film, it->path_only && !it->trial_loop, &it->start);
    if (it->probing) probe_begin(&p->probe, film);
}

/* The worth's cell: PM_CONNECT_CELL of the median distance from the camera to what its sparse
 * grid of rays sees (a room's cells a few tens of centimetres wide, a landscape's metres), or of
 * the scene's radius where it sees nothing. */
static int compare_floats(const void *a, const void *b) {
    float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

static float connection_cell(const pm_progressive *p) {
    int n = p->seen_count[0];
    float distance[SEEN_POINTS];
    for (int k = 0; k < n; k++) distance[k] = v3_length(v3_sub(p->seen[0][k].p, p->camera.position));
    qsort(distance, (size_t)n, sizeof *distance, compare_floats);
    return (float)PM_CONNECT_CELL * (n ? distance[n / 2] : p->scene->radius);
}

/* The unit a connection's worth is counted in (eye.c, join): a worth is about a reflectance
 * squared x a vertex's flux / a distance squared, and a unit of 1e-7 of the first pass's mean
 * flux over the cell squared counts 1e-6 to 1e3 of the flux per metre squared, at a cell of 10 cm,
 * in 32 bits. 0 while no pass kept a vertex with flux. */
static float connection_worth_unit(const pm_light_vertex_buffer *lv, float cell) {
    double flux = 0.0;
    for (size_t k = 0; k < lv->count; k++) flux += v3_luminance(lv->data[k].flux);
    return lv->count && flux > 0.0 ? (float)(PM_CONNECT_WORTH_UNIT * flux / (double)lv->count / ((double)cell * cell)) : 0.f;
}

/* A path iteration's light vertices for its connections (eye.h): a pass of as many punctual-light
 * photons as a global pass (guided as it is), whose first hits are kept in proportion to the worth
 * earlier connections found in their cell (pm_light_vertex_keep): light no path is helped to is
 * seldom joined, and the path's own samples find it. The connections' density takes the photons
 * per kept vertex of the passes before this one (faded by PM_CONNECT_HISTORY_FADE each), so the
 * first pass only measures. */
static bool trace_light_vertices(pm_progressive *p, uint64_t photons, uint64_t seed, const uint8_t *pixels) {
    if (!p->worth_sized) {
        float cell = connection_cell(p);
        pm_cell_values_clear(&p->worth, cell);
        for (int t = 0; t < p->worth_tables; t++) pm_cell_values_clear(&p->worth_next[t], cell);
        p->worth_sized = true;
    }
    double photons_per_vertex = p->history_vertices > 0.0 ? p->history_photons / p->history_vertices : 0.0;
    const pm_cell_values *worth = p->worth.mean > 0.0 ? &p->worth : NULL;
    pm_light_vertex_buffer *lv = &p->light_vertices;
    if (!pm_photon_tracer_trace_light_vertices(p->tracer, photons, seed, worth, lv, &p->stats.photons)) return false;
    if (pm_parallel_cancelled()) return true;
    p->connections = (pm_connections){lv->data, photons_per_vertex > 0.0 && p->worth_unit > 0.f ? (uint32_t)lv->count : 0,
                                      p->tracer, (float)photons_per_vertex, worth, p->worth_unit, p->worth_next, p->worth_tables, pixels};
    p->eye.connections = &p->connections;
    return true;
}

/* What a path iteration with connections leaves for the next, once it is whole: its pass in the
 * history, and the worth its connections found (a cancelled iteration's is dropped, take_back). */
static void end_light_vertices(pm_progressive *p) {
    const pm_light_vertex_buffer *lv = &p->light_vertices;
    if (!(p->worth_unit > 0.f)) p->worth_unit = connection_worth_unit(lv, p->worth.cell);
    p->history_photons = PM_CONNECT_HISTORY_FADE * p->history_photons + (double)lv->photons;
    p->history_vertices = PM_CONNECT_HISTORY_FADE * p->history_vertices + (double)lv->count;
    p->stats.light_vertices += lv->count;
    for (int t = 0; t < p->worth_tables; t++) pm_cell_values_merge(&p->worth, &p->worth_next[t]);
}

/* ---- the connections' trial ---- */
/* (What the costs were measured from: docs/design.md, Connections, the trial.) */

/* Connections help where the path tracer finds a punctual light's light reflected once more only
 * by chance (a sunlit patch in a room), and cost a shadow ray and a light vertex pass where its
 * own samples find that light well enough (a room under a sky, a point light among many surfaces).
 * So once the path tracer's light is chosen (and any caustic trial decided), with --connect auto,
 * 2 x PM_CONNECT_TRIAL_ITERATIONS iterations alternate with connections (even steps) and without;
 * both arms are unbiased and every sample stays in the image. At up to PM_CONNECT_TRIAL_PIXELS
 * pixels of an even grid (grid_size) each iteration's light (the film's total gained, the mean
 * of its channels: probed_total) is summed with its square per arm: an arm's error is its iterations' variance per pixel relative to
 * (mean^2 + 0.01), as relMSE weighs a pixel, averaged over the grid, times its work per iteration
 * (rays, a connection at PM_CONNECT_COST rays beyond its own). The lower is kept for the rest of
 * the run. Counts and the film only: the same choice at any thread count. */
/* The arm of the trial's next iteration: with connections, unmeasured, until at least
 * PM_CONNECT_TRIAL_WARMUP iterations and PM_CONNECT_TRIAL_WARMUP_PHOTONS light vertex photons
 * (the first pass only measures their density; the emission guide learns from the photons where
 * they reach, and the worth of cells from the connections: measured after 48 iterations at 64x64,
 * the hollow room's connections read 1.02-1.13 of the path tracer's error x work under sun and
 * sky and 0.89-1.16 under the sun alone, after a million photons (100 iterations) 0.87-0.98 and
 * 0.66-0.98, near what the finished runs show); then the two in turn. */
static int connection_trial_arm(const pm_progressive *p) {
    return !p->radii.connect_warm || p->radii.connect_step % 2 == 0 ? CONNECT_ON : CONNECT_OFF;
}

static bool connection_trial_due(const pm_progressive *p) {
    return p->connecting && !p->radii.connect_decided && p->radii.gather_chosen && p->radii.gather_source == PM_GATHER_PATH &&
           p->radii.caustic_decided;
}

/* The grid (grid_size, as the probe's and the caustic trial's), made at the first trial iteration
 * (false when out of memory: the trial is given up). */
static bool connection_grid_ready(pm_progressive *p, const pm_film *film) {
    if (p->connect_grid.count) return true;
    int nx, ny;
    grid_size(film->width, film->height, PM_CONNECT_TRIAL_PIXELS, &nx, &ny);
    size_t n = (size_t)nx * ny;
    p->connect_grid.pixel = pm_malloc(n * sizeof(size_t), "connection trial grid");
    p->connect_grid.only = pm_calloc(p->pixels, 1, "connection trial grid");
    p->connect_grid.before = pm_calloc(6 * n, sizeof(double), "connection trial grid");
    if (!p->connect_grid.pixel || !p->connect_grid.only || !p->connect_grid.before) {
        p->radii.connect_decided = true; /* connections stay off */
        return false;
    }
    p->connect_grid.mean = p->connect_grid.before + n;
    for (int arm = 0; arm < 2; arm++) {
        p->connect_grid.sum[arm] = p->connect_grid.mean + (size_t)(1 + 2 * arm) * n;
        p->connect_grid.square[arm] = p->connect_grid.sum[arm] + n;
    }
    for (int y = 0; y < ny; y++)
        for (int x = 0; x < nx; x++) {
            size_t px = grid_pixel(film->width, film->height, nx, ny, x, y);
            p->connect_grid.pixel[(size_t)y * nx + x] = px;
            p->connect_grid.only[px] = 1;
        }
    p->connect_grid.count = n;
    return true;
}

/* The grid's film totals before an iteration; at the trial's first, each pixel's mean so far too,
 * which weighs its variance: a mean of the trial's own samples would rise with their rare bright
 * ones and hide the very variance they carry, most in the arm with the heavier tail. */
static void connection_grid_before(pm_progressive *p, const pm_film *film) {
    bool first = p->radii.connect_warm && p->radii.connect_step == 0;
    for (size_t k = 0; k < p->connect_grid.count; k++) {
        p->connect_grid.before[k] = probed_total(film, p->connect_grid.pixel[k]);
        if (first) p->connect_grid.mean[k] = film->samples ? p->connect_grid.before[k] / film->samples : 0.0;
    }
}

static void choose_connections(pm_progressive *p) {
    double n = PM_CONNECT_TRIAL_ITERATIONS, score[2];
    for (int arm = 0; arm < 2; arm++) {
        double relative = 0.0;
        for (size_t k = 0; k < p->connect_grid.count; k++) {
            double mean = p->connect_grid.mean[k];
            double s = p->connect_grid.sum[arm][k], var = fmax(0.0, (p->connect_grid.square[arm][k] - s * s / n) / (n - 1.0));
            relative += var / (mean * mean + 0.01);
        }
        double error = relative / (double)p->connect_grid.count, cost = p->radii.connect_cost[arm] / n;
        score[arm] = error * cost;
        p->stats.connect_trial_error[arm] = score[arm];
        p->stats.connect_trial_cost[arm] = cost;
    }
    p->radii.connect_on = score[CONNECT_ON] < score[CONNECT_OFF];
    p->radii.connect_decided = true;
    p->stats.connect_trial = p->radii.connect_on ? 1 : 0;
}

/* A whole trial iteration's light at the grid and its work, and the decision once both arms ran. */
static void learn_connection_trial(pm_progressive *p, const pm_film *film, const iteration_run *it) {
    int arm = connection_trial_arm(p);
    if (!p->radii.connect_warm) {
        p->radii.connect_warmup_photons += (double)p->light_vertices.photons;
        p->radii.connect_warm = ++p->radii.connect_warmup_steps >= PM_CONNECT_TRIAL_WARMUP &&
                                p->radii.connect_warmup_photons >= PM_CONNECT_TRIAL_WARMUP_PHOTONS;
        return;
    }
    p->radii.connect_step++;
    for (size_t k = 0; k < p->connect_grid.count; k++) {
        /* per sample, as relMSE weighs a pixel's mean */
        double x = (probed_total(film, p->connect_grid.pixel[k]) - p->connect_grid.before[k]) / it->whole_passes;
        p->connect_grid.sum[arm][k] += x;
        p->connect_grid.square[arm][k] += x * x;
    }
    /* the arm with connections joins at the grid's pixels alone: what joining adds is scaled to the
     * whole image (the paths are the same otherwise) */
    double whole = (double)p->pixels / (double)p->connect_grid.count;
    double joins = (double)(p->stats.eye.connections - it->connections_before);
    double join_rays = (double)(p->stats.eye.connection_rays - it->connection_rays_before);
    p->radii.connect_cost[arm] += (double)(p->stats.eye.rays - it->eye_rays_before) - join_rays +
                                  whole * (join_rays + PM_CONNECT_COST * joins) +
                                  PM_CONNECT_PHOTON_COST * (double)(p->stats.photons.rays - it->photon_rays_before);
    if (p->radii.connect_step == 2 * PM_CONNECT_TRIAL_ITERATIONS) choose_connections(p);
}

/* Phase 1: the photon passes, a fresh, independent set every iteration. */
static phase_result trace_photon_passes(pm_progressive *p, pm_film *film, iteration_run *it) {
    const pm_progressive_settings *set = &p->settings;
    bool global_pass = traces_global(p, it->source);
    /* the path tracer's gathers read only the light it cannot find: once the radii are measured
     * (from all the photons), its iterations trace that light alone */
    if (p->tracer)
        pm_photon_tracer_tag_punctual_specular(p->tracer, p->punctual_specular,
                                               p->punctual_specular && it->source == PM_GATHER_PATH && p->radii.seen_measured);
    uint64_t seed = pm_hash64(set->seed * 0x9e3779b97f4a7c15ULL + it->iteration);
    bool ok = true;
    pm_photon_buffer *caustic = &p->buffer[KIND_CAUSTIC], *global = &p->buffer[KIND_INDIRECT];
    caustic->count = global->count = 0;
    uint64_t asked[KIND_COUNT] = {photons_to_emit(set, set->caustic_photons, it->iteration),
                                  photons_to_emit(set, set->photons, it->iteration)};
    it->to_whole[KIND_CAUSTIC] = whole_over_asked(set->caustic_photons, asked[KIND_CAUSTIC]);
    it->to_whole[KIND_INDIRECT] = whole_over_asked(set->photons, asked[KIND_INDIRECT]);
    p->splats.count = 0;
    if (p->trace_caustic && !it->path_only) {
        pm_photon_tracer_set_splats(p->tracer, p->splatting ? &p->camera : NULL, film->width, film->height, &p->splats);
        ok = pm_photon_tracer_trace_into(p->tracer, true, asked[KIND_CAUSTIC], seed, caustic, &p->stats.photons);
    }
    if (ok && global_pass && !pm_parallel_cancelled())
        ok = pm_photon_tracer_trace_into(p->tracer, false, asked[KIND_INDIRECT], seed, global, &p->stats.photons);
    p->eye.connections = NULL;
    /* the warm-up measures nothing */
    if (ok && it->connect_trial && p->radii.connect_warm) connection_grid_before(p, film);
    if (ok && it->connecting && !pm_parallel_cancelled())
        ok = trace_light_vertices(p, asked[KIND_INDIRECT], seed, it->connect_trial && p->radii.connect_warm ? p->connect_grid.only : NULL);
    /* cancelled: the iteration is dropped before it touched the film; out of memory: the film
     * untouched, the state as the iteration found it */
    if (pm_parallel_cancelled()) return PHASE_CANCELLED;
    if (!ok) return PHASE_FAILED;
    if (it->probing) probe_splats(&p->probe, film, &p->splats);
    /* a whole pass's rays (the first pass asks fewer photons), for the next iteration's eye passes */
    it->photon_rays = (double)(p->stats.photons.rays - it->photon_rays_before) *
                      (p->trace_global ? it->to_whole[KIND_INDIRECT] : it->to_whole[KIND_CAUSTIC]);
    return PHASE_DONE;
}

/* Phase 2: the radii the photons' density sets where none is known yet, and the photons sorted
 * into hash grids. */
static phase_result build_photon_grids(pm_progressive *p, iteration_run *it) {
    const pm_progressive_settings *set = &p->settings;
    pm_photon_buffer *caustic = &p->buffer[KIND_CAUSTIC], *global = &p->buffer[KIND_INDIRECT];
    if (p->radii.density_r2[KIND_CAUSTIC] == 0.0)
        p->radii.density_r2[KIND_CAUSTIC] = density_radius2(p, caustic->count, it->to_whole[KIND_CAUSTIC]);
    p->stats.photons_stored += caustic->count + global->count;
    /* visible points read only indirect photons (direct light and caustics have their own
     * estimates); gather points read all of them */
    if (!p->gathering) keep_tagged(global, 1u << PM_PATH_INDIRECT);
    if (p->radii.density_r2[KIND_INDIRECT] == 0.0)
        p->radii.density_r2[KIND_INDIRECT] = density_radius2(p, global->count, it->to_whole[KIND_INDIRECT]);
    if (p->gathering && p->radii.gather_r2 == 0.0)
        p->radii.gather_r2 = set->initial_radius > 0.0 ? set->initial_radius * set->initial_radius
                                                 : p->radii.density_r2[KIND_INDIRECT] * PM_PPM_GATHER_PHOTONS / PM_PPM_INITIAL_PHOTONS;
    it->t_grid = pm_now_seconds();
    bool built = build_grid(p, KIND_CAUSTIC) && build_grid(p, KIND_INDIRECT);
    if (pm_parallel_cancelled()) return PHASE_CANCELLED; /* a cancelled sort left the grids empty */
    return built ? PHASE_DONE : PHASE_FAILED;
}

/* Phase 3: the first pass with global photons sets the radii from their density where the camera
 * looks; while the guide learns to send photons there (at every power of two of the iterations),
 * the shared gather radius may shrink again to the denser light's (a deterministic sequence that
 * only ever shrinks faster, so the limit is unchanged). */
static void measure_seen_radii(pm_progressive *p, const iteration_run *it) {
    uint32_t iteration = it->iteration;
    bool remeasure = p->guiding && p->gathering && p->radii.gather_chosen && p->radii.gather_source == PM_GATHER_PHOTONS &&
                     p->radii.seen_measured && iteration >= 2 && (iteration & (iteration - 1)) == 0;
    if ((p->radii.seen_measured && !remeasure) || !p->buffer[KIND_INDIRECT].count || !(p->settings.initial_radius <= 0.0)) return;
    const pm_photon_grid *g = &p->grid[KIND_INDIRECT];
    double mean_r2 = p->radii.density_r2[KIND_INDIRECT] * (p->gathering ? PM_PPM_GATHER_PHOTONS / PM_PPM_INITIAL_PHOTONS : 1.0);
    if (!p->radii.seen_measured && !p->gathering) { /* gather points start from the shared radius alone */
        double seen = seen_density_radius2(p, g, 0, mean_r2, PM_PPM_INITIAL_PHOTONS, it->to_whole[KIND_INDIRECT]);
        if (seen > 0.0) p->radii.density_r2[KIND_INDIRECT] = fmin(seen, p->radii.density_r2[KIND_INDIRECT]);
    }
    if (p->gathering) {
        double gathered = seen_density_radius2(p, g, 1, remeasure ? p->radii.gather_r2 : mean_r2, PM_PPM_GATHER_PHOTONS,
                                               it->to_whole[KIND_INDIRECT]);
        if (gathered > 0.0) p->radii.gather_r2 = fmin(gathered, p->radii.gather_r2);
    }
    p->radii.seen_measured = true;
}

/* The eye passes' gather job over this iteration's grids, and the guide's marks cleared for them
 * (a mark's cell: twice the radius global photons are read with). NULL when out of memory. */
static gather_job *new_gather_job(pm_progressive *p, pm_film *film, const iteration_run *it) {
    gather_job *job = pm_calloc(1, sizeof *job, "gather job");
    if (!job) return NULL;
    job->p = p;
    job->film = film;
    job->caustic = p->grid[KIND_CAUSTIC].count ? &p->grid[KIND_CAUSTIC] : NULL;
    job->global = p->grid[KIND_INDIRECT].count ? &p->grid[KIND_INDIRECT] : NULL;
    job->gather_r2 = p->radii.gather_r2;
    job->gather_paths = it->source == PM_GATHER_PATH ? 1u << PM_PATH_PUNCTUAL_SPECULAR : PM_PATH_ALL;
    job->to_whole[KIND_CAUSTIC] = it->to_whole[KIND_CAUSTIC];
    job->to_whole[KIND_INDIRECT] = it->to_whole[KIND_INDIRECT];
    if (p->guiding && it->source == PM_GATHER_PHOTONS) { /* only such an iteration's marks are swapped in (end_iteration) */
        double read_radius = p->gathering ? sqrt(p->radii.gather_r2)
                                          : (p->radii.query_radius[KIND_INDIRECT] > 0.0 ? p->radii.query_radius[KIND_INDIRECT]
                                                                                  : mean_initial_radius(p, KIND_INDIRECT));
        pm_marks_clear(&p->marks_next, (float)(0.25 * read_radius));
    }
    return job;
}

/* The gather's per-thread counters summed into the run's statistics and radii. The gathering ran
 * inside the eye pass's wall time: its share (thread seconds over threads) is reported as gather
 * time, the rest as the eye pass's. */
static void add_gather_counters(pm_progressive *p, const gather_job *job) {
    int threads = pm_thread_count(p->settings.threads);
    double query_sum[KIND_COUNT] = {0, 0}, gather_seconds = 0.0;
    uint64_t query_count[KIND_COUNT] = {0, 0};
    for (int t = 0; t < threads; t++) {
        p->radii.initial_radius_sum += job->counters[t].radius_sum;
        p->radii.initial_radius_count += job->counters[t].radius_count;
        p->stats.photons_found += job->counters[t].found;
        p->stats.photons_examined += job->counters[t].inside;
        p->stats.disc_queries += job->counters[t].queries;
        p->stats.eye.dropped_samples += job->counters[t].dropped;
        p->stats.clip_rays += job->counters[t].clip_rays;
        gather_seconds += job->counters[t].seconds;
        for (int k = 0; k < KIND_COUNT; k++) {
            query_sum[k] += job->counters[t].query_sum[k];
            query_count[k] += job->counters[t].query_count[k];
        }
    }
    for (int k = 0; k < KIND_COUNT; k++) {
        if (query_count[k]) p->radii.query_radius[k] = query_sum[k] / (double)query_count[k];
        p->stats.photons_read += pm_photon_grid_read_count(&p->grid[k]);
    }
    gather_seconds /= threads;
    p->stats.gather_seconds += gather_seconds;
    p->stats.eye.seconds -= fmin(gather_seconds, p->stats.eye.seconds);
}

/* Phase 4: the eye passes: visible points (and gather points), emission and direct light; each
 * tile's points gather this iteration's photons as soon as the tile is traced (statistics at
 * visible points in the first pass, estimates at gather points in every pass). A pass cut short
 * by the deadline is the iteration's last: the pixels it reached are marked in the film, which
 * divides each pixel by its own counts; a cancelled pass takes the whole iteration back (its
 * first pass saved every pixel it wrote). */
static phase_result run_eye_passes(pm_progressive *p, pm_film *film, iteration_run *it) {
    gather_job *job = new_gather_job(p, film, it);
    if (!job) return PHASE_FAILED;
    bool photons_here = job->caustic || job->global;
    /* the photons' measuring iteration traces the probed pixels alone: its samples are read there
     * and nowhere else, and its cost is counted as the whole image's (eye_scale) */
    it->eye_scale = 1.0;
    if (it->measure_only) {
        size_t traced = it->trial_loop ? p->trial_grid.traced : p->probe.count;
        it->eye_scale = (double)p->pixels / (double)traced;
    }
    job->measure_caustic = it->learning && it->measure_only && p->caustic_surfaces;
    if (job->measure_caustic) memset(p->probe.gathered[0], 0, 2 * p->probe.count * sizeof(double));
    if (it->measure_only) {
        if (!pm_film_open_copy(film)) { free(job); return PHASE_FAILED; }
        pm_film_save_rect(film, 0, 0, film->width, film->height);
        p->eye.deadline = 0.0;
        p->eye.only_pixels = it->trial_loop ? p->trial_grid.only : p->probe.only;
    }
    phase_result result = PHASE_DONE;
    for (uint32_t pass = 0; pass < it->eye_passes && !it->cut; pass++) {
        job->statistics = pass == 0;
        job->sample = film->samples;
        /* gather points even with no photon to read there: their punctual light is traced */
        unsigned reached = PM_FILM_AHEAD_SAMPLE | (pass == 0 ? PM_FILM_AHEAD_PHOTON_PASS : 0u);
        pm_eye_pass_result r = pm_eye_visible_points(p->scene, p->accel, &p->camera, &p->eye, film->samples, film,
                                                     p->gathering, photons_here ? gather_tile : NULL, job, reached,
                                                     pass == 0, &p->stats.eye);
        if (r == PM_EYE_PASS_FAILED && pass == 0) { result = PHASE_FAILED; break; } /* nothing ran */
        /* out of memory after whole passes: the iteration ends with them (their splats, their
         * counts), so the film holds nothing half counted, and the failure is reported */
        if (r == PM_EYE_PASS_FAILED) { it->failed = true; break; }
        if (r == PM_EYE_PASS_CANCELLED) {
            /* the first pass put back the tiles it traced; after it, every pixel was saved */
            if (pass > 0 || it->measure_only) pm_film_restore_rect(film, 0, 0, film->width, film->height);
            result = PHASE_CANCELLED;
            break;
        }
        it->cut = r == PM_EYE_PASS_CUT;
        if (it->cut) break;
        film->samples++;
        if (pass == 0) film->photon_passes++;
        it->whole_passes++;
        if (it->probing && pass < 2 && it->trial_loop)
            probe_trial_loop_pass(&p->probe, film, pass, p->radii.trial_learned[TRIAL_LOOP]);
        else if (it->probing && pass < 2)
            probe_eye_pass(&p->probe, film, pass, it->learning ? (int)it->source : -1, p->radii.learned[it->source],
                           it->trial ? (int)p->radii.trial_learned[TRIAL_PHOTONS] : -1);
    }
    if (result == PHASE_DONE && p->splatting && !it->path_only) add_splats(p, film, it->whole_passes, it->cut);
    p->eye.deadline = it->deadline;
    p->eye.only_pixels = NULL;
    if (result == PHASE_DONE) add_gather_counters(p, job);
    free(job);
    return result;
}

/* A measured iteration's cost for a pair of eye passes, in rays: its photon passes and two eye
 * passes with their gathers. */
static double pair_cost(const pm_progressive *p, const iteration_run *it) {
    double passes = (double)it->whole_passes;
    /* a shadow test the shadow photons decided counts as the ray it saved: whether they are
     * built is measured in seconds (shadowmap.c), and the choice must not depend on it */
    double eye = (double)(p->stats.eye.rays - it->eye_rays_before) + (double)(p->stats.eye.shadow_rays_saved - it->saved_before) +
                 (double)(p->stats.clip_rays - it->clip_rays_before) +
                 PM_PPM_EXAMINED_COST * (double)(p->stats.photons_examined - it->examined_before) +
                 PM_PPM_QUERY_COST * (double)(p->stats.disc_queries - it->queries_before);
    eye *= it->eye_scale; /* a measuring iteration's eye passes cost what they would over the whole image */
    return (double)(p->stats.photons.rays - it->photon_rays_before) + 2.0 * eye / passes;
}

/* A learning iteration's cost, for choose_gather; once both sources are learned the choice is
 * made and the eye passes are learned again on it alone. */
static void learn_gather_cost(pm_progressive *p, const iteration_run *it) {
    p->radii.learn_cost[it->source] += pair_cost(p, it);
    p->radii.learned[it->source]++;
    if (it->measure_only && p->caustic_surfaces)
        for (size_t i = 0; i < p->probe.count; i++) {
            p->radii.gathered_light[0] += p->probe.gathered[0][i];
            p->radii.gathered_light[1] += p->probe.gathered[1][i];
        }
    if ((it->measure_only && keep_photons(p)) || (p->radii.learned[0] >= 2 && p->radii.learned[1] >= 2 && choose_gather(p))) {
        memset(p->probe.mean, 0, 3 * p->probe.count * sizeof(double));
        p->probe.pairs = 0;
    }
}

/* A caustic trial iteration's cost, and the decision once both arms are measured (choose_caustics). */
static void learn_caustic_trial(pm_progressive *p, pm_film *film, const iteration_run *it) {
    int arm = it->trial_loop ? TRIAL_LOOP : TRIAL_PHOTONS;
    p->radii.trial_cost[arm] += pair_cost(p, it);
    p->radii.trial_learned[arm]++;
    if (p->radii.trial_learned[TRIAL_PHOTONS] >= PM_PPM_TRIAL_ITERATIONS && p->radii.trial_learned[TRIAL_LOOP] >= PM_PPM_TRIAL_ITERATIONS)
        choose_caustics(p, film);
}

/* Phase 5: what the next iteration starts from: the shrunk gather radius, the guide's marks, the
 * gather source's learning, the eye passes per photon pass, and the counts. */
static void end_iteration(pm_progressive *p, pm_film *film, const iteration_run *it) {
    const pm_progressive_settings *set = &p->settings;
    /* Knaus and Zwicker's shrinking radius for the next iteration's gather points (an iteration
     * whose statistics pass was cut counts no photon pass: the next one reads with this radius) */
    if (p->gathering && p->radii.gather_r2 > 0.0 && it->whole_passes > 0) {
        uint32_t steps = set->radius_steps > 1 ? set->radius_steps : 1u;
        for (uint32_t step = 0; step < steps; step++) {
            double i = (double)it->iteration * steps + step + 1.0;
            p->radii.gather_r2 *= (i + set->alpha) / (i + 1.0);
        }
    }
    if (p->guiding && it->source == PM_GATHER_PHOTONS) {
        /* the marks this iteration made are the next global pass's to learn from (the path
         * tracer's iterations read no photons and make none: the last ones are kept; a measuring
         * iteration's come from the probed pixels alone) */
        pm_marks swap = p->marks;
        p->marks = p->marks_next;
        p->marks_next = swap;
    }
    if (it->path_only && !it->measure_only) p->stats.path_only_samples += it->whole_passes;
    if (it->learning && !it->cut) p->radii.learn_step++;
    if (it->learning && it->probing && it->whole_passes >= 2) learn_gather_cost(p, it);
    /* the caustic trial's measures, as learn_caustic_trial counts them (the loop's before its film is put back) */
    if (it->trial && it->probing && it->whole_passes >= 2) trial_grid_after(p, film, it->trial_loop ? TRIAL_LOOP : TRIAL_PHOTONS, it->whole_passes);
    if (it->measure_only) {
        /* the photons' learning iteration leaves the image as it found it (see begin_iteration) */
        pm_film_restore_rect(film, 0, 0, film->width, film->height);
        film->samples = it->start.samples;
        film->photon_passes = it->start.photon_passes;
    }
    if (it->trial && !it->cut) p->radii.trial_step++;
    if (it->connecting) end_light_vertices(p);
    if (p->arrival.counts) {
        pm_arrival_finish(&p->arrival);
        p->stats.sky_arrival_cells = p->arrival.usable_count;
    }
    if (it->connect_trial && !it->cut && it->whole_passes > 0) learn_connection_trial(p, film, it);
    if (it->trial && it->probing && it->whole_passes >= 2) learn_caustic_trial(p, film, it);
    if (it->probing && !it->cut && !it->trial_loop)
        p->radii.eye_passes = choose_eye_passes(&p->probe, film->photon_passes, it->photon_rays,
                                                it->eye_scale * (double)(p->stats.eye.rays - it->eye_rays_before) / it->eye_passes);
    /* a learning iteration needs a pair of eye passes, and the session plans as many as asked for
     * here: one would stall the learning (where photon noise dominates the probe asks one) */
    if (!p->radii.gather_chosen && p->radii.eye_passes < 2) p->radii.eye_passes = 2;
    p->stats.iterations = film->samples;
    p->stats.photon_passes = film->photon_passes;
}

/* One iteration: its phases in order; a cancel or a failure in any of them takes it back whole. */
static bool iterate(pm_progressive *p, pm_film *film, uint32_t max_samples) {
    assert((size_t)film->width * film->height == p->pixels);
    iteration_run it;
    begin_iteration(p, film, max_samples, &it);
    phase_result r = trace_photon_passes(p, film, &it);
    if (r == PHASE_DONE) r = build_photon_grids(p, &it);
    if (r != PHASE_DONE) return give_up(p, film, &it, r);
    measure_seen_radii(p, &it);
    double t1 = pm_now_seconds();
    p->stats.grid_seconds += t1 - it.t_grid;
    p->stats.photons.seconds += t1 - it.t0;
    /* what the eye passes' gathers cost (the radii's measurement above is the run's, once) */
    it.clip_rays_before = p->stats.clip_rays;
    it.examined_before = p->stats.photons_examined;
    it.queries_before = p->stats.disc_queries;
    r = run_eye_passes(p, film, &it);
    if (r != PHASE_DONE) return give_up(p, film, &it, r);
    end_iteration(p, film, &it);
    return !it.failed;
}

void pm_progressive_set_deadline(pm_progressive *p, double deadline) {
    if (p->tracer) pm_photon_tracer_set_deadline(p->tracer, deadline);
    p->eye.deadline = deadline;
}

void pm_progressive_set_shadow_map(pm_progressive *p, const pm_shadow_map *m) { p->eye.shadow = m; }

const pm_progressive_stats *pm_progressive_get_stats(const pm_progressive *p) { return &p->stats; }

pm_radius_summary pm_progressive_radii(const pm_progressive *p, const pm_film *film) {
    pm_radius_summary r = {0, 0, 0, 0, 0, 0};
    r.initial_mean = p->radii.initial_radius_count ? p->radii.initial_radius_sum / (double)p->radii.initial_radius_count : 0.0;
    r.gather = p->gathering ? sqrt(p->radii.gather_r2) : 0.0;
    double sum = 0.0;
    r.min = INFINITY;
    size_t n = (size_t)film->width * film->height;
    for (int k = 0; k < PM_SLOT_COUNT; k++) {
        if (!film->ppm[k]) continue;
        for (size_t i = 0; i < n; i++) {
            double r2 = film->ppm[k][i].r2;
            if (!(r2 > 0.0)) continue;
            double rad = sqrt(r2);
            sum += rad;
            r.min = fmin(r.min, rad);
            r.max = fmax(r.max, rad);
            r.pixels++;
        }
    }
    r.mean = r.pixels ? sum / (double)r.pixels : 0.0;
    if (!r.pixels) r.min = 0.0;
    return r;
}

/* test_cancel.c: a cancel in the middle of an iteration takes it back whole: the film, its statistics and the mode's state as before it, and more iterations end bit for bit where the run without the cancel does (progressive, classic and path-traced). */
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "accel.h"
#include "defaults.h"
#include "eye.h"
#include "film.h"
#include "parallel.h"
#include "photonmap.h"
#include "progressive.h"
#include "scene_builder.h"
#include "testing.h"

enum { W = 96, H = 80, PIXELS = W * H, TILES = (W / 16) * (H / 16) };

/* A glass ball and a mirror ball in a grey box under two point lights: caustic photons with camera
 * splats and statistics, a guided global pass (its guide and marks), gather points. */
static pm_accel *caustic_box(pm_scene *s, pm_camera *cam) {
    memset(s, 0, sizeof *s);
    sb_box(s, v3s(-1.f), v3s(1.f), sb_lambert(s, v3s(0.6f)), true);
    sb_sphere(s, v3(-0.4f, -0.6f, 0.f), 0.3f, 16, sb_material(s, v3s(1.f), 0, 0, 1, v3s(0), false));
    sb_sphere(s, v3(0.4f, -0.6f, 0.2f), 0.3f, 16, sb_material(s, v3s(0.9f), 1, 0, 0, v3s(0), false));
    sb_point_light(s, v3(0.f, 0.8f, 0.f), v3s(1.f));
    sb_point_light(s, v3(0.5f, 0.7f, -0.5f), v3s(0.5f));
    *cam = sb_camera(v3(0.f, 0.f, 0.95f), v3(0.f, -0.3f, 0.f), v3(0.f, 1.f, 0.f), 60.f);
    return sb_finish(s);
}

/* Sets the cancel flag as the `at`-th tile (from 0) of the `pass`-th eye pass (from 0) after arming is
 * handed out: eye passes are the parallel-fors over TILES tasks (no photon pass here has that many
 * chunks), and a pass hands out all its tasks before the next starts. Counts what the cancelled
 * pass handed out. */
typedef struct {
    atomic_bool flag;
    int pass, at;
    atomic_int tiles_seen;
    atomic_bool landed;
} canceller;

static void observe(void *ctx, size_t task, size_t count) {
    canceller *c = ctx;
    if (count != TILES) return;
    int seen = atomic_fetch_add(&c->tiles_seen, 1);
    if (seen == c->pass * TILES + c->at) {
        atomic_store(&c->flag, true);
        atomic_store(&c->landed, true);
    }
}

static int handed_out(canceller *c) { return atomic_load(&c->tiles_seen) - c->pass * TILES; }

static void arm(canceller *c, int pass, int at) {
    atomic_store(&c->flag, false);
    atomic_store(&c->landed, false);
    atomic_store(&c->tiles_seen, 0);
    c->pass = pass;
    c->at = at;
    pm_parallel_set_task_observer(observe, c);
}

static void disarm(canceller *c) {
    pm_parallel_set_task_observer(NULL, NULL);
    atomic_store(&c->flag, false);
}

/* The film's buffers bit for bit: sums, their low bits, statistics, counts. */
static bool same_film(const pm_film *a, const pm_film *b) {
    size_t n = 3 * (size_t)PIXELS;
    if (a->samples != b->samples || a->photon_passes != b->photon_passes || a->ragged != b->ragged) return false;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        if (!a->sum[c] != !b->sum[c]) return false;
        if (a->sum[c] && (memcmp(a->sum[c], b->sum[c], n * sizeof(float)) || memcmp(a->low[c], b->low[c], n * sizeof(int16_t))))
            return false;
    }
    for (int k = 0; k < PM_SLOT_COUNT; k++) {
        if (!a->ppm[k] != !b->ppm[k]) return false;
        if (a->ppm[k] && memcmp(a->ppm[k], b->ppm[k], PIXELS * sizeof(pm_ppm_stat))) return false;
    }
    return true;
}

static void copy_film(pm_film *to, const pm_film *from) {
    size_t n = 3 * (size_t)PIXELS;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++)
        if (from->sum[c]) {
            memcpy(to->sum[c], from->sum[c], n * sizeof(float));
            memcpy(to->low[c], from->low[c], n * sizeof(int16_t));
        }
    for (int k = 0; k < PM_SLOT_COUNT; k++)
        if (from->ppm[k]) memcpy(to->ppm[k], from->ppm[k], PIXELS * sizeof(pm_ppm_stat));
    to->samples = from->samples;
    to->photon_passes = from->photon_passes;
    to->ragged = from->ragged;
}

typedef struct {
    pm_progressive *p;
    pm_film film;
} run;

static bool begin(run *r, const pm_scene *s, const pm_accel *a, const pm_camera *cam, const pm_progressive_settings *ps) {
    char err[256];
    memset(r, 0, sizeof *r);
    r->p = pm_progressive_create(s, a, cam, ps, err, sizeof err);
    bool components[PM_COMPONENT_COUNT];
    if (r->p) pm_progressive_components(r->p, components);
    bool ok = r->p && pm_film_init(&r->film, W, H, components) && pm_progressive_bind(r->p, &r->film, err, sizeof err);
    CHECK(ok, "progressive set-up: %s", err);
    return ok;
}

static void end(run *r) {
    pm_progressive_destroy(r->p);
    pm_film_free(&r->film);
}

/* Progressive: `iterations` iterations with a cancel landing in eye pass `pass` of iteration
 * `cancelled`, after `at` tiles, against the same run without it. */
static void test_progressive(const pm_scene *s, const pm_accel *a, const pm_camera *cam, pm_indirect_mode indirect,
                             int eye_passes, uint32_t cancelled, int pass, int at, uint32_t iterations) {
    const char *mode = indirect == PM_INDIRECT_GATHER ? "gather" : "photons";
    pm_progressive_settings ps = {.seed = 7, .threads = 2, .photons = 4000, .caustic_photons = 4000, .alpha = PM_DEFAULT_ALPHA,
                                  .indirect = indirect, .max_specular_depth = PM_DEFAULT_MAX_SPECULAR_DEPTH,
                                  .max_photon_bounces = PM_DEFAULT_MAX_PHOTON_BOUNCES, .eye_passes = eye_passes};
    run whole, cut;
    pm_film before;
    bool components[PM_COMPONENT_COUNT];
    if (!begin(&whole, s, a, cam, &ps)) return;
    if (!begin(&cut, s, a, cam, &ps)) { end(&whole); return; }
    pm_progressive_components(cut.p, components);
    bool slots[PM_SLOT_COUNT];
    for (int k = 0; k < PM_SLOT_COUNT; k++) slots[k] = cut.film.ppm[k] != NULL;
    CHECK(pm_film_init(&before, W, H, components) && pm_film_enable_ppm(&before, slots), "film");
    CHECK(cut.film.sum[PM_CAUSTIC] && cut.film.ppm[PM_SLOT_SPECULAR_CAUSTIC], "%s: caustic splats and statistics", mode);
    canceller c;
    atomic_init(&c.flag, false);
    atomic_init(&c.tiles_seen, 0);
    atomic_init(&c.landed, false);
    /* both runs under a cancel flag (the first pass of each iteration saves what it writes) */
    pm_parallel_set_cancel(&c.flag);
    for (uint32_t i = 0; i < iterations; i++) CHECK(pm_progressive_iterate(whole.p, &whole.film, 0), "iteration");
    uint32_t eye_passes_then = 0;
    for (uint32_t i = 0; i < iterations; i++) {
        if (i == cancelled) {
            eye_passes_then = pm_progressive_eye_passes(cut.p);
            copy_film(&before, &cut.film);
            pm_progressive_stats stats = *pm_progressive_get_stats(cut.p);
            pm_radius_summary radii = pm_progressive_radii(cut.p, &cut.film);
            arm(&c, pass, at);
            CHECK(pm_progressive_iterate(cut.p, &cut.film, 0), "%s: a cancelled iteration is no failure", mode);
            disarm(&c);
            int handed = handed_out(&c);
            printf("progressive (%s, eye passes %d): cancel in eye pass %d of iteration %u after %d of %d tiles handed out\n",
                   mode, eye_passes, pass, cancelled, handed, TILES);
            CHECK(atomic_load(&c.landed) && handed > at && handed < TILES,
                  "%s: the cancel landed in the middle of eye pass %d (%d of %d tiles handed out)", mode, pass, handed, TILES);
            CHECK(same_film(&cut.film, &before), "%s: the cancelled iteration left the film, its sums and statistics as before it",
                  mode);
            pm_radius_summary again = pm_progressive_radii(cut.p, &cut.film);
            CHECK(memcmp(&radii, &again, sizeof radii) == 0 && pm_progressive_eye_passes(cut.p) == eye_passes_then,
                  "%s: radii and eye passes as before the iteration", mode);
            CHECK(memcmp(&stats, pm_progressive_get_stats(cut.p), sizeof stats) == 0, "%s: stats as before the iteration", mode);
        }
        CHECK(pm_progressive_iterate(cut.p, &cut.film, 0), "iteration");
    }
    pm_parallel_set_cancel(NULL);
    CHECK(cut.film.samples > 0 && same_film(&cut.film, &whole.film),
          "%s: after the cancel and %u iterations the film is the uncancelled run's bit for bit (%u vs %u samples)", mode,
          iterations, cut.film.samples, whole.film.samples);
    float *x = malloc(sizeof(float) * 3 * PIXELS), *y = malloc(sizeof(float) * 3 * PIXELS);
    pm_film_resolve_total(&cut.film, x);
    pm_film_resolve_total(&whole.film, y);
    CHECK(memcmp(x, y, sizeof(float) * 3 * PIXELS) == 0, "%s: the same image bit for bit", mode);
    free(x);
    free(y);
    pm_film_free(&before);
    end(&whole);
    end(&cut);
}

/* Classic (photon maps) or path-traced eye passes: a cancel in the middle of the second. */
static void test_eye(const pm_scene *s, const pm_accel *a, const pm_camera *cam, bool path_trace) {
    const char *mode = path_trace ? "path tracing" : "classic";
    pm_photon_maps maps;
    memset(&maps, 0, sizeof maps);
    pm_eye_settings es;
    memset(&es, 0, sizeof es);
    es.seed = 5;
    es.threads = 2;
    es.max_specular_depth = PM_DEFAULT_MAX_SPECULAR_DEPTH;
    es.path_trace = path_trace;
    if (!path_trace) {
        pm_photon_settings phs;
        memset(&phs, 0, sizeof phs);
        phs.seed = 3;
        phs.threads = 2;
        phs.global_photons = 20000;
        phs.caustic_photons = 20000;
        phs.max_bounces = PM_DEFAULT_MAX_PHOTON_BOUNCES;
        phs.projection_maps = true;
        pm_photon_stats st;
        memset(&st, 0, sizeof st);
        CHECK(pm_photon_maps_build(s, a, &phs, &maps, &st), "classic: photon maps");
        es.maps = &maps;
        es.caustic_estimate = (pm_estimate_settings){.k = 50, .max_radius = 0.2f, .path_mask = 1u << PM_PATH_CAUSTIC};
        es.global_estimate = (pm_estimate_settings){.k = 50, .max_radius = 0.3f, .path_mask = 1u << PM_PATH_INDIRECT};
        es.indirect = PM_INDIRECT_PHOTONS;
    }
    bool on[PM_COMPONENT_COUNT];
    for (int k = 0; k < PM_COMPONENT_COUNT; k++) on[k] = s->analysis.component_possible[k];
    pm_film whole, cut, before;
    CHECK(pm_film_init(&whole, W, H, on) && pm_film_init(&cut, W, H, on) && pm_film_init(&before, W, H, on), "films");
    canceller c;
    atomic_init(&c.flag, false);
    atomic_init(&c.tiles_seen, 0);
    atomic_init(&c.landed, false);
    pm_parallel_set_cancel(&c.flag);
    pm_eye_stats ws, cs;
    memset(&ws, 0, sizeof ws);
    memset(&cs, 0, sizeof cs);
    for (uint32_t i = 0; i < 3; i++) pm_eye_iterate(s, a, cam, &es, whole.samples, &whole, &ws);
    pm_eye_iterate(s, a, cam, &es, cut.samples, &cut, &cs);
    copy_film(&before, &cut);
    pm_eye_stats stats = cs;
    arm(&c, 0, TILES / 2);
    CHECK(pm_eye_iterate(s, a, cam, &es, cut.samples, &cut, &cs), "%s: a cancelled pass is no failure", mode);
    disarm(&c);
    int handed = handed_out(&c);
    printf("%s: cancel after %d of %d tiles handed out\n", mode, handed, TILES);
    CHECK(atomic_load(&c.landed) && handed < TILES, "%s: the cancel landed in the middle of the pass (%d of %d)", mode, handed, TILES);
    CHECK(same_film(&cut, &before) && !cut.ragged, "%s: the cancelled pass left the film as before it", mode);
    CHECK(memcmp(&stats, &cs, sizeof stats) == 0, "%s: and its counters", mode);
    while (cut.samples < 3) pm_eye_iterate(s, a, cam, &es, cut.samples, &cut, &cs);
    pm_parallel_set_cancel(NULL);
    CHECK(same_film(&cut, &whole), "%s: after the cancel and two more passes the film is the uncancelled run's bit for bit", mode);
    pm_film_free(&whole);
    pm_film_free(&cut);
    pm_film_free(&before);
    pm_photon_maps_free(&maps);
}

int main(void) {
    alarm(300);
    pm_scene s;
    pm_camera cam;
    pm_accel *a = caustic_box(&s, &cam);
    CHECK(a != NULL, "accel");
    if (a) {
        /* automatic eye passes: one in the first iteration, two while the probe learns */
        test_progressive(&s, a, &cam, PM_INDIRECT_GATHER, 0, 2, 0, TILES / 2, 5);
        test_progressive(&s, a, &cam, PM_INDIRECT_GATHER, 0, 3, 1, TILES / 3, 5);
        test_progressive(&s, a, &cam, PM_INDIRECT_PHOTONS, 2, 1, 1, TILES / 2, 4);
        test_progressive(&s, a, &cam, PM_INDIRECT_PHOTONS, 1, 0, 0, TILES / 2, 3);
        test_eye(&s, a, &cam, true);
        test_eye(&s, a, &cam, false);
    }
    pm_accel_destroy(a);
    pm_scene_free(&s);
    return pm_test_done("test_cancel");
}

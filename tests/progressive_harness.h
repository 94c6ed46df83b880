/* progressive_harness.h: what the progressive tests share: default settings, a progressive run over a film, small image helpers. */
#ifndef PM_PROGRESSIVE_HARNESS_H
#define PM_PROGRESSIVE_HARNESS_H

#include <stdlib.h>
#include <string.h>

#include "accel.h"
#include "defaults.h"
#include "film.h"
#include "progressive.h"
#include "scene_builder.h"
#include "testing.h"

static pm_progressive_settings default_settings(int w, int h) {
    pm_progressive_settings ps;
    memset(&ps, 0, sizeof ps);
    ps.seed = 1;
    ps.threads = 2;
    ps.photons = ps.caustic_photons = pm_progressive_default_photons(w, h);
    ps.alpha = PM_DEFAULT_ALPHA;
    ps.indirect = PM_INDIRECT_GATHER;
    ps.max_specular_depth = PM_DEFAULT_MAX_SPECULAR_DEPTH;
    ps.max_photon_bounces = PM_DEFAULT_MAX_PHOTON_BOUNCES;
    return ps;
}

typedef struct {
    pm_progressive *p;
    pm_film film;
} session;

static bool start(session *r, const pm_scene *s, const pm_accel *a, const pm_camera *cam, int w, int h,
                  const pm_progressive_settings *ps) {
    char err[256];
    memset(r, 0, sizeof *r);
    r->p = pm_progressive_create(s, a, cam, ps, err, sizeof err);
    if (!r->p) { CHECK(false, "create: %s", err); return false; }
    bool components[PM_COMPONENT_COUNT];
    pm_progressive_components(r->p, components);
    if (!pm_film_init(&r->film, w, h, components) || !pm_progressive_bind(r->p, &r->film, err, sizeof err)) {
        CHECK(false, "bind: %s", err);
        return false;
    }
    return true;
}

static void stop(session *r) {
    pm_progressive_destroy(r->p);
    pm_film_free(&r->film);
}

/* n more samples per pixel (an iteration may add several: pm_progressive_iterate) */
static bool iterate(session *r, int n) {
    uint32_t target = r->film.samples + (uint32_t)n;
    while (r->film.samples < target)
        if (!pm_progressive_iterate(r->p, &r->film, target - r->film.samples)) {
            CHECK(false, "iteration %u failed", r->film.samples);
            return false;
        }
    return true;
}

/* Iterations until the film holds n photon passes (the radii shrink per photon pass). */
static inline bool iterate_passes(session *r, uint32_t n) {
    while (r->film.photon_passes < n)
        if (!pm_progressive_iterate(r->p, &r->film, 0)) {
            CHECK(false, "iteration %u failed", r->film.samples);
            return false;
        }
    return true;
}

static double mean_of(const float *img, size_t n) {
    double s = 0;
    for (size_t i = 0; i < n; i++) s += img[i];
    return s / (double)n;
}

#endif

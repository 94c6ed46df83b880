/* progressive_harness.h: what the progressive tests share: a progressive render session at the tests' defaults, run n samples at a time, and small image helpers. */
#ifndef PM_PROGRESSIVE_HARNESS_H
#define PM_PROGRESSIVE_HARNESS_H

#include <stdlib.h>
#include <string.h>

#include "accel.h"
#include "defaults.h"
#include "film.h"
#include "progressive.h"
#include "scene_builder.h"
#include "session.h"
#include "testing.h"

/* The session's defaults, seed 1 on two threads. */
static inline pm_progressive_settings default_settings(int w, int h) { return pm_session_progressive_defaults(w, h, 1, 2); }

typedef struct {
    pm_session *session;
    pm_progressive *p;      /* the session's */
    const pm_film *film;    /* the session's */
} session;

/* A progressive session without shadow photons (the tests that want them set their own map). */
static inline bool start(session *r, const pm_scene *s, const pm_accel *a, const pm_camera *cam, int w, int h,
                  const pm_progressive_settings *ps) {
    char err[256];
    memset(r, 0, sizeof *r);
    pm_session_config config;
    pm_session_config_defaults(&config, PM_MODE_PROGRESSIVE, w, h, ps->seed, ps->threads);
    config.progressive = *ps;
    config.shadow.mode = PM_SHADOW_OFF;
    r->session = pm_session_create(s, a, cam, &config, err, sizeof err);
    if (!r->session) { CHECK(false, "create: %s", err); return false; }
    r->p = pm_session_progressive(r->session);
    r->film = pm_session_film(r->session);
    return true;
}

static inline void stop(session *r) {
    pm_session_destroy(r->session);
    memset(r, 0, sizeof *r);
}

/* n more samples per pixel (an iteration may add several: pm_progressive_iterate) */
static inline bool iterate(session *r, int n) {
    pm_session_goal goal = {r->film->samples + (uint32_t)n, 0.0};
    if (pm_session_run(r->session, &goal, NULL, NULL, NULL) == PM_RUN_FAILED) {
        CHECK(false, "iteration %u failed: %s", r->film->samples, pm_session_error(r->session));
        return false;
    }
    return true;
}

/* Iterations until the film holds n photon passes (the radii shrink per photon pass). */
static inline bool iterate_passes(session *r, uint32_t n) {
    while (r->film->photon_passes < n)
        if (!pm_session_iterate(r->session, 0)) {
            CHECK(false, "iteration %u failed: %s", r->film->samples, pm_session_error(r->session));
            return false;
        }
    return true;
}

static inline double mean_of(const float *img, size_t n) {
    double s = 0;
    for (size_t i = 0; i < n; i++) s += img[i];
    return s / (double)n;
}

/* A small room with an emissive ceiling patch and a glass ball, scaled by `scale` about the origin. */
static inline pm_accel *scaled_room(pm_scene *s, float scale, pm_camera *cam) {
    memset(s, 0, sizeof *s);
    uint32_t white = sb_lambert(s, v3s(0.7f)), red = sb_lambert(s, v3(0.7f, 0.1f, 0.1f));
    uint32_t lamp = sb_material(s, v3s(0), 0, 1, 0, v3s(5.f), false);
    uint32_t glass = sb_material(s, v3s(1), 0, 0, 1, v3s(0), false);
    float k = scale;
    sb_box(s, v3(-k, -k, -k), v3(k, k, k), white, true);
    sb_quad(s, v3(-k, -k, -k), v3(-k, k, -k), v3(-k, k, k), v3(-k, -k, k), red);
    sb_quad(s, v3(-0.3f * k, 0.99f * k, -0.3f * k), v3(0.3f * k, 0.99f * k, -0.3f * k), v3(0.3f * k, 0.99f * k, 0.3f * k),
            v3(-0.3f * k, 0.99f * k, 0.3f * k), lamp);
    sb_sphere(s, v3(0.3f * k, -0.6f * k, 0), 0.35f * k, 24, glass);
    *cam = sb_camera(v3(0, 0, 0.95f * k), v3(0, -0.3f * k, -k), v3(0, 1, 0), 70.f);
    return sb_finish(s);
}

#endif

/* session_harness.h: an image rendered in any mode through the session, as pmview renders it: pm_session_config_defaults with a test's overrides, run to n samples. */
#ifndef PM_SESSION_HARNESS_H
#define PM_SESSION_HARNESS_H

#include "session.h"
#include "testing.h"

/* The session's defaults for a mode without shadow photons (a test that wants them sets
 * config.shadow) and, in the classic mode, without a photon pass: the eye pass alone (emission,
 * direct light, specular chains) until the test gives photon settings (with_photons). */
static inline pm_session_config mode_config(pm_mode mode, int w, int h, uint64_t seed, int threads) {
    pm_session_config config;
    pm_session_config_defaults(&config, mode, w, h, seed, threads);
    config.shadow.mode = PM_SHADOW_OFF;
    config.classic_photon_pass = false;
    config.classic_photons.global_photons = config.classic_photons.caustic_photons = 0;
    return config;
}

/* The classic mode's maps, built by the session before its first iteration with exactly these
 * settings, read with these estimates. */
static inline void with_photons(pm_session_config *config, const pm_photon_settings *photons, pm_estimate_settings global,
                                pm_estimate_settings caustic) {
    config->classic_photon_pass = true;
    config->classic_photons = *photons;
    config->eye.global_estimate = global;
    config->eye.caustic_estimate = caustic;
}

/* A session for config run to `samples` samples per pixel, the observer (may be NULL) called
 * after each iteration; NULL after a failed CHECK. The image is pm_session_film's;
 * pm_session_destroy frees it. */
static inline pm_session *observed_session(const pm_scene *s, const pm_accel *a, const pm_camera *cam,
                                           const pm_session_config *config, uint32_t samples, pm_session_observer observer,
                                           void *context) {
    char err[256];
    pm_session *session = pm_session_create(s, a, cam, config, err, sizeof err);
    if (!session) { CHECK(false, "session: %s", err); return NULL; }
    pm_session_goal goal = {samples, 0.0};
    if (pm_session_run(session, &goal, observer, context, NULL) != PM_RUN_DONE || pm_session_film(session)->samples != samples) {
        CHECK(false, "%u of %u samples: %s", pm_session_film(session)->samples, samples, pm_session_error(session));
        pm_session_destroy(session);
        return NULL;
    }
    return session;
}

static inline pm_session *render_session(const pm_scene *s, const pm_accel *a, const pm_camera *cam,
                                         const pm_session_config *config, uint32_t samples) {
    return observed_session(s, a, cam, config, samples, NULL, NULL);
}

#endif

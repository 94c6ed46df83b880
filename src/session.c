/* session.c: the render session: mode state and film, and synchronous iterations planned to a time budget (the worker thread is in session_worker.c). */
#include "session.h"
#include "session_state.h"
#include "clock.h"
#include "memory.h"

#include <math.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "defaults.h"
#include "image_io.h"
#include "parallel.h"


/* A failure of the call under way: its message, kept until the next top-level call. */
void pm_session_fail(pm_session *s, const char *format, ...) {
    va_list args;
    va_start(args, format);
    vsnprintf(s->error, sizeof s->error, format, args);
    va_end(args);
}

/* The start of a top-level call: no earlier failure, handled or not, may name this one's. */
void pm_session_begin(pm_session *s) {
    s->error[0] = '\0';
    pm_memory_clear_failure();
}

/* The failure the call met since its mark (never another thread's, nor an older one), or `what`. */
static const char *memory_failure_or(uint64_t mark, const char *what) { return pm_memory_failure_since_or(mark, what); }

/* The mode state and film for config, from camera: nothing of the session's is touched, so a
 * caller whose build fails keeps what it had. */
bool pm_session_build_state(const pm_session *s, const pm_session_config *config, const pm_camera *camera,
                            pm_progressive **progressive, pm_film *film, char *err, size_t err_size) {
    *progressive = NULL;
    memset(film, 0, sizeof *film);
    uint64_t mark = pm_memory_failure_mark();
    bool components[PM_COMPONENT_COUNT];
    if (config->mode == PM_MODE_PROGRESSIVE) {
        *progressive = pm_progressive_create(s->scene, s->accel, camera, &config->progressive, err, err_size);
        if (!*progressive) return false;
        pm_progressive_components(*progressive, components);
    } else {
        for (int c = 0; c < PM_COMPONENT_COUNT; c++) components[c] = s->scene->analysis.component_possible[c];
        /* the maps are built at the first iteration; a component they cannot feed has no buffer
         * (the path tracer feeds every component the scene can have) */
        bool maps = config->mode == PM_MODE_CLASSIC;
        components[PM_CAUSTIC] = components[PM_CAUSTIC] && (!maps || (config->classic_photon_pass && config->classic_photons.caustic_photons));
        components[PM_INDIRECT] = components[PM_INDIRECT] && (!maps || (config->classic_photon_pass && config->classic_photons.global_photons));
    }
    bool ok = pm_film_init(film, config->width, config->height, components);
    if (!ok)
        snprintf(err, err_size, "out of memory (%s) for a %dx%d film", memory_failure_or(mark, "film"), config->width, config->height);
    else if (*progressive)
        ok = pm_progressive_bind(*progressive, film, err, err_size);
    /* room for the copy each iteration makes for a cancel to put back, taken now: refused, the
     * session cannot be made, rather than failing at its first iteration */
    if (ok && !pm_film_reserve_copy(film)) {
        snprintf(err, err_size, "out of memory (%s) for a %dx%d film", memory_failure_or(mark, "film"), config->width, config->height);
        ok = false;
    }
    if (!ok) {
        pm_progressive_destroy(*progressive);
        *progressive = NULL;
        pm_film_free(film);
    }
    return ok;
}

/* (Re)creates the mode state and the film for the current configuration. */
bool pm_session_build_mode(pm_session *s, char *err, size_t err_size) {
    pm_progressive_destroy(s->progressive);
    s->progressive = NULL;
    pm_film_free(&s->film);
    return pm_session_build_state(s, &s->config, &s->camera, &s->progressive, &s->film, err, err_size);
}

/* The classic mode's automatic photon counts: from the image size, or with a time budget from a
 * pilot pass's photon speed, so the pass gets its share of the budget. The pilot's own failure
 * is handled here (the image size's count stands) and forgotten. */
static void choose_classic_photons(const pm_session *s, pm_photon_settings *ps) {
    if (ps->global_photons != PM_PHOTONS_AUTO && ps->caustic_photons != PM_PHOTONS_AUTO) return;
    double n = (double)s->config.width * s->config.height * PM_DEFAULT_PHOTONS_PER_PIXEL;
    if (s->config.time_budget > 0) {
        pm_photon_settings pilot = *ps;
        pilot.global_photons = pilot.caustic_photons = PM_PILOT_PHOTONS;
        pm_photon_stats pilot_stats;
        pm_photon_maps pilot_maps;
        if (pm_photon_maps_build(s->scene, s->accel, &pilot, &pilot_maps, &pilot_stats) && pilot_stats.seconds > 0)
            n = PM_TIME_SHARE_PHOTONS * s->config.time_budget * (double)pilot_stats.emitted / pilot_stats.seconds / 2.0;
        pm_photon_maps_free(&pilot_maps);
        pm_memory_clear_failure();
    }
    if (n < PM_MIN_DEFAULT_PHOTONS) n = PM_MIN_DEFAULT_PHOTONS;
    if (n > PM_MAX_DEFAULT_PHOTONS) n = PM_MAX_DEFAULT_PHOTONS;
    if (ps->global_photons == PM_PHOTONS_AUTO) ps->global_photons = (uint64_t)n;
    if (ps->caustic_photons == PM_PHOTONS_AUTO) ps->caustic_photons = (uint64_t)n;
}

uint64_t pm_session_forecast_bytes(const pm_session *s) {
    uint64_t bytes = pm_film_bytes(&s->film) + PM_RENDER_RESIDENT_BYTES;
    if (s->progressive && pm_progressive_uses_photons(s->progressive))
        bytes += pm_progressive_photons_per_iteration(s->progressive) * sizeof(pm_photon) * PM_PHOTON_PASS_RECORDS;
    const pm_photon_settings *ps = &s->config.classic_photons;
    if (s->config.mode == PM_MODE_CLASSIC && s->config.classic_photon_pass)
        bytes += (ps->global_photons * PM_PHOTON_MAP_RECORDS + ps->caustic_photons) * sizeof(pm_photon);
    return bytes + pm_shadow_map_forecast_bytes(s->scene, &s->config.shadow);
}

pm_progressive_settings pm_session_progressive_defaults(int width, int height, uint64_t seed, int threads) {
    pm_progressive_settings ps;
    memset(&ps, 0, sizeof ps);
    ps.seed = seed;
    ps.threads = pm_thread_count(threads);
    ps.photons = ps.caustic_photons = pm_progressive_default_photons(width, height);
    ps.alpha = PM_DEFAULT_ALPHA;
    ps.indirect = PM_INDIRECT_GATHER;
    ps.max_specular_depth = PM_DEFAULT_MAX_SPECULAR_DEPTH;
    ps.max_photon_bounces = PM_DEFAULT_MAX_PHOTON_BOUNCES;
    return ps;
}

void pm_session_config_defaults(pm_session_config *c, pm_mode mode, int width, int height, uint64_t seed, int threads) {
    memset(c, 0, sizeof *c);
    c->mode = mode;
    c->width = width;
    c->height = height;
    threads = pm_thread_count(threads);
    c->progressive = pm_session_progressive_defaults(width, height, seed, threads);
    c->eye.seed = seed;
    c->eye.threads = threads;
    c->eye.max_specular_depth = PM_DEFAULT_MAX_SPECULAR_DEPTH;
    c->eye.path_trace = mode == PM_MODE_PATHTRACE;
    c->classic_photon_pass = mode == PM_MODE_CLASSIC;
    c->classic_photons.seed = seed;
    c->classic_photons.threads = threads;
    c->classic_photons.max_bounces = PM_DEFAULT_MAX_PHOTON_BOUNCES;
    c->classic_photons.projection_maps = true;
    c->classic_photons.global_photons = c->classic_photons.caustic_photons = PM_PHOTONS_AUTO;
    c->shadow.mode = PM_SHADOW_AUTO;
    c->shadow.photons_per_light = pm_shadow_default_photons(width, height);
    c->shadow.threads = threads;
}

pm_session *pm_session_create(const pm_scene *scene, const pm_accel *a, const pm_camera *camera,
                              const pm_session_config *config, char *err, size_t err_size) {
    pm_session *s = pm_calloc(1, sizeof *s, "render session");
    if (!s) { snprintf(err, err_size, "out of memory (render session, %zu bytes)", sizeof *s); return NULL; }
    s->scene = scene;
    s->accel = a;
    s->camera = *camera;
    s->config = *config;
    s->indirect_change = -1;
    pthread_mutex_init(&s->lock, NULL);
    pthread_cond_init(&s->wake, NULL);
    atomic_init(&s->cancel, false);
    atomic_init(&s->halt, false);
    s->preview_divisor = PM_PREVIEW_DIVISOR;
    pm_memory_clear_failure();
    if (s->config.mode == PM_MODE_CLASSIC && s->config.classic_photon_pass) choose_classic_photons(s, &s->config.classic_photons);
    if (!pm_session_build_mode(s, err, err_size)) { pm_session_destroy(s); return NULL; }
    return s;
}

void pm_session_destroy(pm_session *s) {
    if (!s) return;
    pm_session_stop(s);
    pm_progressive_destroy(s->progressive);
    pm_photon_maps_free(&s->maps);
    pm_shadow_map_free(s->shadow);
    pm_film_free(&s->film);
    pm_session_free_display(s->front, s->back);
    free((double *)s->packed.values);
    free(s->packed_back);
    pthread_mutex_destroy(&s->lock);
    pthread_cond_destroy(&s->wake);
    free(s);
}

const pm_film *pm_session_film(const pm_session *s) { return &s->film; }
pm_progressive *pm_session_progressive(pm_session *s) { return s->progressive; }
const pm_photon_maps *pm_session_classic_maps(const pm_session *s) { return s->config.mode == PM_MODE_CLASSIC ? &s->maps : NULL; }
const pm_photon_stats *pm_session_classic_photon_stats(const pm_session *s) { return &s->classic_photon_stats; }
const pm_eye_stats *pm_session_eye_stats(const pm_session *s) { return &s->eye_stats; }
const char *pm_session_error(const pm_session *s) { return s->error; }
const pm_shadow_stats *pm_session_shadow_stats(const pm_session *s) { return &s->shadow_stats; }

void pm_session_set_deadline(pm_session *s, double deadline) {
    double now = pm_now_seconds();
    s->config.shadow.deadline = deadline > now ? now + (deadline - now) * PM_SHADOW_TIME_SHARE : now;
    s->config.eye.deadline = deadline;
    if (s->progressive) pm_progressive_set_deadline(s->progressive, deadline);
}

void pm_session_cancel(pm_session *s) { atomic_store(&s->cancel, true); }

/* The shadow photons, once: they depend on the scene and its lights only, so camera moves and
 * restarts keep them. A build cut short by a restart is no map: it is built again next time. */
static bool decide_shadow_map(pm_session *s) {
    if (s->shadow_decided) return true;
    s->shadow = pm_shadow_map_build(s->scene, s->accel, &s->config.shadow, &s->shadow_stats);
    if (s->shadow_stats.out_of_memory) return false;
    if (atomic_load(&s->cancel)) {
        pm_shadow_map_free(s->shadow);
        s->shadow = NULL;
        return true;
    }
    s->shadow_decided = true;
    return true;
}

void pm_session_set_budget(pm_session *s, double start, double seconds) {
    s->budget_start = start;
    s->budget_seconds = seconds > 0.0 ? seconds : 0.0;
    if (s->budget_seconds > 0.0) pm_session_set_deadline(s, start + seconds);
}

uint32_t pm_session_plan_samples(const pm_session *s, uint32_t wanted) {
    if (s->film.ragged) return 0; /* a pass was cut: the run is over */
    if (!wanted || s->budget_seconds <= 0.0) return wanted;
    /* the first iteration: one sample, whatever the eye passes a photon pass (its cost is unknown) */
    if (s->film.samples == 0) return 1;
    double left = s->budget_seconds - (pm_now_seconds() - s->budget_start);
    if (left <= 0.0) return 0;
    /* the last iteration added nothing (its eye pass was cut before a tile): none to plan from */
    if (s->last_samples == 0) return 1;
    /* at most as many samples as fit in the time left at the last iteration's wall time a sample
     * (its photon pass shared out: an over-estimate for more samples, so the cap errs short) */
    uint32_t next = s->progressive ? pm_progressive_eye_passes(s->progressive) : 1;
    double fit = floor(left / (s->last_wall / s->last_samples));
    if (fit < next) next = fit < 1.0 ? 1 : (uint32_t)fit;
    if (next > wanted) next = wanted;
    /* The deadline cuts the eye passes between tiles (and the photon pass between chunks), so an
     * iteration started with time left ends near the budget instead of a pass past it: it is
     * started unless the time left is too short for its photon pass and sort to leave any for
     * eye tiles (a twentieth of a sample's time). */
    if (left <= 0.05 * (s->last_wall / s->last_samples)) return 0;
    return next;
}

/* One iteration; false when it failed without a cancel (out of memory), the reason in memory.c's record. */
bool pm_session_iterate_once(pm_session *s, uint32_t max_samples) {
    /* a film a cut pass left ragged is a finished run's: passing over it again could leave a
     * pixel two samples ahead, which the film does not count */
    if (s->film.ragged) pm_session_restart(s, NULL);
    /* the passes stop at the session's cancel flag, on this thread too (a snapshot's signal) */
    const atomic_bool *cancel_before = pm_parallel_get_cancel();
    pm_parallel_set_cancel(&s->cancel);
    double t0 = pm_now_seconds();
    uint32_t samples_before = s->film.samples;
    bool ok = decide_shadow_map(s);
    if (!ok) { pm_parallel_set_cancel(cancel_before); return false; }
    if (s->progressive) {
        /* a map the caller set on the mode state stands where the session has none (tests) */
        if (s->shadow) pm_progressive_set_shadow_map(s->progressive, s->shadow);
        ok = pm_progressive_iterate(s->progressive, &s->film, max_samples);
    } else {
        if (!s->maps_built && s->config.classic_photon_pass && s->config.mode == PM_MODE_CLASSIC) {
            ok = pm_photon_maps_build(s->scene, s->accel, &s->config.classic_photons, &s->maps, &s->classic_photon_stats);
            s->maps_built = ok;
            if (ok && atomic_load(&s->cancel)) {
                /* a map cut short is no map: build it again next time */
                pm_photon_maps_free(&s->maps);
                s->maps_built = false;
            }
        }
        if (ok) {
            pm_eye_settings eye = s->config.eye;
            eye.maps = s->maps_built ? &s->maps : NULL;
            eye.path_trace = s->config.mode == PM_MODE_PATHTRACE;
            eye.shadow = s->shadow;
            pm_eye_iterate(s->scene, s->accel, &s->camera, &eye, s->film.samples, &s->film, &s->eye_stats);
            ok = !s->eye_stats.failed;
        }
    }
    double t1 = pm_now_seconds();
    s->render_seconds += t1 - t0;
    s->last_samples = s->film.samples - samples_before;
    s->last_wall = t1 - t0;
    pm_parallel_set_cancel(cancel_before);
    /* what a cancel cut short is no failure, even where it ran out of memory on the way */
    return ok || atomic_load(&s->cancel);
}

static uint64_t run_photons(const pm_session *s) {
    return s->progressive ? pm_progressive_get_stats(s->progressive)->photons.emitted : s->classic_photon_stats.emitted;
}

bool pm_session_iterate(pm_session *s, uint32_t max_samples) {
    pm_session_begin(s);
    uint64_t mark = pm_memory_failure_mark();
    if (pm_session_iterate_once(s, max_samples)) return true;
    pm_session_fail(s, "out of memory (%s) in iteration %u", memory_failure_or(mark, "unknown"), s->film.samples + 1);
    return false;
}

pm_session_run_result pm_session_run(pm_session *s, const pm_session_goal *goal, pm_session_observer observer,
                                     void *context, pm_session_run_state *state_out) {
    pm_session_begin(s);
    pm_session_run_state state = {0, 0, 0.0, 0.0, 0.0};
    uint32_t target = goal->samples ? goal->samples : UINT32_MAX;
    /* the budget counts from here: the photon pass is part of what it buys */
    double start = pm_now_seconds();
    if (goal->seconds > 0) pm_session_set_budget(s, start, goal->seconds);
    pm_session_run_result result = PM_RUN_DONE;
    while (s->film.samples < target && !atomic_load(&s->cancel)) {
        uint32_t limit = pm_session_plan_samples(s, target - s->film.samples);
        if (!limit) break;
        double iteration_start = pm_now_seconds();
        uint64_t mark = pm_memory_failure_mark();
        bool iterated = pm_session_iterate_once(s, limit);
        state.rendered += pm_now_seconds() - iteration_start;
        if (state.first_iteration == 0.0) state.first_iteration = pm_now_seconds() - start;
        state.samples = s->film.samples;
        state.photons = run_photons(s);
        state.elapsed = pm_now_seconds() - start;
        if (!iterated) {
            pm_session_fail(s, "out of memory (%s) in iteration %u", memory_failure_or(mark, "unknown"), s->film.samples + 1);
            result = PM_RUN_FAILED;
            break;
        }
        if (observer) observer(context, s, &state);
    }
    if (result == PM_RUN_DONE && atomic_load(&s->cancel)) result = PM_RUN_CANCELLED;
    state.samples = s->film.samples;
    state.photons = run_photons(s);
    state.elapsed = pm_now_seconds() - start;
    if (state_out) *state_out = state;
    return result;
}

bool pm_session_save_exr(pm_session *s, const char *path) {
    pm_session_begin(s);
    return pm_write_exr(path, &s->film, s->error, sizeof s->error);
}

void pm_session_restart(pm_session *s, const pm_camera *camera) {
    if (camera) s->camera = *camera;
    if (s->progressive) pm_progressive_restart(s->progressive, &s->film, &s->camera);
    else pm_film_clear(&s->film);
    s->render_seconds = 0.0;
    s->last_samples = 0;
}


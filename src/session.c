/* session.c: the render session: mode state and film, synchronous iterations planned to a time budget, and the worker thread that publishes double-buffered images. */
#include "session.h"
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

struct pm_session {
    const pm_scene *scene;
    const pm_accel *accel;
    pm_camera camera;
    pm_session_config config;
    pm_film film;
    pm_progressive *progressive;          /* progressive mode */
    pm_photon_maps maps;                  /* classic mode */
    bool maps_built;
    pm_photon_stats classic_photon_stats;
    pm_eye_stats eye_stats;
    pm_shadow_map *shadow;                /* both modes; NULL: shadow rays only */
    pm_shadow_stats shadow_stats;
    bool shadow_decided;                  /* built, or known to be unneeded */
    double render_seconds;                /* since the last restart */
    /* a time budget (pm_session_set_budget) and what the last iteration cost, to plan the next */
    double budget_start, budget_seconds;  /* seconds 0: no budget */
    uint32_t last_samples;                /* the samples the last iteration added */
    double last_wall;                     /* its wall time, photon pass included */
    char error[1024];                     /* the last top-level call's failure, "" when it succeeded */

    /* background rendering: everything below `lock` is shared with the worker */
    pthread_t worker;
    bool worker_running;
    pthread_mutex_t lock;
    pthread_cond_t wake;
    atomic_bool cancel;                   /* the running pass stops at its next task */
    atomic_bool halt;                     /* the worker is being stopped: even a preview stops at its next task */
    int preview_divisor;                  /* the next preview's pixels are this many film pixels across */
    double last_restart;                  /* when the worker took the last restart (0: none yet) */
    bool stop, paused, restart_pending, have_camera_change;
    bool held;                            /* pm_session_hold: previews only, no iteration */
    int indirect_change;                  /* -1 none */
    pm_camera pending_camera;
    float *front[PM_COMPONENT_COUNT], *back[PM_COMPONENT_COUNT];
    uint64_t version;
    pm_session_progress published;
    atomic_int view;                      /* pm_session_view: what publish() writes */
    /* a cluster's additive form (pm_session_keep_packed): published like the images, valid while
     * packed_epoch equals epoch (the restarts and resizes asked for) */
    double *packed_back;                  /* the worker's, packed outside the lock */
    size_t packed_back_capacity, packed_front_capacity;
    pm_session_packed packed;             /* the front: its values swapped in under the lock */
    bool keep_packed;
    uint64_t epoch, packed_epoch, worker_epoch;
};

/* A failure of the call under way: its message, kept until the next top-level call. */
static void fail(pm_session *s, const char *format, ...) {
    va_list args;
    va_start(args, format);
    vsnprintf(s->error, sizeof s->error, format, args);
    va_end(args);
}

/* The start of a top-level call: no earlier failure, handled or not, may name this one's. */
static void begin(pm_session *s) {
    s->error[0] = '\0';
    pm_memory_clear_failure();
}

/* The failure the call met since its mark (never another thread's, nor an older one), or `what`. */
static const char *memory_failure_or(uint64_t mark, const char *what) { return pm_memory_failure_since_or(mark, what); }

/* The mode state and film for config, from camera: nothing of the session's is touched, so a
 * caller whose build fails keeps what it had. */
static bool build_state(const pm_session *s, const pm_session_config *config, const pm_camera *camera,
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
static bool build_mode(pm_session *s, char *err, size_t err_size) {
    pm_progressive_destroy(s->progressive);
    s->progressive = NULL;
    pm_film_free(&s->film);
    return build_state(s, &s->config, &s->camera, &s->progressive, &s->film, err, err_size);
}

/* The front and back display buffers for a film: a component's pair where the film has it. */
static bool alloc_display(const pm_film *film, float *front[PM_COMPONENT_COUNT], float *back[PM_COMPONENT_COUNT], char *err,
                          size_t err_size) {
    size_t n = 3 * (size_t)film->width * film->height;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        if (!film->sum[c] || front[c]) continue;
        front[c] = pm_calloc(n, sizeof(float), "display buffers");
        back[c] = pm_calloc(n, sizeof(float), "display buffers");
        if (!front[c] || !back[c]) {
            snprintf(err, err_size, "out of memory (display buffers, %zu bytes)", 2 * PM_COMPONENT_COUNT * n * sizeof(float));
            return false;
        }
    }
    return true;
}

static void free_display(float *front[PM_COMPONENT_COUNT], float *back[PM_COMPONENT_COUNT]) {
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        free(front[c]);
        free(back[c]);
        front[c] = back[c] = NULL;
    }
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
    bool photons = (s->progressive && pm_progressive_uses_photons(s->progressive)) ||
                   (s->config.mode == PM_MODE_CLASSIC && s->config.classic_photon_pass);
    if (photons) bytes += (uint64_t)s->scene->emitter_count * PM_PHOTON_BYTES_PER_EMITTER; /* every placed emissive triangle */
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
    if (!build_mode(s, err, err_size)) { pm_session_destroy(s); return NULL; }
    return s;
}

void pm_session_destroy(pm_session *s) {
    if (!s) return;
    pm_session_stop(s);
    pm_progressive_destroy(s->progressive);
    pm_photon_maps_free(&s->maps);
    pm_shadow_map_free(s->shadow);
    pm_film_free(&s->film);
    free_display(s->front, s->back);
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
static bool iterate_once(pm_session *s, uint32_t max_samples) {
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
    begin(s);
    uint64_t mark = pm_memory_failure_mark();
    if (iterate_once(s, max_samples)) return true;
    fail(s, "out of memory (%s) in iteration %u", memory_failure_or(mark, "unknown"), s->film.samples + 1);
    return false;
}

pm_session_run_result pm_session_run(pm_session *s, const pm_session_goal *goal, pm_session_observer observer,
                                     void *context, pm_session_run_state *state_out) {
    begin(s);
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
        bool iterated = iterate_once(s, limit);
        state.rendered += pm_now_seconds() - iteration_start;
        if (state.first_iteration == 0.0) state.first_iteration = pm_now_seconds() - start;
        state.samples = s->film.samples;
        state.photons = run_photons(s);
        state.elapsed = pm_now_seconds() - start;
        if (!iterated) {
            fail(s, "out of memory (%s) in iteration %u", memory_failure_or(mark, "unknown"), s->film.samples + 1);
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
    begin(s);
    return pm_write_exr(path, &s->film, s->error, sizeof s->error);
}

void pm_session_restart(pm_session *s, const pm_camera *camera) {
    if (camera) s->camera = *camera;
    if (s->progressive) pm_progressive_restart(s->progressive, &s->film, &s->camera);
    else pm_film_clear(&s->film);
    s->render_seconds = 0.0;
    s->last_samples = 0;
}

/* ---- background rendering ---- */

static uint64_t photons_emitted(const pm_session *s) {
    if (s->progressive) return pm_progressive_get_stats(s->progressive)->photons.emitted;
    return s->maps_built ? s->classic_photon_stats.emitted : 0;
}

/* Blue (low) through green to red (high) for t in [0, 1]. */
static void heat_colour(double t, float *rgb) {
    t = t < 0 ? 0 : (t > 1 ? 1 : t);
    rgb[0] = (float)(t < 0.5 ? 0.0 : 2.0 * t - 1.0);
    rgb[1] = (float)(t < 0.5 ? 2.0 * t : 2.0 - 2.0 * t);
    rgb[2] = (float)(t < 0.5 ? 1.0 - 2.0 * t : 0.0);
}

/* The diagnostic views of the progressive statistics, false colour in the direct layer: each
 * pixel's photon density N / (pi R^2) or its radius R, on a log scale over the image's range. */
static void diagnostic_view(const pm_session *s, int view, float *out) {
    size_t pixels = (size_t)s->config.width * s->config.height;
    double lo = INFINITY, hi = -INFINITY;
    uint64_t mark = pm_memory_failure_mark();
    double *value = pm_malloc(pixels * sizeof *value, "density view");
    if (!value) {
        /* the view is a diagnostic: black, with the reason, rather than a stale picture */
        fprintf(stderr, "pmview: error: out of memory (%s) for the density view\n", memory_failure_or(mark, "density view"));
        memset(out, 0, 3 * pixels * sizeof(float));
        return;
    }
    for (size_t i = 0; i < pixels; i++) {
        double n = 0, r2 = 0;
        int slots = 0;
        for (int k = 0; k < PM_SLOT_COUNT; k++) {
            if (!s->film.ppm[k] || !(s->film.ppm[k][i].r2 > 0)) continue;
            n += s->film.ppm[k][i].n;
            r2 += s->film.ppm[k][i].r2;
            slots++;
        }
        value[i] = NAN;
        if (!slots) continue;
        r2 /= slots;
        double v = view == PM_VIEW_RADIUS ? sqrt(r2) : n / (PM_PI * r2);
        if (!(v > 0)) continue;
        value[i] = log(v);
        lo = fmin(lo, value[i]);
        hi = fmax(hi, value[i]);
    }
    for (size_t i = 0; i < pixels; i++) {
        if (isnan(value[i])) { out[3 * i] = out[3 * i + 1] = out[3 * i + 2] = 0.f; continue; }
        heat_colour(hi > lo ? (value[i] - lo) / (hi - lo) : 0.5, out + 3 * i);
    }
    free(value);
}

/* The film's additive form into the back buffer (grown when a rebuilt mode added statistics
 * slots), swapped in under the lock with what it was packed from. */
static void publish_packed(pm_session *s) {
    const pm_film *f = &s->film;
    size_t count = pm_film_packed_count(f);
    if (count > s->packed_back_capacity) {
        uint64_t mark = pm_memory_failure_mark();
        double *grown = pm_malloc(count * sizeof(double), "the cluster's packed film");
        if (!grown) {
            fprintf(stderr, "pmview: error: out of memory (%s) packing the image for the other ranks\n",
                    memory_failure_or(mark, "the cluster's packed film"));
            return;
        }
        free(s->packed_back);
        s->packed_back = grown;
        s->packed_back_capacity = count;
    }
    pm_film_pack(f, s->packed_back);
    pthread_mutex_lock(&s->lock);
    double *front = (double *)s->packed.values;
    size_t front_capacity = s->packed_front_capacity;
    s->packed.values = s->packed_back;
    s->packed_front_capacity = s->packed_back_capacity;
    s->packed_back = front;
    s->packed_back_capacity = front_capacity;
    s->packed.count = count;
    s->packed.width = f->width;
    s->packed.height = f->height;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) s->packed.components[c] = f->sum[c] != NULL;
    for (int k = 0; k < PM_SLOT_COUNT; k++) s->packed.slots[k] = f->ppm[k] != NULL;
    s->packed.photons = photons_emitted(s);
    s->packed_epoch = s->worker_epoch;
    pthread_mutex_unlock(&s->lock);
}

/* Resolves into the back buffers, then swaps them in under the lock. At 8192 x 8192 that is
 * seconds of work (3 GB written): a cancel abandons it between components and row blocks, and
 * nothing is published. */
static void publish(pm_session *s, const pm_film *film, bool preview) {
    size_t n = 3 * (size_t)s->config.width * s->config.height;
    /* a preview is of a camera asked for: a newer one does not abandon it (under a moving camera
     * every preview would be), only a stop does */
    atomic_bool *abandon = preview ? &s->halt : &s->cancel;
    if (atomic_load(abandon)) return;
    int view = atomic_load(&s->view);
    if (view != PM_VIEW_SHADED && !preview && s->progressive && s->back[PM_DIRECT]) {
        for (int c = 0; c < PM_COMPONENT_COUNT; c++)
            if (s->back[c]) memset(s->back[c], 0, n * sizeof(float));
        diagnostic_view(s, view, s->back[PM_DIRECT]);
        film = NULL;
    }
    for (int c = 0; c < PM_COMPONENT_COUNT && film; c++) {
        if (atomic_load(abandon)) return;
        if (!s->back[c]) continue;
        if (!film->sum[c]) { memset(s->back[c], 0, n * sizeof(float)); continue; }
        if (film->width == s->config.width && film->height == s->config.height) {
            pm_film_resolve(film, (pm_component)c, s->back[c]);
            continue;
        }
        /* the coarse preview, each of its pixels spread over the block it covers */
        size_t small = 3 * (size_t)film->width * film->height;
        uint64_t mark = pm_memory_failure_mark();
        float *tmp = pm_malloc(small * sizeof(float), "preview");
        if (!tmp) {
            fprintf(stderr, "pmview: error: out of memory (%s) for the preview\n", memory_failure_or(mark, "preview"));
            return;
        }
        pm_film_resolve(film, (pm_component)c, tmp);
        for (int y = 0; y < s->config.height; y++) {
            if ((y & 63) == 0 && atomic_load(abandon)) { free(tmp); return; }
            int sy = y * film->height / s->config.height;
            for (int x = 0; x < s->config.width; x++) {
                int sx = x * film->width / s->config.width;
                memcpy(s->back[c] + 3 * ((size_t)y * s->config.width + x), tmp + 3 * ((size_t)sy * film->width + sx),
                       3 * sizeof(float));
            }
        }
        free(tmp);
    }
    pm_radius_summary r = {0, 0, 0, 0, 0, 0};
    if (s->progressive && !preview && !atomic_load(&s->cancel)) r = pm_progressive_radii(s->progressive, &s->film);
    if (atomic_load(abandon)) return;
    pthread_mutex_lock(&s->lock);
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        float *t = s->front[c];
        s->front[c] = s->back[c];
        s->back[c] = t;
    }
    s->version++;
    s->published.iterations = preview ? 0 : s->film.samples;
    s->published.photons = preview ? 0 : photons_emitted(s);
    s->published.seconds = s->render_seconds;
    s->published.mean_radius = r.pixels ? r.mean : r.gather; /* a scene read by gathering alone has no pixel radii */
    s->published.preview = preview;
    s->published.preview_divisor = preview ? s->config.width / film->width : 0;
    pthread_mutex_unlock(&s->lock);
    if (preview || !s->keep_packed || atomic_load(&s->cancel)) return;
    publish_packed(s);
}

/* A coarse direct-light image (each of its pixels preview_divisor film pixels across): a picture
 * within milliseconds of a restart. A newer camera does not cut it short, a stop does. The
 * divisor follows the measured cost: past PM_PREVIEW_BUDGET_SECONDS the next preview is coarser
 * (cost goes as 1 / divisor^2), and it comes back finer once the finer one would fit again: a
 * camera in motion on a big scene gets coarser pixels, never a frozen image. */
static bool preview(pm_session *s) {
    int divisor = s->preview_divisor;
    while (divisor > PM_PREVIEW_DIVISOR && (s->config.width / divisor < 8 || s->config.height / divisor < 8)) divisor /= 2;
    int w = s->config.width / divisor, h = s->config.height / divisor;
    if (w < 8 || h < 8) return false;
    double start = pm_now_seconds();
    bool components[PM_COMPONENT_COUNT] = {s->film.sum[PM_DIRECT] != NULL, s->film.sum[PM_SPECULAR] != NULL, false, false};
    pm_film small;
    if (!pm_film_init(&small, w, h, components)) return false;
    pm_eye_settings eye;
    memset(&eye, 0, sizeof eye);
    eye.seed = s->config.progressive.seed ^ 0x9e37u;
    eye.threads = s->config.mode == PM_MODE_PROGRESSIVE ? s->config.progressive.threads : s->config.eye.threads;
    eye.max_specular_depth = 8;
    pm_parallel_set_cancel(&s->halt);
    pm_eye_iterate(s->scene, s->accel, &s->camera, &eye, 0, &small, NULL);
    pm_parallel_set_cancel(&s->cancel);
    if (!atomic_load(&s->halt)) publish(s, &small, true);
    pm_film_free(&small);
    double seconds = pm_now_seconds() - start;
    if (seconds > PM_PREVIEW_BUDGET_SECONDS && divisor < PM_PREVIEW_MAX_DIVISOR) s->preview_divisor = 2 * divisor;
    else if (divisor > PM_PREVIEW_DIVISOR && 4.0 * seconds < 0.5 * PM_PREVIEW_BUDGET_SECONDS) s->preview_divisor = divisor / 2;
    return true;
}

static void *worker_main(void *arg) {
    pm_session *s = arg;
    pm_parallel_set_cancel(&s->cancel);
    bool need_preview = true, need_clear = false, moving = false;
    double restart_interval = 0;          /* between the last two restarts, while moving */
    pthread_mutex_lock(&s->lock);
    for (;;) {
        if (s->stop) break;
        if (s->restart_pending) {
            /* restarts closer than PM_WINDOW_MOTION_GAP are a camera in motion */
            double now = pm_now_seconds();
            moving = s->last_restart > 0 && now - s->last_restart < PM_WINDOW_MOTION_GAP;
            restart_interval = now - s->last_restart;
            s->last_restart = now;
            s->restart_pending = false;
            bool camera = s->have_camera_change;
            pm_camera cam = s->pending_camera;
            int indirect = s->indirect_change;
            s->have_camera_change = false;
            s->indirect_change = -1;
            s->worker_epoch = s->epoch;
            atomic_store(&s->cancel, false);
            pthread_mutex_unlock(&s->lock);
            if (camera) s->camera = cam;
            if (indirect >= 0 && s->config.mode == PM_MODE_PROGRESSIVE && (int)s->config.progressive.indirect != indirect) {
                char err[256];
                s->config.progressive.indirect = (pm_indirect_mode)indirect;
                if (!build_mode(s, err, sizeof err)) {
                    fprintf(stderr, "pmview: error: %s\n", err);
                    pthread_mutex_lock(&s->lock);
                    s->published.finished = true;
                    break;
                }
            }
            /* the film is cleared once the camera rests: a moving camera's restarts show previews only */
            need_clear = true;
            need_preview = true;
            pthread_mutex_lock(&s->lock);
            continue;
        }
        /* a film still to be cleared holds the old camera's samples: not done */
        bool done = !need_clear && s->config.max_iterations && s->film.samples >= s->config.max_iterations;
        s->published.finished = done;
        s->published.paused = s->paused;
        if (s->paused || done || (s->held && !need_preview)) {
            pthread_cond_wait(&s->wake, &s->lock);
            continue;
        }
        pthread_mutex_unlock(&s->lock);
        if (need_preview) {
            bool shown = preview(s);
            need_preview = false;
            /* a restart asked for meanwhile goes first: another preview, not a full iteration. A
             * moving camera's next position is likely on its way: it is waited for a little
             * before a full iteration, which it would cancel at a cost (a photon chunk, an eye
             * tile, the film's tiles put back): twice the time between its last two, at most
             * PM_PREVIEW_SETTLE_SECONDS */
            pthread_mutex_lock(&s->lock);
            double settle = fmin(PM_PREVIEW_SETTLE_SECONDS, 2.0 * restart_interval);
            double wait = s->last_restart + settle - pm_now_seconds();
            if (shown && moving && wait > 0 && !s->restart_pending && !s->stop) {
                struct timespec until;
                clock_gettime(CLOCK_REALTIME, &until);
                long ns = until.tv_nsec + (long)(wait * 1e9);
                until.tv_sec += ns / 1000000000L;
                until.tv_nsec = ns % 1000000000L;
                pthread_cond_timedwait(&s->wake, &s->lock, &until);
            }
            continue;
        }
        if (need_clear) {
            pm_session_restart(s, NULL);
            need_clear = false;
        }
        uint32_t left = s->config.max_iterations ? s->config.max_iterations - s->film.samples : 0;
        uint64_t mark = pm_memory_failure_mark();
        bool ok = atomic_load(&s->cancel) ? true : iterate_once(s, left);
        if (!ok)
            fprintf(stderr, "pmview: error: out of memory (%s) in an iteration; rendering stops\n",
                    memory_failure_or(mark, "unknown"));
        bool cut_short = atomic_load(&s->cancel);
        if (ok && !cut_short) publish(s, &s->film, false);
        pthread_mutex_lock(&s->lock);
        if (!ok) { s->published.finished = true; s->paused = true; }
        /* an iteration cut short is discarded by the restart that cut it */
    }
    pthread_mutex_unlock(&s->lock);
    /* a film left uncleared holds no image of the camera the session has */
    if (need_clear) pm_session_restart(s, NULL);
    return NULL;
}

bool pm_session_start(pm_session *s, char *err, size_t err_size) {
    begin(s);
    if (s->worker_running) return true;
    if (!alloc_display(&s->film, s->front, s->back, s->error, sizeof s->error)) {
        if (err != s->error) snprintf(err, err_size, "%s", s->error);
        return false;
    }
    s->stop = false;
    s->worker_epoch = s->epoch;
    atomic_store(&s->cancel, false);
    if (pthread_create(&s->worker, NULL, worker_main, s) != 0) {
        fail(s, "cannot start the render thread");
        if (err != s->error) snprintf(err, err_size, "%s", s->error);
        return false;
    }
    s->worker_running = true;
    return true;
}

bool pm_session_resize(pm_session *s, int width, int height, const pm_camera *camera) {
    begin(s);
    bool running = s->worker_running;
    pm_session_stop(s);
    if (camera) s->camera = *camera;
    pm_session_config config = s->config;
    config.width = width;
    config.height = height;
    pm_progressive *progressive;
    pm_film film;
    float *front[PM_COMPONENT_COUNT] = {NULL, NULL, NULL, NULL}, *back[PM_COMPONENT_COUNT] = {NULL, NULL, NULL, NULL};
    bool built = build_state(s, &config, &s->camera, &progressive, &film, s->error, sizeof s->error);
    if (built && running && !alloc_display(&film, front, back, s->error, sizeof s->error)) {
        built = false;
        free_display(front, back);
        pm_progressive_destroy(progressive);
        pm_film_free(&film);
    }
    s->epoch++;
    if (built) {
        pm_progressive_destroy(s->progressive);
        pm_film_free(&s->film);
        free_display(s->front, s->back);
        s->progressive = progressive;
        s->film = film;
        memcpy(s->front, front, sizeof front);
        memcpy(s->back, back, sizeof back);
        s->config = config;
        s->render_seconds = 0.0;
        s->last_samples = 0;
        memset(&s->published, 0, sizeof s->published);
        s->published.paused = s->paused;
    }
    /* the running pass was cancelled by the stop: the worker goes on, at the new size or the old */
    char error[sizeof s->error];
    snprintf(error, sizeof error, "%s", s->error);
    if (running && !pm_session_start(s, s->error, sizeof s->error)) return false;
    snprintf(s->error, sizeof s->error, "%s", error);
    return built;
}

void pm_session_hold(pm_session *s, bool held) {
    pthread_mutex_lock(&s->lock);
    s->held = held;
    pthread_cond_signal(&s->wake);
    pthread_mutex_unlock(&s->lock);
}

void pm_session_pause(pm_session *s, bool paused) {
    pthread_mutex_lock(&s->lock);
    s->paused = paused;
    s->published.paused = paused;
    pthread_cond_signal(&s->wake);
    pthread_mutex_unlock(&s->lock);
}


bool pm_session_set_view(pm_session *s, pm_session_view view) {
    if (view != PM_VIEW_SHADED && !s->progressive) return false;
    atomic_store(&s->view, (int)view);
    return true;
}

void pm_session_request_restart(pm_session *s, const pm_camera *camera, int indirect) {
    pthread_mutex_lock(&s->lock);
    if (camera) {
        s->pending_camera = *camera;
        s->have_camera_change = true;
    }
    if (indirect >= 0) s->indirect_change = indirect;
    s->restart_pending = true;
    s->epoch++;
    atomic_store(&s->cancel, true);
    pthread_cond_signal(&s->wake);
    pthread_mutex_unlock(&s->lock);
}

const float *const *pm_session_lock_latest(pm_session *s, uint64_t *version, pm_session_progress *progress) {
    pthread_mutex_lock(&s->lock);
    if (progress) *progress = s->published;
    if (s->version == *version) {
        pthread_mutex_unlock(&s->lock);
        return NULL;
    }
    *version = s->version;
    return (const float *const *)s->front;
}

void pm_session_unlock_latest(pm_session *s) { pthread_mutex_unlock(&s->lock); }

uint64_t pm_session_photons(const pm_session *s) { return photons_emitted(s); }

bool pm_session_keep_packed(pm_session *s, bool on) {
    begin(s);
    bool running = s->worker_running;
    pm_session_stop(s);
    free((double *)s->packed.values);
    free(s->packed_back);
    memset(&s->packed, 0, sizeof s->packed);
    s->packed_back = NULL;
    s->packed_back_capacity = s->packed_front_capacity = 0;
    s->packed_epoch = UINT64_MAX;
    s->keep_packed = on;
    bool ok = true;
    if (on) {
        /* the usual size up front, so that running out of memory is this call's error */
        size_t count = pm_film_packed_count(&s->film);
        uint64_t mark = pm_memory_failure_mark();
        s->packed_back = pm_malloc(count * sizeof(double), "the cluster's packed film");
        double *front = s->packed_back ? pm_malloc(count * sizeof(double), "the cluster's packed film") : NULL;
        if (!front) {
            fail(s, "out of memory (%s)", memory_failure_or(mark, "the cluster's packed film"));
            free(s->packed_back);
            s->packed_back = NULL;
            s->keep_packed = false;
            ok = false;
        } else {
            s->packed.values = front;
            s->packed_back_capacity = s->packed_front_capacity = count;
        }
    }
    if (running && !pm_session_start(s, s->error, sizeof s->error)) return false;
    return ok;
}

bool pm_session_lock_packed(pm_session *s, pm_session_packed *out) {
    pthread_mutex_lock(&s->lock);
    if (!s->keep_packed || s->packed_epoch != s->epoch) {
        pthread_mutex_unlock(&s->lock);
        return false;
    }
    *out = s->packed;
    return true;
}

void pm_session_stop(pm_session *s) {
    if (!s->worker_running) return;
    pthread_mutex_lock(&s->lock);
    s->stop = true;
    atomic_store(&s->cancel, true);
    atomic_store(&s->halt, true);
    pthread_cond_signal(&s->wake);
    pthread_mutex_unlock(&s->lock);
    pthread_join(s->worker, NULL);
    s->worker_running = false;
    atomic_store(&s->cancel, false);
    atomic_store(&s->halt, false);
}

/* session_worker.c: the session's background rendering: the worker thread, double-buffered publishing, previews, diagnostic views and the packed form a cluster merges. */
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

void pm_session_free_display(float *front[PM_COMPONENT_COUNT], float *back[PM_COMPONENT_COUNT]) {
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        free(front[c]);
        free(back[c]);
        front[c] = back[c] = NULL;
    }
}


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
        fprintf(stderr, "pmview: error: out of memory (%s) for the density view\n", pm_memory_failure_since_or(mark, "density view"));
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
                    pm_memory_failure_since_or(mark, "the cluster's packed film"));
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
            fprintf(stderr, "pmview: error: out of memory (%s) for the preview\n", pm_memory_failure_since_or(mark, "preview"));
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
                if (!pm_session_build_mode(s, err, sizeof err)) {
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
        bool ok = atomic_load(&s->cancel) ? true : pm_session_iterate_once(s, left);
        if (!ok)
            fprintf(stderr, "pmview: error: out of memory (%s) in an iteration; rendering stops\n",
                    pm_memory_failure_since_or(mark, "unknown"));
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
    pm_session_begin(s);
    if (s->worker_running) return true;
    if (!alloc_display(&s->film, s->front, s->back, s->error, sizeof s->error)) {
        if (err != s->error) snprintf(err, err_size, "%s", s->error);
        return false;
    }
    s->stop = false;
    s->worker_epoch = s->epoch;
    atomic_store(&s->cancel, false);
    if (pthread_create(&s->worker, NULL, worker_main, s) != 0) {
        pm_session_fail(s, "cannot start the render thread");
        if (err != s->error) snprintf(err, err_size, "%s", s->error);
        return false;
    }
    s->worker_running = true;
    return true;
}

bool pm_session_resize(pm_session *s, int width, int height, const pm_camera *camera) {
    pm_session_begin(s);
    bool running = s->worker_running;
    pm_session_stop(s);
    if (camera) s->camera = *camera;
    pm_session_config config = s->config;
    config.width = width;
    config.height = height;
    pm_progressive *progressive;
    pm_film film;
    float *front[PM_COMPONENT_COUNT] = {NULL, NULL, NULL, NULL}, *back[PM_COMPONENT_COUNT] = {NULL, NULL, NULL, NULL};
    bool built = pm_session_build_state(s, &config, &s->camera, &progressive, &film, s->error, sizeof s->error);
    if (built && running && !alloc_display(&film, front, back, s->error, sizeof s->error)) {
        built = false;
        pm_session_free_display(front, back);
        pm_progressive_destroy(progressive);
        pm_film_free(&film);
    }
    s->epoch++;
    if (built) {
        pm_progressive_destroy(s->progressive);
        pm_film_free(&s->film);
        pm_session_free_display(s->front, s->back);
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
    pm_session_begin(s);
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
            pm_session_fail(s, "out of memory (%s)", pm_memory_failure_since_or(mark, "the cluster's packed film"));
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

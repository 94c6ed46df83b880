/* session.h: one render session (scene, accel, camera, mode state, film) that the window, the snapshot path and the tests all drive.
 *
 * Synchronous use (snapshots, tests, the bench): pm_session_run() to a goal (samples, a time
 * budget, a cancel) with an observer called after each iteration, or pm_session_iterate() one
 * iteration at a time, on the calling thread; then read the film or pm_session_save_exr(). Background use (the window): pm_session_start() runs iterations on a worker thread;
 * after each one the worker resolves the film's components into a back buffer and swaps it with
 * the front one under a lock, so the thread that owns the window only ever reads a complete
 * image (pm_session_lock_latest / pm_session_unlock_latest) and never waits for a pass.
 * A restart (camera moved, settings changed) cancels the running pass at its next task, clears
 * per-pixel state and shows a coarse direct-light preview within milliseconds, then refines.
 */
#ifndef PM_SESSION_H
#define PM_SESSION_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "accel.h"
#include "eye.h"
#include "film.h"
#include "photonmap.h"
#include "progressive.h"
#include "scene.h"
#include "shadowmap.h"

typedef enum { PM_MODE_PROGRESSIVE = 0, PM_MODE_CLASSIC = 1, PM_MODE_PATHTRACE = 2 } pm_mode;

/* A photon count the session chooses (classic mode): pixels x PM_DEFAULT_PHOTONS_PER_PIXEL, or with a
 * time budget what a pilot pass measures fits PM_TIME_SHARE_PHOTONS of it; clamped to
 * PM_MIN_DEFAULT_PHOTONS .. PM_MAX_DEFAULT_PHOTONS. */
#define PM_PHOTONS_AUTO UINT64_MAX

typedef struct {
    pm_mode mode;
    int width, height;
    pm_progressive_settings progressive;   /* progressive mode */
    pm_photon_settings classic_photons;    /* classic mode: the maps, built before the first iteration (counts may be PM_PHOTONS_AUTO) */
    pm_eye_settings eye;                   /* the eye pass of the classic and path-tracing modes: its maps pointer is the
                                              session's, path_trace is set by the session from the mode */
    bool classic_photon_pass;              /* classic mode: build maps at all */
    uint32_t max_iterations;               /* background rendering stops there (0 = never) */
    double time_budget;                    /* seconds a run is given (0 = none): sizes the classic mode's automatic photon counts */
    pm_shadow_settings shadow;             /* shadow photons, every mode: built before the first iteration */
} pm_session_config;

/* The defaults every driver starts from (pmview's options, the tests, the bench): the mode, the
 * image size, the seed and threads (clamped by pm_thread_count) everywhere; the progressive
 * mode's photons per iteration (pm_progressive_default_photons), radius reduction and final
 * gathering; the depth and bounce caps; shadow photons where they pay. The classic mode's
 * estimates (k, radii from the scene's size) are the caller's; its photon counts are
 * PM_PHOTONS_AUTO and its photon pass on. */
void pm_session_config_defaults(pm_session_config *config, pm_mode mode, int width, int height, uint64_t seed, int threads);
/* The progressive part of those defaults alone. */
pm_progressive_settings pm_session_progressive_defaults(int width, int height, uint64_t seed, int threads);

typedef struct {
    uint32_t iterations;       /* in the published image (0: a preview) */
    uint64_t photons;          /* emitted since the last restart */
    double seconds;            /* rendering time since the last restart */
    double mean_radius;        /* progressive: mean radius of the pixels' statistics, or the final-gather radius where no
                                  pixel keeps statistics (0 in the other modes) */
    bool preview;              /* the published image is the coarse preview */
    int preview_divisor;       /* its pixels are this many image pixels across (0: not a preview) */
    bool paused, finished;
} pm_session_progress;

typedef struct pm_session pm_session;

/* NULL with err set when out of memory. The scene and accel must outlive the session. In the
 * classic mode with PM_PHOTONS_AUTO counts and a time budget, a pilot photon pass runs here. */
pm_session *pm_session_create(const pm_scene *s, const pm_accel *a, const pm_camera *camera,
                              const pm_session_config *config, char *err, size_t err_size);
/* The memory forecast's share of the render (memory.h): the film, the photon records an
 * iteration keeps alive (progressive) or the classic maps, the shadow photons, the threads. */
uint64_t pm_session_forecast_bytes(const pm_session *s);
/* Stops the worker, if any, and frees everything the session owns. */
void pm_session_destroy(pm_session *s);

/* One iteration on the calling thread (synchronous use only), adding at most max_samples samples
 * per pixel (0: no limit; a progressive iteration may add several, see pm_progressive_iterate).
 * False when out of memory. The deadline (pm_session_set_deadline) or pm_session_cancel may cut
 * it short, between photon chunks or eye tiles: the film then holds what was finished, marked
 * ragged where an eye pass reached only some pixels (film.h), and that ends the run: the next
 * iteration starts the film again (pm_session_restart). */
bool pm_session_iterate(pm_session *s, uint32_t max_samples);
/* Cuts the running iteration short at its next photon chunk or eye tile, and every later one:
 * the flag stays set until pm_session_start or the worker's next restart clears it. Only stores
 * an atomic flag: safe in a signal handler (SIGINT during a snapshot). */
void pm_session_cancel(pm_session *s);
const pm_film *pm_session_film(const pm_session *s);
pm_progressive *pm_session_progressive(pm_session *s);               /* NULL in the classic mode */
const pm_photon_maps *pm_session_classic_maps(const pm_session *s);  /* NULL in the progressive mode */
const pm_photon_stats *pm_session_classic_photon_stats(const pm_session *s);
const pm_eye_stats *pm_session_eye_stats(const pm_session *s); /* classic and path-tracing modes */
/* The shadow photons: whether there are any, why not, and what they cost (zeros before the first iteration). */
const pm_shadow_stats *pm_session_shadow_stats(const pm_session *s);
/* A time budget's end (CLOCK_MONOTONIC seconds): the shadow photons, when they are still to be
 * built, may take PM_SHADOW_TIME_SHARE of the time left, the progressive mode's photon passes
 * are cut to fit (pm_progressive_set_deadline), and an eye pass running past it stops at its
 * tile under way, unless it is the film's first (eye.h). */
void pm_session_set_deadline(pm_session *s, double deadline);
/* A time budget (--time): `seconds` (> 0) from `start` (CLOCK_MONOTONIC). Sets the deadline
 * above and lets pm_session_plan_samples share the time out between iterations. */
void pm_session_set_budget(pm_session *s, double start, double seconds);
/* The samples the next pm_session_iterate should add, at most `wanted`. Without a budget,
 * `wanted`. With one: 1 for the first iteration (its cost is unknown); then as many as fit in the
 * time left at the last iteration's wall time a sample (the deadline cuts the last one short);
 * 0 (stop) when too little time is left for an iteration to add anything. It predicts from the time
 * spent inside pm_session_iterate: a caller's own work between iterations (a log row) is not
 * foreseen, only paid from the budget. 0 once a pass was cut short (the run is over). */
uint32_t pm_session_plan_samples(const pm_session *s, uint32_t wanted);
/* Clears the accumulation, optionally with a new camera (synchronous use). */
void pm_session_restart(pm_session *s, const pm_camera *camera);

/* ---- errors ----
 * The message of the last top-level call that failed (create, iterate, run, resize, start,
 * save), "" when it succeeded. Each of those calls clears it, and memory.c's recorded failure
 * (pm_memory_failure), at its start: a message names the failure of the call that returns it,
 * never an earlier one that was handled. */
const char *pm_session_error(const pm_session *s);

/* ---- a run to a stop condition (synchronous use) ---- */
typedef struct {
    uint32_t samples;          /* stop once the film holds this many samples per pixel (0: the budget alone) */
    double seconds;            /* a time budget from the run's start, photon passes included (0: none) */
} pm_session_goal;

typedef struct {
    uint32_t samples;          /* in the film */
    uint64_t photons;          /* emitted since the last restart */
    double elapsed;            /* wall seconds since the run started */
    double rendered;           /* seconds spent inside iterations (an observer's own work left out) */
    double first_iteration;    /* wall seconds from the start to the end of the first iteration (0 before it) */
} pm_session_run_state;

/* Called after every iteration of a run, on the run's thread (a progress bar, a log row, an error
 * curve); the session is between iterations and may be read. */
typedef void (*pm_session_observer)(void *context, pm_session *s, const pm_session_run_state *state);

typedef enum { PM_RUN_DONE = 0, PM_RUN_CANCELLED = 1, PM_RUN_FAILED = 2 } pm_session_run_result;

/* Iterates until the goal's samples, its time budget (shared out by pm_session_plan_samples, the
 * deadline cutting the last pass short), or pm_session_cancel (a signal). A budget spent before
 * the first iteration still gets that iteration. FAILED with pm_session_error set ("out of memory
 * (...) in iteration N"); the film then holds the iterations before. state (may be NULL) is the
 * run's at its end. */
pm_session_run_result pm_session_run(pm_session *s, const pm_session_goal *goal, pm_session_observer observer,
                                     void *context, pm_session_run_state *state);

/* Writes the film's layers as a multi-layer EXR (image_io.h); false with pm_session_error set. */
bool pm_session_save_exr(pm_session *s, const char *path);

/* A new image size, with the camera (NULL: the same): a new film and mode state at that size; the
 * shadow photons and the classic mode's maps are kept (they do not depend on it). A running
 * worker is stopped and started again on the new film (a preview first). When the new size's
 * buffers cannot be had, the session keeps its size and film, goes on as before, and returns false
 * with pm_session_error set. */
bool pm_session_resize(pm_session *s, int width, int height, const pm_camera *camera);

/* ---- background rendering ---- */
/* Starts the worker; false with err (and pm_session_error) set. */
bool pm_session_start(pm_session *s, char *err, size_t err_size);
void pm_session_pause(pm_session *s, bool paused);
/* Held, the worker renders its previews (the first, and one after each restart) but no iteration
 * until released: a window's first scene publishes its coarse image while the window opens, and
 * the photon and eye passes wait for the window instead of taking its cores meanwhile. */
void pm_session_hold(pm_session *s, bool held);
/* Takes effect at once: the running pass stops at its next task. camera may be NULL (same camera).
 * indirect: -1 keeps the setting, else the new pm_indirect_mode (the G key). */
void pm_session_request_restart(pm_session *s, const pm_camera *camera, int indirect);
/* The newest complete image: w*h*3 floats per component (NULL for a component the session does
 * not have). Returns NULL, without locking, when nothing newer than *version was published; else
 * the caller must call pm_session_unlock_latest() once it has read the layers. */
const float *const *pm_session_lock_latest(pm_session *s, uint64_t *version, pm_session_progress *progress);
void pm_session_unlock_latest(pm_session *s);
/* What the published images show: the shaded components, or (progressive mode) a false-colour
 * map of each pixel's photon density N / (pi R^2) or of its radius R, log scale, in the direct
 * layer. Takes effect with the next published image; false when the mode has no statistics. */
typedef enum { PM_VIEW_SHADED = 0, PM_VIEW_DENSITY = 1, PM_VIEW_RADIUS = 2, PM_VIEW_COUNT = 3 } pm_session_view;
bool pm_session_set_view(pm_session *s, pm_session_view view);
/* Photons emitted since the last restart (the classic mode's maps once built). */
uint64_t pm_session_photons(const pm_session *s);
/* For a cluster (cluster.h): with `on`, the worker also publishes the film's additive form
 * (pm_film_pack) after each iteration it publishes. False when out of memory. */
bool pm_session_keep_packed(pm_session *s, bool on);
/* A published additive form and what it was packed from: the film's size and layout, which a
 * restart that rebuilds the mode (the G key) may change. */
typedef struct {
    const double *values;      /* `count` doubles */
    size_t count;
    int width, height;
    bool components[PM_COMPONENT_COUNT], slots[PM_SLOT_COUNT];
    uint64_t photons;          /* emitted when it was packed */
} pm_session_packed;
/* The newest form published since the last restart or resize was asked for: true with *out set
 * and the lock held (pm_session_unlock_latest() once read), or false, without locking, when the
 * worker has published none since. Reads nothing the worker writes outside the lock. */
bool pm_session_lock_packed(pm_session *s, pm_session_packed *out);
/* Stops the worker (the running pass is cancelled) and waits for it. */
void pm_session_stop(pm_session *s);

#endif

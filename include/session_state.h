/* session_state.h: the render session's state, shared by its synchronous runs (session.c) and its worker thread (session_worker.c); nothing else includes it. */
#ifndef PM_SESSION_STATE_H
#define PM_SESSION_STATE_H

#include <pthread.h>
#include <stdatomic.h>

#include "session.h"

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
void pm_session_fail(pm_session *s, const char *format, ...);
/* The start of a top-level call: no earlier failure, handled or not, may name this one's. */
void pm_session_begin(pm_session *s);
/* The mode state and film for config, from camera: nothing of the session's is touched, so a
 * caller whose build fails keeps what it had. */
bool pm_session_build_state(const pm_session *s, const pm_session_config *config, const pm_camera *camera,
                            pm_progressive **progressive, pm_film *film, char *err, size_t err_size);
/* (Re)creates the mode state and the film for the current configuration. */
bool pm_session_build_mode(pm_session *s, char *err, size_t err_size);
/* One iteration; false when it failed without a cancel (out of memory), the reason in memory.c's record. */
bool pm_session_iterate_once(pm_session *s, uint32_t max_samples);
/* Frees the display buffers (session_worker.c). */
void pm_session_free_display(float *front[PM_COMPONENT_COUNT], float *back[PM_COMPONENT_COUNT]);

#endif

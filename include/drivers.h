/* drivers.h: the two ways pmview renders, above the session and the view: a snapshot written to a file (src/snapshot.c) and the window (src/window_app.c). */
#ifndef PM_DRIVERS_H
#define PM_DRIVERS_H

#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "accel.h"
#include "cluster.h"
#include "options.h"
#include "runlog.h"
#include "scene.h"
#include "session.h"
#include "view.h"

/* ---- snapshots (src/snapshot.c) ---- */
/* From here a SIGINT or SIGTERM is the snapshot's: the session's passes stop at their next task,
 * the image so far is written and pmview exits 130 or 143. */
void pm_snapshot_catch_signals(pm_session *session);
/* Everything writing the snapshot takes beside the film, admitted before the render so that a run
 * whose file could not be written is refused at once. */
uint64_t pm_snapshot_output_bytes(const char *path, const pm_film *film);
/* Renders to --iterations or --time with the progress bar, --log rows, the --reference curve and
 * --checkpoint writes as the run's observer, then writes the file (the room `reserved` for it is
 * given back first). Under mpirun (cluster not NULL) every rank calls it: each renders its share,
 * rank 0 reads and writes the merged image. Returns the exit code: 0, 1 (an error line printed),
 * 130 or 143 (interrupted: the image so far). */
int pm_snapshot_run(const pm_options *o, pm_cluster *cluster, pm_session *session, const pm_reference_image *reference,
                    uint64_t *reserved);

/* ---- what both show (src/snapshot.c) ---- */
/* The display settings the options ask for at first: components and exposure. */
void pm_display_from_options(const pm_options *o, pm_display *display);
/* A PNG of what the display shows for resolved layers (w*h*3 floats each, NULL = black), drawn
 * by an offscreen view; its memory is admitted for the time of the write. */
bool pm_write_png_view(const float *const layers[PM_COMPONENT_COUNT], int width, int height, const pm_display *display,
                       const char *path, char *err, size_t err_size);
/* From here a signal ends the process at once, removing a file under way (130 or 143). */
void pm_exit_on_signals(void);

/* ---- the window (src/window_app.c) ---- */
/* The window opens before the scene is loaded: pm_window_open shows it at once (a cleared frame,
 * its title naming the scene), pm_window_wait runs the set-up on a thread of its own while the
 * window answers keys and shows the set-up's stage, and pm_window_run renders. */
typedef struct pm_window pm_window;

/* A set-up to run while the window waits: work(arg) returns -1 once the session is ready, else
 * an exit code (its error line printed); meanwhile it names its stage ("loading", "building the
 * BVH of", ...) in `stage`, which the title shows before the scene's file name. */
typedef struct {
    int (*work)(void *arg);
    void *arg;
    const char *scene_path;
    _Atomic(const char *) stage;
    /* the job's thread (pm_window_job_start) */
    pthread_t thread;
    bool started;
    atomic_bool done;
    _Atomic(pm_view *) view; /* woken when the job ends, once the window waits */
    int result;
} pm_window_job;

/* Starts the set-up on a thread of its own before the window opens, so that the scene loads
 * while the window and its context are made; pm_window_wait (or, without a window,
 * pm_window_job_finish) waits for it and returns its result. */
void pm_window_job_start(pm_window_job *job);
int pm_window_job_finish(pm_window_job *job);

/* Opens the window (rank 0 only) at the film size the options give, square when the height
 * waits for the scene's camera. Returns -1 with *window set, else the exit code, its line
 * printed (2: no DISPLAY). process_start: for the time to the first frame (--stats). */
int pm_window_open(const pm_options *o, pm_cluster *cluster, double process_start, pm_window **window);
/* Runs the job on a thread while the window polls; returns the job's result. Esc or closing the
 * window meanwhile: a single process exits at once with status 0, the set-up abandoned (the
 * loader and the BVH build have no point to stop at); under mpirun the window waits for the
 * set-up, which every rank agrees on, and pm_window_run then quits at once. */
int pm_window_wait(pm_window *window, pm_cluster *cluster, pm_window_job *job);
/* What the window renders: a set-up's scene, accel and session, its start camera and --reference. */
typedef struct {
    const pm_scene *scene;
    const pm_accel *accel;
    pm_session *session;
    pm_camera camera;                    /* the start camera (Home) */
    const pm_reference_image *reference; /* --reference, or NULL */
    void *handle;                        /* the set-up's own state, for the reloader */
} pm_window_scene;

/* A reload the window asks for: the scene file, the sky (NULL: as the options say), the film's
 * size, the camera to keep (NULL: the file's first, or the framing) and the material variant
 * (KHR_materials_variants; NULL: the file's default materials). */
typedef struct {
    const char *scene_path, *sky;
    int width, height;
    const pm_camera *camera;
    const char *variant;
} pm_window_reload;

/* How the window reloads (--watch, a dropped file, the variant key): load runs the start-up's set-up again on the
 * calling thread (a thread of the window's), true with *out ready (not started), false with err
 * set (its line printed on stderr); adopt makes a loaded scene the current one, the previous one
 * freed (its session stopped first); discard frees a loaded scene not adopted. */
typedef struct {
    bool (*load)(void *context, const pm_window_reload *ask, pm_window_scene *out, char *err, size_t err_size);
    void (*adopt)(void *context, const pm_window_scene *next);
    void (*discard)(void *context, const pm_window_scene *loaded);
    void *context;
} pm_window_reloader;

/* The GLFW loop: camera navigation and keys, drawn from the session's published images, restarts
 * and resizes asked of the session. The window takes the film's size. With a reloader, --watch
 * and dropped files replace the scene (or the sky) through it. Returns the exit code. */
int pm_window_run(pm_window *window, const pm_options *o, pm_cluster *cluster, const pm_window_scene *start,
                  const pm_window_reloader *reloader);
void pm_window_close(pm_window *window);

#endif

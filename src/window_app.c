/* window_app.c: the window's driver: the GLFW loop of the view, camera navigation and keys, restarts and resizes asked of the session (and, under mpirun, of every rank), its published or merged images drawn and saved. */
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/inotify.h>
#include <time.h>
#include <unistd.h>
#include <errno.h>

#include "camera_control.h"
#include "clock.h"
#include "defaults.h"
#include "drivers.h"
#include "image_io.h"
#include "memory.h"

/* The view's shaders compiled and turned into code on a thread of its own (the GL context current
 * there meanwhile), so that the window's thread answers keys through it. */
typedef struct {
    pm_view *view;
    pthread_t thread;
    bool started, running, ok;
    char err[1024];
} view_preparation;

struct pm_window {
    pm_view *view;
    view_preparation preparation;
    pm_display display;
    double process_start;
    double first_frame, setup_done; /* from process_start: the cleared window on screen, the session ready */
    bool quit;                      /* Esc or the window closed while the scene was set up */
};

static const char window_help[] =
    "pmview keys: left drag orbit, right/middle drag pan, wheel dolly, double click: orbit about that point\n"
    "  W A S D / Q E fly (Shift faster), F frame the scene, C next camera, Home starting camera\n"
    "  M next material variant (KHR_materials_variants; after the last, the file's default materials)\n"
    "  1 2 3 4 direct/specular/caustic/indirect, + - exposure, 0 reset, T tonemap, G final gathering on/off\n"
    "  V views: shaded, photon density, radius; Space pause, R restart, P or F12 save PNG and EXR, H this help, Esc quit\n";

static void save_from_window(const pm_options *opt, const float *const layers[PM_COMPONENT_COUNT], int width, int height,
                             const pm_display *display) {
    char err[1024], exr_path[1024];
    snprintf(exr_path, sizeof exr_path, "%.*s.exr", (int)(strlen(opt->screenshot) - 4), opt->screenshot);
    /* both files from the same published layers: the PNG as shown, the EXR linear; each failure
     * is reported and, handled, forgotten, so that no later message names it */
    pm_memory_clear_failure();
    bool ok = pm_write_png_view(layers, width, height, display, opt->screenshot, err, sizeof err) &&
              pm_write_exr_layers(exr_path, width, height, layers, err, sizeof err);
    if (ok) printf("pmview: saved %s and %s\n", opt->screenshot, exr_path);
    else fprintf(stderr, "pmview: error: %s\n", err);
    pm_memory_clear_failure();
}

/* Under mpirun: the merged film's components resolved for the view (rank 0). */
typedef struct {
    float *layers[PM_COMPONENT_COUNT];
    int width, height;
    bool shown;               /* a merge of the current camera and size is on screen */
} merged_layers;

static void free_merged(merged_layers *m) {
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) free(m->layers[c]);
    memset(m, 0, sizeof *m);
}

static bool resolve_merged(merged_layers *m, const pm_film *film) {
    if (m->width != film->width || m->height != film->height) {
        free_merged(m);
        for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
            if (!film->sum[c]) continue;
            m->layers[c] = pm_malloc(3 * sizeof(float) * (size_t)film->width * film->height, "the merged image's layers");
            if (!m->layers[c]) { free_merged(m); return false; }
        }
        m->width = film->width;
        m->height = film->height;
    }
    for (int c = 0; c < PM_COMPONENT_COUNT; c++)
        if (m->layers[c]) pm_film_resolve(film, (pm_component)c, m->layers[c]);
    return true;
}

/* The scene's file name, without its folders, for the title. */
static const char *file_name(const char *path) {
    const char *slash = path ? strrchr(path, '/') : NULL;
    return slash ? slash + 1 : (path ? path : "");
}

/* ---- --watch: the scene's folder, through inotify ---- */

/* A file closed after writing, or renamed into the folder (an editor's save: write a temporary
 * file, then rename it over the scene), marks a reload as wanted; it starts once the folder has
 * been quiet for PM_WATCH_SETTLE_SECONDS, so a burst of saves is one reload. */
typedef struct {
    int fd;
    char name[1024];       /* the scene file's name in its folder */
    char screenshot[1024]; /* the P key's PNG, which may be written into the same folder */
    bool pending;
    double last_event;
} watcher;

static void watch_stop(watcher *wt) {
    if (wt->fd >= 0) close(wt->fd);
    wt->fd = -1;
    wt->pending = false;
}

static void watch_start(watcher *wt, const char *scene_path, const pm_options *opt) {
    watch_stop(wt);
    char folder[4096];
    const char *slash = strrchr(scene_path, '/');
    if (slash) snprintf(folder, sizeof folder, "%.*s", slash == scene_path ? 1 : (int)(slash - scene_path), scene_path);
    else snprintf(folder, sizeof folder, ".");
    snprintf(wt->name, sizeof wt->name, "%s", file_name(scene_path));
    snprintf(wt->screenshot, sizeof wt->screenshot, "%s", file_name(opt->screenshot));
    wt->fd = inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
    if (wt->fd < 0 || inotify_add_watch(wt->fd, folder, IN_CLOSE_WRITE | IN_MOVED_TO) < 0) {
        fprintf(stderr, "pmview: warning: --watch: cannot watch %s: %s\n", folder, strerror(errno));
        watch_stop(wt);
    }
}

/* The scene file itself, or what a scene beside it reads: buffers and images. */
static bool watched_name(const watcher *wt, const char *name) {
    if (!strcmp(name, wt->name)) return true;
    if (!strcmp(name, wt->screenshot)) return false;
    static const char *const kinds[] = {".bin", ".png", ".jpg", ".jpeg"};
    for (size_t k = 0; k < sizeof kinds / sizeof *kinds; k++)
        if (pm_has_extension(name, kinds[k])) return true;
    return false;
}

static void watch_read(watcher *wt) {
    if (wt->fd < 0) return;
    _Alignas(struct inotify_event) char buffer[8192];
    for (;;) {
        ssize_t n = read(wt->fd, buffer, sizeof buffer);
        if (n <= 0) return;
        for (char *p = buffer; p < buffer + n;) {
            const struct inotify_event *e = (const struct inotify_event *)p;
            if (e->len && watched_name(wt, e->name)) {
                wt->pending = true;
                wt->last_event = pm_now_seconds();
            }
            p += sizeof *e + e->len;
        }
    }
}

/* ---- reloads (--watch, a dropped file), one at a time on a thread of their own ---- */

typedef enum { RELOAD_WATCH, RELOAD_SCENE, RELOAD_SKY, RELOAD_VARIANT } reload_kind;

typedef struct {
    const pm_window_reloader *reloader;
    pm_view *view;
    pthread_t thread;
    bool running, ok;
    atomic_bool done;
    reload_kind kind;
    char scene_path[4096], sky[4096], variant[1024];
    int variant_index; /* in the scene's list, -1: the file's default materials */
    pm_camera camera;
    pm_window_reload ask;
    pm_window_scene out;
    char err[1024];
} reload_job;

static void *run_reload(void *arg) {
    reload_job *job = arg;
    job->ok = job->reloader->load(job->reloader->context, &job->ask, &job->out, job->err, sizeof job->err);
    atomic_store(&job->done, true);
    pm_view_wake(job->view);
    return NULL;
}

/* variant: the material variant to load (its index in the scene's list, -1 for the file's
 * default materials, named by `name`) */
static bool reload_start(reload_job *job, reload_kind kind, const char *scene_path, const char *sky, int width, int height,
                         const pm_camera *camera, int variant, const char *name) {
    job->kind = kind;
    snprintf(job->scene_path, sizeof job->scene_path, "%s", scene_path);
    snprintf(job->sky, sizeof job->sky, "%s", sky ? sky : "");
    snprintf(job->variant, sizeof job->variant, "%s", variant >= 0 && name ? name : "");
    job->variant_index = variant >= 0 && name ? variant : -1;
    job->camera = *camera;
    job->ask = (pm_window_reload){.scene_path = job->scene_path, .sky = job->sky[0] ? job->sky : NULL, .width = width,
                                  .height = height, .camera = kind == RELOAD_SCENE ? NULL : &job->camera,
                                  .variant = job->variant_index >= 0 ? job->variant : NULL};
    job->ok = false;
    job->err[0] = '\0';
    atomic_store(&job->done, false);
    job->running = pthread_create(&job->thread, NULL, run_reload, job) == 0;
    return job->running;
}

/* --reference: the total of the layers shown (3 floats a pixel, the reference's size) and its
 * relMSE against it, for the title. */
static double window_relmse(const float *const *layers, const pm_reference_image *ref, float *total, double ratio[3]) {
    size_t n = 3 * (size_t)ref->width * ref->height;
    memset(total, 0, n * sizeof *total);
    for (int c = 0; c < PM_COMPONENT_COUNT; c++)
        if (layers[c])
            for (size_t i = 0; i < n; i++) total[i] += layers[c][i];
    return pm_reference_relmse_total(total, ref, ratio);
}

/* KHR_materials_variants: the name of variant `index` of the scene's list (NULL when out of it),
 * and the index of `name` (-1 when the list has no such name, or name is NULL). */
static const char *variant_name(const pm_scene *s, int index) {
    if (index < 0 || (uint32_t)index >= s->variant_count || !s->variant_names) return NULL;
    const char *n = s->variant_names;
    for (int k = 0; k < index; k++) n += strlen(n) + 1;
    return n;
}
static int variant_index(const pm_scene *s, const char *name) {
    for (uint32_t k = 0; name && k < s->variant_count; k++)
        if (!strcmp(variant_name(s, (int)k), name)) return (int)k;
    return -1;
}
/* A variant's name for the title and the terminal: bytes outside printable ASCII as '?', at most
 * size - 1 of them. */
static void printable_name(const char *name, char *out, size_t size) {
    size_t k = 0;
    for (; name[k] && k + 1 < size; k++) out[k] = name[k] >= 0x20 && name[k] < 0x7f ? name[k] : '?';
    out[k] = '\0';
}

/* The reference's planes interleaved for the view's error display. */
static void show_reference(pm_view *view, const pm_reference_image *ref) {
    if (!ref) { pm_view_set_reference(view, 0, 0, NULL); return; }
    size_t n = (size_t)ref->width * ref->height;
    uint64_t mark = pm_memory_failure_mark();
    float *rgb = pm_malloc(3 * n * sizeof *rgb, "the reference's display copy");
    if (!rgb) {
        /* the error view then compares against nothing: said, not silent */
        fprintf(stderr, "pmview: error: out of memory (%s): the reference is not shown\n",
                pm_memory_failure_since_or(mark, "the reference's display copy"));
        pm_view_set_reference(view, 0, 0, NULL);
        return;
    }
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) rgb[3 * i + c] = ref->rgb[c][i];
    pm_view_set_reference(view, ref->width, ref->height, rgb);
    free(rgb);
}

int pm_window_open(const pm_options *opt, pm_cluster *cluster, double process_start, pm_window **out) {
    *out = NULL;
    if (!getenv("DISPLAY")) {
        fprintf(stderr, "pmview: no DISPLAY for a window; use --snapshot FILE.png|FILE.exr to render offscreen\n");
        return 2;
    }
    uint64_t mark = pm_memory_failure_mark();
    pm_window *w = pm_calloc(1, sizeof *w, "the window");
    if (!w) { fprintf(stderr, "pmview: error: out of memory (%s)\n", pm_memory_failure_since(mark)); return 1; }
    w->process_start = process_start;
    pm_display_from_options(opt, &w->display);
    /* the film's size is known once the scene's camera is: until then the width asked for and the
     * height asked for, else a square (the default scene's shape) */
    int width = opt->width ? (int)opt->width : PM_DEFAULT_WIDTH;
    int height = opt->height ? (int)opt->height : width;
    if (height > PM_MAX_IMAGE_SIDE) height = PM_MAX_IMAGE_SIDE;
    char title[64], err[1024];
    if (cluster) snprintf(title, sizeof title, "pmview (%d ranks)", pm_cluster_size(cluster));
    else snprintf(title, sizeof title, "pmview");
    w->view = pm_view_create_window(width, height, title, err, sizeof err);
    if (!w->view) {
        fprintf(stderr, "pmview: error: %s\n", err);
        free(w);
        return 1;
    }
    w->first_frame = pm_now_seconds() - process_start;
    char status[160];
    snprintf(status, sizeof status, "loading %s", file_name(opt->scene_path));
    pm_view_set_status(w->view, status);
    /* the title at once, not at the first poll of the wait */
    if (pm_view_poll(w->view, &w->display, false, 0).quit) w->quit = true;
    *out = w;
    return -1;
}

static void *run_preparation(void *arg) {
    view_preparation *p = arg;
    p->ok = pm_view_prepare(p->view, p->err, sizeof p->err);
    pm_view_release_context(p->view);
    return NULL;
}

/* Waits for the view's preparation; false with err set when it failed. */
static bool prepared(pm_window *w, char *err, size_t err_size) {
    view_preparation *p = &w->preparation;
    if (!p->started) {
        p->started = true;
        p->view = w->view;
        run_preparation(p);
    }
    if (p->running) {
        pthread_join(p->thread, NULL);
        p->running = false;
    }
    if (!p->ok) snprintf(err, err_size, "%s", p->err);
    return p->ok;
}

static void *run_job(void *arg) {
    pm_window_job *job = arg;
    job->result = job->work(job->arg);
    atomic_store(&job->done, true);
    pm_view *view = atomic_load(&job->view);
    if (view) pm_view_wake(view);
    return NULL;
}

void pm_window_job_start(pm_window_job *job) {
    job->result = 1;
    atomic_init(&job->done, false);
    atomic_init(&job->view, NULL);
    job->started = pthread_create(&job->thread, NULL, run_job, job) == 0;
}

int pm_window_job_finish(pm_window_job *job) {
    if (!job->started) return job->work(job->arg);
    pthread_join(job->thread, NULL);
    job->started = false;
    return job->result;
}

/* The shader is compiled and turned into code on a thread while a scene loads; a set-up quicker
 * than this leaves it for after the first image, which needs no shader (pm_view_show_quick). */
static void start_preparation(pm_window *w) {
    view_preparation *p = &w->preparation;
    if (p->started) return;
    p->started = true;
    p->view = w->view;
    pm_view_release_context(w->view);
    p->running = pthread_create(&p->thread, NULL, run_preparation, p) == 0;
    if (!p->running) run_preparation(p);
}

int pm_window_wait(pm_window *w, pm_cluster *cluster, pm_window_job *job) {
    if (!job->started) return job->work(job->arg); /* no thread: set up here, unseen */
    atomic_store(&job->view, w->view);
    double wait_start = pm_now_seconds();
    const char *shown = NULL;
    while (!atomic_load(&job->done)) {
        if (pm_now_seconds() - wait_start > PM_PREPARE_AFTER_SECONDS) start_preparation(w);
        const char *stage = atomic_load(&job->stage);
        if (stage && stage != shown) {
            char status[192];
            snprintf(status, sizeof status, "%s %s", stage, file_name(job->scene_path));
            pm_view_set_status(w->view, status);
            shown = stage;
        }
        pm_view_events ev = pm_view_poll(w->view, &w->display, true, 1.0 / 60.0);
        if (ev.help) fputs(window_help, stdout);
        /* the display keys edit w->display (the title shows it); the first image will use it */
        if (ev.quit && !w->quit) {
            w->quit = true;
            pm_view_hide(w->view); /* at once: freeing the context would wait for its threads */
        }
        if (w->quit && !cluster) {
            /* One process: it ends here, its set-up abandoned on the other thread. The loader and
             * the BVH build have no point to stop at, and exit() would run the libraries' static
             * destructors under that thread, so the process leaves by _exit (the system takes the
             * memory back); only the output streams are flushed. Under mpirun the other ranks
             * wait in the agreement after the set-up, so rank 0 goes there too and quits next. */
            fflush(stdout);
            fflush(stderr);
            _exit(0);
        }
    }
    int result = pm_window_job_finish(job);
    w->setup_done = pm_now_seconds() - w->process_start;
    return result;
}

void pm_window_close(pm_window *w) {
    if (!w) return;
    if (w->preparation.running) pthread_join(w->preparation.thread, NULL);
    pm_view_destroy(w->view);
    free(w);
}

/* ---- the window's loop: its state, its set-up, one function a phase of a turn, its ending ---- */

/* everything the loop carries from one turn to the next */
typedef struct {
    pm_window *w;
    const pm_options *opt;
    pm_cluster *cluster;
    const pm_window_reloader *reloader;
    pm_view *view;
    int ranks;
    char err[1024];
    merged_layers merged;
    pm_window_scene cur;
    double first_image;          /* from the process's start */
    double first_image_realtime; /* the wall clock at the first image, for a time from the process's exec */
    double first_image_cpu;      /* the process's processor time then, its loading before main() included */
    int width, height;
    pm_display display;
    /* the scene shown: its file (a dropped one replaces it) and a dropped sky */
    char scene_path[4096], sky[4096];
    char tracing[160];
    float *total; /* --reference: the title's relMSE, V's error view */
    watcher watch;
    reload_job job;
    char dropped[4096]; /* a dropped file waiting for the reload in flight to end */
    /* KHR_materials_variants: the variant shown (-1: the file's default materials), the one M asked
     * for and not yet loaded (-2: none), and its name for the title */
    int variant, wanted_variant;
    char variant_note[160];
    char notice[1200]; /* a failed reload or drop, in the title until the next success */
    char status[1600];
    uint64_t reloads, failed_reloads;
    double relmse, ratio[3];
    double process_start, first_frame, restart_requested, restart_to_image;
    uint64_t loops, frames, restarts;
    /* While the camera moves (changes less than PM_WINDOW_MOTION_GAP apart): how long, and how many
     * new images, of a camera asked for since the motion began, reached the screen. Frames drawn
     * count redraws of an old image too; this is what makes motion look fluid. */
    double last_move, motion_seconds;
    uint64_t motion_images;
    int coarsest_preview;
    double loop_start;
    pm_camera camera, home;
    vec3 pivot;
    float step;
    uint32_t camera_index;
    uint64_t version;
    bool finished_said, paused;
    int view_mode;
    int indirect; /* the G key's setting */
    /* this turn: the title and the window want redrawing */
    bool notice_changed, redraw;
} window_run;

/* The session started, its first image shown if it comes soon, the view prepared: 0, or 1 with the
 * error printed (and, under mpirun, the other ranks told). */
static int start_showing(window_run *r) {
    pm_window *w = r->w;
    pm_cluster *cluster = r->cluster;
    pm_session *session = r->cur.session;
    /* the session first: its preview renders while the view's preparation may still be running */
    if ((cluster && !pm_session_keep_packed(session, true)) || !pm_session_start(session, r->err, sizeof r->err)) {
        if (cluster) pm_cluster_abort(cluster, pm_session_error(session));
        fprintf(stderr, "pmview: error: %s\n", r->err);
        return 1;
    }
    /* A set-up that finished before the shader was wanted: the session's first image (its coarse
     * preview, out within milliseconds) is shown composed on the CPU, then the shader is built. */
    if (!w->preparation.started) {
        double give_up = pm_now_seconds() + PM_QUICK_IMAGE_WAIT_SECONDS;
        uint64_t seen = 0;
        while (pm_now_seconds() < give_up) {
            const float *const *quick = pm_session_lock_latest(session, &seen, NULL);
            if (quick) {
                pm_view_show_quick(r->view, r->width, r->height, quick, &w->display);
                pm_session_unlock_latest(session);
                r->first_image = pm_now_seconds() - w->process_start;
                r->first_image_realtime = pm_realtime_seconds();
                r->first_image_cpu = pm_process_cpu_seconds();
                break;
            }
            nanosleep(&(struct timespec){.tv_nsec = 1000000}, NULL);
        }
    }
    /* the first image is up (or not coming soon): the iterations may take the cores now (a session
     * the set-up started was held at its preview while the window opened) */
    pm_session_hold(session, false);
    if (!prepared(w, r->err, sizeof r->err) || !pm_view_set_size(r->view, r->width, r->height, r->err, sizeof r->err)) {
        if (cluster) pm_cluster_abort(cluster, r->err); /* the other ranks are waiting for its commands */
        fprintf(stderr, "pmview: error: %s\n", r->err);
        pm_session_stop(session);
        return 1;
    }
    return 0;
}

/* the loop's state before its first turn, the view prepared */
static void start_loop(window_run *r) {
    const pm_options *opt = r->opt;
    r->display = r->w->display;
    snprintf(r->scene_path, sizeof r->scene_path, "%s", opt->scene_path);
    r->sky[0] = '\0';
    snprintf(r->tracing, sizeof r->tracing, "tracing %.140s", file_name(r->scene_path));
    pm_view_set_status(r->view, r->tracing);
    if (r->cur.reference) {
        r->total = pm_malloc(3 * sizeof(float) * (size_t)r->cur.reference->width * r->cur.reference->height,
                             "the window's reference measure");
        if (!r->total) r->cur.reference = NULL;
        show_reference(r->view, r->cur.reference);
    }
    r->watch = (watcher){.fd = -1};
    if (opt->watch && r->reloader) watch_start(&r->watch, r->scene_path, opt); /* (main refuses --watch under mpirun) */
    r->job.reloader = r->reloader;
    r->job.view = r->view;
    atomic_init(&r->job.done, false);
    r->variant = variant_index(r->cur.scene, opt->variant);
    r->wanted_variant = -2;
    if (r->variant >= 0) {
        char shown[128];
        printable_name(variant_name(r->cur.scene, r->variant), shown, sizeof shown);
        snprintf(r->variant_note, sizeof r->variant_note, "variant %s  ", shown);
    }
    r->relmse = -1;
    /* no frame is drawn here: the window's grey one is on screen, and the first image (the
     * session's preview) follows within milliseconds */
    r->process_start = r->w->process_start;
    r->first_frame = r->w->first_frame;
    r->frames = 1;
    r->last_move = -1;
    r->loop_start = pm_now_seconds();
    r->camera = r->home = r->cur.camera;
    r->pivot = r->cur.scene->center;
    r->step = 0.05f * (r->cur.scene->radius > 0.f ? r->cur.scene->radius : 1.f);
    r->camera_index = opt->camera >= 0 ? (uint32_t)opt->camera : 0;
    r->view_mode = PM_VIEW_SHADED;
    r->indirect = opt->indirect;
}

/* navigation: the camera moved by the events, and a restart asked for a moved camera or R */
static void move_camera(window_run *r, const pm_view_events *ev) {
    const pm_scene *scene = r->cur.scene;
    pm_camera before = r->camera;
    pm_camera camera = r->camera;
    vec3 pivot = r->pivot;
    if (ev->orbit_dx != 0 || ev->orbit_dy != 0)
        camera = pm_camera_orbit(camera, pivot, (float)(-ev->orbit_dx * 0.01), (float)(-ev->orbit_dy * 0.01));
    if (ev->pan_dx != 0 || ev->pan_dy != 0) camera = pm_camera_pan(camera, &pivot, (float)ev->pan_dx, (float)ev->pan_dy, r->height);
    if (ev->dolly != 0) camera = pm_camera_dolly(camera, pivot, (float)ev->dolly);
    if (ev->fly[0] != 0 || ev->fly[1] != 0 || ev->fly[2] != 0)
        camera = pm_camera_fly(camera, &pivot, ev->fly, ev->fast ? 5.f * r->step : r->step);
    if (ev->frame) { camera = pm_camera_frame(scene, camera, (float)r->width / r->height); pivot = scene->center; }
    if (ev->home) { camera = r->home; pivot = scene->center; }
    if (ev->next_camera && scene->camera_count) {
        r->camera_index = (r->camera_index + 1) % scene->camera_count;
        camera = scene->cameras[r->camera_index];
        pivot = scene->center;
    }
    if (ev->pick) {
        vec3 o, d;
        pm_hit h;
        pm_camera_ray(&camera, r->width, r->height, (float)ev->pick_x, (float)ev->pick_y, &o, &d);
        if (pm_accel_intersect(r->cur.accel, o, d, INFINITY, &h)) pivot = v3_madd(o, d, h.t);
    }
    r->camera = camera;
    r->pivot = pivot;
    bool moved = memcmp(&before, &camera, sizeof camera) != 0;
    if (moved) {
        double t = pm_now_seconds();
        if (r->last_move >= 0 && t - r->last_move < PM_WINDOW_MOTION_GAP) r->motion_seconds += t - r->last_move;
        r->last_move = t;
    }
    if (moved || ev->restart) {
        pm_session_request_restart(r->cur.session, moved ? &r->camera : NULL, -1);
        pm_cluster_send_restart(r->cluster, moved ? &r->camera : NULL, -1);
        r->merged.shown = false;
        if (r->restart_requested == 0) r->restart_requested = pm_now_seconds();
    }
}

/* V: shaded, the progressive mode's photon density and radius, then with --reference each pixel's
 * relative error, and round again */
static void cycle_view(window_run *r) {
    static const char *const names[PM_VIEW_COUNT] = {"shaded", "photon density (false colour, log scale)",
                                                     "radius (false colour, log scale)"};
    pm_session *session = r->cur.session;
    if (r->display.error_view) {
        r->display.error_view = false;
        r->view_mode = PM_VIEW_SHADED;
        printf("pmview: view: %s\n", names[r->view_mode]);
    } else if (r->view_mode + 1 < PM_VIEW_COUNT && pm_session_set_view(session, (pm_session_view)(r->view_mode + 1))) {
        r->view_mode++;
        printf("pmview: view: %s\n", names[r->view_mode]);
    } else if (r->cur.reference && r->total) {
        if (r->view_mode != PM_VIEW_SHADED) pm_session_set_view(session, PM_VIEW_SHADED);
        r->view_mode = PM_VIEW_SHADED;
        r->display.error_view = true;
        printf("pmview: view: relative error against %s (false colour, log scale: blue 0.001, green 0.03, red 1)\n",
               file_name(r->opt->reference));
    } else {
        bool had_none = r->view_mode == PM_VIEW_SHADED;
        r->view_mode = PM_VIEW_SHADED;
        pm_session_set_view(session, PM_VIEW_SHADED);
        if (had_none) printf("pmview: the photon density and radius views need the progressive mode\n");
        else printf("pmview: view: %s\n", names[r->view_mode]);
    }
}

/* the keys that change how the session renders (G, Space, V), H, and a resized window */
static void handle_keys(window_run *r, const pm_view_events *ev) {
    pm_session *session = r->cur.session;
    pm_cluster *cluster = r->cluster;
    if (ev->toggle_gather && r->opt->mode == PM_MODE_PROGRESSIVE) {
        r->indirect = r->indirect == PM_INDIRECT_GATHER ? PM_INDIRECT_PHOTONS : PM_INDIRECT_GATHER;
        pm_session_request_restart(session, NULL, r->indirect);
        pm_cluster_send_restart(cluster, NULL, r->indirect);
        r->merged.shown = false;
        printf("pmview: indirect light by %s\n", r->indirect == PM_INDIRECT_GATHER ? "final gathering" : "photons at the visible point");
    }
    if (ev->pause) {
        r->paused = !r->paused;
        pm_session_pause(session, r->paused);
        pm_cluster_send_pause(cluster, r->paused);
    }
    if (ev->help) fputs(window_help, stdout);
    r->redraw = ev->display_changed;
    if (ev->cycle_view) {
        cycle_view(r);
        r->redraw = true;
    }
    if (ev->resized_width && (ev->resized_width != r->width || ev->resized_height != r->height)) {
        /* a new size is a new film, rendered with the camera as it is */
        if (!pm_session_resize(session, ev->resized_width, ev->resized_height, &r->camera)) {
            fprintf(stderr, "pmview: error: %s (window resized to %dx%d); keeping %dx%d\n", pm_session_error(session),
                    ev->resized_width, ev->resized_height, r->width, r->height);
        } else {
            pm_cluster_send_resize(cluster, ev->resized_width, ev->resized_height, &r->camera);
            r->merged.shown = false;
            r->width = ev->resized_width;
            r->height = ev->resized_height;
            printf("pmview: rendering at %dx%d\n", r->width, r->height);
        }
    }
}

/* --watch and drops: a dropped file while a reload runs waits for it; a bad file changes nothing but
 * the title. M: the next material variant, then the file's default materials, and round again; the
 * file is loaded again with it and rendered from scratch, the camera kept. */
static void take_requests(window_run *r, const pm_view_events *ev) {
    const pm_scene *scene = r->cur.scene;
    r->notice_changed = false;
    if (ev->next_variant) {
        if (!scene->variant_count) {
            snprintf(r->notice, sizeof r->notice, "%.400s has no material variants  ", file_name(r->scene_path));
            fprintf(stderr, "pmview: %s has no material variants (KHR_materials_variants): M changes nothing\n", r->scene_path);
            r->notice_changed = true;
        } else if (!r->reloader) {
            snprintf(r->notice, sizeof r->notice, "material variants: for a single process, not under mpirun  ");
            fprintf(stderr, "pmview: material variants are for a single process: under mpirun every rank would have to reload alike\n");
            r->notice_changed = true;
        } else {
            int from = r->wanted_variant >= -1 ? r->wanted_variant : r->variant;
            r->wanted_variant = from + 1 < (int)scene->variant_count ? from + 1 : -1;
        }
    }
    if (ev->dropped[0]) {
        if (!r->reloader) {
            snprintf(r->notice, sizeof r->notice, "drop: a dropped file is for a single process, not under mpirun  ");
            r->notice_changed = true;
        } else if (pm_has_extension(ev->dropped, ".gltf") || pm_has_extension(ev->dropped, ".glb") ||
                   pm_has_extension(ev->dropped, ".hdr") || pm_has_extension(ev->dropped, ".exr")) {
            snprintf(r->dropped, sizeof r->dropped, "%s", ev->dropped);
        } else {
            snprintf(r->notice, sizeof r->notice, "drop: %.400s is not a .gltf, .glb, .hdr or .exr file  ", file_name(ev->dropped));
            fprintf(stderr, "pmview: error: %s: dropped, but not a .gltf, .glb, .hdr or .exr file\n", ev->dropped);
            r->notice_changed = true;
        }
    }
}

/* with no reload running: one started for a dropped file, a settled change to a watched one, or M */
static void start_reload(window_run *r) {
    reload_job *job = &r->job;
    const pm_scene *scene = r->cur.scene;
    if (r->dropped[0]) {
        bool is_sky = pm_has_extension(r->dropped, ".hdr") || pm_has_extension(r->dropped, ".exr");
        int sw = 0, sh = 0;
        if (is_sky && !pm_environment_size(r->dropped, &sw, &sh, r->err, sizeof r->err)) {
            snprintf(r->notice, sizeof r->notice, "drop failed: %s  ", r->err);
            fprintf(stderr, "pmview: error: %s\n", r->err);
            r->failed_reloads++;
            r->notice_changed = true;
        } else {
            /* a sky keeps the variant; another file starts with its default materials */
            reload_start(job, is_sky ? RELOAD_SKY : RELOAD_SCENE, is_sky ? r->scene_path : r->dropped, is_sky ? r->dropped : r->sky,
                         r->width, r->height, &r->camera, is_sky ? r->variant : -1, is_sky ? variant_name(scene, r->variant) : NULL);
        }
        r->dropped[0] = '\0';
    } else if (r->watch.pending && pm_now_seconds() - r->watch.last_event >= PM_WATCH_SETTLE_SECONDS) {
        r->watch.pending = false;
        reload_start(job, RELOAD_WATCH, r->scene_path, r->sky, r->width, r->height, &r->camera, r->variant,
                     variant_name(scene, r->variant));
    } else if (r->wanted_variant >= -1) {
        reload_start(job, RELOAD_VARIANT, r->scene_path, r->sky, r->width, r->height, &r->camera, r->wanted_variant,
                     variant_name(scene, r->wanted_variant));
        r->wanted_variant = -2;
    }
    if (job->running) {
        char loading[160];
        if (job->kind == RELOAD_VARIANT) {
            char shown[128];
            printable_name(job->variant_index >= 0 ? job->variant : "the default materials", shown, sizeof shown);
            snprintf(loading, sizeof loading, "loading variant %s  ", shown);
        } else {
            snprintf(loading, sizeof loading, "%s %.140s  ", job->kind == RELOAD_WATCH ? "reloading" : "loading",
                     file_name(job->kind == RELOAD_SKY ? job->sky : job->scene_path));
        }
        snprintf(r->notice, sizeof r->notice, "%s", loading);
        r->notice_changed = true;
    }
}

/* a finished reload: its scene adopted and started with the window's settings (false: it would not
 * start, the error printed), or its failure in the title */
static bool finish_reload(window_run *r) {
    reload_job *job = &r->job;
    pthread_join(job->thread, NULL);
    job->running = false;
    r->notice_changed = true;
    if (!job->ok) {
        r->failed_reloads++;
        snprintf(r->notice, sizeof r->notice, "%s failed: %s  ",
                 job->kind == RELOAD_WATCH ? "reload" : job->kind == RELOAD_VARIANT ? "variant" : "drop", job->err);
        /* the set-up printed its line; a failure before it did is said here */
        if (!job->err[0]) fprintf(stderr, "pmview: error: %s: the reload failed\n", job->scene_path);
        return true;
    }
    pm_session_stop(r->cur.session);
    r->reloader->adopt(r->reloader->context, &job->out);
    r->cur = job->out;
    pm_session *session = r->cur.session;
    const pm_scene *scene = r->cur.scene;
    if (!pm_session_start(session, r->err, sizeof r->err)) {
        fprintf(stderr, "pmview: error: %s\n", r->err);
        return false;
    }
    if (job->kind == RELOAD_SCENE) {
        snprintf(r->scene_path, sizeof r->scene_path, "%s", job->scene_path);
        r->camera = r->home = r->cur.camera;
        r->pivot = scene->center;
        r->step = 0.05f * (scene->radius > 0.f ? scene->radius : 1.f);
        r->camera_index = 0;
        if (r->watch.fd >= 0) watch_start(&r->watch, r->scene_path, r->opt);
    } else if (memcmp(&r->camera, &job->camera, sizeof r->camera)) {
        pm_session_request_restart(session, &r->camera, -1); /* moved while it loaded */
    }
    if (job->kind == RELOAD_SKY) snprintf(r->sky, sizeof r->sky, "%s", job->sky);
    r->variant = job->variant_index;
    r->variant_note[0] = '\0';
    char shown[128] = "";
    if (r->variant >= 0) {
        printable_name(job->variant, shown, sizeof shown);
        snprintf(r->variant_note, sizeof r->variant_note, "variant %s  ", shown);
    }
    if (r->view_mode != PM_VIEW_SHADED) pm_session_set_view(session, (pm_session_view)r->view_mode);
    if (r->indirect != r->opt->indirect) pm_session_request_restart(session, NULL, r->indirect);
    if (r->paused) pm_session_pause(session, true);
    if (r->cur.reference && r->total) show_reference(r->view, r->cur.reference);
    else r->cur.reference = NULL;
    r->version = 0;
    r->finished_said = false;
    r->reloads++;
    r->notice[0] = '\0';
    if (job->kind == RELOAD_VARIANT && r->variant >= 0)
        printf("pmview: material variant %s (%d of %u)\n", shown, r->variant + 1, scene->variant_count);
    else if (job->kind == RELOAD_VARIANT)
        printf("pmview: the file's default materials\n");
    else
        printf("pmview: %s %s\n", job->kind == RELOAD_WATCH ? "reloaded" : "loaded", job->kind == RELOAD_SKY ? job->sky : job->scene_path);
    return true;
}

/* under mpirun: a merged image of this camera and size, uploaded (and saved for P) */
static void show_merged(window_run *r, const pm_film *whole, const pm_session_progress *progress, bool *save_png) {
    if (!resolve_merged(&r->merged, whole)) return;
    const float *const *layers = (const float *const *)r->merged.layers;
    char error_note[96] = "";
    r->merged.shown = true;
    pm_view_upload_layers(r->view, r->width, r->height, layers);
    if (*save_png) save_from_window(r->opt, layers, r->width, r->height, &r->display);
    *save_png = false;
    r->redraw = true;
    if (r->cur.reference && r->total) {
        r->relmse = window_relmse(layers, r->cur.reference, r->total, r->ratio);
        snprintf(error_note, sizeof error_note, "  relMSE %.3g  ratio %.3f", r->relmse, (r->ratio[0] + r->ratio[1] + r->ratio[2]) / 3);
    }
    pm_cluster_totals totals = pm_cluster_get_totals(r->cluster);
    snprintf(r->status, sizeof r->status, "%d ranks  %u it  %.2f Mphotons  %.1f s  r %.3g%s%s", r->ranks, whole->samples,
             totals.photons * 1e-6, progress->seconds, progress->mean_radius, error_note, r->paused ? "  paused" : "");
    r->notice_changed = true;
}

/* the session's newest image, locked: uploaded (and saved for P), measured, the title's status set, the lock let go */
static void show_published(window_run *r, const float *const *layers, const pm_session_progress *progress, bool *save_png) {
    double t = pm_now_seconds();
    char error_note[96] = "";
    if (r->first_image == 0) {
        r->first_image = t - r->process_start;
        r->first_image_realtime = pm_realtime_seconds();
        r->first_image_cpu = pm_process_cpu_seconds();
    }
    if (r->restart_requested > 0 && progress->preview) {
        r->restart_to_image += t - r->restart_requested;
        r->restarts++;
        r->restart_requested = 0;
    }
    if (r->last_move >= 0 && t - r->last_move < PM_WINDOW_MOTION_GAP) r->motion_images++;
    if (progress->preview_divisor > r->coarsest_preview) r->coarsest_preview = progress->preview_divisor;
    pm_view_upload_layers(r->view, r->width, r->height, layers);
    if (*save_png) save_from_window(r->opt, layers, r->width, r->height, &r->display);
    *save_png = false;
    /* a preview is a quarter of the size: measured only at the film's */
    if (r->cur.reference && r->total && !progress->preview) {
        r->relmse = window_relmse(layers, r->cur.reference, r->total, r->ratio);
        snprintf(error_note, sizeof error_note, "  relMSE %.3g  ratio %.3f", r->relmse, (r->ratio[0] + r->ratio[1] + r->ratio[2]) / 3);
    }
    pm_session_unlock_latest(r->cur.session);
    r->redraw = true;
    /* under mpirun, until the first merge of this camera: rank 0's own image */
    char own[32] = "";
    if (r->cluster) snprintf(own, sizeof own, "%d ranks (rank 0)  ", r->ranks);
    char preview_note[32] = "";
    if (progress->preview) snprintf(preview_note, sizeof preview_note, "preview 1/%d  ", progress->preview_divisor);
    snprintf(r->status, sizeof r->status, "%s%s%u it  %.2f Mphotons  %.3g Mphotons/s  %.1f s  r %.3g%s%s", own, preview_note,
             progress->iterations, progress->photons * 1e-6,
             progress->seconds > 0 ? progress->photons / progress->seconds * 1e-6 : 0.0, progress->seconds,
             progress->mean_radius, error_note, r->paused ? "  paused" : "");
    r->notice_changed = true;
    if (progress->finished && !r->finished_said) {
        printf("pmview: iterations done (%u)\n", progress->iterations);
        r->finished_said = true;
    }
}

/* the newest image (merged under mpirun, else the session's) shown, the title set, P saved, the window drawn */
static void show_latest(window_run *r, bool save_png) {
    pm_session *session = r->cur.session;
    /* before the session's lock is taken: a merge reads the session's packed image under it */
    const pm_film *whole = pm_cluster_poll_merge(r->cluster, session);
    pm_session_progress progress;
    const float *const *layers = pm_session_lock_latest(session, &r->version, &progress);
    r->loops++;
    /* under mpirun the merged image, once one of this camera and size has come, stands for the
     * session's own (its preview and first iterations show until then) */
    if (layers && r->merged.shown) {
        pm_session_unlock_latest(session);
        layers = NULL;
    }
    if (whole && whole->width == r->width && whole->height == r->height && whole->samples > 0 && !layers)
        show_merged(r, whole, &progress, &save_png);
    if (layers) show_published(r, layers, &progress, &save_png);
    if (r->notice_changed) {
        char title[sizeof r->notice + sizeof r->variant_note + sizeof r->status];
        snprintf(title, sizeof title, "%s%s%s", r->notice, r->variant_note, r->status[0] ? r->status : r->tracing);
        pm_view_set_status(r->view, title);
    }
    if (save_png && r->merged.shown) {
        save_from_window(r->opt, (const float *const *)r->merged.layers, r->width, r->height, &r->display);
        save_png = false;
    }
    if (save_png) {
        /* nothing newer was published: save the image on screen */
        uint64_t any = 0;
        const float *const *shown = pm_session_lock_latest(session, &any, NULL);
        if (shown) {
            save_from_window(r->opt, shown, r->width, r->height, &r->display);
            pm_session_unlock_latest(session);
        }
    }
    if (r->redraw) { pm_view_draw(r->view, &r->display); r->frames++; }
}

/* the loop left: a reload in flight waited for, the window's figures printed, everything stopped and freed */
static void end_loop(window_run *r) {
    pm_window *w = r->w;
    if (r->job.running) { /* a reload under way when the window closed: waited for, then freed */
        pthread_join(r->job.thread, NULL);
        if (r->job.ok) r->reloader->discard(r->reloader->context, &r->job.out);
    }
    watch_stop(&r->watch);
    double seconds = pm_now_seconds() - r->loop_start;
    if (r->opt->stats)
        printf("stat window first_frame_seconds=%.4f first_image_seconds=%.4f ui_loops_per_second=%.1f frames_per_second=%.1f restarts=%llu restart_to_image_seconds=%.4f"
               " motion_seconds=%.3f motion_images=%llu motion_images_per_second=%.1f coarsest_preview_divisor=%d setup_seconds=%.4f"
               " reloads=%llu failed_reloads=%llu relmse=%.6g first_image_realtime=%.6f first_image_cpu_seconds=%.4f\n",
               r->first_frame, r->first_image, seconds > 0 ? r->loops / seconds : 0.0, seconds > 0 ? r->frames / seconds : 0.0,
               (unsigned long long)r->restarts, r->restarts ? r->restart_to_image / r->restarts : 0.0, r->motion_seconds,
               (unsigned long long)r->motion_images, r->motion_seconds > 0 ? r->motion_images / r->motion_seconds : 0.0,
               r->coarsest_preview, w->setup_done, (unsigned long long)r->reloads, (unsigned long long)r->failed_reloads,
               r->relmse, r->first_image_realtime, r->first_image_cpu);
    pm_cluster_send_quit(r->cluster);
    pm_session_stop(r->cur.session);
    pm_view_destroy(r->view);
    w->view = NULL;
    free_merged(&r->merged);
    free(r->total);
}

int pm_window_run(pm_window *w, const pm_options *opt, pm_cluster *cluster, const pm_window_scene *start,
                  const pm_window_reloader *reloader) {
    /* Ctrl-C in the terminal during a P save: the half-written file goes with the process */
    pm_exit_on_signals();
    window_run run; /* (the loop's locals, as one: a few pages of the window's thread's stack) */
    memset(&run, 0, sizeof run);
    window_run *r = &run;
    r->w = w;
    r->opt = opt;
    r->cluster = cluster;
    r->reloader = reloader;
    r->view = w->view;
    r->ranks = pm_cluster_size(cluster);
    r->cur = *start;
    const pm_film *film = pm_session_film(r->cur.session);
    r->width = film->width;
    r->height = film->height;
    int code = start_showing(r);
    if (code) return code;
    start_loop(r);
    for (;;) {
        pm_view_events ev = pm_view_poll(r->view, &r->display, true, 1.0 / 60.0);
        if (ev.quit || w->quit) break;
        move_camera(r, &ev);
        handle_keys(r, &ev);
        take_requests(r, &ev);
        watch_read(&r->watch);
        if (reloader && !r->job.running) start_reload(r);
        if (r->job.running && atomic_load(&r->job.done) && !finish_reload(r)) {
            code = 1;
            break;
        }
        show_latest(r, ev.save_png);
    }
    end_loop(r);
    return code;
}

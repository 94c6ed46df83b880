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

int pm_window_run(pm_window *w, const pm_options *opt, pm_cluster *cluster, const pm_window_scene *start,
                  const pm_window_reloader *reloader) {
    char err[1024];
    int ranks = pm_cluster_size(cluster);
    merged_layers merged;
    memset(&merged, 0, sizeof merged);
    /* Ctrl-C in the terminal during a P save: the half-written file goes with the process */
    pm_exit_on_signals();
    pm_window_scene cur = *start;
    double first_image_realtime = 0; /* the wall clock at the first image, for a time from the process's exec */
    double first_image_cpu = 0;      /* the process's processor time then, its loading before main() included */
    const pm_film *film = pm_session_film(cur.session);
    int width = film->width, height = film->height;
    pm_view *view = w->view;
    /* the session first: its preview renders while the view's preparation may still be running */
    if ((cluster && !pm_session_keep_packed(cur.session, true)) || !pm_session_start(cur.session, err, sizeof err)) {
        if (cluster) pm_cluster_abort(cluster, pm_session_error(cur.session));
        fprintf(stderr, "pmview: error: %s\n", err);
        return 1;
    }
    /* A set-up that finished before the shader was wanted: the session's first image (its coarse
     * preview, out within milliseconds) is shown composed on the CPU, then the shader is built. */
    double first_image = 0;
    if (!w->preparation.started) {
        double give_up = pm_now_seconds() + PM_QUICK_IMAGE_WAIT_SECONDS;
        uint64_t seen = 0;
        while (pm_now_seconds() < give_up) {
            const float *const *quick = pm_session_lock_latest(cur.session, &seen, NULL);
            if (quick) {
                pm_view_show_quick(view, width, height, quick, &w->display);
                pm_session_unlock_latest(cur.session);
                first_image = pm_now_seconds() - w->process_start;
                first_image_realtime = pm_realtime_seconds();
                first_image_cpu = pm_process_cpu_seconds();
                break;
            }
            nanosleep(&(struct timespec){.tv_nsec = 1000000}, NULL);
        }
    }
    /* the first image is up (or not coming soon): the iterations may take the cores now (a session
     * the set-up started was held at its preview while the window opened) */
    pm_session_hold(cur.session, false);
    if (!prepared(w, err, sizeof err) || !pm_view_set_size(view, width, height, err, sizeof err)) {
        if (cluster) pm_cluster_abort(cluster, err); /* the other ranks are waiting for its commands */
        fprintf(stderr, "pmview: error: %s\n", err);
        pm_session_stop(cur.session);
        return 1;
    }
    pm_display display = w->display;
    /* the scene shown: its file (a dropped one replaces it) and a dropped sky */
    char scene_path[4096], sky[4096] = "";
    snprintf(scene_path, sizeof scene_path, "%s", opt->scene_path);
    char tracing[160];
    snprintf(tracing, sizeof tracing, "tracing %.140s", file_name(scene_path));
    pm_view_set_status(view, tracing);
    /* --reference: the title's relMSE, V's error view */
    float *total = NULL;
    if (cur.reference) {
        total = pm_malloc(3 * sizeof(float) * (size_t)cur.reference->width * cur.reference->height, "the window's reference measure");
        if (!total) cur.reference = NULL;
        show_reference(view, cur.reference);
    }
    watcher watch = {.fd = -1};
    if (opt->watch && reloader) watch_start(&watch, scene_path, opt); /* (main refuses --watch under mpirun) */
    reload_job job;
    memset(&job, 0, sizeof job);
    job.reloader = reloader;
    job.view = view;
    atomic_init(&job.done, false);
    char dropped[4096] = "";   /* a dropped file waiting for the reload in flight to end */
    /* KHR_materials_variants: the variant shown (-1: the file's default materials), the one M asked
     * for and not yet loaded (-2: none), and its name for the title */
    int variant = variant_index(cur.scene, opt->variant), wanted_variant = -2;
    char variant_note[160] = "";
    if (variant >= 0) {
        char shown[128];
        printable_name(variant_name(cur.scene, variant), shown, sizeof shown);
        snprintf(variant_note, sizeof variant_note, "variant %s  ", shown);
    }
    char notice[1200] = "";    /* a failed reload or drop, in the title until the next success */
    char status[1600] = "";
    uint64_t reloads = 0, failed_reloads = 0;
    double relmse = -1, ratio[3] = {0, 0, 0};
    /* no frame is drawn here: the window's grey one is on screen, and the first image (the
     * session's preview) follows within milliseconds */
    double process_start = w->process_start, first_frame = w->first_frame, restart_requested = 0, restart_to_image = 0;
    uint64_t loops = 0, frames = 1, restarts = 0;
    /* While the camera moves (changes less than PM_WINDOW_MOTION_GAP apart): how long, and how many
     * new images, of a camera asked for since the motion began, reached the screen. Frames drawn
     * count redraws of an old image too; this is what makes motion look fluid. */
    double last_move = -1, motion_seconds = 0;
    uint64_t motion_images = 0;
    int coarsest_preview = 0;
    double loop_start = pm_now_seconds();
    pm_camera camera = cur.camera, home = cur.camera;
    vec3 pivot = cur.scene->center;
    float step = 0.05f * (cur.scene->radius > 0.f ? cur.scene->radius : 1.f);
    uint32_t camera_index = opt->camera >= 0 ? (uint32_t)opt->camera : 0;
    uint64_t version = 0;
    bool finished_said = false, paused = false;
    int view_mode = PM_VIEW_SHADED;
    int indirect = opt->indirect; /* the G key's setting */
    int code = 0;
    for (;;) {
        pm_view_events ev = pm_view_poll(view, &display, true, 1.0 / 60.0);
        if (ev.quit || w->quit) break;
        pm_session *session = cur.session;
        const pm_scene *scene = cur.scene;
        bool moved = false;
        pm_camera before = camera;
        if (ev.orbit_dx != 0 || ev.orbit_dy != 0)
            camera = pm_camera_orbit(camera, pivot, (float)(-ev.orbit_dx * 0.01), (float)(-ev.orbit_dy * 0.01));
        if (ev.pan_dx != 0 || ev.pan_dy != 0) camera = pm_camera_pan(camera, &pivot, (float)ev.pan_dx, (float)ev.pan_dy, height);
        if (ev.dolly != 0) camera = pm_camera_dolly(camera, pivot, (float)ev.dolly);
        if (ev.fly[0] != 0 || ev.fly[1] != 0 || ev.fly[2] != 0) camera = pm_camera_fly(camera, &pivot, ev.fly, ev.fast ? 5.f * step : step);
        if (ev.frame) { camera = pm_camera_frame(scene, camera, (float)width / height); pivot = scene->center; }
        if (ev.home) { camera = home; pivot = scene->center; }
        if (ev.next_camera && scene->camera_count) {
            camera_index = (camera_index + 1) % scene->camera_count;
            camera = scene->cameras[camera_index];
            pivot = scene->center;
        }
        if (ev.pick) {
            vec3 o, d;
            pm_hit h;
            pm_camera_ray(&camera, width, height, (float)ev.pick_x, (float)ev.pick_y, &o, &d);
            if (pm_accel_intersect(cur.accel, o, d, INFINITY, &h)) pivot = v3_madd(o, d, h.t);
        }
        moved = memcmp(&before, &camera, sizeof camera) != 0;
        if (moved) {
            double t = pm_now_seconds();
            if (last_move >= 0 && t - last_move < PM_WINDOW_MOTION_GAP) motion_seconds += t - last_move;
            last_move = t;
        }
        if (moved || ev.restart) {
            pm_session_request_restart(session, moved ? &camera : NULL, -1);
            pm_cluster_send_restart(cluster, moved ? &camera : NULL, -1);
            merged.shown = false;
            if (restart_requested == 0) restart_requested = pm_now_seconds();
        }
        if (ev.toggle_gather && opt->mode == PM_MODE_PROGRESSIVE) {
            indirect = indirect == PM_INDIRECT_GATHER ? PM_INDIRECT_PHOTONS : PM_INDIRECT_GATHER;
            pm_session_request_restart(session, NULL, indirect);
            pm_cluster_send_restart(cluster, NULL, indirect);
            merged.shown = false;
            printf("pmview: indirect light by %s\n", indirect == PM_INDIRECT_GATHER ? "final gathering" : "photons at the visible point");
        }
        if (ev.pause) {
            paused = !paused;
            pm_session_pause(session, paused);
            pm_cluster_send_pause(cluster, paused);
        }
        if (ev.help) fputs(window_help, stdout);
        bool redraw = ev.display_changed;
        if (ev.cycle_view) {
            static const char *const names[PM_VIEW_COUNT] = {"shaded", "photon density (false colour, log scale)",
                                                             "radius (false colour, log scale)"};
            /* shaded, the progressive mode's photon density and radius, then with --reference each
             * pixel's relative error, and round again */
            if (display.error_view) {
                display.error_view = false;
                view_mode = PM_VIEW_SHADED;
                printf("pmview: view: %s\n", names[view_mode]);
            } else if (view_mode + 1 < PM_VIEW_COUNT && pm_session_set_view(session, (pm_session_view)(view_mode + 1))) {
                view_mode++;
                printf("pmview: view: %s\n", names[view_mode]);
            } else if (cur.reference && total) {
                if (view_mode != PM_VIEW_SHADED) pm_session_set_view(session, PM_VIEW_SHADED);
                view_mode = PM_VIEW_SHADED;
                display.error_view = true;
                printf("pmview: view: relative error against %s (false colour, log scale: blue 0.001, green 0.03, red 1)\n",
                       file_name(opt->reference));
            } else {
                bool had_none = view_mode == PM_VIEW_SHADED;
                view_mode = PM_VIEW_SHADED;
                pm_session_set_view(session, PM_VIEW_SHADED);
                if (had_none) printf("pmview: the photon density and radius views need the progressive mode\n");
                else printf("pmview: view: %s\n", names[view_mode]);
            }
            redraw = true;
        }
        if (ev.resized_width && (ev.resized_width != width || ev.resized_height != height)) {
            /* a new size is a new film, rendered with the camera as it is */
            if (!pm_session_resize(session, ev.resized_width, ev.resized_height, &camera)) {
                fprintf(stderr, "pmview: error: %s (window resized to %dx%d); keeping %dx%d\n", pm_session_error(session),
                        ev.resized_width, ev.resized_height, width, height);
            } else {
                pm_cluster_send_resize(cluster, ev.resized_width, ev.resized_height, &camera);
                merged.shown = false;
                width = ev.resized_width;
                height = ev.resized_height;
                printf("pmview: rendering at %dx%d\n", width, height);
            }
        }
        /* --watch and drops: a dropped file while a reload runs waits for it; a bad file changes
         * nothing but the title */
        bool notice_changed = false;
        /* M: the next material variant, then the file's default materials, and round again; the
         * file is loaded again with it and rendered from scratch, the camera kept */
        if (ev.next_variant) {
            if (!scene->variant_count) {
                snprintf(notice, sizeof notice, "%.400s has no material variants  ", file_name(scene_path));
                fprintf(stderr, "pmview: %s has no material variants (KHR_materials_variants): M changes nothing\n", scene_path);
                notice_changed = true;
            } else if (!reloader) {
                snprintf(notice, sizeof notice, "material variants: for a single process, not under mpirun  ");
                fprintf(stderr, "pmview: material variants are for a single process: under mpirun every rank would have to reload alike\n");
                notice_changed = true;
            } else {
                int from = wanted_variant >= -1 ? wanted_variant : variant;
                wanted_variant = from + 1 < (int)scene->variant_count ? from + 1 : -1;
            }
        }
        if (ev.dropped[0]) {
            if (!reloader) {
                snprintf(notice, sizeof notice, "drop: a dropped file is for a single process, not under mpirun  ");
                notice_changed = true;
            } else if (pm_has_extension(ev.dropped, ".gltf") || pm_has_extension(ev.dropped, ".glb") ||
                       pm_has_extension(ev.dropped, ".hdr") || pm_has_extension(ev.dropped, ".exr")) {
                snprintf(dropped, sizeof dropped, "%s", ev.dropped);
            } else {
                snprintf(notice, sizeof notice, "drop: %.400s is not a .gltf, .glb, .hdr or .exr file  ", file_name(ev.dropped));
                fprintf(stderr, "pmview: error: %s: dropped, but not a .gltf, .glb, .hdr or .exr file\n", ev.dropped);
                notice_changed = true;
            }
        }
        watch_read(&watch);
        if (reloader && !job.running) {
            if (dropped[0]) {
                bool is_sky = pm_has_extension(dropped, ".hdr") || pm_has_extension(dropped, ".exr");
                int sw = 0, sh = 0;
                if (is_sky && !pm_environment_size(dropped, &sw, &sh, err, sizeof err)) {
                    snprintf(notice, sizeof notice, "drop failed: %s  ", err);
                    fprintf(stderr, "pmview: error: %s\n", err);
                    failed_reloads++;
                    notice_changed = true;
                } else {
                    /* a sky keeps the variant; another file starts with its default materials */
                    reload_start(&job, is_sky ? RELOAD_SKY : RELOAD_SCENE, is_sky ? scene_path : dropped, is_sky ? dropped : sky,
                                 width, height, &camera, is_sky ? variant : -1, is_sky ? variant_name(scene, variant) : NULL);
                }
                dropped[0] = '\0';
            } else if (watch.pending && pm_now_seconds() - watch.last_event >= PM_WATCH_SETTLE_SECONDS) {
                watch.pending = false;
                reload_start(&job, RELOAD_WATCH, scene_path, sky, width, height, &camera, variant, variant_name(scene, variant));
            } else if (wanted_variant >= -1) {
                reload_start(&job, RELOAD_VARIANT, scene_path, sky, width, height, &camera, wanted_variant,
                             variant_name(scene, wanted_variant));
                wanted_variant = -2;
            }
            if (job.running) {
                char loading[160];
                if (job.kind == RELOAD_VARIANT) {
                    char shown[128];
                    printable_name(job.variant_index >= 0 ? job.variant : "the default materials", shown, sizeof shown);
                    snprintf(loading, sizeof loading, "loading variant %s  ", shown);
                } else {
                    snprintf(loading, sizeof loading, "%s %.140s  ", job.kind == RELOAD_WATCH ? "reloading" : "loading",
                             file_name(job.kind == RELOAD_SKY ? job.sky : job.scene_path));
                }
                snprintf(notice, sizeof notice, "%s", loading);
                notice_changed = true;
            }
        }
        if (job.running && atomic_load(&job.done)) {
            pthread_join(job.thread, NULL);
            job.running = false;
            if (job.ok) {
                pm_session_stop(cur.session);
                reloader->adopt(reloader->context, &job.out);
                cur = job.out;
                session = cur.session;
                scene = cur.scene;
                if (!pm_session_start(session, err, sizeof err)) {
                    fprintf(stderr, "pmview: error: %s\n", err);
                    code = 1;
                    break;
                }
                if (job.kind == RELOAD_SCENE) {
                    snprintf(scene_path, sizeof scene_path, "%s", job.scene_path);
                    camera = home = cur.camera;
                    pivot = scene->center;
                    step = 0.05f * (scene->radius > 0.f ? scene->radius : 1.f);
                    camera_index = 0;
                    if (watch.fd >= 0) watch_start(&watch, scene_path, opt);
                } else if (memcmp(&camera, &job.camera, sizeof camera)) {
                    pm_session_request_restart(session, &camera, -1); /* moved while it loaded */
                }
                if (job.kind == RELOAD_SKY) snprintf(sky, sizeof sky, "%s", job.sky);
                variant = job.variant_index;
                variant_note[0] = '\0';
                char shown[128] = "";
                if (variant >= 0) {
                    printable_name(job.variant, shown, sizeof shown);
                    snprintf(variant_note, sizeof variant_note, "variant %s  ", shown);
                }
                if (view_mode != PM_VIEW_SHADED) pm_session_set_view(session, (pm_session_view)view_mode);
                if (indirect != opt->indirect) pm_session_request_restart(session, NULL, indirect);
                if (paused) pm_session_pause(session, true);
                if (cur.reference && total) show_reference(view, cur.reference);
                else cur.reference = NULL;
                version = 0;
                finished_said = false;
                reloads++;
                notice[0] = '\0';
                if (job.kind == RELOAD_VARIANT && variant >= 0)
                    printf("pmview: material variant %s (%d of %u)\n", shown, variant + 1, scene->variant_count);
                else if (job.kind == RELOAD_VARIANT)
                    printf("pmview: the file's default materials\n");
                else
                    printf("pmview: %s %s\n", job.kind == RELOAD_WATCH ? "reloaded" : "loaded",
                           job.kind == RELOAD_SKY ? job.sky : job.scene_path);
            } else {
                failed_reloads++;
                snprintf(notice, sizeof notice, "%s failed: %s  ",
                         job.kind == RELOAD_WATCH ? "reload" : job.kind == RELOAD_VARIANT ? "variant" : "drop", job.err);
                /* the set-up printed its line; a failure before it did is said here */
                if (!job.err[0]) fprintf(stderr, "pmview: error: %s: the reload failed\n", job.scene_path);
            }
            notice_changed = true;
        }
        /* before the session's lock is taken: a merge reads the session's packed image under it */
        const pm_film *whole = pm_cluster_poll_merge(cluster, session);
        pm_session_progress progress;
        const float *const *layers = pm_session_lock_latest(session, &version, &progress);
        loops++;
        /* under mpirun the merged image, once one of this camera and size has come, stands for the
         * session's own (its preview and first iterations show until then) */
        if (layers && merged.shown) {
            pm_session_unlock_latest(session);
            layers = NULL;
        }
        char error_note[96] = "";
        if (whole && whole->width == width && whole->height == height && whole->samples > 0 && !layers) {
            if (resolve_merged(&merged, whole)) {
                merged.shown = true;
                pm_view_upload_layers(view, width, height, (const float *const *)merged.layers);
                if (ev.save_png) save_from_window(opt, (const float *const *)merged.layers, width, height, &display);
                ev.save_png = false;
                redraw = true;
                if (cur.reference && total) {
                    relmse = window_relmse((const float *const *)merged.layers, cur.reference, total, ratio);
                    snprintf(error_note, sizeof error_note, "  relMSE %.3g  ratio %.3f", relmse, (ratio[0] + ratio[1] + ratio[2]) / 3);
                }
                pm_cluster_totals totals = pm_cluster_get_totals(cluster);
                snprintf(status, sizeof status, "%d ranks  %u it  %.2f Mphotons  %.1f s  r %.3g%s%s", ranks, whole->samples,
                         totals.photons * 1e-6, progress.seconds, progress.mean_radius, error_note, paused ? "  paused" : "");
                notice_changed = true;
            }
        }
        if (layers) {
            double t = pm_now_seconds();
            if (first_image == 0) {
                first_image = t - process_start;
                first_image_realtime = pm_realtime_seconds();
                first_image_cpu = pm_process_cpu_seconds();
            }
            if (restart_requested > 0 && progress.preview) {
                restart_to_image += t - restart_requested;
                restarts++;
                restart_requested = 0;
            }
            if (last_move >= 0 && t - last_move < PM_WINDOW_MOTION_GAP) motion_images++;
            if (progress.preview_divisor > coarsest_preview) coarsest_preview = progress.preview_divisor;
            pm_view_upload_layers(view, width, height, layers);
            if (ev.save_png) save_from_window(opt, layers, width, height, &display);
            ev.save_png = false;
            /* a preview is a quarter of the size: measured only at the film's */
            if (cur.reference && total && !progress.preview) {
                relmse = window_relmse(layers, cur.reference, total, ratio);
                snprintf(error_note, sizeof error_note, "  relMSE %.3g  ratio %.3f", relmse, (ratio[0] + ratio[1] + ratio[2]) / 3);
            }
            pm_session_unlock_latest(session);
            redraw = true;
            /* under mpirun, until the first merge of this camera: rank 0's own image */
            char own[32] = "";
            if (cluster) snprintf(own, sizeof own, "%d ranks (rank 0)  ", ranks);
            char preview_note[32] = "";
            if (progress.preview) snprintf(preview_note, sizeof preview_note, "preview 1/%d  ", progress.preview_divisor);
            snprintf(status, sizeof status, "%s%s%u it  %.2f Mphotons  %.3g Mphotons/s  %.1f s  r %.3g%s%s", own, preview_note,
                     progress.iterations, progress.photons * 1e-6, progress.seconds > 0 ? progress.photons / progress.seconds * 1e-6 : 0.0,
                     progress.seconds, progress.mean_radius, error_note, paused ? "  paused" : "");
            notice_changed = true;
            if (progress.finished && !finished_said) { printf("pmview: iterations done (%u)\n", progress.iterations); finished_said = true; }
        }
        if (notice_changed) {
            char title[sizeof notice + sizeof variant_note + sizeof status];
            snprintf(title, sizeof title, "%s%s%s", notice, variant_note, status[0] ? status : tracing);
            pm_view_set_status(view, title);
        }
        if (ev.save_png && merged.shown) {
            save_from_window(opt, (const float *const *)merged.layers, width, height, &display);
            ev.save_png = false;
        }
        if (ev.save_png) {
            /* nothing newer was published: save the image on screen */
            uint64_t any = 0;
            const float *const *shown = pm_session_lock_latest(session, &any, NULL);
            if (shown) {
                save_from_window(opt, shown, width, height, &display);
                pm_session_unlock_latest(session);
            }
        }
        if (redraw) { pm_view_draw(view, &display); frames++; }
    }
    if (job.running) { /* a reload under way when the window closed: waited for, then freed */
        pthread_join(job.thread, NULL);
        if (job.ok) reloader->discard(reloader->context, &job.out);
    }
    watch_stop(&watch);
    double seconds = pm_now_seconds() - loop_start;
    if (opt->stats)
        printf("stat window first_frame_seconds=%.4f first_image_seconds=%.4f ui_loops_per_second=%.1f frames_per_second=%.1f restarts=%llu restart_to_image_seconds=%.4f"
               " motion_seconds=%.3f motion_images=%llu motion_images_per_second=%.1f coarsest_preview_divisor=%d setup_seconds=%.4f"
               " reloads=%llu failed_reloads=%llu relmse=%.6g first_image_realtime=%.6f first_image_cpu_seconds=%.4f\n",
               first_frame, first_image, seconds > 0 ? loops / seconds : 0.0, seconds > 0 ? frames / seconds : 0.0,
               (unsigned long long)restarts, restarts ? restart_to_image / restarts : 0.0, motion_seconds,
               (unsigned long long)motion_images, motion_seconds > 0 ? motion_images / motion_seconds : 0.0, coarsest_preview,
               w->setup_done, (unsigned long long)reloads, (unsigned long long)failed_reloads, relmse, first_image_realtime, first_image_cpu);
    pm_cluster_send_quit(cluster);
    pm_session_stop(cur.session);
    pm_view_destroy(view);
    w->view = NULL;
    free_merged(&merged);
    free(total);
    return code;
}

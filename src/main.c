/* main.c: the pmview command line: parse the options, load the scene and build what the session needs, then hand over to the snapshot or the window driver.
 *
 * Exit codes: 0 success, 1 a file could not be loaded, rendered or written, 2 a usage error.
 */
#include <math.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "accel.h"
#include "clock.h"
#include "cluster.h"
#include "defaults.h"
#include "drivers.h"
#include "image_io.h"
#include "loader.h"
#include "memory.h"
#include "options.h"
#include "report.h"
#include "runlog.h"
#include "scene.h"
#include "session.h"
#include "sky_choice.h"

/* ---- outputs and inputs ---- */

/* No output may be an input (the scene, the reference, the sky map) or another output: --log
 * naming the scene would overwrite it with CSV. One error line, before any work. */
static bool outputs_spare_inputs(const pm_options *o, bool window) {
    char screenshot_exr[4096] = "";
    if (window) snprintf(screenshot_exr, sizeof screenshot_exr, "%.*s.exr", (int)strlen(o->screenshot) - 4, o->screenshot);
    bool sky_file = o->sky && (pm_has_extension(o->sky, ".exr") || pm_has_extension(o->sky, ".hdr"));
    const struct { const char *path, *what; } inputs[] = {
        {o->scene_path, "the scene file"}, {o->reference, "the --reference image"}, {sky_file ? o->sky : NULL, "the --sky map"}};
    const struct { const char *path, *flag; } outputs[] = {
        {o->snapshot, "--snapshot"}, {pm_log_to_stdout(o->log) ? NULL : o->log, "--log"}, {window ? o->screenshot : NULL, "--screenshot"},
        {window ? screenshot_exr : NULL, "--screenshot's EXR"}};
    const int n_in = sizeof inputs / sizeof *inputs, n_out = sizeof outputs / sizeof *outputs;
    for (int i = 0; i < n_out; i++) {
        if (!outputs[i].path) continue;
        for (int k = 0; k < n_in; k++)
            if (inputs[k].path && pm_same_file(outputs[i].path, inputs[k].path)) {
                fprintf(stderr, "pmview: error: %s: %s would overwrite %s, an input\n", outputs[i].path, outputs[i].flag,
                        inputs[k].what);
                return false;
            }
        for (int k = i + 1; k < n_out; k++)
            if (outputs[k].path && pm_same_file(outputs[i].path, outputs[k].path)) {
                fprintf(stderr, "pmview: error: %s: %s and %s name the same file\n", outputs[i].path, outputs[i].flag,
                        outputs[k].flag);
                return false;
            }
    }
    return true;
}

/* What the set-up builds, for the driver and for the clean-up. */
typedef struct {
    pm_options opt;
    pm_sky_request sky;
    bool sky_prepared, scene_loaded;
    pm_scene scene;
    pm_accel *accel;
    pm_session *session;
    pm_reference_image reference;
    pm_camera camera;
    uint64_t output_reserved; /* the snapshot writers' room, admitted before the render */
    _Atomic(const char *) *stage; /* where the window reads the set-up's stage; NULL without a window */
    bool start_session;           /* the window's first scene, one process: its session starts, held, at the end
                                     of the set-up, so that its preview renders while the window opens */
    /* a reload asked by the window (--watch, a dropped file): */
    bool heap;                    /* allocated for it, freed with it */
    bool keep_camera;             /* `kept` replaces the file's camera */
    pm_camera kept;
    char scene_path[4096], sky_path[4096]; /* what opt's paths point at when they were given at run time */
    char variant[1024];                    /* what opt.variant points at when the window chose it */
    char error[1024];             /* the failure's line, without "pmview: error: " (for the window's title) */
} run_state;

/* A set-up's error: its line printed and kept for the window's title; returns code. */
static int failed(run_state *r, int code, const char *format, ...) {
    va_list args;
    va_start(args, format);
    vsnprintf(r->error, sizeof r->error, format, args);
    va_end(args);
    fprintf(stderr, "pmview: error: %s\n", r->error);
    return code;
}

/* The same for a failure whose callee printed its own line: only kept. */
static int noted(run_state *r, int code, const char *format, ...) {
    va_list args;
    va_start(args, format);
    vsnprintf(r->error, sizeof r->error, format, args);
    va_end(args);
    return code;
}

static void say_stage(run_state *r, const char *stage) {
    if (r->stage) atomic_store(r->stage, stage);
}

static void release(run_state *r) {
    if (r->sky_prepared) pm_sky_release(&r->sky);
    r->sky_prepared = false;
    pm_memory_release(r->output_reserved);
    r->output_reserved = 0;
    pm_reference_free(&r->reference);
    memset(&r->reference, 0, sizeof r->reference); /* (a state the window adopted is released again at the end) */
    pm_session_destroy(r->session);
    r->session = NULL;
    pm_accel_destroy(r->accel);
    r->accel = NULL;
    if (r->scene_loaded) pm_scene_free(&r->scene);
    r->scene_loaded = false;
}

/* What set_up's phases share besides the run state: the rank's part, the image's size as it
 * becomes known, and the line a callee writes its error into. */
typedef struct {
    pm_cluster *cluster;
    bool root;                   /* rank 0: it alone checks the outputs and reads the reference */
    const char *reference;       /* the reference image's path on rank 0, else NULL */
    int width, height;           /* height 0 until the camera gives the aspect */
    char err[1024];
} set_up_context;

/* Before any work: the outputs writable and sparing the inputs, the sky map and the reference
 * usable (a snapshot or a log that cannot be written would waste the whole render; a bad sky map
 * or reference costs no load and no BVH build). */
static int check_files(run_state *r, set_up_context *c, bool window) {
    pm_options *o = &r->opt;
    if (c->root && !outputs_spare_inputs(o, window)) return noted(r, 1, "an output would overwrite an input");
    if (c->root && o->snapshot && !pm_check_output_path(o->snapshot, c->err, sizeof c->err)) return failed(r, 1, "%s", c->err);
    /* the log too, here where a refusal reaches every rank through the set-up's agreement: opened
     * after it, a failure ended rank 0 alone and mpirun waited for ever on the others */
    if (c->root && o->log && !pm_log_to_stdout(o->log) && !pm_check_output_path(o->log, c->err, sizeof c->err)) {
        size_t named = strlen(o->log);
        const char *why = strncmp(c->err, o->log, named) == 0 && strncmp(c->err + named, ": ", 2) == 0 ? c->err + named + 2 : c->err;
        return failed(r, 1, "%s: cannot write the log (%s)", o->log, why);
    }
    r->sky = (pm_sky_request){.sky = o->sky, .no_default_light = o->no_default_light, .scene_path = o->scene_path,
                              .quiet = o->quiet, .stats = o->stats, .rotate_degrees = o->sky_rotate};
    /* (pm_sky_prepare and pm_choose_sky print their own line; the title gets a short one) */
    if (!pm_sky_prepare(&r->sky)) return noted(r, 1, "%s: the environment map cannot be used", o->sky);
    r->sky_prepared = true;
    c->width = o->width ? (int)o->width : PM_DEFAULT_WIDTH;
    c->height = (int)o->height;
    c->reference = c->root ? o->reference : NULL;
    /* (the reference's height is compared again once the camera gives the image's) */
    if (c->reference && !pm_reference_check(c->reference, c->width, c->height, c->err, sizeof c->err))
        return failed(r, 1, "%s", c->err);
    return -1;
}

/* The scene loaded and finalised, and the options' lengths brought to its units. */
static int load_scene(run_state *r, set_up_context *c) {
    pm_options *o = &r->opt;
    /* the forecast's baseline: code, libraries and (with a window) its context, before any scene */
    pm_memory_forecast_start();
    pm_load_report report;
    say_stage(r, "loading");
    pm_load_options load_options = {.flatten_instances = o->flatten_instances, .variant = o->variant};
    if (!pm_load_gltf_with(o->scene_path, &load_options, o->quiet, &r->scene, &report, c->err, sizeof c->err))
        return failed(r, 1, "%s", c->err);
    r->scene_loaded = true;
    pm_memory_forecast_phase(report.peak_bytes);
    uint64_t mark = pm_memory_failure_mark(); /* what the finalisation meets, never an older failure */
    bool finalized = pm_scene_finalize(&r->scene, false, NULL);
    pm_memory_forecast_hold((int64_t)pm_scene_bytes(&r->scene));
    if (finalized && r->scene.clamped_emission && !o->quiet)
        fprintf(stderr, "pmview: warning: %s: %u emission or light value(s) above %g (or not a number) clamped: a float film could not sum them\n",
                o->scene_path, r->scene.clamped_emission, (double)PM_MAX_EMISSION);
    if (!finalized) return failed(r, 1, "%s: out of memory (%s)", o->scene_path, pm_memory_failure_since_or(mark, "the scene's arrays"));
    if (o->stats) pm_print_load_stats(&report, &r->scene);
    /* the options' lengths are in the file's units; the loader may have rescaled the scene */
    o->radius *= report.unit_scale;
    o->max_radius *= report.unit_scale;
    if (o->radius > PM_MAX_RADIUS || o->max_radius > PM_MAX_RADIUS || (o->radius > 0 && o->radius < PM_MIN_RADIUS) ||
        (o->max_radius > 0 && o->max_radius < PM_MIN_RADIUS)) {
        fprintf(stderr, "pmview: %s: the file's units are scaled by %g: --radius or --max-radius is then outside 1e-18 to 1e18 scene units\n",
                o->scene_path, report.unit_scale);
        return 2;
    }
    return -1;
}

/* The camera (the file's, the one asked for, or one made to frame the scene; a reload's kept
 * camera over them all), which sets the image's height when none was given. */
static int place_camera(run_state *r, set_up_context *c) {
    pm_options *o = &r->opt;
    if (o->camera >= 0 && (uint32_t)o->camera >= r->scene.camera_count)
        return failed(r, 1, "%s: --camera %ld but the scene has %u perspective camera(s)", o->scene_path, o->camera,
                      r->scene.camera_count);
    if (r->scene.camera_count) {
        r->camera = r->scene.cameras[o->camera >= 0 ? o->camera : 0];
        if (!c->height) c->height = r->camera.aspect > 0.f ? (int)lroundf(c->width / r->camera.aspect) : c->width;
    } else {
        if (!c->height) c->height = c->width;
        r->camera = pm_scene_auto_camera(&r->scene, (float)c->width / c->height);
    }
    if (r->keep_camera) r->camera = r->kept;
    if (c->height < 1) c->height = 1;
    if (c->height > PM_MAX_IMAGE_SIDE) c->height = PM_MAX_IMAGE_SIDE;
    if (c->reference && !o->height && !pm_reference_check(c->reference, c->width, c->height, c->err, sizeof c->err))
        return failed(r, 1, "%s", c->err);
    return -1;
}

/* The BVH, then the environment, whose choice looks through the scene from the camera. */
static int build_accel(run_state *r, set_up_context *c) {
    pm_options *o = &r->opt;
    say_stage(r, "building the BVH of");
    pm_memory_forecast_phase(pm_accel_forecast_bytes(&r->scene, true));
    pm_memory_forecast_hold((int64_t)pm_accel_forecast_bytes(&r->scene, false));
    r->accel = pm_accel_create(&r->scene, c->err, sizeof c->err);
    if (!r->accel) return failed(r, 1, "%s: %s", o->scene_path, c->err);
    if (o->stats) pm_print_bvh_stats(r->accel);
    if (!pm_choose_sky(&r->sky, &r->scene, r->accel, &r->camera, (float)c->width / c->height))
        return noted(r, 1, "%s: the environment map cannot be used", o->sky ? o->sky : "the sky");
    if (o->stats) pm_print_analysis_stats(&r->scene);
    return -1;
}

/* The render session, this rank's share of the cluster's iterations, and the film's memory. */
static int create_session(run_state *r, set_up_context *c) {
    pm_options *o = &r->opt;
    say_stage(r, "setting up");
    pm_session_config config;
    /* each rank renders iterations of its own: rank 0 with the seed given, the others apart */
    long seed = o->seed;
    o->seed = (long)pm_cluster_seed(c->cluster, (uint64_t)seed);
    pm_options_session_config(o, &r->scene, c->width, c->height, &config);
    o->seed = seed;
    config.progressive.radius_steps = (uint32_t)pm_cluster_size(c->cluster);
    config.progressive.caustics_kept = pm_cluster_size(c->cluster) > 1;
    /* the window's --iterations is the whole image's too */
    if (config.max_iterations) {
        uint32_t share = pm_cluster_share(c->cluster, config.max_iterations);
        config.max_iterations = share ? share : 1;
    }
    r->session = pm_session_create(&r->scene, r->accel, &r->camera, &config, c->err, sizeof c->err);
    if (!r->session) return failed(r, 1, "%s: %s", o->scene_path, c->err);
    if (!pm_cluster_prepare(c->cluster, pm_session_film(r->session)))
        return failed(r, 1, "%s: %s", o->scene_path, pm_cluster_error(c->cluster));
    /* from here a signal is the snapshot's: the image so far (none yet) is written, 130 or 143;
     * before, it ends the process at once */
    if (o->snapshot) pm_snapshot_catch_signals(r->session);
    pm_memory_forecast_hold((int64_t)pm_session_forecast_bytes(r->session));
    /* each iteration that can be cancelled holds a copy of the film while it runs */
    pm_memory_forecast_phase(pm_film_copy_bytes(pm_session_film(r->session)));
    if (o->stats) {
        pm_print_film_stats(pm_session_film(r->session));
        fflush(stdout); /* a script waiting for the render to start sees it */
    }
    return -1;
}

/* The outputs' set-up: rank 0's room for the snapshot's writers, admitted before the render; the
 * reference, read and matched to the image's size; and the window's session, held until the window
 * shows its preview. */
static int prepare_outputs(run_state *r, set_up_context *c) {
    pm_options *o = &r->opt;
    if (o->snapshot && c->root) {
        uint64_t bytes = pm_snapshot_output_bytes(o->snapshot, pm_session_film(r->session));
        uint64_t mark = pm_memory_failure_mark();
        if (!pm_memory_admit(bytes, pm_has_extension(o->snapshot, ".png") ? "PNG output buffers" : "EXR output buffers"))
            return failed(r, 1, "%s: out of memory (%s)", o->snapshot, pm_memory_failure_since_or(mark, "output buffers"));
        r->output_reserved = bytes;
        /* a PNG is composed by the display shader in an offscreen context made for it (its
         * library opened then) */
        pm_memory_forecast_phase(bytes + (pm_has_extension(o->snapshot, ".png") ? PM_GL_RESIDENT_BYTES + PM_OSMESA_LIBRARY_BYTES : 0));
    }
    if (c->reference) {
        if (!pm_reference_load(c->reference, o->log != NULL, &r->reference, c->err, sizeof c->err)) return failed(r, 1, "%s", c->err);
        if (r->reference.width != c->width || r->reference.height != c->height)
            return failed(r, 1, "%s: the reference is %dx%d but the image is %dx%d (use --width/--height)", c->reference,
                          r->reference.width, r->reference.height, c->width, c->height);
    }
    if (r->start_session) {
        pm_session_hold(r->session, true); /* (released by the window, once it shows the preview) */
        if (!pm_session_start(r->session, c->err, sizeof c->err)) return failed(r, 1, "%s", c->err);
    }
    return -1;
}

/* Everything before the render, phase by phase: -1 when it is ready, else the exit code (its line
 * printed). Under mpirun every rank sets up its own scene and session; only rank 0 checks the
 * outputs and the reference, which only it reads or writes. */
static int set_up(pm_cluster *cluster, run_state *r, bool window) {
    set_up_context c = {.cluster = cluster, .root = pm_cluster_rank(cluster) == 0};
    int code = check_files(r, &c, window);
    if (code < 0) code = load_scene(r, &c);
    if (code < 0) code = place_camera(r, &c);
    if (code < 0) code = build_accel(r, &c);
    if (code < 0) code = create_session(r, &c);
    if (code < 0) code = prepare_outputs(r, &c);
    return code;
}

typedef struct {
    pm_cluster *cluster;
    run_state *r;
} window_set_up;

static int set_up_for_window(void *arg) {
    window_set_up *w = arg;
    return set_up(w->cluster, w->r, true);
}

/* ---- reloads asked by the window (--watch, a dropped file, the variant key): the start-up's set-up again ---- */

typedef struct {
    pm_options parsed; /* the options as given (set_up rescales some by the file's units) */
    run_state *current;
} reloads;

static void window_scene_of(run_state *r, pm_window_scene *out) {
    *out = (pm_window_scene){.scene = &r->scene, .accel = r->accel, .session = r->session, .camera = r->camera,
                             .reference = r->reference.rgb[0] ? &r->reference : NULL, .handle = r};
}

static bool reload(void *context, const pm_window_reload *ask, pm_window_scene *out, char *err, size_t err_size) {
    reloads *c = context;
    uint64_t mark = pm_memory_failure_mark();
    run_state *fresh = pm_calloc(1, sizeof *fresh, "the reloaded scene's state");
    if (!fresh) { snprintf(err, err_size, "out of memory (%s)", pm_memory_failure_since_or(mark, "the reloaded scene's state")); return false; }
    fresh->heap = true;
    fresh->opt = c->parsed;
    snprintf(fresh->scene_path, sizeof fresh->scene_path, "%s", ask->scene_path);
    fresh->opt.scene_path = fresh->scene_path;
    if (ask->sky) {
        snprintf(fresh->sky_path, sizeof fresh->sky_path, "%s", ask->sky);
        fresh->opt.sky = fresh->sky_path;
    }
    if (ask->variant) {
        snprintf(fresh->variant, sizeof fresh->variant, "%s", ask->variant);
        fresh->opt.variant = fresh->variant;
    } else {
        fresh->opt.variant = NULL;
    }
    fresh->opt.width = ask->width;
    fresh->opt.height = ask->height;
    fresh->opt.stats = false; /* the stat lines describe the start-up's scene */
    if (ask->camera) {
        fresh->keep_camera = true;
        fresh->kept = *ask->camera;
    } else {
        fresh->opt.camera = -1; /* another file: its first camera, or the framing */
    }
    if (set_up(NULL, fresh, true) >= 0) {
        snprintf(err, err_size, "%s", fresh->error[0] ? fresh->error : "the set-up failed");
        release(fresh);
        free(fresh);
        return false;
    }
    window_scene_of(fresh, out);
    return true;
}

static void drop_state(run_state *r) {
    release(r);
    if (r->heap) free(r);
}

static void adopt(void *context, const pm_window_scene *next) {
    reloads *c = context;
    drop_state(c->current);
    c->current = next->handle;
}

static void discard(void *context, const pm_window_scene *loaded) {
    (void)context;
    drop_state(loaded->handle);
}

int main(int argc, char **argv) {
    double process_start = pm_now_seconds();
    /* A file-size limit (ulimit -f, as a full quota gives) must make a write fail with EFBIG,
     * reported by the writer in one line and its temporary file removed, rather than kill the
     * process with SIGXFSZ mid-write. */
    signal(SIGXFSZ, SIG_IGN);
    /* under mpirun, every rank runs all of this; rank 0 alone speaks and writes */
    pm_cluster *cluster = pm_cluster_join(&argc, &argv);
    run_state r;
    memset(&r, 0, sizeof r);
    int code = pm_options_parse(argc, argv, &r.opt);
    reloads reloaded = {.parsed = r.opt, .current = &r};
    /* a reload runs the whole set-up again in one process: under mpirun every rank would have to
     * reload alike, so --watch is refused there at once (a file dropped on the window only says so
     * in its title) */
    if (code < 0 && cluster && r.opt.watch) {
        fprintf(stderr, "pmview: --watch is for a single process, not under mpirun (every rank would have to reload alike)\n");
        code = 2;
    }
    pm_window *window = NULL;
    if (code < 0) {
        setvbuf(stdout, NULL, _IOLBF, 0);
        if (r.opt.max_memory) pm_memory_set_limit(r.opt.max_memory);
        bool wants_window = !r.opt.snapshot;
        /* rank 0's window opens first and shows the set-up's progress: a big scene takes seconds
         * to load and build, and Esc must answer meanwhile */
        if (wants_window && pm_cluster_rank(cluster) == 0) {
            /* the set-up starts first, on a thread: the scene loads while the window is made */
            window_set_up job = {cluster, &r};
            pm_window_job wait = {.work = set_up_for_window, .arg = &job, .scene_path = r.opt.scene_path};
            atomic_init(&wait.stage, NULL);
            r.stage = &wait.stage;
            /* (under mpirun every rank's session starts once the ranks have agreed) */
            r.start_session = !cluster;
            if (getenv("DISPLAY")) pm_window_job_start(&wait); /* (without one the window is refused at once) */
            code = pm_window_open(&r.opt, cluster, process_start, &window);
            if (code < 0) {
                code = pm_window_wait(window, cluster, &wait);
            } else {
                if (wait.started) {
                    int set_up_code = pm_window_job_finish(&wait); /* its error line, if any, came first */
                    if (set_up_code >= 0) code = set_up_code;
                }
            }
            r.stage = NULL;
        } else if (code < 0) {
            code = set_up(cluster, &r, wants_window);
        }
    }
    /* what every rank must share: the scene it loaded and the command line it was given */
    uint64_t digest = cluster && code < 0 && r.scene_loaded ? pm_scene_digest(&r.scene) : 0;
    for (int i = 1; cluster && i < argc; i++)
        for (const char *c = argv[i]; ; c++) {
            digest = (digest ^ (unsigned char)*c) * 1099511628211ull;
            if (!*c) break;
        }
    code = pm_cluster_agree(cluster, code, digest);
    if (code < 0) {
        const pm_options *o = &r.opt;
        if (o->snapshot) {
            code = pm_snapshot_run(o, cluster, r.session, &r.reference, &r.output_reserved);
        } else if (pm_cluster_rank(cluster) == 0) {
            pm_window_scene start;
            window_scene_of(&r, &start);
            /* reloads are a single process's: under mpirun every rank would have to load alike */
            pm_window_reloader reloader = {.load = reload, .adopt = adopt, .discard = discard, .context = &reloaded};
            code = pm_window_run(window, o, cluster, &start, cluster ? NULL : &reloader);
        } else {
            code = pm_cluster_follow(cluster, r.session);
        }
        run_state *last = reloaded.current; /* the window's last scene */
        if (code != 1 && o->stats) {
            pm_print_final_stats(last->session, last->accel, (int)o->threads, o->alpha, o->mode == PM_MODE_PATHTRACE);
            pm_print_cluster_stats(cluster);
        }
    }
    pm_window_close(window);
    if (reloaded.current != &r) drop_state(reloaded.current);
    release(&r);
    pm_cluster_leave(cluster);
    return code;
}

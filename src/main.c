/* main.c: the pmview command line: parse the options, load the scene and build what the session needs, then hand over to the snapshot or the window driver.
 *
 * Exit codes: 0 success, 1 a file could not be loaded, rendered or written, 2 a usage error.
 */
#include <math.h>
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
        {o->snapshot, "--snapshot"}, {o->log, "--log"}, {window ? o->screenshot : NULL, "--screenshot"},
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
} run_state;

static void say_stage(run_state *r, const char *stage) {
    if (r->stage) atomic_store(r->stage, stage);
}

static void release(run_state *r) {
    if (r->sky_prepared) pm_sky_release(&r->sky);
    pm_memory_release(r->output_reserved);
    pm_reference_free(&r->reference);
    pm_session_destroy(r->session);
    pm_accel_destroy(r->accel);
    if (r->scene_loaded) pm_scene_free(&r->scene);
}

/* Everything before the render: -1 when it is ready, else the exit code (its line printed). Under
 * mpirun every rank sets up its own scene and session; only rank 0 checks the outputs and the
 * reference, which only it reads or writes. */
static int set_up(pm_cluster *cluster, run_state *r, bool window) {
    pm_options *o = &r->opt;
    char err[1024] = "";
    bool root = pm_cluster_rank(cluster) == 0;
    if (root && !outputs_spare_inputs(o, window)) return 1;
    /* before any work: a snapshot that cannot be written would waste the whole render */
    if (root && o->snapshot && !pm_check_output_path(o->snapshot, err, sizeof err)) {
        fprintf(stderr, "pmview: error: %s\n", err);
        return 1;
    }
    /* the log too, here where a refusal reaches every rank through the set-up's agreement: opened
     * after it, a failure ended rank 0 alone and mpirun waited for ever on the others */
    if (root && o->log && !pm_check_output_path(o->log, err, sizeof err)) {
        size_t named = strlen(o->log);
        const char *why = strncmp(err, o->log, named) == 0 && strncmp(err + named, ": ", 2) == 0 ? err + named + 2 : err;
        fprintf(stderr, "pmview: error: %s: cannot write the log (%s)\n", o->log, why);
        return 1;
    }
    /* before the scene too: a sky map or a reference that cannot be used costs no load and no BVH
     * build (the reference's height is compared once the camera gives the image's) */
    r->sky = (pm_sky_request){.sky = o->sky, .no_default_light = o->no_default_light, .scene_path = o->scene_path,
                              .quiet = o->quiet, .stats = o->stats};
    if (!pm_sky_prepare(&r->sky)) return 1;
    r->sky_prepared = true;
    int width = o->width ? (int)o->width : PM_DEFAULT_WIDTH, height = (int)o->height;
    const char *reference = root ? o->reference : NULL;
    if (reference && !pm_reference_check(reference, width, height, err, sizeof err)) {
        fprintf(stderr, "pmview: error: %s\n", err);
        return 1;
    }
    /* the forecast's baseline: code, libraries and (with a window) its context, before any scene */
    pm_memory_forecast_start();
    pm_load_report report;
    say_stage(r, "loading");
    pm_load_options load_options = {.flatten_instances = o->flatten_instances};
    if (!pm_load_gltf_with(o->scene_path, &load_options, o->quiet, &r->scene, &report, err, sizeof err)) {
        fprintf(stderr, "pmview: error: %s\n", err);
        return 1;
    }
    r->scene_loaded = true;
    pm_memory_forecast_phase(report.peak_bytes);
    bool finalized = pm_scene_finalize(&r->scene, false, NULL);
    pm_memory_forecast_hold((int64_t)pm_scene_bytes(&r->scene));
    if (finalized && r->scene.clamped_emission && !o->quiet)
        fprintf(stderr, "pmview: warning: %s: %u emission or light value(s) above %g (or not a number) clamped: a float film could not sum them\n",
                o->scene_path, r->scene.clamped_emission, (double)PM_MAX_EMISSION);
    if (!finalized) {
        fprintf(stderr, "pmview: error: %s: out of memory (%s)\n", o->scene_path, pm_memory_failure());
        return 1;
    }
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
    if (o->camera >= 0 && (uint32_t)o->camera >= r->scene.camera_count) {
        fprintf(stderr, "pmview: error: %s: --camera %ld but the scene has %u perspective camera(s)\n", o->scene_path, o->camera,
                r->scene.camera_count);
        return 1;
    }
    if (r->scene.camera_count) {
        r->camera = r->scene.cameras[o->camera >= 0 ? o->camera : 0];
        if (!height) height = r->camera.aspect > 0.f ? (int)lroundf(width / r->camera.aspect) : width;
    } else {
        if (!height) height = width;
        r->camera = pm_scene_auto_camera(&r->scene, (float)width / height);
    }
    if (height < 1) height = 1;
    if (height > PM_MAX_IMAGE_SIDE) height = PM_MAX_IMAGE_SIDE;
    if (reference && !o->height && !pm_reference_check(reference, width, height, err, sizeof err)) {
        fprintf(stderr, "pmview: error: %s\n", err);
        return 1;
    }

    say_stage(r, "building the BVH of");
    pm_memory_forecast_phase(pm_accel_forecast_bytes(&r->scene, true));
    pm_memory_forecast_hold((int64_t)pm_accel_forecast_bytes(&r->scene, false));
    r->accel = pm_accel_create(&r->scene, err, sizeof err);
    if (!r->accel) { fprintf(stderr, "pmview: error: %s: %s\n", o->scene_path, err); return 1; }
    if (o->stats) pm_print_bvh_stats(r->accel);
    if (!pm_choose_sky(&r->sky, &r->scene, r->accel, &r->camera, (float)width / height)) return 1;
    if (o->stats) pm_print_analysis_stats(&r->scene);

    say_stage(r, "setting up");
    pm_session_config config;
    /* each rank renders iterations of its own: rank 0 with the seed given, the others apart */
    long seed = o->seed;
    o->seed = (long)pm_cluster_seed(cluster, (uint64_t)seed);
    pm_options_session_config(o, &r->scene, width, height, &config);
    o->seed = seed;
    config.progressive.radius_steps = (uint32_t)pm_cluster_size(cluster);
    /* the window's --iterations is the whole image's too */
    if (config.max_iterations) {
        uint32_t share = pm_cluster_share(cluster, config.max_iterations);
        config.max_iterations = share ? share : 1;
    }
    r->session = pm_session_create(&r->scene, r->accel, &r->camera, &config, err, sizeof err);
    if (!r->session) { fprintf(stderr, "pmview: error: %s: %s\n", o->scene_path, err); return 1; }
    if (!pm_cluster_prepare(cluster, pm_session_film(r->session))) {
        fprintf(stderr, "pmview: error: %s: %s\n", o->scene_path, pm_cluster_error(cluster));
        return 1;
    }
    /* from here a signal is the snapshot's: the image so far (none yet) is written, 130 or 143;
     * before, it ends the process at once */
    if (o->snapshot) pm_snapshot_catch_signals(r->session);
    pm_memory_forecast_hold((int64_t)pm_session_forecast_bytes(r->session));
    if (o->stats) {
        pm_print_film_stats(pm_session_film(r->session));
        fflush(stdout); /* a script waiting for the render to start sees it */
    }
    if (o->snapshot && root) {
        uint64_t bytes = pm_snapshot_output_bytes(o->snapshot, pm_session_film(r->session));
        if (!pm_memory_admit(bytes, pm_has_extension(o->snapshot, ".png") ? "PNG output buffers" : "EXR output buffers")) {
            fprintf(stderr, "pmview: error: %s: out of memory (%s)\n", o->snapshot, pm_memory_failure());
            return 1;
        }
        r->output_reserved = bytes;
        /* a PNG is composed by the display shader in an offscreen context made for it */
        pm_memory_forecast_phase(bytes + (pm_has_extension(o->snapshot, ".png") ? PM_GL_RESIDENT_BYTES : 0));
    }
    if (reference) {
        if (!pm_reference_load(reference, o->log != NULL, &r->reference, err, sizeof err)) {
            fprintf(stderr, "pmview: error: %s\n", err);
            return 1;
        }
        if (r->reference.width != width || r->reference.height != height) {
            fprintf(stderr, "pmview: error: %s: the reference is %dx%d but the image is %dx%d (use --width/--height)\n", reference,
                    r->reference.width, r->reference.height, width, height);
            return 1;
        }
    }
    return -1;
}

typedef struct {
    pm_cluster *cluster;
    run_state *r;
} window_set_up;

static int set_up_for_window(void *arg) {
    window_set_up *w = arg;
    return set_up(w->cluster, w->r, true);
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
    pm_window *window = NULL;
    if (code < 0) {
        setvbuf(stdout, NULL, _IOLBF, 0);
        if (r.opt.max_memory) pm_memory_set_limit(r.opt.max_memory);
        bool wants_window = !r.opt.snapshot;
        /* rank 0's window opens first and shows the set-up's progress: a big scene takes seconds
         * to load and build, and Esc must answer meanwhile */
        if (wants_window && pm_cluster_rank(cluster) == 0) code = pm_window_open(&r.opt, cluster, process_start, &window);
        if (code < 0 && window) {
            window_set_up job = {cluster, &r};
            pm_window_job wait = {.work = set_up_for_window, .arg = &job, .scene_path = r.opt.scene_path};
            atomic_init(&wait.stage, NULL);
            r.stage = &wait.stage;
            code = pm_window_wait(window, cluster, &wait);
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
        if (o->snapshot) code = pm_snapshot_run(o, cluster, r.session, &r.reference, &r.output_reserved);
        else if (pm_cluster_rank(cluster) == 0) code = pm_window_run(window, o, cluster, &r.scene, r.accel, r.session, &r.camera);
        else code = pm_cluster_follow(cluster, r.session);
        if (code != 1 && o->stats) {
            pm_print_final_stats(r.session, r.accel, (int)o->threads, o->alpha, o->mode == PM_MODE_PATHTRACE);
            pm_print_cluster_stats(cluster);
        }
    }
    pm_window_close(window);
    release(&r);
    pm_cluster_leave(cluster);
    return code;
}

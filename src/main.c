/* main.c: the pmview command line: parse the options, load the scene and build what the session needs, then hand over to the snapshot or the window driver.
 *
 * Exit codes: 0 success, 1 a file could not be loaded, rendered or written, 2 a usage error.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "accel.h"
#include "clock.h"
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

int main(int argc, char **argv) {
    double process_start = pm_now_seconds();
    pm_options opt;
    int code = pm_options_parse(argc, argv, &opt);
    if (code >= 0) return code;
    setvbuf(stdout, NULL, _IOLBF, 0);
    if (opt.max_memory) pm_memory_set_limit(opt.max_memory);

    bool window = !opt.snapshot;
    if (window && !getenv("DISPLAY")) {
        fprintf(stderr, "pmview: no DISPLAY for a window; use --snapshot FILE.png|FILE.exr to render offscreen\n");
        return 2;
    }

    char err[1024] = "";
    if (!outputs_spare_inputs(&opt, window)) return 1;
    /* before any work: a snapshot that cannot be written would waste the whole render */
    if (opt.snapshot && !pm_check_output_path(opt.snapshot, err, sizeof err)) {
        fprintf(stderr, "pmview: error: %s\n", err);
        return 1;
    }
    /* before the scene too: a sky map or a reference that cannot be used costs no load and no BVH
     * build (the reference's height is compared once the camera gives the image's) */
    pm_sky_request sky = {.sky = opt.sky, .no_default_light = opt.no_default_light, .scene_path = opt.scene_path,
                          .quiet = opt.quiet, .stats = opt.stats};
    if (!pm_sky_prepare(&sky)) return 1;
    int width = opt.width ? (int)opt.width : PM_DEFAULT_WIDTH, height = (int)opt.height;
    if (opt.reference && !pm_reference_check(opt.reference, width, height, err, sizeof err)) {
        fprintf(stderr, "pmview: error: %s\n", err);
        pm_sky_release(&sky);
        return 1;
    }
    pm_scene scene;
    pm_load_report report;
    if (!pm_load_gltf(opt.scene_path, opt.quiet, &scene, &report, err, sizeof err)) {
        fprintf(stderr, "pmview: error: %s\n", err);
        pm_sky_release(&sky);
        return 1;
    }
    bool finalized = pm_scene_finalize(&scene, false, NULL);
    if (finalized && scene.clamped_emission && !opt.quiet)
        fprintf(stderr, "pmview: warning: %s: %u emission or light value(s) above %g (or not a number) clamped: a float film could not sum them\n",
                opt.scene_path, scene.clamped_emission, (double)PM_MAX_EMISSION);
    if (!finalized) {
        fprintf(stderr, "pmview: error: %s: out of memory (%s)\n", opt.scene_path, pm_memory_failure());
        pm_scene_free(&scene);
        pm_sky_release(&sky);
        return 1;
    }
    if (opt.stats) pm_print_load_stats(&report, &scene);
    /* the options' lengths are in the file's units; the loader may have rescaled the scene */
    opt.radius *= report.unit_scale;
    opt.max_radius *= report.unit_scale;
    if (opt.radius > PM_MAX_RADIUS || opt.max_radius > PM_MAX_RADIUS || (opt.radius > 0 && opt.radius < PM_MIN_RADIUS) ||
        (opt.max_radius > 0 && opt.max_radius < PM_MIN_RADIUS)) {
        fprintf(stderr, "pmview: %s: the file's units are scaled by %g: --radius or --max-radius is then outside 1e-18 to 1e18 scene units\n",
                opt.scene_path, report.unit_scale);
        pm_scene_free(&scene);
        pm_sky_release(&sky);
        return 2;
    }

    int exit_code = 0;
    uint64_t output_reserved = 0; /* the snapshot writers' room, admitted before the render */
    pm_accel *accel = NULL;
    pm_session *session = NULL;
    pm_reference_image reference;
    memset(&reference, 0, sizeof reference);

    pm_camera camera;
    if (opt.camera >= 0 && (uint32_t)opt.camera >= scene.camera_count) {
        fprintf(stderr, "pmview: error: %s: --camera %ld but the scene has %u perspective camera(s)\n", opt.scene_path,
                opt.camera, scene.camera_count);
        exit_code = 1;
        goto done;
    }
    if (scene.camera_count) {
        camera = scene.cameras[opt.camera >= 0 ? opt.camera : 0];
        if (!height) height = camera.aspect > 0.f ? (int)lroundf(width / camera.aspect) : width;
    } else {
        if (!height) height = width;
        camera = pm_scene_auto_camera(&scene, (float)width / height);
    }
    if (height < 1) height = 1;
    if (height > PM_MAX_IMAGE_SIDE) height = PM_MAX_IMAGE_SIDE;
    if (opt.reference && !opt.height && !pm_reference_check(opt.reference, width, height, err, sizeof err)) {
        fprintf(stderr, "pmview: error: %s\n", err);
        exit_code = 1;
        goto done;
    }

    accel = pm_accel_create(&scene, err, sizeof err);
    if (!accel) { fprintf(stderr, "pmview: error: %s: %s\n", opt.scene_path, err); exit_code = 1; goto done; }
    if (opt.stats) pm_print_bvh_stats(accel);
    if (!pm_choose_sky(&sky, &scene, accel, &camera, (float)width / height)) { exit_code = 1; goto done; }
    if (opt.stats) pm_print_analysis_stats(&scene);

    pm_session_config config;
    pm_options_session_config(&opt, &scene, width, height, &config);
    session = pm_session_create(&scene, accel, &camera, &config, err, sizeof err);
    if (!session) { fprintf(stderr, "pmview: error: %s: %s\n", opt.scene_path, err); exit_code = 1; goto done; }
    /* from here a signal is the snapshot's: the image so far (none yet) is written, 130 or 143;
     * before, it ends the process at once */
    if (opt.snapshot) pm_snapshot_catch_signals(session);
    if (opt.stats) {
        pm_print_film_stats(pm_session_film(session));
        fflush(stdout); /* a script waiting for the render to start sees it */
    }
    if (opt.snapshot) {
        uint64_t bytes = pm_snapshot_output_bytes(opt.snapshot, pm_session_film(session));
        if (!pm_memory_admit(bytes, pm_has_extension(opt.snapshot, ".png") ? "PNG output buffers" : "EXR output buffers")) {
            fprintf(stderr, "pmview: error: %s: out of memory (%s)\n", opt.snapshot, pm_memory_failure());
            exit_code = 1;
            goto done;
        }
        output_reserved = bytes;
    }
    if (opt.reference) {
        if (!pm_reference_load(opt.reference, opt.log != NULL, &reference, err, sizeof err)) {
            fprintf(stderr, "pmview: error: %s\n", err);
            exit_code = 1;
            goto done;
        }
        if (reference.width != width || reference.height != height) {
            fprintf(stderr, "pmview: error: %s: the reference is %dx%d but the image is %dx%d (use --width/--height)\n",
                    opt.reference, reference.width, reference.height, width, height);
            exit_code = 1;
            goto done;
        }
    }
    exit_code = window ? pm_window_run(&opt, &scene, accel, session, &camera, process_start)
                       : pm_snapshot_run(&opt, session, &reference, &output_reserved);
    if (exit_code == 1) goto done;
    if (opt.stats) pm_print_final_stats(session, accel, (int)opt.threads, opt.alpha, opt.mode == PM_MODE_PATHTRACE);

done:
    pm_sky_release(&sky);
    pm_memory_release(output_reserved);
    pm_reference_free(&reference);
    pm_session_destroy(session);
    pm_accel_destroy(accel);
    pm_scene_free(&scene);
    return exit_code;
}

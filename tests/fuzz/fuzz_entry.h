/* fuzz_entry.h: one fuzz input through the whole pipeline (load from memory, scene set-up, accel, one tiny progressive render), shared by the libFuzzer target and the regression replay.
 *
 * Header-only so that the libFuzzer target (clang, tests/fuzz/fuzz_target.c) and the replay test
 * (gcc under ASan/UBSan, tests/test_fuzz_regressions.c) run the very same code without libFuzzer.
 * The input is read as GLB when it starts with "glTF", else as glTF JSON; external files are
 * unavailable (pm_load_gltf_memory). A refused input is a normal outcome; what counts is that
 * nothing crashes, overflows, leaks or runs away.
 */
#ifndef PM_FUZZ_ENTRY_H
#define PM_FUZZ_ENTRY_H

#include <math.h>
#include <stdio.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "accel.h"
#include "defaults.h"
#include "loader.h"
#include "memory.h"
#include "scene.h"
#include "session.h"

/* How far an input got: what the replay test reports and asserts on known-good inputs. */
typedef enum {
    PM_FUZZ_REFUSED = 0,      /* the loader refused it (one error line) */
    PM_FUZZ_LOADED = 1,       /* loaded, then the set-up or accel refused it (out of memory, Embree) */
    PM_FUZZ_RENDERED = 2,     /* one iteration rendered */
} pm_fuzz_stage;

enum { PM_FUZZ_SIDE = 8, PM_FUZZ_PHOTONS = 256 };

typedef struct {
    pm_fuzz_stage stage;
    uint32_t triangles;
    uint64_t nonfinite_values;   /* NaN or Inf values in the resolved image */
    char error[512];             /* the loader's or the set-up's message when refused */
} pm_fuzz_result;

static pm_fuzz_result pm_fuzz_run(const uint8_t *data, size_t size) {
    pm_fuzz_result r;
    memset(&r, 0, sizeof r);
    pm_scene scene;
    const char *name = size >= 4 && !memcmp(data, "glTF", 4) ? "fuzz-input.glb" : "fuzz-input.gltf";
    if (!pm_load_gltf_memory(data, size, name, true, &scene, NULL, r.error, sizeof r.error)) return r;
    r.stage = PM_FUZZ_LOADED;
    r.triangles = scene.triangle_count;
    bool finalized = pm_scene_finalize(&scene, false, NULL);
    pm_accel *accel = NULL;
    pm_session *session = NULL;
    if (!finalized) {
        snprintf(r.error, sizeof r.error, "out of memory (%s)", pm_memory_failure());
        goto done;
    }
    /* as main does for a file without lights: the environment lights it (here uniform white) */
    if (scene.light_count == 0 && scene.emitter_count == 0) pm_scene_set_sky(&scene, true, v3s(1.f), NULL);
    pm_camera camera = scene.camera_count ? scene.cameras[0] : pm_scene_auto_camera(&scene, 1.f);
    accel = pm_accel_create(&scene, r.error, sizeof r.error);
    if (!accel) goto done;

    pm_session_config config;
    pm_session_config_defaults(&config, PM_MODE_PROGRESSIVE, PM_FUZZ_SIDE, PM_FUZZ_SIDE, 1, 1);
    config.progressive.photons = config.progressive.caustic_photons = PM_FUZZ_PHOTONS;
    session = pm_session_create(&scene, accel, &camera, &config, r.error, sizeof r.error);
    if (!session) goto done;
    if (!pm_session_iterate(session, 0)) {
        snprintf(r.error, sizeof r.error, "%s", pm_session_error(session));
        goto done;
    }
    r.stage = PM_FUZZ_RENDERED;
    const pm_film *film = pm_session_film(session);
    float total[PM_FUZZ_SIDE * PM_FUZZ_SIDE * 3];
    if (pm_film_resolve_total(film, total))
        for (size_t i = 0; i < sizeof total / sizeof total[0]; i++)
            if (!isfinite(total[i])) r.nonfinite_values++;
done:
    pm_session_destroy(session);
    pm_accel_destroy(accel);
    pm_scene_free(&scene);
    return r;
}

#endif

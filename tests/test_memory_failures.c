/* test_memory_failures.c: every checked allocation of a render made to fail in turn, and the memory limit refusing a photon pass: a reason each time, never a crash or (ASan) a leak. */
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "accel.h"
#include "clock.h"
#include "defaults.h"
#include "memory.h"
#include "photonmap.h"
#include "progressive.h"
#include "scene_builder.h"
#include "testing.h"

/* A glass ball and a mirror ball in a grey box, lit by two point lights: caustic photons,
 * projection maps (one per light, built in parallel) and camera splats all allocate. */
static pm_accel *caustic_box(pm_scene *s, pm_camera *cam) {
    memset(s, 0, sizeof *s);
    sb_box(s, v3s(-1.f), v3s(1.f), sb_lambert(s, v3s(0.5f)), true);
    sb_sphere(s, v3(-0.4f, -0.6f, 0.f), 0.3f, 16, sb_material(s, v3s(1.f), 0, 0, 1, v3s(0), false));
    sb_sphere(s, v3(0.4f, -0.6f, 0.2f), 0.3f, 16, sb_material(s, v3s(0.9f), 1, 0, 0, v3s(0), false));
    sb_point_light(s, v3(0.f, 0.8f, 0.f), v3s(1.f));
    sb_point_light(s, v3(0.5f, 0.7f, -0.5f), v3s(0.5f));
    *cam = sb_camera(v3(0.f, 0.f, 0.95f), v3(0.f, -0.3f, 0.f), v3(0.f, 1.f, 0.f), 60.f);
    return sb_finish(s);
}

/* Every checked allocation of a progressive session's set-up and first two iterations made to
 * fail in turn: each failure is reported (pm_memory_failure names what), the call returns
 * false, nothing crashes and (under ASan) nothing leaks. */
static void test_allocation_failures(bool caustics) {
    pm_scene s;
    pm_camera cam;
    pm_accel *a = caustics ? caustic_box(&s, &cam) : sb_furnace(&s, 0.5f, 1.f, &cam);
    enum { W = 8, H = 8 };
    pm_progressive_settings ps = {.seed = 1, .threads = 2, .photons = 3000, .caustic_photons = 3000, .alpha = PM_DEFAULT_ALPHA,
                                  .indirect = PM_INDIRECT_GATHER, .max_specular_depth = PM_DEFAULT_MAX_SPECULAR_DEPTH,
                                  .max_photon_bounces = PM_DEFAULT_MAX_PHOTON_BOUNCES};
    uint64_t total = 0;
    int failures_seen = 0, unreported = 0;
    for (uint64_t n = 0;; n++) {
        pm_memory_clear_failure();
        pm_memory_fail_at(n, false);
        char err[256] = "";
        bool ok = true;
        pm_progressive *p = pm_progressive_create(&s, a, &cam, &ps, err, sizeof err);
        pm_film film;
        memset(&film, 0, sizeof film);
        if (!p) ok = false;
        bool components[PM_COMPONENT_COUNT];
        if (ok) pm_progressive_components(p, components);
        if (ok && (!pm_film_init(&film, W, H, components) || !pm_progressive_bind(p, &film, err, sizeof err))) ok = false;
        for (int i = 0; ok && i < 2; i++) ok = pm_progressive_iterate(p, &film, 0);
        pm_progressive_destroy(p);
        pm_film_free(&film);
        if (n == 0) {
            total = pm_memory_allocations();
            CHECK(ok, "the run without an injected failure succeeds");
            continue;
        }
        if (!ok) failures_seen++;
        if (!ok && !pm_memory_failure()) unreported++;
        if (n > total) break;
    }
    pm_memory_fail_at(0, false);
    pm_memory_clear_failure();
    printf("allocation failures (%s): %llu checked allocations, %d failing runs, %d without a reason\n",
           caustics ? "glass and mirror balls, point lights" : "furnace", (unsigned long long)total, failures_seen, unreported);
    CHECK(total >= 10 && failures_seen >= (int)total - 2,
          "criterion: every injected allocation failure fails the run cleanly (%d of %llu)", failures_seen,
          (unsigned long long)total);
    CHECK(unreported == 0, "criterion: every failure names what could not be allocated (%d did not)", unreported);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

/* A memory limit below one pass's photon records: the pass fails at once with the estimate,
 * instead of tracing on and exhausting the machine. */
static void test_photon_record_limit(void) {
    pm_scene s;
    pm_camera cam;
    pm_accel *a = sb_furnace(&s, 1.f, 1.f, &cam);
    pm_photon_settings ps = {.seed = 1, .threads = 2, .max_bounces = PM_DEFAULT_MAX_PHOTON_BOUNCES, .projection_maps = true};
    pm_photon_tracer *t = pm_photon_tracer_create(&s, a, &ps);
    pm_photon_buffer buf = {NULL, 0, 0};
    pm_photon_stats st;
    memset(&st, 0, sizeof st);
    pm_memory_clear_failure();
    pm_memory_set_limit(1 << 20);
    double t0 = pm_now_seconds();
    bool ok = pm_photon_tracer_trace_into(t, false, 10000000, 1, &buf, &st);
    double secs = pm_now_seconds() - t0;
    pm_memory_set_limit(pm_memory_default_limit());
    const char *why = pm_memory_failure();
    printf("10^7 photons in an albedo-1 room under a 1 MiB limit: %s after %.3f s (%s)\n", ok ? "stored" : "refused", secs,
           why ? why : "no reason");
    CHECK(!ok && why && strstr(why, "photon records") && strstr(why, "--max-memory"),
          "criterion: the pass is refused, naming the photon records and --max-memory");
    CHECK(secs < 2.0, "criterion: refused without tracing the whole pass (%.2f s)", secs);
    free(buf.data);
    pm_memory_clear_failure();
    pm_photon_tracer_destroy(t);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

int main(void) {
    test_allocation_failures(false);
    test_allocation_failures(true);
    test_photon_record_limit();
    return pm_test_done("test_memory_failures");
}

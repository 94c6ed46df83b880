/* test_cut.c: passes cut short by a deadline or a cancel: each pixel is divided by its own sample count (pixels the cut pass reached equal a whole run's, the others the run before it, bit for bit), a cancelled iteration leaves the film untouched, the first pass is never cut. */
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "accel.h"
#include "clock.h"
#include "eye.h"
#include "film.h"
#include "loader.h"
#include "parallel.h"
#include "progressive.h"
#include "progressive_harness.h"
#include "testing.h"

enum { W = 96, H = 80, PIXELS = W * H };

/* Every component resolved, one after another (NULL components as zeros). */
static void resolve_all(const pm_film *f, float *out) {
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) pm_film_resolve(f, (pm_component)c, out + (size_t)c * 3 * PIXELS);
}

/* Pixel i of `cut` must equal `whole` where the cut pass reached it and `before` elsewhere, bit for bit. */
static void check_pixels(const char *what, const pm_film *cut, const float *got, const float *whole, const float *before) {
    int wrong_reached = 0, wrong_other = 0;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++)
        for (size_t i = 0; i < PIXELS; i++) {
            bool reached = pm_film_samples_at(cut, i) > cut->samples;
            const float *want = reached ? whole : before;
            size_t at = (size_t)c * 3 * PIXELS + 3 * i;
            if (memcmp(got + at, want + at, 3 * sizeof(float)) != 0) *(reached ? &wrong_reached : &wrong_other) += 1;
        }
    CHECK(wrong_reached == 0, "%s: %d pixel components the cut pass reached differ from the whole run", what, wrong_reached);
    CHECK(wrong_other == 0, "%s: %d pixel components it did not reach differ from the run before it", what, wrong_other);
}

/* The film alone: a pixel a cut pass reached is divided by one sample more, its statistics by one
 * photon pass more when the cut pass updated them; a clear forgets the cut. */
static void test_film_resolve(void) {
    bool on[PM_COMPONENT_COUNT] = {true, false, false, true};
    bool slots[PM_SLOT_COUNT] = {false, true, false, false};
    pm_film f;
    CHECK(pm_film_init(&f, 4, 2, on) && pm_film_enable_ppm(&f, slots), "film");
    f.samples = 2;
    f.photon_passes = 2;
    for (size_t i = 0; i < 8; i++) {
        for (int ch = 0; ch < 3; ch++) f.sum[PM_DIRECT][3 * i + ch] = 6.f;
        f.ppm[PM_SLOT_INDIRECT][i] = (pm_ppm_stat){{6.0 * PM_PI, 6.0 * PM_PI, 6.0 * PM_PI}, 1.0, 1.0};
    }
    float out[24];
    pm_film_resolve(&f, PM_DIRECT, out);
    CHECK(out[0] == 3.f && out[23] == 3.f && pm_film_pixels_ahead(&f) == 0, "an even film: sum / samples (%g)", out[0]);
    /* a cut pass reached the left half (x < 2) of both rows; the statistics pass reached column 0 */
    pm_film_mark_ahead(&f, 0, 0, 2, 2, PM_FILM_AHEAD_SAMPLE);
    pm_film_mark_ahead(&f, 0, 0, 1, 2, PM_FILM_AHEAD_PHOTON_PASS);
    CHECK(f.ragged && pm_film_pixels_ahead(&f) == 4, "ragged, 4 pixels ahead (%zu)", pm_film_pixels_ahead(&f));
    CHECK(pm_film_samples_at(&f, 1) == 3 && pm_film_samples_at(&f, 2) == 2 && pm_film_samples_at(&f, 5) == 3,
          "samples at pixels 1, 2, 5: %u %u %u", pm_film_samples_at(&f, 1), pm_film_samples_at(&f, 2), pm_film_samples_at(&f, 5));
    pm_film_resolve(&f, PM_DIRECT, out);
    CHECK(out[3 * 1] == 2.f && out[3 * 2] == 3.f && out[3 * 5] == 2.f && out[3 * 7] == 3.f,
          "direct: reached pixels 6/3, the others 6/2 (%g %g %g %g)", out[3], out[6], out[15], out[21]);
    pm_film_resolve(&f, PM_INDIRECT, out);
    /* tau / (pi r^2 passes) = 6 / passes */
    CHECK(out[0] == 2.f && out[3 * 1] == 3.f && out[3 * 4] == 2.f && out[3 * 6] == 3.f,
          "statistics: column 0 over 3 photon passes, the rest over 2 (%g %g %g %g)", out[0], out[3], out[12], out[18]);
    pm_film_clear(&f);
    CHECK(!f.ragged && pm_film_pixels_ahead(&f) == 0 && pm_film_samples_at(&f, 0) == 0, "a clear forgets the cut");
    pm_film_free(&f);
}

/* Path-traced eye passes (every component): film B holds one pass and a second cut by a deadline
 * set part way through it; A holds two whole passes, C the first alone. The deadline is moved until
 * the cut falls inside the pass (its timing is the machine's). */
static void test_eye_pass_cut(const pm_scene *s, const pm_accel *a, const pm_camera *cam) {
    pm_eye_settings es;
    memset(&es, 0, sizeof es);
    es.seed = 3;
    es.threads = 2;
    es.max_specular_depth = PM_DEFAULT_MAX_SPECULAR_DEPTH;
    es.path_trace = true;
    bool on[PM_COMPONENT_COUNT];
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) on[c] = s->analysis.component_possible[c];
    pm_film A, B, C;
    CHECK(pm_film_init(&A, W, H, on) && pm_film_init(&B, W, H, on) && pm_film_init(&C, W, H, on), "films");
    float *whole = malloc(sizeof(float) * 12 * PIXELS), *before = malloc(sizeof(float) * 12 * PIXELS),
          *got = malloc(sizeof(float) * 12 * PIXELS);
    pm_eye_iterate(s, a, cam, &es, 0, &C, NULL);
    pm_eye_iterate(s, a, cam, &es, 0, &A, NULL);
    double t0 = pm_now_seconds();
    pm_eye_iterate(s, a, cam, &es, 1, &A, NULL);
    double pass = pm_now_seconds() - t0, share = 0.5;
    resolve_all(&A, whole);
    resolve_all(&C, before);
    size_t ahead = 0;
    for (int attempt = 0; attempt < 12; attempt++) {
        pm_film_clear(&B);
        es.deadline = 0.0;
        pm_eye_iterate(s, a, cam, &es, 0, &B, NULL);
        es.deadline = pm_now_seconds() + share * pass;
        pm_eye_iterate(s, a, cam, &es, 1, &B, NULL);
        ahead = pm_film_pixels_ahead(&B);
        if (ahead > 0 && ahead < PIXELS) break;
        /* cut before its first tile: later; finished before the deadline or every pixel reached: earlier */
        share = ahead == 0 && B.samples == 1 ? share * 1.5 + 0.05 : share * 0.5;
    }
    printf("eye pass cut by a deadline: %zu of %d pixels got the second sample, %u whole\n", ahead, PIXELS, B.samples);
    CHECK(ahead > 0 && ahead < PIXELS && B.samples == 1 && B.ragged, "the deadline cut the pass part way (%zu of %d pixels, %u samples)",
          ahead, PIXELS, B.samples);
    resolve_all(&B, got);
    check_pixels("path-traced eye pass", &B, got, whole, before);
    /* the first pass is never cut: a deadline long past still gives every pixel its sample */
    pm_film_clear(&B);
    es.deadline = 1.0;
    pm_eye_iterate(s, a, cam, &es, 0, &B, NULL);
    CHECK(B.samples == 1 && !B.ragged, "the first pass past its deadline is whole (%u samples, ragged %d)", B.samples, B.ragged);
    /* a cancel before the pass: nothing added, and the film not ragged */
    atomic_bool cancel;
    atomic_init(&cancel, true);
    pm_parallel_set_cancel(&cancel);
    es.deadline = 0.0;
    pm_eye_iterate(s, a, cam, &es, 1, &B, NULL);
    pm_parallel_set_cancel(NULL);
    resolve_all(&B, got);
    CHECK(B.samples == 1 && !B.ragged && memcmp(got, before, sizeof(float) * 12 * PIXELS) == 0,
          "a cancelled pass adds nothing (%u samples, ragged %d)", B.samples, B.ragged);
    free(whole);
    free(before);
    free(got);
    pm_film_free(&A);
    pm_film_free(&B);
    pm_film_free(&C);
}

/* The progressive mode, one eye pass an iteration and photon passes of one chunk (the deadline
 * never cuts those): B's second iteration has its eye pass cut by a deadline. The pixels it reached
 * have their sample, their statistics' photon pass and their camera splats, exactly as after two
 * whole iterations (A); the others are as after the first (C). With final gathering (estimates
 * per sample) and without (indirect light from statistics at every visible point). A cancel
 * drops an iteration whole. */
static void test_progressive_cut(const pm_scene *s, const pm_accel *a, const pm_camera *cam, pm_indirect_mode indirect) {
    const char *mode = indirect == PM_INDIRECT_GATHER ? "gather" : "photons";
    pm_progressive_settings ps = default_settings(W, H);
    ps.photons = ps.caustic_photons = 2000;
    ps.eye_passes = 1;
    ps.indirect = indirect;
    session A, B, C;
    if (!start(&A, s, a, cam, W, H, &ps) || !start(&B, s, a, cam, W, H, &ps) || !start(&C, s, a, cam, W, H, &ps)) return;
    CHECK(A.film->sum[PM_CAUSTIC] && A.film->ppm[PM_SLOT_SPECULAR_CAUSTIC], "the scene has caustic splats and statistics");
    CHECK(indirect == PM_INDIRECT_GATHER || A.film->ppm[PM_SLOT_INDIRECT], "%s: indirect statistics", mode);
    float *whole = malloc(sizeof(float) * 12 * PIXELS), *before = malloc(sizeof(float) * 12 * PIXELS),
          *got = malloc(sizeof(float) * 12 * PIXELS);
    iterate(&C, 1);
    iterate(&A, 1);
    double t0 = pm_now_seconds();
    iterate(&A, 1);
    double pass = pm_now_seconds() - t0, share = 0.5;
    resolve_all(A.film, whole);
    resolve_all(C.film, before);
    size_t ahead = 0;
    for (int attempt = 0; attempt < 12; attempt++) {
        stop(&B);
        if (!start(&B, s, a, cam, W, H, &ps)) break;
        iterate(&B, 1);
        pm_session_set_deadline(B.session, pm_now_seconds() + share * pass);
        CHECK(pm_session_iterate(B.session, 0), "the cut iteration succeeds: %s", pm_session_error(B.session));
        ahead = pm_film_pixels_ahead(B.film);
        if (ahead > 0 && ahead < PIXELS) break;
        /* the pass finished before the deadline, or reached every pixel: an earlier deadline; cut
         * before its first tile: a later one (a shared machine's timings wander) */
        share = ahead == 0 && B.film->samples == 1 ? share * 1.5 + 0.05 : share * 0.5;
    }
    printf("progressive (%s): the eye pass cut by a deadline reached %zu of %d pixels\n", mode, ahead, PIXELS);
    CHECK(ahead > 0 && ahead < PIXELS && B.film->samples == 1 && B.film->photon_passes == 1,
          "%s: the deadline cut the statistics pass part way (%zu of %d pixels, %u samples, %u photon passes)", mode, ahead,
          PIXELS, B.film->samples, B.film->photon_passes);
    resolve_all(B.film, got);
    printf("progressive (%s): image mean %.5f after one iteration and a cut one, %.5f after two whole ones\n", mode,
           mean_of(got, 12 * PIXELS), mean_of(whole, 12 * PIXELS));
    check_pixels(mode, B.film, got, whole, before);
    /* a cancel during an iteration: dropped before it touched the film */
    pm_session_cancel(C.session);
    uint32_t samples = C.film->samples, passes = C.film->photon_passes;
    CHECK(pm_session_iterate(C.session, 0), "a cancelled iteration is no failure");
    resolve_all(C.film, got);
    CHECK(C.film->samples == samples && C.film->photon_passes == passes && !C.film->ragged &&
              memcmp(got, before, sizeof(float) * 12 * PIXELS) == 0,
          "a cancelled iteration leaves the film as it was (%u samples, %u photon passes)", C.film->samples, C.film->photon_passes);
    free(whole);
    free(before);
    free(got);
    stop(&A);
    stop(&B);
    stop(&C);
}

int main(void) {
    alarm(120); /* a pass that never stops fails the test instead of hanging it */
    test_film_resolve();
    pm_scene s;
    pm_load_report rep;
    char err[256];
    if (!pm_load_gltf("scenes/cornell-box.gltf", true, &s, &rep, err, sizeof err)) {
        CHECK(false, "load: %s", err);
        return pm_test_done("test_cut");
    }
    pm_scene_finalize(&s, false, NULL);
    pm_accel *a = pm_accel_create(&s, err, sizeof err);
    CHECK(a != NULL, "accel: %s", err);
    if (a) {
        test_eye_pass_cut(&s, a, &s.cameras[0]);
        test_progressive_cut(&s, a, &s.cameras[0], PM_INDIRECT_GATHER);
        test_progressive_cut(&s, a, &s.cameras[0], PM_INDIRECT_PHOTONS);
    }
    pm_accel_destroy(a);
    pm_scene_free(&s);
    return pm_test_done("test_cut");
}

/* test_session_errors.c: a session's error belongs to the call that failed: a resize that runs out of memory is reported and handled (the session keeps its size and renders on), a later, different failure names its own cause, never the earlier one, and a session whose cancel copy the limit refuses names that copy. */
#include <stdio.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "accel.h"
#include "clock.h"
#include "film.h"
#include "memory.h"
#include "session.h"
#include "scene_builder.h"
#include "testing.h"

/* A closed white room lit by a ceiling patch, with a glass block (caustic photons). */
static void build_room(pm_scene *s) {
    memset(s, 0, sizeof *s);
    uint32_t white = sb_lambert(s, v3s(0.7f));
    uint32_t lamp = sb_material(s, v3s(0.f), 0, 1, 0, v3s(10.f), false);
    uint32_t glass = sb_material(s, v3s(1.f), 0, 0, 1, v3s(0), false);
    sb_box(s, v3(-1, 0, -1), v3(1, 2, 1), white, true);
    sb_quad(s, v3(-0.3f, 1.99f, -0.3f), v3(0.3f, 1.99f, -0.3f), v3(0.3f, 1.99f, 0.3f), v3(-0.3f, 1.99f, 0.3f), lamp);
    sb_box(s, v3(0.2f, 0, -0.2f), v3(0.6f, 0.5f, 0.3f), glass, false);
}

static pm_session_config small_config(pm_mode mode) {
    pm_session_config config;
    pm_session_config_defaults(&config, mode, 32, 24, 5, 2);
    config.progressive.photons = config.progressive.caustic_photons = 2000;
    config.shadow.mode = PM_SHADOW_OFF;
    return config;
}

/* Synchronous: a resize whose first allocation fails keeps the film; the next call's failure (an
 * EXR refused by the memory limit) names the EXR's buffers, not the resize's allocation. */
static void resize_then_save(const pm_scene *s, const pm_accel *a, const pm_camera *cam) {
    char err[256];
    pm_session_config config = small_config(PM_MODE_PROGRESSIVE);
    pm_session *session = pm_session_create(s, a, cam, &config, err, sizeof err);
    CHECK(session != NULL, "session: %s", err);
    if (!session) return;
    CHECK(pm_session_iterate(session, 2) && pm_session_error(session)[0] == '\0', "two samples: '%s'", pm_session_error(session));
    uint32_t samples = pm_session_film(session)->samples;

    pm_memory_fail_at(1, false);
    bool resized = pm_session_resize(session, 64, 48, NULL);
    pm_memory_fail_at(0, false);
    char first[1024];
    snprintf(first, sizeof first, "%s", pm_session_error(session));
    printf("a resize with its first allocation failed: '%s'\n", first);
    CHECK(!resized && strstr(first, "out of memory (") != NULL, "the failed resize reports out of memory: '%s'", first);
    const pm_film *film = pm_session_film(session);
    CHECK(film->width == 32 && film->height == 24 && film->samples == samples,
          "the session keeps its film (%dx%d, %u samples)", film->width, film->height, film->samples);

    /* the later failure, right after: the EXR writer's buffers refused by the limit */
    char path[64];
    snprintf(path, sizeof path, "/tmp/test_session_errors_%d.exr", (int)getpid());
    uint64_t limit = pm_memory_limit();
    pm_memory_set_limit(pm_memory_committed() + 1);
    bool saved = pm_session_save_exr(session, path);
    pm_memory_set_limit(limit);
    const char *second = pm_session_error(session);
    printf("then an EXR refused by the memory limit: '%s'\n", second);
    CHECK(!saved && strstr(second, "EXR output buffers") != NULL, "the save names the EXR's buffers: '%s'", second);
    /* the resize's cause, "what, N bytes", must not reappear */
    char cause[256] = "";
    const char *open = strchr(first, '(');
    if (open) snprintf(cause, sizeof cause, "%.*s", (int)strcspn(open + 1, ","), open + 1);
    CHECK(cause[0] && strstr(second, cause) == NULL, "the save's error does not name the resize's '%s': '%s'", cause, second);

    /* and the session renders on, with no error left */
    CHECK(pm_session_iterate(session, 1) && pm_session_film(session)->samples == samples + 1 && pm_session_error(session)[0] == '\0',
          "an iteration after both failures: %u samples, '%s'", pm_session_film(session)->samples, pm_session_error(session));
    CHECK(pm_session_save_exr(session, path) && pm_session_error(session)[0] == '\0', "the save within the limit: '%s'",
          pm_session_error(session));
    unlink(path);
    CHECK(pm_session_resize(session, 40, 30, NULL) && pm_session_film(session)->width == 40 && pm_session_film(session)->samples == 0,
          "a resize with memory: %dx%d, '%s'", pm_session_film(session)->width, pm_session_film(session)->height,
          pm_session_error(session));
    CHECK(pm_session_iterate(session, 1) && pm_session_film(session)->samples == 1, "an iteration at the new size");
    pm_session_destroy(session);
}

/* The window's way: a resize of a running session that fails keeps rendering at the old size; one
 * that succeeds renders at the new size. */
static void background_resize(const pm_scene *s, const pm_accel *a, const pm_camera *cam) {
    char err[256];
    pm_session_config config = small_config(PM_MODE_PROGRESSIVE);
    /* the worker finishes its iterations and waits before the injected failure, so the failure is
     * the resize's own first allocation and never one the worker makes meanwhile */
    config.max_iterations = 2;
    pm_session *session = pm_session_create(s, a, cam, &config, err, sizeof err);
    CHECK(session && pm_session_start(session, err, sizeof err), "background session: %s", err);
    if (!session) return;
    bool finished = false;
    for (double until = pm_now_seconds() + 60; !finished && pm_now_seconds() < until;) {
        uint64_t version = 0;
        pm_session_progress progress = {0};
        if (pm_session_lock_latest(session, &version, &progress)) {
            finished = progress.finished;
            pm_session_unlock_latest(session);
        }
        if (!finished) nanosleep(&(struct timespec){0, 2000000}, NULL);
    }
    CHECK(finished, "the background session finishes its two iterations");
    pm_memory_fail_at(1, false);
    bool resized = pm_session_resize(session, 64, 48, cam);
    pm_memory_fail_at(0, false);
    CHECK(!resized && strstr(pm_session_error(session), "out of memory (") != NULL, "a running session's failed resize: '%s'",
          pm_session_error(session));
    for (int round = 0; round < 2; round++) {
        int want_width = round == 0 ? 32 : 48;
        if (round == 1)
            CHECK(pm_session_resize(session, 48, 36, cam) && pm_session_error(session)[0] == '\0', "a running session's resize: '%s'",
                  pm_session_error(session));
        uint64_t version = 0;
        pm_session_progress progress = {0};
        bool rendered = false;
        double until = pm_now_seconds() + 60;
        while (!rendered && pm_now_seconds() < until) {
            const float *const *layers = pm_session_lock_latest(session, &version, &progress);
            if (layers) {
                rendered = progress.iterations >= 2;
                pm_session_unlock_latest(session);
            }
            if (!rendered) nanosleep(&(struct timespec){0, 2000000}, NULL);
        }
        CHECK(rendered && pm_session_film(session)->width == want_width, "renders on at %d wide (%u iterations published)",
              want_width, progress.iterations);
    }
    pm_session_destroy(session);
}

/* The classic mode's pilot pass (a time budget, automatic photon counts) fails on its first
 * allocation, which the session handles; then the film is refused by the memory limit: the
 * error names the film. */
static void pilot_then_film(const pm_scene *s, const pm_accel *a, const pm_camera *cam) {
    char err[256];
    pm_session_config config = small_config(PM_MODE_CLASSIC);
    config.time_budget = 1.0;
    uint64_t limit = pm_memory_limit();
    pm_memory_set_limit(pm_memory_committed() + 1000);
    pm_memory_fail_at(2, false); /* the session's own struct first, then the pilot's first allocation */
    pm_session *session = pm_session_create(s, a, cam, &config, err, sizeof err);
    pm_memory_fail_at(0, false);
    pm_memory_set_limit(limit);
    printf("a pilot pass failed, then the film refused: '%s'\n", session ? "" : err);
    CHECK(!session && strncmp(err, "out of memory (film, ", 21) == 0, "the error names the film: '%s'", err);
    pm_session_destroy(session);
}

/* The copy a cancel puts back is made for each iteration that can be cancelled (every session
 * iteration), in room the session takes when it is made: refused by the memory limit, the session
 * cannot be made and its error names that copy; made, its iterations commit nothing more and keep
 * no copy between them. */
static void copy_refused(const pm_scene *s, const pm_accel *a, const pm_camera *cam) {
    char err[256];
    pm_session_config config = small_config(PM_MODE_PROGRESSIVE);
    uint64_t base = pm_memory_committed();
    pm_session *session = pm_session_create(s, a, cam, &config, err, sizeof err);
    CHECK(session != NULL, "session: %s", err);
    if (!session) return;
    uint64_t made = pm_memory_committed(), copy = pm_film_copy_bytes(pm_session_film(session));
    CHECK(copy > 0 && made - base >= copy + pm_film_bytes(pm_session_film(session)),
          "the session commits its film and the copy's room (%llu bytes, the copy %llu)", (unsigned long long)(made - base),
          (unsigned long long)copy);
    CHECK(pm_session_iterate(session, 1) && pm_memory_committed() == made && !pm_film_can_restore(pm_session_film(session)),
          "criterion: an iteration commits nothing more and keeps no copy after it (%llu more)",
          (unsigned long long)(pm_memory_committed() - made));
    pm_session_destroy(session);
    CHECK(pm_memory_committed() == base, "the session gives everything back");
    uint64_t limit = pm_memory_limit();
    pm_memory_set_limit(made - 1); /* the copy's room, taken last, does not fit */
    session = pm_session_create(s, a, cam, &config, err, sizeof err);
    pm_memory_set_limit(limit);
    printf("a session whose copy the limit refuses: '%s'\n", session ? "" : err);
    CHECK(!session && strstr(err, "out of memory (film (the copy a cancel restores), ") != NULL,
          "criterion: the session's error names the copy: '%s'", err);
    CHECK(pm_memory_committed() == base, "a refused session keeps nothing committed (%llu)", (unsigned long long)(pm_memory_committed() - base));
    pm_session_destroy(session);
}

int main(void) {
    pm_scene s;
    build_room(&s);
    pm_scene_finalize(&s, false, NULL);
    char err[256];
    pm_accel *a = pm_accel_create(&s, err, sizeof err);
    CHECK(a != NULL, "%s", err);
    if (!a) return pm_test_done("test_session_errors");
    pm_camera cam = sb_camera(v3(0, 1, 0.95f), v3(0, 0.9f, 0), v3(0, 1, 0), 75.f);
    resize_then_save(&s, a, &cam);
    background_resize(&s, a, &cam);
    pilot_then_film(&s, a, &cam);
    copy_refused(&s, a, &cam);
    pm_accel_destroy(a);
    pm_scene_free(&s);
    return pm_test_done("test_session_errors");
}

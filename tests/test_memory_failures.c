/* test_memory_failures.c: every checked allocation of a render made to fail in turn, the memory limit refusing a photon pass, the limit bounding the sum of what is admitted, and failures kept apart by owner (thread, parallel-for) and forgiven when handled: a reason each time, never a crash, a leak (ASan) or a commitment left behind. */
#include <pthread.h>
#include <sched.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "accel.h"
#include "clock.h"
#include "defaults.h"
#include "film.h"
#include "loader.h"
#include "memory.h"
#include "parallel.h"
#include "photonmap.h"
#include "progressive.h"
#include "scene_builder.h"
#include "session.h"
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
    uint64_t total = 0, committed = pm_memory_committed();
    int failures_seen = 0, unreported = 0, unreleased = 0, handled = 0, kept_record = 0;
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
        if (pm_memory_committed() != committed) unreleased++;
        if (n == 0) {
            total = pm_memory_allocations();
            CHECK(ok, "the run without an injected failure succeeds");
            continue;
        }
        if (!ok) failures_seen++;
        if (!ok && !pm_memory_failure()) unreported++;
        /* a run that went on handled its failure (the clip cache, which only saves time): no record stays */
        if (ok && n <= total) handled++;
        if (ok && pm_memory_failure()) kept_record++;
        if (n > total) break;
    }
    pm_memory_fail_at(0, false);
    pm_memory_clear_failure();
    printf("allocation failures (%s): %llu checked allocations, %d failing runs, %d without a reason, %d handled\n",
           caustics ? "glass and mirror balls, point lights" : "furnace", (unsigned long long)total, failures_seen, unreported,
           handled);
    CHECK(total >= 10 && failures_seen + handled >= (int)total - 2 && handled <= (int)total / 4,
          "criterion: every injected allocation failure fails the run cleanly or is handled (%d failed, %d handled of %llu)",
          failures_seen, handled, (unsigned long long)total);
    CHECK(kept_record == 0, "criterion: a run that handled a failure keeps no record a later error could name (%d did)", kept_record);
    CHECK(unreported == 0, "criterion: every failure names what could not be allocated (%d did not)", unreported);
    CHECK(unreleased == 0, "criterion: every run gives back all it admitted, failed or not (%d did not)", unreleased);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

/* A session's configuration for each mode on the caustic box, shadow photons on (their map
 * allocates too), small enough that every allocation can be failed in turn. */
static pm_session_config session_config(pm_mode mode, int w, int h) {
    pm_session_config c;
    pm_session_config_defaults(&c, mode, w, h, 1, 2);
    c.shadow.mode = PM_SHADOW_ON;
    c.shadow.photons_per_light = 4000;
    c.progressive.photons = c.progressive.caustic_photons = 3000;
    if (mode == PM_MODE_CLASSIC) {
        c.classic_photons.global_photons = c.classic_photons.caustic_photons = 3000;
        c.classic_photons.projection_maps = true;
        c.eye.caustic_estimate = (pm_estimate_settings){.k = 20, .max_radius = 0.2f, .path_mask = 1u << PM_PATH_CAUSTIC};
        c.eye.global_estimate = (pm_estimate_settings){.k = 20, .max_radius = 0.3f, .path_mask = 1u << PM_PATH_INDIRECT};
        c.eye.indirect = PM_INDIRECT_PHOTONS;
    } else {
        c.classic_photon_pass = false;
    }
    return c;
}

/* A whole run through the session, as pmview makes one: create, three iterations, the image
 * resolved. False with the error line (what the caller would print) when it failed. */
static bool session_run(const pm_scene *s, const pm_accel *a, const pm_camera *cam, const pm_session_config *c, char *err,
                        size_t err_size) {
    err[0] = 0;
    pm_memory_clear_failure();
    pm_session *session = pm_session_create(s, a, cam, c, err, err_size);
    if (!session) return false;
    bool ok = true;
    for (int i = 0; ok && i < 3; i++) {
        /* each top-level call owns the failures it meets */
        pm_memory_clear_failure();
        ok = pm_session_iterate(session, 0);
        if (!ok) snprintf(err, err_size, "out of memory (%s) in iteration %d", pm_memory_failure() ? pm_memory_failure() : "", i + 1);
    }
    if (ok) {
        const pm_film *f = pm_session_film(session);
        float *image = pm_malloc(3 * sizeof(float) * (size_t)f->width * f->height, "image");
        ok = image && pm_film_resolve_total(f, image);
        if (!ok) snprintf(err, err_size, "out of memory (%s) for the image", pm_memory_failure() ? pm_memory_failure() : "");
        free(image);
    }
    pm_session_destroy(session);
    return ok;
}

/* Every checked allocation of a progressive, a classic and a path-traced run through the session
 * failed in turn (n = 1 .. the allocations of a whole run): each failing run gives one error line
 * that names what failed ("out of memory (what, N bytes)"), a run that goes on despite the failure
 * has handled it and recorded nothing, nothing is left committed, nothing crashes, nothing leaks
 * (ASan's leak check at exit). */
static void test_session_failures(pm_mode mode) {
    static const char *const names[3] = {"progressive", "classic", "path tracing"};
    pm_scene s;
    pm_camera cam;
    pm_accel *a = caustic_box(&s, &cam);
    pm_session_config c = session_config(mode, 16, 12);
    uint64_t committed = pm_memory_committed();
    char err[512];
    pm_memory_fail_at(0, false);
    bool ok = session_run(&s, a, &cam, &c, err, sizeof err);
    uint64_t total = pm_memory_allocations();
    CHECK(ok, "%s: the run without an injected failure succeeds: %s", names[mode], err);
    int failed = 0, nameless = 0, kept_record = 0, unreleased = 0;
    for (uint64_t n = 1; n <= total; n++) {
        pm_memory_fail_at(n, false);
        ok = session_run(&s, a, &cam, &c, err, sizeof err);
        pm_memory_fail_at(0, false);
        if (pm_memory_committed() != committed) unreleased++;
        if (ok) {
            if (pm_memory_failure()) kept_record++;
            continue;
        }
        failed++;
        /* one line naming the allocation: "out of memory (what, N bytes)..." with a non-empty what */
        const char *open = strstr(err, "out of memory (");
        bool named = open && open[15] != ')' && open[15] != ',' && strstr(open, " bytes") && !strchr(err, '\n');
        if (!named) {
            nameless++;
            if (nameless <= 3) printf("  %s, allocation %llu: \"%s\"\n", names[mode], (unsigned long long)n, err);
        }
    }
    pm_memory_clear_failure();
    printf("allocation failures (%s session): %llu checked allocations, %d failing runs, %d went on\n", names[mode],
           (unsigned long long)total, failed, (int)total - failed);
    CHECK(total >= 20 && failed >= 1, "%s: allocations were failed (%llu, %d runs failed)", names[mode], (unsigned long long)total, failed);
    CHECK(nameless == 0, "criterion: %s: every failing run's error names what failed (%d did not)", names[mode], nameless);
    CHECK(kept_record == 0, "criterion: %s: a run that handled a failure keeps no record a later error could name (%d did)",
          names[mode], kept_record);
    CHECK(unreleased == 0, "criterion: %s: every run gives back all it admitted (%d did not)", names[mode], unreleased);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

/* An error names its own cause: a failure handled earlier (and not cleared) is not what a later
 * failing call reports. */
static void test_error_names_new_cause(void) {
    pm_memory_clear_failure();
    pm_memory_fail(100, "an earlier structure, handled");
    uint64_t mark = pm_memory_failure_mark();
    CHECK(pm_memory_failure_since(mark) == NULL, "nothing failed since the mark");
    pm_memory_fail(200, "the new structure");
    pm_memory_fail(300, "a consequence");
    const char *since = pm_memory_failure_since(mark);
    CHECK(since && !strcmp(since, "the new structure, 200 bytes"), "the first failure after the mark: \"%s\"", since ? since : "");
    CHECK(pm_memory_failure() && !strcmp(pm_memory_failure(), "an earlier structure, handled, 100 bytes"),
          "pm_memory_failure: the first since the last clear");
    pm_memory_clear_failure();
    pm_memory_fail(400, "after the clear");
    CHECK(pm_memory_failure() && !strcmp(pm_memory_failure(), "after the clear, 400 bytes"), "a clear starts the record again");
    /* through a real call: a progressive state whose creation fails after a handled failure */
    pm_scene s;
    pm_camera cam;
    pm_accel *a = caustic_box(&s, &cam);
    pm_progressive_settings ps = session_config(PM_MODE_PROGRESSIVE, 8, 8).progressive;
    int checked = 0, wrong = 0;
    char err[256] = "";
    pm_memory_fail_at(0, false);
    pm_progressive_destroy(pm_progressive_create(&s, a, &cam, &ps, err, sizeof err));
    uint64_t creation = pm_memory_allocations();
    for (uint64_t n = 1; n <= creation; n++) {
        pm_memory_clear_failure();
        pm_memory_fail(1, "an old failure, handled");
        pm_memory_fail_at(n, false);
        err[0] = 0;
        pm_progressive *p = pm_progressive_create(&s, a, &cam, &ps, err, sizeof err);
        pm_memory_fail_at(0, false);
        if (p) { pm_progressive_destroy(p); continue; } /* a failure it handled (the clip cache, which only saves time) */
        checked++;
        if (strstr(err, "an old failure")) wrong++;
    }
    printf("progressive state creation failed in turn after a handled failure: %d runs, %d named the old failure\n", checked, wrong);
    CHECK(checked > 0 && wrong == 0, "criterion: the error names the new cause (%d of %d named the old)", wrong, checked);
    pm_memory_clear_failure();
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

static void *fail_elsewhere(void *arg) {
    pm_memory_fail(50, "another thread's structure");
    return arg;
}

static void fail_in_task(void *ctx, size_t task, int thread) {
    if (task == 1) pm_memory_fail(90, "a task's structure");
}

/* A failure is its owner's: a call's mark never answers with another thread's failure, a
 * parallel-for's tasks fail on behalf of the thread that started it, and a failure the caller
 * handled and forgave is named by no later error. */
static void test_failures_belong_to_their_owner(void) {
    pm_memory_clear_failure();
    uint64_t mark = pm_memory_failure_mark();
    pthread_t other;
    CHECK(pthread_create(&other, NULL, fail_elsewhere, NULL) == 0, "thread");
    pthread_join(other, NULL);
    CHECK(pm_memory_failure_since(mark) == NULL, "criterion: another thread's failure after the mark is not this thread's");
    pm_memory_fail(60, "this thread's structure");
    const char *since = pm_memory_failure_since(mark);
    CHECK(since && !strcmp(since, "this thread's structure, 60 bytes"), "criterion: the call's own failure: \"%s\"", since ? since : "");
    mark = pm_memory_failure_mark();
    pm_parallel_for(2, 4, fail_in_task, NULL);
    since = pm_memory_failure_since(mark);
    CHECK(since && !strcmp(since, "a task's structure, 90 bytes"), "criterion: a task's failure is the caller's: \"%s\"",
          since ? since : "");
    /* forgiven: a handled failure names nothing, before or after a real one */
    pm_memory_clear_failure();
    mark = pm_memory_failure_mark();
    pm_memory_fail(70, "a cache done without");
    pm_memory_forgive_last();
    CHECK(!pm_memory_failure() && !pm_memory_failure_since(mark), "criterion: a forgiven failure is no record");
    pm_memory_fail(80, "the real one");
    since = pm_memory_failure_since(mark);
    CHECK(since && !strcmp(since, "the real one, 80 bytes") && pm_memory_failure() && !strcmp(pm_memory_failure(), since),
          "after a forgiven failure the real one is named: \"%s\"", since ? since : "");
    pm_memory_fail(85, "handled after it");
    pm_memory_forgive_last();
    CHECK(pm_memory_failure() && !strcmp(pm_memory_failure(), "the real one, 80 bytes"), "forgiving a later one keeps the first");
    pm_memory_clear_failure();
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

/* Admits and releases 1 MiB at a time from several threads with room for one and a half: the
 * committed total must never pass the limit, and must end where it began. */
enum { RACE_THREADS = 4, RACE_ROUNDS = 5000 };
static uint64_t race_limit;
static _Atomic int race_over, race_refused;
static pthread_barrier_t race_start;

static void *race(void *arg) {
    (void)arg;
    pthread_barrier_wait(&race_start);
    for (int i = 0; i < RACE_ROUNDS; i++) {
        if (!pm_memory_admit(1 << 20, "race")) { race_refused++; continue; }
        if (pm_memory_committed() > race_limit) race_over++;
        sched_yield(); /* holding it, so that the others meet it even when the threads share a core */
        pm_memory_release(1 << 20);
    }
    return NULL;
}

/* --max-memory bounds the sum: what is admitted stays committed until released, a structure
 * that fits alone is refused beside others, and the refusal says what was already committed. */
static void test_committed_sum(void) {
    pm_memory_clear_failure();
    const uint64_t base = pm_memory_committed(), MiB = 1 << 20, limit = base + 10 * MiB;
    pm_memory_set_limit(limit);
    CHECK(pm_memory_admit(6 * MiB, "first structure"), "6 MiB under a 10 MiB room");
    CHECK(pm_memory_committed() == base + 6 * MiB, "committed %llu, want %llu", (unsigned long long)pm_memory_committed(),
          (unsigned long long)(base + 6 * MiB));
    CHECK(pm_memory_available() == 4 * MiB, "available %llu, want 4 MiB", (unsigned long long)pm_memory_available());
    CHECK(!pm_memory_admit(6 * MiB, "second structure"), "criterion: a second 6 MiB beside the first is refused");
    char want[320];
    snprintf(want, sizeof want,
             "second structure, 6291456 bytes, with %llu bytes already committed, over the limit of %llu bytes; see --max-memory",
             (unsigned long long)(base + 6 * MiB), (unsigned long long)limit);
    const char *why = pm_memory_failure();
    CHECK(why && !strcmp(why, want), "criterion: the refusal names the structure, its bytes, the committed bytes and "
                                     "--max-memory:\n  got  %s\n  want %s", why ? why : "(none)", want);
    CHECK(pm_memory_committed() == base + 6 * MiB, "a refusal commits nothing");
    pm_memory_release(6 * MiB);
    pm_memory_clear_failure();
    CHECK(pm_memory_admit(6 * MiB, "second structure"), "after the release the second one fits");
    pm_memory_release(6 * MiB);
    CHECK(pm_memory_committed() == base, "all given back");

    race_limit = base + MiB + MiB / 2;
    pm_memory_set_limit(race_limit);
    pthread_t threads[RACE_THREADS];
    pthread_barrier_init(&race_start, NULL, RACE_THREADS);
    for (int t = 0; t < RACE_THREADS; t++) pthread_create(&threads[t], NULL, race, NULL);
    for (int t = 0; t < RACE_THREADS; t++) pthread_join(threads[t], NULL);
    pthread_barrier_destroy(&race_start);
    printf("%d threads x %d admissions of 1 MiB with room for 1.5: %d refused, %d saw the total over the limit\n",
           RACE_THREADS, RACE_ROUNDS, (int)race_refused, (int)race_over);
    CHECK(race_refused > 0, "the threads never met: nothing was tested");
    CHECK(race_over == 0, "criterion: the committed total never passes the limit (%d times it did)", (int)race_over);
    CHECK(pm_memory_committed() == base, "criterion: the race ends where it began (%llu, want %llu)",
          (unsigned long long)pm_memory_committed(), (unsigned long long)base);
    pm_memory_clear_failure();
    pm_memory_set_limit(pm_memory_default_limit());
}

static void base64_append(char *out, const unsigned char *in, size_t n) {
    static const char digits[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    out += strlen(out);
    for (size_t i = 0; i < n; i += 3) {
        uint32_t v = (uint32_t)in[i] << 16 | (i + 1 < n ? (uint32_t)in[i + 1] << 8 : 0) | (i + 2 < n ? in[i + 2] : 0);
        *out++ = digits[v >> 18 & 63];
        *out++ = digits[v >> 12 & 63];
        *out++ = i + 1 < n ? digits[v >> 6 & 63] : '=';
        *out++ = i + 2 < n ? digits[v & 63] : '=';
    }
    *out = 0;
}

/* In libstb; stb_image_write.h declares it only inside its implementation section. */
unsigned char *stbi_write_png_to_mem(const unsigned char *pixels, int stride_bytes, int x, int y, int n, int *out_len);

/* A triangle with a 64 x 64 texture, all in data: URIs. */
static char *textured_triangle(void) {
    enum { SIDE = 64 };
    static unsigned char texels[SIDE * SIDE * 4];
    for (int i = 0; i < SIDE * SIDE * 4; i++) texels[i] = (unsigned char)(i * 7);
    int png_size = 0;
    unsigned char *png = stbi_write_png_to_mem(texels, SIDE * 4, SIDE, SIDE, 4, &png_size);
    const float geometry[15] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 1}; /* 3 positions, 3 uvs */
    char *json = malloc(4096 + 2 * (size_t)png_size);
    if (!json || !png) abort();
    snprintf(json, 4096,
             "{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
             "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":1},\"material\":0}]}],"
             "\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0}}}],"
             "\"textures\":[{\"source\":0}],"
             "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]},"
             "{\"bufferView\":0,\"byteOffset\":36,\"componentType\":5126,\"count\":3,\"type\":\"VEC2\"}],"
             "\"bufferViews\":[{\"buffer\":0,\"byteLength\":60}],"
             "\"buffers\":[{\"byteLength\":60,\"uri\":\"data:application/octet-stream;base64,");
    base64_append(json, (const unsigned char *)geometry, sizeof geometry);
    strcat(json, "\"}],\"images\":[{\"uri\":\"data:image/png;base64,");
    base64_append(json, png, (size_t)png_size);
    strcat(json, "\"}]}");
    free(png);
    return json;
}

/* What the film, the loaded scene and the acceleration structure admit is given back when they
 * are freed, and a load refused halfway keeps nothing committed. */
static void test_structures_give_back(void) {
    pm_memory_clear_failure();
    const uint64_t base = pm_memory_committed();
    pm_film film;
    const bool all[PM_COMPONENT_COUNT] = {true, true, true, true};
    CHECK(pm_film_init(&film, 64, 32, all), "film");
    CHECK(pm_memory_committed() == base + 4 * 3 * (4 + 2) * 64 * 32 + 64 * 32,
          "the film commits its buffers (four layers, each a float and 16 low bits a channel; one ahead byte a pixel): %llu bytes",
          (unsigned long long)(pm_memory_committed() - base));
    /* the copy a cancel puts back is committed only while it is open */
    CHECK(pm_film_open_copy(&film) && pm_memory_committed() == base + 2 * (4 * 3 * (4 + 2) * 64 * 32) + 64 * 32,
          "criterion: the open copy commits the layers again: %llu bytes", (unsigned long long)(pm_memory_committed() - base));
    pm_film_close_copy(&film);
    CHECK(pm_memory_committed() == base + 4 * 3 * (4 + 2) * 64 * 32 + 64 * 32 && !pm_film_can_restore(&film),
          "criterion: closing the copy gives its bytes back");
    pm_film_free(&film);
    CHECK(pm_memory_committed() == base, "pm_film_free gives the film's bytes back");

    char *json = textured_triangle();
    pm_scene s;
    char err[512] = "";
    bool ok = pm_load_gltf_memory(json, strlen(json), "textured.gltf", true, &s, NULL, err, sizeof err);
    CHECK(ok && s.texture_count == 1, "the textured triangle loads: %s", err);
    if (ok) {
        printf("a triangle with a 64 x 64 texture keeps %llu bytes committed (the texels: 16384)\n",
               (unsigned long long)(pm_memory_committed() - base));
        CHECK(s.memory_admitted >= 64 * 64 * 4 && pm_memory_committed() == base + s.memory_admitted,
              "criterion: the scene holds the texels and geometry it admitted (%llu), the decoded image is given back "
              "(committed %llu)", (unsigned long long)s.memory_admitted, (unsigned long long)(pm_memory_committed() - base));
        pm_scene_finalize(&s, false, NULL);
        pm_accel *a = pm_accel_create(&s, err, sizeof err);
        CHECK(a && pm_memory_committed() > base + s.memory_admitted, "criterion: Embree's allocations are admitted too");
        pm_accel_destroy(a);
        CHECK(pm_memory_committed() == base + s.memory_admitted, "pm_accel_destroy gives Embree's bytes back (%llu left)",
              (unsigned long long)(pm_memory_committed() - base - s.memory_admitted));
        pm_scene_free(&s);
        CHECK(pm_memory_committed() == base, "criterion: pm_scene_free gives the scene's bytes back (%llu left)",
              (unsigned long long)(pm_memory_committed() - base));
    }
    /* room for decoding the image (twice its 16384 bytes), which is also room for its texels beside
     * the decoded copy the model keeps, but not for the geometry beside both */
    pm_memory_set_limit(base + 2 * 16384 + 16);
    ok = pm_load_gltf_memory(json, strlen(json), "textured.gltf", true, &s, NULL, err, sizeof err);
    char want[96];
    snprintf(want, sizeof want, "with %llu bytes already committed", (unsigned long long)(base + 2 * 16384));
    CHECK(!ok && strstr(err, "out of memory (scene geometry and its acceleration structure, ") && strstr(err, want) &&
              strstr(err, "--max-memory"),
          "criterion: the geometry beside the texels and the decoded image passes the limit: \"%s\"", err);
    CHECK(pm_memory_committed() == base, "criterion: a refused load keeps nothing committed (%llu)",
          (unsigned long long)(pm_memory_committed() - base));
    pm_memory_set_limit(pm_memory_default_limit());
    pm_memory_clear_failure();
    free(json);
}

int main(void) {
    test_committed_sum();
    test_structures_give_back();
    test_allocation_failures(false);
    test_allocation_failures(true);
    test_photon_record_limit();
    test_error_names_new_cause();
    test_failures_belong_to_their_owner();
    test_session_failures(PM_MODE_PROGRESSIVE);
    test_session_failures(PM_MODE_CLASSIC);
    test_session_failures(PM_MODE_PATHTRACE);
    return pm_test_done("test_memory_failures");
}

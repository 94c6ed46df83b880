/* test_threads.c: the same seed gives the same photon maps and image bit for bit at 1, 2 and 3 threads, classic and progressive; a session cancelled from another thread and cut by its deadline; a worker's published images and packed forms read while it renders (also run under TSan). */
#include <pthread.h>
#include <time.h>

#include "clock.h"
#include "accel.h"
#include "eye.h"
#include "film.h"
#include "photonmap.h"
#include "progressive.h"
#include "session.h"
#include "progressive_harness.h"
#include "session_harness.h"
#include "scene_builder.h"
#include "testing.h"

/* A small Cornell-like room: coloured walls, an emissive ceiling patch, a mirror block, a glass block. */
static void build_room(pm_scene *s) {
    memset(s, 0, sizeof *s);
    uint32_t white = sb_lambert(s, v3s(0.7f)), red = sb_lambert(s, v3(0.6f, 0.05f, 0.05f));
    uint32_t green = sb_lambert(s, v3(0.1f, 0.5f, 0.1f));
    uint32_t lamp = sb_material(s, v3s(0.f), 0, 1, 0, v3s(10.f), false);
    uint32_t mirror = sb_material(s, v3s(0.9f), 1, 0, 0, v3s(0), false);
    uint32_t glass = sb_material(s, v3s(1.f), 0, 0, 1, v3s(0), false);
    sb_box(s, v3(-1, 0, -1), v3(1, 2, 1), white, true);
    sb_quad(s, v3(-0.999f, 0, -1), v3(-0.999f, 0, 1), v3(-0.999f, 2, 1), v3(-0.999f, 2, -1), red);
    sb_quad(s, v3(0.999f, 0, 1), v3(0.999f, 0, -1), v3(0.999f, 2, -1), v3(0.999f, 2, 1), green);
    sb_quad(s, v3(-0.3f, 1.99f, -0.3f), v3(0.3f, 1.99f, -0.3f), v3(0.3f, 1.99f, 0.3f), v3(-0.3f, 1.99f, 0.3f), lamp);
    sb_box(s, v3(-0.7f, 0, -0.5f), v3(-0.2f, 0.8f, 0.0f), mirror, false);
    sb_box(s, v3(0.2f, 0, -0.2f), v3(0.6f, 0.5f, 0.3f), glass, false);
}

/* The window's way of rendering: a worker thread iterates and publishes, this thread reads the
 * newest image, moves the camera (restarts that cancel a running pass), pauses and stops. Under
 * TSan this is where a race between the two would show. */
static void background_session(const pm_scene *s, const pm_accel *a, pm_camera cam) {
    pm_session_config config;
    memset(&config, 0, sizeof config);
    config.mode = PM_MODE_PROGRESSIVE;
    config.width = 32;
    config.height = 24;
    config.progressive = (pm_progressive_settings){.seed = 3, .threads = 2, .photons = 5000, .caustic_photons = 5000,
                                                   .alpha = 2.0 / 3.0, .indirect = PM_INDIRECT_GATHER,
                                                   .max_specular_depth = 8, .max_photon_bounces = 16};
    char err[256];
    pm_session *session = pm_session_create(s, a, &cam, &config, err, sizeof err);
    /* the packed form MPI ranks merge is published beside the images */
    CHECK(session && pm_session_keep_packed(session, true), "packed forms kept");
    CHECK(session && pm_session_start(session, err, sizeof err), "background session: %s", err);
    if (!session) return;
    uint64_t version = 0;
    int images = 0, restarts = 0, packs = 0, empty_packs = 0, stale_packs = 0;
    double sum = 0;
    for (int round = 0; round < 1200 && images < 12; round++) {
        pm_session_progress progress;
        const float *const *layers = pm_session_lock_latest(session, &version, &progress);
        if (layers) {
            images++;
            for (int c = 0; c < PM_COMPONENT_COUNT; c++)
                if (layers[c]) sum += layers[c][3 * (12 * 32 + 16)];
            pm_session_unlock_latest(session);
            pm_session_packed packed;
            if (pm_session_lock_packed(session, &packed)) {
                packs++;
                /* its header: the samples every pixel holds; its size: what the film's layout gives */
                size_t per_pixel = 1;
                for (int c = 0; c < PM_COMPONENT_COUNT; c++) per_pixel += packed.components[c] ? 3 : 0;
                for (int k = 0; k < PM_SLOT_COUNT; k++) per_pixel += packed.slots[k] ? 7 : 0;
                empty_packs += !(packed.values[0] >= 1.0) || packed.width != 32 || packed.height != 24 ||
                               packed.count != 2 + (size_t)32 * 24 * per_pixel;
                pm_session_unlock_latest(session);
            }
            if (images % 4 == 0) {
                cam.position.x += 0.01f;
                pm_session_request_restart(session, &cam, images == 8 ? PM_INDIRECT_PHOTONS : -1);
                restarts++;
                /* a form of the old camera is never handed out after the restart was asked for */
                if (pm_session_lock_packed(session, &packed)) {
                    stale_packs++;
                    pm_session_unlock_latest(session);
                }
            }
        }
        struct timespec ts = {0, 5000000};
        nanosleep(&ts, NULL);
    }
    pm_session_pause(session, true);
    pm_session_pause(session, false);
    pm_session_stop(session);
    CHECK(images >= 8, "the worker published %d images", images);
    CHECK(packs >= 4 && empty_packs == 0, "%d packed forms read, %d of them empty", packs, empty_packs);
    CHECK(stale_packs == 0, "%d packed forms of a camera already left", stale_packs);
    CHECK(sum > 0, "the published images are lit");
    pm_session_destroy(session);
}

static void *cancel_soon(void *session) {
    struct timespec ts = {0, 50000000};
    nanosleep(&ts, NULL);
    pm_session_cancel(session); /* what a snapshot's signal handler does */
    return NULL;
}

/* A snapshot's way of rendering: pm_session_iterate on this thread while another cancels it in
 * the middle of a photon pass far too long to wait for (5 million photons); then an eye pass cut
 * between tiles by a deadline. Each is answered at once, and the film holds only whole work. */
static void cut_sessions(const pm_scene *s, const pm_accel *a, pm_camera cam) {
    pm_session_config config;
    memset(&config, 0, sizeof config);
    config.mode = PM_MODE_PROGRESSIVE;
    config.width = 64;
    config.height = 48;
    config.progressive = (pm_progressive_settings){.seed = 3, .threads = 2, .photons = 5000000, .caustic_photons = 5000000,
                                                   .alpha = 2.0 / 3.0, .indirect = PM_INDIRECT_GATHER,
                                                   .max_specular_depth = 8, .max_photon_bounces = 16, .eye_passes = 1};
    char err[256];
    pm_session *session = pm_session_create(s, a, &cam, &config, err, sizeof err);
    CHECK(session != NULL, "session: %s", err);
    if (!session) return;
    pthread_t canceller;
    pthread_create(&canceller, NULL, cancel_soon, session);
    double t0 = pm_now_seconds();
    bool ok = pm_session_iterate(session, 0);
    double waited = pm_now_seconds() - t0;
    pthread_join(canceller, NULL);
    const pm_film *film = pm_session_film(session);
    printf("a 5-million-photon iteration cancelled from another thread returned after %.3f s\n", waited);
    CHECK(ok && waited < 5.0, "the cancelled iteration returns at once, without failing (%.3f s)", waited);
    CHECK(film->samples == 0 && !film->ragged && film->photon_passes == 0, "the cancelled iteration left the film empty");
    pm_session_destroy(session);

    config.progressive.photons = config.progressive.caustic_photons = 4000;
    config.width = 256;
    config.height = 192;
    session = pm_session_create(s, a, &cam, &config, err, sizeof err);
    CHECK(session != NULL, "session: %s", err);
    if (!session) return;
    CHECK(pm_session_iterate(session, 1), "first iteration");
    film = pm_session_film(session);
    pm_session_set_deadline(session, pm_now_seconds() + 0.005);
    CHECK(pm_session_iterate(session, 1), "the iteration the deadline cuts");
    size_t ahead = pm_film_pixels_ahead(film);
    printf("the deadline cut the second eye pass after %zu of %d pixels\n", ahead, config.width * config.height);
    CHECK(film->samples == 1 && ahead < (size_t)config.width * config.height, "the second pass did not finish (%u, %zu)",
          film->samples, ahead);
    float *image = malloc(sizeof(float) * 3 * (size_t)config.width * config.height);
    CHECK(pm_film_resolve_total(film, image), "resolve");
    double sum = 0;
    for (size_t i = 0; i < 3 * (size_t)config.width * config.height; i++) sum += image[i];
    CHECK(sum > 0 && isfinite(sum), "the cut film resolves to a lit image (%g)", sum);
    free(image);
    pm_session_destroy(session);
}

int main(void) {
    pm_scene s;
    build_room(&s);
    pm_scene_finalize(&s, false, NULL);
    char err[256];
    pm_accel *a = pm_accel_create(&s, err, sizeof err);
    CHECK(a != NULL, "%s", err);
    pm_camera cam = sb_camera(v3(0, 1, 0.95f), v3(0, 0.9f, 0), v3(0, 1, 0), 75.f);
    pm_session *classic[3];
    const pm_film *films[3];
    const pm_photon_maps *maps[3];
    bool rendered = true;
    for (int t = 0; t < 3; t++) {
        pm_photon_settings ps = {.global_photons = 20000, .caustic_photons = 20000, .seed = 77, .threads = t + 1,
                                 .max_bounces = 16, .projection_maps = true, .irradiance_stride = 4,
                                 .irradiance_estimate = {PM_KERNEL_DISC, 32, 0.5f, 7u}};
        pm_session_config config = mode_config(PM_MODE_CLASSIC, 40, 36, 99, t + 1);
        config.eye.max_specular_depth = 8;
        pm_estimate_settings estimate = {PM_KERNEL_DISC, 32, 0.2f, 7u};
        with_photons(&config, &ps, estimate, estimate);
        config.eye.gather_rays = 1;
        classic[t] = render_session(&s, a, &cam, &config, 2);
        rendered = rendered && classic[t];
        films[t] = classic[t] ? pm_session_film(classic[t]) : NULL;
        maps[t] = classic[t] ? pm_session_classic_maps(classic[t]) : NULL;
    }
    if (!rendered) return pm_test_done("test_threads");
    for (int t = 1; t < 3; t++) {
        CHECK(maps[t]->global.count == maps[0]->global.count && maps[t]->caustic.count == maps[0]->caustic.count,
              "photon counts differ at %d threads", t + 1);
        if (maps[t]->global.count == maps[0]->global.count)
            CHECK(memcmp(maps[t]->global.photons, maps[0]->global.photons, maps[0]->global.count * sizeof(pm_photon)) == 0,
                  "global map differs at %d threads", t + 1);
        if (maps[t]->caustic.count == maps[0]->caustic.count)
            CHECK(memcmp(maps[t]->caustic.photons, maps[0]->caustic.photons, maps[0]->caustic.count * sizeof(pm_photon)) == 0,
                  "caustic map differs at %d threads", t + 1);
    }
    CHECK(maps[0]->caustic.count > 0, "mirror and glass under an area light make caustic photons");
    size_t n = 3 * 40 * 36;
    double energy = 0;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        if (!films[0]->sum[c]) continue;
        for (int t = 1; t < 3; t++)
            CHECK(memcmp(films[0]->sum[c], films[t]->sum[c], n * sizeof(float)) == 0, "component %s differs between 1 and %d threads",
                  pm_component_names[c], t + 1);
        for (size_t i = 0; i < n; i++) energy += films[0]->sum[c][i];
    }
    CHECK(energy > 0, "the room must be lit");
    CHECK(films[0]->sum[PM_SPECULAR] != NULL, "mirror and glass make a specular buffer");
    for (int t = 0; t < 3; t++) pm_session_destroy(classic[t]);
    /* the progressive mode: eye pass, photon passes, grids and gather on every thread count, both
     * ways of reading indirect light */
    for (int mode = 0; mode < 2; mode++) {
        float *images[3];
        for (int t = 0; t < 3; t++) {
            pm_progressive_settings ps = {.seed = 5, .threads = t + 1, .photons = 8000, .caustic_photons = 8000,
                                          .alpha = 2.0 / 3.0, .indirect = mode ? PM_INDIRECT_PHOTONS : PM_INDIRECT_GATHER,
                                          .max_specular_depth = 8, .max_photon_bounces = 16};
            session r;
            images[t] = calloc(n, sizeof(float));
            if (start(&r, &s, a, &cam, 40, 36, &ps) && iterate_passes(&r, 3)) pm_film_resolve_total(r.film, images[t]);
            stop(&r);
        }
        for (int t = 1; t < 3; t++)
            CHECK(memcmp(images[0], images[t], n * sizeof(float)) == 0, "progressive (%s) image differs between 1 and %d threads",
                  mode ? "photons" : "gather", t + 1);
        for (int t = 0; t < 3; t++) free(images[t]);
    }
    background_session(&s, a, cam);
    cut_sessions(&s, a, cam);
    pm_accel_destroy(a);
    pm_scene_free(&s);
    return pm_test_done("test_threads");
}

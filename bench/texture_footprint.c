/* texture_footprint.c: the eye pass's cost with an 8K texture against a 1K one on the same scene, with texture filtering by footprint and without (level 0 alone), as ratios within one run.
 *
 * Usage: build/rel/texture_footprint — prints "bench texture_footprint ..." lines. The scene is a
 * plane tilted away from the camera filling a 640 x 480 view under a sky (classic mode, no
 * photon pass, one thread): every pixel reads the base colour texture once at its camera hit. The
 * textures are made in memory (random texels: nothing about their content helps a cache). Without
 * the footprint, every lookup of the 8K texture lands on texels its neighbours' lookups do not
 * share, and misses the caches; with it, the pixel reads the level whose texels are about its own
 * size, as the 1K texture's. Each figure is the best of five interleaved runs, in processor time.
 * A second line gives the shimmer of the 8K plane's first iteration with and without (shimmer()).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "accel.h"
#include "clock.h"
#include "eye.h"
#include "film.h"
#include "memory.h"
#include "rng.h"
#include "scene.h"
#include "scene_builder.h"
#include "session.h"

enum { WIDTH = 640, HEIGHT = 480, ITERATIONS = 4 };

/* A plane 24 x 24 at y = 0 with one texture of side n repeated 8 times across it, under a white sky. */
static pm_accel *textured_plane(pm_scene *s, int n, double *levels_seconds) {
    memset(s, 0, sizeof *s);
    uint32_t m = sb_lambert(s, v3s(0.8f));
    s->textures = calloc(1, sizeof *s->textures);
    pm_texture *t = &s->textures[0];
    t->width = t->height = n;
    t->wrap_s = t->wrap_t = PM_WRAP_REPEAT;
    t->rgba = malloc(4 * (size_t)n * n);
    if (!t->rgba) return NULL;
    pm_rng rng = pm_rng_for(17, (uint64_t)n, 0);
    uint32_t *texels = (uint32_t *)(void *)t->rgba;
    for (size_t i = 0; i < (size_t)n * n; i++) texels[i] = pm_rng_u32(&rng) | 0xff000000u;
    s->texture_count = 1;
    s->materials[m].base_color_texture = 0;
    sb_quad(s, v3(-12, 0, 12), v3(12, 0, 12), v3(12, 0, -12), v3(-12, 0, -12), m);
    s->uvs = malloc(2 * sizeof(float) * s->vertex_count);
    for (uint32_t i = 0; i < s->vertex_count; i++) {
        s->uvs[2 * i] = (s->positions[i].x + 12.f) / 3.f;
        s->uvs[2 * i + 1] = (s->positions[i].z + 12.f) / 3.f;
    }
    s->sky = true;
    s->sky_radiance = v3s(1.f);
    double start = pm_now_seconds();
    pm_accel *a = sb_finish(s);
    *levels_seconds = pm_now_seconds() - start;
    return a;
}

static double process_seconds(void) {
    struct timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* Processor seconds of ITERATIONS classic iterations without photons, one thread: the eye passes
 * and little else. The process's own time, not the wall clock's: the machine is shared, and a
 * neighbour's load would move the wall-clock figures more than the textures do. */
static double eye_seconds(const pm_scene *s, const pm_accel *a, const pm_camera *cam) {
    pm_session_config config;
    pm_session_config_defaults(&config, PM_MODE_CLASSIC, WIDTH, HEIGHT, 1, 1);
    config.classic_photon_pass = false;
    config.shadow.mode = PM_SHADOW_OFF;
    char err[256];
    pm_session *session = pm_session_create(s, a, cam, &config, err, sizeof err);
    if (!session) {
        fprintf(stderr, "texture_footprint: %s\n", err);
        exit(1);
    }
    pm_session_goal goal = {ITERATIONS, 0.0};
    double start = process_seconds();
    if (pm_session_run(session, &goal, NULL, NULL, NULL) != PM_RUN_DONE) {
        fprintf(stderr, "texture_footprint: %s\n", pm_session_error(session));
        exit(1);
    }
    double seconds = process_seconds() - start;
    pm_session_destroy(session);
    return seconds;
}

/* One iteration's image (the sum of the components, 3 floats a pixel) with this seed. */
static void one_iteration(const pm_scene *s, const pm_accel *a, const pm_camera *cam, uint64_t seed, float *out) {
    pm_session_config config;
    pm_session_config_defaults(&config, PM_MODE_CLASSIC, WIDTH, HEIGHT, seed, 2);
    config.classic_photon_pass = false;
    config.shadow.mode = PM_SHADOW_OFF;
    char err[256];
    pm_session *session = pm_session_create(s, a, cam, &config, err, sizeof err);
    pm_session_goal goal = {1, 0.0};
    if (!session || pm_session_run(session, &goal, NULL, NULL, NULL) != PM_RUN_DONE) {
        fprintf(stderr, "texture_footprint: %s\n", session ? pm_session_error(session) : err);
        exit(1);
    }
    pm_film_resolve_total(pm_session_film(session), out);
    pm_session_destroy(session);
}

/* Shimmer: how much two first iterations with different jitter differ, mean |a - b| over the mean
 * value. On this plane under a uniform sky the light is the same at every point, so what differs is
 * the texels each sample lands on. */
static double shimmer(const pm_scene *s, const pm_accel *a, const pm_camera *cam) {
    size_t n = 3 * (size_t)WIDTH * HEIGHT;
    float *x = malloc(n * sizeof *x), *y = malloc(n * sizeof *y);
    if (!x || !y) exit(1);
    one_iteration(s, a, cam, 1, x);
    one_iteration(s, a, cam, 2, y);
    double diff = 0.0, sum = 0.0;
    for (size_t i = 0; i < n; i++) {
        diff += fabs((double)x[i] - y[i]);
        sum += x[i];
    }
    free(x);
    free(y);
    return sum > 0.0 ? diff / sum : 0.0;
}

int main(void) {
    pm_scene small, large;
    double small_levels, large_levels;
    pm_accel *a_small = textured_plane(&small, 1024, &small_levels);
    pm_accel *a_large = textured_plane(&large, 8192, &large_levels);
    if (!a_small || !a_large) {
        fprintf(stderr, "texture_footprint: could not build the scenes\n");
        return 1;
    }
    /* looking down 45 degrees: the plane fills the view, 5.5 to 12 units away (a pixel covers
     * about 15 to 60 of the 8K texture's texels, 2 to 8 of the 1K texture's) */
    pm_camera cam = sb_camera(v3(0.f, 5.f, 5.f), v3(0.f, 0.f, 0.f), v3(0.f, 1.f, 0.f), 40.f);
    cam.aspect = (float)WIDTH / HEIGHT;
    double best[2][2] = {{INFINITY, INFINITY}, {INFINITY, INFINITY}}; /* [filtered][8K] */
    for (int run = 0; run < 5; run++)
        for (int filtered = 1; filtered >= 0; filtered--)
            for (int big = 0; big < 2; big++) {
                pm_scene *s = big ? &large : &small;
                int levels = s->textures[0].level_count;
                if (!filtered) s->textures[0].level_count = 1; /* level 0 alone, whatever the footprint */
                double t = eye_seconds(s, big ? a_large : a_small, &cam);
                s->textures[0].level_count = levels;
                if (t < best[filtered][big]) best[filtered][big] = t;
            }
    double flicker = shimmer(&large, a_large, &cam);
    int levels = large.textures[0].level_count;
    large.textures[0].level_count = 1;
    double flicker_level0 = shimmer(&large, a_large, &cam);
    large.textures[0].level_count = levels;
    printf("bench texture_shimmer width=%d height=%d texture=8k first_iteration_difference=%.4f level0=%.4f\n", WIDTH,
           HEIGHT, flicker, flicker_level0);
    printf("bench texture_footprint width=%d height=%d threads=1 iterations=%d cpu_seconds_1k=%.4f cpu_seconds_8k=%.4f "
           "ratio_8k_1k=%.3f cpu_seconds_1k_level0=%.4f cpu_seconds_8k_level0=%.4f ratio_8k_1k_level0=%.3f "
           "levels_seconds_1k=%.4f levels_seconds_8k=%.4f\n",
           WIDTH, HEIGHT, ITERATIONS, best[1][0], best[1][1], best[1][1] / best[1][0], best[0][0], best[0][1],
           best[0][1] / best[0][0], small_levels, large_levels);
    pm_accel_destroy(a_small);
    pm_accel_destroy(a_large);
    pm_scene_free(&small);
    pm_scene_free(&large);
    return 0;
}

/* bench_pm.c: speed figures measured as ratios within one run: eye and photon passes against raw Embree, kd-tree rates, thread scaling.
 *
 * Usage: build/rel/bench_pm [SCENE.gltf] — prints "bench KEY=VALUE ..." lines (stable, for
 * scripts) and nothing else. Absolute rates on a shared machine are noisy; the ratios, each
 * measured back to back and as the best of three interleaved runs, are the figures to compare.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "accel.h"
#include "eye.h"
#include "film.h"
#include "kdtree.h"
#include "loader.h"
#include "photonmap.h"
#include "rng.h"
#include "scene.h"

static double now_seconds(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + ts.tv_nsec * 1e-9;
}

/* Rays like the passes cast: camera rays and cosine bounces from their hits, half each. */
static size_t make_rays(const pm_scene *s, const pm_accel *a, const pm_camera *cam, size_t n, vec3 *o, vec3 *d) {
    pm_rng rng = pm_rng_for(11, 0, 0);
    size_t k = 0;
    while (k + 1 < n) {
        vec3 co, cd;
        pm_camera_ray(cam, 256, 256, pm_rng_float(&rng) * 256, pm_rng_float(&rng) * 256, &co, &cd);
        o[k] = co;
        d[k++] = cd;
        pm_hit h;
        if (!pm_accel_intersect(a, co, cd, INFINITY, &h)) continue;
        pm_surface sf;
        pm_scene_surface(s, h.tri, h.b1, h.b2, &sf);
        vec3 n = v3_dot(sf.ng, cd) < 0 ? sf.ng : v3_neg(sf.ng);
        o[k] = pm_surface_origin(&sf, n, s->ray_scale);
        d[k++] = pm_sample_cosine(n, pm_rng_float(&rng), pm_rng_float(&rng));
    }
    return k;
}

/* Rays like the photon pass casts: surface to surface in cosine directions, no camera rays.
 * Chains of bounces that start at camera hits, so they cover what the camera sees. */
static size_t make_scattered_rays(const pm_scene *s, const pm_accel *a, const pm_camera *cam, size_t n, vec3 *o, vec3 *d) {
    pm_rng rng = pm_rng_for(12, 0, 0);
    size_t k = 0;
    while (k < n) {
        vec3 ro, rd;
        pm_camera_ray(cam, 256, 256, pm_rng_float(&rng) * 256, pm_rng_float(&rng) * 256, &ro, &rd);
        for (int bounce = 0; bounce < 4 && k < n; bounce++) {
            pm_hit h;
            if (!pm_accel_intersect(a, ro, rd, INFINITY, &h)) break;
            pm_surface sf;
            pm_scene_surface(s, h.tri, h.b1, h.b2, &sf);
            vec3 nf = v3_dot(sf.ng, rd) < 0 ? sf.ng : v3_neg(sf.ng);
            ro = pm_surface_origin(&sf, nf, s->ray_scale);
            rd = pm_sample_cosine(nf, pm_rng_float(&rng), pm_rng_float(&rng));
            o[k] = ro;
            d[k++] = rd;
        }
    }
    return k;
}

static double raw_rate(const pm_accel *a, const vec3 *o, const vec3 *d, size_t n) {
    size_t hits;
    double best = 0;
    for (int r = 0; r < 3; r++) {
        double t = pm_accel_bench_raw(a, o, d, n, &hits);
        if (t > 0 && n / t > best) best = n / t;
    }
    return best;
}

static double eye_rate(const pm_scene *s, const pm_accel *a, const pm_camera *cam, int threads, int iterations) {
    bool comps[PM_COMPONENT_COUNT] = {true, true, false, false};
    pm_film film;
    pm_film_init(&film, 256, 256, comps);
    pm_eye_settings es;
    memset(&es, 0, sizeof es);
    es.seed = 1;
    es.threads = threads;
    es.max_specular_depth = 12;
    pm_eye_stats st = {0, 0, 0, false};
    for (int i = 0; i < iterations; i++) pm_eye_iterate(s, a, cam, &es, i, &film, &st);
    pm_film_free(&film);
    return st.rays / st.seconds;
}

int main(int argc, char **argv) {
    const char *path = argc > 1 ? argv[1] : "scenes/cornell-box.gltf";
    pm_scene s;
    pm_load_report rep;
    char err[1024];
    double t0 = now_seconds();
    if (!pm_load_gltf(path, true, &s, &rep, err, sizeof err)) { fprintf(stderr, "bench: %s\n", err); return 1; }
    pm_scene_finalize(&s, true, NULL);
    double load = now_seconds() - t0;
    pm_accel *a = pm_accel_create(&s, err, sizeof err);
    if (!a) { fprintf(stderr, "bench: %s\n", err); return 1; }
    printf("bench scene=%s triangles=%u load_seconds=%.4f bvh_seconds=%.4f bvh_bytes=%zu\n", path, s.triangle_count, load,
           pm_accel_build_seconds(a), pm_accel_bytes(a));
    pm_camera cam = s.camera_count ? s.cameras[0] : pm_scene_auto_camera(&s, 1.f);

    size_t n = 1000000;
    vec3 *o = malloc(n * sizeof *o), *d = malloc(n * sizeof *d);
    n = make_rays(&s, a, &cam, n, o, d);
    double raw1 = raw_rate(a, o, d, n);
    size_t ns = make_scattered_rays(&s, a, &cam, n, o, d);
    double raw_scattered = raw_rate(a, o, d, ns);
    printf("bench raw threads=1 eye_like_rays_per_second=%.0f scattered_rays_per_second=%.0f\n", raw1, raw_scattered);
    /* best of three, 1 and 2 threads interleaved: another tenant's burst lowers a run, never raises it */
    double eye1 = 0, eye2 = 0;
    for (int rep = 0; rep < 3; rep++) {
        double r1 = eye_rate(&s, a, &cam, 1, 8), r2 = eye_rate(&s, a, &cam, 2, 8);
        if (r1 > eye1) eye1 = r1;
        if (r2 > eye2) eye2 = r2;
    }
    printf("bench eye threads=1 rays_per_second=%.0f raw_embree_rays_per_second=%.0f ratio_to_raw=%.3f\n", eye1, raw1, eye1 / raw1);
    printf("bench eye threads=2 rays_per_second=%.0f speedup=%.2f\n", eye2, eye2 / eye1);

    double photon_rate[3] = {0, 0, 0}, photon_rays[3] = {0, 0, 0}, kd_seconds[3] = {0, 0, 0};
    uint64_t emitted = 0, stored = 0;
    pm_photon_maps maps;
    memset(&maps, 0, sizeof maps);
    for (int rep = 0; rep < 3; rep++)
        for (int threads = 1; threads <= 2; threads++) {
            pm_photon_settings ps;
            memset(&ps, 0, sizeof ps);
            ps.global_photons = 500000;
            ps.caustic_photons = 500000;
            ps.seed = 1;
            ps.threads = threads;
            ps.max_bounces = 32;
            ps.projection_maps = true;
            pm_photon_stats st;
            pm_photon_maps_free(&maps);
            if (!pm_photon_maps_build(&s, a, &ps, &maps, &st)) { fprintf(stderr, "bench: photon build failed\n"); return 1; }
            /* tracing only: the kd-tree build is measured on its own below */
            if (st.emitted / st.trace_seconds > photon_rate[threads]) {
                photon_rate[threads] = st.emitted / st.trace_seconds;
                photon_rays[threads] = st.rays / st.trace_seconds;
                kd_seconds[threads] = st.kdtree_seconds;
            }
            emitted = st.emitted;
            stored = st.stored_global + st.stored_caustic;
        }
    for (int threads = 1; threads <= 2; threads++)
        printf("bench photons threads=%d emitted=%llu stored=%llu photons_per_second=%.0f rays_per_second=%.0f ratio_to_raw_scattered=%.3f kdtree_seconds=%.4f\n",
               threads, (unsigned long long)emitted, (unsigned long long)stored, photon_rate[threads], photon_rays[threads],
               photon_rays[threads] / (raw_scattered * threads), kd_seconds[threads]);
    printf("bench photons speedup=%.2f\n", photon_rate[2] / photon_rate[1]);

    /* kd-tree: rebuild the global map's photons (copied) and query at random stored positions */
    size_t count = maps.global.count;
    if (count) {
        for (int threads = 1; threads <= 2; threads++) {
            pm_photon *copy = malloc(count * sizeof *copy);
            memcpy(copy, maps.global.photons, count * sizeof *copy);
            pm_kdtree t;
            double b0 = now_seconds();
            pm_kdtree_build(&t, copy, count, threads);
            double build = now_seconds() - b0;
            printf("bench kdtree threads=%d photons=%zu build_photons_per_second=%.0f\n", threads, count, count / build);
            if (threads == 2) {
                /* queries are independent, one thread measures their cost (the eye pass runs them per thread) */
                uint32_t idx[64];
                float d2[64], r2;
                pm_rng rng = pm_rng_for(3, 0, 0);
                int queries = 200000;
                double q0 = now_seconds();
                size_t found = 0;
                for (int q = 0; q < queries; q++) {
                    const pm_photon *ph = &t.photons[(size_t)(pm_rng_float(&rng) * count) % count];
                    found += pm_kdtree_nearest(&t, pm_photon_position(ph), 50, 1e30f, idx, d2, &r2);
                }
                double query = now_seconds() - q0;
                printf("bench knn threads=1 photons=%zu k=50 queries_per_second=%.0f found=%zu\n", count, queries / query, found);
            }
            pm_kdtree_free(&t);
        }
    }
    pm_photon_maps_free(&maps);
    free(o);
    free(d);
    pm_accel_destroy(a);
    pm_scene_free(&s);
    return 0;
}

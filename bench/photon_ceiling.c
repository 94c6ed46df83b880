/* photon_ceiling.c: the photon pass against raw Embree on the very rays it casts, the exact ceiling for its speed.
 *
 * Usage: build/rel/photon_ceiling [SCENE.gltf] — prints a "bench photon_ceiling KEY=VALUE ..." line for
 * the caustic pass, the global pass and both together (pass=caustic|global|both).
 *
 * bench_pm's photon ratio divides by the raw rate of cosine bounces from camera hits. On a closed
 * room those are much like photon paths; in an open scene most of them leave it at once, which
 * Embree answers far faster than the hits that photons aimed at glass make, so that ratio mixes
 * our own per-ray work with the difference of the two sets of rays. Here the pass's own rays are
 * recorded (the link wraps pm_accel_intersect for this program only: the renderer's code is the
 * same), then traced again in a bare rtcIntersect1 loop. Both rates come from one thread, as the
 * best of three interleaved runs; the pass's time is timed with recording off.
 */
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "accel.h"
#include "bench_settings.h"
#include "loader.h"
#include "photonmap.h"
#include "scene.h"

enum { MAX_LOGGED = 8 * 1000 * 1000 };
static vec3 *logged_origin, *logged_direction;
static size_t logged;
static bool logging;

bool __real_pm_accel_intersect(const pm_accel *a, vec3 o, vec3 d, float tmax, pm_hit *hit);
bool __wrap_pm_accel_intersect(const pm_accel *a, vec3 o, vec3 d, float tmax, pm_hit *hit);
bool __wrap_pm_accel_intersect(const pm_accel *a, vec3 o, vec3 d, float tmax, pm_hit *hit) {
    if (logging && logged < MAX_LOGGED) {
        logged_origin[logged] = o;
        logged_direction[logged++] = d;
    }
    return __real_pm_accel_intersect(a, o, d, tmax, hit);
}

/* One photon pass as bench_pm times it, on one thread: 500,000 photons of each kind the pass asks for. */
typedef enum { PASS_CAUSTIC, PASS_GLOBAL, PASS_BOTH } pass_kind;
static const char *const pass_name[] = {"caustic", "global", "both"};
static bool photon_pass(const pm_scene *s, const pm_accel *a, pass_kind kind, pm_photon_stats *st) {
    pm_photon_settings ps = bench_photon_settings(1);
    ps.global_photons = kind == PASS_CAUSTIC ? 0 : 500000;
    ps.caustic_photons = kind == PASS_GLOBAL ? 0 : 500000;
    pm_photon_maps maps;
    memset(&maps, 0, sizeof maps);
    bool ok = pm_photon_maps_build(s, a, &ps, &maps, st);
    pm_photon_maps_free(&maps);
    return ok;
}

int main(int argc, char **argv) {
    const char *path = argc > 1 ? argv[1] : "scenes/cornell-box.gltf";
    pm_scene s;
    pm_load_report rep;
    char err[1024];
    if (!pm_load_gltf(path, true, &s, &rep, err, sizeof err)) { fprintf(stderr, "photon_ceiling: %s\n", err); return 1; }
    pm_scene_finalize(&s, true, NULL);
    pm_accel *a = pm_accel_create(&s, err, sizeof err);
    if (!a) { fprintf(stderr, "photon_ceiling: %s\n", err); return 1; }
    logged_origin = malloc(MAX_LOGGED * sizeof *logged_origin);
    logged_direction = malloc(MAX_LOGGED * sizeof *logged_direction);
    if (!logged_origin || !logged_direction) { fprintf(stderr, "photon_ceiling: out of memory (ray log)\n"); return 1; }

    for (pass_kind kind = PASS_CAUSTIC; kind <= PASS_BOTH; kind++) {
        pm_photon_stats st;
        logged = 0;
        logging = true;
        bool ok = photon_pass(&s, a, kind, &st);
        logging = false;
        if (!ok) { fprintf(stderr, "photon_ceiling: photon pass failed\n"); return 1; }
        if (!st.rays) continue; /* no specular surface: no caustic pass */
        if (logged != st.rays) {
            fprintf(stderr, "photon_ceiling: logged %zu rays of %llu\n", logged, (unsigned long long)st.rays);
            return 1;
        }
        double pass_rate = 0.0, raw_rate = 0.0;
        size_t hits = 0;
        for (int rep_i = 0; rep_i < 3; rep_i++) {
            if (!photon_pass(&s, a, kind, &st)) return 1;
            if (st.rays / st.trace_seconds > pass_rate) pass_rate = st.rays / st.trace_seconds;
            double t = pm_accel_bench_raw(a, logged_origin, logged_direction, logged, &hits);
            if (t > 0 && logged / t > raw_rate) raw_rate = logged / t;
        }
        printf("bench photon_ceiling scene=%s pass=%s threads=1 rays=%zu hit_fraction=%.3f photon_rays_per_second=%.0f "
               "raw_own_rays_per_second=%.0f ratio_to_raw_own_rays=%.3f\n",
               path, pass_name[kind], logged, (double)hits / (double)logged, pass_rate, raw_rate, pass_rate / raw_rate);
    }
    free(logged_origin);
    free(logged_direction);
    pm_accel_destroy(a);
    pm_scene_free(&s);
    return 0;
}

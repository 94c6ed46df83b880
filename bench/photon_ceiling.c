/* photon_ceiling.c: the photon pass against raw Embree on the very rays it casts, the exact ceiling for its speed.
 *
 * Usage: build/rel/photon_ceiling [SCENE.gltf] — prints a "bench photon_ceiling KEY=VALUE ..." line for
 * the caustic pass, the global pass and both together (pass=caustic|global|both).
 *
 * bench_pm's photon ratio divides by the raw rate of cosine bounces from camera hits. On a closed
 * room those are much like photon paths; in an open scene most of them leave it at once, which
 * Embree answers far faster than the hits that photons aimed at glass make, so that ratio mixes
 * our own per-ray work with the difference of the two sets of rays. Here the pass's own rays are
 * recorded (the link wraps pm_accel_intersect and pm_accel_intersect_packets for this program
 * only: the renderer's code is the same), then traced again in a bare rtcIntersect1 loop. One
 * thread; the progressive mode's passes (a tracer and buffers kept across iterations); 15 pairs
 * of a pass (recording off) and the replay right after it. ratio_to_raw_own_rays is the median of
 * the pairs' ratios (ratio_quartiles its spread); the two rates printed are each the median of
 * their own, so their quotient need not equal it.
 * The pass casts its rays in packets of 8 (a wave of photons at a time), which Embree answers
 * faster than rtcIntersect1; the same rays, in the same packets, replayed bare (rtcIntersect8)
 * give the second ceiling, raw_packet_rays_per_second, and ratio_to_raw_packets: about the share
 * of the pass's time that is Embree's, the rest being our own work per ray. The rays are logged
 * in the pass's order (a wave's first rays, then its second, ...); rtcIntersect1 takes them 2-6%
 * slower than one photon's bounces after another (docs/design.md, why the photon pass traces in waves).
 * emission_share is what starting the photons alone costs (the same passes with max_bounces 0: the
 * photons emitted, no ray cast; median of PAIRS) over the whole pass: the part of our own work that
 * is no bounce.
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
void __real_pm_accel_intersect_packets(const pm_accel *a, size_t n, const vec3 *o, const vec3 *d, bool coherent, bool *hit,
                                       pm_hit *hits);
void __wrap_pm_accel_intersect_packets(const pm_accel *a, size_t n, const vec3 *o, const vec3 *d, bool coherent, bool *hit,
                                       pm_hit *hits);
void __wrap_pm_accel_intersect_packets(const pm_accel *a, size_t n, const vec3 *o, const vec3 *d, bool coherent, bool *hit,
                                       pm_hit *hits) {
    for (size_t i = 0; logging && i < n && logged < MAX_LOGGED; i++) {
        logged_origin[logged] = o[i];
        logged_direction[logged++] = d[i];
    }
    __real_pm_accel_intersect_packets(a, n, o, d, coherent, hit, hits);
}

/* One iteration's photon passes as the progressive mode (the default) runs them, on one thread:
 * PASS_PHOTONS photons of each kind asked for, traced by a tracer kept across iterations into buffers
 * kept across iterations. */
typedef enum { PASS_CAUSTIC, PASS_GLOBAL, PASS_BOTH } pass_kind;
static const char *const pass_name[] = {"caustic", "global", "both"};
enum { PASS_PHOTONS = 100000, PAIRS = 15 };
static pm_photon_buffer global_records, caustic_records;
static bool photon_pass(pm_photon_tracer *t, pass_kind kind, uint64_t seed, pm_photon_stats *st) {
    memset(st, 0, sizeof *st);
    bool ok = true;
    if (kind != PASS_CAUSTIC) ok = pm_photon_tracer_trace_into(t, false, PASS_PHOTONS, seed, &global_records, st);
    if (ok && kind != PASS_GLOBAL) ok = pm_photon_tracer_trace_into(t, true, PASS_PHOTONS, seed, &caustic_records, st);
    return ok;
}

static int compare_doubles(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
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
    pm_photon_settings settings = bench_photon_settings(1);
    pm_photon_tracer *tracer = pm_photon_tracer_create(&s, a, &settings);
    pm_photon_settings emit_settings = settings;
    emit_settings.max_bounces = 0;
    pm_photon_tracer *emitter = pm_photon_tracer_create(&s, a, &emit_settings);
    if (!tracer || !emitter) { fprintf(stderr, "photon_ceiling: out of memory (tracer)\n"); return 1; }
    logged_origin = malloc(MAX_LOGGED * sizeof *logged_origin);
    logged_direction = malloc(MAX_LOGGED * sizeof *logged_direction);
    if (!logged_origin || !logged_direction) { fprintf(stderr, "photon_ceiling: out of memory (ray log)\n"); return 1; }

    for (pass_kind kind = PASS_CAUSTIC; kind <= PASS_BOTH; kind++) {
        pm_photon_stats st;
        logged = 0;
        logging = true;
        bool ok = photon_pass(tracer, kind, 1, &st);
        logging = false;
        if (!ok) { fprintf(stderr, "photon_ceiling: photon pass failed\n"); return 1; }
        if (!st.rays) continue; /* no specular surface: no caustic pass */
        if (logged != st.rays) {
            fprintf(stderr, "photon_ceiling: logged %zu rays of %llu\n", logged, (unsigned long long)st.rays);
            return 1;
        }
        /* PAIRS pairs, each a pass and the replay of its rays right after it (a tenth of a second
         * apart): each pair's ratio sees the machine in one state, and the median of the ratios
         * shrugs off the pairs another tenant disturbed */
        double ratios[PAIRS], packet_ratios[PAIRS], pass_rates[PAIRS], raw_rates[PAIRS], packet_rates[PAIRS];
        double pass_seconds[PAIRS], emit_seconds[PAIRS];
        size_t hits = 0, packet_hits = 0;
        for (int pair = 0; pair < PAIRS; pair++) {
            if (!photon_pass(tracer, kind, 1, &st)) return 1;
            pass_seconds[pair] = st.trace_seconds;
            double t = pm_accel_bench_raw(a, logged_origin, logged_direction, logged, false, &hits);
            double tp = pm_accel_bench_raw(a, logged_origin, logged_direction, logged, true, &packet_hits);
            pass_rates[pair] = st.rays / st.trace_seconds;
            raw_rates[pair] = t > 0 ? logged / t : 0.0;
            packet_rates[pair] = tp > 0 ? logged / tp : 0.0;
            ratios[pair] = raw_rates[pair] > 0 ? pass_rates[pair] / raw_rates[pair] : 0.0;
            packet_ratios[pair] = packet_rates[pair] > 0 ? pass_rates[pair] / packet_rates[pair] : 0.0;
        }
        for (int pair = 0; pair < PAIRS; pair++) {
            pm_photon_stats emitted;
            if (!photon_pass(emitter, kind, 1, &emitted) || emitted.rays) return 1;
            emit_seconds[pair] = emitted.trace_seconds;
        }
        qsort(pass_seconds, PAIRS, sizeof *pass_seconds, compare_doubles);
        qsort(emit_seconds, PAIRS, sizeof *emit_seconds, compare_doubles);
        if (hits != packet_hits) {
            fprintf(stderr, "photon_ceiling: single rays hit %zu times, packets %zu\n", hits, packet_hits);
            return 1;
        }
        qsort(ratios, PAIRS, sizeof *ratios, compare_doubles);
        qsort(packet_ratios, PAIRS, sizeof *packet_ratios, compare_doubles);
        qsort(pass_rates, PAIRS, sizeof *pass_rates, compare_doubles);
        qsort(raw_rates, PAIRS, sizeof *raw_rates, compare_doubles);
        qsort(packet_rates, PAIRS, sizeof *packet_rates, compare_doubles);
        double pass_rate = pass_rates[PAIRS / 2], raw_rate = raw_rates[PAIRS / 2];
        printf("bench photon_ceiling scene=%s pass=%s threads=1 rays=%zu hit_fraction=%.3f photon_rays_per_second=%.0f "
               "raw_own_rays_per_second=%.0f ratio_to_raw_own_rays=%.3f ratio_quartiles=%.3f,%.3f pairs=%d "
               "raw_packet_rays_per_second=%.0f ratio_to_raw_packets=%.3f emission_share=%.3f\n",
               path, pass_name[kind], logged, (double)hits / (double)logged, pass_rate, raw_rate, ratios[PAIRS / 2],
               ratios[PAIRS / 4], ratios[3 * PAIRS / 4], PAIRS, packet_rates[PAIRS / 2], packet_ratios[PAIRS / 2],
               pass_seconds[PAIRS / 2] > 0 ? emit_seconds[PAIRS / 2] / pass_seconds[PAIRS / 2] : 0.0);
    }
    free(global_records.data);
    free(caustic_records.data);
    pm_photon_tracer_destroy(tracer);
    pm_photon_tracer_destroy(emitter);
    free(logged_origin);
    free(logged_direction);
    pm_accel_destroy(a);
    pm_scene_free(&s);
    return 0;
}

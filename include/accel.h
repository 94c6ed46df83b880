/* accel.h: ray queries over all scene triangles: closest hit and occlusion, the only place Embree is used.
 *
 * One Embree scene, built once: one triangle geometry, plus one for triangles whose material is
 * MASK or BLEND (glTF alphaMode), whose hits pass the alpha test inside every query: MASK cuts out
 * where alpha < alphaCutoff, BLEND lets each ray through with probability 1 - alpha, decided by a
 * hash of the ray and the triangle (see accel.c), so callers pass no random numbers. Rays are
 * single (rtcIntersect1 / rtcOccluded1), the integrators being incoherent path tracers, except
 * in two places, where rays go in packets of 8 with the same answers: where they start together
 * and point alike (a tile's camera rays: twice as fast), and the photon tracer's waves of
 * unrelated photons, whose rays Embree answers faster 8 to a call than one by one. A scene with
 * alpha-tested triangles must outlive its accel. Instanced meshes (scene.h) are Embree child
 * scenes placed by instance geometries; a hit's tri is the scene's triangle id either way.
 */
#ifndef PM_ACCEL_H
#define PM_ACCEL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "scene.h"

typedef struct pm_accel pm_accel;

typedef struct {
    float t;        /* distance along the (unit) direction */
    uint32_t tri;   /* triangle id in the scene (a stored index, or a placed triangle's: pm_scene_stored_triangle) */
    float b1, b2;   /* barycentrics of vertex 1 and vertex 2 */
} pm_hit;

pm_accel *pm_accel_create(const pm_scene *s, char *err, size_t err_size);
void pm_accel_destroy(pm_accel *a);
/* Closest hit in (0, tmax); d must be unit length. */
bool pm_accel_intersect(const pm_accel *a, vec3 o, vec3 d, float tmax, pm_hit *hit);
/* pm_accel_intersect(o[i], d[i], INFINITY, &hits[i]) for i < n, its answer in hit[i] (hits[i] is
 * written only where hit[i]), traced in packets of PM_ACCEL_PACKET consecutive rays. coherent:
 * rays that start together and point alike, in that order (a 4 x 2 block of camera rays, not a
 * row of 8), which Embree traces about twice as fast as single rays. Not coherent: unrelated
 * rays (a wave of photons), which Embree still answers 10-25% faster in a packet than one call
 * each when called in a tight loop (build/rel/photon_ceiling: raw_packet_rays_per_second against raw_own_rays_per_second). */
#define PM_ACCEL_PACKET 8
void pm_accel_intersect_packets(const pm_accel *a, size_t n, const vec3 *o, const vec3 *d, bool coherent, bool *hit,
                                pm_hit *hits);
/* True when anything blocks (0, tmax). */
bool pm_accel_occluded(const pm_accel *a, vec3 o, vec3 d, float tmax);
/* Calls visit(user, tri, &radius) for every triangle that may lie within radius of p (at least
 * those that do: Embree offers each triangle whose bounds reach the ball, possibly more than
 * once), in no set order, until visit returns false. The visitor may shrink the radius it is
 * given: the search then offers what may lie within the smaller ball (within instances the ball
 * keeps its first radius). Returns true when every candidate was visited, false when visit ended
 * the search (or p or radius is out of Embree's range). */
bool pm_accel_triangles_near(const pm_accel *a, vec3 p, float radius, bool (*visit)(void *user, uint32_t tri, float *radius),
                             void *user);
size_t pm_accel_bytes(const pm_accel *a);
/* The memory forecast's share for the BVH of s: what it keeps, or (building) the build's peak. */
uint64_t pm_accel_forecast_bytes(const pm_scene *s, bool building);
double pm_accel_build_seconds(const pm_accel *a);
/* Triangles behind the alpha filter; 0 means no filter is installed (an opaque scene). */
uint32_t pm_accel_alpha_tested_triangles(const pm_accel *a);

/* Benchmark hook: casts n rays (o, d pairs) with plain rtcIntersect1 (packet false) or as
 * incoherent packets of PM_ACCEL_PACKET consecutive rays (rtcIntersect8, packet true) and returns
 * the seconds taken, so raw Embree throughput can be set beside ours in one run. */
double pm_accel_bench_raw(const pm_accel *a, const vec3 *origins, const vec3 *dirs, size_t n, bool packet, size_t *hits);

#endif

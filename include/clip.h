/* clip.h: the part of a photon-gather disc on the gather point's side of the geometry, so that no estimate reads light through a wall, from a floor below a floor or across a room's corner.
 *
 * A density estimate at a point p counts the photons within a radius r. The 25-degree normal
 * test (pm_photon_counts_for) already refuses photons on the back of a thin panel and on surfaces
 * turned away, but not photons on a surface that faces the same way beyond a wall (the next room's
 * floor, the sunlit ground outside a window) or a little below or above p (the ground under a
 * raised floor, a shelf). A clip bounds the disc by what the geometry around p shows:
 *   - probes along the tangent plane (PM_CLIP_PROBES rays, lifted a little off the surface, in a
 *     fan whose rotation is random per query) that meet a surface not continuing p's (its normal
 *     more than about 25 degrees from n) within reach: each adds that surface's plane, and
 *     photons behind the plane do not count;
 *   - one probe behind p (along -n) and one above it (along n) that meet a surface facing the way
 *     p's does: photons farther off p's tangent plane than half that distance do not count.
 *   - where a probe's clear stretch leaves p's triangle, a ray down to the surface from the
 *     stretch's end: where p's surface is gone (a shelf's edge, a sill, a hole), the edge found by
 *     halving the stretch adds its plane, so the disc's part over nothing is not counted as area.
 * The estimate then divides by the area of the disc that the planes keep (pm_clip_area_fraction
 * times pi r^2), not by the whole disc: where the photons' density is uniform the clipped estimate
 * is as unbiased as the disc's, and corners lose the darkening a disc reaching into a wall gives.
 * As r shrinks, the planes leave every point off the geometry unclipped: the limit is unchanged.
 * Where nothing but p's own flat surface, closed all round, lies within the probes' reach, no probe
 * could clip the disc: the clip is left open without casting one (pm_clip_needless: one query of
 * the BVH; pm_clip_cache_lookup: a cell of the triangle's clearance grid), the same clip the probes
 * would have made.
 * The design and its cost: docs/design.md, "Estimates stay on their side of the geometry".
 */
#ifndef PM_CLIP_H
#define PM_CLIP_H

#include <stdbool.h>
#include <stdint.h>
#include "accel.h"
#include "defaults.h"
#include "pm_math.h"
#include "scene.h"

#define PM_CLIP_MAX_PLANES (3 * PM_CLIP_PROBES) /* per probe: a plane where it stops, one where it slides on, one where p's surface ends */

typedef struct {
    vec3 p, n;               /* the gather point and its unit normal on the photons' side */
    vec3 t1, t2;             /* tangent basis, for the kept area */
    float below, above;      /* photons count within this distance of p's tangent plane, behind and in front */
    int planes;
    float tolerance;         /* a photon counts up to this far behind a plane (photons on the plane's own surface) */
    float rotation;          /* of the area pattern, radians */
    vec3 plane_point[PM_CLIP_MAX_PLANES];
    vec3 plane_normal[PM_CLIP_MAX_PLANES]; /* unit, toward p's side */
} pm_clip;

/* What is known of the surfaces around a disc's point before any probe: nothing, nothing within
 * any probe's reach (PM_CLEAR_OPEN: the clip stays open), nothing within the tangent fan's reach
 * (PM_CLEAR_SLAB: only the probes along the normal can bound it), or a surface within the fan's
 * reach (PM_CLEAR_NEAR: every probe is cast). */
typedef enum { PM_CLEAR_UNKNOWN, PM_CLEAR_OPEN, PM_CLEAR_NEAR, PM_CLEAR_SLAB } pm_clip_known;

/* Probes the geometry around p (on triangle tri, or PM_CLIP_NO_TRIANGLE where it is not known;
 * unit normal n on the side photons arrive) for a disc of radius up to reach; seed rotates the
 * probe fan (a hash of the pixel and the iteration, so the image does not depend on the threads).
 * Adds the rays it cast to *rays when not NULL. */
#define PM_CLIP_NO_TRIANGLE UINT32_MAX
void pm_clip_make(pm_clip *c, const pm_scene *s, const pm_accel *a, vec3 p, vec3 n, uint32_t tri, float reach,
                  uint64_t seed, uint64_t *rays);
/* The same given what is known (pm_clip_cache_lookup; UNKNOWN: pm_clip_make, which asks
 * pm_clip_search): the same clip, with only the probes that can meet something cast. */
void pm_clip_make_known(pm_clip *c, const pm_scene *s, const pm_accel *a, vec3 p, vec3 n, uint32_t tri, float reach,
                        uint64_t seed, uint64_t *rays, pm_clip_known known);
/* Only the probes along the normal: the clip pm_clip_make_probed makes where nothing lies within
 * the fan's reach (PM_CLEAR_SLAB); what the shortcut must agree with (tests/test_clip_shortcut.c). */
void pm_clip_make_slab(pm_clip *c, const pm_scene *s, const pm_accel *a, vec3 p, vec3 n, uint32_t tri, float reach,
                       uint64_t seed, uint64_t *rays);
/* The same with the probes always cast (pm_clip_make skips them where pm_clip_needless): what the
 * shortcut must agree with (tests/test_clip_shortcut.c). */
void pm_clip_make_probed(pm_clip *c, const pm_scene *s, const pm_accel *a, vec3 p, vec3 n, uint32_t tri, float reach,
                         uint64_t seed, uint64_t *rays);

/* Whether no probe of a clip at p (unit normal n) for a disc of radius up to reach could meet
 * anything: nothing but p's own flat surface lies within 2.01 reach of p (the probes' farthest),
 * and that surface has no edge there. One query of the BVH, no rays; pm_clip_make asks it first
 * and leaves such a clip open. False where unsure (a curved or cut-out surface, many small
 * triangles). */
bool pm_clip_needless(const pm_scene *s, const pm_accel *a, vec3 p, vec3 n, float reach);
/* What the same query knows (never PM_CLEAR_UNKNOWN): open, slab or near. */
pm_clip_known pm_clip_search(const pm_scene *s, const pm_accel *a, vec3 p, vec3 n, float reach);

/* Per-triangle clearance grids, built for a triangle once discs have asked about it a few times:
 * where a cell of p's triangle shows what pm_clip_needless would say, no search is made.
 * Create returns NULL where the scene is too large or instanced (then every disc searches). */
typedef struct pm_clip_cache pm_clip_cache;
pm_clip_cache *pm_clip_cache_create(const pm_scene *s, const pm_accel *a);
void pm_clip_cache_destroy(pm_clip_cache *c);
/* What p's cell on triangle tri shows for a disc of radius reach (pm_clip_known; for
 * pm_clip_make_known). Thread safe; c may be NULL. */

pm_clip_known pm_clip_cache_lookup(pm_clip_cache *c, uint32_t tri, vec3 p, float reach);
/* Starts loading p's cell on triangle tri, for a lookup soon after: a batch of discs prefetches
 * all its cells first, so that their cache misses overlap. */
void pm_clip_cache_prefetch(pm_clip_cache *c, uint32_t tri, vec3 p);
/* What p's cell shows of p's clearance, whatever the disc: at least low, at most high (-INFINITY
 * and INFINITY where the cell shows nothing). The discs of one point (a visible point's caustic
 * and indirect statistics) read the cell once and each asks pm_clip_bound_known with its own
 * radius; reach sizes the triangle's grid where this ask builds it. Thread safe; c may be NULL. */
typedef struct { float low, high; } pm_clip_bound;
void pm_clip_cache_bound(pm_clip_cache *c, uint32_t tri, vec3 p, float reach, pm_clip_bound *b);
pm_clip_known pm_clip_bound_known(const pm_clip_bound *b, const pm_scene *s, vec3 p, float reach);

/* A clip that keeps everything: an estimate may read its disc unclipped. */
static inline bool pm_clip_is_open(const pm_clip *c) {
    return !c->planes && c->below == INFINITY && c->above == INFINITY;
}

/* What a clip is made from, for an estimate that makes it only when its query found photons;
 * or, in made, one already made for a reach at least as long as the estimate's radius. */
typedef struct {
    const pm_scene *scene;
    const pm_accel *accel;
    uint32_t tri;
    uint64_t seed;
    uint64_t *rays;
    const pm_clip *made;
} pm_clip_site;

/* A clip that keeps everything (no probe cast). */
void pm_clip_open(pm_clip *c, vec3 p, vec3 n);

/* Whether a photon at x lies on p's side of every plane and within the slab. */
static inline __attribute__((always_inline)) bool pm_clip_keeps(const pm_clip *c, vec3 x) {
    vec3 d = v3_sub(x, c->p);
    float z = v3_dot(d, c->n);
    if (z < -c->below || z > c->above) return false;
    for (int k = 0; k < c->planes; k++)
        if (v3_dot(v3_sub(x, c->plane_point[k]), c->plane_normal[k]) < -c->tolerance) return false;
    return true;
}

/* The share of the disc of the given radius around p, in its tangent plane, that the planes keep:
 * 1 without planes, else counted over a fixed pattern of points rotated by c->rotation (at least
 * one point's share: p's own side is never empty). */
float pm_clip_area_fraction(const pm_clip *c, float radius);

#endif

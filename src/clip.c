/* clip.c: probes the geometry around a gather point for the planes and slab that bound its disc, and the share of the disc they keep. */
#include "clip.h"

#include <math.h>

#include "defaults.h"
#include "rng.h"

/* A surface continues p's when its normal is within the photons' normal test of p's (cos 0.9). */
#define CONTINUES_COS 0.9f
/* Surfaces a probe may pass (continuations of p's surface, or the wrong way round) before it gives up. */
#define PROBE_HITS 4

static vec3 triangle_normal(const pm_scene *s, uint32_t tri) { return pm_scene_triangle_face_normal(s, tri); }

static vec3 triangle_centroid(const pm_scene *s, uint32_t tri) {
    vec3 p[3];
    pm_scene_triangle_corners(s, tri, p);
    return v3_scale(v3_add(v3_add(p[0], p[1]), p[2]), 1.f / 3.f);
}

/* A step past a surface a probe goes through: far enough to leave its plane at any position. */
static float step_past(vec3 q, float scale) {
    float m = pm_maxf(fabsf(q.x), pm_maxf(fabsf(q.y), fabsf(q.z)));
    return pm_maxf(scale * 1e-6f, m * 1e-6f);
}

void pm_clip_open(pm_clip *c, vec3 p, vec3 n) {
    c->p = p;
    c->n = n;
    v3_basis(n, &c->t1, &c->t2);
    c->below = c->above = INFINITY;
    c->planes = 0;
    c->tolerance = 0.f;
    c->rotation = 0.f;
}

/* Along a tangent probe: the first surface within reach that does not continue p's, as a plane
 * facing the probe's origin. A probe that meets such a surface near a corner (the floor, seen from
 * a wall just above it) would hide what lies beyond along the corner (the next room's wall): it
 * slides on once along the surface it met, lifted off it, for the rest of its reach. Returns how
 * far the probe went before it first met anything (reach when it met nothing): the stretch of
 * the probe known to run above p's surface. */
static float tangent_probe(pm_clip *c, const pm_scene *s, const pm_accel *a, vec3 o, vec3 d, float reach, float lift,
                           uint64_t *rays) {
    int slides = 1;
    float clear = -1.f;
    for (int k = 0; k < PROBE_HITS && reach > 0.f && c->planes < PM_CLIP_MAX_PLANES; k++) {
        pm_hit h;
        if (rays) (*rays)++;
        if (!pm_accel_intersect(a, o, d, reach, &h)) break;
        if (clear < 0.f) clear = h.t;
        vec3 at = v3_madd(o, d, h.t), m = triangle_normal(s, h.tri);
        if (v3_dot(m, d) > 0.f) m = v3_neg(m);
        if (v3_dot(m, c->n) < CONTINUES_COS) {
            c->plane_point[c->planes] = at;
            c->plane_normal[c->planes] = m;
            c->planes++;
            vec3 along = v3_sub(d, v3_scale(m, v3_dot(d, m)));
            float len = v3_length(along);
            if (!slides-- || len < 0.2f) break;
            d = v3_scale(along, 1.f / len);
            o = v3_madd(at, m, lift);
            reach -= h.t;
            continue;
        }
        float step = step_past(at, s->ray_scale);
        o = v3_madd(at, d, step);
        reach -= h.t + step;
    }
    return clear;
}

/* How far a line from q along d (both in triangle tri's plane, q inside it) runs before it
 * leaves the triangle, and through which edge (its first vertex's index 0..2 in *edge). */
static float triangle_exit(const pm_scene *s, uint32_t tri, vec3 q, vec3 d, int *edge) {
    vec3 v[3];
    pm_scene_triangle_corners(s, tri, v);
    vec3 m = v3_cross(v3_sub(v[1], v[0]), v3_sub(v[2], v[0]));
    float best = INFINITY;
    *edge = -1;
    for (int k = 0; k < 3; k++) {
        vec3 a = v[k], b = v[(k + 1) % 3];
        vec3 inward = v3_cross(m, v3_sub(b, a)); /* in the plane, toward the triangle's inside */
        float toward = v3_dot(d, inward);
        if (toward >= 0.f) continue;
        float t = pm_maxf(v3_dot(v3_sub(q, a), inward), 0.f) / -toward;
        if (t < best) { best = t; *edge = k; }
    }
    return best;
}

/* Whether p's surface lies under the point o + d t of a probe line lifted `lift` above it: a ray
 * down from there meets a surface continuing p's (its normal within the normal test, no farther
 * below the line than its slope allows: a curved surface falls away from the tangent plane, a
 * step down to a lower floor does not count). The surface met is left in *tri. */
static bool surface_under(const pm_clip *c, const pm_scene *s, const pm_accel *a, vec3 o, vec3 d, float t, float lift,
                          uint32_t *tri, uint64_t *rays) {
    float depth = 2.f * lift + 0.5f * t;
    pm_hit h;
    if (rays) (*rays)++;
    if (!pm_accel_intersect(a, v3_madd(o, d, t), v3_neg(c->n), depth, &h)) return false;
    vec3 m = triangle_normal(s, h.tri);
    if (fabsf(v3_dot(m, c->n)) < CONTINUES_COS) return false;
    *tri = h.tri;
    return true;
}

/* Where p's surface ends along a probe (the edge of a shelf, a sill, a table, a hole in a floor)
 * within the stretch the probe ran clear of anything, the disc hangs over nothing: no photon can
 * land there, so the kept area must leave it out as it leaves out what lies behind a wall. The
 * edge is found by halving the stretch with rays down to the surface; its plane is the last
 * triangle met's edge the probe crosses, standing on p's tangent plane and facing p. */
static void ledge_probe(pm_clip *c, const pm_scene *s, const pm_accel *a, vec3 o, vec3 d, float clear, float lift,
                        uint32_t tri, uint64_t *rays) {
    enum { HALVINGS = 5 };
    if (c->planes >= PM_CLIP_MAX_PLANES || !(clear > 0.f)) return;
    vec3 foot = v3_madd(o, c->n, -lift); /* the probe's origin on p's tangent plane */
    int edge;
    /* the line leaves no part of p's own triangle within the stretch: nothing to look for */
    if (tri != PM_CLIP_NO_TRIANGLE && triangle_exit(s, tri, foot, d, &edge) >= clear) return;
    uint32_t met;
    if (surface_under(c, s, a, o, d, clear, lift, &met, rays)) return;
    float lo = 0.f, hi = clear;
    uint32_t last = tri;
    for (int k = 0; k < HALVINGS; k++) {
        float mid = 0.5f * (lo + hi);
        if (surface_under(c, s, a, o, d, mid, lift, &met, rays)) { lo = mid; last = met; }
        else hi = mid;
    }
    vec3 point = v3_madd(foot, d, 0.5f * (lo + hi)), normal = v3_neg(d);
    if (last != PM_CLIP_NO_TRIANGLE) {
        float out = triangle_exit(s, last, v3_madd(foot, d, lo), d, &edge);
        /* a triangle going on past the miss: the ray down slipped through a crack between triangles */
        if (edge >= 0 && out > (hi - lo) * 1.01f + step_past(foot, s->ray_scale)) return;
        if (edge >= 0) {
            vec3 corners[3];
            pm_scene_triangle_corners(s, last, corners);
            vec3 ea = corners[edge], eb = corners[(edge + 1) % 3];
            vec3 across = v3_cross(c->n, v3_sub(eb, ea)); /* in p's tangent plane, across the edge */
            float len = v3_length(across);
            if (len > 0.f) {
                across = v3_scale(across, 1.f / len);
                if (v3_dot(across, d) > 0.f) across = v3_neg(across);
                /* the edge's point where the probe crosses it, on p's tangent plane */
                point = v3_madd(foot, d, lo + out);
                normal = across;
            }
        }
    }
    c->plane_point[c->planes] = point;
    c->plane_normal[c->planes] = normal;
    c->planes++;
}

/* Along n (up) or -n (down): the distance to the first surface that may hold photons facing the
 * way p's do (its front faces that way, or it is double sided); INFINITY when none is within reach. */
static float normal_probe(const pm_clip *c, const pm_scene *s, const pm_accel *a, vec3 o, vec3 d, float reach, uint64_t *rays) {
    float travelled = 0.f;
    for (int k = 0; k < PROBE_HITS && travelled < reach; k++) {
        pm_hit h;
        if (rays) (*rays)++;
        if (!pm_accel_intersect(a, o, d, reach - travelled, &h)) return INFINITY;
        travelled += h.t;
        const pm_material *mat = &s->materials[pm_scene_triangle_material(s, h.tri)];
        if (mat->double_sided || v3_dot(triangle_normal(s, h.tri), c->n) >= CONTINUES_COS) return travelled;
        vec3 at = v3_madd(o, d, h.t);
        float step = step_past(at, s->ray_scale);
        o = v3_madd(at, d, step);
        travelled += step;
    }
    return INFINITY;
}

void pm_clip_make(pm_clip *c, const pm_scene *s, const pm_accel *a, vec3 p, vec3 n, uint32_t tri, float reach,
                  uint64_t seed, uint64_t *rays) {
    pm_clip_open(c, p, n);
    if (!(reach > 0.f) || !isfinite(reach)) return;
    uint64_t h = pm_hash64(seed);
    float fan = (float)(h >> 40) * (2.f * PM_PI / 16777216.f);
    c->rotation = (float)(h & 0xffffffu) * (2.f * PM_PI / 16777216.f);
    /* the origins are pulled toward the triangle's centroid, off shared edges, where it is known */
    vec3 centroid = tri == PM_CLIP_NO_TRIANGLE ? p : triangle_centroid(s, tri);
    /* the fan is lifted off the surface so that it does not graze its own triangles; a plane
     * keeps what lies on it up to rounding (a wall of no thickness has the next room's photons
     * just behind it) */
    float lift = PM_CLIP_LIFT * reach;
    c->tolerance = step_past(p, s->ray_scale);
    vec3 o = v3_madd(pm_offset_surface_origin(p, centroid, n, s->ray_scale), n, lift);
    /* a straight wall across the disc meets the nearest probe within reach / cos(pi / probes) */
    float fan_reach = reach / cosf(PM_PI / PM_CLIP_PROBES);
    for (int k = 0; k < PM_CLIP_PROBES; k++) {
        float angle = fan + 2.f * PM_PI * (float)k / PM_CLIP_PROBES;
        vec3 d = v3_add(v3_scale(c->t1, cosf(angle)), v3_scale(c->t2, sinf(angle)));
        float clear = tangent_probe(c, s, a, o, d, fan_reach, lift, rays);
        ledge_probe(c, s, a, o, d, clear < 0.f ? fan_reach : clear * 0.98f, lift, tri, rays);
    }
    /* a photon of the disc lies within reach of p: surfaces farther than twice that need no bound */
    float below = normal_probe(c, s, a, pm_offset_surface_origin(p, centroid, v3_neg(n), s->ray_scale), v3_neg(n),
                               2.f * reach, rays);
    float above = normal_probe(c, s, a, o, n, 2.f * reach, rays);
    c->below = 0.5f * below;
    c->above = 0.5f * (above + lift);
}

/* Points spread evenly over the unit disc (Vogel's sunflower), fixed: the kept share is counted on them. */
#define AREA_POINTS 128

float pm_clip_area_fraction(const pm_clip *c, float radius) {
    if (!c->planes) return 1.f;
    /* each plane as a line in the tangent plane: kept where base + radius (u a + v b) >= 0 */
    float base[PM_CLIP_MAX_PLANES], along1[PM_CLIP_MAX_PLANES], along2[PM_CLIP_MAX_PLANES];
    int cutting = 0;
    for (int k = 0; k < c->planes; k++) {
        base[cutting] = v3_dot(v3_sub(c->p, c->plane_point[k]), c->plane_normal[k]) + c->tolerance;
        along1[cutting] = radius * v3_dot(c->t1, c->plane_normal[k]);
        along2[cutting] = radius * v3_dot(c->t2, c->plane_normal[k]);
        /* a line no nearer p than the radius keeps the whole disc: only the others are counted */
        cutting += base[cutting] * base[cutting] < along1[cutting] * along1[cutting] + along2[cutting] * along2[cutting] ||
                   base[cutting] < 0.f;
    }
    if (!cutting) return 1.f;
    /* the i-th point at angle rotation + i x golden: turned by one golden angle a step */
    const float golden_cos = -0.73736887f, golden_sin = 0.67549029f; /* the angle pi (3 - sqrt 5) */
    float dir_u = cosf(c->rotation), dir_v = sinf(c->rotation);
    int kept = 0;
    for (int i = 0; i < AREA_POINTS; i++) {
        float rho = sqrtf((i + 0.5f) / AREA_POINTS), u = rho * dir_u, v = rho * dir_v;
        bool in = true;
        for (int k = 0; k < cutting; k++) in &= base[k] + u * along1[k] + v * along2[k] >= 0.f;
        kept += in;
        float next_u = dir_u * golden_cos - dir_v * golden_sin;
        dir_v = dir_u * golden_sin + dir_v * golden_cos;
        dir_u = next_u;
    }
    return kept ? (float)kept / AREA_POINTS : 1.f / AREA_POINTS;
}

/* clip.c: probes the geometry around a gather point for the planes and slab that bound its disc, and the share of the disc they keep. */
#include "clip.h"
#include "memory.h"

#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

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

/* ---- discs no probe can clip ----
 *
 * The probes can add a plane or a slab only where they meet something: a surface within the fan's
 * reach of p (the probes along the tangent plane, the rays down from their ends), one along p's
 * normal within twice the radius, or an edge of p's own surface within the fan's reach. All of
 * these lie within OPEN_REACH radii of p. p's clearance is the distance from p to the nearest of
 * them that is not p's own flat surface: the nearest other triangle, or the nearest edge where
 * that surface ends. Where it is at least OPEN_REACH radii, every probe would pass without effect
 * and the clip is open without casting one. The answer is the probes' own, found geometrically
 * (one query of the BVH, or a cell of the triangle's precomputed clearance grid); the crowded,
 * curved and cut-out places are left to the probes. */

/* Beyond every probe's reach: the probes along the normal go twice the radius, plus the lift. */
#define OPEN_REACH 2.01f
/* Triangles of p's flat surface near p, matched edge to edge: more and the probes decide. */
#define OPEN_FLAT_MAX 24
/* A triangle lies in p's plane when its normal is within this cosine of p's and p within rounding of its plane. */
#define OPEN_FLAT_COS 0.99999
#define OPEN_SEEN_MAX 32
/* Beyond the fan's reach: its probes go r / cos(pi / PM_CLIP_PROBES) along the tangent plane from
 * an origin lifted PM_CLIP_LIFT r off it, and the rays down from their ends meet p's own surface
 * within two lifts, where p's flat surface runs closed all round (1.4142 + 0.004, with a margin). A
 * disc whose clearance is at least this many radii gets no plane from the fan: only the probes
 * along the normal can bound it. */
#define SLAB_REACH 1.45f

/* SLAB_REACH radii, plus what the probes' origins move off p (toward the centroid and off the
 * surface, a few steps of the scene's rounding each). */
static float slab_need(const pm_scene *s, vec3 p, float reach) {
    float m = pm_maxf(fabsf(p.x), pm_maxf(fabsf(p.y), fabsf(p.z)));
    return SLAB_REACH * reach + 8.f * pm_maxf(s->ray_scale * (1.f / 65536.f), m * (1.f / 262144.f));
}

typedef struct {
    const pm_scene *s;
    double p[3], n[3];
    vec3 pf;
    double best;      /* the nearest other surface found so far (the search's radius at first) */
    double need;      /* the search may end once best falls below this */
    double tolerance; /* p's own rounding, well under the probes' offset off the surface (32 ulps along the normal) */
    bool on_flat;     /* p lies on one of the flat triangles */
    bool crowded;     /* more flat triangles than fit, or a cut-out: unknown */
    int flat, seen;
    uint32_t seen_tri[OPEN_SEEN_MAX]; /* triangles already judged: Embree offers a large one many times */
    float corners[OPEN_FLAT_MAX][3][3];
} clear_search;

static double d3_dot(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static void d3_sub(const double a[3], const double b[3], double out[3]) {
    for (int k = 0; k < 3; k++) out[k] = a[k] - b[k];
}
static void d3_cross(const double a[3], const double b[3], double out[3]) {
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

/* Distance from q to the segment ab. */
static double segment_distance(const double q[3], const double a[3], const double b[3]) {
    double ab[3], aq[3];
    d3_sub(b, a, ab);
    d3_sub(q, a, aq);
    double len2 = d3_dot(ab, ab), t = len2 > 0.0 ? d3_dot(aq, ab) / len2 : 0.0;
    t = t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t;
    double d[3] = {aq[0] - t * ab[0], aq[1] - t * ab[1], aq[2] - t * ab[2]};
    return sqrt(d3_dot(d, d));
}

/* Distance from q to triangle v of unit normal m: to its plane where q's projection falls inside
 * it, else to the nearest edge. */
static double triangle_distance(const double q[3], const double v[3][3], const double m[3]) {
    double rel[3];
    d3_sub(q, v[0], rel);
    bool inside = true;
    for (int k = 0; k < 3 && inside; k++) {
        double e[3], w[3], c[3];
        d3_sub(v[(k + 1) % 3], v[k], e);
        d3_sub(q, v[k], w);
        d3_cross(e, w, c);
        inside = d3_dot(c, m) >= 0.0;
    }
    if (inside) return fabs(d3_dot(rel, m));
    double best = INFINITY;
    for (int k = 0; k < 3; k++) best = fmin(best, segment_distance(q, v[k], v[(k + 1) % 3]));
    return best;
}

/* One triangle the BVH offers near p; false ends the search (the answer is known to be too small). */
static bool clear_visit(void *user, uint32_t tri, float *radius) {
    clear_search *o = user;
    const pm_scene *s = o->s;
    for (int i = 0; i < o->seen; i++)
        if (o->seen_tri[i] == tri) return true;
    if (o->seen < OPEN_SEEN_MAX) o->seen_tri[o->seen++] = tri;
    vec3 c[3];
    pm_scene_triangle_corners(s, tri, c);
    /* the cheap answer first: Embree offers a whole leaf's triangles, most far from p. A
     * triangle whose bounding box or plane lies beyond the nearest surface found so far changes
     * nothing (float rounding is far below the margin OPEN_REACH leaves over the probes). */
    vec3 pq = o->pf;
    float far = (float)o->best;
    if (pm_minf(c[0].x, pm_minf(c[1].x, c[2].x)) > pq.x + far || pm_maxf(c[0].x, pm_maxf(c[1].x, c[2].x)) < pq.x - far ||
        pm_minf(c[0].y, pm_minf(c[1].y, c[2].y)) > pq.y + far || pm_maxf(c[0].y, pm_maxf(c[1].y, c[2].y)) < pq.y - far ||
        pm_minf(c[0].z, pm_minf(c[1].z, c[2].z)) > pq.z + far || pm_maxf(c[0].z, pm_maxf(c[1].z, c[2].z)) < pq.z - far)
        return true;
    vec3 mf = v3_cross(v3_sub(c[1], c[0]), v3_sub(c[2], c[0]));
    float hf = v3_dot(mf, v3_sub(pq, c[0]));
    if (hf * hf > 1.0001f * far * far * v3_dot(mf, mf)) return true;
    double v[3][3] = {{c[0].x, c[0].y, c[0].z}, {c[1].x, c[1].y, c[1].z}, {c[2].x, c[2].y, c[2].z}};
    double e1[3], e2[3], m[3], rel[3];
    d3_sub(v[1], v[0], e1);
    d3_sub(v[2], v[0], e2);
    d3_cross(e1, e2, m);
    double len = sqrt(d3_dot(m, m));
    if (!(len > 0.0)) return true; /* no area: no ray meets it */
    for (int k = 0; k < 3; k++) m[k] /= len;
    /* a cut-out lets probes through here and not there: the probes decide */
    bool opaque = s->materials[pm_scene_triangle_material(s, tri)].alpha_mode == PM_ALPHA_OPAQUE;
    d3_sub(o->p, v[0], rel);
    double h = d3_dot(rel, m), facing = d3_dot(m, o->n);
    if (opaque && fabs(facing) >= OPEN_FLAT_COS && fabs(h) <= o->tolerance) {
        for (int i = 0; i < o->flat; i++)
            if (!memcmp(o->corners[i], c, sizeof o->corners[i])) return true; /* offered again */
        if (o->flat == OPEN_FLAT_MAX) { o->crowded = true; return false; }
        memcpy(o->corners[o->flat++], c, sizeof o->corners[0]);
        if (!o->on_flat && triangle_distance(o->p, v, m) <= 4.0 * o->tolerance) o->on_flat = true;
        return true;
    }
    double d = opaque ? triangle_distance(o->p, v, m) : 0.0;
    if (d < o->best) {
        o->best = d;
        /* nothing beyond the nearest surface found can lower it: the search narrows to it (the
         * flat triangles that close an edge nearer than that lie within it too) */
        *radius = pm_minf(*radius, (float)d * 1.001f + (float)o->tolerance);
    }
    return o->best >= o->need;
}

/* The flat triangles' edges within best of p that no other flat triangle closes (the same two
 * corners, its third on the other side of the edge) are where p's surface ends: best falls to the
 * nearest. */
static void flat_edges(clear_search *o) {
    for (int i = 0; i < o->flat; i++)
        for (int k = 0; k < 3; k++) {
            const float *a = o->corners[i][k], *b = o->corners[i][(k + 1) % 3], *third = o->corners[i][(k + 2) % 3];
            double da[3] = {a[0], a[1], a[2]}, db[3] = {b[0], b[1], b[2]};
            double d = segment_distance(o->p, da, db);
            if (d >= o->best) continue;
            /* the third corner's side of the edge, about p's normal */
            double ab[3] = {db[0] - da[0], db[1] - da[1], db[2] - da[2]}, at[3] = {third[0] - da[0], third[1] - da[1], third[2] - da[2]}, x[3];
            d3_cross(ab, at, x);
            double mine = d3_dot(x, o->n);
            bool closed = false;
            for (int j = 0; j < o->flat && !closed; j++) {
                if (j == i) continue;
                for (int l = 0; l < 3 && !closed; l++) {
                    const float *c0 = o->corners[j][l], *c1 = o->corners[j][(l + 1) % 3], *other = o->corners[j][(l + 2) % 3];
                    bool same = (!memcmp(c0, a, 12) && !memcmp(c1, b, 12)) || (!memcmp(c0, b, 12) && !memcmp(c1, a, 12));
                    if (!same) continue;
                    double ot[3] = {other[0] - da[0], other[1] - da[1], other[2] - da[2]};
                    d3_cross(ab, ot, x);
                    closed = d3_dot(x, o->n) * mine < 0.0;
                }
            }
            if (!closed) o->best = d;
        }
}

/* p's clearance (see above), searched up to `reach`: reach when nothing is nearer; -1 where it
 * is unknown (p on no flat triangle, too many of them). The search ends early once the answer is
 * known to be below `need` (returning a distance below need, an upper bound of the clearance). */
static double clearance(const pm_scene *s, const pm_accel *a, vec3 p, vec3 n, double reach, double need) {
    clear_search o;
    o.s = s;
    o.p[0] = p.x, o.p[1] = p.y, o.p[2] = p.z;
    o.n[0] = n.x, o.n[1] = n.y, o.n[2] = n.z;
    o.pf = p;
    o.best = reach;
    o.need = need;
    float m = pm_maxf(fabsf(p.x), pm_maxf(fabsf(p.y), fabsf(p.z)));
    o.tolerance = ldexp(pm_maxf(m, 1e-30f), -21);
    o.on_flat = o.crowded = false;
    o.flat = o.seen = 0;
    bool all = pm_accel_triangles_near(a, p, (float)reach, clear_visit, &o);
    if (o.crowded) return -1.0;
    if (!all) return o.best < o.need ? o.best : -1.0; /* ended at a surface nearer than need, or p out of range */
    if (!o.on_flat) return -1.0;
    flat_edges(&o);
    return o.best;
}

bool pm_clip_needless(const pm_scene *s, const pm_accel *a, vec3 p, vec3 n, float reach) {
    double need = OPEN_REACH * (double)reach;
    return clearance(s, a, p, n, need, need) >= need;
}

pm_clip_known pm_clip_search(const pm_scene *s, const pm_accel *a, vec3 p, vec3 n, float reach) {
    double need = OPEN_REACH * (double)reach, slab = slab_need(s, p, reach);
    double clear = clearance(s, a, p, n, need, slab);
    return clear >= need ? PM_CLEAR_OPEN : clear >= slab ? PM_CLEAR_SLAB : PM_CLEAR_NEAR;
}

/* ---- per-triangle clearance grids ----
 *
 * A triangle many discs ask about gets a grid over its plane: per cell, the clearance at the
 * cell's centre. A distance changes no faster than the point moves, so a point at distance d from
 * the centre has a clearance within d of it: a disc whose bound certifies OPEN_REACH radii needs
 * no search at all, and one whose bound shows a surface nearer goes straight to the probes. Grids
 * are built whole by the first thread to ask and published at once; a cell that certifies neither
 * sends the disc on to the search. Either way the clip is the probes' own, so the image does not
 * depend on which thread built what, or when. */

#define GRID_AFTER 16       /* asks before a triangle's grid is built */
#define GRID_MAX 64         /* cells a side */
#define GRID_BYTES (16u << 20) /* all grids together, at most */
#define GRID_TRIANGLES (1u << 20) /* scenes larger than this search each time */

typedef struct {
    vec3 origin, u, w;  /* the plane's frame: origin + x u + y w */
    vec3 m;             /* its unit normal */
    float cell;         /* side of a cell */
    int nu, nw;
    float reach;        /* clearances were searched this far */
    float clear[];      /* nu x nw cells, row by row: the clearance at the cell's centre (-1: unknown;
                           INFINITY: at least reach) */
} clear_grid;

struct pm_clip_cache {
    const pm_scene *scene;
    const pm_accel *accel;
    uint32_t count;
    _Atomic(clear_grid *) *grid;
    _Atomic uint32_t *asks;
    _Atomic uint64_t bytes;
};

static clear_grid building_marker;
#define GRID_BUILDING (&building_marker)

pm_clip_cache *pm_clip_cache_create(const pm_scene *s, const pm_accel *a) {
    if (s->placement_count || !s->triangle_count || s->triangle_count > GRID_TRIANGLES) return NULL;
    /* the cache only saves time (without it each disc searches the BVH, to the same answer): a
     * failure here is handled, and forgiven so that no error names it */
    pm_clip_cache *c = pm_calloc(1, sizeof *c, "clip cache");
    if (!c) { pm_memory_forgive_last(); return NULL; }
    c->scene = s;
    c->accel = a;
    c->count = s->triangle_count;
    c->grid = pm_calloc(c->count, sizeof *c->grid, "clip cache");
    c->asks = c->grid ? pm_calloc(c->count, sizeof *c->asks, "clip cache") : NULL;
    if (!c->grid || !c->asks) { pm_memory_forgive_last(); pm_clip_cache_destroy(c); return NULL; }
    return c;
}

void pm_clip_cache_destroy(pm_clip_cache *c) {
    if (!c) return;
    for (uint32_t i = 0; c->grid && i < c->count; i++) {
        clear_grid *g = atomic_load(&c->grid[i]);
        if (g != GRID_BUILDING) free(g);
    }
    free((void *)c->grid);
    free((void *)c->asks);
    free(c);
}

/* Builds triangle tri's grid for discs of about radius r; NULL when it cannot. */
static clear_grid *build_grid(pm_clip_cache *c, uint32_t tri, float r) {
    const pm_scene *s = c->scene;
    vec3 v[3];
    pm_scene_triangle_corners(s, tri, v);
    vec3 m = v3_cross(v3_sub(v[1], v[0]), v3_sub(v[2], v[0]));
    float e = v3_length(v3_sub(v[1], v[0]));
    if (!(v3_length(m) > 0.f) || !(e > 0.f)) return NULL;
    m = v3_normalize(m);
    vec3 u = v3_scale(v3_sub(v[1], v[0]), 1.f / e), w = v3_cross(m, u);
    float lo_u = INFINITY, hi_u = -INFINITY, lo_w = INFINITY, hi_w = -INFINITY;
    for (int k = 0; k < 3; k++) {
        vec3 d = v3_sub(v[k], v[0]);
        lo_u = pm_minf(lo_u, v3_dot(d, u)), hi_u = pm_maxf(hi_u, v3_dot(d, u));
        lo_w = pm_minf(lo_w, v3_dot(d, w)), hi_w = pm_maxf(hi_w, v3_dot(d, w));
    }
    float extent = pm_maxf(hi_u - lo_u, hi_w - lo_w);
    /* cells half the radius wide where the triangle allows */
    int cells = (int)pm_minf(GRID_MAX, pm_maxf(1.f, ceilf(extent / (0.5f * r))));
    float cell = extent / (float)cells * 1.0001f;
    int nu = (int)pm_maxf(1.f, ceilf((hi_u - lo_u) / cell)), nw = (int)pm_maxf(1.f, ceilf((hi_w - lo_w) / cell));
    size_t bytes = sizeof(clear_grid) + sizeof(float) * (size_t)nu * (size_t)nw;
    if (atomic_fetch_add(&c->bytes, bytes) + bytes > GRID_BYTES) return NULL;
    clear_grid *g = pm_malloc(bytes, "clip cache grid");
    if (!g) { pm_memory_forgive_last(); return NULL; } /* the disc searches the BVH: the same answer */
    g->origin = v3_add(v[0], v3_add(v3_scale(u, lo_u), v3_scale(w, lo_w)));
    g->u = u, g->w = w, g->m = m, g->cell = cell, g->nu = nu, g->nw = nw;
    /* clearances are searched up to what a disc a few times this one's size could ask */
    double reach = OPEN_REACH * 4.0 * r + 0.70711 * cell;
    g->reach = (float)reach;
    for (int j = 0; j < nw; j++)
        for (int i = 0; i < nu; i++) {
            vec3 centre = v3_add(g->origin, v3_add(v3_scale(u, (i + 0.5f) * cell), v3_scale(w, (j + 0.5f) * cell)));
            double clear = clearance(s, c->accel, centre, m, reach, 0.0);
            g->clear[j * nu + i] = clear < 0.0 ? -1.f : clear >= reach ? INFINITY : (float)clear;
        }
    return g;
}

void pm_clip_cache_bound(pm_clip_cache *c, uint32_t tri, vec3 p, float reach, pm_clip_bound *b) {
    b->low = -INFINITY, b->high = INFINITY; /* unknown */
    if (!c || tri >= c->count || !(reach > 0.f)) return;
    clear_grid *g = atomic_load_explicit(&c->grid[tri], memory_order_acquire);
    if (!g) {
        if (atomic_fetch_add_explicit(&c->asks[tri], 1, memory_order_relaxed) + 1 != GRID_AFTER) return;
        clear_grid *none = NULL;
        if (!atomic_compare_exchange_strong(&c->grid[tri], &none, GRID_BUILDING)) return;
        g = build_grid(c, tri, reach);
        atomic_store_explicit(&c->grid[tri], g ? g : GRID_BUILDING, memory_order_release);
        if (!g) return;
    }
    if (g == GRID_BUILDING) return;
    vec3 d = v3_sub(p, g->origin);
    float x = v3_dot(d, g->u) / g->cell, y = v3_dot(d, g->w) / g->cell;
    int i = (int)floorf(x), j = (int)floorf(y);
    if (i < 0 || j < 0 || i >= g->nu || j >= g->nw) return;
    float clear = g->clear[j * g->nu + i];
    if (clear < 0.f) return;
    /* p's distance from the cell's centre: across the plane, and off it (p lies on it up to rounding) */
    float du = (x - (float)i - 0.5f) * g->cell, dw = (y - (float)j - 0.5f) * g->cell;
    float off = v3_dot(d, g->m);
    float moved = sqrtf(du * du + dw * dw + off * off) * 1.001f;
    /* relative margins far above float rounding of the distances */
    b->low = clear == INFINITY ? g->reach - moved : clear * 0.9999f - moved;
    b->high = clear == INFINITY ? INFINITY : clear * 1.0001f + moved;
}

pm_clip_known pm_clip_bound_known(const pm_clip_bound *b, const pm_scene *s, vec3 p, float reach) {
    if (b->low >= OPEN_REACH * reach * 1.0001f) return PM_CLEAR_OPEN;
    if (b->low == -INFINITY && b->high == INFINITY) return PM_CLEAR_UNKNOWN;
    float slab = slab_need(s, p, reach);
    if (b->low >= slab * 1.0001f) return PM_CLEAR_SLAB;
    if (b->high < slab * 0.9999f) return PM_CLEAR_NEAR;
    return PM_CLEAR_UNKNOWN;
}

pm_clip_known pm_clip_cache_lookup(pm_clip_cache *c, uint32_t tri, vec3 p, float reach) {
    pm_clip_bound b;
    pm_clip_cache_bound(c, tri, p, reach, &b);
    return c ? pm_clip_bound_known(&b, c->scene, p, reach) : PM_CLEAR_UNKNOWN;
}

void pm_clip_cache_prefetch(pm_clip_cache *c, uint32_t tri, vec3 p) {
    if (!c || tri >= c->count) return;
    clear_grid *g = atomic_load_explicit(&c->grid[tri], memory_order_acquire);
    if (!g || g == GRID_BUILDING) return;
    vec3 d = v3_sub(p, g->origin);
    int i = (int)(v3_dot(d, g->u) / g->cell), j = (int)(v3_dot(d, g->w) / g->cell);
    if (i < 0 || j < 0 || i >= g->nu || j >= g->nw) return;
    __builtin_prefetch(&g->clear[j * g->nu + i]);
}

static void make_probed(pm_clip *c, const pm_scene *s, const pm_accel *a, vec3 p, vec3 n, uint32_t tri, float reach,
                        uint64_t seed, uint64_t *rays, bool fan_reaches);

void pm_clip_make(pm_clip *c, const pm_scene *s, const pm_accel *a, vec3 p, vec3 n, uint32_t tri, float reach,
                  uint64_t seed, uint64_t *rays) {
    pm_clip_make_known(c, s, a, p, n, tri, reach, seed, rays, PM_CLEAR_UNKNOWN);
}

void pm_clip_make_known(pm_clip *c, const pm_scene *s, const pm_accel *a, vec3 p, vec3 n, uint32_t tri, float reach,
                        uint64_t seed, uint64_t *rays, pm_clip_known known) {
    if (known == PM_CLEAR_UNKNOWN && reach > 0.f && isfinite(reach)) known = pm_clip_search(s, a, p, n, reach);
    if (known == PM_CLEAR_OPEN) pm_clip_open(c, p, n);
    else make_probed(c, s, a, p, n, tri, reach, seed, rays, known != PM_CLEAR_SLAB);
}

void pm_clip_make_probed(pm_clip *c, const pm_scene *s, const pm_accel *a, vec3 p, vec3 n, uint32_t tri, float reach,
                         uint64_t seed, uint64_t *rays) {
    make_probed(c, s, a, p, n, tri, reach, seed, rays, true);
}

void pm_clip_make_slab(pm_clip *c, const pm_scene *s, const pm_accel *a, vec3 p, vec3 n, uint32_t tri, float reach,
                       uint64_t seed, uint64_t *rays) {
    make_probed(c, s, a, p, n, tri, reach, seed, rays, false);
}

/* The probes; without the fan where it is known to meet nothing (fan_reaches false). */
static void make_probed(pm_clip *c, const pm_scene *s, const pm_accel *a, vec3 p, vec3 n, uint32_t tri, float reach,
                        uint64_t seed, uint64_t *rays, bool fan_reaches) {
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
    for (int k = 0; k < PM_CLIP_PROBES && fan_reaches; k++) {
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

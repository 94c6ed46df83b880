/* scene_core.c: the scene's core, the region holding its bulk: small strays far from it (a forgotten helper, a camera target) are left out of every size the renderer derives from the scene. */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "memory.h"
#include "scene.h"

/* Why: ray offsets, the sky's and the sun's photon disc, the shadow-photon grid, default radii and
 * the automatic framing are sized from the scene's extent. A 0.2-unit cube 10^6 units from a
 * lit box made that extent 10^6: ray origins near the box stepped a whole box width off their
 * surface and the sun's photons spread over a disc 10^6 wide, so the image went black. Far
 * geometry needs none of those sizes: a point there is offset by ulps of its own coordinates.
 *
 * The core, on a sample of at most CORE_SAMPLES triangles (evenly strided over the ids): start
 * from the triangle nearest the area-weighted median of the centroids, then absorb every
 * triangle whose bounds lie within CORE_REACH times the core's extent of it, pass after pass
 * until none does. A core holding less than CORE_SHARE of the area takes the nearest triangle
 * left whatever its distance (two houses far apart are one scene) and goes on. The core is
 * then the bounds of every triangle, sampled or not, within that reach. Past CORE_PASSES passes
 * (a file built to defeat this) the core is the whole scene's bounds. */
#define CORE_SAMPLES 65536u
#define CORE_REACH 8.0
#define CORE_SHARE 0.9
#define CORE_PASSES 64

typedef struct {
    double lo[3], hi[3];
    double area;
} core_triangle;

static int compare_pairs(const void *a, const void *b) {
    const double *x = a, *y = b;
    return (x[0] > y[0]) - (x[0] < y[0]);
}

/* the distance (largest per axis) from a triangle's bounds to a box's, 0 when they overlap */
static double gap_to(const double lo[3], const double hi[3], const core_triangle *t) {
    double g = 0.0;
    for (int a = 0; a < 3; a++) g = fmax(g, fmax(t->lo[a] - hi[a], lo[a] - t->hi[a]));
    return g;
}

static void make_triangle(const double p[9], core_triangle *t) {
    for (int a = 0; a < 3; a++) {
        t->lo[a] = fmin(p[a], fmin(p[3 + a], p[6 + a]));
        t->hi[a] = fmax(p[a], fmax(p[3 + a], p[6 + a]));
    }
    double e1[3], e2[3];
    for (int a = 0; a < 3; a++) {
        e1[a] = p[3 + a] - p[a];
        e2[a] = p[6 + a] - p[a];
    }
    double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2], cz = e1[0] * e2[1] - e1[1] * e2[0];
    t->area = 0.5 * sqrt(cx * cx + cy * cy + cz * cz);
    if (!isfinite(t->area)) t->area = 0.0;
}

static void absorb(double lo[3], double hi[3], const core_triangle *t) {
    for (int a = 0; a < 3; a++) {
        lo[a] = fmin(lo[a], t->lo[a]);
        hi[a] = fmax(hi[a], t->hi[a]);
    }
}

static double extent_of(const double lo[3], const double hi[3]) {
    return fmax(hi[0] - lo[0], fmax(hi[1] - lo[1], hi[2] - lo[2]));
}

/* the area-weighted median of the centroids along each axis */
static bool weighted_medians(const core_triangle *t, uint32_t n, double total, double median[3]) {
    double *pairs = pm_malloc(2 * sizeof(double) * n, "scene core");
    if (!pairs) return false;
    for (int a = 0; a < 3; a++) {
        for (uint32_t i = 0; i < n; i++) {
            pairs[2 * i] = 0.5 * (t[i].lo[a] + t[i].hi[a]);
            pairs[2 * i + 1] = total > 0.0 ? t[i].area : 1.0;
        }
        qsort(pairs, n, 2 * sizeof(double), compare_pairs);
        double half = 0.5 * (total > 0.0 ? total : (double)n), sum = 0.0;
        median[a] = pairs[2 * (n - 1)];
        for (uint32_t i = 0; i < n; i++) {
            sum += pairs[2 * i + 1];
            if (sum >= half) { median[a] = pairs[2 * i]; break; }
        }
    }
    free(pairs);
    return true;
}

bool pm_core_bounds(const pm_core_source *src, double core_lo[3], double core_hi[3]) {
    uint64_t ids = src->count;
    if (ids < 2) return true;
    uint64_t stride = (ids + CORE_SAMPLES - 1) / CORE_SAMPLES;
    uint32_t n = 0, cap = (uint32_t)((ids + stride - 1) / stride);
    core_triangle *t = pm_malloc(sizeof *t * cap, "scene core");
    if (!t) return false;
    double total = 0.0, p[9];
    for (uint64_t i = 0; src->next(src->context, i == 0, p); i++) {
        if (i % stride || n >= cap) continue;
        make_triangle(p, &t[n]);
        total += t[n++].area;
    }
    double median[3];
    char *inside = n ? pm_calloc(n, 1, "scene core") : NULL;
    if (!inside || !weighted_medians(t, n, total, median)) {
        free(inside);
        free(t);
        return n == 0;
    }
    uint32_t start = 0;
    double nearest = INFINITY;
    for (uint32_t i = 0; i < n; i++) {
        double d = 0.0;
        for (int a = 0; a < 3; a++) d = fmax(d, fabs(0.5 * (t[i].lo[a] + t[i].hi[a]) - median[a]));
        if (d < nearest) { nearest = d; start = i; }
    }
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    absorb(lo, hi, &t[start]);
    inside[start] = 1;
    double weight = total > 0.0 ? t[start].area : 1.0, whole = total > 0.0 ? total : (double)n;
    bool settled = false;
    for (int pass = 0; pass < CORE_PASSES && !settled; pass++) {
        double reach = CORE_REACH * extent_of(lo, hi);
        bool grew = false;
        for (uint32_t i = 0; i < n; i++)
            if (!inside[i] && gap_to(lo, hi, &t[i]) <= reach) {
                absorb(lo, hi, &t[i]);
                inside[i] = 1;
                weight += total > 0.0 ? t[i].area : 1.0;
                grew = true;
            }
        if (grew) continue;
        if (weight >= CORE_SHARE * whole) { settled = true; break; }
        uint32_t next = n;
        double closest = INFINITY;
        for (uint32_t i = 0; i < n; i++) {
            double g = inside[i] ? INFINITY : gap_to(lo, hi, &t[i]);
            if (g < closest) { closest = g; next = i; }
        }
        if (next == n) { settled = true; break; }
        absorb(lo, hi, &t[next]);
        inside[next] = 1;
        weight += total > 0.0 ? t[next].area : 1.0;
    }
    free(inside);
    free(t);
    if (!settled || !(extent_of(lo, hi) >= 0.0)) return true; /* the whole scene's bounds */
    /* every triangle within reach of the sampled core, the unsampled ones included */
    double reach = CORE_REACH * extent_of(lo, hi), clo[3] = {INFINITY, INFINITY, INFINITY}, chi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint64_t i = 0; src->next(src->context, i == 0, p); i++) {
        core_triangle c;
        make_triangle(p, &c);
        if (gap_to(lo, hi, &c) <= reach) absorb(clo, chi, &c);
    }
    if (!(clo[0] <= chi[0] && clo[1] <= chi[1] && clo[2] <= chi[2])) return true;
    for (int a = 0; a < 3; a++) {
        core_lo[a] = clo[a];
        core_hi[a] = chi[a];
    }
    return true;
}

/* the scene's triangles in world space, placements applied */
typedef struct {
    const pm_scene *s;
    pm_triangle_walk w;
} scene_walk;

static bool next_scene_triangle(void *context, bool restart, double corners[9]) {
    scene_walk *sw = context;
    if (restart) sw->w = (pm_triangle_walk){.placement = -2};
    if (!pm_scene_walk_next(sw->s, &sw->w)) return false;
    vec3 p[3];
    pm_scene_walk_corners(sw->s, &sw->w, p);
    for (int k = 0; k < 3; k++)
        for (int a = 0; a < 3; a++) corners[3 * k + a] = (double)v3_get(p[k], a);
    return true;
}

bool pm_scene_core(const pm_scene *s, vec3 *core_min, vec3 *core_max) {
    double lo[3] = {s->bounds_min.x, s->bounds_min.y, s->bounds_min.z}, hi[3] = {s->bounds_max.x, s->bounds_max.y, s->bounds_max.z};
    scene_walk sw = {s, {.placement = -2}};
    pm_core_source src = {pm_scene_triangle_ids(s), &sw, next_scene_triangle};
    bool ok = pm_core_bounds(&src, lo, hi);
    *core_min = v3((float)lo[0], (float)lo[1], (float)lo[2]);
    *core_max = v3((float)hi[0], (float)hi[1], (float)hi[2]);
    return ok;
}

/* light.h: the small geometry of lights that direct light, photon emission and shadow photons share: a spot's cone falloff, an emitting triangle's corners, normal and area. */
#ifndef PM_LIGHT_H
#define PM_LIGHT_H

#include "pm_math.h"
#include "scene.h"

/* glTF's recommended spot cone falloff toward the unit direction light_to_point. */
static inline float pm_spot_falloff(const pm_light *l, vec3 light_to_point) {
    float cd = v3_dot(l->direction, light_to_point);
    float scale = 1.f / pm_maxf(1e-3f, l->cos_inner - l->cos_outer);
    float t = pm_minf(pm_maxf(cd * scale - l->cos_outer * scale, 0.f), 1.f);
    return t * t;
}

/* Triangle tri's corners, its unit face normal (by the winding; (0, 0, 1) when degenerate) and
 * its area, from one cross product: an emitter's geometry where a light sample or a photon starts
 * on it, or where a ray met it and its area pdf is wanted. */
typedef struct { vec3 p0, p1, p2, normal; float area; } pm_triangle_geometry;

static inline pm_triangle_geometry pm_triangle_geometry_of(const pm_scene *s, uint32_t tri) {
    vec3 p[3];
    pm_scene_triangle_corners(s, tri, p);
    pm_triangle_geometry g = {p[0], p[1], p[2], v3(0.f, 0.f, 1.f), 0.f};
    vec3 cross = v3_cross(v3_sub(g.p1, g.p0), v3_sub(g.p2, g.p0));
    float len = v3_length(cross);
    int32_t placement = pm_scene_placement_of(s, tri); /* a mirroring placement reverses the stored winding */
    if (placement >= 0) cross = v3_scale(cross, s->placements[placement].handedness);
    if (len > 0.f) g.normal = v3_scale(cross, 1.f / len);
    g.area = 0.5f * len;
    return g;
}

/* The point of the triangle at the barycentrics of p1 and p2. */
static inline vec3 pm_triangle_point(const pm_triangle_geometry *g, float b1, float b2) {
    return pm_barycentric_point(g->p0, g->p1, g->p2, b1, b2);
}

#endif

/* thin.h: light along straight lines across thin-walled glass: what a direct-light segment keeps, and the first surface past thin walls.
 *
 * A thin wall (KHR_materials_transmission without a volume, pm_surface.thin) bends nothing, so
 * next-event estimation may cross it: a segment to a light keeps kt x (1 - F) of each thin wall it
 * crosses (F: pm_thin_fresnel, the same the specular function's choice uses) and stops at
 * anything else. Paths that cross a thin wall by pm_scatter_specular's straight transmission
 * count that crossing as no scattering at all (vertex.h's `straight`): their light belongs to
 * direct light, so it is not counted twice. A rough thin wall (pm_surface.glass_alpha > 0)
 * scatters what crosses it: a segment stops there as at any surface, and paths crossing it count
 * a specular bounce (scatter.h). Scenes without thin glass (analysis.has_thin_glass) take
 * pm_accel_occluded alone: no extra cost.
 */
#ifndef PM_THIN_H
#define PM_THIN_H

#include <stdbool.h>
#include <stdint.h>
#include "accel.h"
#include "pm_math.h"
#include "scene.h"

/* One crossing for a ray from o along unit d whose closest hit is *h: false, and nothing done,
 * unless that surface is a smooth thin wall with some transmission; else its straight-through weight
 * multiplies *transmittance, the ray goes on from the wall's far side within tmax, and *hit and
 * *h (t still from o) are its next answer. *rays counts the query (may be NULL). */
bool pm_thin_step(const pm_scene *s, const pm_accel *a, vec3 o, vec3 d, float tmax, pm_hit *h, bool *hit,
                  vec3 *transmittance, uint64_t *rays);

/* Follows the ray (o, unit d) within (0, tmax) from the answer to its first closest-hit query
 * (hit, *h) across thin walls: while the surface hit is a smooth thin wall with some transmission, its
 * straight-through weight multiplies *transmittance and the ray goes on from its far side.
 * Returns whether the ray stops at a surface before tmax (*h is then that surface, h->t from o);
 * false when it reaches tmax or leaves the scene. A ray still crossing after
 * PM_THIN_MAX_CROSSINGS walls stops there (*transmittance 0). *rays counts the queries added
 * (may be NULL). */
bool pm_thin_cross(const pm_scene *s, const pm_accel *a, vec3 o, vec3 d, float tmax, bool hit, pm_hit *h,
                   vec3 *transmittance, uint64_t *rays);

/* Whether light passes the segment (o, unit d, tmax), and the fraction of it that does: thin walls
 * let through kt (1 - F) each, anything else (a rough thin wall too) blocks. In a scene without thin glass this is
 * !pm_accel_occluded with *transmittance 1. */
static inline bool pm_thin_visible(const pm_scene *s, const pm_accel *a, vec3 o, vec3 d, float tmax, vec3 *transmittance,
                                   uint64_t *rays) {
    *transmittance = v3s(1.f);
    if (!s->analysis.has_thin_glass) return !pm_accel_occluded(a, o, d, tmax);
    pm_hit h;
    bool hit = pm_accel_intersect(a, o, d, tmax, &h);
    return !pm_thin_cross(s, a, o, d, tmax, hit, &h, transmittance, rays) && !v3_is_black(*transmittance);
}

#endif

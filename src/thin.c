/* thin.c: straight segments across thin-walled glass (thin.h): the loop of closest-hit queries direct light uses. */
#include "thin.h"

#include "defaults.h"
#include "scatter.h"

bool pm_thin_step(const pm_scene *s, const pm_accel *a, vec3 o, vec3 d, float tmax, pm_hit *h, bool *hit,
                  vec3 *transmittance, uint64_t *rays) {
    pm_surface sf;
    pm_scene_surface_scattering(s, h->tri, h->b1, h->b2, &sf);
    /* a rough wall scatters what crosses it (its microfacets turn each ray): a segment through it
     * is not a path light takes, so it stops there like any surface (scatter.h) */
    if (!sf.thin || v3_is_black(sf.kt) || sf.glass_alpha > 0.f) return false;
    *transmittance = v3_mul(*transmittance, v3_scale(sf.kt, 1.f - pm_thin_fresnel(&sf, v3_neg(d))));
    /* on from the wall's far side, t still measured from o (a light's pdf reads the whole distance) */
    vec3 from = pm_thin_exit(&sf, d, s->ray_scale);
    float travelled = v3_dot(v3_sub(from, o), d);
    if (rays) (*rays)++;
    pm_hit next;
    *hit = pm_accel_intersect(a, from, d, tmax - travelled, &next);
    if (*hit) {
        next.t += travelled;
        *h = next;
    }
    return true;
}

bool pm_thin_cross(const pm_scene *s, const pm_accel *a, vec3 o, vec3 d, float tmax, bool hit, pm_hit *h,
                   vec3 *transmittance, uint64_t *rays) {
    for (int crossings = 0; hit; crossings++) {
        if (crossings == PM_THIN_MAX_CROSSINGS) {
            *transmittance = v3s(0.f);
            return true;
        }
        if (!pm_thin_step(s, a, o, d, tmax, h, &hit, transmittance, rays)) return true;
    }
    return false;
}

/* scatter.h: the one specular scattering function (mirror, glass with Fresnel) that eye paths, gather rays and photons share.
 *
 * Eye paths and photons must scatter identically or photon estimates are biased, so every
 * tracer calls pm_scatter_specular() once it has chosen the specular part of a surface. The
 * path-vertex kernel (vertex.h) owns the choice between the diffuse and specular parts and the
 * survival after it; this function picks mirror or glass in proportion
 * to their mean weights, lets Fresnel pick reflection or refraction, and returns the lobe's
 * colour divided by the probability of the pick, relative to the specular total. Thin-walled
 * glass (pm_surface.thin) lets the transmitted share through along the incoming direction:
 * nothing bends, and no medium is entered.
 */
#ifndef PM_SCATTER_H
#define PM_SCATTER_H

#include <stdbool.h>
#include "pm_math.h"
#include "rng.h"
#include "scene.h"

/* n turned to the side of `toward` (a face normal to the side a ray arrives from or leaves to). */
static inline vec3 pm_facing(vec3 n, vec3 toward) { return v3_dot(n, toward) < 0.f ? v3_neg(n) : n; }

typedef struct {
    vec3 direction;   /* unit, leaving the surface */
    vec3 origin;      /* offset off the surface on the side the ray leaves */
    vec3 weight;      /* lobe colour / P(lobe | specular) */
    float radiance_scale; /* (eta_i / eta_t)^2 on refraction, else 1: radiance, not flux, carries it */
    bool transmitted;
    bool straight;    /* crossed a thin wall along the incoming direction (transmitted too) */
} pm_specular_sample;

/* Unpolarised Fresnel reflectance of a smooth dielectric; cos_i > 0 on the incident side. */
static inline float pm_fresnel_dielectric(float cos_i, float eta_i, float eta_t, float *cos_t) {
    float sin_t = eta_i / eta_t * sqrtf(pm_maxf(0.f, 1.f - cos_i * cos_i));
    if (sin_t >= 1.f) { *cos_t = 0.f; return 1.f; }
    float ct = sqrtf(pm_maxf(0.f, 1.f - sin_t * sin_t));
    float rs = (eta_i * cos_i - eta_t * ct) / (eta_i * cos_i + eta_t * ct);
    float rp = (eta_t * cos_i - eta_i * ct) / (eta_t * cos_i + eta_i * ct);
    *cos_t = ct;
    return 0.5f * (rs * rs + rp * rp);
}

/* Fresnel reflectance of a thin wall met from wo (unit, leaving the surface toward the viewer): one
 * interface's at the material's ior, at the angle to the shading normal on wo's side. The thin
 * sheet of KHR_materials_transmission reflects this and lets kt x (1 - this) straight through. */
static inline float pm_thin_fresnel(const pm_surface *sf, vec3 wo) {
    vec3 ng = pm_facing(sf->ng, wo), ns = pm_facing(sf->ns, ng);
    float cos_t, cos_i = pm_maxf(0.f, pm_minf(1.f, v3_dot(wo, ns)));
    return pm_fresnel_dielectric(cos_i, 1.f, sf->ior, &cos_t);
}

/* Where a ray along unit d that crosses the thin wall sf goes on from: on its own line, just past
 * the wall (as far behind it as pm_surface_origin's offset), so the scene behind is not shifted by
 * the offset; at grazing angles, where that point would lie far along the line, the offset point. */
static inline vec3 pm_thin_exit(const pm_surface *sf, vec3 d, float scale) {
    vec3 back = pm_facing(sf->ng, d), off = pm_surface_origin(sf, back, scale);
    float depth = v3_dot(v3_sub(off, sf->p), back), cos_d = v3_dot(d, back);
    return cos_d > 0.1f ? v3_madd(sf->p, d, depth / cos_d) : off;
}

/* The perfect mirror's reflectance for light leaving at cosine cos_o to the shading normal: Schlick's
 * Fresnel, glTF's metal at roughness 0, rising from ks at normal incidence to ks_grazing (a white
 * mirror reflects ks at every angle, bit for bit). */
static inline vec3 pm_mirror_reflectance(const pm_surface *sf, float cos_o) {
    float m = pm_maxf(0.f, 1.f - pm_minf(1.f, cos_o)), m2 = m * m;
    return v3_add(sf->ks, v3_scale(v3_sub(v3s(sf->ks_grazing), sf->ks), m2 * m2 * m));
}

/* Mean weight of the specular part (mirror + glass) of a surface: S in Russian roulette (the
 * mirror's at normal incidence: the choice it makes needs only some positive weight per part, and
 * the survival rule takes any probability). */
static inline float pm_specular_weight(const pm_surface *sf) { return v3_average(sf->ks) + v3_average(sf->kt); }

/* Scatters a ray arriving along unit d off the specular part of sf. Returns false when the
 * path must end (a shading normal bent the refracted ray back out of the surface, or a rough
 * surface's microfacet sent it under the surface).
 *
 * Rough glass (sf->glass_alpha > 0: KHR_materials_transmission with roughness) is GGX microfacet
 * scattering (Walter et al., "Microfacet models for refraction through rough surfaces", 2007): a
 * microfacet normal m drawn from the visible normals seen from wo (Heitz 2018), then Fresnel at
 * wo.m picks reflection about m or refraction through it; the sample's weight is Smith's G1 of
 * the direction leaving (the visible-normal estimator's G2 / G1(wo) in Smith's separable form),
 * so it never exceeds the smooth glass's. A thin wall's rough transmission is its reflection
 * about m mirrored through the sheet (glTF's thin-walled BTDF: no bending, the roughness blurs).
 * That crossing scatters: it is a specular bounce like rough solid glass's, not `straight`, and
 * shadow rays stop at a rough thin wall (thin.h), so light across it reaches a diffuse point as
 * a caustic (photons) or along the path's own continuation, never as direct light along a line
 * the wall would have bent. Smooth glass draws no number for m: its paths are as they were. */
static inline bool pm_scatter_specular(const pm_surface *sf, vec3 d, pm_rng *rng, float scale, pm_specular_sample *out) {
    vec3 wo = v3_neg(d);
    bool front = v3_dot(sf->ng, wo) > 0.f;
    vec3 ng = front ? sf->ng : v3_neg(sf->ng);
    vec3 ns = pm_facing(sf->ns, ng);
    float wm = v3_average(sf->ks), wt = v3_average(sf->kt), total = wm + wt;
    out->radiance_scale = 1.f;
    out->transmitted = out->straight = false;
    bool reflect = true;
    vec3 m = ns; /* the normal reflection and refraction are about */
    bool rough = false;
    if (pm_rng_float(rng) * total < wm) {
        out->weight = v3_scale(pm_mirror_reflectance(sf, v3_dot(wo, ns)), total / wm);
    } else {
        out->weight = v3_scale(sf->kt, total / wt);
        float cos_wo = pm_minf(1.f, v3_dot(wo, ns));
        if (sf->glass_alpha > 0.f && cos_wo > 0.f) {
            float u1 = pm_rng_float(rng), u2 = pm_rng_float(rng);
            m = pm_ggx_visible_normal(sf->glass_alpha, ns, wo, cos_wo, u1, u2);
            rough = true;
        }
        if (sf->thin) {
            /* a sheet with no far side: both faces alike, the crossing ray goes on along d (smooth)
             * or along its reflection about m mirrored through the sheet (rough) */
            float cos_t, f = rough ? pm_fresnel_dielectric(pm_maxf(0.f, pm_minf(1.f, v3_dot(wo, m))), 1.f, sf->ior, &cos_t)
                                   : pm_thin_fresnel(sf, wo);
            if (pm_rng_float(rng) >= f) {
                out->direction = d;
                if (rough) {
                    vec3 r = v3_reflect(d, m);
                    out->direction = v3_sub(r, v3_scale(ns, 2.f * v3_dot(r, ns)));
                    if (!(v3_dot(out->direction, ng) < 0.f)) return false;
                    out->weight = v3_scale(out->weight, pm_ggx_g1(sf->glass_alpha, v3_dot(out->direction, ns)));
                }
                out->origin = pm_thin_exit(sf, out->direction, scale);
                out->transmitted = true;
                out->straight = !rough;
                reflect = false;
            }
        } else {
            float eta_i = front ? 1.f : sf->ior, eta_t = front ? sf->ior : 1.f, cos_t;
            float cos_i = rough ? pm_maxf(0.f, pm_minf(1.f, v3_dot(wo, m))) : cos_wo;
            float f = pm_fresnel_dielectric(cos_i, eta_i, eta_t, &cos_t);
            if (pm_rng_float(rng) >= f) {
                float eta = eta_i / eta_t;
                vec3 t = v3_normalize(v3_add(v3_scale(d, eta), v3_scale(m, eta * cos_i - cos_t)));
                if (v3_dot(t, ng) >= 0.f) return false;
                if (rough) out->weight = v3_scale(out->weight, pm_ggx_g1(sf->glass_alpha, v3_dot(t, ns)));
                out->direction = t;
                out->origin = pm_surface_origin(sf, v3_neg(ng), scale);
                out->radiance_scale = eta * eta;
                out->transmitted = true;
                reflect = false;
            }
        }
    }
    if (reflect) {
        vec3 r = v3_reflect(d, m);
        if (rough) {
            if (!(v3_dot(r, ng) > 0.f)) return false;
            out->direction = r;
            out->weight = v3_scale(out->weight, pm_ggx_g1(sf->glass_alpha, v3_dot(r, ns)));
        } else {
            /* a shading normal can tilt the mirror direction under the surface: reflect about the face */
            out->direction = v3_dot(r, ng) > 0.f ? r : v3_reflect(d, ng);
        }
        out->origin = pm_surface_origin(sf, ng, scale);
    }
    return true;
}

#endif

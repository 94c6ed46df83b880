/* brdf.c: the glTF metallic-roughness BRDF of brdf.h: GGX D, height-correlated Smith V, Schlick F, visible-normal sampling. */
#include "brdf.h"

static inline float schlick_weight(float cos_theta) {
    float m = pm_maxf(0.f, 1.f - cos_theta), m2 = m * m;
    return m2 * m2 * m;
}

static inline float ggx_d(float alpha2, float cos_h) {
    float c2 = cos_h * cos_h, t = c2 * (alpha2 - 1.f) + 1.f;
    return alpha2 / (PM_PI * t * t);
}

/* sqrt(cos^2 (1 - alpha^2) + alpha^2) = cos x (1 + 2 Lambda): Smith's term for one direction. */
static inline float smith_root(float alpha2, float c) { return sqrtf(c * c * (1.f - alpha2) + alpha2); }

/* Probability of sampling the specular lobe: the lobes' Fresnel-weighted reflectance at wo
 * (depends on wo only, as the pdf requires). A diffuse share keeps at least a fifth of the
 * samples, and the specular lobe too, so neither part is left to rare samples. */
static float specular_probability(const pm_brdf *b, float cos_o) {
    float w = schlick_weight(cos_o);
    float f0 = 0.04f * (1.f - b->metallic) + b->metallic * v3_average(b->base);
    float spec = f0 + (1.f - f0) * w;
    float diff = (1.f - b->metallic) * v3_average(b->base) * (1.f - (0.04f + 0.96f * w));
    if (!(diff > 0.f)) return 1.f;
    float p = spec / (spec + diff);
    return pm_minf(0.8f, pm_maxf(0.2f, p));
}

vec3 pm_brdf_eval(const pm_brdf *b, vec3 n, vec3 wo, vec3 wi) {
    float cos_o = v3_dot(n, wo), cos_i = v3_dot(n, wi);
    if (!(cos_o > 0.f) || !(cos_i > 0.f)) return v3s(0.f);
    vec3 h = v3_add(wo, wi);
    float hl = v3_length(h);
    if (!(hl > 0.f)) return v3s(0.f);
    h = v3_scale(h, 1.f / hl);
    float cos_h = pm_maxf(0.f, v3_dot(n, h)), v_h = pm_maxf(0.f, v3_dot(wo, h));
    float a2 = b->alpha * b->alpha;
    float vis = 0.5f / (cos_i * smith_root(a2, cos_o) + cos_o * smith_root(a2, cos_i));
    float dv = ggx_d(a2, cos_h) * vis, w = schlick_weight(v_h);
    vec3 f0 = v3_add(v3s(0.04f * (1.f - b->metallic)), v3_scale(b->base, b->metallic));
    vec3 fresnel = v3_add(f0, v3_scale(v3_sub(v3s(1.f), f0), w));
    /* The dielectric's diffuse base under its 4% coat: Schlick at the two macro angles, not at
     * v.h as the sample viewer does, whose sum with the coat reflects up to 1.39 at grazing
     * angles (measured, tests/test_brdf.c) where Russian roulette needs at most 1; still reciprocal. */
    float diffuse = (1.f - b->metallic) * (1.f - (0.04f + 0.96f * schlick_weight(cos_o))) *
                    (1.f - (0.04f + 0.96f * schlick_weight(cos_i))) * PM_INV_PI;
    return v3_scale(v3_add(v3_scale(fresnel, dv), v3_scale(b->base, diffuse)), b->weight);
}

float pm_brdf_pdf(const pm_brdf *b, vec3 n, vec3 wo, vec3 wi) {
    float cos_o = v3_dot(n, wo), cos_i = v3_dot(n, wi);
    if (!(cos_o > 0.f) || !(cos_i > 0.f)) return 0.f;
    float p_spec = specular_probability(b, cos_o);
    float pdf = (1.f - p_spec) * cos_i * PM_INV_PI;
    vec3 h = v3_add(wo, wi);
    float hl = v3_length(h);
    if (hl > 0.f) {
        h = v3_scale(h, 1.f / hl);
        float cos_h = v3_dot(n, h);
        if (cos_h > 0.f && v3_dot(wo, h) > 0.f) {
            /* visible normals: D(h) G1(wo) max(0, wo.h) / cos_o, times the reflection's Jacobian 1 / (4 wo.h) */
            float a2 = b->alpha * b->alpha;
            float g1 = 2.f * cos_o / (cos_o + smith_root(a2, cos_o));
            pdf += p_spec * ggx_d(a2, cos_h) * g1 / (4.f * cos_o);
        }
    }
    return pdf;
}

/* A GGX microfacet normal seen from v (local frame, v.z > 0), distributed as D(m) G1(v) max(0, v.m) / v.z. */
static vec3 sample_visible_normal(float alpha, vec3 v, float u1, float u2) {
    vec3 vh = v3_normalize(v3(alpha * v.x, alpha * v.y, v.z)); /* to the hemisphere configuration */
    float len2 = vh.x * vh.x + vh.y * vh.y;
    vec3 t1 = len2 > 0.f ? v3_scale(v3(-vh.y, vh.x, 0.f), 1.f / sqrtf(len2)) : v3(1.f, 0.f, 0.f);
    vec3 t2 = v3_cross(vh, t1);
    float r = sqrtf(u1), s, c;
    pm_sincos_turn(u2, &s, &c);
    float p1 = r * c, p2 = r * s, blend = 0.5f * (1.f + vh.z);
    p2 = (1.f - blend) * sqrtf(pm_maxf(0.f, 1.f - p1 * p1)) + blend * p2;
    float p3 = sqrtf(pm_maxf(0.f, 1.f - p1 * p1 - p2 * p2));
    vec3 nh = v3_add(v3_add(v3_scale(t1, p1), v3_scale(t2, p2)), v3_scale(vh, p3));
    return v3_normalize(v3(alpha * nh.x, alpha * nh.y, pm_maxf(1e-7f, nh.z))); /* back to the ellipsoid */
}

bool pm_brdf_sample(const pm_brdf *b, vec3 n, vec3 wo, float u0, float u1, float u2, vec3 *wi, vec3 *f, float *pdf) {
    float cos_o = v3_dot(n, wo);
    if (!(cos_o > 0.f)) return false;
    if (u0 < specular_probability(b, cos_o)) {
        vec3 t, bt;
        v3_basis(n, &t, &bt);
        vec3 local = v3(v3_dot(wo, t), v3_dot(wo, bt), cos_o);
        vec3 m = sample_visible_normal(b->alpha, local, u1, u2);
        vec3 h = v3_add(v3_add(v3_scale(t, m.x), v3_scale(bt, m.y)), v3_scale(n, m.z));
        *wi = v3_sub(v3_scale(h, 2.f * v3_dot(wo, h)), wo);
    } else {
        *wi = pm_sample_cosine(n, u1, u2);
    }
    if (!(v3_dot(n, *wi) > 0.f)) return false;
    *pdf = pm_brdf_pdf(b, n, wo, *wi);
    if (!(*pdf > 0.f)) return false;
    *f = pm_brdf_eval(b, n, wo, *wi);
    return true;
}

/* brdf.c: the glTF metallic-roughness BRDF of brdf.h with its specular, sheen and clearcoat layers: GGX D, height-correlated Smith V, Schlick F, Charlie sheen, their sampling. */
#include "brdf.h"

#include <math.h>
#include <pthread.h>

static const double pi_d = 3.14159265358979323846;

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

/* D V of GGX at alpha^2 for the pair (cosines cos_o, cos_i, half-vector cosine cos_h). */
static inline float ggx_dv(float a2, float cos_o, float cos_i, float cos_h) {
    float vis = 0.5f / (cos_i * smith_root(a2, cos_o) + cos_o * smith_root(a2, cos_i));
    return ggx_d(a2, cos_h) * vis;
}


/* 1 - specular x F(max3 F0, cos): the share the dielectric's specular leaves its diffuse base. */
static inline float dielectric_transmittance(float specular, float f0_max, float cos_theta) {
    return 1.f - specular * (f0_max + (1.f - f0_max) * schlick_weight(cos_theta));
}

static inline float coat_fresnel(float c) { return 0.04f + 0.96f * schlick_weight(c); }

/* ---- sheen (KHR_materials_sheen: Charlie distribution and visibility, Conty Estevez and Kulla 2017) ---- */

static double charlie_l(double x, double r) {
    double t = (1.0 - r) * (1.0 - r);
    double a = 21.5473 + (25.3245 - 21.5473) * t, b = 3.82987 + (3.32435 - 3.82987) * t;
    double c = 0.19823 + (0.16801 - 0.19823) * t, d = -1.97760 + (-1.27393 + 1.97760) * t;
    double e = -4.32054 + (-4.85967 + 4.32054) * t;
    return a / (1.0 + b * pow(x, c)) + d * x + e;
}

static double charlie_lambda(double c, double r) {
    return c < 0.5 ? exp(charlie_l(c, r)) : exp(2.0 * charlie_l(0.5, r) - charlie_l(1.0 - c, r));
}

/* D_Charlie(h) V_Charlie(wo, wi) of alphaG = r (double: the table integrates it; eval rounds it to
 * float), from the two directions' lambdas (charlie_lambda), which the table's quadrature computes
 * once per direction rather than once per point (each is up to two pow and an exp: per point, the
 * table would take 0.15 s of a sheen scene's first image). The extension maps sheenRoughness to
 * alphaG = sheenRoughness^2. */
static double charlie_dv_lambdas(double r, double cos_o, double cos_i, double cos_h, double lambda_o, double lambda_i) {
    double inv_r = 1.0 / r, sin2h = fmax(0.0, 1.0 - cos_h * cos_h);
    double d = (2.0 + inv_r) * pow(sin2h, 0.5 * inv_r) / (2.0 * pi_d);
    double v = 1.0 / ((1.0 + lambda_o + lambda_i) * 4.0 * cos_o * cos_i);
    return d * v;
}

static double charlie_dv(double r, double cos_o, double cos_i, double cos_h) {
    return charlie_dv_lambdas(r, cos_o, cos_i, cos_h, charlie_lambda(cos_o, r), charlie_lambda(cos_i, r));
}

enum { SHEEN_COS_STEPS = 32, SHEEN_ROUGH_STEPS = 16, SHEEN_THETA_QUAD = 48, SHEEN_PHI_QUAD = 24 };
static float sheen_table[SHEEN_ROUGH_STEPS][SHEEN_COS_STEPS];
static pthread_once_t sheen_once = PTHREAD_ONCE_INIT;

static float sheen_node_roughness(int j) {
    return PM_SHEEN_MIN_ROUGHNESS + (1.f - PM_SHEEN_MIN_ROUGHNESS) * (float)j / (SHEEN_ROUGH_STEPS - 1);
}

/* Directional albedo at cosine c by midpoint quadrature in (cos_i, phi), phi over half the circle
 * (the lobe is symmetric about the plane of wo and n). */
static void fill_sheen_table(void) {
    for (int j = 0; j < SHEEN_ROUGH_STEPS; j++) {
        double r = (double)sheen_node_roughness(j) * sheen_node_roughness(j);
        for (int k = 0; k < SHEEN_COS_STEPS; k++) {
            double cos_o = fmax(1e-3, (double)k / (SHEEN_COS_STEPS - 1)), sin_o = sqrt(1.0 - cos_o * cos_o), sum = 0.0;
            double lambda_o = charlie_lambda(cos_o, r);
            for (int a = 0; a < SHEEN_THETA_QUAD; a++) {
                double cos_i = (a + 0.5) / SHEEN_THETA_QUAD, sin_i = sqrt(1.0 - cos_i * cos_i), lambda_i = charlie_lambda(cos_i, r);
                for (int p = 0; p < SHEEN_PHI_QUAD; p++) {
                    double phi = pi_d * (p + 0.5) / SHEEN_PHI_QUAD;
                    /* wo = (sin_o, 0, cos_o), wi = (sin_i cos phi, sin_i sin phi, cos_i) */
                    double hx = sin_o + sin_i * cos(phi), hy = sin_i * sin(phi), hz = cos_o + cos_i;
                    double cos_h = hz / sqrt(hx * hx + hy * hy + hz * hz);
                    sum += charlie_dv_lambdas(r, cos_o, cos_i, cos_h, lambda_o, lambda_i) * cos_i;
                }
            }
            /* d omega = d cos_i d phi; phi over [0, pi] counted twice */
            sheen_table[j][k] = (float)(sum * 2.0 * (1.0 / SHEEN_THETA_QUAD) * (pi_d / SHEEN_PHI_QUAD));
        }
    }
}

float pm_sheen_albedo(float cos_theta, float sheen_roughness) {
    pthread_once(&sheen_once, fill_sheen_table);
    float x = pm_minf(1.f, pm_maxf(0.f, cos_theta)) * (SHEEN_COS_STEPS - 1);
    float y = (pm_maxf(PM_SHEEN_MIN_ROUGHNESS, pm_minf(1.f, sheen_roughness)) - PM_SHEEN_MIN_ROUGHNESS) /
              (1.f - PM_SHEEN_MIN_ROUGHNESS) * (SHEEN_ROUGH_STEPS - 1);
    int x0 = (int)x, y0 = (int)y;
    if (x0 > SHEEN_COS_STEPS - 2) x0 = SHEEN_COS_STEPS - 2;
    if (y0 > SHEEN_ROUGH_STEPS - 2) y0 = SHEEN_ROUGH_STEPS - 2;
    float fx = x - x0, fy = y - y0;
    float lo = sheen_table[y0][x0] + (sheen_table[y0][x0 + 1] - sheen_table[y0][x0]) * fx;
    float hi = sheen_table[y0 + 1][x0] + (sheen_table[y0 + 1][x0 + 1] - sheen_table[y0 + 1][x0]) * fx;
    return lo + (hi - lo) * fy;
}

static inline bool has_sheen(const pm_brdf *b) { return b->layered && v3_max_component(b->sheen_color) > 0.f; }
static inline bool has_coat(const pm_brdf *b) { return b->layered && b->clearcoat > 0.f; }

/* The coat's normal on the side of the base's n: its own (clearcoatNormalTexture) or n. */
static inline vec3 coat_normal(const pm_brdf *b, vec3 n) {
    if (!b->layered || !b->coat_normal) return n;
    return v3_dot(b->coat_n, n) < 0.f ? v3_neg(b->coat_n) : b->coat_n;
}

/* ---- lobe choice ---- */

/* The probabilities of the four sampling techniques at wo (they depend on wo only, as the pdf
 * requires): in proportion to each layer's estimated albedo there. Within the base, the
 * specular lobe's share is its Fresnel-weighted reflectance's, kept within [0.2, 0.8] while there
 * is a diffuse part so neither is left to rare samples; a coat or sheen keeps at least a tenth
 * of its share. The parts a lobe skips get none, the others' shares scaled to sum to 1. */
typedef struct { float coat, specular, diffuse, sheen; } lobe_choice;

/* The base's estimated albedos at wo, its specular and its diffuse term, with the dielectric's
 * weight s and F0 (KHR_materials_specular's, or the constants 1 and 0.04, which inlining folds
 * in for the plain lobe). */
static inline void base_albedos(const pm_brdf *b, float s, vec3 f0v, float cos_o, float *spec, float *diff) {
    float w = schlick_weight(cos_o);
    float f0_d = v3_average(f0v), f0_max = v3_max_component(f0v);
    float f0 = (1.f - b->metallic) * s * f0_d + b->metallic * v3_average(b->base);
    float f90 = 1.f - (1.f - b->metallic) * (1.f - s);
    *spec = f0 + (f90 - f0) * w;
    *diff = (1.f - b->metallic) * v3_average(b->base) * dielectric_transmittance(s, f0_max, cos_o);
}

/* The base's specular probability from its two albedos. */
static inline float base_specular_probability(float spec, float diff) {
    if (!(spec > 0.f)) return 0.f; /* the dielectric alone with specular 0: Lambert */
    if (diff > 0.f) return pm_minf(0.8f, pm_maxf(0.2f, spec / (spec + diff)));
    return 1.f;
}

/* The layers' estimated albedos at wo before any part is skipped: coat, sheen, and the base
 * (its specular and diffuse terms) under them. */
typedef struct { float coat, sheen, base, spec, diff; } layer_albedos;

static inline layer_albedos albedos(const pm_brdf *b, float cos_o, float coat_cos_o) {
    layer_albedos a = {0.f, 0.f, 0.f, 0.f, 0.f};
    if (!b->layered) {
        base_albedos(b, 1.f, v3s(0.04f), cos_o, &a.spec, &a.diff);
        a.base = 1.f;
        return a;
    }
    base_albedos(b, b->specular, b->specular_f0, cos_o, &a.spec, &a.diff);
    a.coat = has_coat(b) && coat_cos_o > 0.f ? b->clearcoat * coat_fresnel(coat_cos_o) : 0.f;
    float sheen_share = has_sheen(b) ? v3_max_component(b->sheen_color) * pm_sheen_albedo(cos_o, b->sheen_roughness) : 0.f;
    a.sheen = (1.f - a.coat) * sheen_share;
    a.base = (1.f - a.coat) * pm_maxf(0.f, 1.f - sheen_share); /* what reaches the base */
    return a;
}

static inline lobe_choice choose_lobes(const pm_brdf *b, float cos_o, float coat_cos_o) {
    lobe_choice p = {0.f, 0.f, 0.f, 0.f};
    layer_albedos a = albedos(b, cos_o, coat_cos_o);
    float p_spec = base_specular_probability(a.spec, a.diff);
    if (!b->layered) {
        p.specular = p_spec;
        p.diffuse = 1.f - p.specular;
    } else {
        float base = a.base * (a.spec + a.diff);
        float total = a.coat + a.sheen + base;
        int present = 1 + (a.coat > 0.f) + (a.sheen > 0.f);
        float floor_share = 0.1f / present;
        float pc = a.coat > 0.f ? 0.9f * a.coat / total + floor_share : 0.f;
        float ps = a.sheen > 0.f ? 0.9f * a.sheen / total + floor_share : 0.f;
        float pb = 1.f - pc - ps;
        p.coat = pc;
        p.sheen = ps;
        p.specular = pb * p_spec;
        p.diffuse = pb - p.specular;
    }
    if (b->skip) {
        if (b->skip & PM_BRDF_SPECULAR) p.specular = 0.f;
        if (b->skip & PM_BRDF_COAT) p.coat = 0.f;
        if (b->skip & PM_BRDF_DIFFUSE) p.diffuse = 0.f;
        if (b->skip & PM_BRDF_SHEEN) p.sheen = 0.f;
        float sum = p.specular + p.coat + p.diffuse + p.sheen;
        if (sum > 0.f) {
            float scale = 1.f / sum;
            p.specular *= scale;
            p.coat *= scale;
            p.diffuse *= scale;
            p.sheen *= scale;
        }
    }
    return p;
}

float pm_brdf_albedo_estimate(const pm_brdf *b, vec3 n, vec3 wo) {
    float cos_o = v3_dot(n, wo);
    if (!(cos_o > 0.f)) return 0.f;
    float coat_cos_o = b->layered && b->coat_normal ? v3_dot(coat_normal(b, n), wo) : cos_o;
    layer_albedos a = albedos(b, cos_o, coat_cos_o);
    float base = (b->skip & PM_BRDF_SPECULAR ? 0.f : a.spec) + (b->skip & PM_BRDF_DIFFUSE ? 0.f : a.diff);
    float sum = a.base * base + (b->skip & PM_BRDF_COAT ? 0.f : a.coat) + (b->skip & PM_BRDF_SHEEN ? 0.f : a.sheen);
    return sum * b->weight;
}

/* ---- evaluation ---- */

/* The base lobe (metal and dielectric, the dielectric's weight s and F0 as in
 * base_specular_probability). */
static inline vec3 base_eval(const pm_brdf *b, float s, vec3 f0d, float cos_o, float cos_i, float cos_h, float v_h) {
    float dv = b->skip & PM_BRDF_SPECULAR ? 0.f : ggx_dv(b->alpha * b->alpha, cos_o, cos_i, cos_h), w = schlick_weight(v_h);
    /* Schlick is linear in F0 and F90: the metal (F0 = base, F90 = 1) and the dielectric (F0 =
     * specular_f0, F90 = specular) merge into one lobe; with the defaults this is
     * F0 = mix(0.04, base, metallic), F90 = 1 */
    vec3 f0 = v3_add(v3_scale(f0d, (1.f - b->metallic) * s), v3_scale(b->base, b->metallic));
    float f90 = 1.f - (1.f - b->metallic) * (1.f - s);
    vec3 fresnel = v3_add(f0, v3_scale(v3_sub(v3s(f90), f0), w));
    /* The dielectric's diffuse base under its specular coat: Schlick at the two macro angles, not at
     * v.h as the sample viewer does, whose sum with the coat reflects up to 1.39 at grazing
     * angles (measured, tests/test_brdf.c) where Russian roulette needs at most 1; still reciprocal. */
    float f0_max = v3_max_component(f0d);
    float diffuse = b->skip & PM_BRDF_DIFFUSE ? 0.f
                                              : (1.f - b->metallic) * dielectric_transmittance(s, f0_max, cos_o) *
                                                    dielectric_transmittance(s, f0_max, cos_i) * PM_INV_PI;
    return v3_add(v3_scale(fresnel, dv), v3_scale(b->base, diffuse));
}

/* The unit half vector of wo and wi; false where they cancel (no half vector: f = 0 there, and
 * the specular parts have no density). */
static inline bool half_vector(vec3 wo, vec3 wi, vec3 *h) {
    vec3 sum = v3_add(wo, wi);
    float hl = v3_length(sum);
    if (!(hl > 0.f)) return false;
    *h = v3_scale(sum, 1.f / hl);
    return true;
}

/* f for cos_o, cos_i > 0 and their half vector h: pm_brdf_eval's and pm_brdf_sample's one body. */
static vec3 eval_at(const pm_brdf *b, vec3 n, vec3 wo, vec3 wi, float cos_o, float cos_i, vec3 h) {
    float cos_h = pm_maxf(0.f, v3_dot(n, h)), v_h = pm_maxf(0.f, v3_dot(wo, h));
    if (!b->layered) return v3_scale(base_eval(b, 1.f, v3s(0.04f), cos_o, cos_i, cos_h, v_h), b->weight);
    vec3 f = base_eval(b, b->specular, b->specular_f0, cos_o, cos_i, cos_h, v_h);
    if (has_sheen(b)) {
        float r = b->sheen_roughness, m = v3_max_component(b->sheen_color);
        float scale = pm_minf(1.f - m * pm_sheen_albedo(cos_o, r), 1.f - m * pm_sheen_albedo(cos_i, r));
        float sheen = b->skip & PM_BRDF_SHEEN ? 0.f : (float)charlie_dv((double)r * r, cos_o, cos_i, cos_h);
        f = v3_add(v3_scale(f, pm_maxf(0.f, scale)), v3_scale(b->sheen_color, sheen));
    }
    if (has_coat(b)) {
        float c = b->clearcoat, co = cos_o, ci = cos_i, ch = cos_h;
        if (b->coat_normal) { /* the coat's own normal: its cosines (h is the same half vector) */
            vec3 cn = coat_normal(b, n);
            co = pm_maxf(0.f, v3_dot(cn, wo));
            ci = pm_maxf(0.f, v3_dot(cn, wi));
            ch = pm_maxf(0.f, v3_dot(cn, h));
        }
        float coat = co > 0.f && ci > 0.f && !(b->skip & PM_BRDF_COAT) ? c * coat_fresnel(v_h) * ggx_dv(b->clearcoat_alpha * b->clearcoat_alpha, co, ci, ch) : 0.f;
        float under = (1.f - c * coat_fresnel(co)) * (1.f - c * coat_fresnel(ci));
        f = v3_add(v3_scale(f, under), v3s(coat));
    }
    return v3_scale(f, b->weight);
}

vec3 pm_brdf_eval(const pm_brdf *b, vec3 n, vec3 wo, vec3 wi) {
    float cos_o = v3_dot(n, wo), cos_i = v3_dot(n, wi);
    if (!(cos_o > 0.f) || !(cos_i > 0.f)) return v3s(0.f);
    vec3 h;
    if (!half_vector(wo, wi, &h)) return v3s(0.f);
    return eval_at(b, n, wo, wi, cos_o, cos_i, h);
}

/* ---- sampling ---- */

/* The visible-normal density of GGX at alpha^2 for wi, per solid angle of wi: D(h) G1(wo) max(0,
 * wo.h) / cos_o times the reflection's Jacobian 1 / (4 wo.h). */
static float ggx_reflection_pdf(float a2, float cos_o, float cos_h) {
    float g1 = 2.f * cos_o / (cos_o + smith_root(a2, cos_o));
    return ggx_d(a2, cos_h) * g1 / (4.f * cos_o);
}

/* The mixture's density at wi for cos_o, cos_i > 0, from the choice p made at wo (coat normal cn,
 * its cosine coat_cos_o) and the half vector h where there is one (has_h): pm_brdf_pdf's and
 * pm_brdf_sample's one body. */
static float pdf_at(const pm_brdf *b, const lobe_choice *p, vec3 n, vec3 cn, vec3 wo, float cos_o, float coat_cos_o, float cos_i,
                    bool has_h, vec3 h) {
    float pdf = p->diffuse * cos_i * PM_INV_PI;
    if (b->layered) pdf += p->sheen * (0.5f * PM_INV_PI);
    if (has_h) {
        float cos_h = v3_dot(n, h), coat_cos_h = b->layered && b->coat_normal ? v3_dot(cn, h) : cos_h;
        if (v3_dot(wo, h) > 0.f) {
            if (cos_h > 0.f) pdf += p->specular * ggx_reflection_pdf(b->alpha * b->alpha, cos_o, cos_h);
            if (p->coat > 0.f && coat_cos_h > 0.f && coat_cos_o > 0.f)
                pdf += p->coat * ggx_reflection_pdf(b->clearcoat_alpha * b->clearcoat_alpha, coat_cos_o, coat_cos_h);
        }
    }
    return pdf;
}

float pm_brdf_pdf(const pm_brdf *b, vec3 n, vec3 wo, vec3 wi) {
    float cos_o = v3_dot(n, wo), cos_i = v3_dot(n, wi);
    if (!(cos_o > 0.f) || !(cos_i > 0.f)) return 0.f;
    vec3 cn = coat_normal(b, n), h = v3s(0.f);
    float coat_cos_o = b->layered && b->coat_normal ? v3_dot(cn, wo) : cos_o;
    lobe_choice p = choose_lobes(b, cos_o, coat_cos_o);
    bool has_h = half_vector(wo, wi, &h);
    return pdf_at(b, &p, n, cn, wo, cos_o, coat_cos_o, cos_i, has_h, h);
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

vec3 pm_ggx_visible_normal(float alpha, vec3 n, vec3 wo, float cos_o, float u1, float u2) {
    vec3 t, bt;
    v3_basis(n, &t, &bt);
    vec3 local = v3(v3_dot(wo, t), v3_dot(wo, bt), cos_o);
    vec3 m = sample_visible_normal(alpha, local, u1, u2);
    return v3_add(v3_add(v3_scale(t, m.x), v3_scale(bt, m.y)), v3_scale(n, m.z));
}

float pm_ggx_g1(float alpha, float c) {
    c = pm_maxf(1e-6f, pm_minf(1.f, fabsf(c)));
    return 2.f * c / (c + smith_root(alpha * alpha, c));
}

static inline vec3 sample_ggx_reflection(float alpha, vec3 n, vec3 wo, float cos_o, float u1, float u2) {
    vec3 h = pm_ggx_visible_normal(alpha, n, wo, cos_o, u1, u2);
    return v3_sub(v3_scale(h, 2.f * v3_dot(wo, h)), wo);
}

/* Uniform over the hemisphere about n (the sheen's technique: its lobe is widest at grazing
 * angles, where a cosine sample is rare). */
static vec3 sample_uniform_hemisphere(vec3 n, float u1, float u2) {
    vec3 t, bt;
    v3_basis(n, &t, &bt);
    float z = u1, r = sqrtf(pm_maxf(0.f, 1.f - z * z)), s, c;
    pm_sincos_turn(u2, &s, &c);
    return v3_add(v3_add(v3_scale(t, r * c), v3_scale(bt, r * s)), v3_scale(n, z));
}

bool pm_brdf_sample(const pm_brdf *b, vec3 n, vec3 wo, float u0, float u1, float u2, vec3 *wi, vec3 *f, float *pdf) {
    float cos_o = v3_dot(n, wo);
    if (!(cos_o > 0.f)) return false;
    vec3 cn = coat_normal(b, n);
    float coat_cos_o = b->layered && b->coat_normal ? v3_dot(cn, wo) : cos_o;
    lobe_choice p = choose_lobes(b, cos_o, coat_cos_o);
    if (!(p.specular + p.coat + p.sheen + p.diffuse > 0.f)) return false; /* every part skipped */
    if (u0 < p.specular) *wi = sample_ggx_reflection(b->alpha, n, wo, cos_o, u1, u2);
    else if (u0 < p.specular + p.coat) *wi = sample_ggx_reflection(b->clearcoat_alpha, cn, wo, coat_cos_o, u1, u2);
    else if (u0 < p.specular + p.coat + p.sheen) *wi = sample_uniform_hemisphere(n, u1, u2);
    else if (p.diffuse > 0.f) *wi = pm_sample_cosine(n, u1, u2);
    else return false; /* u0 past the others' sum by rounding, with the diffuse part skipped */
    /* the density and value as pm_brdf_pdf and pm_brdf_eval give them, from the choice above and
     * one half vector */
    float cos_i = v3_dot(n, *wi);
    if (!(cos_i > 0.f)) return false;
    vec3 h = v3s(0.f);
    bool has_h = half_vector(wo, *wi, &h);
    *pdf = pdf_at(b, &p, n, cn, wo, cos_o, coat_cos_o, cos_i, has_h, h);
    if (!(*pdf > 0.f)) return false;
    *f = has_h ? eval_at(b, n, wo, *wi, cos_o, cos_i, h) : v3s(0.f);
    return true;
}

/* brdf.h: glTF's metallic-roughness BRDF (GGX, height-correlated Smith, Schlick Fresnel, Lambert base): evaluation, sampling, pdf.
 *
 * The specification's model expanded into one sum (Schlick is linear in F0, so the metal and
 * dielectric specular lobes merge into one with F0 = mix(0.04, base, metallic)):
 *
 *     f = weight x [ F(F0, v.h) D(h) V(wo, wi)  +  (1 - metallic) (1 - F(0.04, cos_o)) (1 - F(0.04, cos_i)) base / pi ]
 *
 * (the diffuse base's Fresnel at the two macro angles rather than at v.h: with v.h a white
 * dielectric reflects up to 1.39 of the light at grazing angles, which Russian roulette cannot take).
 * D is Trowbridge-Reitz (GGX) with alpha = roughness^2, V = G2 / (4 cos_o cos_i) with the
 * height-correlated Smith G2 = 1 / (1 + Lambda(wo) + Lambda(wi)). Every term is symmetric in
 * wo and wi, so f is reciprocal. Sampling picks the specular lobe (visible normals of GGX,
 * Heitz 2018) or a cosine direction, with a probability that depends on wo only; the pdf is the
 * mixture's, so the sampled direction and pm_brdf_pdf() always agree. Directions are world
 * space; n is the shading normal on the side wo is (wo and wi below it give f = 0).
 */
#ifndef PM_BRDF_H
#define PM_BRDF_H

#include <stdbool.h>
#include "pm_math.h"

typedef struct {
    vec3 base;       /* base colour, each channel in [0, 1] */
    float metallic;  /* [0, 1] */
    float alpha;     /* GGX alpha = roughness^2, at least PM_GLOSSY_MIN_ALPHA */
    float weight;    /* the share of the surface the lobe covers: 1 minus the glass share */
    /* Layers of KHR_materials_specular, _sheen and _clearcoat; read only when `layered` (a
     * struct with it false is the plain lobe above). See below. */
    bool layered;
    float specular;        /* specularFactor: the dielectric lobe's weight and its F90; 1 by default */
    vec3 specular_f0;      /* min(0.04 x specularColorFactor, 1): the dielectric's F0; 0.04 by default */
    vec3 sheen_color;      /* sheenColorFactor (x texture); 0: no sheen */
    float sheen_roughness; /* sheenRoughnessFactor (x texture), at least PM_SHEEN_MIN_ROUGHNESS */
    float clearcoat;       /* clearcoatFactor (x texture); 0: no coat */
    float clearcoat_alpha; /* GGX alpha of the coat = clearcoatRoughness^2, at least PM_GLOSSY_MIN_ALPHA */
    /* the coat's own shading normal (clearcoatNormalTexture), world space, unit, on the side of
     * the base's: read only when coat_normal; the functions below turn it to the side of their n */
    bool coat_normal;
    vec3 coat_n;
    /* The parts left out (PM_BRDF_* bits; 0, the whole lobe): evaluation, density, sampling and
     * the albedo estimate read only the others. The vertex kernel's near-specular split sets it
     * (vertex.h); a struct made without it is the whole lobe. */
    unsigned skip;
} pm_brdf;

/* The parts of a lobe, each one technique of the sampler: the base's GGX reflection, the coat's
 * GGX reflection, the base's diffuse term, the sheen. */
enum { PM_BRDF_SPECULAR = 1, PM_BRDF_COAT = 2, PM_BRDF_DIFFUSE = 4, PM_BRDF_SHEEN = 8 };

/* The layers, each as its extension text defines it (a reciprocal form where the text's is not):
 *
 *   specular:  the dielectric part above with F0 = specular_f0 and F90 = specular, its diffuse
 *              base under 1 - specular x F(max(specular_f0), cos) at the two macro angles;
 *   sheen:     f_sheen = sheen_color D_Charlie(h) V_Charlie (Conty Estevez and Kulla 2017, the
 *              visibility of their lambda fit, alphaG = sheenRoughness^2), the layers below times
 *              min(1 - max3(sheen_color) E(cos_o), 1 - max3(sheen_color) E(cos_i)) with E the
 *              sheen lobe's directional albedo (a table, pm_sheen_albedo);
 *   clearcoat: c F(0.04, v.h) D(h; clearcoat_alpha) V on top, everything below times
 *              (1 - c F(0.04, cos_o)) (1 - c F(0.04, cos_i)); the cosines and h's of the coat are
 *              taken to its own normal coat_n when it has one (clearcoatNormalTexture), the base's n else.
 *
 * Sampling picks the coat, the base's specular lobe, its cosine lobe or the sheen (uniform over
 * the hemisphere) in proportion to their estimated albedos at wo. The whole stays reciprocal and
 * below albedo 1 (tests/test_layers.c), so photons treat it as the plain lobe: D = weight. */
/* sheenRoughness floor: alphaG = 0.265^2 = 0.07, below which the Charlie lobe with its lambda-fit
 * visibility reflects more than it receives at grazing angles (tests/test_layers.c) */
#define PM_SHEEN_MIN_ROUGHNESS 0.265f

/* The parts the lobe has (PM_BRDF_* bits), skipped ones included. */
static inline unsigned pm_brdf_parts(const pm_brdf *b) {
    unsigned parts = 0;
    if (!b->layered || b->metallic > 0.f || b->specular > 0.f) parts |= PM_BRDF_SPECULAR;
    if (b->metallic < 1.f && v3_max_component(b->base) > 0.f) parts |= PM_BRDF_DIFFUSE;
    if (b->layered && b->clearcoat > 0.f) parts |= PM_BRDF_COAT;
    if (b->layered && v3_max_component(b->sheen_color) > 0.f) parts |= PM_BRDF_SHEEN;
    return parts;
}

/* The parts of the lobe that are GGX reflections of alpha below `alpha` (PM_BRDF_SPECULAR,
 * PM_BRDF_COAT): the vertex kernel's one rule for which parts count as near-specular (vertex.h).
 * A metallic 0 point whose file turns the dielectric lobe off (specular 0) has no base reflection. */
static inline unsigned pm_brdf_parts_sharper_than(const pm_brdf *b, float alpha) {
    unsigned parts = 0;
    bool base_reflects = !b->layered || b->metallic > 0.f || b->specular > 0.f;
    if (base_reflects && b->alpha < alpha) parts |= PM_BRDF_SPECULAR;
    if (b->layered && b->clearcoat > 0.f && b->clearcoat_alpha < alpha) parts |= PM_BRDF_COAT;
    return parts;
}

/* E(cos, sheenRoughness): the directional albedo of the sheen lobe of colour 1 (bilinear in a
 * table integrated once, on first use, thread-safe). */
float pm_sheen_albedo(float cos_theta, float sheen_roughness);

/* A GGX microfacet normal of alpha about n seen from wo (cos_o = n.wo > 0), distributed as D(m)
 * G1(wo) max(0, wo.m) / cos_o (Heitz 2018): what rough glass refracts or reflects about. */
vec3 pm_ggx_visible_normal(float alpha, vec3 n, vec3 wo, float cos_o, float u1, float u2);
/* Smith's G1 of GGX alpha for a direction at cosine c to the macro normal. */
float pm_ggx_g1(float alpha, float c);

/* f(wo, wi), the cosine not included. */
vec3 pm_brdf_eval(const pm_brdf *b, vec3 n, vec3 wo, vec3 wi);
/* The density (per solid angle) with which pm_brdf_sample returns wi. */
float pm_brdf_pdf(const pm_brdf *b, vec3 n, vec3 wo, vec3 wi);
/* Samples wi from three uniform numbers; fills f(wo, wi) and the pdf. False when the sample is
 * lost (below the surface): the caller ends the path there. */
bool pm_brdf_sample(const pm_brdf *b, vec3 n, vec3 wo, float u0, float u1, float u2, vec3 *wi, vec3 *f, float *pdf);
/* An estimate of the directional albedo at wo of the parts not skipped (the weights the sampler
 * picks its techniques by, times the lobe's weight): positive wherever those parts reflect
 * anything, so a choice made in proportion to it reaches every path. */
float pm_brdf_albedo_estimate(const pm_brdf *b, vec3 n, vec3 wo);

#endif

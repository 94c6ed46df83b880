/* test_layers.c: the clearcoat, sheen and specular layers of the glossy lobe (brdf.h): furnace, reciprocity, sampler vs pdf vs eval, defaults, references from the extension texts. */
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "brdf.h"
#include "rng.h"
#include "scene.h"
#include "testing.h"

#define PI_D 3.14159265358979323846

static pm_brdf layered(vec3 base, float metallic, float roughness, float specular, vec3 specular_color, vec3 sheen,
                       float sheen_roughness, float clearcoat, float clearcoat_roughness) {
    pm_brdf b = pm_brdf_at(base, metallic, roughness, 0.f);
    pm_brdf_add_layers(&b, specular, specular_color, sheen, sheen_roughness, clearcoat, clearcoat_roughness);
    return b;
}

static vec3 direction_at(float cos_theta, float phi) {
    float s = sqrtf(pm_maxf(0.f, 1.f - cos_theta * cos_theta));
    return v3(s * cosf(phi), s * sinf(phi), cos_theta);
}

typedef struct { double mean[3], stderr_max; } estimate;

static estimate finish(const double sum[3], const double sum2[3], int count) {
    estimate e = {{0, 0, 0}, 0};
    for (int c = 0; c < 3; c++) {
        e.mean[c] = sum[c] / count;
        e.stderr_max = fmax(e.stderr_max, sqrt(fmax(sum2[c] / count - e.mean[c] * e.mean[c], 0.0) / count));
    }
    return e;
}

/* Albedo by stratified uniform directions (knows nothing of the sampler); also the pdf's integral. */
static estimate albedo_uniform(const pm_brdf *b, vec3 wo, int side, double *pdf_integral) {
    double sum[3] = {0, 0, 0}, sum2[3] = {0, 0, 0}, pdf_sum = 0;
    pm_rng rng = pm_rng_for(7, side, 1);
    vec3 n = v3(0, 0, 1);
    for (int i = 0; i < side; i++)
        for (int j = 0; j < side; j++) {
            float z = (i + pm_rng_float(&rng)) / side, phi = 2.f * PM_PI * (j + pm_rng_float(&rng)) / side;
            vec3 wi = direction_at(z, phi);
            vec3 f = pm_brdf_eval(b, n, wo, wi);
            pdf_sum += pm_brdf_pdf(b, n, wo, wi) * 2.0 * PI_D;
            for (int c = 0; c < 3; c++) {
                double v = v3_get(f, c) * z * 2.0 * PI_D;
                sum[c] += v;
                sum2[c] += v * v;
            }
        }
    *pdf_integral = pdf_sum / (side * side);
    return finish(sum, sum2, side * side);
}

/* Albedo as the mean of the sampler's weights f cos / pdf; checks each sample's pdf and f against pdf() and eval(). */
static estimate albedo_sampled(const pm_brdf *b, vec3 wo, int count, int *mismatches, double *kept) {
    double sum[3] = {0, 0, 0}, sum2[3] = {0, 0, 0};
    int k = 0;
    pm_rng rng = pm_rng_for(9, count, 2);
    vec3 n = v3(0, 0, 1);
    for (int i = 0; i < count; i++) {
        vec3 wi, f;
        float pdf;
        if (!pm_brdf_sample(b, n, wo, pm_rng_float(&rng), pm_rng_float(&rng), pm_rng_float(&rng), &wi, &f, &pdf)) continue;
        k++;
        float p2 = pm_brdf_pdf(b, n, wo, wi);
        vec3 f2 = pm_brdf_eval(b, n, wo, wi);
        if (fabsf(p2 - pdf) > 1e-5f * pdf || fabsf(f2.x - f.x) > 1e-5f * f.x) (*mismatches)++;
        for (int c = 0; c < 3; c++) {
            double v = v3_get(f, c) * wi.z / pdf;
            sum[c] += v;
            sum2[c] += v * v;
        }
    }
    *kept = (double)k / count;
    return finish(sum, sum2, count);
}

/* ---- independent references, written from the extension texts in double ---- */

static double schlick(double f0, double f90, double c) { return f0 + (f90 - f0) * pow(1.0 - c, 5.0); }
static double ggx_d(double a, double ch) {
    double t = ch * ch * (a * a - 1.0) + 1.0;
    return a * a / (PI_D * t * t);
}
static double smith_lambda(double a, double c) { return 0.5 * (-1.0 + sqrt(1.0 + a * a * (1.0 - c * c) / (c * c))); }
/* D G2 / (4 cos_o cos_i), G2 the height-correlated Smith term written with Lambda */
static double ggx_lobe(double a, double co, double ci, double ch) {
    return ggx_d(a, ch) / ((1.0 + smith_lambda(a, co) + smith_lambda(a, ci)) * 4.0 * co * ci);
}
static double sheen_l(double x, double r) {
    double t = (1 - r) * (1 - r);
    return (21.5473 * (1 - t) + 25.3245 * t) / (1.0 + (3.82987 * (1 - t) + 3.32435 * t) * pow(x, 0.19823 * (1 - t) + 0.16801 * t)) +
           (-1.97760 * (1 - t) - 1.27393 * t) * x + (-4.32054 * (1 - t) - 4.85967 * t);
}
static double sheen_lambda(double c, double r) { return c < 0.5 ? exp(sheen_l(c, r)) : exp(2.0 * sheen_l(0.5, r) - sheen_l(1.0 - c, r)); }
static double sheen_lobe(double r, double co, double ci, double ch) {
    double d = (2.0 + 1.0 / r) * pow(1.0 - ch * ch, 0.5 / r) / (2.0 * PI_D);
    return d / ((1.0 + sheen_lambda(co, r) + sheen_lambda(ci, r)) * 4.0 * co * ci);
}
/* E(cos_o) of the sheen lobe by the midpoint rule over the whole circle of phi (the table uses half) */
static double sheen_albedo_quadrature(double r, double co) {
    const int nz = 400, nphi = 400;
    double so = sqrt(1.0 - co * co), sum = 0.0;
    for (int i = 0; i < nz; i++) {
        double ci = (i + 0.5) / nz, si = sqrt(1.0 - ci * ci);
        for (int j = 0; j < nphi; j++) {
            double phi = 2.0 * PI_D * (j + 0.5) / nphi, h[3] = {so + si * cos(phi), si * sin(phi), co + ci};
            sum += sheen_lobe(r, co, ci, h[2] / sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2])) * ci;
        }
    }
    return sum * (1.0 / nz) * (2.0 * PI_D / nphi);
}

static void sheen_table(void) {
    clock_t t0 = clock();
    float first = pm_sheen_albedo(0.5f, 0.5f);
    double seconds = (double)(clock() - t0) / CLOCKS_PER_SEC;
    printf("sheen table: %.3f s on first use; E(0.5, 0.5) = %.4f\n", seconds, first);
    const float rough[] = {PM_SHEEN_MIN_ROUGHNESS, 0.3f, 0.5f, 1.f}, cosines[] = {1.f, 0.7f, 0.4f, 0.2f, 0.05f};
    for (size_t r = 0; r < 4; r++)
        for (size_t k = 0; k < 5; k++) {
            double q = sheen_albedo_quadrature((double)rough[r] * rough[r], cosines[k]); /* alphaG = roughness^2 */
            float e = pm_sheen_albedo(cosines[k], rough[r]);
            printf("  E(cos %.2f, roughness %.2f) table %.4f quadrature %.4f\n", cosines[k], rough[r], e, q);
            CHECK_NEAR(e, q, 0.03, 0.004, "sheen albedo table = quadrature of the spec's Charlie lobe");
            CHECK(e <= 1.f, "sheen albedo at most 1 (%g)", e);
        }
}

/* The layered lobe at one pair of directions against the extension texts' formulas in double. */
static void spec_formulas(void) {
    const float cos_o[] = {0.9f, 0.5f, 0.2f}, cos_i[] = {0.8f, 0.3f, 0.6f};
    for (int k = 0; k < 3; k++) {
        vec3 wo = direction_at(cos_o[k], 0.f), wi = direction_at(cos_i[k], 2.5f);
        double co = cos_o[k], ci = cos_i[k];
        double h[3] = {wo.x + wi.x, wo.y + wi.y, wo.z + wi.z}, hl = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
        double ch = h[2] / hl, vh = (wo.x * h[0] + wo.y * h[1] + wo.z * h[2]) / hl;
        /* metallic 0.6, roughness 0.5, specular 0.7 with colour (1, 0.5, 2), sheen (0.8, 0.4, 0.2) roughness 0.4, coat 0.9 roughness 0.3 */
        pm_brdf b = layered(v3(0.5f, 0.6f, 0.7f), 0.6f, 0.5f, 0.7f, v3(1.f, 0.5f, 2.f), v3(0.8f, 0.4f, 0.2f), 0.4f, 0.9f, 0.3f);
        vec3 f = pm_brdf_eval(&b, v3(0, 0, 1), wo, wi);
        const double base[3] = {0.5, 0.6, 0.7}, sc[3] = {1.0, 0.5, 2.0}, sheen[3] = {0.8, 0.4, 0.2}, m = 0.6, s = 0.7;
        double f0max = 0.08, e_o = pm_sheen_albedo(cos_o[k], 0.4f), e_i = pm_sheen_albedo(cos_i[k], 0.4f);
        for (int c = 0; c < 3; c++) {
            double f0d = fmin(0.04 * sc[c], 1.0);
            double metal = schlick(base[c], 1.0, vh) * ggx_lobe(0.25, co, ci, ch);
            double dielectric = s * schlick(f0d, 1.0, vh) * ggx_lobe(0.25, co, ci, ch) +
                                (1 - s * schlick(f0max, 1.0, co)) * (1 - s * schlick(f0max, 1.0, ci)) * base[c] / PI_D;
            double under = m * metal + (1 - m) * dielectric;
            double sheened = sheen[c] * sheen_lobe(0.4 * 0.4, co, ci, ch) + under * fmin(1 - 0.8 * e_o, 1 - 0.8 * e_i);
            double coat = 0.9 * schlick(0.04, 1.0, vh) * ggx_lobe(0.09, co, ci, ch);
            double want = coat + (1 - 0.9 * schlick(0.04, 1.0, co)) * (1 - 0.9 * schlick(0.04, 1.0, ci)) * sheened;
            CHECK_NEAR(v3_get(f, c), want, 2e-4, 1e-7, "layered f = the extension texts' formula");
        }
    }
}

/* The plain lobe (no extension) against glTF's Appendix B written out in double: the specular
 * terms exactly the specification's (metal: Schlick from the base colour; dielectric: F0 0.04
 * from ior 1.5), the dielectric's diffuse base under Fresnel at the two macro angles (brdf.h). */
static void gltf_formulas(void) {
    const float metals[] = {0.f, 0.3f, 1.f}, roughs[] = {0.f, 0.3f, 0.8f};
    const float cos_o[] = {0.9f, 0.5f, 0.15f}, cos_i[] = {0.8f, 0.3f, 0.6f};
    const double base[3] = {0.02, 0.5, 0.9};
    for (int a = 0; a < 3; a++)
        for (int r = 0; r < 3; r++)
            for (int k = 0; k < 3; k++) {
                pm_brdf b = pm_brdf_at(v3(0.02f, 0.5f, 0.9f), metals[a], roughs[r], 0.f);
                vec3 wo = direction_at(cos_o[k], 0.f), wi = direction_at(cos_i[k], 2.5f);
                vec3 f = pm_brdf_eval(&b, v3(0, 0, 1), wo, wi);
                double co = cos_o[k], ci = cos_i[k], m = metals[a];
                double alpha = fmax(1e-3, (double)roughs[r] * roughs[r]);
                double h[3] = {wo.x + wi.x, wo.y + wi.y, wo.z + wi.z}, hl = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
                double ch = h[2] / hl, vh = (wo.x * h[0] + wo.y * h[1] + wo.z * h[2]) / hl;
                for (int c = 0; c < 3; c++) {
                    double metal_brdf = schlick(base[c], 1.0, vh) * ggx_lobe(alpha, co, ci, ch);
                    double dielectric_brdf = schlick(0.04, 1.0, vh) * ggx_lobe(alpha, co, ci, ch) +
                                             (1 - schlick(0.04, 1.0, co)) * (1 - schlick(0.04, 1.0, ci)) * base[c] / PI_D;
                    double want = m * metal_brdf + (1 - m) * dielectric_brdf;
                    CHECK_NEAR(v3_get(f, c), want, 2e-4, 1e-7, "plain f = glTF's mix(dielectric, metal, metallic)");
                }
            }
}

/* Furnace, pdf, sampler and reciprocity over many materials and angles. */
static void furnace(void) {
    const float metals[] = {0.f, 0.5f, 1.f}, roughs[] = {0.05f, 0.4f, 1.f};
    const float coats[] = {0.f, 1.f}, coat_roughs[] = {0.f, 0.5f};
    const float sheens[] = {0.f, 1.f}, sheen_roughs[] = {0.07f, 0.5f, 1.f};
    const float speculars[] = {1.f, 0.4f};
    const vec3 specular_colors[] = {v3s(1.f), v3(2.5f, 1.f, 25.f)};
    const float cosines[] = {1.f, 0.6f, 0.25f, 0.05f};
    double worst = 0.0, kept;
    float worst_cos = 1.f;
    pm_brdf worst_brdf = pm_brdf_at(v3s(1.f), 1.f, 1.f, 0.f);
    int cases = 0, mismatches = 0, pdf_checked = 0;
    for (int a = 0; a < 3; a++)
        for (int b2 = 0; b2 < 3; b2++)
            for (int c = 0; c < 2; c++)
                for (int d = 0; d < 2; d++)
                    for (int e = 0; e < 2; e++)
                        for (int f = 0; f < 3; f++)
                            for (int g = 0; g < 2; g++) {
                                if (coats[c] == 0.f && d > 0) continue;
                                if (sheens[e] == 0.f && f > 0) continue;
                                pm_brdf br = layered(v3s(1.f), metals[a], roughs[b2], speculars[g], specular_colors[g],
                                                     v3s(sheens[e]), sheen_roughs[f], coats[c], coat_roughs[d]);
                                bool sharp = roughs[b2] < 0.3f || (coats[c] > 0.f && coat_roughs[d] < 0.3f);
                                for (int k = 0; k < 4; k++) {
                                    vec3 wo = direction_at(cosines[k], 0.7f);
                                    double kept;
                                    estimate s = albedo_sampled(&br, wo, 3000, &mismatches, &kept);
                                    for (int ch = 0; ch < 3; ch++)
                                        if (s.mean[ch] > worst) {
                                            worst = s.mean[ch];
                                            worst_brdf = br;
                                            worst_cos = cosines[k];
                                        }
                                    cases++;
                                    CHECK(s.mean[0] <= 1.0 + 4.0 * s.stderr_max + 2e-3 && s.mean[2] <= 1.0 + 4.0 * s.stderr_max + 2e-3,
                                          "furnace: albedo %g %g <= 1 (metal %g rough %g coat %g/%g sheen %g/%g spec %g cos %g)",
                                          s.mean[0], s.mean[2], metals[a], roughs[b2], coats[c], coat_roughs[d], sheens[e],
                                          sheen_roughs[f], speculars[g], cosines[k]);
                                    if (!sharp && k < 3) {
                                        double pdf_integral;
                                        estimate u = albedo_uniform(&br, wo, 80, &pdf_integral);
                                        /* GGX samples reflected under the horizon are lost: the pdf's
                                         * integral is the share of samples kept */
                                        CHECK_NEAR(pdf_integral, kept, 0, 0.02, "the pdf integrates to the share of samples kept");
                                        CHECK(pdf_integral <= 1.0 + 0.01, "the pdf integrates to at most 1 (%g)", pdf_integral);
                                        CHECK_NEAR(s.mean[0], u.mean[0], 0, 4.0 * (s.stderr_max + u.stderr_max) + 3e-3,
                                                   "sampler weights = uniform integration of eval");
                                        pdf_checked++;
                                    }
                                    /* reciprocity at a second direction */
                                    vec3 wi = direction_at(0.45f, 2.1f);
                                    vec3 f1 = pm_brdf_eval(&br, v3(0, 0, 1), wo, wi), f2 = pm_brdf_eval(&br, v3(0, 0, 1), wi, wo);
                                    CHECK_NEAR(f1.y, f2.y, 1e-4, 1e-7, "reciprocal");
                                }
                            }
    printf("furnace: %d cases, highest albedo %.4f; %d checked against uniform integration\n", cases, worst, pdf_checked);
    CHECK(mismatches == 0, "sampled f and pdf = eval and pdf (%d mismatches)", mismatches);
    estimate w = albedo_sampled(&worst_brdf, direction_at(worst_cos, 0.7f), 200000, &mismatches, &kept);
    printf("  the highest again with 200000 samples: %.4f +- %.4f (metallic %g alpha %g specular %g coat %g/%g sheen %g/%g cos %g)\n",
           fmax(w.mean[0], w.mean[2]), w.stderr_max, worst_brdf.metallic, worst_brdf.alpha, worst_brdf.specular, worst_brdf.clearcoat,
           worst_brdf.clearcoat_alpha, worst_brdf.sheen_color.x, worst_brdf.sheen_roughness, worst_cos);
    CHECK(w.mean[0] <= 1.0 + 3.0 * w.stderr_max && w.mean[2] <= 1.0 + 3.0 * w.stderr_max, "the highest case, tight: %g %g", w.mean[0],
          w.mean[2]);
    /* a tight furnace at a few worst-looking corners (grazing, white everything) with many samples */
    const float tight_cos[] = {1.f, 0.3f, 0.05f};
    for (int k = 0; k < 3; k++) {
        /* sheen roughness 0.55: alphaG 0.3 */
        pm_brdf br = layered(v3s(1.f), 0.f, 1.f, 0.f, v3s(1.f), v3s(1.f), 0.55f, 1.f, 0.5f); /* Lambert: specular 0 */
        estimate s = albedo_sampled(&br, direction_at(tight_cos[k], 0.f), 200000, &mismatches, &kept);
        printf("  white Lambert + sheen 0.55 + coat 0.5, cos %.2f: albedo %.4f +- %.4f\n", tight_cos[k], s.mean[0], s.stderr_max);
        CHECK(s.mean[0] <= 1.0 + 3.0 * s.stderr_max, "white layered furnace %g", s.mean[0]);
        /* single scattering loses little but at grazing angles (the coat's GGX shadowing) */
        if (tight_cos[k] >= 0.3f) CHECK(s.mean[0] > 0.8, "the layers lose little (%g)", s.mean[0]);
    }
}

/* The layers at their neutral values leave the lobe bit for bit as without them. */
static void defaults(void) {
    pm_rng rng = pm_rng_for(3, 4, 5);
    int differ = 0;
    for (int i = 0; i < 2000; i++) {
        vec3 base = v3(pm_rng_float(&rng), pm_rng_float(&rng), pm_rng_float(&rng));
        float metal = 0.01f + 0.99f * pm_rng_float(&rng), rough = 0.05f + 0.95f * pm_rng_float(&rng);
        pm_brdf plain = pm_brdf_at(base, metal, rough, 0.2f), with = plain;
        pm_brdf_add_layers(&with, 1.f, v3s(1.f), v3s(0.f), 0.5f, 0.f, 0.3f);
        vec3 wo = direction_at(0.02f + 0.98f * pm_rng_float(&rng), 0.f), wi = direction_at(pm_rng_float(&rng), 6.f * pm_rng_float(&rng));
        vec3 n = v3(0, 0, 1), fa = pm_brdf_eval(&plain, n, wo, wi), fb = pm_brdf_eval(&with, n, wo, wi);
        differ += memcmp(&fa, &fb, sizeof fa) != 0;
        differ += pm_brdf_pdf(&plain, n, wo, wi) != pm_brdf_pdf(&with, n, wo, wi);
        float u0 = pm_rng_float(&rng), u1 = pm_rng_float(&rng), u2 = pm_rng_float(&rng);
        vec3 da, db, ga, gb;
        float pa = 0, pb = 0;
        bool ka = pm_brdf_sample(&plain, n, wo, u0, u1, u2, &da, &ga, &pa), kb = pm_brdf_sample(&with, n, wo, u0, u1, u2, &db, &gb, &pb);
        differ += ka != kb || (ka && (memcmp(&da, &db, sizeof da) || memcmp(&ga, &gb, sizeof ga) || pa != pb));
    }
    CHECK(differ == 0, "specular 1 colour 1, sheen 0, clearcoat 0: the plain lobe exactly (%d differences)", differ);
    /* metallic 0 with neutral layers: the plain dielectric lobe, exactly */
    pm_brdf diel = layered(v3(0.8f, 0.5f, 0.2f), 0.f, 0.7f, 1.f, v3s(1.f), v3s(0.f), 0.5f, 0.f, 0.f);
    pm_brdf diel_plain = pm_brdf_at(v3(0.8f, 0.5f, 0.2f), 0.f, 0.7f, 0.f);
    vec3 wo = direction_at(0.3f, 0.f), wi = direction_at(0.8f, 1.f);
    vec3 fd = pm_brdf_eval(&diel, v3(0, 0, 1), wo, wi), fp = pm_brdf_eval(&diel_plain, v3(0, 0, 1), wo, wi);
    CHECK(memcmp(&fd, &fp, sizeof fd) == 0, "metallic 0, neutral layers: the plain dielectric lobe");
    /* metallic 0 with specularFactor 0: Lambert base/pi, sampled by the cosine alone */
    pm_brdf lam = layered(v3(0.8f, 0.5f, 0.2f), 0.f, 0.7f, 0.f, v3s(1.f), v3s(0.f), 0.5f, 0.f, 0.f);
    vec3 f = pm_brdf_eval(&lam, v3(0, 0, 1), wo, wi);
    CHECK_NEAR(f.x, 0.8 / PI_D, 1e-6, 0, "metallic 0 specular 0: Lambert");
    CHECK_NEAR(f.z, 0.2 / PI_D, 1e-6, 0, "metallic 0 specular 0: Lambert");
    CHECK_NEAR(pm_brdf_pdf(&lam, v3(0, 0, 1), wo, wi), 0.8 / PI_D, 1e-6, 0, "metallic 0 specular 0: cosine pdf");
    /* coat factor 0 and sheen colour 0 with other settings: the lobe without those layers */
    pm_brdf spec_only = layered(v3(0.3f, 0.6f, 0.9f), 0.4f, 0.6f, 0.5f, v3(1.f, 2.f, 3.f), v3s(0.f), 0.5f, 0.f, 0.f);
    pm_brdf spec_coat0 = layered(v3(0.3f, 0.6f, 0.9f), 0.4f, 0.6f, 0.5f, v3(1.f, 2.f, 3.f), v3s(0.f), 0.9f, 0.f, 0.7f);
    vec3 fa = pm_brdf_eval(&spec_only, v3(0, 0, 1), wo, wi), fb = pm_brdf_eval(&spec_coat0, v3(0, 0, 1), wo, wi);
    CHECK(memcmp(&fa, &fb, sizeof fa) == 0, "clearcoat 0 and sheen colour 0 leave the lobe as it is");
    /* specular 0 on a metal: the dielectric share is pure Lambert (the text's fresnel_mix with weight 0) */
    pm_brdf no_spec = layered(v3s(1.f), 0.5f, 0.6f, 0.f, v3s(1.f), v3s(0.f), 0.5f, 0.f, 0.f);
    pm_brdf metal = pm_brdf_at(v3s(1.f), 1.f, 0.6f, 0.f);
    vec3 fn = pm_brdf_eval(&no_spec, v3(0, 0, 1), wo, wi), fm = pm_brdf_eval(&metal, v3(0, 0, 1), wo, wi);
    CHECK_NEAR(fn.x, 0.5 * fm.x + 0.5 / PI_D, 1e-5, 0, "specular 0: half metal, half Lambert");
    /* the parts the vertex kernel's near-specular rule looks at: the coat where it is sharp, the
     * base's reflection where it is, none from a Lambert base (specular 0) */
    pm_brdf coated = layered(v3s(0.5f), 0.f, 0.1f, 1.f, v3s(1.f), v3s(0.f), 0.5f, 1.f, 0.f);
    CHECK(pm_brdf_parts_sharper_than(&coated, 0.1f) == (PM_BRDF_SPECULAR | PM_BRDF_COAT), "a smooth coat over a sharp base");
    CHECK(pm_brdf_parts_sharper_than(&coated, 0.005f) == PM_BRDF_COAT, "alpha 0.01 is not below 0.005: the coat alone");
    coated.clearcoat = 0.f;
    CHECK(pm_brdf_parts_sharper_than(&coated, 0.1f) == PM_BRDF_SPECULAR, "without the coat: the dielectric lobe");
    coated.specular = 0.f;
    CHECK(pm_brdf_parts_sharper_than(&coated, 0.1f) == 0, "a Lambert base (specular 0) is not, whatever its roughness");
    CHECK(pm_brdf_parts(&coated) == PM_BRDF_DIFFUSE, "a Lambert base: its diffuse part alone");
    CHECK(pm_brdf_parts_sharper_than(&metal, 0.5f) == PM_BRDF_SPECULAR && pm_brdf_parts_sharper_than(&metal, 0.36f) == 0,
          "a plain lobe: by its alpha, 0.36");
}

/* The coat's own normal (clearcoatNormalTexture): its highlight turns with it, the base's stays
 * about n; the whole stays reciprocal, its sampler agrees with pdf() and eval(), under albedo 1. */
static void coat_normal(void) {
    vec3 n = v3(0, 0, 1), cn = v3_normalize(v3(0.3f, 0.f, 1.f));
    pm_brdf b = layered(v3s(0.9f), 1.f, 0.2f, 1.f, v3s(1.f), v3s(0.f), 0.5f, 1.f, 0.1f), tilted = b;
    tilted.coat_normal = true;
    tilted.coat_n = cn;
    vec3 wo = direction_at(0.8f, 0.f);
    vec3 about_n = v3_reflect(v3_neg(wo), n), about_cn = v3_reflect(v3_neg(wo), cn);
    float plain_n = pm_brdf_eval(&b, n, wo, about_n).y, plain_cn = pm_brdf_eval(&b, n, wo, about_cn).y;
    float tilted_n = pm_brdf_eval(&tilted, n, wo, about_n).y, tilted_cn = pm_brdf_eval(&tilted, n, wo, about_cn).y;
    printf("coat normal tilted 17 deg: f at the mirror direction about n %.3f -> %.3f, about the coat's normal %.3f -> %.3f\n",
           plain_n, tilted_n, plain_cn, tilted_cn);
    CHECK(tilted_cn > 10.f * plain_cn, "the coat's highlight moves to its own normal's mirror direction");
    CHECK(tilted_n < plain_n && tilted_n > 0.4f * plain_n, "the base's highlight stays about n (the coat's left it)");
    /* the base's highlight alone (no coat): the same with or without the coat's normal */
    pm_brdf bare = b, bare_tilted = tilted;
    bare.clearcoat = bare_tilted.clearcoat = 0.f;
    vec3 fa = pm_brdf_eval(&bare, n, wo, about_n), fb = pm_brdf_eval(&bare_tilted, n, wo, about_n);
    CHECK(memcmp(&fa, &fb, sizeof fa) == 0, "without a coat its normal changes nothing");
    /* reciprocity, sampler against pdf and eval, furnace, for a rough tilted coat */
    pm_brdf rough = layered(v3s(1.f), 0.f, 0.6f, 1.f, v3s(1.f), v3s(0.f), 0.5f, 1.f, 0.5f);
    rough.coat_normal = true;
    rough.coat_n = cn;
    const float cosines[] = {1.f, 0.6f, 0.25f};
    for (int k = 0; k < 3; k++) {
        vec3 w = direction_at(cosines[k], 2.f), wi = direction_at(0.45f, 0.7f);
        vec3 f1 = pm_brdf_eval(&rough, n, w, wi), f2 = pm_brdf_eval(&rough, n, wi, w);
        CHECK_NEAR(f1.y, f2.y, 1e-4, 1e-7, "a tilted coat stays reciprocal");
        int mismatches = 0;
        double kept, pdf_integral;
        estimate s = albedo_sampled(&rough, w, 40000, &mismatches, &kept);
        estimate u = albedo_uniform(&rough, w, 200, &pdf_integral);
        CHECK(mismatches == 0, "tilted coat: sampled pdf and f are pdf() and eval() (%d differ)", mismatches);
        CHECK_NEAR(pdf_integral, kept, 0, 0.02, "tilted coat: the pdf integrates to the share of samples kept");
        CHECK_NEAR(s.mean[0], u.mean[0], 0, 4.0 * (s.stderr_max + u.stderr_max) + 3e-3, "tilted coat: sampler = uniform integration");
        CHECK(s.mean[0] <= 1.0 + 4.0 * s.stderr_max, "tilted coat: albedo %g <= 1", s.mean[0]);
    }
}

int main(void) {
    sheen_table();
    spec_formulas();
    gltf_formulas();
    coat_normal();
    defaults();
    furnace();
    return pm_test_done("test_layers");
}

/* test_brdf.c: the glossy BRDF alone: white furnace (albedo <= 1, brute force vs sampler), reciprocity, sampler vs pdf(), material mapping; rough glass's white furnace. */
#include <stdio.h>
#include <string.h>

#include "brdf.h"
#include "rng.h"
#include "scatter.h"
#include "scene.h"
#include "testing.h"

#define PM_PI_D 3.14159265358979323846

static pm_brdf make_brdf(vec3 base, float metallic, float roughness) {
    pm_brdf b;
    memset(&b, 0, sizeof b); /* no layers */
    b.base = base;
    b.metallic = metallic;
    b.alpha = pm_maxf(PM_GLOSSY_MIN_ALPHA, roughness * roughness);
    b.weight = 1.f;
    return b;
}

static vec3 direction_at(float cos_theta, float phi) {
    float s = sqrtf(pm_maxf(0.f, 1.f - cos_theta * cos_theta));
    return v3(s * cosf(phi), s * sinf(phi), cos_theta);
}

typedef struct { double mean[3], stderr_max; } estimate;

/* Directional albedo integral of f cos over the hemisphere by uniform (stratified) directions:
 * the brute force that knows nothing of the sampler. */
static estimate albedo_uniform(const pm_brdf *b, vec3 n, vec3 wo, int side) {
    double sum[3] = {0, 0, 0}, sum2[3] = {0, 0, 0};
    pm_rng rng = pm_rng_for(7, side, 1);
    int count = side * side;
    for (int i = 0; i < side; i++)
        for (int j = 0; j < side; j++) {
            float z = (i + pm_rng_float(&rng)) / side, phi = 2.f * PM_PI * (j + pm_rng_float(&rng)) / side;
            vec3 wi = direction_at(z, phi);
            vec3 f = pm_brdf_eval(b, n, wo, wi);
            for (int c = 0; c < 3; c++) {
                double v = v3_get(f, c) * z * 2.0 * PM_PI; /* uniform pdf 1 / (2 pi) */
                sum[c] += v;
                sum2[c] += v * v;
            }
        }
    estimate e = {{0, 0, 0}, 0};
    for (int c = 0; c < 3; c++) {
        e.mean[c] = sum[c] / count;
        /* stratification only lowers the error: the plain estimator's is an upper bound */
        double var = sum2[c] / count - e.mean[c] * e.mean[c];
        e.stderr_max = fmax(e.stderr_max, sqrt(fmax(var, 0.0) / count));
    }
    return e;
}

/* The same integral as the mean of the sampler's weights f cos / pdf (a lost sample counts 0). */
static estimate albedo_sampled(const pm_brdf *b, vec3 n, vec3 wo, int count, double *max_weight) {
    double sum[3] = {0, 0, 0}, sum2[3] = {0, 0, 0};
    pm_rng rng = pm_rng_for(9, count, 2);
    *max_weight = 0.0;
    for (int i = 0; i < count; i++) {
        vec3 wi, f;
        float pdf;
        if (!pm_brdf_sample(b, n, wo, pm_rng_float(&rng), pm_rng_float(&rng), pm_rng_float(&rng), &wi, &f, &pdf)) continue;
        for (int c = 0; c < 3; c++) {
            double v = v3_get(f, c) * v3_dot(n, wi) / pdf;
            sum[c] += v;
            sum2[c] += v * v;
            *max_weight = fmax(*max_weight, v);
        }
    }
    estimate e = {{0, 0, 0}, 0};
    for (int c = 0; c < 3; c++) {
        e.mean[c] = sum[c] / count;
        e.stderr_max = fmax(e.stderr_max, sqrt(fmax(sum2[c] / count - e.mean[c] * e.mean[c], 0.0) / count));
    }
    return e;
}

/* Independent reference for metal with F = 1: the albedo written with Smith's Lambda (not the
 * V form the BRDF uses), integrated in double precision by the midpoint rule in (cos theta, phi). */
static double lambda_ggx(double a2, double c) { return 0.5 * (-1.0 + sqrt(1.0 + a2 * (1.0 - c * c) / (c * c))); }
static double metal_albedo_quadrature(double alpha, double cos_o) {
    const int nz = 1500, nphi = 600;
    double a2 = alpha * alpha, so = sqrt(1.0 - cos_o * cos_o), sum = 0.0;
    for (int i = 0; i < nz; i++) {
        double ci = (i + 0.5) / nz, si = sqrt(1.0 - ci * ci);
        for (int j = 0; j < nphi; j++) {
            double phi = 2.0 * PM_PI_D * (j + 0.5) / nphi;
            double h[3] = {so + si * cos(phi), si * sin(phi), cos_o + ci};
            double hl = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]), ch = h[2] / hl;
            double t = ch * ch * (a2 - 1.0) + 1.0, d = a2 / (PM_PI_D * t * t);
            double g2 = 1.0 / (1.0 + lambda_ggx(a2, cos_o) + lambda_ggx(a2, ci));
            sum += d * g2 / (4.0 * cos_o); /* f cos_i = D G2 / (4 cos_o) */
        }
    }
    return sum * (1.0 / nz) * (2.0 * PM_PI_D / nphi);
}

static void white_furnace(void) {
    const float roughness[] = {0.2f, 0.4f, 0.6f, 0.8f, 1.f}, cosines[] = {1.f, 0.7f, 0.3f, 0.1f};
    vec3 n = v3(0, 0, 1);
    printf("white furnace, metal with F0 = 1: albedo (brute force / sampler / quadrature), i.e. what single-scattering GGX+Smith loses\n");
    for (size_t r = 0; r < sizeof roughness / sizeof *roughness; r++) {
        pm_brdf metal = make_brdf(v3s(1.f), 1.f, roughness[r]);
        printf("  roughness %.1f:", roughness[r]);
        for (size_t k = 0; k < sizeof cosines / sizeof *cosines; k++) {
            vec3 wo = direction_at(cosines[k], 0.3f);
            estimate u = albedo_uniform(&metal, n, wo, 1000);
            double max_w;
            estimate s = albedo_sampled(&metal, n, wo, 400000, &max_w);
            double q = metal_albedo_quadrature(metal.alpha, cosines[k]);
            printf(" cos %.1f %.4f/%.4f/%.4f", cosines[k], u.mean[0], s.mean[0], q);
            CHECK(s.mean[0] <= 1.0 + 4.0 * s.stderr_max && u.mean[0] <= 1.0 + 4.0 * u.stderr_max,
                  "energy <= 1 (roughness %g, cos %g): %g %g", roughness[r], cosines[k], s.mean[0], u.mean[0]);
            CHECK_NEAR(s.mean[0], u.mean[0], 0, 4.0 * (s.stderr_max + u.stderr_max) + 1e-3, "sampler weights = uniform integration");
            /* float vs double and the quadrature's own error near the peak */
            /* the midpoint rule misses narrow peaks: only for the wider lobes */
            if (roughness[r] >= 0.4f) CHECK_NEAR(u.mean[0], q, 0.002, 4.0 * u.stderr_max, "uniform integration = Lambda-form quadrature");
            /* F = 1 and visible-normal sampling: every weight is G2 / G1(wo) <= 1 */
            CHECK(max_w <= 1.0 + 1e-3, "metal F0=1 sample weight <= 1 (got %g)", max_w);
            /* alpha 1 head-on: D = 1/pi, G2 = 2c/(1+c), so the albedo is 1 - ln 2 */
            if (roughness[r] == 1.f && cosines[k] == 1.f) CHECK_NEAR(q, 1.0 - log(2.0), 1e-3, 0, "alpha 1, head-on: 1 - ln 2");
            if (roughness[r] <= 0.4f && cosines[k] >= 0.3f) CHECK(s.mean[0] > 0.88, "smoother: little is lost (%g)", s.mean[0]);
        }
        printf("\n");
    }
    /* smooth limit: almost nothing is lost at normal incidence (every weight is G2/G1 there) */
    {
        pm_brdf smooth = make_brdf(v3s(1.f), 1.f, 0.1f);
        double max_w;
        estimate s = albedo_sampled(&smooth, n, v3(0, 0, 1), 100000, &max_w);
        CHECK_NEAR(s.mean[0], 1.0, 0.002, 0, "alpha 0.01 keeps the energy head-on");
    }

    /* dielectric and mixed materials, white base: still no energy gain */
    const float metals[] = {0.f, 0.3f, 0.7f};
    for (size_t m = 0; m < 3; m++)
        for (size_t r = 0; r < sizeof roughness / sizeof *roughness; r++)
            for (size_t k = 0; k < sizeof cosines / sizeof *cosines; k++) {
                pm_brdf b = make_brdf(v3(1.f, 0.8f, 0.3f), metals[m], roughness[r]);
                vec3 wo = direction_at(cosines[k], 1.1f);
                estimate u = albedo_uniform(&b, n, wo, 400);
                double max_w;
                estimate s = albedo_sampled(&b, n, wo, 100000, &max_w);
                for (int c = 0; c < 3; c++) {
                    CHECK(u.mean[c] <= 1.0 + 4.0 * u.stderr_max, "metallic %g roughness %g cos %g channel %d: albedo %g > 1",
                          metals[m], roughness[r], cosines[k], c, u.mean[c]);
                    CHECK_NEAR(s.mean[c], u.mean[c], 0, 4.0 * (s.stderr_max + u.stderr_max) + 2e-3,
                               "mixed: sampler weights = uniform integration");
                }
            }
}

/* The sharp end, which uniform integration cannot resolve: the sampler's albedo at roughness 0
 * (alpha PM_GLOSSY_MIN_ALPHA), 0.05 and 0.1 stays at most 1 for white dielectric, mixed and metal
 * lobes; a smooth black dielectric reflects Schlick's curve 0.04 + 0.96 (1 - cos)^5 (its lobe is
 * nearly a mirror, F taken at v.h ~ cos_o, and smooth GGX loses little). */
static void sharp_furnace(void) {
    const float roughness[] = {0.f, 0.05f, 0.1f}, metals[] = {0.f, 0.5f, 1.f}, cosines[] = {1.f, 0.7f, 0.3f, 0.1f};
    vec3 n = v3(0, 0, 1);
    printf("sharp lobes, white base (sampler albedo):");
    for (size_t r = 0; r < 3; r++)
        for (size_t m = 0; m < 3; m++)
            for (size_t k = 0; k < 4; k++) {
                pm_brdf b = make_brdf(v3s(1.f), metals[m], roughness[r]);
                double max_w;
                estimate s = albedo_sampled(&b, n, direction_at(cosines[k], 0.4f), 100000, &max_w);
                if (k == 0 || k == 3) printf(" r%.2f m%.1f c%.1f %.4f", roughness[r], metals[m], cosines[k], s.mean[0]);
                CHECK(s.mean[0] <= 1.0 + 4.0 * s.stderr_max + 1e-3, "sharp furnace: albedo %g <= 1 (roughness %g metallic %g cos %g)",
                      s.mean[0], roughness[r], metals[m], cosines[k]);
            }
    printf("\nsmooth black dielectric (sampler albedo / Schlick):");
    for (size_t k = 0; k < 4; k++) {
        pm_brdf b = make_brdf(v3s(0.f), 0.f, 0.f);
        double max_w, c = cosines[k], want = 0.04 + 0.96 * pow(1.0 - c, 5.0);
        estimate s = albedo_sampled(&b, n, direction_at(cosines[k], 0.4f), 100000, &max_w);
        printf(" cos %.1f %.4f/%.4f", c, s.mean[0], want);
        CHECK_NEAR(s.mean[0], want, 0.02, 4.0 * s.stderr_max, "a smooth black dielectric reflects Schlick's curve");
    }
    printf("\n");
}

static void reciprocity(void) {
    pm_rng rng = pm_rng_for(3, 4, 5);
    vec3 n = v3_normalize(v3(0.2f, -0.4f, 1.f));
    double worst = 0.0;
    for (int i = 0; i < 20000; i++) {
        pm_brdf b = make_brdf(v3(pm_rng_float(&rng), pm_rng_float(&rng), pm_rng_float(&rng)), pm_rng_float(&rng),
                              0.05f + 0.95f * pm_rng_float(&rng));
        vec3 wo = pm_sample_cosine(n, pm_rng_float(&rng), pm_rng_float(&rng));
        vec3 wi = pm_sample_cosine(n, pm_rng_float(&rng), pm_rng_float(&rng));
        vec3 a = pm_brdf_eval(&b, n, wo, wi), c = pm_brdf_eval(&b, n, wi, wo);
        for (int k = 0; k < 3; k++) {
            double scale = fmax(fabs(v3_get(a, k)), 1e-6);
            worst = fmax(worst, fabs(v3_get(a, k) - v3_get(c, k)) / scale);
        }
        CHECK(v3_is_black(pm_brdf_eval(&b, n, wo, v3_neg(wi))), "f = 0 below the surface");
    }
    printf("reciprocity: largest relative |f(wo,wi) - f(wi,wo)| over 20000 pairs %.2g\n", worst);
    CHECK(worst < 1e-4, "f(wo, wi) = f(wi, wo) (worst relative difference %g)", worst);
}

/* The sampler's histogram over (cos theta, phi) bins against pdf() integrated over each bin, and
 * pdf() integrated over the hemisphere against the share of samples that were not lost. */
static void sampler_matches_pdf(float metallic, float roughness, float cos_o, unsigned skip) {
    enum { NZ = 12, NP = 24, SUB = 12, SAMPLES = 1000000 };
    static double hist[NZ][NP];
    memset(hist, 0, sizeof hist);
    vec3 n = v3(0, 0, 1), wo = direction_at(cos_o, 0.f);
    pm_brdf b = make_brdf(v3(0.9f, 0.6f, 0.3f), metallic, roughness);
    b.skip = skip; /* one part of the vertex kernel's split samples the others alone */
    pm_rng rng = pm_rng_for(11, (uint64_t)(roughness * 100), (uint64_t)(cos_o * 100));
    int kept = 0, pdf_mismatch = 0;
    for (int i = 0; i < SAMPLES; i++) {
        vec3 wi, f;
        float pdf;
        if (!pm_brdf_sample(&b, n, wo, pm_rng_float(&rng), pm_rng_float(&rng), pm_rng_float(&rng), &wi, &f, &pdf)) continue;
        kept++;
        if (fabsf(pdf - pm_brdf_pdf(&b, n, wo, wi)) > 1e-4f * pdf) pdf_mismatch++;
        float phi = atan2f(wi.y, wi.x);
        if (phi < 0.f) phi += 2.f * PM_PI;
        int iz = (int)(wi.z * NZ), ip = (int)(phi / (2.f * PM_PI) * NP);
        hist[iz < NZ ? iz : NZ - 1][ip < NP ? ip : NP - 1] += 1.0;
    }
    double total = 0.0, worst = 0.0;
    for (int iz = 0; iz < NZ; iz++)
        for (int ip = 0; ip < NP; ip++) {
            double p = 0.0;
            for (int a = 0; a < SUB; a++)
                for (int c = 0; c < SUB; c++) {
                    float z = (iz + (a + 0.5f) / SUB) / NZ, phi = 2.f * PM_PI * (ip + (c + 0.5f) / SUB) / NP;
                    p += pm_brdf_pdf(&b, n, wo, direction_at(z, phi));
                }
            p *= (1.0 / NZ) * (2.0 * PM_PI_D / NP) / (SUB * SUB); /* d omega = d(cos theta) d phi */
            total += p;
            double freq = hist[iz][ip] / SAMPLES, tol = 5.0 * sqrt(p / SAMPLES) + 0.03 * p + 2e-5;
            worst = fmax(worst, fabs(freq - p) / tol);
        }
    printf("sampler vs pdf (metallic %.1f roughness %.1f cos %.1f skip %u): integral of pdf %.4f, samples kept %.4f, worst bin %.2f of its tolerance\n",
           metallic, roughness, cos_o, skip, total, (double)kept / SAMPLES, worst);
    CHECK(pdf_mismatch == 0, "the sample's pdf is pm_brdf_pdf at the sampled direction (%d differ)", pdf_mismatch);
    CHECK(total <= 1.0 + 5e-3, "pdf integrates to <= 1 (%g)", total);
    CHECK_NEAR(total, (double)kept / SAMPLES, 0.01, 2e-3, "pdf integral = share of samples kept");
    CHECK(worst <= 1.0, "every bin's frequency matches the integral of pdf() over it (worst %.2f of tolerance)", worst);
}

/* The vertex kernel's split of a lobe into parts (brdf.h skip): the parts' values add up to the
 * whole's, their albedo estimates too, and each part's sampler estimates its own albedo (the
 * brute force over the hemisphere of that part alone). */
static void split_parts(void) {
    vec3 n = v3(0, 0, 1);
    pm_brdf whole = make_brdf(v3(0.9f, 0.6f, 0.3f), 0.3f, 0.2f), spec = whole, rest = whole;
    spec.skip = PM_BRDF_DIFFUSE | PM_BRDF_SHEEN | PM_BRDF_COAT;
    rest.skip = PM_BRDF_SPECULAR;
    pm_rng rng = pm_rng_for(13, 0, 0);
    double worst = 0.0;
    for (int i = 0; i < 2000; i++) {
        vec3 wo = direction_at(0.05f + 0.95f * pm_rng_float(&rng), 0.f);
        vec3 wi = direction_at(0.05f + 0.95f * pm_rng_float(&rng), 2.f * PM_PI * pm_rng_float(&rng));
        vec3 f = pm_brdf_eval(&whole, n, wo, wi), a = pm_brdf_eval(&spec, n, wo, wi), b = pm_brdf_eval(&rest, n, wo, wi);
        for (int c = 0; c < 3; c++)
            worst = fmax(worst, fabs(v3_get(a, c) + v3_get(b, c) - v3_get(f, c)) / fmax(1e-6, v3_get(f, c)));
    }
    CHECK(worst < 1e-5, "the parts' values add up to the lobe's (worst relative difference %g)", worst);
    vec3 wo = direction_at(0.6f, 0.f);
    float e_whole = pm_brdf_albedo_estimate(&whole, n, wo), e_spec = pm_brdf_albedo_estimate(&spec, n, wo),
          e_rest = pm_brdf_albedo_estimate(&rest, n, wo);
    CHECK(e_spec > 0.f && e_rest > 0.f, "each part reflects something (estimates %g, %g)", e_spec, e_rest);
    CHECK_NEAR(e_spec + e_rest, e_whole, 1e-6, 1e-6, "the parts' albedo estimates add up to the lobe's");
    const pm_brdf *parts[2] = {&spec, &rest};
    for (int k = 0; k < 2; k++) {
        double max_weight;
        estimate u = albedo_uniform(parts[k], n, wo, 400), smp = albedo_sampled(parts[k], n, wo, 400000, &max_weight);
        double tol = 4.0 * (u.stderr_max + smp.stderr_max) + 1e-3;
        printf("part %d: albedo by the sampler %.4f %.4f, brute force %.4f %.4f (tolerance %.4f)\n", k, smp.mean[0], smp.mean[2],
               u.mean[0], u.mean[2], tol);
        CHECK(fabs(smp.mean[0] - u.mean[0]) <= tol && fabs(smp.mean[2] - u.mean[2]) <= tol,
              "part %d: the sampler's albedo is the brute force's", k);
    }
}

static void material_mapping(void) {
    pm_material m;
    memset(&m, 0, sizeof m);
    m.base_color = v3(0.8f, 0.6f, 0.4f);
    m.base_color_texture = m.emission_texture = -1;
    m.ior = 1.5f;
    vec3 kd, ks, kt;
    m.metallic = 1.f;
    m.roughness = 0.f;
    CHECK(!pm_material_glossy(&m), "metal roughness 0 is the mirror");
    pm_material_split(&m, m.base_color, &kd, &ks, &kt);
    CHECK(v3_is_black(kd) && ks.x == 0.8f && v3_is_black(kt), "mirror split unchanged");
    m.roughness = 0.03f; /* alpha 9e-4 < 1e-3 */
    CHECK(!pm_material_glossy(&m), "below the threshold: still the mirror");
    m.roughness = 0.04f;
    CHECK(pm_material_glossy(&m), "alpha 1.6e-3: glossy");
    m.roughness = 0.5f;
    m.metallic = 0.5f;
    m.transmission = 0.4f;
    CHECK(pm_material_glossy(&m), "some metal, rough: glossy");
    pm_material_split(&m, m.base_color, &kd, &ks, &kt);
    CHECK(v3_is_black(kd) && v3_is_black(ks), "glossy: the lobe replaces kd and ks");
    CHECK_NEAR(kt.x, 0.8f * 0.4f * 0.5f, 1e-6, 0, "glossy: glass share t (1 - m) stays");
    pm_brdf b = pm_material_brdf(&m, m.base_color);
    CHECK_NEAR(b.alpha, 0.25f, 1e-6, 0, "alpha = roughness^2");
    CHECK_NEAR(b.weight, 1.f - 0.4f * 0.5f, 1e-6, 0, "lobe weight = 1 - glass share");
    m.metallic = 0.f;
    m.transmission = 0.f;
    CHECK(pm_material_glossy(&m), "metallic 0: glTF's dielectric lobe over the diffuse base");
    m.roughness = 0.f;
    CHECK(pm_material_glossy(&m), "a smooth dielectric too (its lobe at the smallest alpha)");
    m.transmission = 1.f;
    CHECK(!pm_material_glossy(&m), "clear glass: no opaque share, Fresnel is the glass's");
    m.transmission = 0.f;
    m.layered = true; /* KHR_materials_specular specularFactor 0: the file says Lambert */
    m.layers.specular = 0.f;
    m.layers.specular_color = v3s(1.f);
    CHECK(!pm_material_glossy(&m), "specularFactor 0: Lambert");
    pm_material_split(&m, m.base_color, &kd, &ks, &kt);
    CHECK(kd.x == 0.8f && v3_is_black(ks), "Lambert split unchanged");
    m.metallic = 1.f;
    CHECK(!pm_material_glossy(&m), "specularFactor 0 does not touch the metal: roughness 0 is the mirror");
    /* the smooth metal's mirror follows Schlick from the base colour to 1 at grazing */
    float grazing;
    pm_material_split_at(m.base_color, 1.f, 0.f, 0.f, 1.f, &kd, &ks, &grazing, &kt);
    pm_surface sf;
    memset(&sf, 0, sizeof sf);
    sf.ks = ks;
    sf.ks_grazing = grazing;
    const float cosines[] = {1.f, 0.5f, 0.2f, 0.f};
    for (size_t k = 0; k < 4; k++) {
        double c = cosines[k], w = pow(1.0 - c, 5.0);
        vec3 r = pm_mirror_reflectance(&sf, cosines[k]);
        CHECK_NEAR(r.x, 0.8 + 0.2 * w, 1e-6, 1e-6, "mirror Schlick red");
        CHECK_NEAR(r.z, 0.4 + 0.6 * w, 1e-6, 1e-6, "mirror Schlick blue");
    }
    sf.ks = v3s(1.f);
    sf.ks_grazing = 1.f;
    CHECK(pm_mirror_reflectance(&sf, 0.3f).y == 1.f, "a white mirror reflects 1 at every angle, exactly");
}

/* Rough glass (pm_scatter_specular's GGX microfacet reflection and refraction, Walter et al.
 * 2007), white (kt 1, no mirror share), solid (entered from outside and left from inside) and
 * thin: the mean weight of the scattered rays, reflected and transmitted together, is the energy
 * kept, at most 1 at every roughness and angle (each weight is G1 <= 1: single scattering only
 * loses), 1 for smooth glass exactly, and growing toward 1 as the roughness falls. */
static void glass_furnace(void) {
    const float roughness[] = {0.f, 0.05f, 0.1f, 0.3f, 0.6f, 1.f}, cosines[] = {1.f, 0.7f, 0.3f, 0.1f};
    printf("white rough glass furnace (solid from outside / from inside / thin), energy kept:\n");
    for (int kind = 0; kind < 3; kind++) {
        double previous[4] = {2, 2, 2, 2};
        for (size_t r = 0; r < sizeof roughness / sizeof *roughness; r++) {
            printf("  %-14s roughness %.2f:", kind == 0 ? "from outside" : kind == 1 ? "from inside" : "thin", roughness[r]);
            for (size_t k = 0; k < 4; k++) {
                pm_surface sf;
                memset(&sf, 0, sizeof sf);
                sf.ng = sf.ns = v3(0, 0, 1);
                sf.p = sf.centroid = v3s(0.f);
                sf.kt = v3s(1.f);
                sf.ior = 1.5f;
                sf.thin = kind == 2;
                sf.glass_alpha = pm_glass_alpha_at(roughness[r]);
                vec3 wo = direction_at(cosines[k], 0.7f);
                if (kind == 1) wo = v3_neg(wo); /* from inside: arriving from below */
                pm_rng rng = pm_rng_for(13, r * 4 + k, (uint64_t)kind);
                enum { N = 200000 };
                double sum = 0, sum2 = 0, worst = 0;
                for (int i = 0; i < N; i++) {
                    pm_specular_sample sp;
                    double w = pm_scatter_specular(&sf, v3_neg(wo), &rng, 1.f, &sp) ? sp.weight.y : 0.0;
                    sum += w;
                    sum2 += w * w;
                    worst = fmax(worst, w);
                }
                double mean = sum / N, err = sqrt(fmax(0.0, sum2 / N - mean * mean) / N);
                printf(" cos %.1f %.4f", cosines[k], mean);
                CHECK(worst <= 1.0 + 1e-5, "rough glass: every weight <= 1 (kind %d roughness %g cos %g: %g)", kind, roughness[r], cosines[k], worst);
                CHECK(mean <= 1.0 + 4.0 * err + 1e-6, "rough glass: energy <= 1 (kind %d roughness %g cos %g: %g)", kind, roughness[r],
                      cosines[k], mean);
                if (roughness[r] == 0.f) CHECK_NEAR(mean, 1.0, 1e-6, 0, "smooth white glass keeps all of it");
                /* rougher loses at least as much (within the noise) */
                CHECK(mean <= previous[k] + 4.0 * err + 1e-3, "rough glass: energy falls with roughness (kind %d cos %g: %g after %g)",
                      kind, cosines[k], mean, previous[k]);
                if (roughness[r] <= 0.3f && cosines[k] >= 0.7f)
                    CHECK(mean > 0.9, "rough glass near normal incidence loses little (kind %d roughness %g: %g)", kind, roughness[r], mean);
                previous[k] = mean;
            }
            printf("\n");
        }
    }
}

int main(void) {
    material_mapping();
    reciprocity();
    sampler_matches_pdf(1.f, 0.3f, 0.9f, 0);
    sampler_matches_pdf(1.f, 0.7f, 0.2f, 0);
    sampler_matches_pdf(0.4f, 0.5f, 0.5f, 0);
    sampler_matches_pdf(0.1f, 1.0f, 0.95f, 0);
    sampler_matches_pdf(0.4f, 0.5f, 0.5f, PM_BRDF_SPECULAR);
    sampler_matches_pdf(0.4f, 0.5f, 0.5f, PM_BRDF_DIFFUSE);
    split_parts();
    white_furnace();
    sharp_furnace();
    glass_furnace();
    return pm_test_done("test_brdf");
}

/* vertex.c: the path-vertex kernel (vertex.h): the part chosen, its sampling, value and pdf, and the one survival rule. */
#include "vertex.h"

vec3 pm_vertex_f(const pm_surface *sf, pm_lobe part, vec3 ns, vec3 wo, vec3 wi) {
    if (!sf->glossy) return part == PM_LOBE_NONSPECULAR ? v3_scale(sf->kd, PM_INV_PI) : v3s(0.f);
    if (part != PM_LOBE_NONSPECULAR && part != PM_LOBE_NEAR_SPECULAR) return v3s(0.f);
    pm_brdf b = pm_vertex_part_lobe(sf, part);
    return pm_brdf_eval(&b, ns, wo, wi);
}

float pm_vertex_pdf(const pm_surface *sf, pm_lobe part, vec3 ns, vec3 wo, vec3 wi) {
    if (!sf->glossy) return part == PM_LOBE_NONSPECULAR ? pm_maxf(0.f, v3_dot(ns, wi)) * PM_INV_PI : 0.f;
    if (part != PM_LOBE_NONSPECULAR && part != PM_LOBE_NEAR_SPECULAR) return 0.f;
    pm_brdf b = pm_vertex_part_lobe(sf, part);
    return pm_brdf_pdf(&b, ns, wo, wi);
}

bool pm_vertex_sample_part(const pm_surface *sf, pm_lobe part, vec3 wo, pm_rng *rng, float scale, pm_vertex_ray *out) {
    vec3 ng = pm_facing(sf->ng, wo), ns = pm_facing(sf->ns, ng);
    out->radiance_scale = 1.f;
    out->transmitted = out->straight = false;
    out->sampled = false;
    if (sf->glossy) {
        pm_brdf b = pm_vertex_part_lobe(sf, part);
        vec3 f;
        if (!pm_brdf_sample(&b, ns, wo, pm_rng_float(rng), pm_rng_float(rng), pm_rng_float(rng), &out->direction, &f, &out->pdf))
            return false;
        out->value = v3_scale(f, v3_dot(ns, out->direction) / out->pdf);
    } else {
        if (part != PM_LOBE_NONSPECULAR) return false;
        out->direction = pm_sample_cosine(ns, pm_rng_float(rng), pm_rng_float(rng));
        out->pdf = pm_maxf(0.f, v3_dot(ns, out->direction)) * PM_INV_PI;
        out->value = sf->kd; /* kd/pi x cos / (cos/pi) */
    }
    out->origin = pm_surface_origin(sf, ng, scale);
    out->sampled = v3_dot(out->direction, ng) > 0.f;
    return out->sampled;
}

/* The parts' choice weights at wo: N's and G's estimated albedos (Lambert's mean kd), S the
 * mirror's and glass's mean weights. */
static void part_weights(const pm_surface *sf, vec3 wo, bool nonspecular_in_place, float *n, float *g, float *s) {
    *s = pm_specular_weight(sf);
    if (!sf->glossy) {
        *n = nonspecular_in_place ? 0.f : v3_average(sf->kd);
        *g = 0.f;
        return;
    }
    vec3 ns = pm_vertex_normal(sf, wo);
    unsigned near = pm_vertex_near_specular_parts(&sf->brdf);
    *n = 0.f;
    if (!nonspecular_in_place) {
        pm_brdf b = pm_vertex_part_lobe(sf, PM_LOBE_NONSPECULAR);
        *n = pm_brdf_albedo_estimate(&b, ns, wo);
    }
    *g = 0.f;
    if (near) {
        pm_brdf b = pm_vertex_part_lobe(sf, PM_LOBE_NEAR_SPECULAR);
        *g = pm_brdf_albedo_estimate(&b, ns, wo);
    }
}

/* Step 1: the part, by one number when two or more can be chosen; *total is the weights' sum. */
static pm_lobe choose(float n, float g, float s, pm_rng *rng, float *choice, float *total) {
    n = n > 0.f ? n : 0.f;
    g = g > 0.f ? g : 0.f;
    s = s > 0.f ? s : 0.f;
    *total = n + g + s;
    *choice = 1.f;
    int present = (n > 0.f) + (g > 0.f) + (s > 0.f);
    if (!present) return PM_LOBE_NONE;
    if (present == 1) return n > 0.f ? PM_LOBE_NONSPECULAR : (g > 0.f ? PM_LOBE_NEAR_SPECULAR : PM_LOBE_SPECULAR);
    float u = pm_rng_float(rng) * *total;
    if (u < n) { *choice = *total / n; return PM_LOBE_NONSPECULAR; }
    if (u < n + g || !(s > 0.f)) { *choice = *total / g; return PM_LOBE_NEAR_SPECULAR; }
    *choice = *total / s;
    return PM_LOBE_SPECULAR;
}

/* Step 3's draw: true when the path goes on, with q in *q. */
static bool survives(float mean, pm_rng *rng, float *q) {
    *q = pm_minf(PM_MAX_SURVIVAL, mean);
    return *q > 0.f && pm_rng_float(rng) < *q;
}

bool pm_vertex_choose(const pm_surface *sf, vec3 d, int vertex, const pm_vertex_policy *policy, pm_rng *rng, pm_vertex_ray *out) {
    vec3 wo = v3_neg(d);
    float n, g, s, total;
    part_weights(sf, wo, policy->nonspecular_in_place, &n, &g, &s);
    if (policy->only != PM_LOBE_NONE) {
        n = policy->only == PM_LOBE_NONSPECULAR ? n : 0.f;
        g = policy->only == PM_LOBE_NEAR_SPECULAR ? g : 0.f;
        s = policy->only == PM_LOBE_SPECULAR ? s : 0.f;
    }
    /* N's share of the weights, which ends the path in a choice among all three, left out of the
     * choice (G and S in proportion to theirs, their weight over their probability as always) */
    out->specular_share = 1.f;
    if (policy->nonspecular_weighed && n > 0.f) {
        float all = n + pm_maxf(0.f, g) + pm_maxf(0.f, s);
        out->specular_share = (all - n) / all;
        n = 0.f;
    }
    out->lobe = choose(n, g, s, rng, &out->choice, &total);
    out->sampled = false;
    out->survival = 0.f;
    out->choice_total = total;
    if (out->lobe == PM_LOBE_NONE || (out->lobe == PM_LOBE_NONSPECULAR && policy->nonspecular_ends)) return false;
    /* step 3 before step 2 where the survival does not hang on the sample (every part but a GGX
     * one) and nothing is read of a path that ends: a photon absorbed draws no sample */
    bool sample_free = !sf->glossy || out->lobe == PM_LOBE_SPECULAR;
    if (policy->ended_unsampled && sample_free && vertex >= policy->roulette_from)
        return survives(total / out->specular_share, rng, &out->survival);
    return true;
}

bool pm_vertex_sample_chosen(const pm_surface *sf, vec3 d, int vertex, const pm_vertex_policy *policy, pm_rng *rng, float scale,
                             pm_vertex_ray *out) {
    /* step 2 */
    if (out->lobe == PM_LOBE_SPECULAR) {
        pm_specular_sample sp;
        if (!pm_scatter_specular(sf, d, rng, scale, &sp)) return false;
        out->direction = sp.direction;
        out->origin = sp.origin;
        out->value = sp.weight;
        out->pdf = 0.f;
        out->radiance_scale = sp.radiance_scale;
        out->transmitted = sp.transmitted;
        out->straight = sp.straight;
        out->sampled = true;
    } else if (!pm_vertex_sample_part(sf, out->lobe, v3_neg(d), rng, scale, out)) {
        return false;
    }
    out->weight = v3_scale(out->value, out->choice);
    /* step 3: Lambert's, the mirror's and glass's mean weight over their choice is the weights' sum;
     * a GGX part's weight depends on the direction drawn: the sample's. With N left out of the
     * choice (nonspecular_weighed) both are taken as in the choice among all three (the weight
     * over P, the sum with N's): the path goes on with that choice's q where a choice among all
     * three goes on with P q, and the weight it carries on with is P times that choice's (P <= 1:
     * it only falls) */
    if (vertex < policy->roulette_from) return true;
    if (!(out->survival > 0.f)) {
        float mean = sf->glossy && out->lobe != PM_LOBE_SPECULAR ? v3_average(out->weight) : out->choice_total;
        if (!survives(mean / out->specular_share, rng, &out->survival)) return false;
    }
    out->weight = v3_scale(out->weight, 1.f / out->survival);
    return true;
}

bool pm_vertex_step(const pm_surface *sf, vec3 d, int vertex, const pm_vertex_policy *policy, pm_rng *rng, float scale,
                    pm_vertex_ray *out) {
    return pm_vertex_choose(sf, d, vertex, policy, rng, out) && pm_vertex_sample_chosen(sf, d, vertex, policy, rng, scale, out);
}

/* vertex.c: the path-vertex kernel (vertex.h): lobe choice, continuation sampling and the one survival rule. */
#include "vertex.h"

#include "brdf.h"
#include "defaults.h"

pm_lobe pm_vertex_choose(const pm_surface *sf, bool diffuse_in_place, pm_rng *rng, float *inverse_probability) {
    float D = diffuse_in_place ? 0.f : pm_vertex_diffuse_weight(sf), S = pm_specular_weight(sf);
    *inverse_probability = 1.f;
    if (!(D > 0.f) && !(S > 0.f)) return PM_LOBE_NONE;
    /* one part: no number drawn, so a path through pure mirrors or pure Lambert uses none here */
    if (!(S > 0.f)) return PM_LOBE_DIFFUSE;
    if (!(D > 0.f)) return PM_LOBE_SPECULAR;
    if (pm_rng_float(rng) * (D + S) < D) {
        *inverse_probability = (D + S) / D;
        return PM_LOBE_DIFFUSE;
    }
    *inverse_probability = (D + S) / S;
    return PM_LOBE_SPECULAR;
}

bool pm_vertex_sample_diffuse(const pm_surface *sf, vec3 wo, pm_rng *rng, float scale, pm_vertex_ray *out) {
    vec3 ng = pm_facing(sf->ng, wo), ns = pm_facing(sf->ns, ng);
    out->radiance_scale = 1.f;
    out->transmitted = out->straight = false;
    if (sf->glossy) {
        vec3 f;
        if (!pm_brdf_sample(&sf->brdf, ns, wo, pm_rng_float(rng), pm_rng_float(rng), pm_rng_float(rng), &out->direction, &f,
                            &out->pdf))
            return false;
        out->weight = v3_scale(f, v3_dot(ns, out->direction) / out->pdf);
    } else {
        out->direction = pm_sample_cosine(ns, pm_rng_float(rng), pm_rng_float(rng));
        out->pdf = pm_maxf(0.f, v3_dot(ns, out->direction)) * PM_INV_PI;
        out->weight = sf->kd; /* kd/pi x cos / (cos/pi) */
    }
    out->origin = pm_surface_origin(sf, ng, scale);
    return v3_dot(out->direction, ng) > 0.f;
}

bool pm_vertex_sample(const pm_surface *sf, pm_lobe lobe, vec3 d, pm_rng *rng, float scale, pm_vertex_ray *out) {
    if (lobe == PM_LOBE_DIFFUSE) return pm_vertex_sample_diffuse(sf, v3_neg(d), rng, scale, out);
    if (lobe != PM_LOBE_SPECULAR) return false;
    pm_specular_sample sp;
    if (!pm_scatter_specular(sf, d, rng, scale, &sp)) return false;
    out->direction = sp.direction;
    out->origin = sp.origin;
    out->weight = sp.weight;
    out->pdf = 0.f;
    out->radiance_scale = sp.radiance_scale;
    out->transmitted = sp.transmitted;
    out->straight = sp.straight;
    return true;
}

/* The rule on the bounce's mean weight: false ends the path, else *scale = 1 / the survival probability. */
static bool survives(int vertex, const pm_vertex_policy *policy, pm_rng *rng, float mean_weight, float *scale) {
    *scale = 1.f;
    if (vertex < policy->roulette_from) return true;
    float q = pm_minf(PM_MAX_SURVIVAL, mean_weight);
    if (!(q > 0.f) || pm_rng_float(rng) >= q) return false;
    *scale = 1.f / q;
    return true;
}

bool pm_vertex_survives(int vertex, const pm_vertex_policy *policy, pm_rng *rng, vec3 *weight) {
    float scale;
    if (!survives(vertex, policy, rng, v3_average(*weight), &scale)) return false;
    *weight = v3_scale(*weight, scale);
    return true;
}

bool pm_vertex_step(const pm_surface *sf, vec3 d, int vertex, const pm_vertex_policy *policy, pm_rng *rng, float scale,
                    pm_vertex_ray *out) {
    float inverse_probability, survival;
    pm_lobe lobe = pm_vertex_choose(sf, policy->diffuse_in_place, rng, &inverse_probability);
    out->lobe = lobe;
    if (lobe == PM_LOBE_NONE || (lobe == PM_LOBE_DIFFUSE && policy->diffuse_ends)) return false;
    if (lobe == PM_LOBE_DIFFUSE && sf->glossy) {
        /* the lobe's weight depends on the direction drawn: survival on the sample's */
        if (!pm_vertex_sample(sf, lobe, d, rng, scale, out)) return false;
        out->weight = v3_scale(out->weight, inverse_probability);
        return pm_vertex_survives(vertex, policy, rng, &out->weight);
    }
    /* kd's mean is D, the specular sample's S (its colour over the mirror-or-glass pick): the
     * weight's mean is the chosen part's weight over its probability */
    float part = lobe == PM_LOBE_DIFFUSE ? pm_vertex_diffuse_weight(sf) : pm_specular_weight(sf);
    if (!survives(vertex, policy, rng, part * inverse_probability, &survival)) return false;
    if (!pm_vertex_sample(sf, lobe, d, rng, scale, out)) return false;
    out->weight = v3_scale(out->weight, inverse_probability * survival);
    return true;
}

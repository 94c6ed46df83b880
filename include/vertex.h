/* vertex.h: the one step every path takes at a surface (eye chains, gather walks, the path tracer, photons): lobe choice, continuation sampling, survival.
 *
 * A surface has a diffuse part (Lambert's kd, or the glossy GGX lobe with its weight) of mean
 * weight D and a specular part (mirror ks and glass kt, pm_scatter_specular) of mean weight S;
 * glTF's split keeps D + S <= 1 (Jensen's condition for Russian roulette on them). A path at a
 * vertex:
 *   1. chooses the part it goes on with in proportion to D and S (pm_vertex_choose), every
 *      contribution the caller makes for that part (a photon record, a visible point, direct
 *      light) divided by the choice's probability; a caller that reads the diffuse part where
 *      it is (the classic eye chain, a classic gather walk) goes on with the specular part only;
 *   2. samples the chosen part (pm_vertex_sample): the cosine or the lobe's own sampler for the
 *      diffuse part, the shared specular function for the other, so photons and eye paths
 *      scatter identically (photon estimates are unbiased only then);
 *   3. survives (pm_vertex_survives) from vertex policy->roulette_from on with probability
 *      q = min(PM_MAX_SURVIVAL, mean of the weight the bounce multiplies the path by), the
 *      weight divided by q. For Lambert, mirrors and glass that weight's mean is D + S: Jensen's
 *      albedo roulette, under which a photon keeps its power; for the GGX lobe it is the sampled
 *      f cos / pdf. The cap keeps q above albedo^2 (finite variance, defaults.h) and ends paths
 *      in a closed room of albedo 1 after 1 / (1 - PM_MAX_SURVIVAL) bounces on average.
 * What differs between the tracers is their business: a path tracer goes on through diffuse
 * vertices and adds direct light there, a visible-point walk stops at its first diffuse vertex,
 * photons store records; they share this kernel and its one survival rule.
 */
#ifndef PM_VERTEX_H
#define PM_VERTEX_H

#include <stdbool.h>
#include "pm_math.h"
#include "rng.h"
#include "scatter.h"
#include "scene.h"

typedef enum { PM_LOBE_NONE, PM_LOBE_DIFFUSE, PM_LOBE_SPECULAR } pm_lobe;

typedef struct {
    int roulette_from;     /* survival applies at the surface of this index (0: the first a path meets) and later */
    bool diffuse_in_place; /* the diffuse part is read at the vertex (classic eye chain): only the specular part goes on */
    bool diffuse_ends;     /* choosing the diffuse part ends the path (a caustic photon): pm_vertex_step samples nothing */
} pm_vertex_policy;

/* The continuation a vertex samples. */
typedef struct {
    vec3 direction;       /* unit, leaving the surface */
    vec3 origin;          /* offset off the surface on the side the ray leaves */
    vec3 weight;          /* f cos / pdf of the sampled part (kd for Lambert's cosine samples, the specular colour) */
    float pdf;            /* the diffuse part's sampling density per solid angle (MIS); 0 for the specular part */
    float radiance_scale; /* (eta_i / eta_t)^2 across a refraction, else 1: radiance carries it, flux not */
    bool transmitted;
    bool straight;        /* crossed a thin wall along the incoming direction: no scattering as far as
                             paths' kinds go (direct light and shadow rays cross it too, thin.h) */
    pm_lobe lobe;         /* the part chosen (pm_vertex_step) */
} pm_vertex_ray;

/* D: the diffuse part's mean weight (the glossy lobe's share of the surface, else mean kd). */
static inline float pm_vertex_diffuse_weight(const pm_surface *sf) { return sf->glossy ? sf->brdf.weight : v3_average(sf->kd); }

/* Chooses the part a path goes on with, in proportion to D and S (S alone with diffuse_in_place),
 * by one number of rng; *inverse_probability = 1 / P(choice). PM_LOBE_NONE: the surface has no part to go on with. */
pm_lobe pm_vertex_choose(const pm_surface *sf, bool diffuse_in_place, pm_rng *rng, float *inverse_probability);

/* Samples the diffuse part (cosine for Lambert, the lobe's sampler for glossy) for a path arriving
 * from wo; false when the sample is lost (below the surface). ng and ns are taken on wo's side. */
bool pm_vertex_sample_diffuse(const pm_surface *sf, vec3 wo, pm_rng *rng, float scale, pm_vertex_ray *out);

/* Samples the chosen part for a path arriving along unit d; false when the path ends there. */
bool pm_vertex_sample(const pm_surface *sf, pm_lobe lobe, vec3 d, pm_rng *rng, float scale, pm_vertex_ray *out);

/* The one survival rule (see above) at the vertex of that index, on the weight the bounce
 * multiplies the path by (the lobe's weight over its choice probability): false ends the path,
 * else *weight is divided by the survival probability. */
bool pm_vertex_survives(int vertex, const pm_vertex_policy *policy, pm_rng *rng, vec3 *weight);

/* Steps 1 to 3 at once for a caller that adds nothing between them: false when the path ends
 * (out->lobe says which part was chosen, PM_LOBE_NONE for none); out->weight is then all the
 * path's weight is multiplied by (radiance_scale apart). Where the bounce's mean weight is known
 * before sampling (Lambert, mirror, glass: D + S) the survival comes first, so an ended path
 * samples nothing; the rule is the same. */
bool pm_vertex_step(const pm_surface *sf, vec3 d, int vertex, const pm_vertex_policy *policy, pm_rng *rng, float scale,
                    pm_vertex_ray *out);

#endif

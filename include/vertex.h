/* vertex.h: the one step every path takes at a surface (eye chains, gather walks, the path tracer, photons): the part chosen, its sample, value and pdf, and survival.
 *
 * A surface has three parts (Jensen's roulette split, extended to rough lobes):
 *   non-specular (N):  Lambert's kd, or the parts of the glossy lobe (brdf.h) wider than
 *                      PM_NEAR_SPECULAR_ALPHA: its diffuse base, its sheen, a rough GGX reflection.
 *                      Photons are stored here, visible points made, the lobe evaluated against
 *                      photons and lights;
 *   near-specular (G): the glossy lobe's GGX reflections sharper than PM_NEAR_SPECULAR_ALPHA (a
 *                      polished dielectric's or metal's base, a smooth coat): paths go on through
 *                      them by sampling, as through mirrors and glass;
 *   specular (S):      the perfect mirror ks and glass kt (pm_scatter_specular).
 * The rule that sorts a rough lobe into N or G is one, here (pm_vertex_near_specular_parts). A
 * path at a vertex, in one order of random numbers (pm_vertex_step):
 *   1. chooses the part it goes on with in proportion to the parts' estimated albedos at wo
 *      (one number, drawn only when two parts can be chosen); everything the tracer adds for that
 *      part (a photon record, a visible point, direct light) is multiplied by out->choice, the
 *      inverse of the choice's probability; a tracer that reads N where it is (the classic eye
 *      chain) chooses between G and S only, and so does one that N would end (a caustic photon),
 *      which then survives in step 3 as often as the choice among all three went on;
 *   2. samples the chosen part (the cosine or the N lobe's sampler, the G lobe's sampler, the
 *      shared specular function), so photons and eye paths scatter identically;
 *   3. survives from policy->roulette_from on with probability q = min(PM_MAX_SURVIVAL, mean of
 *      the weight the bounce multiplies the path by), the weight divided by q. For Lambert, mirrors
 *      and glass that mean is the sum of the choice weights: Jensen's albedo roulette, under which
 *      a photon keeps its power; for a GGX part it is the sample's f cos / pdf over its choice. The
 *      cap keeps q above albedo^2 (finite variance, defaults.h). A tracer that reads nothing of a
 *      path the roulette ends (policy->ended_unsampled: photons) draws it before step 2 wherever q
 *      does not hang on the sample (every part but a GGX one), so an absorbed photon costs no sample
 *      and no shading normal: the choice, then absorption, as in Jensen's photon roulette.
 * What differs between tracers is a policy (where roulette starts, whether N is read in place or
 * ends the path); what they add at a vertex is theirs: the path tracer direct light at N and the
 * punctual lights' at G, a visible-point walk its point, photons their records.
 */
#ifndef PM_VERTEX_H
#define PM_VERTEX_H

#include <stdbool.h>
#include "brdf.h"
#include "defaults.h"
#include "pm_math.h"
#include "rng.h"
#include "scatter.h"
#include "scene.h"

typedef enum { PM_LOBE_NONE, PM_LOBE_NONSPECULAR, PM_LOBE_NEAR_SPECULAR, PM_LOBE_SPECULAR } pm_lobe;

typedef struct {
    int roulette_from;         /* survival applies at the surface of this index (0: the first a path meets) and later */
    bool nonspecular_in_place; /* N is read at the vertex (classic eye chain): only G and S are chosen */
    bool nonspecular_ends;     /* choosing N ends the path there, unsampled (a walk to a point) */
    bool nonspecular_weighed;  /* N is never chosen: G or S is, in proportion to their weights (weight: value over
                                  that probability), and the survival q is the choice among all three's, so a path
                                  goes on with probability q where it did with P q, P = (g + s) / (n + g + s), its weight
                                  P times that choice's instead (a caustic photon, which N would end: L S+ D) */
    bool ended_unsampled;      /* nothing is read of a path the roulette ends (photons): step 3 comes before step 2
                                  where q does not hang on the sample */
    pm_lobe only;              /* PM_LOBE_NONE: the part is chosen; else the path goes on by this part alone, with
                                  choice 1 and no number drawn (a classic final-gather ray leaving its point by N) */
} pm_vertex_policy;

/* What a vertex step chose and sampled. */
typedef struct {
    vec3 direction;       /* unit, leaving the surface */
    vec3 origin;          /* offset off the surface on the side the ray leaves */
    vec3 value;           /* f cos / pdf of the sample within its part (kd for Lambert's cosine samples, the specular colour) */
    vec3 weight;          /* what the path's weight is multiplied by going on: value x choice / survival */
    float choice;         /* 1 / P(the part chosen) */
    float pdf;            /* the sample's density per solid angle within its part (MIS); 0 for mirrors and glass */
    float radiance_scale; /* (eta_i / eta_t)^2 across a refraction, else 1: radiance carries it, flux not */
    bool transmitted;
    bool straight;        /* crossed a thin wall along the incoming direction: no scattering as far as
                             paths' kinds go (direct light and shadow rays cross it too, thin.h) */
    bool sampled;         /* direction, origin, value and pdf hold a sample (also when the roulette then ended the path) */
    pm_lobe lobe;         /* the part chosen; PM_LOBE_NONE: the surface has none to go on with */
    float choice_total, specular_share, survival; /* between pm_vertex_choose and pm_vertex_sample_chosen: the
                                                     choice weights' sum, P (nonspecular_weighed) and q once drawn */
} pm_vertex_ray;

/* The one rule: which parts of a glossy lobe count as near-specular (GGX reflections of alpha
 * below PM_NEAR_SPECULAR_ALPHA, defaults.h). */
static inline unsigned pm_vertex_near_specular_parts(const pm_brdf *b) {
    return pm_brdf_parts_sharper_than(b, PM_NEAR_SPECULAR_ALPHA);
}

/* The lobe of part N or G of a glossy surface: its brdf with the other part's components skipped. */
static inline pm_brdf pm_vertex_part_lobe(const pm_surface *sf, pm_lobe part) {
    pm_brdf b = sf->brdf;
    unsigned near = pm_vertex_near_specular_parts(&b);
    b.skip |= part == PM_LOBE_NEAR_SPECULAR ? (unsigned)(PM_BRDF_SPECULAR | PM_BRDF_COAT | PM_BRDF_DIFFUSE | PM_BRDF_SHEEN) & ~near
                                            : near;
    return b;
}

/* Whether photons are stored at sf and visible points made there: it has a non-specular part
 * (needs no shading normal: a photon's lean hit record decides with it). */
static inline bool pm_vertex_has_nonspecular(const pm_surface *sf) {
    if (!sf->glossy) return !v3_is_black(sf->kd);
    return sf->brdf.weight > 0.f && (pm_brdf_parts(&sf->brdf) & ~pm_vertex_near_specular_parts(&sf->brdf)) != 0;
}

/* Whether a path can go on from sf by a near-specular or specular part (a caustic photon's only way on). */
static inline bool pm_vertex_has_specular(const pm_surface *sf) {
    if (pm_specular_weight(sf) > 0.f) return true;
    return sf->glossy && sf->brdf.weight > 0.f && (pm_brdf_parts(&sf->brdf) & pm_vertex_near_specular_parts(&sf->brdf)) != 0;
}

/* The shading normal a vertex evaluates and samples with for light leaving toward wo. */
static inline vec3 pm_vertex_normal(const pm_surface *sf, vec3 wo) { return pm_facing(sf->ns, pm_facing(sf->ng, wo)); }

/* f (no cosine) of part N or G for light arriving from wi and leaving toward wo, ns from
 * pm_vertex_normal: Lambert's kd / pi, or the part's lobe; 0 for a part the surface lacks. */
vec3 pm_vertex_f(const pm_surface *sf, pm_lobe part, vec3 ns, vec3 wo, vec3 wi);
/* The density per solid angle with which part N or G samples wi (pm_vertex_sample_part). */
float pm_vertex_pdf(const pm_surface *sf, pm_lobe part, vec3 ns, vec3 wo, vec3 wi);

/* Samples part N or G for a path leaving toward wo (as step 2 does); false when the sample is lost
 * (below the surface). out->choice and out->weight are left to the caller. */
bool pm_vertex_sample_part(const pm_surface *sf, pm_lobe part, vec3 wo, pm_rng *rng, float scale, pm_vertex_ray *out);

/* Steps 1 to 3 for a path arriving along unit d at the surface of index `vertex`: true when the
 * path goes on along out->direction from out->origin, its weight multiplied by out->weight
 * (radiance also by out->radiance_scale). out->lobe and out->choice say what was chosen whatever
 * the answer, out->sampled whether a sample was drawn (N chosen under nonspecular_ends draws none, nor
 * does a path the roulette ends before step 2 under ended_unsampled). */
bool pm_vertex_step(const pm_surface *sf, vec3 d, int vertex, const pm_vertex_policy *policy, pm_rng *rng, float scale,
                    pm_vertex_ray *out);
/* pm_vertex_step in its two halves, for a tracer that completes its surface record between them
 * (a photon's shading normal, which an absorbed photon never needs): step 1 (and 3 where it comes
 * first), which reads sf->ns on a glossy surface only; then step 2 and the rest of 3. */
bool pm_vertex_choose(const pm_surface *sf, vec3 d, int vertex, const pm_vertex_policy *policy, pm_rng *rng, pm_vertex_ray *out);
bool pm_vertex_sample_chosen(const pm_surface *sf, vec3 d, int vertex, const pm_vertex_policy *policy, pm_rng *rng, float scale,
                             pm_vertex_ray *out);

#endif

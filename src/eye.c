/* eye.c: the eye pass: camera rays, emission and shadow-ray direct light, specular chains, visible points, the path tracer, per-component accumulation.
 *
 * Every path from the eye (a classic chain, a walk to a visible or gather point, a path-traced
 * sample, a classic gather ray) steps through the path-vertex kernel at each surface (vertex.h):
 * it picks the part to go on with, samples it (mirrors and glass through the specular function
 * photons share, the cosine or the glossy lobe otherwise) and meets the one survival rule; what
 * the tracers add at a vertex (emission, direct light, photon estimates, a visible point) is
 * theirs. The first vertex decides the component; see eye.h.
 */
#include "eye.h"
#include "clock.h"
#include "memory.h"

#include <assert.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "defaults.h"
#include "parallel.h"
#include "light.h"
#include "rng.h"
#include "scatter.h"
#include "thin.h"
#include "vertex.h"

#define TILE 16
/* what a tile's paths count (surfaces met, light vertices drawn to join, their shadow rays), and
 * its thread's table for the worth connections find (a table a thread: one shared, the two cores'
 * adds to the same few cells cost 1% of a run) */
typedef struct {
    uint64_t vertices, connections, connection_rays;
    pm_cell_values *worth;
} path_tally;
#define MAX_THREADS PM_MAX_THREADS

typedef struct {
    const pm_scene *scene;
    const pm_accel *accel;
    const pm_camera *camera;
    pm_camera_view view;                 /* the camera at the film's size: one tangent per pass, not per pixel */
    float cone_width, cone_spread;       /* a camera ray's cone is cone_width + cone_spread x distance wide (the
                                            texture footprint: PM_FOOTPRINT_PIXELS of a pixel) */
    const pm_eye_settings *settings;
    uint32_t iteration;
    pm_film *film;
    bool visible_points, gather_points;  /* progressive mode: find each pixel's points, hand them to visit */
    pm_visible_points_fn visit;
    void *visit_ctx;
    int tiles_x;
    double deadline;                     /* tiles not started by then are left out (0 = none) */
    bool save;                           /* the iteration's first pass: each tile saves its pixels before writing them */
    struct { uint64_t rays, dropped, vertices, connections, connection_rays, shadow[3]; } counters[MAX_THREADS];
    uint8_t done[];                      /* per tile: traced (a cut pass marks these in the film) */
} eye_job;

/* The eye paths' policies at the path-vertex kernel (vertex.h): a classic chain reads the
 * non-specular part where it is and goes on with the others; a walk to a visible or gather point
 * stops at a non-specular choice; the path tracer, and a walk whose visible point sends a
 * final-gather ray, go on from it with the sample the step drew; a classic final-gather ray
 * leaves its point by the non-specular part. */
static const pm_vertex_policy chain_policy = {.roulette_from = PM_EYE_ROULETTE_VERTEX, .nonspecular_in_place = true};
static const pm_vertex_policy walk_policy = {.roulette_from = PM_EYE_ROULETTE_VERTEX, .nonspecular_ends = true};
static const pm_vertex_policy continuing_policy = {.roulette_from = PM_EYE_ROULETTE_VERTEX};
static const pm_vertex_policy gather_ray_policy = {.roulette_from = PM_EYE_ROULETTE_VERTEX, .only = PM_LOBE_NONSPECULAR};

/* A segment already traced: the camera ray with its tile, or the non-specular sample that direct
 * light traced for its own use and that the path goes on along, so one ray serves both the light
 * it meets (weighted by MIS) and the continuation. */
typedef struct {
    bool traced;
    bool hit;       /* false: the ray left the scene */
    pm_hit h;
} surface_bounce;


/* Where a path's next segment ends: the surface it meets (from *pending when that segment was
 * already traced), with the medium's transmittance along it applied to *throughput. When `lit`,
 * the light the segment meets counts toward *light: the sky on a miss, or the surface's emission
 * toward the path (an unlit surface's only along a pixel's cone, where it is seen as painted).
 * `cone`: the pixel's cone picks the texture levels (a gather or scattered ray has no cone worth
 * the name and reads level 0). False when the segment leaves the scene. */
static bool meet_surface(const eye_job *job, surface_bounce *pending, vec3 o, vec3 d, bool lit, bool cone,
                         float *path_length, vec3 *throughput, vec3 *light, uint64_t *rays, pm_hit *h, pm_surface *sf) {
    const pm_scene *s = job->scene;
    bool hit;
    if (pending->traced) {
        hit = pending->hit;
        *h = pending->h;
        pending->traced = false;
    } else {
        (*rays)++;
        hit = pm_accel_intersect(job->accel, o, d, INFINITY, h);
    }
    if (!hit) {
        if (lit && s->sky) *light = v3_add(*light, v3_mul(*throughput, pm_scene_sky(s, d)));
        return false;
    }
    *path_length += h->t;
    pm_scene_surface_footprint(s, h->tri, h->b1, h->b2, cone ? job->cone_width + job->cone_spread * *path_length : 0.f, d, sf);
    *throughput = v3_mul(*throughput, pm_volume_transmittance(s, sf, d, h->t));
    bool front = v3_dot(sf->ng, v3_neg(d)) > 0.f;
    if (lit && (front || sf->double_sided) && !v3_is_black(sf->emission) && (!sf->unlit || cone))
        *light = v3_add(*light, v3_mul(*throughput, sf->emission));
    return true;
}

void pm_eye_enclosure(const pm_scene *s, const pm_accel *a, const pm_camera *cam, float aspect, float *view_fraction,
                      float *around_fraction) {
    enum { GRID = 32, AROUND = 1024, BOUNCES = 4 };
    int width = aspect >= 1.f ? GRID : (int)fmaxf(1.f, GRID * aspect), height = aspect >= 1.f ? (int)fmaxf(1.f, GRID / aspect) : GRID;
    int rays = 0, closed = 0;
    pm_hit h;
    pm_rng rng = pm_rng_for(0x5e1f, 0, 0);
    for (int y = 0; y < height; y++)
        for (int x = 0; x < width; x++) {
            vec3 o, d;
            pm_camera_ray(cam, width, height, x + 0.5f, y + 0.5f, &o, &d);
            rays += BOUNCES;
            if (!pm_accel_intersect(a, o, d, INFINITY, &h)) continue;
            /* what the seen surface sees: light from outside reaches it only along rays that escape */
            pm_surface sf;
            pm_scene_surface(s, h.tri, h.b1, h.b2, &sf);
            vec3 n = pm_facing(sf.ng, v3_neg(d));
            vec3 from = pm_surface_origin(&sf, n, s->ray_scale);
            for (int k = 0; k < BOUNCES; k++)
                closed += pm_accel_intersect(a, from, pm_sample_cosine(n, pm_rng_float(&rng), pm_rng_float(&rng)), INFINITY, &h);
        }
    *view_fraction = rays ? (float)closed / (float)rays : 0.f;
    int hits = 0;
    for (int i = 0; i < AROUND; i++) {
        /* a spherical Fibonacci set: even coverage without randomness */
        float z = 1.f - (2.f * i + 1.f) / AROUND, r = sqrtf(fmaxf(0.f, 1.f - z * z)), phi = 2.39996323f * i;
        hits += pm_accel_intersect(a, cam->position, v3(r * cosf(phi), r * sinf(phi), z), INFINITY, &h);
    }
    *around_fraction = (float)hits / AROUND;
}



/* Veach's power heuristic (beta 2): the weight of a sample drawn with pdf a against another strategy's pdf b. */
static inline float power_heuristic(float a, float b) {
    float a2 = a * a, b2 = b * b;
    return a2 + b2 > 0.f ? a2 / (a2 + b2) : 0.f;
}

/* f cos of the part for a light sample arriving along wi (cos_s = ns.wi), from the kernel. */
static inline vec3 reflected(const pm_surface *sf, pm_lobe part, vec3 ns, vec3 wo, vec3 wi, float cos_s) {
    return v3_scale(pm_vertex_f(sf, part, ns, wo, wi), cos_s);
}

/* What direct_light's strategies share: the point lit, seen from wo, its shading frame facing wo,
 * the origin of its rays, and the counts its rays add to. */
typedef struct {
    const pm_scene *s;
    const pm_accel *a;
    const pm_surface *sf;
    pm_lobe part;
    vec3 wo, ng, ns, origin;
    uint64_t *rays;              /* every ray traced */
    uint64_t cast;               /* shadow rays to light samples */
    /* the point reached by a path's sample from a vertex that joined a light vertex (connect):
     * that sample's density per unit area here, against which the punctual lights are weighted;
     * 0: reached otherwise, nothing to weigh */
    const pm_connections *connections;
    float arrival_pdf;
    float arrival_keep;          /* with arrival_pdf: the probability a light vertex here is kept (pm_light_vertex_keep), < 0 until looked up */
    pm_arrival_guide *sky_arrival; /* where a diffuse own ray reaching the sky counts (arrival.h); NULL: nowhere */
    pm_arrival_cell sky_cell;    /* ... and its distribution here, a sky sample of its own (cdf NULL: none) */
    uint64_t sky_samples;        /* the rays of those samples, among cast */
} light_site;

static light_site light_site_at(const pm_scene *s, const pm_accel *a, const pm_surface *sf, pm_lobe part, vec3 wo, uint64_t *rays) {
    vec3 ng = pm_facing(sf->ng, wo);
    light_site ls = {s, a, sf, part, wo, ng, pm_facing(sf->ns, ng), pm_surface_origin(sf, ng, s->ray_scale), rays, 0, NULL, 0.f, -1.f, NULL, {NULL}, 0};
    return ls;
}

/* ---- connections (eye.h) ---- */

/* The connections' density per unit area at point p (face normal ng) for light i's vertices
 * (eye.h; the sky's arriving from to_light, per steradian too), where a vertex is kept with
 * probability keep. */
static float connection_density(const pm_connections *c, uint32_t i, vec3 p, vec3 ng, vec3 to_light, float keep) {
    /* a pass that joins nothing takes no share of the path's own ways */
    if (!c->count) return 0.f;
    return pm_photon_tracer_first_hit_density(c->tracer, i, p, ng, to_light) * keep * c->photons_per_vertex;
}

/* The density per unit area with which a path's sample from x (pdf per solid angle) meets the
 * point p of face normal ng. */
static inline float area_pdf(float pdf, vec3 x, vec3 p, vec3 ng) {
    vec3 d = v3_sub(p, x);
    float d2 = v3_dot(d, d);
    return d2 > 0.f ? pdf * fabsf(v3_dot(ng, d)) / (d2 * sqrtf(d2)) : 0.f;
}

/* The light a connection brings to the non-specular part of sf, seen from wo and reached with
 * weight: one light vertex y drawn uniformly from the pass's n, joined by a shadow ray. A vertex stands for the pass's
 * photons, so n x its flux x f(x) cos_x cos_y / d^2 x f(y) x (shading cosine / face cosine of its
 * arrival: the photon's density on the face, the light's own reflection by the shading normal,
 * as direct light computes it) is the light the whole pass's vertices bring, which the power
 * heuristic then shares with the path's sample from x meeting y and its punctual light there.
 * A thin wall blocks the shadow ray: the path's sample crosses it as a vertex of its own, and
 * such light stays the path's. */
static vec3 join(const eye_job *job, const pm_connections *c, const pm_light_vertex *v, const pm_surface *sf, vec3 wo,
                 vec3 weight, uint64_t *rays, float *worth);

static vec3 connect(const eye_job *job, const pm_connections *c, const pm_surface *sf, vec3 wo, vec3 weight, pm_rng *rng,
                    uint64_t *rays, path_tally *tally) {
    if (!c->count) return v3s(0.f);
    tally->connections++;
    uint64_t rays_before = *rays;
    uint32_t j = (uint32_t)(pm_rng_float(rng) * (float)c->count);
    const pm_light_vertex *v = &c->vertices[j < c->count ? j : c->count - 1];
    float worth = 0.f;
    vec3 e = join(job, c, v, sf, wo, weight, rays, &worth);
    tally->connection_rays += *rays - rays_before;
    if (tally->worth && j % PM_CONNECT_WORTH_SHARE == 0) {
        float units = worth / c->worth_unit + 0.5f;
        pm_cell_values_add(tally->worth, v->p, units < 4294967040.f ? (uint32_t)units : UINT32_MAX);
    }
    return e;
}

/* connect's light through vertex v; *worth: what it brings without the MIS weight, at the flux the
 * vertex had before its keeping and as one vertex (the worth of its cell, pm_light_vertex_keep) */
static vec3 join(const eye_job *job, const pm_connections *c, const pm_light_vertex *v, const pm_surface *sf, vec3 wo,
                 vec3 weight, uint64_t *rays, float *worth) {
    const pm_scene *s = job->scene;
    vec3 ng = pm_facing(sf->ng, wo), ns = pm_facing(sf->ns, ng), origin = pm_surface_origin(sf, ng, s->ray_scale);
    vec3 to = v3_sub(v->p, sf->p);
    float d2 = v3_dot(to, to);
    if (!(d2 > 0.f)) return v3s(0.f);
    vec3 wi = v3_scale(to, 1.f / sqrtf(d2));
    float cos_x = v3_dot(ns, wi), cos_y = -v3_dot(v->ng, wi);
    if (!(cos_x > 0.f && v3_dot(ng, wi) > 0.f && cos_y > 0.f)) return v3s(0.f);
    vec3 to_light = v->to_light;
    float cos_in = v3_dot(v->ng, to_light);
    if (!(cos_in > 0.f)) return v3s(0.f);
    vec3 target = pm_offset_ray_origin(v->p, v->ng, s->ray_scale), seg = v3_sub(target, origin);
    float reach = v3_length(seg);
    (*rays)++;
    if (!(reach > 0.f) || pm_accel_occluded(job->accel, origin, v3_scale(seg, 1.f / reach), reach)) return v3s(0.f);
    pm_surface y;
    pm_scene_surface(s, v->tri, v->b1, v->b2, &y);
    vec3 yns = pm_facing(y.ns, v->ng), wy = v3_neg(wi);
    float cos_in_shading = v3_dot(yns, to_light);
    if (!(cos_in_shading > 0.f && v3_dot(yns, wy) > 0.f)) return v3s(0.f);
    /* the path's way: its sample from here reaching y, then y's punctual light, or for the sky
     * y's own ray or its sky map's sample (two ways, weighed as one of their densities' root
     * sum of squares: the power heuristic over all three) */
    float p_path = area_pdf(pm_vertex_pdf(sf, PM_LOBE_NONSPECULAR, ns, wo, wi), sf->p, v->p, v->ng);
    if (v->light == PM_LIGHT_VERTEX_SKY)
        p_path *= hypotf(pm_vertex_pdf(&y, PM_LOBE_NONSPECULAR, yns, wy, to_light), s->sky_map ? pm_sky_map_pdf(s->sky_map, to_light) : 0.f);
    float scale = (float)c->count * cos_y / d2 * cos_in_shading / cos_in;
    vec3 fy = v3_mul(pm_vertex_f(&y, PM_LOBE_NONSPECULAR, yns, wy, to_light), pm_volume_transmittance(s, &y, wi, sqrtf(d2)));
    vec3 e = v3_mul(v3_mul(v3_mul(reflected(sf, PM_LOBE_NONSPECULAR, ns, wo, wi, cos_x), fy), v3_scale(v->flux, scale)), weight);
    if (!v3_is_finite(e) || v3_is_black(e)) return v3s(0.f);
    /* the density last: half of the connections end at a shadow ray or a cosine before it */
    float density = connection_density(c, v->light, v->p, v->ng, to_light, v->keep);
    if (!(density > 0.f)) return v3s(0.f);
    *worth = v3_luminance(e) * v->keep / (float)c->count;
    return v3_scale(e, power_heuristic(density, p_path));
}

/* The probability a light vertex at ls's point is kept, looked up once a light is seen there
 * (most of a room's vertices see none). */
static float arrival_keep(light_site *ls) {
    if (ls->arrival_keep < 0.f) ls->arrival_keep = pm_light_vertex_keep(ls->connections->worth, ls->sf->p);
    return ls->arrival_keep;
}

/* The power heuristic's weight of one way that the sky along wi is found at ls's point (its
 * density `way`, per steradian) against the others: two of the surface's own ray, the sky map's
 * sample (0 without a map) and the arrival guide's (0 without a cell here), and, where the path
 * arrived from a vertex that joined a light vertex, the connection to a sky light vertex here
 * (its density per unit area and steradian over the arrival's per unit area; join weighs it the
 * same way). Over several ways the heuristic weighs against their densities' root sum of squares. */
static float sky_weight(light_site *ls, vec3 wi, float way, float other, float another) {
    float joined = 0.f;
    if (ls->arrival_pdf > 0.f)
        joined = connection_density(ls->connections, PM_LIGHT_VERTEX_SKY, ls->sf->p, ls->sf->ng, wi, arrival_keep(ls)) / ls->arrival_pdf;
    float others = hypotf(hypotf(other, another), joined);
    return others > 0.f ? power_heuristic(way, others) : 1.f;
}

static inline float sky_map_pdf_along(const light_site *ls, vec3 wi) {
    return ls->s->sky_map ? pm_sky_map_pdf(ls->s->sky_map, wi) : 0.f;
}

/* The punctual lights' share of direct_light (below): their light reflected toward ls->wo by the
 * part; ls->cast and *saved count shadow rays cast and made unnecessary by shadow photons. */
static vec3 punctual_light(light_site *ls, pm_rng *rng, const pm_shadow_map *shadow, uint64_t *saved) {
    const pm_scene *s = ls->s;
    const pm_surface *sf = ls->sf;
    vec3 ng = ls->ng, ns = ls->ns, origin = ls->origin, e = v3s(0.f);
    bool sampled_lights = s->light_count > PM_DIRECT_LIGHT_SAMPLES;
    uint32_t light_samples = sampled_lights ? PM_DIRECT_LIGHT_SAMPLES : s->light_count;
    float stratum = sampled_lights ? pm_rng_float(rng) : 0.f;
    const uint8_t *records = shadow && light_samples ? pm_shadow_map_find(shadow, sf->p, ng, v3_dot(ng, sf->ng) > 0.f) : NULL;
    for (uint32_t j = 0; j < light_samples; j++) {
        uint32_t i = j;
        float pick_weight = 1.f;
        if (sampled_lights) {
            float pick_pdf;
            i = pm_scene_pick_light(s, ((float)j + stratum) / (float)light_samples, &pick_pdf);
            if (!(pick_pdf > 0.f)) continue;
            pick_weight = 1.f / ((float)light_samples * pick_pdf);
        }
        const pm_light *l = &s->lights[i];
        vec3 wi, radiance_scale;
        float tmax;
        if (l->type == PM_LIGHT_DIRECTIONAL) {
            wi = v3_neg(l->direction);
            tmax = INFINITY;
            radiance_scale = l->intensity;
        } else {
            vec3 to_light = v3_sub(l->position, origin);
            float d2 = v3_dot(to_light, to_light);
            if (d2 <= 0.f) continue;
            tmax = sqrtf(d2);
            wi = v3_scale(to_light, 1.f / tmax);
            float falloff = l->type == PM_LIGHT_SPOT ? pm_spot_falloff(l, v3_neg(wi)) : 1.f;
            if (falloff <= 0.f) continue;
            radiance_scale = v3_scale(l->intensity, falloff / d2);
        }
        float cos_s = v3_dot(ns, wi);
        if (cos_s <= 0.f || v3_dot(ng, wi) <= 0.f) continue;
        pm_visibility verdict = records ? pm_shadow_map_verdict(shadow, records, i) : PM_VISIBILITY_UNKNOWN;
        if (verdict == PM_VISIBILITY_HIDDEN) { (*saved)++; continue; }
        /* shadow photons call what lies behind glass uncertain: a verdict of seen crosses no thin wall */
        vec3 through = v3s(1.f);
        if (verdict == PM_VISIBILITY_SEEN) {
            (*saved)++;
        } else {
            (*ls->rays)++;
            ls->cast++;
            if (!pm_thin_visible(s, ls->a, origin, wi, tmax, &through, ls->rays)) continue;
        }
        if (ls->arrival_pdf > 0.f)
            pick_weight *= power_heuristic(ls->arrival_pdf, connection_density(ls->connections, i, sf->p, sf->ng, wi, arrival_keep(ls)));
        e = v3_add(e, v3_mul(v3_mul(v3_scale(radiance_scale, pick_weight), through), reflected(sf, ls->part, ns, ls->wo, wi, cos_s)));
    }
    return e;
}

/* The area sample: one point on a power-picked emissive triangle, weighted by MIS against the
 * surface's own sampling (own_ray_light), added to *e. */
static void emitter_area_sample(light_site *ls, pm_rng *rng, vec3 *e) {
    const pm_scene *s = ls->s;
    const pm_surface *sf = ls->sf;
    vec3 ns = ls->ns, origin = ls->origin;
    float pick_pdf;
    uint32_t which = pm_scene_pick_emitter_index(s, pm_rng_float(rng), &pick_pdf);
    float r1 = sqrtf(pm_rng_float(rng)), r2 = pm_rng_float(rng), b1 = r1 * (1.f - r2), b2 = r1 * r2;
    const pm_emitter *light = &s->emitter_records[which];
    vec3 radiance = pm_emitter_emitted_at(s, which, b1, b2); /* a point picked by area: cut-outs count */
    vec3 q = pm_emitter_point(light, b1, b2), nl = light->normal;
    float area = light->area;
    vec3 to_light = v3_sub(q, origin);
    float dist = v3_length(to_light);
    if (!(dist > 0.f && area > 0.f && pick_pdf > 0.f && !v3_is_black(radiance))) return; /* a cut-out or black texel */
    vec3 wi = v3_scale(to_light, 1.f / dist);
    float cos_l = -v3_dot(nl, wi);
    if (light->double_sided) cos_l = fabsf(cos_l);
    float cos_s = v3_dot(ns, wi);
    if (!(cos_l > 0.f && cos_s > 0.f && v3_dot(ls->ng, wi) > 0.f)) return;
    vec3 target = pm_offset_ray_origin(q, pm_facing(nl, v3_neg(wi)), s->ray_scale);
    vec3 seg = v3_sub(target, origin);
    float seg_len = v3_length(seg);
    (*ls->rays)++;
    ls->cast++;
    vec3 through;
    if (seg_len > 0.f && pm_thin_visible(s, ls->a, origin, v3_scale(seg, 1.f / seg_len), seg_len, &through, ls->rays)) {
        float g = cos_l / (dist * dist);
        float pdf_light = pick_pdf * dist * dist / (area * cos_l);
        float pdf_surface = pm_vertex_pdf(sf, ls->part, ns, ls->wo, wi);
        *e = v3_add(*e, v3_mul(v3_mul(v3_scale(radiance, g * area / pick_pdf * power_heuristic(pdf_light, pdf_surface)),
                                      through),
                               reflected(sf, ls->part, ns, ls->wo, wi, cos_s)));
    }
}

/* A ray of a sky sample along wi (radiance there, drawn with density pdf by the sky map's sampling
 * or, by_map false, the arrival guide's), weighted against the surface's own ray and the other of
 * the two; false where no ray was cast (nothing to reach). */
static bool sky_sample_along(light_site *ls, vec3 wi, vec3 radiance, float pdf, bool by_map, vec3 *e) {
    float cos_s = v3_dot(ls->ns, wi);
    if (!(pdf > 0.f && cos_s > 0.f && v3_dot(ls->ng, wi) > 0.f)) return false;
    (*ls->rays)++;
    ls->cast++;
    float pdf_surface = pm_vertex_pdf(ls->sf, ls->part, ls->ns, ls->wo, wi);
    vec3 through;
    if (pm_thin_visible(ls->s, ls->a, ls->origin, wi, INFINITY, &through, ls->rays)) {
        float other = by_map ? pm_arrival_pdf(&ls->sky_cell, wi) : sky_map_pdf_along(ls, wi);
        *e = v3_add(*e, v3_mul(v3_mul(v3_scale(radiance, sky_weight(ls, wi, pdf, pdf_surface, other) / pdf), through),
                               reflected(ls->sf, ls->part, ls->ns, ls->wo, wi, cos_s)));
    }
    return true;
}

/* A sky with a map (a sun, a bright window) gets a ray drawn from the map too, weighted against
 * the surface's own ray (own_ray_light); a uniform sky is sampled best by that ray alone. */
static void sky_map_sample(light_site *ls, pm_rng *rng, vec3 *e) {
    const pm_scene *s = ls->s;
    vec3 wi;
    float pdf_sky;
    vec3 radiance = v3_mul(s->sky_radiance, pm_sky_map_sample(s->sky_map, pm_rng_float(rng), pm_rng_float(rng), &wi, &pdf_sky));
    sky_sample_along(ls, wi, radiance, pdf_sky, true, e);
}

/* Where the sky is seen from here (arrival.h): a ray drawn from the directions the cell learned,
 * weighted against the surface's own ray and the sky map's sample. */
static void sky_arrival_sample(light_site *ls, pm_rng *rng, vec3 *e) {
    float pdf_arrival, u_bin = pm_rng_float(rng), u1 = pm_rng_float(rng), u2 = pm_rng_float(rng);
    vec3 wi = pm_arrival_sample(&ls->sky_cell, u_bin, u1, u2, &pdf_arrival);
    if (sky_sample_along(ls, wi, pm_scene_sky(ls->s, wi), pdf_arrival, false, e)) ls->sky_samples++;
}

/* The weight of the sky the surface's own ray finds along wi (sky_weight). */
static inline float own_ray_sky_weight(light_site *ls, vec3 wi, float pdf_surface) {
    return sky_weight(ls, wi, pdf_surface, sky_map_pdf_along(ls, wi), pm_arrival_pdf(&ls->sky_cell, wi));
}

/* The light the own ray (direction wi, value weight, pdf pdf_surface) finds at its hit h and past
 * every thin wall it meets (emitting or not), which the continuation crosses as no scattering:
 * counted here, once. The sky by sky_weight, the emitters by MIS against the area sample. */
static void light_along_own_ray(light_site *ls, vec3 wi, vec3 weight, float pdf_surface, pm_hit h, bool hit, vec3 *e) {
    const pm_scene *s = ls->s;
    for (int crossings = 0;; crossings++) {
        if (!hit) {
            if (s->sky) {
                *e = v3_add(*e, v3_mul(pm_scene_sky(s, wi), v3_scale(weight, own_ray_sky_weight(ls, wi, pdf_surface))));
                if (ls->sky_arrival) pm_arrival_count(ls->sky_arrival, ls->sf->p, ls->ng, wi);
            }
        } else if (s->emitter_count) {
            const pm_material *m = &s->materials[pm_scene_triangle_material(s, h.tri)];
            float pick_pdf = v3_is_black(m->emission) ? 0.f : pm_scene_emitter_pdf(s, h.tri);
            if (pick_pdf > 0.f) {
                pm_triangle_geometry g = pm_triangle_geometry_of(s, h.tri);
                float cos_l = g.area > 0.f ? -v3_dot(g.normal, wi) : 0.f;
                if (m->double_sided) cos_l = fabsf(cos_l);
                if (cos_l > 0.f) {
                    float pdf_light = pick_pdf * h.t * h.t / (g.area * cos_l);
                    *e = v3_add(*e, v3_mul(v3_scale(pm_scene_emission_at(s, h.tri, h.b1, h.b2),
                                                    power_heuristic(pdf_surface, pdf_light)), weight));
                }
            }
        }
        if (!hit || !s->analysis.has_thin_glass || crossings == PM_THIN_MAX_CROSSINGS ||
            !pm_thin_step(s, ls->a, ls->origin, wi, INFINITY, &h, &hit, &weight, ls->rays))
            break;
    }
}

/* One ray from the surface's own sampling serves the sky and, weighted against the area sample,
 * the emitters: near an emitter (a lamp's own wall, a glowing corner) area sampling alone has
 * unbounded variance, and this sample bounds it (and on a glossy surface it finds the highlight
 * of a large lamp that area sampling rarely would). The same ray is the path's next segment when
 * the caller goes on along it (next). */
static void own_ray_light(light_site *ls, pm_rng *rng, const pm_vertex_ray *bounce, surface_bounce *next, vec3 *e) {
    const pm_scene *s = ls->s;
    pm_vertex_ray own;
    if (!bounce) { /* no step drew one (a classic point, a walk that stops here): the kernel's sampler */
        pm_vertex_sample_part(ls->sf, ls->part, ls->wo, rng, s->ray_scale, &own);
        bounce = &own;
    }
    bool leaves = bounce->sampled;
    vec3 wi = bounce->direction, weight = bounce->value;
    float pdf_surface = bounce->pdf, cos_s = leaves ? v3_dot(ls->ns, wi) : 0.f;
    bool lit = leaves && cos_s > 0.f && (s->sky || s->emitter_count);
    if (leaves && (next || s->emitter_count)) {
        (*ls->rays)++;
        pm_hit h;
        bool hit = pm_accel_intersect(ls->a, ls->origin, wi, INFINITY, &h);
        if (next) {
            next->traced = true;
            next->hit = hit;
            next->h = h;
        }
        if (lit) light_along_own_ray(ls, wi, weight, pdf_surface, h, hit, e);
    } else if (lit) {
        /* a sky without emitters: only whether the ray gets out matters */
        (*ls->rays)++;
        vec3 through;
        if (pm_thin_visible(s, ls->a, ls->origin, wi, INFINITY, &through, ls->rays)) {
            *e = v3_add(*e, v3_mul(v3_mul(pm_scene_sky(s, wi), through), v3_scale(weight, own_ray_sky_weight(ls, wi, pdf_surface))));
            if (ls->sky_arrival) pm_arrival_count(ls->sky_arrival, ls->sf->p, ls->ng, wi);
        }
    }
}

/* Direct light reflected toward wo by a part of sf: the non-specular part, or the near-specular part
 * where an eye path goes on through it (its light-finding ray is then the path's own next segment,
 * and what that segment meets is counted here, weighted by MIS, not where the path meets it). One shadow ray per punctual
 * light (with more than PM_DIRECT_LIGHT_SAMPLES lights, that many drawn by power, stratified,
 * each weighted by 1 / (samples x its pick probability)), one to a power-picked emissive
 * triangle, one ray from the surface's own sampling (cosine on Lambert, the lobe's sampler on
 * glossy; the vertex step's own sample when the caller has one, `bounce`) for the sky and the
 * emitters, combined with the area sample by multiple importance
 * sampling (punctual lights are deltas: no other strategy can find them, so they take no MIS
 * weight). With shadow photons (shadow != NULL) a punctual light that the records near the point
 * surely show or surely hide costs no ray; shadow_counts (may be NULL) adds the shadow rays cast
 * to light samples [0], those the records made unnecessary [1] and the arrival guide's samples
 * [2]. A NULL shadow map is exactly the ray-only estimate, random numbers included. With `next`,
 * the bounce's ray is traced whatever the scene's lights, its hit kept there for the path that
 * goes on along it. Given the sky's arrival guide (sky_arrival), a diffuse own ray that reaches
 * the sky counts there, and with sky_sample (the path's first non-specular vertex) a used cell
 * here adds a ray drawn from it, weighed with the own ray and the map's sample (sky_weight). */
static vec3 direct_light(const pm_scene *s, const pm_accel *a, const pm_surface *sf, pm_lobe part, vec3 wo, pm_rng *rng,
                         uint64_t *rays, const pm_shadow_map *shadow, uint64_t shadow_counts[3], const pm_vertex_ray *bounce,
                         surface_bounce *next, const pm_connections *connections, float arrival_pdf,
                         pm_arrival_guide *sky_arrival, bool sky_sample) {
    light_site ls = light_site_at(s, a, sf, part, wo, rays);
    ls.connections = connections;
    ls.arrival_pdf = connections ? arrival_pdf : 0.f;
    /* the guide's directions are a diffuse surface's: a glossy lobe's own ray finds its highlight */
    if (s->sky && part == PM_LOBE_NONSPECULAR && sky_arrival) {
        if (sky_sample) pm_arrival_find(sky_arrival, sf->p, ls.ng, &ls.sky_cell);
        /* cosine-distributed rays alone count: the guide's counts are the sky's cosine-weighted visibility */
        if (!sf->glossy) ls.sky_arrival = sky_arrival;
    }
    uint64_t saved = 0;
    vec3 e = punctual_light(&ls, rng, shadow, &saved);
    if (s->emitter_count) emitter_area_sample(&ls, rng, &e);
    if (s->sky && s->sky_map) sky_map_sample(&ls, rng, &e);
    if (ls.sky_cell.cdf) sky_arrival_sample(&ls, rng, &e);
    if (next) next->traced = false;
    if (s->sky || s->emitter_count || next) own_ray_light(&ls, rng, bounce, next, &e);
    if (shadow_counts) {
        shadow_counts[0] += ls.cast;
        shadow_counts[1] += saved;
        shadow_counts[2] += ls.sky_samples;
    }
    return e;
}

/* Where a classic estimate at sf (on triangle tri) is clipped to its side of the geometry
 * (clip.h): its probes' rotation follows the point and the iteration, not the thread. made: a
 * clip already made there, or NULL. */
static pm_clip_site clip_site(const eye_job *job, const pm_surface *sf, uint32_t tri, const pm_clip *made, uint64_t *rays) {
    uint32_t bits[3];
    memcpy(bits, &sf->p, sizeof bits);
    uint64_t seed = job->settings->seed ^ pm_hash64(((uint64_t)bits[0] << 32 | bits[1]) ^ pm_hash64((uint64_t)bits[2] << 32 | job->iteration));
    pm_clip_site site = {job->scene, job->accel, tri, seed, rays, made};
    return site;
}

/* Radiance reflected toward wo by a photon map's estimate at the non-specular part of sf: kd/pi x
 * the irradiance estimate, or each photon weighted by the part's lobe. */
static vec3 map_estimate(const eye_job *job, const pm_kdtree *map, const pm_surface *sf, uint32_t tri, vec3 ng, vec3 wo,
                         const pm_estimate_settings *e, uint64_t *rays) {
    pm_clip_site site = clip_site(job, sf, tri, NULL, rays);
    const pm_clip_site *clip = job->settings->unclipped ? NULL : &site;
    if (sf->glossy) {
        pm_brdf lobe = pm_vertex_part_lobe(sf, PM_LOBE_NONSPECULAR);
        return pm_photon_estimate_brdf(map, sf->p, ng, e, &lobe, pm_facing(sf->ns, ng), wo, clip);
    }
    return v3_scale(v3_mul(sf->kd, pm_photon_estimate(map, sf->p, ng, e, clip)), PM_INV_PI);
}

/* Radiance reflected toward the gather ray's origin (a classic point reached along d0) from the
 * first surface where the ray meets a non-specular part (through any specular and near-specular
 * bounces): the global map's estimate there, emission excluded (direct light and caustics at the
 * gathering point already count it). The ray leaves its point by the non-specular part
 * (gather_ray_policy); its walk is a classic chain (chain_policy) from vertex 1. */
static vec3 gather(const eye_job *job, const pm_surface *sf, vec3 d0, pm_rng *rng, uint64_t *rays) {
    const pm_scene *s = job->scene;
    const pm_eye_settings *set = job->settings;
    pm_vertex_ray ray;
    if (!pm_vertex_step(sf, d0, 0, &gather_ray_policy, rng, s->ray_scale, &ray)) return v3s(0.f);
    vec3 d = ray.direction, o = ray.origin, weight = ray.weight, result = v3s(0.f);
    for (int depth = 1; depth <= set->max_specular_depth; depth++) {
        pm_hit h;
        (*rays)++;
        if (!pm_accel_intersect(job->accel, o, d, INFINITY, &h)) return result;
        pm_surface y;
        pm_scene_surface(s, h.tri, h.b1, h.b2, &y);
        weight = v3_mul(weight, pm_volume_transmittance(s, &y, d, h.t));
        vec3 wo = v3_neg(d), yng = pm_facing(y.ng, wo);
        if (y.glossy) {
            if (pm_vertex_has_nonspecular(&y))
                result = v3_add(result, v3_mul(weight, map_estimate(job, &set->maps->global, &y, h.tri, yng, wo, &set->global_estimate, rays)));
        } else if (!v3_is_black(y.kd)) {
            vec3 e;
            /* one clip for the lookup and the estimate it may fall back to */
            pm_clip clip;
            float reach = fmaxf(set->maps->irradiance_radius, set->global_estimate.max_radius);
            if (!set->unclipped) pm_clip_make(&clip, s, job->accel, y.p, yng, h.tri, reach, clip_site(job, &y, h.tri, NULL, NULL).seed, rays);
            pm_clip_site site = clip_site(job, &y, h.tri, &clip, rays);
            if (!pm_photon_irradiance_lookup(set->maps, y.p, yng, set->unclipped ? NULL : &clip, &e))
                e = pm_photon_estimate(&set->maps->global, y.p, yng, &set->global_estimate, set->unclipped ? NULL : &site);
            result = v3_add(result, v3_mul(weight, v3_scale(v3_mul(y.kd, e), PM_INV_PI)));
        }
        /* the specular and near-specular parts of the same surface reflect what they see too */
        if (!pm_vertex_step(&y, d, depth, &chain_policy, rng, s->ray_scale, &ray)) return result;
        weight = v3_scale(v3_mul(weight, ray.weight), ray.radiance_scale);
        d = ray.direction;
        o = ray.origin;
    }
    return result;
}

/* The punctual lights' direct light reflected toward wo by a part of sf (a gather point's
 * non-specular part), times throughput, added to *out; its shadow rays counted. */
static void add_punctual_light(const eye_job *job, const pm_surface *sf, pm_lobe part, vec3 wo, vec3 throughput,
                               pm_rng *rng, uint64_t *rays, uint64_t shadow_counts[3], vec3 *out) {
    uint64_t saved = 0;
    light_site ls = light_site_at(job->scene, job->accel, sf, part, wo, rays);
    vec3 e = punctual_light(&ls, rng, job->settings->shadow, &saved);
    *out = v3_add(*out, v3_mul(throughput, e));
    if (shadow_counts) {
        shadow_counts[0] += ls.cast;
        shadow_counts[1] += saved;
    }
}

static void trace_pixel(const eye_job *job, vec3 o, vec3 d, const surface_bounce *camera, pm_rng *rng,
                        vec3 out[PM_COMPONENT_COUNT], uint64_t *rays, uint64_t shadow_counts[3]) {
    const pm_scene *s = job->scene;
    vec3 throughput = v3s(1.f);
    float path_length = 0.f; /* the pixel's cone widens along the chain as it would unfolded (flat mirrors) */
    surface_bounce pending = *camera; /* a segment already traced: the camera ray, or a near-specular bounce's */
    bool lit = true; /* light the segment meets counts here (not after a near-specular bounce: its direct light did) */
    for (int depth = 0;; depth++) {
        int comp = depth == 0 ? PM_DIRECT : PM_SPECULAR;
        pm_hit h;
        pm_surface sf;
        if (!meet_surface(job, &pending, o, d, lit, true, &path_length, &throughput, &out[comp], rays, &h, &sf)) return;
        vec3 wo = v3_neg(d);
        if (pm_vertex_has_nonspecular(&sf)) {
            const pm_eye_settings *set = job->settings;
            vec3 ng = pm_facing(sf.ng, wo);
            if (set->view_photons && set->maps) {
                pm_estimate_settings direct_only = set->global_estimate, indirect_only = set->global_estimate;
                direct_only.path_mask = 1u << PM_PATH_DIRECT;
                indirect_only.path_mask = 1u << PM_PATH_INDIRECT;
                out[comp] = v3_add(out[comp], v3_mul(throughput, map_estimate(job, &set->maps->global, &sf, h.tri, ng, wo, &direct_only, rays)));
                out[depth == 0 ? PM_INDIRECT : PM_SPECULAR] = v3_add(out[depth == 0 ? PM_INDIRECT : PM_SPECULAR],
                    v3_mul(throughput, map_estimate(job, &set->maps->global, &sf, h.tri, ng, wo, &indirect_only, rays)));
            } else {
                out[comp] = v3_add(out[comp], v3_mul(throughput, direct_light(s, job->accel, &sf, PM_LOBE_NONSPECULAR, wo, rng, rays,
                                                                              set->shadow, shadow_counts, NULL, NULL, NULL, 0.f, set->sky_arrival, true)));
            }
            if (set->maps && set->maps->caustic.count) {
                int c = depth == 0 ? PM_CAUSTIC : PM_SPECULAR;
                out[c] = v3_add(out[c], v3_mul(throughput, map_estimate(job, &set->maps->caustic, &sf, h.tri, ng, wo, &set->caustic_estimate, rays)));
            }
            if (set->maps && set->maps->global.count && !set->view_photons) {
                int c = depth == 0 ? PM_INDIRECT : PM_SPECULAR;
                vec3 l = v3s(0.f);
                if (set->indirect == PM_INDIRECT_GATHER && depth == 0 && set->gather_rays > 0) {
                    /* each gather ray carries its sample's weight: kd x L for Lambert's cosine rays */
                    for (int g = 0; g < set->gather_rays; g++) l = v3_add(l, gather(job, &sf, d, rng, rays));
                    l = v3_scale(v3_mul(throughput, l), 1.f / set->gather_rays);
                } else {
                    pm_estimate_settings indirect_only = set->global_estimate;
                    indirect_only.path_mask = 1u << PM_PATH_INDIRECT;
                    l = v3_mul(throughput, map_estimate(job, &set->maps->global, &sf, h.tri, ng, wo, &indirect_only, rays));
                }
                out[c] = v3_add(out[c], l);
            }
        }

        /* the specular and near-specular parts go on; the non-specular part was read here */
        if (depth >= job->settings->max_specular_depth) return;
        pm_vertex_ray ray;
        bool goes_on = pm_vertex_step(&sf, d, depth, &chain_policy, rng, s->ray_scale, &ray);
        lit = ray.lobe != PM_LOBE_NEAR_SPECULAR;
        if (!lit)
            out[PM_SPECULAR] = v3_add(out[PM_SPECULAR], v3_mul(v3_scale(throughput, ray.choice),
                                                               direct_light(s, job->accel, &sf, PM_LOBE_NEAR_SPECULAR, wo, rng, rays,
                                                                            job->settings->shadow, shadow_counts, &ray,
                                                                            goes_on ? &pending : NULL, NULL, 0.f, NULL, false)));
        if (!goes_on) return;
        throughput = v3_scale(v3_mul(throughput, ray.weight), ray.radiance_scale);
        d = ray.direction;
        o = ray.origin;
    }
}

/* The segment a visible point's path goes on along (its final-gather ray, or the path tracer's
 * continuation): the vertex step's sample, the path's weight along it, and its hit when direct
 * light traced it. */
typedef struct {
    bool goes_on;
    pm_vertex_ray ray;
    vec3 throughput;
    surface_bounce traced;
} point_exit;

/* A visible or gather point at surface sf (ng its face normal on the side of wo), reached with
 * throughput (the choice of its non-specular part included). */
static void set_point(pm_visible_point *vp, const pm_surface *sf, vec3 ng, vec3 wo, vec3 throughput, float path_length,
                      uint32_t tri, bool seen_directly) {
    vp->p = sf->p;
    vp->n = ng;
    vp->glossy = sf->glossy;
    vp->wo = wo;
    if (sf->glossy) {
        vp->weight = throughput;
        vp->brdf = pm_vertex_part_lobe(sf, PM_LOBE_NONSPECULAR);
        vp->ns = pm_facing(sf->ns, ng);
    } else {
        vp->weight = v3_mul(throughput, v3_scale(sf->kd, PM_INV_PI));
        vp->ns = ng; /* read by nothing on a Lambert point, but every field is set */
    }
    vp->path_length = path_length;
    vp->tri = tri;
    vp->seen_directly = seen_directly;
    vp->valid = true;
}

/* Follows a ray through specular and near-specular bounces to the first surface where the vertex
 * kernel chooses its non-specular part, and returns that point (false when the path leaves the
 * scene, is absorbed or cut). Camera rays add the emission they see on the way to out[], direct
 * light at the point, and at a near-specular bounce the direct light reflected there (MIS with the
 * bounce's own sample, which direct light traces: what that segment meets it counts, not the walk). A mixed surface is the point with the
 * probability of its non-specular part, scatters on otherwise, each choice weighted by the
 * inverse of its probability (vertex.h). With `exit`, the point's step samples the segment the
 * path goes on along (continuing_policy), which direct light uses and traces; without, the walk
 * stops there unsampled (walk_policy).
 *
 * Gather rays add nothing through specular and near-specular bounces (direct light and caustics
 * at their origin already count it: the caustic photons go on through near-specular parts as
 * through mirrors); at their gather point they add the punctual lights' direct light, by shadow
 * rays as at a visible point (out[lobe_component]), and the global passes store no first hit of
 * a punctual light (pm_photon_tracer_skip_punctual_first_hits): read as photons, that light was
 * most of a gather estimate's noise and its dark bias where a disc overhangs an edge, while shadow
 * photons make most of its rays free. Emitters and the sky stay with the photons: an area sample
 * and its MIS partner would be two more rays a pixel (an iteration 30% longer on the Cornell box
 * at 512x512 for the same error at 320x320). */
static bool walk_to_diffuse(const eye_job *job, vec3 o, vec3 d, const surface_bounce *traced, vec3 throughput,
                            bool camera_ray, int first_vertex, pm_rng *rng, vec3 out[PM_COMPONENT_COUNT], int lobe_component, uint64_t *rays,
                            uint64_t shadow_counts[3], pm_visible_point *vp, pm_surface *sf, vec3 *point_throughput,
                            point_exit *exit) {
    const pm_scene *s = job->scene;
    float path_length = 0.f;
    surface_bounce pending = {.traced = false};
    if (traced) pending = *traced;
    bool lit = camera_ray; /* light the segment meets counts here (a camera path's, not after a near-specular bounce) */
    for (int depth = 0;; depth++) {
        int comp = depth == 0 ? PM_DIRECT : PM_SPECULAR;
        pm_hit h;
        if (!meet_surface(job, &pending, o, d, lit, camera_ray, &path_length, &throughput, &out[comp], rays, &h, sf)) return false;
        vec3 wo = v3_neg(d);
        pm_vertex_ray ray;
        bool goes_on = pm_vertex_step(sf, d, first_vertex + depth, exit ? &continuing_policy : &walk_policy, rng,
                                      s->ray_scale, &ray);
        if (ray.lobe == PM_LOBE_NONE) return false;
        if (ray.lobe == PM_LOBE_NONSPECULAR) {
            vec3 ng = pm_facing(sf->ng, wo);
            vec3 before = throughput;
            throughput = v3_scale(throughput, ray.choice);
            if (exit) {
                exit->goes_on = goes_on;
                exit->ray = ray;
                exit->throughput = v3_mul(before, ray.weight);
                exit->traced.traced = false;
            }
            if (camera_ray) {
                out[comp] = v3_add(out[comp], v3_mul(throughput, direct_light(s, job->accel, sf, PM_LOBE_NONSPECULAR, wo, rng, rays,
                                                                              job->settings->shadow, shadow_counts, exit ? &ray : NULL,
                                                                              exit && goes_on ? &exit->traced : NULL, NULL, 0.f,
                                                                              job->settings->sky_arrival, true)));
            } else if (s->light_count) {
                /* the punctual lights at a gather point: the visible point's indirect light, traced
                 * (their first-hit photons are not stored, see above) */
                add_punctual_light(job, sf, PM_LOBE_NONSPECULAR, wo, throughput, rng, rays, shadow_counts, &out[lobe_component]);
            }
            set_point(vp, sf, ng, wo, throughput, path_length, h.tri, depth == 0);
            *point_throughput = throughput;
            return true;
        }
        if (!goes_on || depth >= job->settings->max_specular_depth) return false;
        lit = camera_ray && ray.lobe != PM_LOBE_NEAR_SPECULAR;
        if (camera_ray && !lit)
            out[PM_SPECULAR] = v3_add(out[PM_SPECULAR], v3_mul(v3_scale(throughput, ray.choice),
                                                               direct_light(s, job->accel, sf, PM_LOBE_NEAR_SPECULAR, wo, rng, rays,
                                                                            job->settings->shadow, shadow_counts, &ray, &pending, NULL, 0.f, NULL, false)));
        throughput = v3_scale(v3_mul(throughput, ray.weight), ray.radiance_scale);
        d = ray.direction;
        o = ray.origin;
    }
}

/* Where a path-traced sample starts: the camera (path_from_camera), or the segment leaving a
 * progressive visible point (trace_visible with PM_GATHER_PATH). */
typedef struct {
    vec3 throughput;
    int depth;               /* the index of the surface the first segment meets */
    bool from_camera;        /* the camera ray: its emission and sky count, its cone picks texture levels */
    bool behind_specular;    /* the first eye vertex was specular: everything is the specular component */
    bool caustics_read;      /* light met through specular bounces before the next diffuse vertex is the caustic
                                photons' (read at the visible point this path leaves): not counted */
    /* where the path first chooses a non-specular part (when not NULL): a gather point, whose
     * photons carry the light no path finds (settings->gather_punctual_specular) */
    pm_visible_point *gather_point;
    const pm_connections *connections; /* the light vertices the path joins (eye.h); NULL: none */
    /* the visible point joined a light vertex (connect): where it is and its sample's pdf, against
     * which the first vertex's punctual lights are weighed */
    bool joined;
    vec3 joined_at;
    float joined_pdf;
} path_start;

static const path_start path_from_camera = {{1.f, 1.f, 1.f}, 0, true, false, false, NULL, NULL, false, {0.f, 0.f, 0.f}, 0.f};

static void trace_path(const eye_job *job, vec3 o, vec3 d, const surface_bounce *first, const path_start *start,
                       pm_rng *rng, vec3 out[PM_COMPONENT_COUNT], uint64_t *rays, uint64_t shadow_counts[3],
                       path_tally *tally);

/* The progressive mode's eye sample: the pixel's visible point and, with final gathering, the
 * point its one gather ray finds (the segment the visible point's step drew, which direct light
 * there traced); emission and direct light go to out[]. With PM_GATHER_PATH the path tracer goes
 * on from the visible point instead (no gather point). */
static void trace_visible(const eye_job *job, vec3 o, vec3 d, const surface_bounce *camera, const pm_connections *connections,
                          pm_rng *rng, vec3 out[PM_COMPONENT_COUNT], uint64_t *rays, uint64_t shadow_counts[3],
                          path_tally *tally, pm_visible_point *vp, pm_visible_point *gp) {
    /* a point's fields are all written where it becomes valid; clearing two 96-byte records per
     * pixel would cost 2% of an iteration */
    vp->valid = false;
    if (gp) gp->valid = false;
    pm_surface sf, y;
    vec3 throughput, unused;
    point_exit exit;
    if (!walk_to_diffuse(job, o, d, camera, v3s(1.f), true, 0, rng, out, PM_DIRECT, rays, shadow_counts, vp, &sf, &throughput,
                         gp ? &exit : NULL) ||
        !gp)
        return;
    if (job->settings->gather_source == PM_GATHER_PATH) {
        /* the path tracer from here on: its light is the visible point's indirect light; the
         * light it cannot find, the photons bring to its first non-specular vertex. A connection
         * joins here whether the path goes on or not, as the path tracer's loop joins at every
         * such vertex (its weight is the point's, unscaled by the survival). */
        if (connections) {
            int c = vp->seen_directly ? PM_INDIRECT : PM_SPECULAR;
            out[c] = v3_add(out[c], connect(job, connections, &sf, vp->wo, throughput, rng, rays, tally));
        }
        if (!exit.goes_on) return;
        path_start from = {exit.throughput, 1, false, !vp->seen_directly, true, job->settings->gather_punctual_specular ? gp : NULL,
                           connections, connections && exit.ray.sampled, sf.p, exit.ray.pdf};
        trace_path(job, exit.ray.origin, exit.ray.direction, &exit.traced, &from, rng, out, rays, shadow_counts, tally);
        return;
    }
    if (!exit.goes_on) return;
    /* light the gather point's punctual lights give is the visible point's indirect light */
    int lobe_component = vp->seen_directly ? PM_INDIRECT : PM_SPECULAR;
    if (walk_to_diffuse(job, exit.ray.origin, exit.ray.direction, &exit.traced, exit.throughput, false, 1, rng, out,
                        lobe_component, rays, shadow_counts, gp, &y, &unused, NULL))
        gp->seen_directly = vp->seen_directly; /* the component is the visible point's */
}


/* The path tracer's sample (settings->path_trace; the rules are in eye.h at pm_eye_iterate), or
 * its continuation from a visible point (start). `seen` is the component that light met along the
 * next segment belongs to, `lit_by_segment` whether such light counts at all (camera ray, or the
 * last bounce was specular). first: the first segment, already traced. At a non-specular or
 * near-specular choice direct light adds the lights (MIS with the step's own sample, which it
 * traces for the path to go on along, counting what that segment meets). */
static void trace_path(const eye_job *job, vec3 o, vec3 d, const surface_bounce *first, const path_start *start,
                       pm_rng *rng, vec3 out[PM_COMPONENT_COUNT], uint64_t *rays, uint64_t shadow_counts[3],
                       path_tally *tally) {
    const pm_scene *s = job->scene;
    vec3 throughput = start->throughput;
    bool behind_specular = start->behind_specular;
    int seen = PM_DIRECT; /* from a visible point: set at the next diffuse vertex, before any light counts */
    bool lit_by_segment = start->from_camera;
    bool caustic_segment = start->caustics_read; /* no diffuse vertex yet since the visible point */
    bool past_nonspecular = !start->from_camera; /* a non-specular vertex met (a visible point's continuation starts past one) */
    bool cone = start->from_camera; /* the pixel's cone, until the first diffuse or glossy bounce (level 0 after it) */
    float path_length = 0.f;
    surface_bounce next = *first; /* the camera ray, traced with its tile, or the visible point's direct light's */
    const pm_connections *connections = start->connections;
    bool joined = start->joined; /* the last vertex joined a light vertex: where it was, its sample's pdf */
    vec3 joined_at = start->joined_at;
    float joined_pdf = start->joined_pdf;
    for (int depth = start->depth; depth < PM_PATHTRACE_MAX_VERTICES; depth++) {
        pm_hit h;
        pm_surface sf;
        if (!meet_surface(job, &next, o, d, lit_by_segment, cone, &path_length, &throughput, &out[seen], rays, &h, &sf)) return;
        tally->vertices++;
        vec3 wo = v3_neg(d);
        pm_vertex_ray ray;
        bool goes_on = pm_vertex_step(&sf, d, depth, &continuing_policy, rng, s->ray_scale, &ray);
        if (ray.lobe == PM_LOBE_NONE) return;
        if (ray.lobe == PM_LOBE_NONSPECULAR) {
            /* the gather point's component is the visible point's (seen directly unless behind specular) */
            if (start->gather_point && !start->gather_point->valid)
                set_point(start->gather_point, &sf, pm_facing(sf.ng, wo), wo, v3_scale(throughput, ray.choice), path_length, h.tri,
                          !start->behind_specular);
            int here = depth == 0 ? PM_DIRECT : (behind_specular ? PM_SPECULAR : PM_INDIRECT);
            float arrival_pdf = joined ? area_pdf(joined_pdf, joined_at, sf.p, sf.ng) : 0.f;
            out[here] = v3_add(out[here], v3_mul(v3_scale(throughput, ray.choice),
                                                 direct_light(s, job->accel, &sf, PM_LOBE_NONSPECULAR, wo, rng, rays,
                                                              job->settings->shadow, shadow_counts, &ray, goes_on ? &next : NULL,
                                                              connections, arrival_pdf, job->settings->sky_arrival,
                                                              !past_nonspecular)));
            if (connections) {
                /* the light a vertex reached from here adds by its punctual lights, as NEE there would */
                int there = behind_specular ? PM_SPECULAR : PM_INDIRECT;
                out[there] = v3_add(out[there], connect(job, connections, &sf, wo, v3_scale(throughput, ray.choice), rng, rays, tally));
            }
            joined = connections && ray.sampled;
            joined_at = sf.p;
            joined_pdf = ray.pdf;
            /* from a first-hit diffuse vertex, what specular bounces lead to is the caustic (and
             * from the first non-specular vertex behind specular ones, where it is measured apart) */
            seen = depth == 0 || (job->settings->caustic_apart && !past_nonspecular) ? PM_CAUSTIC : here;
            past_nonspecular = true;
            lit_by_segment = false;
            caustic_segment = false;
            cone = false;
        } else {
            joined = false;
            if (depth == 0) {
                behind_specular = true;
                seen = PM_SPECULAR;
            }
            /* straight across a thin wall scatters nothing: light met past it is counted where
             * it was before (after a diffuse vertex, by its direct light, which crosses thin walls) */
            if (ray.sampled && !ray.straight && !caustic_segment) lit_by_segment = true;
            if (ray.lobe == PM_LOBE_NEAR_SPECULAR && ray.sampled && !caustic_segment) {
                /* the lights by MIS with this sample, which direct light traces and counts */
                out[seen] = v3_add(out[seen], v3_mul(v3_scale(throughput, ray.choice),
                                                     direct_light(s, job->accel, &sf, PM_LOBE_NEAR_SPECULAR, wo, rng, rays,
                                                                  job->settings->shadow, shadow_counts, &ray, goes_on ? &next : NULL, NULL, 0.f, NULL, false)));
                lit_by_segment = false;
            }
        }
        if (!goes_on) return;
        throughput = v3_scale(v3_mul(throughput, ray.weight), ray.radiance_scale);
        d = ray.direction;
        o = ray.origin;
    }
}

static void render_tile(void *ctx, size_t task, int thread) {
    eye_job *job = ctx;
    pm_film *film = job->film;
    if (job->deadline > 0.0 && pm_now_seconds() > job->deadline) return;
    job->done[task] = 1;
    int tx = (int)(task % job->tiles_x), ty = (int)(task / job->tiles_x);
    int x0 = tx * TILE, y0 = ty * TILE;
    int x1 = x0 + TILE < film->width ? x0 + TILE : film->width;
    int y1 = y0 + TILE < film->height ? y0 + TILE : film->height;
    if (job->save) pm_film_save_rect(film, x0, y0, x1, y1); /* what a cancel puts back */
    uint64_t rays = 0, dropped = 0, shadow_counts[3] = {0, 0, 0};
    const pm_connections *joining = job->settings->connections;
    path_tally tally = {0, 0, 0, joining && joining->worth_next ? &joining->worth_next[thread] : NULL};
    assert(!tally.worth || thread < joining->worth_tables);
    pm_visible_point visible[TILE * TILE], gathered[TILE * TILE];
    size_t pixels[TILE * TILE], points = 0;
    /* a tile's rows are short runs in each component's sum, too short for the hardware prefetcher:
     * asking for them now hides the misses behind the tile's rays */
    for (int c = 0; c < PM_COMPONENT_COUNT; c++)
        if (film->sum[c])
            for (int y = y0; y < y1; y++)
                for (int x = x0; x < x1 + 4; x += 5) /* 60 bytes apart: every 64-byte line */
                    __builtin_prefetch(film->sum[c] + 3 * ((size_t)y * film->width + (x < x1 ? x : x1 - 1)), 1);
    /* The tile's camera rays first, in 4 x 2 blocks: Embree traces such a packet of 8 about twice
     * as fast as 8 single rays. Each pixel's random numbers go on from where its jitter left them. */
    enum { BLOCK_W = 4, BLOCK_H = 2 };
    vec3 origin[TILE * TILE], direction[TILE * TILE];
    pm_rng rngs[TILE * TILE];
    bool hit[TILE * TILE];
    pm_hit hits[TILE * TILE];
    uint16_t ray_of[TILE * TILE]; /* by the pixel's place in the tile, row by row */
    size_t traced = 0;
    const uint8_t *only = job->settings->only_pixels;
    for (int by = y0; by < y1; by += BLOCK_H)
        for (int bx = x0; bx < x1; bx += BLOCK_W)
            for (int y = by; y < by + BLOCK_H && y < y1; y++)
                for (int x = bx; x < bx + BLOCK_W && x < x1; x++) {
                    if (only && !only[(size_t)y * film->width + x]) continue;
                    pm_rng *rng = &rngs[traced];
                    *rng = pm_rng_for(job->settings->seed, job->iteration, (size_t)y * film->width + x);
                    /* y's number first: the order the images have always had */
                    float jy = pm_rng_float(rng), jx = pm_rng_float(rng);
                    pm_camera_view_ray(&job->view, x + jx, y + jy, &origin[traced], &direction[traced]);
                    ray_of[(y - y0) * TILE + (x - x0)] = (uint16_t)traced++;
                }
    if (!traced) return; /* an empty tile: none is ever made */
    pm_accel_intersect_packets(job->accel, traced, origin, direction, true, hit, hits);
    rays += traced;
    for (int y = y0; y < y1; y++)
        for (int x = x0; x < x1; x++) {
            size_t pixel = (size_t)y * film->width + x;
            if (only && !only[pixel]) continue;
            size_t k = ray_of[(y - y0) * TILE + (x - x0)];
            pm_rng rng = rngs[k];
            vec3 o = origin[k], d = direction[k];
            surface_bounce camera = {.traced = true, .hit = hit[k]};
            if (hit[k]) camera.h = hits[k];
            vec3 out[PM_COMPONENT_COUNT] = {{0}};
            const pm_connections *joins = job->settings->connections;
            if (joins && joins->pixels && !joins->pixels[pixel]) joins = NULL;
            if (job->settings->path_trace) {
                path_start from = path_from_camera;
                from.connections = joins;
                trace_path(job, o, d, &camera, &from, &rng, out, &rays, shadow_counts, &tally);
            }
            else if (job->visible_points) {
                trace_visible(job, o, d, &camera, joins, &rng, out, &rays, shadow_counts, &tally, &visible[points],
                              job->gather_points ? &gathered[points] : NULL);
                pixels[points++] = pixel;
            } else
                trace_pixel(job, o, d, &camera, &rng, out, &rays, shadow_counts);
            /* a sample pm_film_add refuses is counted (stat eye dropped_samples=), so tests can see one; a
             * zero adds nothing (sums are never -0, and NaN is not zero), so the components this pass
             * leaves to photons are not touched */
            for (int c = 0; c < PM_COMPONENT_COUNT; c++)
                if (film->sum[c] && (out[c].x != 0.f || out[c].y != 0.f || out[c].z != 0.f) &&
                    !pm_film_add(film, (pm_component)c, pixel, out[c]))
                    dropped++;
        }
    if (job->visit && points) job->visit(job->visit_ctx, pixels, visible, job->gather_points ? gathered : NULL, points, thread);
    job->counters[thread].rays += rays;
    job->counters[thread].dropped += dropped;
    job->counters[thread].vertices += tally.vertices;
    job->counters[thread].connections += tally.connections;
    job->counters[thread].connection_rays += tally.connection_rays;
    job->counters[thread].shadow[0] += shadow_counts[0];
    job->counters[thread].shadow[1] += shadow_counts[1];
    job->counters[thread].shadow[2] += shadow_counts[2];
}

/* How the pass ended. Cut by the deadline: the traced tiles' pixels are marked `reached` in the
 * film. Cancelled (the calling thread's flag, and some tile left undone): the traced tiles are put
 * back from the film's saved copy when this pass saved them (job->save), else the caller, whose
 * first pass saved every pixel, puts the whole film back; no counter is added. */
static pm_eye_pass_result run_eye_pass(const pm_scene *s, const pm_accel *a, const pm_camera *cam,
                                       const pm_eye_settings *settings, uint32_t iteration, pm_film *film,
                                       bool visible_points, bool gather_points, pm_visible_points_fn visit, void *visit_ctx,
                                       unsigned reached, bool first_of_iteration, pm_eye_stats *stats) {
    double start = pm_now_seconds();
    int tiles_x = (film->width + TILE - 1) / TILE, tiles_y = (film->height + TILE - 1) / TILE;
    size_t tiles = (size_t)tiles_x * tiles_y;
    eye_job *job = pm_calloc(1, sizeof *job + tiles, "eye pass job");
    if (!job) { if (stats) stats->failed = true; return PM_EYE_PASS_FAILED; }
    job->scene = s;
    job->accel = a;
    job->camera = cam;
    job->view = pm_camera_view_make(cam, film->width, film->height);
    job->cone_width = PM_FOOTPRINT_PIXELS * pm_camera_pixel_size(cam, film->height, 0.f);
    job->cone_spread = PM_FOOTPRINT_PIXELS * pm_camera_pixel_size(cam, film->height, 1.f) - job->cone_width;
    job->settings = settings;
    job->iteration = iteration;
    job->film = film;
    job->visible_points = visible_points;
    job->gather_points = visible_points && gather_points;
    job->visit = visit;
    job->visit_ctx = visit_ctx;
    job->tiles_x = tiles_x;
    job->deadline = film->samples > 0 && !film->ragged ? settings->deadline : 0.0;
    int threads = pm_thread_count(settings->threads);
    /* a pass over a ragged film is never cancelled (a pixel could be left two samples ahead), and
     * a film that keeps no copy cannot take a cancel back: its pass runs to the end */
    const atomic_bool *cancel = pm_parallel_get_cancel();
    bool cancellable = !film->ragged && pm_film_can_restore(film);
    job->save = cancellable && first_of_iteration && cancel;
    if (!cancellable) pm_parallel_set_cancel(NULL);
    pm_parallel_for(threads, tiles, render_tile, job);
    if (!cancellable) pm_parallel_set_cancel(cancel);
    size_t traced = 0;
    for (size_t t = 0; t < tiles; t++) traced += job->done[t];
    bool cancelled = traced < tiles && cancellable && cancel && atomic_load(cancel);
    for (size_t t = 0; t < tiles && traced < tiles; t++) {
        if (!job->done[t]) continue;
        int x0 = (int)(t % (size_t)tiles_x) * TILE, y0 = (int)(t / (size_t)tiles_x) * TILE;
        int x1 = x0 + TILE < film->width ? x0 + TILE : film->width, y1 = y0 + TILE < film->height ? y0 + TILE : film->height;
        if (!cancelled) pm_film_mark_ahead(film, x0, y0, x1, y1, reached);
        else if (job->save) pm_film_restore_rect(film, x0, y0, x1, y1);
    }
    if (stats && !cancelled) {
        for (int t = 0; t < threads; t++) {
            stats->rays += job->counters[t].rays;
            stats->dropped_samples += job->counters[t].dropped;
            stats->path_vertices += job->counters[t].vertices;
            stats->connections += job->counters[t].connections;
            stats->connection_rays += job->counters[t].connection_rays;
            stats->shadow_rays += job->counters[t].shadow[0];
            stats->shadow_rays_saved += job->counters[t].shadow[1];
            stats->sky_arrival_samples += job->counters[t].shadow[2];
        }
        stats->seconds += pm_now_seconds() - start;
    }
    free(job);
    return traced == tiles ? PM_EYE_PASS_WHOLE : (cancelled ? PM_EYE_PASS_CANCELLED : PM_EYE_PASS_CUT);
}

bool pm_eye_iterate(const pm_scene *s, const pm_accel *a, const pm_camera *cam, const pm_eye_settings *settings,
                    uint32_t iteration, pm_film *film, pm_eye_stats *stats) {
    /* out of memory and a cancel add no sample (a cancel leaves the film as it was); a pass cut
     * by the deadline marked the pixels it reached */
    /* the copy a cancel puts back lives only while a cancellable pass runs */
    bool copy = pm_parallel_get_cancel() && !film->ragged;
    if (copy && !pm_film_open_copy(film)) {
        if (stats) stats->failed = true;
        return false;
    }
    pm_eye_pass_result r = run_eye_pass(s, a, cam, settings, iteration, film, false, false, NULL, NULL,
                                        PM_FILM_AHEAD_SAMPLE, true, stats);
    pm_film_close_copy(film);
    if (r == PM_EYE_PASS_WHOLE) film->samples++;
    return r != PM_EYE_PASS_FAILED;
}

pm_eye_pass_result pm_eye_visible_points(const pm_scene *s, const pm_accel *a, const pm_camera *cam,
                                         const pm_eye_settings *settings, uint32_t iteration, pm_film *film,
                                         bool gather_points, pm_visible_points_fn visit, void *ctx, unsigned reached,
                                         bool first_of_iteration, pm_eye_stats *stats) {
    return run_eye_pass(s, a, cam, settings, iteration, film, true, gather_points, visit, ctx, reached,
                        first_of_iteration, stats);
}

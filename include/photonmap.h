/* photonmap.h: the photon pass: emission from every light by power, Russian-roulette tracing, caustic and global maps.
 *
 * Built as a function of a photon budget and a seed, so the progressive mode can call it
 * once per iteration. The caustic map holds L S+ D photons (stored at the first diffuse hit
 * after one or more specular bounces; the trace stops there), aimed with projection maps; the
 * global map holds every diffuse hit of every photon, each tagged by how it got there so
 * that an estimate can leave out what another component already counts.
 */
#ifndef PM_PHOTONMAP_H
#define PM_PHOTONMAP_H

#include <stdbool.h>
#include <stdint.h>
#include "accel.h"
#include "brdf.h"
#include "clip.h"
#include "guide.h"
#include "kdtree.h"
#include "scene.h"

/* How a stored photon reached its surface (the record's 2-bit path tag): straight from its light,
 * through mirrors and glass alone, past a diffuse or glossy bounce; or, where a tracer is asked to
 * tell it apart (pm_photon_tracer_tag_punctual_specular), left a punctual light and met a mirror or
 * glass before anything else scattered it, whatever came after: light no path from the camera
 * finds, since neither a shadow ray nor a sampled direction crosses a specular surface to a point
 * or a single direction. */
enum { PM_PATH_DIRECT = 0, PM_PATH_CAUSTIC = 1, PM_PATH_INDIRECT = 2, PM_PATH_PUNCTUAL_SPECULAR = 3 };
#define PM_PATH_ALL 15u /* a path mask of every tag */

/* Radiance estimate kernels. */
typedef enum { PM_KERNEL_DISC = 0, PM_KERNEL_GAUSSIAN = 1, PM_KERNEL_CONE = 2 } pm_kernel;

typedef struct {
    pm_kernel kernel;
    int k;                 /* photons per estimate */
    float max_radius;      /* world units */
    unsigned path_mask;    /* which PM_PATH_* tags to include (bit per tag) */
} pm_estimate_settings;

typedef struct {
    uint64_t global_photons;   /* photons emitted for the global map (0 = no global map) */
    uint64_t caustic_photons;  /* photons emitted for the caustic map (0 = none) */
    uint64_t seed;
    int threads;
    int max_bounces;
    /* photons a chunk traces side by side (0: PM_PHOTON_WAVE, also the most): any size stores
     * the same records, in another order; 1 traces one photon's path after another */
    int wave;
    /* the hits' triangles are prefetched when what a surface record reads of the mesh is at least
     * this many bytes, their texels when the textures' level 0 is (0: more than
     * PM_PREFETCH_GEOMETRY_BYTES; 1: always; UINT64_MAX: never): the records are the same either way */
    uint64_t prefetch_bytes;
    bool projection_maps;      /* aim caustic photons at specular objects */
    /* Christensen's precomputation for final gathering: irradiance estimated once at every
     * irradiance_stride-th global photon (0 = none), with irradiance_estimate; a gather ray
     * then needs only the nearest such point instead of a k-nearest estimate. */
    int irradiance_stride;
    pm_estimate_settings irradiance_estimate;
    bool unclipped;            /* the precomputed estimates read their whole disc, through walls (to measure clip.h) */
} pm_photon_settings;

typedef struct {
    pm_kdtree caustic, global;
    /* precomputed irradiance points: a photon record whose power is the irradiance there */
    pm_kdtree irradiance;
    float irradiance_radius;   /* lookups farther than this fall back to a full estimate */
    uint64_t caustic_emitted, global_emitted;
    /* fraction of the caustic lights' emission directions the projection maps kept */
    double projection_fraction;
} pm_photon_maps;

typedef struct {
    uint64_t emitted, stored_caustic, stored_global, rays;
    uint64_t dropped;      /* photon paths ended because their power was NaN or infinite */
    double seconds;        /* the whole build */
    double trace_seconds;  /* emitting and tracing photons (both maps) */
    double kdtree_seconds; /* building the kd-trees */
    double irradiance_seconds; /* precomputing irradiance points */
} pm_photon_stats;

/* The photon tracer: light sources, their power distribution and projection maps, built once
 * per scene, then asked for as many passes as a mode needs (the classic mode one of each kind,
 * the progressive mode a fresh pass every iteration). A pass with the same (photons, seed)
 * gives the same tree at any thread count. */
typedef struct pm_photon_tracer pm_photon_tracer;
pm_photon_tracer *pm_photon_tracer_create(const pm_scene *s, const pm_accel *a, const pm_photon_settings *settings);
void pm_photon_tracer_destroy(pm_photon_tracer *t);
/* Whether a pass of that kind can store anything (a light and a diffuse surface; for caustics a
 * specular object some light reaches). */
bool pm_photon_tracer_can_trace(const pm_photon_tracer *t, bool caustic);
double pm_photon_tracer_projection_fraction(const pm_photon_tracer *t);
/* Traces `photons` photons (each carrying 1/photons of the lights' flux) into a new tree in
 * *out, adding to the counters in *stats. False when out of memory. */
bool pm_photon_tracer_trace(pm_photon_tracer *t, bool caustic, uint64_t photons, uint64_t seed, pm_kdtree *out,
                            pm_photon_stats *stats);

/* Passes started after this (CLOCK_MONOTONIC seconds; 0 = never) stop starting chunks once it is
 * past, and rescale what they stored so the expected power stays the same: a time budget holds
 * however long a pass would have run. Not for trees (the classic mode sizes its passes). */
void pm_photon_tracer_set_deadline(pm_photon_tracer *t, double deadline);

/* With skip true, global passes store no record of a photon's first hit when it left a punctual
 * light: the reader traces that light itself (the progressive mode's gather points, by shadow
 * rays). Its later hits are stored as any photon's. */
void pm_photon_tracer_skip_punctual_first_hits(pm_photon_tracer *t, bool skip);

/* With tag true, global passes tag PM_PATH_PUNCTUAL_SPECULAR the records of light that left a
 * punctual light and met a mirror or glass first; with only true too, they store those records
 * alone, end every other path as soon as it can no longer become one (a photon of an emitting
 * surface or the sky never starts) and leave the emission guide alone: the photons a path-traced
 * gather adds for the light it cannot find (the progressive mode's gather points). */
void pm_photon_tracer_tag_punctual_specular(pm_photon_tracer *t, bool tag, bool only);


/* Camera splats: light tracing of the caustic seen directly. While set, every caustic pass also
 * connects each caustic photon it stores at a diffuse or glossy point to the camera (an image
 * width x height) and, where the camera sees that point, appends the radiance the photon adds to
 * that pixel's mean (the particle tracer's estimate) to out, in photon order: the same splats at
 * any thread count. out is emptied at each caustic pass and rescaled with the records when a
 * deadline cuts the pass. camera NULL stops it; the camera is copied, out must outlive the passes. */
typedef struct {
    uint32_t pixel; /* y x width + x */
    float rgb[3];
} pm_camera_splat;
typedef struct {
    pm_camera_splat *data;
    size_t count, capacity;
} pm_splat_buffer;
void pm_photon_tracer_set_splats(pm_photon_tracer *t, const pm_camera *camera, int width, int height, pm_splat_buffer *out);

/* The emission guide (guide.h): how many of the tracer's sources it may steer; with a guide of
 * that many sources, every later global pass draws guided photons from it, counts their records
 * in marked cells, and teaches it from them (NULL: unguided, every source sampled by its own density). False when out of memory. */
uint32_t pm_photon_tracer_guided_sources(const pm_photon_tracer *t);
bool pm_photon_tracer_set_guide(pm_photon_tracer *t, pm_guide *guide, const pm_marks *marks);

/* Light vertices: where photons from the punctual lights and the sky first meet a diffuse or
 * glossy surface (past thin walls crossed straight), kept for the eye paths to connect to (eye.c,
 * connections). flux is the photon's power there (over keep, the probability it was kept with),
 * ng faces the side it arrived from, to_light back along its way, light its scene light
 * (PM_LIGHT_VERTEX_SKY: the sky), (tri, b1, b2) the hit for the surface to be made again. */
#define PM_LIGHT_VERTEX_SKY UINT32_MAX
typedef struct {
    vec3 p, ng, to_light, flux;
    uint32_t tri, light;
    float b1, b2, keep;
} pm_light_vertex;
/* A pass's light vertices in photon order, reused from pass to pass; photons: those it traced. */
typedef struct {
    pm_light_vertex *data;
    size_t count, capacity;
    uint64_t photons;
} pm_light_vertex_buffer;
/* A pass of `photons` photons from the punctual lights and the sky (not the emitters, whose area
 * samples find their light; guided as global passes are, and teaching the guide by the first hits
 * as they teach it by every record), each ended at its first diffuse or glossy hit, which is kept with the
 * probability pm_light_vertex_keep gives there, its flux divided by it. The same vertices at any
 * thread count; a cancelled pass keeps none. False when out of memory. */
bool pm_photon_tracer_trace_light_vertices(pm_photon_tracer *t, uint64_t photons, uint64_t seed, const pm_cell_values *worth,
                                           pm_light_vertex_buffer *out, pm_photon_stats *stats);
/* The density per unit area, for one photon of such a pass, of its first hits from scene light
 * `light` at p (face normal ng), where that light reaches p unblocked: the source's pick, the
 * guide's density over the cell its placing numbers fall in (emit's mapping turned back), and the
 * start's density across the light (or the direction's per solid angle, over the square of the
 * distance). The sky's (light PM_LIGHT_VERTEX_SKY) arriving from to_light is per unit area and
 * per steradian of to_light: its start's density across the disc times its direction's. 0 where
 * no photon of it can start toward p. */
float pm_photon_tracer_first_hit_density(const pm_photon_tracer *t, uint32_t light, vec3 p, vec3 ng, vec3 to_light);
/* The probability a light vertex at p is kept: its cell's mean worth over the mean of all, between
 * PM_CONNECT_KEEP_LEAST and 1; 1 in a cell not yet valued (or with no worth table). */
static inline float pm_light_vertex_keep(const pm_cell_values *worth, vec3 p) {
    float mean;
    if (!worth || !(worth->mean > 0.0) || !pm_cell_values_mean(worth, p, &mean)) return 1.f;
    float keep = mean / (float)worth->mean;
    return keep < PM_CONNECT_KEEP_LEAST ? PM_CONNECT_KEEP_LEAST : (keep < 1.f ? keep : 1.f);
}

/* A growable array of photon records, reused from pass to pass. */
typedef struct { pm_photon *data; size_t count, capacity; } pm_photon_buffer;
/* The same pass into a buffer (grown when needed, never shrunk) instead of a new tree. A pass the
 * calling thread's cancel flag stops (pm_parallel_set_cancel) is answered within a wave of
 * paths, stores nothing and returns true, out of memory or not: its caller discards it. */
bool pm_photon_tracer_trace_into(pm_photon_tracer *t, bool caustic, uint64_t photons, uint64_t seed,
                                 pm_photon_buffer *out, pm_photon_stats *stats);

bool pm_photon_maps_build(const pm_scene *s, const pm_accel *a, const pm_photon_settings *settings,
                          pm_photon_maps *maps, pm_photon_stats *stats);
void pm_photon_maps_free(pm_photon_maps *maps);

/* Irradiance-like estimate E at point p with side normal n (facing the viewer), so that the
 * reflected radiance off a Lambert surface is kd/pi * E: the sum of the power of the k nearest
 * photons that arrived from the front of this surface, divided by the kernel's area. */
/* With a site, only the photons on p's side of the geometry count (clip.h), over the area of the
 * disc they stand for; the clip is made only when the query found photons. */
vec3 pm_photon_estimate(const pm_kdtree *map, vec3 p, vec3 n, const pm_estimate_settings *e, const pm_clip_site *site);

/* The reflected radiance toward wo at a glossy point (Jensen's estimate with any BRDF): the same
 * photons, each one's power weighted by f(wo, wi) for the direction wi it arrived from; ns is
 * the shading normal on wo's side. */
vec3 pm_photon_estimate_brdf(const pm_kdtree *map, vec3 p, vec3 n, const pm_estimate_settings *e, const pm_brdf *b,
                             vec3 ns, vec3 wo, const pm_clip_site *site);

/* The precomputed irradiance nearest p on a surface facing n (and kept by clip, when not NULL);
 * false when there is none within irradiance_radius (the caller then makes a full estimate). */
bool pm_photon_irradiance_lookup(const pm_photon_maps *maps, vec3 p, vec3 n, const pm_clip *clip, vec3 *irradiance);

#endif

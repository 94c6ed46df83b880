/* eye.h: the eye pass: rays from the camera, jittered in each pixel, split into the four components at the first hit.
 *
 * Component rule (by the first eye vertex): `direct` is emission seen at the first hit plus
 * direct light (shadow rays) at a first-hit diffuse surface; `specular` is everything that
 * reaches the eye through one or more specular bounces; `caustic` and `indirect` are the
 * photon estimates at a first-hit diffuse surface (black until a photon pass supplies maps).
 * One iteration adds one sample per pixel to the film, on all threads, tile by tile; every
 * sample's random stream depends on (seed, iteration, pixel) only.
 *
 * A pass stops between tiles in two ways. A cancel (the calling thread's flag, parallel.h: a
 * restart, a stop, a signal) takes the iteration back whole: its first pass saves each tile's
 * pixels before writing them (pm_film_save_rect), the tiles traced are put back, no sample is
 * counted, and the next iteration is the one cancelled, with the same seeds, so a run with a
 * cancel ends bit for bit where the run without it does. The deadline (settings->deadline,
 * --time) keeps what finished: the tiles traced are marked in the film (pm_film_mark_ahead), whose
 * resolve divides each pixel by its own sample count, so pixels the cut pass reached and pixels it
 * did not are each unbiased, no sample is thrown away, and the cut ends the run. Two passes are
 * never cut by the deadline: a film's first pass (an image needs every pixel once, so a budget
 * shorter than one pass gets that one whole pass, late, rather than a partly black image) and any
 * pass over a film already ragged (a cut is the end of a run; such a pass is not cancelled either,
 * since a pixel could then hold two samples more). A film made by hand (no saved copy) is never
 * cancelled.
 */
#ifndef PM_EYE_H
#define PM_EYE_H

#include <stdint.h>
#include "accel.h"
#include "arrival.h"
#include "camera.h"
#include "film.h"
#include "photonmap.h"
#include "scene.h"
#include "shadowmap.h"

typedef enum { PM_INDIRECT_GATHER = 0, PM_INDIRECT_PHOTONS = 1 } pm_indirect_mode;

/* Where the progressive mode's final gather takes the visible point's indirect light from.
 * PHOTONS: the gather ray's first diffuse or glossy point reads the iteration's global photons (the
 * punctual lights traced there by shadow rays). PATH: no gather point; the path tracer's own loop
 * goes on from the visible point along the same ray (direct light at every vertex, roulette), and
 * light reaching the visible point through specular bounces alone is left to the caustic photons
 * read there, so nothing is counted twice. Both estimate the same light; the progressive mode
 * chooses per scene from measured error and cost (progressive.c, choose_gather). */
typedef enum { PM_GATHER_PHOTONS = 0, PM_GATHER_PATH = 1 } pm_gather_source;

/* Connections (eye.c, connect): at a path-traced sample's diffuse and glossy vertices, one light
 * vertex (photonmap.h) drawn uniformly from a pass's is joined to the path by a shadow ray, and
 * weighted by MIS (the power heuristic) against the path's own ways to the same light: its sample
 * from that vertex reaching the light vertex's point, whose punctual light is then traced, or
 * whose own ray or sky map sample finds the sky along the sky vertex's arrival. The
 * connection's density per unit area at a point is the pass's first-hit density there
 * (pm_photon_tracer_first_hit_density) x the chance a vertex there is kept x photons per kept
 * vertex; the last is the mean of earlier passes (photons_per_vertex), never of the vertices it
 * weighs, and any fixed stand-in keeps the two ways' weights summing to one. */
typedef struct {
    const pm_light_vertex *vertices;
    uint32_t count;               /* 0: no vertex is joined (the pass only counts the worth) */
    const pm_photon_tracer *tracer;
    float photons_per_vertex;
    const pm_cell_values *worth;  /* how the pass kept vertices (pm_light_vertex_keep) */
    float worth_unit;             /* a connection's worth is counted in these (an integer in the cells) */
    pm_cell_values *worth_next;   /* a table per eye thread, where a share of the connections add their light vertex's worth
                                     (NULL: nowhere): the next passes' keeping */
    int worth_tables;             /* how many: at least the eye pass's threads */
    const uint8_t *pixels;        /* NULL: every pixel's paths join; else only those whose byte is non-zero */
} pm_connections;

typedef struct {
    uint64_t seed;
    int threads;
    int max_specular_depth;   /* specular bounces followed before a path is cut: a safety stop, roulette ends chains first
                                 (PM_DEFAULT_MAX_SPECULAR_DEPTH) */
    const pm_photon_maps *maps; /* NULL: no caustic or indirect component */
    pm_estimate_settings caustic_estimate, global_estimate;
    pm_indirect_mode indirect;
    pm_gather_source gather_source; /* progressive, final gathering: photons or the path tracer (above) */
    /* with PM_GATHER_PATH: the path's first non-specular vertex past the visible point is a gather
     * point all the same, where the photons of light no path finds are read (PM_PATH_PUNCTUAL_SPECULAR:
     * a punctual light's, past a mirror or glass first) */
    bool gather_punctual_specular;
    int gather_rays;          /* final-gather rays per eye sample at the first diffuse hit */
    bool view_photons;        /* show the maps' estimates at the first diffuse hit, no shadow rays */
    bool path_trace;          /* the path tracer (--mode pathtrace): maps are ignored, see pm_eye_iterate */
    /* with path_trace: the light a progressive visible point's continuation leaves to the caustic
     * photons (met through specular and near-specular bounces between a path's first non-specular
     * vertex and its second) goes to the caustic component whatever the first vertex was: the
     * caustic trial's measure of what those photons would carry (progressive.c) */
    bool caustic_apart;
    const pm_shadow_map *shadow; /* shadow photons; NULL: every punctual light sample casts its shadow ray */
    const pm_connections *connections; /* light vertices the path tracer's samples join (above); NULL: none */
    /* where the sky is seen from (arrival.h): direct light's sky sample where it is learned, and
     * every diffuse vertex's own ray that reaches the sky counts there; NULL: none */
    pm_arrival_guide *sky_arrival;
    bool unclipped;           /* classic estimates read their whole disc, through walls (no clip.h): only to measure what clipping mends */
    double deadline;          /* CLOCK_MONOTONIC seconds (0 = none): tiles not started by then are left out (see above) */
    const uint8_t *only_pixels; /* NULL: every pixel; else only the pixels whose byte is non-zero are traced (a
                                   measurement's sparse pixels, progressive.c); the others keep their sums */
} pm_eye_settings;

typedef struct {
    uint64_t rays;            /* closest-hit + shadow rays cast */
    double seconds;
    uint64_t dropped_samples; /* component samples that were NaN or infinite, left out of the film */
    uint64_t path_vertices;   /* path tracer: surfaces its paths met (for the mean path length) */
    uint64_t shadow_rays;     /* shadow rays toward light samples (punctual, emitter, sky map), among rays: direct light's, and from sharp glossy lobes on gather paths */
    uint64_t shadow_rays_saved; /* punctual light samples that shadow photons decided without a ray */
    uint64_t sky_arrival_samples; /* the sky's samples drawn from the arrival guide (arrival.h), among shadow_rays */
    uint64_t connections;     /* light vertices drawn to join (eye.h, connections) */
    uint64_t connection_rays; /* ... their shadow rays, among rays */
    bool failed;              /* out of memory: the pass did not run */
} pm_eye_stats;

/* A point waiting for photons (progressive mode): where an eye path, or the gather ray of one,
 * first met a diffuse or glossy surface. */
typedef struct {
    vec3 p;
    vec3 n;               /* geometric normal on the side the path arrived from */
    vec3 weight;          /* Lambert: path throughput x kd / pi, turns an irradiance estimate into radiance;
                             glossy: the path throughput, the lobe is evaluated per photon */
    bool glossy;          /* brdf, ns and wo hold the glossy lobe seen from wo */
    pm_brdf brdf;
    vec3 ns, wo;          /* shading normal on wo's side; unit direction toward the eye (or the gather ray's origin) */
    float path_length;    /* from the camera (or the gather ray's origin), for the pixel footprint */
    uint32_t tri;         /* the triangle it lies on (its curvature bounds a first radius) */
    bool seen_directly;   /* first eye vertex (caustic / indirect components), else through specular bounces */
    bool valid;
} pm_visible_point;

/* How shut in the view is. view_fraction: of cosine rays from the surfaces a grid of camera rays
 * sees (a camera ray that misses counts as open), the fraction that hit geometry: near 1 in a
 * room, low around a model in open space. around_fraction: of rays from the camera's position
 * in all directions, the fraction that hit geometry (1 = the camera is shut in). */
void pm_eye_enclosure(const pm_scene *s, const pm_accel *a, const pm_camera *cam, float aspect, float *view_fraction,
                      float *around_fraction);

/* Adds one jittered sample per pixel (iteration number `iteration`) to the film.
 *
 * With settings->path_trace, each sample is an unbiased path-traced estimate. At every diffuse or
 * glossy vertex it adds direct light by next-event estimation (the same direct_light() the other
 * modes call: punctual lights, an emissive triangle picked by power and the sky map, combined by
 * multiple importance sampling with a ray from the material's own sampling), then continues along
 * that same ray (cosine or the glossy lobe: one traced segment serves both); the choice of part, its
 * sampling and the survival are the path-vertex kernel's (vertex.h), as for every eye path and photon.
 * Emission and the sky are counted where a segment meets them only when no light sampling could
 * have found them: on the camera ray and after a specular bounce (after a diffuse or glossy bounce
 * the vertex's direct light already holds them). Russian roulette is vertex.h's one rule from the
 * surface of index PM_EYE_ROULETTE_VERTEX (from 0) on (survival min(PM_MAX_SURVIVAL, the bounce's
 * mean weight), the weight divided by it); paths stop at PM_PATHTRACE_MAX_VERTICES as a safety. Components, by the first eye
 * vertex as in the photon modes: direct = emission and sky seen by the camera ray + direct light at
 * a first-hit diffuse vertex; specular = everything behind a first-hit specular vertex; caustic =
 * light the continuation from a first-hit diffuse vertex x1 finds through one or more specular
 * bounces and no other diffuse vertex (E D S+ L, the eye side of the caustic photons' L S+ D);
 * indirect = everything found after a second diffuse vertex (E D ... D ... L, which the photon modes
 * gather from the global map at the second diffuse vertex). Punctual lights are points or
 * directions: their light through mirrors or glass (an L S+ D caustic, or a light seen in a mirror)
 * cannot be found by a path from the eye and is missing, as in any path tracer; the photon modes
 * have it. */
/* False when out of memory (the film untouched, stats->failed set when stats is given); a
 * cancelled pass returns true and adds nothing. */
bool pm_eye_iterate(const pm_scene *s, const pm_accel *a, const pm_camera *cam, const pm_eye_settings *settings,
                    uint32_t iteration, pm_film *film, pm_eye_stats *stats);

/* The progressive mode's eye pass: one jittered sample per pixel followed through specular
 * bounces to its first diffuse point; emission and direct light there are added to the film's
 * sums. With gather_points, one gather ray from each visible point (the ray direct light drew from
 * the material there, cosine or glossy lobe) finds the point its final gather reads, through
 * mirrors, glass and sharp glossy lobes, and adds the punctual lights' direct light there (shadow
 * rays, as at the visible point) as the visible point's indirect light; past a sharp lobe the
 * light it meets, and a shadow ray from the lobe to each punctual light, go to the film as the
 * visible point's indirect light
 * (see walk_to_diffuse in eye.c for when it does not go on). With settings->gather_source
 * PM_GATHER_PATH the path tracer goes on from the visible point instead and its light goes to the
 * film as the visible point's indirect light; its first non-specular vertex is the gather point
 * with settings->gather_punctual_specular, and none is made without. Each tile's
 * points go to visit (when not NULL) at the end of the tile, on the thread that traced them: the
 * caller gathers this iteration's photons there while the points are still in cache, and no
 * per-pixel point array exists. pixels[k] is the film index of visible[k] (and gathered[k], NULL
 * without gather_points); an invalid point found no diffuse surface. The film's sample count is
 * left to the caller, and so is the rest of a cancelled iteration: first_of_iteration makes the
 * pass save each tile's pixels (visit's writes included) before it writes them, so that a cancel
 * in this pass puts its tiles back itself, and a cancel in a later pass of the iteration leaves
 * the caller to restore the whole film (pm_film_restore_rect). Cut by the deadline, the pixels
 * the pass reached are marked `reached` (PM_FILM_AHEAD_*: its sample, and the photon pass when
 * visit updated their statistics). */
typedef enum {
    PM_EYE_PASS_WHOLE,     /* every pixel got its sample */
    PM_EYE_PASS_CUT,       /* the deadline stopped it: the pixels reached are marked */
    PM_EYE_PASS_CANCELLED, /* the cancel flag stopped it: see above for what is put back */
    PM_EYE_PASS_FAILED     /* out of memory: nothing ran (stats->failed) */
} pm_eye_pass_result;
typedef void (*pm_visible_points_fn)(void *ctx, const size_t *pixels, const pm_visible_point *visible,
                                     const pm_visible_point *gathered, size_t count, int thread);
pm_eye_pass_result pm_eye_visible_points(const pm_scene *s, const pm_accel *a, const pm_camera *cam,
                                         const pm_eye_settings *settings, uint32_t iteration, pm_film *film,
                                         bool gather_points, pm_visible_points_fn visit, void *ctx, unsigned reached,
                                         bool first_of_iteration, pm_eye_stats *stats);

#endif

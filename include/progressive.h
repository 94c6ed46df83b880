/* progressive.h: stochastic progressive photon mapping (the default mode): per-iteration eye and photon passes, shrinking radii, constant memory.
 *
 * Each iteration, in named phases as pbrt-v4's SPPM:
 *   1. photon pass: a fresh set of global photons, and of caustic photons aimed by projection
 *      maps, each pass carrying the lights' whole flux, sorted into hash grids; every caustic
 *      photon stored where the camera sees its surface is also connected to the camera, and the
 *      radiance it adds to that pixel is splatted (light tracing: the caustic seen directly);
 *   2. eye pass: a fresh jittered sample per pixel is followed through mirrors and glass to its
 *      first diffuse point (the visible point); emission and direct light (shadow rays) go to
 *      the film as in the classic mode; with final gathering, the gather ray (the surface's own
 *      sample that direct light traced) finds a gather point, whose light from punctual lights
 *      is traced the same way (the visible point's indirect light);
 *   3. gather, tile by tile inside the eye pass: every visible point collects the new photons
 *      within its pixel's radius and updates the pixel's statistics (Hachisuka and Jensen 2009):
 *          N' = N + alpha M,  R'^2 = R^2 (N + alpha M) / (N + M),  tau' = (tau + Phi) R'^2 / R^2
 *      with caustic (seen through mirrors and glass; seen directly only when splats are off) and
 *      indirect photons in separate statistics; a gather point instead makes an independent
 *      estimate (from every photon but a punctual light's first hits) with a radius shared by
 *      all pixels that shrinks with the iteration count,
 *      r_{i+1}^2 = r_i^2 (i + alpha) / (i + 1) (Knaus and Zwicker 2011).
 *   4. steps 2 and 3 may run K times on the same photons (K eye passes, each a sample per pixel;
 *      statistics updated by the first, splats weighed by K): K = --eye-passes, or chosen each
 *      iteration by a noise probe that weighs the noise eye passes average against the noise only
 *      photons do, and their costs in rays (see choose_eye_passes in progressive.c).
 * The film resolves a pixel's photon part as tau / (pi R^2 photon passes), its splats and gather
 * estimates as their mean over samples.
 *
 * The first iteration after a start or a restart emits PM_PPM_FIRST_PHOTON_FRACTION of the
 * photons: it is the one a user waits for.
 *
 * An iteration may be stopped by the calling thread's cancel flag (parallel.h) anywhere: it is
 * then taken back whole, the film's sums and statistics (radii, photon counts, tau), its counts,
 * the radii and density estimates, the noise probe, the guide and its marks and the stats all as
 * before it, so the next iteration is the cancelled one again, with the same seeds (eye.h). The
 * deadline instead cuts the photon pass (fewer photons, rescaled) and an eye pass after the
 * film's first (eye.h): a cut eye pass is the iteration's last, the pixels it reached marked in
 * the film (its sample, and the photon pass when it was the pass that updates the statistics).
 * The camera splats go to the film after the eye passes, each weighed by the samples its pixel
 * got in the iteration.
 *
 * Memory stops growing after the first iterations (the photon buffers keep the largest
 * iteration's size): the statistics in the film, one iteration's photons and splats, and one
 * tile's points per thread. Restarting (a camera move) clears per-pixel state only.
 */
#ifndef PM_PROGRESSIVE_H
#define PM_PROGRESSIVE_H

#include <stdbool.h>
#include <stdint.h>
#include "accel.h"
#include "eye.h"
#include "film.h"
#include "photonmap.h"
#include "scene.h"

/* --gather: where final gathering takes the visible point's indirect light from (pm_gather_source,
 * eye.h). AUTO (the default): both are measured over the first iterations and the one predicted
 * to err less at equal cost is kept (pm_progressive_iterate); PHOTONS or PATH force one. */
typedef enum { PM_GATHER_AUTO = 0, PM_GATHER_FORCE_PHOTONS = 1, PM_GATHER_FORCE_PATH = 2 } pm_gather_choice;
typedef enum { PM_CONNECT_AUTO = 0, PM_CONNECT_FORCE_ON = 1, PM_CONNECT_FORCE_OFF = 2 } pm_connect_choice;

typedef struct {
    uint64_t seed;
    int threads;
    uint64_t photons;          /* global photons emitted per iteration (0: no global pass) */
    uint64_t caustic_photons;  /* caustic photons emitted per iteration (0: no caustic pass) */
    double alpha;              /* radius reduction, in (0, 1) */
    double initial_radius;     /* scene units; 0 = from the pixel footprint and the first photon density */
    pm_indirect_mode indirect; /* photons: read at the visible point; gather: one final-gather bounce */
    pm_gather_choice gather;   /* with final gathering: the source of its light, chosen per scene (auto) or forced (see eye.h) */
    int max_specular_depth;
    int max_photon_bounces;
    bool caustic_by_statistics; /* the caustic seen directly from visible-point statistics, no camera splats (to compare) */
    double first_photon_fraction; /* share of the photons the first iteration after a start or a restart emits; 0 = PM_PPM_FIRST_PHOTON_FRACTION */
    int eye_passes;            /* eye passes reading each photon pass; 0 = automatic (from the rays of both, see pm_progressive_iterate) */
    uint32_t radius_steps;     /* radius reductions an iteration makes (0 or 1: one); under mpirun the rank count, so that the
                                  radii of each rank shrink with the job's iterations, as one process's would, not with its own */
    bool unclipped;            /* estimates read their whole disc, through walls (no clip.h): only to measure what clipping costs and mends */
    bool unguided;             /* photons emitted without the learned guide (guide.h), the sky sampled without its arrival
                                  guide (arrival.h): only to measure what guiding gains */
    pm_connect_choice connect; /* where the path tracer's light is chosen: its samples join light vertices (eye.h), measured or forced */
    /* the caustic photons stay wherever they are traced, with no caustic trial (progressive.c):
     * under mpirun, where a rank that gave them up would dilute the others' caustic statistics in
     * the merge (each rank's photon passes count in every pixel's) */
    bool caustics_kept;
} pm_progressive_settings;

typedef struct {
    uint32_t iterations;       /* samples per pixel: eye passes */
    uint32_t photon_passes;
    pm_eye_stats eye;
    pm_photon_stats photons;   /* totals over the run (their kdtree_seconds stays 0: this mode has no kd-tree) */
    double grid_seconds;       /* sorting each iteration's photons into the hash grids */
    double gather_seconds;
    uint64_t photons_found;    /* photons that fell inside a visible or gather point's disc */
    uint64_t photons_examined; /* photons within a disc's radius that its surface and clip tests ran on */
    uint64_t disc_queries;     /* discs queried (visible points' statistics and gather points' estimates), each with its clip */
    uint64_t splats;           /* caustic photons splatted to the camera */
    uint64_t clip_rays;        /* rays the clips' probes cast (clip.h) */
    uint64_t photons_stored;   /* photon records the passes stored */
    uint64_t photons_read;     /* ... of which some estimate counted (the useful ones) */
    /* the final gather's source, chosen per scene (pm_progressive_iterate): -1 while learning or
     * without final gathering, else a pm_gather_source; the predicted relMSE of each at the choice's
     * horizon, the photon gather's squared relative bias then, and each one's cost per iteration */
    int gather_source;
    double choice_relmse[2], choice_bias2, choice_cost[2];
    uint32_t choice_iterations;  /* learning iterations probed before the choice, both sources */
    uint32_t path_only_samples;  /* samples taken as the path tracer's eye pass alone, the choice made (progressive.c, begin_iteration) */
    uint64_t light_vertices;     /* light vertices the path iterations' passes kept for connections (eye.h) */
    uint32_t sky_arrival_cells;  /* the sky's arrival guide's cells that direct light samples (arrival.h) */
    /* the connections' trial (progressive.c): -1 none run, 0 connections left off, 1 kept; each
     * arm's predicted error x cost and its cost per iteration (CONNECT_ON, CONNECT_OFF) */
    int connect_trial;
    double connect_trial_error[2], connect_trial_cost[2];
    /* the caustic trial (progressive.c): -1 none run, 0 the caustic photons kept, 1 given up for the
     * path tracer's loop; each arm's predicted error x cost and its cost per iteration */
    int caustic_trial;
    double caustic_trial_error[2], caustic_trial_cost[2];
    double choice_caustic_share; /* of the light the photons' measuring iterations gathered at the probed pixels'
                                  * gather points, the share that came off a mirror or glass last (0: none measured) */
} pm_progressive_stats;

/* Radii over the pixels whose statistics have started (scene units). */
typedef struct {
    double initial_mean;       /* mean initial radius */
    double mean, min, max;     /* now, over every statistics slot in use */
    double gather;             /* the final-gather radius of the next iteration (0 without gathering) */
    uint64_t pixels;
} pm_radius_summary;

typedef struct pm_progressive pm_progressive;

/* The automatic photon count per iteration: PM_PPM_PHOTONS_PER_PIXEL per pixel, clamped. */
uint64_t pm_progressive_default_photons(int width, int height);

/* NULL with err set when out of memory. The camera is copied. */
pm_progressive *pm_progressive_create(const pm_scene *s, const pm_accel *a, const pm_camera *camera,
                                      const pm_progressive_settings *settings, char *err, size_t err_size);
void pm_progressive_destroy(pm_progressive *p);
/* Which film components this mode can make non-zero for the scene (what the film should hold). */
void pm_progressive_components(const pm_progressive *p, bool enabled[PM_COMPONENT_COUNT]);
/* Allocates the per-pixel state for a film made with those components. */
bool pm_progressive_bind(pm_progressive *p, pm_film *film, char *err, size_t err_size);
/* One iteration: a photon pass (caustic and global photons) and the eye passes that gather from
 * it, each adding a sample per pixel to the film: --eye-passes of them, or automatically 1 to
 * PM_PPM_MAX_EYE_PASSES, more where a photon pass costs more rays than an eye pass; at most
 * max_samples (0: no limit). False when out of memory; a cancelled iteration (taken back whole,
 * see above) returns true. */
bool pm_progressive_iterate(pm_progressive *p, pm_film *film, uint32_t max_samples);
/* Starts again from nothing (a new camera, or the same one): clears the film and per-pixel
 * state; allocates nothing. */
void pm_progressive_restart(pm_progressive *p, pm_film *film, const pm_camera *camera);
/* A time budget's end (CLOCK_MONOTONIC seconds, 0 = none): photon passes running past it are
 * cut short (see pm_photon_tracer_set_deadline), and so are eye passes after the film's first,
 * between tiles (eye.h). */
void pm_progressive_set_deadline(pm_progressive *p, double deadline);
/* Shadow photons for direct light at the visible points (NULL: shadow rays only); the map must
 * outlive its use. */
void pm_progressive_set_shadow_map(pm_progressive *p, const pm_shadow_map *m);
const pm_progressive_stats *pm_progressive_get_stats(const pm_progressive *p);
pm_radius_summary pm_progressive_radii(const pm_progressive *p, const pm_film *film);
/* Whether this scene needs any photon pass at all. */
bool pm_progressive_uses_photons(const pm_progressive *p);
/* Photons a whole iteration emits, over the passes the scene uses (the first iteration after a
 * start or a restart emits PM_PPM_FIRST_PHOTON_FRACTION of them). */
uint64_t pm_progressive_photons_per_iteration(const pm_progressive *p);
/* The eye passes the next iteration will run per photon pass (before any max_samples cut). */
uint32_t pm_progressive_eye_passes(const pm_progressive *p);

/* Share of the caustic lights' emission the projection maps kept (0 without caustic photons). */
double pm_progressive_projection_fraction(const pm_progressive *p);

#endif

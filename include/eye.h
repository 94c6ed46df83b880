/* eye.h: the eye pass: rays from the camera, jittered in each pixel, split into the four components at the first hit.
 *
 * Component rule (by the first eye vertex): `direct` is emission seen at the first hit plus
 * direct light (shadow rays) at a first-hit diffuse surface; `specular` is everything that
 * reaches the eye through one or more specular bounces; `caustic` and `indirect` are the
 * photon estimates at a first-hit diffuse surface (black until a photon pass supplies maps).
 * One iteration adds one sample per pixel to the film, on all threads, tile by tile; every
 * sample's random stream depends on (seed, iteration, pixel) only.
 */
#ifndef PM_EYE_H
#define PM_EYE_H

#include <stdint.h>
#include "accel.h"
#include "film.h"
#include "photonmap.h"
#include "scene.h"

typedef enum { PM_INDIRECT_GATHER = 0, PM_INDIRECT_PHOTONS = 1 } pm_indirect_mode;

typedef struct {
    uint64_t seed;
    int threads;
    int max_specular_depth;   /* specular bounces followed before a path is cut */
    const pm_photon_maps *maps; /* NULL: no caustic or indirect component */
    pm_estimate_settings caustic_estimate, global_estimate;
    pm_indirect_mode indirect;
    int gather_rays;          /* final-gather rays per eye sample at the first diffuse hit */
    bool view_photons;        /* show the maps' estimates at the first diffuse hit, no shadow rays */
} pm_eye_settings;

typedef struct {
    uint64_t rays;            /* closest-hit + shadow rays cast */
    double seconds;
    uint64_t dropped_samples; /* component samples that were NaN or infinite, left out of the film */
} pm_eye_stats;

/* Builds the camera ray through film position (x, y) in pixels (0,0 = top-left corner). */
void pm_camera_ray(const pm_camera *c, int width, int height, float x, float y, vec3 *origin, vec3 *dir);

/* Adds one jittered sample per pixel (iteration number `iteration`) to the film. */
void pm_eye_iterate(const pm_scene *s, const pm_accel *a, const pm_camera *cam, const pm_eye_settings *settings,
                    uint32_t iteration, pm_film *film, pm_eye_stats *stats);

#endif

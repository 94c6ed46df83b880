/* arrival.h: the sky's arrival guide: per cell of space and side, the directions the sky was seen from there, from which direct light draws a sample of the sky.
 *
 * In a room lit through a window, a point sees the sky through the opening alone: the surface's
 * own ray (cosine-distributed on Lambert) leaves through it seldom, and a sample of the sky's
 * map, which knows nothing of the walls, as seldom. The default mode learns, while it renders,
 * where the sky is seen from each cell: every own ray of a diffuse vertex that reaches the sky
 * counts in its cell's bin of directions. Cosine-distributed, those counts times the sky's
 * radiance are proportional to the radiance x cosine x visibility that a diffuse surface's sky
 * sample wants (the guiding of Vorba et al. 2014 and Mueller et al. 2017, here for direct light
 * from the sky alone).
 *
 * A cell is PM_ARRIVAL_CELL of the connections' cell, on one of six sides (the axis direction
 * nearest the surface's normal, toward the light), hashed into PM_ARRIVAL_SLOTS slots where two
 * cells that meet share: a slot's counts are integers added atomically, so they and the image do
 * not depend on the thread count. Its directions are PM_ARRIVAL_BINS_SIDE^2 bins of equal solid
 * angle (pm_sample_sphere's squares). A slot is used once PM_ARRIVAL_MIN_HITS rays reached the
 * sky there and its light is concentrated, its bins' probabilities' squares summing to at least
 * PM_ARRIVAL_CONCENTRATION over the bins' count (an open floor under the sky reads 2.7, a point
 * seeing the sky through a window tens): elsewhere the own ray finds the sky as well and the
 * extra shadow ray would not pay. The sample is weighted against the own ray (and the sky map's
 * sample, and a connection) by the power heuristic, so whatever the guide misses the own ray
 * still finds: the estimate is unbiased whatever was learned.
 *
 * The eye passes count and read the distributions made before them (pm_arrival_finish, between
 * iterations): what they sample does not change under them.
 */
#ifndef PM_ARRIVAL_H
#define PM_ARRIVAL_H

#include <stdbool.h>
#include <stdint.h>
#include "defaults.h"
#include "pm_math.h"

#define PM_ARRIVAL_BINS (PM_ARRIVAL_BINS_SIDE * PM_ARRIVAL_BINS_SIDE)

typedef struct {
    uint32_t *counts;               /* PM_ARRIVAL_SLOTS x PM_ARRIVAL_BINS: rays that reached the sky */
    uint32_t *hits;                 /* per slot, their sum */
    uint32_t *hits_made;            /* per slot, the hits its distribution was made from */
    float *cdf;                     /* PM_ARRIVAL_SLOTS x (PM_ARRIVAL_BINS + 1), made where usable */
    uint8_t *usable;                /* per slot */
    uint64_t *touched;              /* a bit a slot: counted since the last pm_arrival_finish */
    float bin_radiance[PM_ARRIVAL_BINS]; /* the sky's luminance at each bin's middle: the counts' weights */
    float cell, inv_cell;
    uint32_t usable_count;
} pm_arrival_guide;

/* A slot found usable (pm_arrival_find): its distribution; cdf NULL: none. */
typedef struct {
    const float *cdf;
} pm_arrival_cell;

/* A guide of cells of this size, its bins weighted by the sky's luminance along their middle
 * directions, as luminance(ctx, direction) gives it; false when out of memory. */
bool pm_arrival_init(pm_arrival_guide *g, float cell, float (*luminance)(const void *ctx, vec3 w), const void *ctx);
void pm_arrival_free(pm_arrival_guide *g);
/* Forgets what was learned and sets the cell size. */
void pm_arrival_clear(pm_arrival_guide *g, float cell);
/* Counts a ray of a diffuse vertex at p (ng on the side the ray leaves) that reached the sky along
 * w (several threads may count at once). */
void pm_arrival_count(pm_arrival_guide *g, vec3 p, vec3 ng, vec3 w);
/* Makes the distributions of the slots counted in since the last call, and decides which are
 * usable. Alone: no eye pass may run. */
void pm_arrival_finish(pm_arrival_guide *g);
/* The usable distribution at p on the side ng faces; false where none. */
bool pm_arrival_find(const pm_arrival_guide *g, vec3 p, vec3 ng, pm_arrival_cell *c);
/* Draws a direction from a usable cell: *pdf per steradian. */
vec3 pm_arrival_sample(const pm_arrival_cell *c, float u_bin, float u1, float u2, float *pdf);
/* The density per steradian of c's sample along w (0 for a NULL cell or one without a distribution). */
float pm_arrival_pdf(const pm_arrival_cell *c, vec3 w);

#endif

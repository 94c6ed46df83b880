/* guide.h: photons sent where the camera looks: marks of where estimates read photons, and an emission guide per light learned from them.
 *
 * Most photons of a sun or a sky land where no camera point ever reads them (outside the room a
 * window lights). The progressive mode learns, iteration after iteration, which emissions pay:
 *   - the marks are a hashed bit set over space: the eye pass marks the cell of every point that
 *     reads global photons (gather points, or visible points without final gathering), the cell
 *     twice the radius it reads with, and that cell on the side its surface faces (one of six
 *     axis directions). A global pass counts a record useful in a marked cell on either side;
 *     a light vertex pass (photonmap.h) a first hit on its own side, so a first hit on a roof or
 *     under a floor does not count for the ceiling or the floor a few centimetres away (see
 *     count_useful in photonmap.c for why the global pass keeps either side);
 *   - the guide splits the two random numbers that place a guided source's photon (the start on
 *     the disc across the scene for a directional light and the sky, the direction for a point
 *     or spot light; the sky's direction and start, each apart) into PM_GUIDE_CELLS x PM_GUIDE_CELLS
 *     cells, and counts per cell the photons emitted and their hits in marked cells; a cell's
 *     learned probability is its share of the useful hits per photon.
 * A photon draws all its guided numbers uniformly with probability PM_GUIDE_UNIFORM, else each
 * from its learned distribution, and carries its power divided by that mixture's density (against
 * the uniform's): every emission the unguided pass could make stays possible, the estimate is
 * unbiased whatever was learned, and no weight exceeds 1 / PM_GUIDE_UNIFORM (a defensive mixture
 * over the whole photon: mixing each number apart, the sky's two would multiply their weights to
 * 1 / PM_GUIDE_UNIFORM^2, and such rare heavy photons leave a finite run looking dark). Counts are
 * integers summed over threads, so the guide, like the image, does not depend on the thread count.
 */
#ifndef PM_GUIDE_H
#define PM_GUIDE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "defaults.h"
#include "pm_math.h"

/* ---- the cells of space the marks, the cell values and the sky's arrival guide (arrival.h) hash ---- */
static inline int32_t pm_cell_coord(float x, float inv_cell) {
    float c = x * inv_cell;
    c = c < -1e9f ? -1e9f : (c > 1e9f ? 1e9f : c);
    int32_t i = (int32_t)c;
    return i - (c < (float)i);
}

/* p's cell's coordinates folded into one word, before mixing (pm_cell_mix). */
static inline uint32_t pm_cell_key(vec3 p, float inv_cell) {
    uint32_t x = (uint32_t)pm_cell_coord(p.x, inv_cell), y = (uint32_t)pm_cell_coord(p.y, inv_cell), z = (uint32_t)pm_cell_coord(p.z, inv_cell);
    return (x * 73856093u) ^ (y * 19349663u) ^ (z * 83492791u);
}

/* A key mixed so that its low bits index a table of 2^k entries. */
static inline uint32_t pm_cell_mix(uint32_t h) {
    h ^= h >> 15;
    h *= 0x2c1b3c6du;
    h ^= h >> 12;
    return h;
}

/* The hash of p's cell, for a table of 2^k entries: its low k bits. */
static inline uint32_t pm_cell_hash(vec3 p, float inv_cell) { return pm_cell_mix(pm_cell_key(p, inv_cell)); }

/* Which of the six axis directions n is nearest: 0-5 (+x, -x, +y, -y, +z, -z). */
static inline uint32_t pm_axis_side(vec3 n) {
    float ax = fabsf(n.x), ay = fabsf(n.y), az = fabsf(n.z);
    return ax >= ay && ax >= az ? (n.x < 0.f) : ay >= az ? 2u + (n.y < 0.f) : 4u + (n.z < 0.f);
}

/* ---- marks ---- */
typedef struct {
    uint64_t *bits;      /* PM_GUIDE_MARK_BITS bits: cells */
    uint64_t *facing_bits; /* as many: cells on one side (pm_marks_test_facing) */
    float cell, inv_cell;
    bool any;            /* some cell is marked */
} pm_marks;

bool pm_marks_init(pm_marks *m);
void pm_marks_free(pm_marks *m);
/* Forgets every mark and sets the cell size for the next ones. */
void pm_marks_clear(pm_marks *m, float cell);
/* Marks p's cell, and p's cell on the side n faces: the geometric normal on the side light
 * arrives from (several threads may mark at once). */
void pm_marks_set(pm_marks *m, vec3 p, vec3 n);
/* Whether p's cell is marked, on any side. */
bool pm_marks_test(const pm_marks *m, vec3 p);
/* Whether p's cell is marked on the side n faces. */
bool pm_marks_test_facing(const pm_marks *m, vec3 p, vec3 n);

/* ---- cell values: per cell, how many values were added and their sum, hashed as the marks are;
 * integers, so that the sums do not depend on the order tables are merged in. A table has one
 * writer: threads add to tables of their own, merged into one when their work is whole ---- */
#define PM_CELL_VALUES_BLOCK 64 /* cells a bit of `touched` stands for */
typedef struct {
    uint32_t *count;     /* PM_CELL_VALUES_CELLS each */
    uint64_t *sum;
    float cell, inv_cell;
    double total_sum, total_count, mean; /* over all cells (pm_cell_values_merge): the sums, and the mean value */
    /* the blocks of cells added to since the last merge or drop, so that these visit no others */
    uint64_t touched[PM_CELL_VALUES_CELLS / PM_CELL_VALUES_BLOCK / 64];
} pm_cell_values;

bool pm_cell_values_init(pm_cell_values *v);
void pm_cell_values_free(pm_cell_values *v);
/* Forgets every value and sets the cell size. */
void pm_cell_values_clear(pm_cell_values *v, float cell);
/* Adds a value to p's cell (a full counter stays full). */
void pm_cell_values_add(pm_cell_values *v, vec3 p, uint32_t value);
/* p's cell's mean value; false where none was added. */
bool pm_cell_values_mean(const pm_cell_values *v, vec3 p, float *mean);
/* Adds from's values to into's (both of one cell size), empties from, and sets into's mean.
 * Visits only the blocks of from's cells that were added to. */
void pm_cell_values_merge(pm_cell_values *into, pm_cell_values *from);
/* Empties v as pm_cell_values_merge does, its values dropped. */
void pm_cell_values_drop(pm_cell_values *v);

/* ---- the emission guide ---- */
#define PM_GUIDE_CELL_COUNT (PM_GUIDE_CELLS * PM_GUIDE_CELLS)

typedef struct {
    uint32_t sources;            /* guided sources, at most PM_GUIDE_MAX_SOURCES */
    float *cdf;                  /* per source, PM_GUIDE_CELL_COUNT + 1 entries */
    uint32_t *cut;               /* per source, the cdf's PM_GUIDE_CELL_COUNT cut points (pm_cdf_cut_points) */
    uint64_t *emitted, *useful;  /* per source and cell, summed over the run */
} pm_guide;

bool pm_guide_init(pm_guide *g, uint32_t sources);
void pm_guide_free(pm_guide *g);
/* Copies src's distribution and counts into dst, both initialised for as many sources. */
void pm_guide_copy(pm_guide *dst, const pm_guide *src);
/* Back to uniform, the counts forgotten (a restart). */
void pm_guide_reset(pm_guide *g);
/* Draws a cell of source s's learned distribution with u_cell, and places u1, u2 (uniform in
 * [0, 1)) within it; returns the cell. */
uint32_t pm_guide_pick(const pm_guide *g, uint32_t s, float u_cell, float *u1, float *u2);
/* The cell two numbers in [0, 1) fall in. */
uint32_t pm_guide_cell_of(float u1, float u2);
/* The learned density of source s at a cell, against the uniform's 1. A photon whose guided
 * numbers were drawn with probability PM_GUIDE_UNIFORM all uniformly, else all from their
 * sources' learned distributions, has the density PM_GUIDE_UNIFORM + (1 - PM_GUIDE_UNIFORM) x the
 * product of these (at least PM_GUIDE_UNIFORM: its weight is at most 1 / PM_GUIDE_UNIFORM). */
double pm_guide_density(const pm_guide *g, uint32_t s, uint32_t cell);
/* Adds a pass's counts (per source and cell) and draws the probabilities anew from all so far. */
void pm_guide_learn(pm_guide *g, const uint32_t *emitted, const uint32_t *useful);

#endif

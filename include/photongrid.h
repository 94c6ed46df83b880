/* photongrid.h: a hashed uniform grid over one iteration's photons, rebuilt every iteration, for fixed-radius gathers.
 *
 * The progressive mode gathers with known radii, so it needs no k-nearest search: photons are
 * counting-sorted by the hash of their cell (cell size from the radii that will query it, as
 * in SmallVCM), and a query visits the few cells its disc overlaps. Buffers grow to the largest
 * iteration and are then reused: memory stays flat however long the run.
 */
#ifndef PM_PHOTONGRID_H
#define PM_PHOTONGRID_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "brdf.h"
#include "clip.h"
#include "photon.h"

typedef struct {
    pm_photon *photons;     /* sorted by bucket */
    uint32_t *bucket_start; /* bucket_count + 1 offsets into photons */
    uint64_t *occupied;     /* a bit per bucket: holds a photon */
    uint8_t *read;          /* a mark per photon (in sorted order): some query counted it */
    size_t count, capacity;
    size_t bucket_count, bucket_capacity; /* bucket_count is a power of two */
    vec3 origin, upper;     /* the photons' bounds: a disc outside them finds nothing without a lookup */
    int32_t top[3];         /* the cell of upper: every photon's cell lies in [0, top] on each axis */
    float cell, inv_cell;
} pm_photon_grid;

/* Sorts count photons into the grid with the given cell size (> 0). False when out of memory
 * (the grid is then empty); empty too, and true, when the calling thread's cancel flag
 * (parallel.h) stops it. */
bool pm_photon_grid_build(pm_photon_grid *g, const pm_photon *photons, size_t count, float cell);
void pm_photon_grid_free(pm_photon_grid *g);
/* The photons some query has counted since the grid was built: the useful ones. */
size_t pm_photon_grid_read_count(const pm_photon_grid *g);

/* Whether a disc of that radius around p may hold any photon: false when it lies outside the
 * photons' bounds or meets only empty cells (a cheap look at the grid, no photon read). */
bool pm_photon_grid_may_find(const pm_photon_grid *g, vec3 p, float radius2);

/* The summed power and count of the photons within sqrt(radius2) of p that pm_photon_counts_for
 * a surface facing n with that path mask. */
uint32_t pm_photon_grid_sum_facing(const pm_photon_grid *g, vec3 p, vec3 n, float radius2, unsigned path_mask,
                                   vec3 *power);
/* One disc query of a batch: lobe NULL for the plain sum (pm_photon_grid_sum_facing), else the
 * same photons, each one's power times the lobe's f(wo, wi) for the direction wi it arrived from
 * (ns: the shading normal on wo's side; Jensen's estimate at a glossy point); clip NULL for the whole disc,
 * else only the photons it keeps count (the caller divides by the kept area). */
typedef struct {
    vec3 p, n;
    float radius2;
    unsigned path_mask;
    const pm_brdf *lobe;
    vec3 ns, wo;
    const pm_clip *clip;
} pm_grid_query;
typedef struct {
    vec3 power;
    uint32_t found;
    uint32_t inside;   /* photons within the radius the surface and clip tests then ran on (found or not): the query's work */
} pm_grid_result;
/* The same sums for count queries (out[k] for q[k]), faster than one by one: the memory reads of
 * several queries overlap. Each result is bit for bit the single query's. */
void pm_photon_grid_sum_many(const pm_photon_grid *g, const pm_grid_query *q, size_t count, pm_grid_result *out);

#endif

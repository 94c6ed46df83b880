/* kdtree.h: a balanced kd-tree over photon records, built in parallel, with k-nearest and fixed-radius queries.
 *
 * Implicit layout: the photons are reordered so that no pointers are stored; one byte per
 * photon keeps the split axis. Queries never allocate.
 */
#ifndef PM_KDTREE_H
#define PM_KDTREE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "photon.h"

typedef struct {
    pm_photon *photons;   /* owned, reordered into tree order */
    uint8_t *axis;        /* split axis per node (0, 1, 2; 3 = leaf) */
    size_t count;
} pm_kdtree;

/* Takes ownership of photons (malloc'ed). threads >= 1. Returns false only when out of memory
 * (photons are then freed too). */
bool pm_kdtree_build(pm_kdtree *t, pm_photon *photons, size_t count, int threads);
void pm_kdtree_free(pm_kdtree *t);
size_t pm_kdtree_bytes(const pm_kdtree *t);

/* The k photons nearest p with squared distance <= max_dist2. Writes up to k indices into
 * index_out (into t->photons) and their squared distances into dist2_out, and returns how
 * many were found; *radius2_out receives the largest squared distance among them (the disc
 * the estimate divides by). Results are in no particular order. */
size_t pm_kdtree_nearest(const pm_kdtree *t, vec3 p, size_t k, float max_dist2, uint32_t *index_out,
                         float *dist2_out, float *radius2_out);

/* pm_kdtree_nearest that also reports how many photons it measured the distance to, so tests
 * and benches can check query cost without timing it. */
size_t pm_kdtree_nearest_count_visits(const pm_kdtree *t, vec3 p, size_t k, float max_dist2, uint32_t *index_out,
                                      float *dist2_out, float *radius2_out, size_t *visits_out);

/* Calls visit for every photon with squared distance <= radius2. */
void pm_kdtree_within(const pm_kdtree *t, vec3 p, float radius2,
                      void (*visit)(void *ctx, const pm_photon *ph, float dist2), void *ctx);

/* The summed power and the count of the photons within sqrt(radius2) of p whose 2-bit path tag is
 * in path_mask, that arrived from the side n faces and whose surface normal is within about 25
 * degrees of n: the progressive mode's gather, with the filters inlined into the walk. */
uint32_t pm_kdtree_sum_facing(const pm_kdtree *t, vec3 p, vec3 n, float radius2, unsigned path_mask, vec3 *power);

#endif

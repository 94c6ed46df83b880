/* photongrid.c: the hashed photon grid: counting sort by cell hash, and the fixed-radius gather over overlapped cells. */
#include "photongrid.h"
#include "memory.h"

#include <float.h>
#include <stdlib.h>
#include <string.h>

/* Cell coordinates stay far from int overflow whatever the scene's scale or position. */
static inline int32_t cell_coord(float x, float origin, float inv_cell) {
    float c = floorf((x - origin) * inv_cell);
    c = c < -1e9f ? -1e9f : (c > 1e9f ? 1e9f : c);
    return (int32_t)c;
}

static inline size_t bucket_of(int32_t x, int32_t y, int32_t z, size_t mask) {
    uint32_t h = ((uint32_t)x * 73856093u) ^ ((uint32_t)y * 19349663u) ^ ((uint32_t)z * 83492791u);
    return (size_t)h & mask;
}

void pm_photon_grid_free(pm_photon_grid *g) {
    free(g->photons);
    free(g->bucket_start);
    memset(g, 0, sizeof *g);
}

size_t pm_photon_grid_bytes(const pm_photon_grid *g) {
    return g->capacity * sizeof(pm_photon) + (g->bucket_capacity + 1) * sizeof(uint32_t);
}

bool pm_photon_grid_build(pm_photon_grid *g, const pm_photon *photons, size_t count, float cell) {
    g->count = 0;
    if (!(cell > 0.f) || !isfinite(cell) || count > UINT32_MAX) return false;
    size_t buckets = 1024;
    while (buckets < count) buckets *= 2;
    if (count > g->capacity) {
        pm_photon *grown = pm_realloc(g->photons, count * sizeof *grown, "photon grid");
        if (!grown) { pm_photon_grid_free(g); return false; }
        g->photons = grown;
        g->capacity = count;
    }
    if (buckets > g->bucket_capacity) {
        uint32_t *grown = pm_realloc(g->bucket_start, (buckets + 1) * sizeof *grown, "photon grid buckets");
        if (!grown) { pm_photon_grid_free(g); return false; }
        g->bucket_start = grown;
        g->bucket_capacity = buckets;
    }
    g->bucket_count = buckets;
    g->cell = cell;
    g->inv_cell = 1.f / cell;
    vec3 lo = v3s(FLT_MAX), hi = v3s(-FLT_MAX);
    for (size_t i = 0; i < count; i++) {
        vec3 q = pm_photon_position(&photons[i]);
        lo = v3_min(lo, q);
        hi = v3_max(hi, q);
    }
    g->origin = count ? lo : v3s(0.f);
    g->upper = count ? hi : v3s(0.f);
    size_t mask = buckets - 1;
    uint32_t *start = g->bucket_start;
    memset(start, 0, (buckets + 1) * sizeof *start);
    /* counting sort: sizes, offsets, then each photon into its bucket's next slot */
    for (size_t i = 0; i < count; i++) {
        const float *q = photons[i].pos;
        start[bucket_of(cell_coord(q[0], g->origin.x, g->inv_cell), cell_coord(q[1], g->origin.y, g->inv_cell),
                        cell_coord(q[2], g->origin.z, g->inv_cell), mask) + 1]++;
    }
    for (size_t b = 0; b < buckets; b++) start[b + 1] += start[b];
    for (size_t i = 0; i < count; i++) {
        const float *q = photons[i].pos;
        size_t b = bucket_of(cell_coord(q[0], g->origin.x, g->inv_cell), cell_coord(q[1], g->origin.y, g->inv_cell),
                             cell_coord(q[2], g->origin.z, g->inv_cell), mask);
        g->photons[start[b]++] = photons[i];
    }
    /* the fill moved each start to the next bucket's: shift back */
    for (size_t b = buckets; b > 0; b--) start[b] = start[b - 1];
    start[0] = 0;
    g->count = count;
    return true;
}

#define MAX_GATHER_CELLS 27 /* a disc up to the cell's width overlaps at most 3 x 3 x 3 cells */

/* One photon's share of a disc sum: inside the radius, counting for the surface, weighted by the
 * lobe's f(wo, wi) when a lobe is given. */
static inline __attribute__((always_inline)) void sum_photon(const pm_photon *ph, vec3 p, vec3 n, float radius2,
                                                             unsigned path_mask, const pm_brdf *lobe, vec3 ns, vec3 wo,
                                                             vec3 *sum, uint32_t *found) {
    float dx = ph->pos[0] - p.x, dy = ph->pos[1] - p.y, dz = ph->pos[2] - p.z;
    if (dx * dx + dy * dy + dz * dz > radius2) return;
    if (!pm_photon_counts_for(ph, n, path_mask)) return;
    vec3 q = pm_photon_power(ph);
    if (lobe) q = v3_mul(q, pm_brdf_eval(lobe, ns, wo, v3_neg(pm_photon_direction(ph))));
    *sum = v3_add(*sum, q);
    (*found)++;
}

/* The disc's photons that count for the surface, each one's power weighted by the lobe's f(wo, wi)
 * when a lobe is given. Inline into both callers, so the plain sum keeps no BRDF branch cost. */
/* Inlined into both callers so that the Lambert one (lobe == NULL) carries no per-photon branch. */
static inline __attribute__((always_inline)) uint32_t sum_disc(const pm_photon_grid *g, vec3 p, vec3 n, float radius2,
                                                               unsigned path_mask, const pm_brdf *lobe, vec3 ns,
                                                               vec3 wo, vec3 *power) {
    vec3 sum = v3s(0.f);
    uint32_t found = 0;
    *power = sum;
    if (!g->count || !(radius2 > 0.f)) return 0;
    float r = sqrtf(radius2);
    /* caustic photons often cover a small part of the image: most discs miss them all */
    if (p.x + r < g->origin.x || p.y + r < g->origin.y || p.z + r < g->origin.z || p.x - r > g->upper.x ||
        p.y - r > g->upper.y || p.z - r > g->upper.z)
        return 0;
    int32_t x0 = cell_coord(p.x - r, g->origin.x, g->inv_cell), x1 = cell_coord(p.x + r, g->origin.x, g->inv_cell);
    int32_t y0 = cell_coord(p.y - r, g->origin.y, g->inv_cell), y1 = cell_coord(p.y + r, g->origin.y, g->inv_cell);
    int32_t z0 = cell_coord(p.z - r, g->origin.z, g->inv_cell), z1 = cell_coord(p.z + r, g->origin.z, g->inv_cell);
    size_t mask = g->bucket_count - 1;
    /* A disc far wider than the cells would visit more cells than there are photons: scan them all. */
    int64_t cells = (int64_t)(x1 - x0 + 1) * (y1 - y0 + 1) * (z1 - z0 + 1);
    if (cells > (int64_t)g->count) {
        for (size_t i = 0; i < g->count; i++) sum_photon(&g->photons[i], p, n, radius2, path_mask, lobe, ns, wo, &sum, &found);
        *power = sum;
        return found;
    }
    if (cells > MAX_GATHER_CELLS) {
        /* a rare wide disc: cell by cell, each photon checked to be its cell's (buckets may repeat) */
        for (int32_t z = z0; z <= z1; z++)
            for (int32_t y = y0; y <= y1; y++)
                for (int32_t x = x0; x <= x1; x++) {
                    size_t b = bucket_of(x, y, z, mask);
                    for (uint32_t i = g->bucket_start[b]; i < g->bucket_start[b + 1]; i++) {
                        const float *q = g->photons[i].pos;
                        if (cell_coord(q[0], g->origin.x, g->inv_cell) == x && cell_coord(q[1], g->origin.y, g->inv_cell) == y &&
                            cell_coord(q[2], g->origin.z, g->inv_cell) == z)
                            sum_photon(&g->photons[i], p, n, radius2, path_mask, lobe, ns, wo, &sum, &found);
                    }
                }
        *power = sum;
        return found;
    }
    /* The overlapped cells' buckets, each once: a photon within the radius lies in one of these
     * cells, so a bucket shared with a far cell only adds photons that fail the distance test, and
     * no photon needs its own cell checked. The lookups are cache misses; prefetching every
     * bucket's bounds and then every bucket's first photons overlaps them. */
    size_t bucket[MAX_GATHER_CELLS];
    int nb = 0;
    for (int32_t z = z0; z <= z1; z++)
        for (int32_t y = y0; y <= y1; y++)
            for (int32_t x = x0; x <= x1; x++) {
                size_t b = bucket_of(x, y, z, mask);
                bool seen = false;
                for (int k = 0; k < nb; k++) seen |= bucket[k] == b;
                if (seen) continue;
                bucket[nb++] = b;
                __builtin_prefetch(&g->bucket_start[b]);
            }
    uint32_t first[MAX_GATHER_CELLS], last[MAX_GATHER_CELLS];
    for (int k = 0; k < nb; k++) {
        first[k] = g->bucket_start[bucket[k]];
        last[k] = g->bucket_start[bucket[k] + 1];
        if (first[k] < last[k]) __builtin_prefetch(&g->photons[first[k]]);
    }
    for (int k = 0; k < nb; k++)
        for (uint32_t i = first[k]; i < last[k]; i++) sum_photon(&g->photons[i], p, n, radius2, path_mask, lobe, ns, wo, &sum, &found);
    *power = sum;
    return found;
}

uint32_t pm_photon_grid_sum_facing(const pm_photon_grid *g, vec3 p, vec3 n, float radius2, unsigned path_mask,
                                   vec3 *power) {
    return sum_disc(g, p, n, radius2, path_mask, NULL, n, n, power);
}

uint32_t pm_photon_grid_sum_brdf(const pm_photon_grid *g, vec3 p, vec3 n, float radius2, unsigned path_mask,
                                 const pm_brdf *b, vec3 ns, vec3 wo, vec3 *reflected) {
    return sum_disc(g, p, n, radius2, path_mask, b, ns, wo, reflected);
}

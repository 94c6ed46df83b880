/* photongrid.c: the hashed photon grid: counting sort by cell hash, and the fixed-radius gather over overlapped cells. */
#include "photongrid.h"
#include "memory.h"
#include "parallel.h"

#include <float.h>
#include <stdlib.h>
#include <string.h>

/* Cell coordinates stay far from int overflow whatever the scene's scale or position. */
static inline int32_t cell_coord(float x, float origin, float inv_cell) {
    float c = (x - origin) * inv_cell;
    c = c < -1e9f ? -1e9f : (c > 1e9f ? 1e9f : c); /* NaN stays NaN: the conversion gives INT32_MIN, a cell no query plans */
    int32_t i = (int32_t)c;                         /* floor without a libm call: truncate, then step down below zero */
    return i - (c < (float)i);
}

static inline size_t bucket_of(int32_t x, int32_t y, int32_t z, size_t mask) {
    uint32_t h = ((uint32_t)x * 73856093u) ^ ((uint32_t)y * 19349663u) ^ ((uint32_t)z * 83492791u);
    return (size_t)h & mask;
}

void pm_photon_grid_free(pm_photon_grid *g) {
    free(g->photons);
    free(g->bucket_start);
    free(g->occupied);
    free(g->read);
    memset(g, 0, sizeof *g);
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
        uint8_t *read = pm_realloc(g->read, count, "photon grid read marks");
        if (!read) { pm_photon_grid_free(g); return false; }
        g->read = read;
        g->capacity = count;
    }
    if (buckets > g->bucket_capacity) {
        uint32_t *grown = pm_realloc(g->bucket_start, (buckets + 1) * sizeof *grown, "photon grid buckets");
        if (!grown) { pm_photon_grid_free(g); return false; }
        g->bucket_start = grown;
        uint64_t *bits = pm_realloc(g->occupied, buckets / 64 * sizeof *bits, "photon grid occupancy");
        if (!bits) { pm_photon_grid_free(g); return false; }
        g->occupied = bits;
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
    g->top[0] = cell_coord(g->upper.x, g->origin.x, g->inv_cell);
    g->top[1] = cell_coord(g->upper.y, g->origin.y, g->inv_cell);
    g->top[2] = cell_coord(g->upper.z, g->origin.z, g->inv_cell);
    size_t mask = buckets - 1;
    uint32_t *start = g->bucket_start;
    memset(start, 0, (buckets + 1) * sizeof *start);
    /* counting sort: sizes, offsets, then each photon into its bucket's next slot. A sort is about
     * 300 ns a photon (two cache misses), 30 s for the 100 million records of a room of albedo 1:
     * the calling thread's cancel flag is looked at every 64k photons, and a cancelled build is empty. */
    for (size_t i = 0; i < count; i++) {
        if ((i & 0xffff) == 0 && pm_parallel_cancelled()) return true;
        const float *q = photons[i].pos;
        start[bucket_of(cell_coord(q[0], g->origin.x, g->inv_cell), cell_coord(q[1], g->origin.y, g->inv_cell),
                        cell_coord(q[2], g->origin.z, g->inv_cell), mask) + 1]++;
    }
    memset(g->occupied, 0, buckets / 64 * sizeof *g->occupied);
    for (size_t b = 0; b < buckets; b++)
        if (start[b + 1]) g->occupied[b >> 6] |= 1ull << (b & 63);
    for (size_t b = 0; b < buckets; b++) start[b + 1] += start[b];
    for (size_t i = 0; i < count; i++) {
        if ((i & 0xffff) == 0 && pm_parallel_cancelled()) return true;
        const float *q = photons[i].pos;
        size_t b = bucket_of(cell_coord(q[0], g->origin.x, g->inv_cell), cell_coord(q[1], g->origin.y, g->inv_cell),
                             cell_coord(q[2], g->origin.z, g->inv_cell), mask);
        g->photons[start[b]++] = photons[i];
    }
    /* the fill moved each start to the next bucket's: shift back */
    for (size_t b = buckets; b > 0; b--) start[b] = start[b - 1];
    start[0] = 0;
    if (count) memset(g->read, 0, count);
    g->count = count;
    return true;
}

#define MAX_GATHER_CELLS 27 /* a disc up to the cell's width overlaps at most 3 x 3 x 3 cells */

/* Whether a photon lies within the radius (NaN distances pass, so that the
 * surface test alone decides for them on every path through the grid). The distance test is most of a query's work (about 8 photons read
 * for each one inside): the three differences in one register, summed in the scalar order
 * (dx^2 + dy^2) + dz^2, so the same photons pass. The fourth lane (the record's codes) is masked
 * off before any arithmetic. */
static inline __attribute__((always_inline)) bool within(const pm_photon *ph, pm_f4_ p4, float radius2) {
    pm_f4_ at;
    memcpy(&at, ph, sizeof at);
    const pm_u4_ xyz = {~0u, ~0u, ~0u, 0u};
    pm_f4_ d = (pm_f4_)((pm_u4_)at & xyz) - p4;
    d *= d;
    return !(d[0] + d[1] + d[2] > radius2);
}

/* The share of a photon within the radius: counting for the surface, weighted by the lobe's
 * f(wo, wi) when a lobe is given. */
static inline __attribute__((always_inline)) void sum_inside(const pm_photon_grid *g, const pm_photon *ph, vec3 n,
                                                             unsigned path_mask, const pm_brdf *lobe, vec3 ns, vec3 wo,
                                                             const pm_clip *clip, vec3 *sum, uint32_t *found) {
    if (!pm_photon_counts_for(ph, n, path_mask)) return;
    if (clip && !pm_clip_keeps(clip, pm_photon_position(ph))) return;
    /* several threads may mark one photon: the same byte, the same value, relaxed */
    __atomic_store_n(&g->read[ph - g->photons], (uint8_t)1, __ATOMIC_RELAXED);
    vec3 q = pm_photon_power(ph);
    if (lobe) q = v3_mul(q, pm_brdf_eval(lobe, ns, wo, v3_neg(pm_photon_direction(ph))));
    *sum = v3_add(*sum, q);
    (*found)++;
}

/* One photon's share of a disc sum (the rare wide discs: every photon, or cell by cell). */
static inline __attribute__((always_inline)) void sum_photon(const pm_photon_grid *g, const pm_photon *ph, pm_f4_ p4, vec3 n, float radius2,
                                                             unsigned path_mask, const pm_brdf *lobe, vec3 ns, vec3 wo,
                                                             const pm_clip *clip, vec3 *sum, uint32_t *found) {
    if (within(ph, p4, radius2)) sum_inside(g, ph, n, path_mask, lobe, ns, wo, clip, sum, found);
}

/* Where a disc's photons are: nothing, every photon (a disc wider than the photons' cells), the
 * cells one by one (a rare wide disc whose buckets may repeat), or a short list of distinct
 * occupied buckets. */
enum { PLAN_NONE, PLAN_ALL, PLAN_CELLS, PLAN_BUCKETS };
typedef struct {
    int kind, buckets;
    int32_t lo[3], hi[3];
    uint32_t bucket[MAX_GATHER_CELLS];
    uint32_t first[MAX_GATHER_CELLS], last[MAX_GATHER_CELLS];
} disc_plan;

/* The overlapped cells' buckets, each once: a photon within the radius lies in one of these cells,
 * so a bucket shared with a far cell only adds photons that fail the distance test, and no photon
 * needs its own cell checked. The occupancy bits (a few kB, in L1) skip the empty buckets, which
 * are most of them on surfaces; the other buckets' bounds are prefetched here and read later. */
static inline void plan_disc(const pm_photon_grid *g, vec3 p, float radius2, disc_plan *plan) {
    plan->kind = PLAN_NONE;
    plan->buckets = 0;
    if (!g->count || !(radius2 > 0.f)) return;
    float r = sqrtf(radius2);
    /* caustic photons often cover a small part of the image: most discs miss them all */
    if (p.x + r < g->origin.x || p.y + r < g->origin.y || p.z + r < g->origin.z || p.x - r > g->upper.x ||
        p.y - r > g->upper.y || p.z - r > g->upper.z)
        return;
    /* The disc's cells, clamped to the photons' (no photon lies outside [0, top]), counted in 64
     * bits axis by axis: a disc as wide as the scene spans at most the grid's cells, not 2e9 a
     * side, and a disc wider than the cells, which would visit more cells than there are
     * photons, scans the photons instead. A NaN centre leaves an empty range: nothing. */
    const float centre[3] = {p.x, p.y, p.z}, origin[3] = {g->origin.x, g->origin.y, g->origin.z};
    int32_t *lo = plan->lo, *hi = plan->hi;
    int64_t cells = 1;
    for (int k = 0; k < 3; k++) {
        int32_t a = cell_coord(centre[k] - r, origin[k], g->inv_cell), b = cell_coord(centre[k] + r, origin[k], g->inv_cell);
        lo[k] = a > 0 ? a : 0;
        hi[k] = b < g->top[k] ? b : g->top[k];
        if (lo[k] > hi[k]) return;
        cells *= (int64_t)hi[k] - lo[k] + 1; /* at most count x (1e9 + 1) before the test below */
        if (cells > (int64_t)g->count) { plan->kind = PLAN_ALL; return; }
    }
    if (cells > MAX_GATHER_CELLS) { plan->kind = PLAN_CELLS; return; }
    plan->kind = PLAN_BUCKETS;
    size_t mask = g->bucket_count - 1;
    for (int32_t z = lo[2]; z <= hi[2]; z++)
        for (int32_t y = lo[1]; y <= hi[1]; y++)
            for (int32_t x = lo[0]; x <= hi[0]; x++) {
                /* kept by an add, not a branch: whether a cell's bucket holds photons is random */
                size_t b = bucket_of(x, y, z, mask);
                bool seen = false;
                for (int k = 0; k < plan->buckets; k++) seen |= plan->bucket[k] == b;
                plan->bucket[plan->buckets] = (uint32_t)b;
                plan->buckets += (int)((g->occupied[b >> 6] >> (b & 63)) & 1u) & !seen;
                __builtin_prefetch(&g->bucket_start[b]);
            }
}

bool pm_photon_grid_may_find(const pm_photon_grid *g, vec3 p, float radius2) {
    disc_plan plan;
    plan_disc(g, p, radius2, &plan);
    return plan.kind == PLAN_ALL || plan.kind == PLAN_CELLS || (plan.kind == PLAN_BUCKETS && plan.buckets > 0);
}

/* Reads the planned buckets' bounds and prefetches each bucket's first photons. */
static inline void locate_buckets(const pm_photon_grid *g, disc_plan *plan) {
    for (int k = 0; k < plan->buckets; k++) {
        plan->first[k] = g->bucket_start[plan->bucket[k]];
        plan->last[k] = g->bucket_start[plan->bucket[k] + 1];
        /* every line of the bucket (a bucket of a gather disc holds about 14 photons, 5 lines) */
        uintptr_t line = (uintptr_t)&g->photons[plan->first[k]] & ~(uintptr_t)63, end = (uintptr_t)&g->photons[plan->last[k]];
        do {
            __builtin_prefetch((const void *)line);
            line += 64;
        } while (line < end);
    }
}

/* The disc's photons that count for the surface, each one's power weighted by the lobe's f(wo, wi)
 * when a lobe is given. Inlined into its callers, so the Lambert one (lobe == NULL) carries no
 * per-photon branch. */
static inline __attribute__((always_inline)) uint32_t sum_planned(const pm_photon_grid *g, const disc_plan *plan, vec3 p,
                                                                  vec3 n, float radius2, unsigned path_mask,
                                                                  const pm_brdf *lobe, vec3 ns, vec3 wo,
                                                                  const pm_clip *clip, vec3 *power, uint32_t *inside_count) {
    vec3 sum = v3s(0.f);
    uint32_t found = 0, inside_total = 0;
    const pm_f4_ p4 = {p.x, p.y, p.z, 0.f};
    if (plan->kind == PLAN_ALL) {
        for (size_t i = 0; i < g->count; i++) sum_photon(g, &g->photons[i], p4, n, radius2, path_mask, lobe, ns, wo, clip, &sum, &found);
        inside_total = (uint32_t)g->count;
    } else if (plan->kind == PLAN_CELLS) {
        size_t mask = g->bucket_count - 1;
        for (int32_t z = plan->lo[2]; z <= plan->hi[2]; z++)
            for (int32_t y = plan->lo[1]; y <= plan->hi[1]; y++)
                for (int32_t x = plan->lo[0]; x <= plan->hi[0]; x++) {
                    size_t b = bucket_of(x, y, z, mask);
                    for (uint32_t i = g->bucket_start[b]; i < g->bucket_start[b + 1]; i++) {
                        const float *q = g->photons[i].pos;
                        if (cell_coord(q[0], g->origin.x, g->inv_cell) == x && cell_coord(q[1], g->origin.y, g->inv_cell) == y &&
                            cell_coord(q[2], g->origin.z, g->inv_cell) == z) {
                            sum_photon(g, &g->photons[i], p4, n, radius2, path_mask, lobe, ns, wo, clip, &sum, &found);
                            inside_total++;
                        }
                    }
                }
    } else if (plan->kind == PLAN_BUCKETS) {
        /* The distance test passes about one photon in eight, at random: as a branch it
         * mispredicted most of those. So the scan only notes the photons inside, by a store and
         * an add, and the surface test runs over the notes, in the same order. */
        enum { NOTES = 64 };
        uint32_t inside[NOTES];
        int noted = 0;
        for (int k = 0; k < plan->buckets; k++)
            for (uint32_t i = plan->first[k]; i < plan->last[k]; i++) {
                inside[noted] = i;
                noted += within(&g->photons[i], p4, radius2);
                if (noted == NOTES) {
                    for (int j = 0; j < noted; j++) sum_inside(g, &g->photons[inside[j]], n, path_mask, lobe, ns, wo, clip, &sum, &found);
                    inside_total += (uint32_t)noted;
                    noted = 0;
                }
            }
        for (int j = 0; j < noted; j++) sum_inside(g, &g->photons[inside[j]], n, path_mask, lobe, ns, wo, clip, &sum, &found);
        inside_total += (uint32_t)noted;
    }
    *power = sum;
    if (inside_count) *inside_count = inside_total;
    return found;
}

static inline __attribute__((always_inline)) uint32_t sum_disc(const pm_photon_grid *g, vec3 p, vec3 n, float radius2,
                                                               unsigned path_mask, const pm_brdf *lobe, vec3 ns,
                                                               vec3 wo, vec3 *power) {
    disc_plan plan;
    plan_disc(g, p, radius2, &plan);
    if (plan.kind == PLAN_BUCKETS) locate_buckets(g, &plan);
    return sum_planned(g, &plan, p, n, radius2, path_mask, lobe, ns, wo, NULL, power, NULL);
}

/* Queries in groups: every disc's bucket bounds are requested, then every disc's first photons,
 * before any photon is read, so the cache misses of a group overlap instead of queuing one after
 * another (a single query has too little independent work to hide them). */
#define QUERY_GROUP 32

void pm_photon_grid_sum_many(const pm_photon_grid *g, const pm_grid_query *q, size_t count, pm_grid_result *out) {
    disc_plan plan[QUERY_GROUP];
    for (size_t base = 0; base < count; base += QUERY_GROUP) {
        size_t n = count - base < QUERY_GROUP ? count - base : QUERY_GROUP;
        for (size_t k = 0; k < n; k++) plan_disc(g, q[base + k].p, q[base + k].radius2, &plan[k]);
        for (size_t k = 0; k < n; k++)
            if (plan[k].kind == PLAN_BUCKETS) locate_buckets(g, &plan[k]);
        for (size_t k = 0; k < n; k++) {
            const pm_grid_query *x = &q[base + k];
            pm_grid_result *r = &out[base + k];
            r->found = x->lobe ? sum_planned(g, &plan[k], x->p, x->n, x->radius2, x->path_mask, x->lobe, x->ns, x->wo, x->clip,
                                             &r->power, &r->inside)
                               : sum_planned(g, &plan[k], x->p, x->n, x->radius2, x->path_mask, NULL, x->n, x->n, x->clip,
                                             &r->power, &r->inside);
        }
    }
}

uint32_t pm_photon_grid_sum_facing(const pm_photon_grid *g, vec3 p, vec3 n, float radius2, unsigned path_mask,
                                   vec3 *power) {
    return sum_disc(g, p, n, radius2, path_mask, NULL, n, n, power);
}

size_t pm_photon_grid_read_count(const pm_photon_grid *g) {
    size_t n = 0;
    for (size_t i = 0; i < g->count; i++) n += g->read[i];
    return n;
}

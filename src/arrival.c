/* arrival.c: the sky's arrival guide's hashed slots, their counting of rays that reached the sky, and the direction samples drawn from them. */
#include "arrival.h"

#include <assert.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "guide.h"
#include "memory.h"

#define TOUCHED_WORDS (PM_ARRIVAL_SLOTS / 64)

/* p's cell on ng's side, hashed to a slot. */
static inline uint32_t slot_of(const pm_arrival_guide *g, vec3 p, vec3 ng) {
    return pm_cell_mix(pm_cell_key(p, g->inv_cell) ^ (pm_axis_side(ng) * 0x9e3779b9u)) & (PM_ARRIVAL_SLOTS - 1);
}

/* The bin of direction w: pm_sample_sphere's numbers, squared into PM_ARRIVAL_BINS_SIDE^2. */
static inline uint32_t bin_of(vec3 w) {
    float u1, u2;
    pm_sphere_numbers(w, &u1, &u2);
    uint32_t i = (uint32_t)(u1 * PM_ARRIVAL_BINS_SIDE), j = (uint32_t)(u2 * PM_ARRIVAL_BINS_SIDE);
    i = i < PM_ARRIVAL_BINS_SIDE ? i : PM_ARRIVAL_BINS_SIDE - 1;
    j = j < PM_ARRIVAL_BINS_SIDE ? j : PM_ARRIVAL_BINS_SIDE - 1;
    return i * PM_ARRIVAL_BINS_SIDE + j;
}

bool pm_arrival_init(pm_arrival_guide *g, float cell, float (*luminance)(const void *ctx, vec3 w), const void *ctx) {
    memset(g, 0, sizeof *g);
    g->counts = pm_calloc((size_t)PM_ARRIVAL_SLOTS * PM_ARRIVAL_BINS, sizeof *g->counts, "sky arrival guide");
    g->hits = pm_calloc(PM_ARRIVAL_SLOTS, sizeof *g->hits, "sky arrival guide");
    g->hits_made = pm_calloc(PM_ARRIVAL_SLOTS, sizeof *g->hits_made, "sky arrival guide");
    g->cdf = pm_calloc((size_t)PM_ARRIVAL_SLOTS * (PM_ARRIVAL_BINS + 1), sizeof *g->cdf, "sky arrival guide");
    g->usable = pm_calloc(PM_ARRIVAL_SLOTS, 1, "sky arrival guide");
    g->touched = pm_calloc(TOUCHED_WORDS, sizeof *g->touched, "sky arrival guide");
    if (!g->counts || !g->hits || !g->hits_made || !g->cdf || !g->usable || !g->touched) {
        pm_arrival_free(g);
        return false;
    }
    for (uint32_t b = 0; b < PM_ARRIVAL_BINS; b++) {
        float u1 = ((float)(b / PM_ARRIVAL_BINS_SIDE) + 0.5f) / PM_ARRIVAL_BINS_SIDE, u2 = ((float)(b % PM_ARRIVAL_BINS_SIDE) + 0.5f) / PM_ARRIVAL_BINS_SIDE;
        float l = luminance(ctx, pm_sample_sphere(u1, u2));
        g->bin_radiance[b] = l > 0.f && isfinite(l) ? l : 0.f;
    }
    pm_arrival_clear(g, cell);
    return true;
}

void pm_arrival_free(pm_arrival_guide *g) {
    free(g->counts);
    free(g->hits);
    free(g->hits_made);
    free(g->cdf);
    free(g->usable);
    free(g->touched);
    memset(g, 0, sizeof *g);
}

void pm_arrival_clear(pm_arrival_guide *g, float cell) {
    if (!g->counts) return;
    memset(g->counts, 0, (size_t)PM_ARRIVAL_SLOTS * PM_ARRIVAL_BINS * sizeof *g->counts);
    memset(g->hits, 0, PM_ARRIVAL_SLOTS * sizeof *g->hits);
    memset(g->hits_made, 0, PM_ARRIVAL_SLOTS * sizeof *g->hits_made);
    memset(g->usable, 0, PM_ARRIVAL_SLOTS);
    memset(g->touched, 0, TOUCHED_WORDS * sizeof *g->touched);
    g->usable_count = 0;
    g->cell = cell;
    g->inv_cell = 1.f / cell;
}

void pm_arrival_count(pm_arrival_guide *g, vec3 p, vec3 ng, vec3 w) {
    uint32_t slot = slot_of(g, p, ng);
    /* a slot that has counted enough stops: under an open sky most own rays reach it, and their
     * counting would cost 5% of the eye pass for distributions long made */
    if (__atomic_load_n(&g->hits[slot], __ATOMIC_RELAXED) >= PM_ARRIVAL_MAX_HITS) return;
    uint32_t *count = &g->counts[(size_t)slot * PM_ARRIVAL_BINS + bin_of(w)];
    __atomic_fetch_add(count, 1u, __ATOMIC_RELAXED);
    __atomic_fetch_add(&g->hits[slot], 1u, __ATOMIC_RELAXED);
    uint64_t bit = 1ull << (slot & 63);
    if (!(__atomic_load_n(&g->touched[slot >> 6], __ATOMIC_RELAXED) & bit)) __atomic_fetch_or(&g->touched[slot >> 6], bit, __ATOMIC_RELAXED);
}

/* Slot i's distribution from its counts, and whether it is usable (arrival.h); made again once its
 * hits grew by an eighth (every iteration, the distributions took 3% of the solid window room's
 * run, and one more eighth of the hits barely moves them). */
static void make_slot(pm_arrival_guide *g, uint32_t i) {
    uint32_t hits = g->hits[i];
    if (hits < PM_ARRIVAL_MIN_HITS || (g->hits_made[i] && hits - g->hits_made[i] < g->hits_made[i] / 8)) return;
    g->hits_made[i] = hits;
    const uint32_t *count = &g->counts[(size_t)i * PM_ARRIVAL_BINS];
    float *cdf = &g->cdf[(size_t)i * (PM_ARRIVAL_BINS + 1)];
    bool was = g->usable[i];
    double total = 0.0, squares = 0.0;
    for (uint32_t b = 0; b < PM_ARRIVAL_BINS; b++) total += (double)count[b] * g->bin_radiance[b];
    bool usable = g->hits[i] >= PM_ARRIVAL_MIN_HITS && total > 0.0;
    if (usable) {
        for (uint32_t b = 0; b < PM_ARRIVAL_BINS; b++) {
            double q = (double)count[b] * g->bin_radiance[b] / total;
            squares += q * q;
        }
        usable = squares * PM_ARRIVAL_BINS >= PM_ARRIVAL_CONCENTRATION;
    }
    if (usable) {
        double run = 0.0;
        cdf[0] = 0.f;
        for (uint32_t b = 0; b < PM_ARRIVAL_BINS; b++) {
            run += (double)count[b] * g->bin_radiance[b];
            cdf[b + 1] = (float)(run / total);
        }
        cdf[PM_ARRIVAL_BINS] = 1.f;
    }
    g->usable[i] = usable;
    g->usable_count += (uint32_t)usable - (uint32_t)was;
}

void pm_arrival_finish(pm_arrival_guide *g) {
    if (!g->counts) return;
    for (uint32_t w = 0; w < TOUCHED_WORDS; w++) {
        for (uint64_t bits = g->touched[w]; bits; bits &= bits - 1) make_slot(g, w * 64 + (uint32_t)__builtin_ctzll(bits));
        g->touched[w] = 0;
    }
}

bool pm_arrival_find(const pm_arrival_guide *g, vec3 p, vec3 ng, pm_arrival_cell *c) {
    if (!g || !g->usable_count) return false;
    uint32_t slot = slot_of(g, p, ng);
    if (!g->usable[slot]) return false;
    c->cdf = &g->cdf[(size_t)slot * (PM_ARRIVAL_BINS + 1)];
    return true;
}

/* A bin's density per steradian: its probability over its solid angle, 4 pi / the bins. */
static inline float bin_pdf(const pm_arrival_cell *c, uint32_t b) {
    return (c->cdf[b + 1] - c->cdf[b]) * (float)(PM_ARRIVAL_BINS / (4.0 * PM_PI));
}

vec3 pm_arrival_sample(const pm_arrival_cell *c, float u_bin, float u1, float u2, float *pdf) {
    uint32_t b = pm_cdf_interval(c->cdf, PM_ARRIVAL_BINS, u_bin);
    float i = (float)(b / PM_ARRIVAL_BINS_SIDE), j = (float)(b % PM_ARRIVAL_BINS_SIDE);
    vec3 w = pm_sample_sphere((i + u1) / PM_ARRIVAL_BINS_SIDE, (j + u2) / PM_ARRIVAL_BINS_SIDE);
    /* the density of the bin the direction falls in by the inverse mapping, as pm_arrival_pdf
     * finds it (rounding at a bin's edge may move it to a neighbour) */
    *pdf = bin_pdf(c, bin_of(w));
    return w;
}

float pm_arrival_pdf(const pm_arrival_cell *c, vec3 w) {
    return c && c->cdf ? bin_pdf(c, bin_of(w)) : 0.f;
}

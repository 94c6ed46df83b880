/* test_photongrid.c: the progressive mode's hashed photon grid against brute force: every disc finds exactly the photons a full scan finds, at any radius against the cell (one cell, the 27-cell fast path, wide discs, discs wider than the photon set, radii up to float's range) and with buckets shared by many cells; the batched query gives each single query's result bit for bit; a cancelled sort leaves an empty grid. */
#include <float.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "parallel.h"
#include "photongrid.h"
#include "rng.h"
#include "testing.h"

/* Photons on three planes of a unit room (floor, wall, a tilted plane) and a dense clump, arriving
 * from random directions, some from behind their surface, with the three path tags. */
static void make_photons(pm_photon *ph, size_t count, pm_rng *rng) {
    for (size_t i = 0; i < count; i++) {
        float u = pm_rng_float(rng), v = pm_rng_float(rng);
        vec3 p, n;
        switch (i % 4) {
        case 0: p = v3(u, 0.f, v); n = v3(0.f, 1.f, 0.f); break;
        case 1: p = v3(0.f, u, v); n = v3(1.f, 0.f, 0.f); break;
        case 2: p = v3(u, 0.5f * u + 0.25f, v); n = v3_normalize(v3(-0.5f, 1.f, 0.f)); break;
        default: p = v3(0.5f + 0.01f * u, 0.f, 0.5f + 0.01f * v); n = v3(0.f, 1.f, 0.f); break;
        }
        vec3 d = pm_sample_sphere(pm_rng_float(rng), pm_rng_float(rng));
        vec3 power = v3(pm_rng_float(rng), pm_rng_float(rng), pm_rng_float(rng));
        pm_photon_set(&ph[i], p, n, d, power, (int)(i % 3));
    }
}

static uint32_t brute_force(const pm_photon *ph, size_t count, vec3 p, vec3 n, float radius2, unsigned mask, vec3 *power) {
    uint32_t found = 0;
    *power = v3s(0.f);
    for (size_t i = 0; i < count; i++) {
        float dx = ph[i].pos[0] - p.x, dy = ph[i].pos[1] - p.y, dz = ph[i].pos[2] - p.z;
        if (dx * dx + dy * dy + dz * dz > radius2 || !pm_photon_counts_for(&ph[i], n, mask)) continue;
        *power = v3_add(*power, pm_photon_power(&ph[i]));
        found++;
    }
    return found;
}

/* Queries at photon positions and at random points, with radii from a tenth of a cell to many
 * cells; counts must be equal and sums equal to rounding (the order of addition differs). */
static void check_against_brute_force(const char *what, const pm_photon *ph, size_t count, float cell, int queries,
                                      pm_rng *rng) {
    pm_photon_grid g;
    memset(&g, 0, sizeof g);
    CHECK(pm_photon_grid_build(&g, ph, count, cell), "%s: build", what);
    static const float radius_in_cells[] = {0.1f, 0.5f, 0.9f, 1.0f, 1.4f, 2.5f, 6.f, 200.f};
    int mismatches = 0, nonempty = 0, batch_mismatches = 0;
    pm_grid_query *batch = calloc((size_t)queries, sizeof *batch);
    pm_grid_result *single = calloc((size_t)queries, sizeof *single), *many = calloc((size_t)queries, sizeof *many);
    for (int q = 0; q < queries; q++) {
        vec3 p = q % 2 ? pm_photon_position(&ph[(size_t)(pm_rng_float(rng) * count) % count])
                       : v3(pm_rng_float(rng), pm_rng_float(rng), pm_rng_float(rng));
        vec3 n = (q / 2) % 2 ? v3(0.f, 1.f, 0.f) : v3(1.f, 0.f, 0.f);
        float r = cell * radius_in_cells[q % 8];
        unsigned mask = q % 5 == 0 ? 1u : 7u;
        vec3 want, got;
        uint32_t nw = brute_force(ph, count, p, n, r * r, mask, &want);
        uint32_t ng = pm_photon_grid_sum_facing(&g, p, n, r * r, mask, &got);
        batch[q] = (pm_grid_query){.p = p, .n = n, .radius2 = r * r, .path_mask = mask, .ns = n, .wo = n};
        single[q].found = ng;
        single[q].power = got;
        nonempty += nw > 0;
        if (nw != ng || fabsf(got.x - want.x) > 1e-4f * (want.x + 1e-6f) + 1e-6f) {
            if (mismatches++ < 5)
                fprintf(stderr, "%s: query %d radius %g cells: found %u, brute force %u (sum %g against %g)\n", what, q,
                        (double)radius_in_cells[q % 8], ng, nw, (double)got.x, (double)want.x);
        }
    }
    CHECK(mismatches == 0, "%s: %d of %d discs differ from brute force", what, mismatches, queries);
    /* in uneven slices, so groups start at every offset and the last one is short */
    for (int at = 0, step = 1; at < queries; at += step, step = step * 3 % 97 + 1)
        pm_photon_grid_sum_many(&g, batch + at, (size_t)(at + step <= queries ? step : queries - at), many + at);
    for (int q = 0; q < queries; q++)
        batch_mismatches += many[q].found != single[q].found || memcmp(&many[q].power, &single[q].power, sizeof(vec3)) != 0;
    CHECK(batch_mismatches == 0, "%s: %d of %d batched discs differ from the single query", what, batch_mismatches, queries);
    free(batch);
    free(single);
    free(many);
    CHECK(nonempty > queries / 8, "%s: only %d of %d discs found photons: the test would not see a miss", what, nonempty,
          queries);
    pm_photon_grid_free(&g);
}

/* Discs far wider than the scene (--radius up to 1e18, and a squared radius that overflowed float
 * to infinity) against brute force: every photon that counts for the surface, found at once. Their
 * cell range was once 2e9 cells a side in int32 (it overflowed and the plan looped for ever). */
static void check_huge_discs(const pm_photon *ph, size_t count, pm_rng *rng) {
    static const float radii[] = {1e6f, 1e18f, 1.8e19f, INFINITY};
    static const float cells[] = {0.004f, 0.02f, 3e18f};
    for (size_t c = 0; c < sizeof cells / sizeof *cells; c++) {
        pm_photon_grid g;
        memset(&g, 0, sizeof g);
        CHECK(pm_photon_grid_build(&g, ph, count, cells[c]), "huge discs: build with cell %g", (double)cells[c]);
        for (size_t k = 0; k < sizeof radii / sizeof *radii; k++)
            for (int q = 0; q < 4; q++) {
                vec3 p = v3(pm_rng_float(rng), pm_rng_float(rng), pm_rng_float(rng)), n = v3(0.f, 1.f, 0.f);
                float r2 = radii[k] * radii[k]; /* 1.8e19 squared is infinite in float */
                vec3 want, got;
                uint32_t nw = brute_force(ph, count, p, n, r2, 7u, &want);
                uint32_t ng = pm_photon_grid_sum_facing(&g, p, n, r2, 7u, &got);
                CHECK(nw == ng && nw > count / 8, "cell %g, radius %g: found %u, brute force %u of %zu", (double)cells[c],
                      (double)radii[k], ng, nw, count);
                CHECK(pm_photon_grid_may_find(&g, p, r2), "cell %g, radius %g: may find", (double)cells[c], (double)radii[k]);
            }
        /* a NaN centre: no disc at all, and no endless loop */
        vec3 none;
        CHECK(pm_photon_grid_sum_facing(&g, v3s(NAN), v3(0.f, 1.f, 0.f), 1.f, 7u, &none) == 0, "a NaN centre finds nothing");
        pm_photon_grid_free(&g);
    }
}

/* A sort the calling thread's cancel flag stops (a quit, a signal: the 100 million records of a
 * room of albedo 1 take 30 s to sort) leaves the grid empty, and is no failure. */
static void check_cancelled_build(const pm_photon *ph, size_t count) {
    pm_photon_grid g;
    memset(&g, 0, sizeof g);
    atomic_bool cancel;
    atomic_init(&cancel, true);
    pm_parallel_set_cancel(&cancel);
    bool built = pm_photon_grid_build(&g, ph, count, 0.02f);
    pm_parallel_set_cancel(NULL);
    vec3 power;
    CHECK(built && g.count == 0, "a cancelled build: true and empty (%d, %zu photons)", built, g.count);
    CHECK(pm_photon_grid_sum_facing(&g, pm_photon_position(&ph[0]), v3(0.f, 1.f, 0.f), 1.f, 7u, &power) == 0,
          "a cancelled grid finds nothing");
    CHECK(pm_photon_grid_build(&g, ph, count, 0.02f) && g.count == count, "built again uncancelled");
    pm_photon_grid_free(&g);
}

int main(void) {
    alarm(60); /* a query that loops for ever fails the test instead of hanging it */
    pm_rng rng = pm_rng_for(7, 0, 0);
    size_t count = 20000;
    pm_photon *ph = malloc(count * sizeof *ph);
    make_photons(ph, count, &rng);
    check_against_brute_force("cell 0.02", ph, count, 0.02f, 4000, &rng);
    check_against_brute_force("cell 0.004 (clump spans cells)", ph, count, 0.004f, 4000, &rng);
    /* few buckets for many cells: 2,048 buckets for 2,000 photons over a fine grid, so many
     * overlapped cells share a bucket and the bucket must be visited once */
    check_against_brute_force("shared buckets", ph, 2000, 0.0003f, 4000, &rng);
    check_huge_discs(ph, 2000, &rng);
    check_cancelled_build(ph, count);
    /* one photon set of a single point: every disc overlaps one cell */
    for (size_t i = 0; i < 64; i++) pm_photon_set(&ph[i], v3(0.3f, 0.f, 0.3f), v3(0.f, 1.f, 0.f), v3(0.f, -1.f, 0.f), v3s(1.f), 0);
    check_against_brute_force("one point", ph, 64, 0.05f, 400, &rng);
    free(ph);
    return pm_test_done("test_photongrid");
}

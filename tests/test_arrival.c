/* test_arrival.c: the sky's arrival guide: a cell that saw the sky through a narrow opening is used and samples there with a density that integrates to one and matches its pdf; an open floor's cell is not used; cells and sides stay apart; the counts weigh by the sky's radiance.
 *
 * Counts are made as the eye pass makes them: cosine-distributed directions about the surface's
 * normal, of which those that leave through the opening (a cone about a window's direction) reach
 * the sky. The sample's density is checked against brute force: the share of samples in a cone
 * against the density integrated over it, and E[1 / pdf] over the samples, which is the solid
 * angle where the density is non-zero (the bins the counts reached).
 */
#include <math.h>
#include <stdlib.h>

#include "arrival.h"
#include "defaults.h"
#include "rng.h"
#include "testing.h"

static float white(const void *ctx, vec3 w) { (void)ctx; (void)w; return 1.f; }
/* brighter above: the counts weigh by it */
static float brighter_up(const void *ctx, vec3 w) { (void)ctx; return w.z > 0.f ? 4.f : 1.f; }

/* A cosine-distributed direction about +y. */
static vec3 cosine_up(pm_rng *r) {
    float u1 = pm_rng_float(r), u2 = pm_rng_float(r), rad = sqrtf(u1), phi = 2.f * (float)PM_PI * u2;
    return v3(rad * cosf(phi), sqrtf(1.f - u1), rad * sinf(phi));
}

/* Counts n cosine rays at p (normal +y) that leave within the cone about axis of cosine cos_cone. */
static void count_through(pm_arrival_guide *g, vec3 p, vec3 axis, float cos_cone, int n, pm_rng *r) {
    for (int k = 0; k < n; k++) {
        vec3 w = cosine_up(r);
        if (v3_dot(w, axis) >= cos_cone) pm_arrival_count(g, p, v3(0.f, 1.f, 0.f), w);
    }
}

int main(void) {
    pm_arrival_guide g;
    CHECK(pm_arrival_init(&g, 0.5f, white, NULL), "the guide allocated");
    pm_rng r = pm_rng_for(7, 0, 0);
    vec3 window = v3_normalize(v3(0.6f, 0.5f, 0.f)), room = v3(1.1f, 0.2f, 1.3f), floor_open = v3(9.1f, 0.2f, 9.3f);
    float cos_cone = 0.95f; /* 0.31 sr */
    count_through(&g, room, window, cos_cone, 200000, &r);
    /* the open floor sees the whole hemisphere */
    count_through(&g, floor_open, v3(0.f, 1.f, 0.f), -1.f, 20000, &r);
    pm_arrival_finish(&g);
    pm_arrival_cell c = {NULL}, open = {NULL}, other_side = {NULL};
    CHECK(pm_arrival_find(&g, room, v3(0.f, 1.f, 0.f), &c), "the room's cell, seeing the sky through an opening, is used");
    CHECK(!pm_arrival_find(&g, floor_open, v3(0.f, 1.f, 0.f), &open), "the open floor's cell is not (the surface's own ray finds the sky as well)");
    CHECK(!pm_arrival_find(&g, room, v3(0.f, -1.f, 0.f), &other_side), "the room cell's other side has learned nothing");
    CHECK(!pm_arrival_find(&g, v3(room.x + 0.6f, room.y, room.z), v3(0.f, 1.f, 0.f), &other_side), "the next cell has learned nothing");
    CHECK(g.usable_count == 1, "one usable cell (%u)", g.usable_count);
    if (!c.cdf) return pm_test_done("test_arrival");

    /* brute force on the sample's density */
    const int n = 400000;
    double inverse = 0.0, in_cone = 0.0, mismatch = 0.0, off_unit = 0.0;
    vec3 probe_axis = v3_normalize(v3(0.7f, 0.45f, 0.1f));
    for (int k = 0; k < n; k++) {
        float pdf;
        vec3 w = pm_arrival_sample(&c, pm_rng_float(&r), pm_rng_float(&r), pm_rng_float(&r), &pdf);
        off_unit = fmax(off_unit, fabs(v3_length(w) - 1.0));
        if (!(pdf > 0.f)) continue;
        inverse += 1.0 / pdf;
        mismatch = fmax(mismatch, fabs(pdf - pm_arrival_pdf(&c, w)) / pdf);
        if (v3_dot(w, probe_axis) >= 0.97f) in_cone += 1.0;
    }
    /* E[1/pdf]: the solid angle of the bins with counts, at least the opening's 0.31 sr and, the
     * opening being about three bins across, well under the hemisphere's 2 pi */
    CHECK(off_unit < 1e-4, "unit directions (%.2g off)", off_unit);
    double support = inverse / n;
    CHECK(support > 0.3 && support < 2.0, "E[1/pdf] is the support's solid angle (%.3f sr)", support);
    CHECK(mismatch < 1e-5, "a sample's pdf is pm_arrival_pdf's along it (%.2g)", mismatch);
    /* the share of samples in a cone against the density integrated over it (a grid over the cone) */
    double integral = 0.0;
    int grid = 400;
    vec3 t = v3_normalize(v3_cross(probe_axis, v3(0.f, 0.f, 1.f))), b = v3_cross(probe_axis, t);
    for (int i = 0; i < grid; i++)
        for (int j = 0; j < grid; j++) {
            float cos_t = 1.f - (1.f - 0.97f) * ((float)i + 0.5f) / (float)grid, sin_t = sqrtf(1.f - cos_t * cos_t);
            float phi = 2.f * (float)PM_PI * ((float)j + 0.5f) / (float)grid;
            vec3 w = v3_add(v3_scale(probe_axis, cos_t), v3_add(v3_scale(t, sin_t * cosf(phi)), v3_scale(b, sin_t * sinf(phi))));
            integral += pm_arrival_pdf(&c, w) * (2.0 * PM_PI * (1.0 - 0.97)) / ((double)grid * grid);
        }
    CHECK(integral > 0.05, "the probe cone holds a share of the density (%.3f)", integral);
    CHECK_NEAR(in_cone / n, integral, 0.02, 0.002, "samples in a cone against the density integrated over it");

    /* the counts weigh by the sky's radiance: a cell that saw the sky equally above and below its
     * horizon (a wall) samples above four times as often */
    pm_arrival_guide h;
    CHECK(pm_arrival_init(&h, 0.5f, brighter_up, NULL), "the second guide allocated");
    vec3 wall = v3(0.2f, 0.3f, 0.1f), axis = v3(1.f, 0.f, 0.f);
    for (int k = 0; k < 40000; k++) {
        /* within a cone about +x, alternately above and below the horizon */
        vec3 w = v3_normalize(v3(1.f, 0.15f * (pm_rng_float(&r) - 0.5f), (k % 2 ? 0.1f : -0.1f) + 0.05f * (pm_rng_float(&r) - 0.5f)));
        pm_arrival_count(&h, wall, axis, w);
    }
    pm_arrival_finish(&h);
    pm_arrival_cell wc = {NULL};
    CHECK(pm_arrival_find(&h, wall, axis, &wc), "the wall's cell is used");
    if (wc.cdf) {
        double up = 0.0;
        for (int k = 0; k < 100000; k++) {
            float pdf;
            vec3 w = pm_arrival_sample(&wc, pm_rng_float(&r), pm_rng_float(&r), pm_rng_float(&r), &pdf);
            up += w.z > 0.f;
        }
        CHECK_NEAR(up / 100000.0, 0.8, 0.03, 0.0, "the share sampled above, where the sky is four times as bright");
    }
    /* forgetting */
    pm_arrival_clear(&g, 0.5f);
    CHECK(!pm_arrival_find(&g, room, v3(0.f, 1.f, 0.f), &c) && g.usable_count == 0, "a cleared guide has no usable cell");
    pm_arrival_free(&g);
    pm_arrival_free(&h);
    return pm_test_done("test_arrival");
}

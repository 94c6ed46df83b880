/* test_film_pack.c: the film's additive form (what MPI ranks sum): two films packed, summed and unpacked resolve to the mean of every sample and photon pass both hold, pixel by pixel against a brute-force sum, ragged films and unset statistics included. */
#include <string.h>

#include "film.h"
#include "rng.h"
#include "testing.h"

enum { W = 5, H = 3, PIXELS = W * H };

/* A film of `samples` samples (one more on the pixels x >= ahead_from, with a photon pass), its
 * sums and statistics random, some pixels' statistics unset. */
static void fill(pm_film *f, uint32_t samples, uint32_t passes, int ahead_from, uint64_t seed) {
    bool on[PM_COMPONENT_COUNT] = {true, false, false, true};
    bool slots[PM_SLOT_COUNT] = {false, true, false, false};
    CHECK(pm_film_init(f, W, H, on) && pm_film_enable_ppm(f, slots), "film");
    pm_rng rng = pm_rng_member(pm_rng_family_for(seed, 0), 0);
    for (size_t i = 0; i < PIXELS; i++) {
        int x = (int)(i % W);
        uint32_t n = samples + (x >= ahead_from ? 1u : 0u);
        for (uint32_t k = 0; k < n; k++) {
            pm_film_add(f, PM_DIRECT, i, v3(pm_rng_float(&rng), 2.f * pm_rng_float(&rng), 0.5f));
            pm_film_add(f, PM_INDIRECT, i, v3(0.1f * pm_rng_float(&rng), 0.f, 0.3f * pm_rng_float(&rng)));
        }
        pm_ppm_stat *st = &f->ppm[PM_SLOT_INDIRECT][i];
        if (i % 4 == 1) continue; /* no visible point at this pixel yet */
        st->r2 = 0.01 + 0.05 * pm_rng_float(&rng);
        st->n = 100.0 * pm_rng_float(&rng);
        for (int ch = 0; ch < 3; ch++) st->tau[ch] = 3.0 * pm_rng_float(&rng);
    }
    f->samples = samples;
    f->photon_passes = passes;
    if (ahead_from < W) pm_film_mark_ahead(f, ahead_from, 0, W, H, PM_FILM_AHEAD_SAMPLE | PM_FILM_AHEAD_PHOTON_PASS);
}

/* The brute-force answer for pixel i, channel ch of a component over films a and b. */
static double expected(const pm_film *a, const pm_film *b, pm_component c, size_t i, int ch) {
    const pm_film *films[2] = {a, b};
    double sum = 0, count = 0, photon = 0, passes = 0;
    for (int k = 0; k < 2; k++) {
        const pm_film *f = films[k];
        sum += pm_film_sum_at(f, c, 3 * i + (size_t)ch);
        count += pm_film_samples_at(f, i);
        bool ahead = f->ragged && (f->ahead[i] & PM_FILM_AHEAD_PHOTON_PASS);
        passes += f->photon_passes + (ahead ? 1 : 0);
        const pm_ppm_stat *st = &f->ppm[PM_SLOT_INDIRECT][i];
        if (c == PM_INDIRECT && st->r2 > 0) photon += st->tau[ch] / st->r2;
    }
    double v = count > 0 ? sum / count : 0;
    if (c == PM_INDIRECT && passes > 0) v += photon / (PM_PI * passes);
    return v;
}

int main(void) {
    pm_film a, b, merged;
    fill(&a, 3, 2, 2, 1);  /* ragged: columns 2.. hold a fourth sample and a third photon pass */
    fill(&b, 5, 4, W, 2);  /* even */
    fill(&merged, 0, 0, W, 3);
    size_t count = pm_film_packed_count(&a);
    CHECK(count == pm_film_packed_count(&b), "the same layout, the same count");
    CHECK(count == 2 + PIXELS * (1 + 3 * 2 + 7), "count %zu: 2 header values, per pixel 1 + 3 per component + 7 per slot", count);
    double *pa = malloc(count * sizeof *pa), *pb = malloc(count * sizeof *pb);
    pm_film_pack(&a, pa);
    pm_film_pack(&b, pb);
    for (size_t k = 0; k < count; k++) pa[k] += pb[k]; /* what MPI_Reduce(MPI_SUM) does */
    pm_film_unpack(&merged, pa);
    CHECK(merged.samples == 8 && merged.photon_passes == 6 && !merged.ragged, "counts %u, %u", merged.samples, merged.photon_passes);
    float out[3 * PIXELS];
    for (int c = 0; c < PM_COMPONENT_COUNT; c += 3) {
        pm_film_resolve(&merged, (pm_component)c, out);
        for (size_t i = 0; i < PIXELS; i++)
            for (int ch = 0; ch < 3; ch++) {
                char what[96];
                snprintf(what, sizeof what, "merged component %d pixel %zu channel %d", c, i, ch);
                CHECK_NEAR(out[3 * i + ch], expected(&a, &b, (pm_component)c, i, ch), 2e-6, 1e-7, what);
            }
    }
    /* the merged radius is the mean of the films that had one */
    for (size_t i = 0; i < PIXELS; i++) {
        double ra = a.ppm[PM_SLOT_INDIRECT][i].r2, rb = b.ppm[PM_SLOT_INDIRECT][i].r2;
        double want = ra > 0 && rb > 0 ? 0.5 * (ra + rb) : (ra > 0 ? ra : rb);
        CHECK_NEAR(merged.ppm[PM_SLOT_INDIRECT][i].r2, want, 1e-7, 0, "merged r2 (a float)");
    }
    /* one film alone, packed and unpacked, resolves as itself (the ragged one: its counts made even) */
    pm_film_pack(&a, pa);
    pm_film_unpack(&merged, pa);
    float own[3 * PIXELS];
    for (int c = 0; c < PM_COMPONENT_COUNT; c += 3) {
        pm_film_resolve(&a, (pm_component)c, own);
        pm_film_resolve(&merged, (pm_component)c, out);
        for (size_t i = 0; i < 3 * PIXELS; i++) CHECK_NEAR(out[i], own[i], 2e-6, 1e-7, "a film through its additive form");
    }
    /* an empty form (a rank with nothing since a restart) adds nothing and makes an empty film */
    memset(pa, 0, count * sizeof *pa);
    pm_film_unpack(&merged, pa);
    pm_film_resolve(&merged, PM_INDIRECT, out);
    double sum = 0;
    for (size_t i = 0; i < 3 * PIXELS; i++) sum += out[i];
    CHECK(merged.samples == 0 && sum == 0, "an empty form: %u samples, %g", merged.samples, sum);
    free(pa);
    free(pb);
    pm_film_free(&a);
    pm_film_free(&b);
    pm_film_free(&merged);
    return pm_test_done("test_film_pack");
}

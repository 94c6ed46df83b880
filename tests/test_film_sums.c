/* test_film_sums.c: the film's compensated sums do not drift: 10^6 samples of a constant resolve to that constant within 1e-6 relative (a plain float sum is percents off), in every component and channel, on even and ragged films; statistics folded into the sums resolve the same after the fold. */
#include <string.h>

#include "film.h"
#include "testing.h"

enum { SAMPLES = 1000000 };

int main(void) {
    /* constants whose float sum rounds at almost every step */
    const float value[3] = {0.1f, 1.f / 3.f, 7.77f};
    bool on[PM_COMPONENT_COUNT] = {true, false, true, false};
    pm_film f;
    CHECK(pm_film_init(&f, 2, 1, on), "film");
    float naive[3] = {0.f, 0.f, 0.f};
    size_t refused = 0;
    for (int i = 0; i < SAMPLES; i++) {
        for (size_t px = 0; px < 2; px++) {
            refused += !pm_film_add(&f, PM_DIRECT, px, v3(value[0], value[1], value[2]));
            /* the second component gets the constant in two halves: a sum of unequal parts */
            refused += !pm_film_add(&f, PM_CAUSTIC, px, v3(0.5f * value[0], 0.5f * value[1], 0.5f * value[2]));
            refused += !pm_film_add(&f, PM_CAUSTIC, px, v3(0.5f * value[0], 0.5f * value[1], 0.5f * value[2]));
        }
        for (int ch = 0; ch < 3; ch++) naive[ch] += value[ch];
    }
    f.samples = SAMPLES;
    CHECK(refused == 0, "no sample refused (%zu)", refused);
    float out[6];
    for (int c = 0; c < PM_COMPONENT_COUNT; c += 2) {
        pm_film_resolve(&f, (pm_component)c, out);
        for (int k = 0; k < 6; k++) {
            double want = value[k % 3], got = out[k];
            CHECK(fabs(got - want) <= 1e-6 * want, "component %d, pixel %d, channel %d: %.9g resolves to %.9g (relative %.3g)", c,
                  k / 3, k % 3, want, got, fabs(got - want) / want);
        }
        for (int ch = 0; ch < 3; ch++)
            CHECK(fabs(pm_film_sum_at(&f, (pm_component)c, (size_t)ch) - (double)SAMPLES * value[ch]) <= 1e-6 * SAMPLES * value[ch],
                  "component %d, channel %d: the compensated sum %.9g, want %.9g", c, ch, pm_film_sum_at(&f, (pm_component)c, (size_t)ch),
                  (double)SAMPLES * value[ch]);
    }
    /* what this guards against: the same sum in plain float is far off */
    for (int ch = 0; ch < 3; ch++) {
        double drift = fabs(naive[ch] / SAMPLES - value[ch]) / value[ch];
        printf("channel %d: a plain float sum of 10^6 samples of %.6g resolves %.3g%% off, the film's %.3g%%\n", ch, value[ch],
               100.0 * drift, 100.0 * fabs(out[ch] - value[ch]) / value[ch]);
        CHECK(drift > 1e-4, "a plain float sum drifts (%.3g): the check above can fail", drift);
    }
    /* a ragged film: pixel 1 one sample ahead, its sum and count both */
    pm_film_add(&f, PM_DIRECT, 1, v3(value[0], value[1], value[2]));
    pm_film_mark_ahead(&f, 1, 0, 2, 1, PM_FILM_AHEAD_SAMPLE);
    pm_film_resolve(&f, PM_DIRECT, out);
    for (int k = 0; k < 6; k++)
        CHECK(fabs(out[k] - value[k % 3]) <= 1e-6 * value[k % 3], "ragged, pixel %d channel %d: %.9g", k / 3, k % 3, out[k]);
    /* the total adds the components, and allocates nothing */
    float total[6];
    CHECK(pm_film_resolve_total(&f, total), "total");
    for (int k = 0; k < 6; k++)
        CHECK(fabs(total[k] - 2.0 * value[k % 3]) <= 2e-6 * value[k % 3], "total, pixel %d channel %d: %.9g", k / 3, k % 3, total[k]);
    pm_film_free(&f);

    /* pm_film_fold_statistics: each pixel resolves the same after the fold (a pixel ahead by a sample and a
     * photon pass, and one whose statistics never started, among them), and the slot is empty */
    bool comps[PM_COMPONENT_COUNT] = {false, true, true, false};
    bool slots[PM_SLOT_COUNT] = {false, false, false, false};
    slots[PM_SLOT_CAUSTIC] = slots[PM_SLOT_SPECULAR_CAUSTIC] = true;
    comps[pm_slot_component[PM_SLOT_CAUSTIC]] = comps[pm_slot_component[PM_SLOT_SPECULAR_CAUSTIC]] = true;
    pm_film g;
    CHECK(pm_film_init(&g, 3, 1, comps) && pm_film_enable_ppm(&g, slots), "film with statistics");
    g.samples = 6;
    g.photon_passes = 3;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++)
        if (comps[c])
            for (size_t i = 0; i < 3; i++) pm_film_add(&g, (pm_component)c, i, v3(0.5f * (float)(i + 1), 0.25f, 2.f));
    for (int k = 0; k < PM_SLOT_COUNT; k++)
        if (slots[k])
            for (size_t i = 0; i < 2; i++) { /* pixel 2 keeps no statistics */
                pm_ppm_stat *st = &g.ppm[k][i];
                st->r2 = 0.01 * (double)(i + 1 + k);
                st->n = 7.0;
                st->tau[0] = 0.3f * (float)(k + 1);
                st->tau[1] = 0.05f;
                st->tau[2] = 1.5f;
            }
    pm_film_mark_ahead(&g, 1, 0, 2, 1, PM_FILM_AHEAD_SAMPLE | PM_FILM_AHEAD_PHOTON_PASS);
    float before[2][9], after[2][9];
    for (int k = 0; k < PM_SLOT_COUNT; k++)
        if (slots[k]) pm_film_resolve(&g, pm_slot_component[k], before[k == PM_SLOT_CAUSTIC ? 0 : 1]);
    pm_film_fold_statistics(&g, PM_SLOT_CAUSTIC);
    pm_film_fold_statistics(&g, PM_SLOT_SPECULAR_CAUSTIC);
    for (int k = 0; k < PM_SLOT_COUNT; k++)
        if (slots[k]) {
            int which = k == PM_SLOT_CAUSTIC ? 0 : 1;
            pm_film_resolve(&g, pm_slot_component[k], after[which]);
            for (int j = 0; j < 9; j++)
                CHECK(fabs(after[which][j] - before[which][j]) <= 1e-6 * fabs(before[which][j]), "folded slot %d, pixel %d channel %d: %.9g resolved %.9g before",
                      k, j / 3, j % 3, after[which][j], before[which][j]);
            for (size_t i = 0; i < 3; i++) CHECK(g.ppm[k][i].r2 == 0.0 && g.ppm[k][i].tau[0] == 0.f, "slot %d, pixel %zu: statistics left after the fold", k, i);
        }
    CHECK(before[0][0] > 0.5f * 1.01f, "the statistics add nothing to the first pixel (%.9g): the check above cannot fail", before[0][0]);
    pm_film_free(&g);
    return pm_test_done("test_film_sums");
}

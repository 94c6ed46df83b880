/* test_film_sums.c: the film's compensated sums do not drift: 10^6 samples of a constant resolve to that constant within 1e-6 relative (a plain float sum is percents off), in every component and channel, on even and ragged films. */
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
    return pm_test_done("test_film_sums");
}

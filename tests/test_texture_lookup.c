/* test_texture_lookup.c: texture lookups against a brute-force double-precision reference of glTF's samplers (REPEAT, CLAMP_TO_EDGE, MIRRORED_REPEAT).
 *
 * The renderer folds a coordinate into one period and wraps texel indices by compares (it runs
 * four times for every texture of every hit); the reference here wraps each tap with a modulo in
 * double precision, as the glTF and OpenGL specifications define the modes. Random texels, sizes
 * from 1 to 257 texels (odd, even, a power of two), coordinates inside the texture, a few periods
 * away, on texel and period boundaries, and very large or tiny: the two must agree to the float
 * rounding of the fold (within 2e-3 in value: a weight off by 2e-3 of a texel at 16 periods
 * out), and lookups at extreme coordinates must give values in the texels' range. A tap outside
 * the texture is a heap overflow that the ASan build of this test reports.
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "rng.h"
#include "scene.h"
#include "testing.h"

/* The texel index a wrap mode gives integer index i on an axis of n texels (glTF / OpenGL). */
static long reference_wrap(long i, long n, int mode) {
    if (mode == PM_WRAP_CLAMP) return i < 0 ? 0 : (i >= n ? n - 1 : i);
    if (mode == PM_WRAP_MIRROR) {
        long m = ((i % (2 * n)) + 2 * n) % (2 * n);
        return m < n ? m : 2 * n - 1 - m;
    }
    return ((i % n) + n) % n;
}

/* Bilinear filtering of the data texture at (u, v), in double, with texel centres at (i + 0.5) / n. */
static double reference_lookup(const pm_texture *t, double u, double v, int channel) {
    if (t->wrap_s == PM_WRAP_CLAMP) u = fmin(fmax(u, -1.0), 2.0);
    if (t->wrap_t == PM_WRAP_CLAMP) v = fmin(fmax(v, -1.0), 2.0);
    double x = u * t->width - 0.5, y = v * t->height - 0.5, x0 = floor(x), y0 = floor(y), ax = x - x0, ay = y - y0;
    double sum = 0.0;
    for (int k = 0; k < 4; k++) {
        long xi = reference_wrap((long)x0 + (k & 1), t->width, t->wrap_s);
        long yi = reference_wrap((long)y0 + (k >> 1), t->height, t->wrap_t);
        double w = ((k & 1) ? ax : 1.0 - ax) * ((k >> 1) ? ay : 1.0 - ay);
        sum += w * t->rgba[4 * (yi * t->width + xi) + channel] / 255.0;
    }
    return sum;
}

static double random_coordinate(pm_rng *rng, int n) {
    switch (pm_rng_u32(rng) % 6) {
    case 0: return pm_rng_float(rng);                                         /* inside */
    case 1: return (pm_rng_float(rng) - 0.5) * 8.0;                           /* a few periods out */
    case 2: return (pm_rng_float(rng) - 0.5) * 32.0;                          /* up to 16 periods out */
    case 3: return (double)((int)(pm_rng_u32(rng) % 9) - 4);                  /* period boundaries */
    case 4: return ((int)(pm_rng_u32(rng) % (4 * n)) - 2 * n + 0.5) / n;     /* texel centres */
    default: return ((int)(pm_rng_u32(rng) % (4 * n)) - 2 * n) / (double)n;  /* texel edges */
    }
}

/* pm_texture_channel_bounds against a per-channel scan, on sizes whose byte counts are and are not
 * multiples of its 16-byte stride, with each channel's extremes planted at the first texel, the
 * last (in the tail past the stride) or between */
static void test_channel_bounds(void) {
    pm_rng rng = pm_rng_for(9, 1, 2);
    const int widths[] = {1, 2, 3, 4, 5, 7, 64, 129};
    long differ = 0, cases = 0;
    for (size_t wi = 0; wi < sizeof widths / sizeof *widths; wi++)
        for (int h = 1; h <= 3; h++)
            for (int trial = 0; trial < 8; trial++) {
                pm_texture t;
                memset(&t, 0, sizeof t);
                t.width = widths[wi], t.height = h;
                size_t n = (size_t)t.width * h;
                t.rgba = malloc(4 * n);
                for (size_t i = 0; i < 4 * n; i++) t.rgba[i] = (uint8_t)(40 + (pm_rng_u32(&rng) % 170));
                for (int c = 0; c < 4; c++) { /* a 0 and a 255 somewhere (or not) in each channel */
                    size_t at[3] = {0, n - 1, pm_rng_u32(&rng) % n};
                    if (trial % 4 != 3) t.rgba[4 * at[(trial + c) % 3] + c] = 0;
                    if (trial % 4 != 2) t.rgba[4 * at[(trial + c + 1) % 3] + c] = 255;
                }
                uint8_t lo[4], hi[4];
                pm_texture_channel_bounds(&t, lo, hi);
                for (int c = 0; c < 4; c++) {
                    uint8_t want_lo = 255, want_hi = 0;
                    for (size_t i = 0; i < n; i++) {
                        uint8_t x = t.rgba[4 * i + c];
                        want_lo = x < want_lo ? x : want_lo;
                        want_hi = x > want_hi ? x : want_hi;
                    }
                    differ += lo[c] != want_lo || hi[c] != want_hi;
                    cases++;
                }
                free(t.rgba);
            }
    CHECK(differ == 0, "channel bounds differ from a per-channel scan in %ld of %ld cases", differ, cases);
}

int main(void) {
    const int sizes[] = {1, 2, 3, 5, 64, 257};
    const int modes[] = {PM_WRAP_REPEAT, PM_WRAP_CLAMP, PM_WRAP_MIRROR};
    pm_rng rng = pm_rng_for(7, 1, 2);
    double worst = 0.0;
    long lookups = 0, outside = 0;
    for (size_t si = 0; si < sizeof sizes / sizeof *sizes; si++)
        for (size_t sj = 0; sj < sizeof sizes / sizeof *sizes; sj += 2)
            for (int ms = 0; ms < 3; ms++)
                for (int mt = 0; mt < 3; mt++) {
                    pm_texture t;
                    memset(&t, 0, sizeof t);
                    t.width = sizes[si];
                    t.height = sizes[sj];
                    t.wrap_s = modes[ms];
                    t.wrap_t = modes[mt];
                    t.rgba = malloc(4 * (size_t)t.width * t.height);
                    for (int i = 0; i < 4 * t.width * t.height; i++) t.rgba[i] = (uint8_t)(pm_rng_u32(&rng) & 255);
                    for (int k = 0; k < 400; k++) {
                        float u = (float)random_coordinate(&rng, t.width), v = (float)random_coordinate(&rng, t.height);
                        vec3 got = pm_texture_lookup_data(&t, u, v);
                        double want = reference_lookup(&t, u, v, 0);
                        double err = fabs(got.x - want);
                        if (err > worst) worst = err;
                        if (err > 2e-3)
                            CHECK(false, "%dx%d wrap %d,%d at (%.9g, %.9g): %.6f, reference %.6f", t.width, t.height,
                                  t.wrap_s, t.wrap_t, u, v, got.x, want);
                        lookups++;
                    }
                    /* far and tiny coordinates: finite, within the texels' range, no index outside */
                    const float extreme[] = {1e7f, -1e7f, 3e9f, -3e9f, 1e30f, -1e30f, 1e-30f, -1e-30f, -0.f, 8388607.5f};
                    for (size_t e = 0; e < sizeof extreme / sizeof *extreme; e++) {
                        vec3 got = pm_texture_lookup_data(&t, extreme[e], extreme[(e + 3) % 10]);
                        outside += !(got.x >= 0.f && got.x <= 1.f && got.y >= 0.f && got.y <= 1.f);
                    }
                    free(t.rgba);
                }
    CHECK(worst <= 2e-3, "worst difference from the reference %.3g", worst);
    CHECK(outside == 0, "%ld lookups at extreme coordinates outside [0, 1]", outside);
    CHECK(lookups == 6 * 3 * 9 * 400, "lookups %ld", lookups);
    printf("worst difference from the reference %.3g over %ld lookups\n", worst, lookups);
    test_channel_bounds();
    return pm_test_done("test_texture_lookup");
}

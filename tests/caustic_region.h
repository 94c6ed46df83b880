/* caustic_region.h: the caustic-against-reference measure shared by test_reference and bench/caustic_error (header-only).
 *
 * The region is the floor in a point light's full shadow, seen directly: pixels whose direct
 * and specular layers are zero in every sample. It is chosen by geometry, not by our own noisy
 * caustic, so noise cannot select the pixels it brightened; light there is the caustic plus a
 * little indirect light, in both renderers. The 3x3 pixels around the reference's brightest one
 * are measured apart: a glass ball's focus is a singularity of the irradiance, where a pixel's
 * value depends on how far a density estimate spreads it, while the rest must match.
 */
#ifndef PM_CAUSTIC_REGION_H
#define PM_CAUSTIC_REGION_H

#include <stddef.h>
#include <stdlib.h>

typedef struct {
    size_t pixels;                 /* in the region, focus excluded */
    double ours, ref, caustic;     /* sums of R+G+B over the region (caustic: our caustic layer) */
    double focus_ours, focus_ref;  /* sums over the 3x3 focus pixels that lie in the region */
    double relmse;                 /* mean of (x - r)^2 / (r^2 + 0.01) over the region's pixels and channels, focus excluded */
    int focus_x, focus_y;
} caustic_region;

/* Interleaved RGB for ours (total), direct, specular and caustic; planar R, G, B for the reference. */
static inline caustic_region caustic_region_measure(int w, int h, const float *total, const float *direct,
                                                    const float *specular, const float *caustic,
                                                    const float *const ref[3]) {
    caustic_region m = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    size_t n = (size_t)w * h, focus = 0;
    for (size_t i = 1; i < n; i++) if (ref[0][i] > ref[0][focus]) focus = i;
    m.focus_x = (int)(focus % (size_t)w);
    m.focus_y = (int)(focus / (size_t)w);
    for (size_t i = 0; i < n; i++) {
        if (direct[3 * i] != 0.f || specular[3 * i] != 0.f || total[3 * i] <= 0.f) continue;
        double o = total[3 * i] + total[3 * i + 1] + total[3 * i + 2], r = ref[0][i] + ref[1][i] + ref[2][i];
        int x = (int)(i % (size_t)w), y = (int)(i / (size_t)w);
        if (abs(x - m.focus_x) <= 1 && abs(y - m.focus_y) <= 1) { m.focus_ours += o; m.focus_ref += r; continue; }
        m.ours += o;
        m.ref += r;
        for (int c = 0; c < 3; c++) {
            double d = total[3 * i + c] - ref[c][i];
            m.relmse += d * d / ((double)ref[c][i] * ref[c][i] + 0.01);
        }
        m.caustic += caustic[3 * i] + caustic[3 * i + 1] + caustic[3 * i + 2];
        m.pixels++;
    }
    if (m.pixels) m.relmse /= 3.0 * (double)m.pixels;
    return m;
}

#endif

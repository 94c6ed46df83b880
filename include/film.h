/* film.h: per-component radiance accumulation (direct, specular, caustic, indirect) in linear float RGB.
 *
 * A component the scene analysis rules out gets no buffer at all (sum[c] == NULL): it is
 * black by construction and costs no memory. The film stores sums of samples; every pixel
 * holds the same sample count, so a component's mean is sum / samples.
 */
#ifndef PM_FILM_H
#define PM_FILM_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "scene.h"

typedef struct {
    int width, height;
    float *sum[PM_COMPONENT_COUNT]; /* 3*width*height floats each, row 0 = top; NULL = always black */
    uint32_t samples;               /* samples per pixel accumulated so far */
} pm_film;

bool pm_film_init(pm_film *f, int width, int height, const bool component_enabled[PM_COMPONENT_COUNT]);
void pm_film_free(pm_film *f);
void pm_film_clear(pm_film *f);
/* Mean radiance of one component into out (3*w*h floats); zeros for an absent component. */
void pm_film_resolve(const pm_film *f, pm_component c, float *out);
/* Mean of the sum of all components. */
void pm_film_resolve_total(const pm_film *f, float *out);
size_t pm_film_bytes(const pm_film *f);

/* An image against a reference: relMSE = mean over pixels (those with mask[i] != 0, or all when
 * mask is NULL) and channels of (x - r)^2 / (r^2 + 0.01), and each channel's sums, whose ratio is
 * the mean ratio. rgb is interleaved, ref planar. The one definition --reference and the tests use. */
typedef struct {
    double relmse;
    double ours[3], ref[3];
    size_t pixels;
} pm_image_error;
pm_image_error pm_image_compare(const float *rgb, const float *const ref[3], size_t pixels, const unsigned char *mask);

#endif

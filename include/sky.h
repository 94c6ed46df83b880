/* sky.h: environment maps around the scene: equirectangular radiance, lookup, importance sampling by luminance.
 *
 * One mechanism for every sky that is not uniform: the default gradient and a user's .exr or
 * .hdr are both maps. Directions map to the image as
 *     u = 1/2 + atan2(x, -z) / 2pi,   v = acos(y) / pi        (+Y up, row 0 = the zenith),
 * so the middle of the image lies along -Z, where a glTF camera looks by default. Radiance is
 * piecewise constant per texel, and the sampler draws texels in proportion to luminance x the
 * texel's solid angle: pm_sky_map_pdf is exactly the density pm_sky_map_sample draws from.
 */
#ifndef PM_SKY_H
#define PM_SKY_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "pm_math.h"

typedef struct {
    int width, height;
    float *rgb;          /* width*height*3, linear radiance, row 0 = the zenith */
    float *row_cdf;      /* height+1: rows by their summed weight */
    float *column_cdf;   /* height*(width+1): texels within each row */
    uint32_t *row_cut;   /* height: row_cdf's cut points (pm_cdf_cut_points) */
    uint32_t *column_cut;/* height*width: each row's column cdf's */
    double *band_cos;    /* height+1: the cosine of each row's upper polar angle (row height: the nadir's) */
    vec3 mean;           /* radiance averaged over the sphere (per solid angle) */
    float peak_over_mean;/* the brightest texel's channel mean over the sphere's (1 for a uniform map): how concentrated its light is */
    size_t clamped;      /* texels above PM_MAX_EMISSION or not finite, clamped: the caller warns */
    uint64_t admitted;   /* bytes admitted against --max-memory for it (memory.h), given back when it is freed */
    bool rotated;        /* turned about +Y (--sky-rotate): lookups and samples go through the turn */
    double turn_cos, turn_sin; /* the turn's cosine and sine, when rotated */
} pm_sky_map;

#define PM_SKY_MAX_TEXELS ((uint64_t)1 << 28) /* 16384 x 16384: past that a map is refused */

/* Copies w*h linear RGB texels. Each is clamped as the scene's emission is: negative and NaN
 * components read as 0, +Inf as the largest float, and a texel whose largest component exceeds
 * PM_MAX_EMISSION is scaled down to it (counted in `clamped`, as are non-finite ones). NULL with
 * err set when out of memory or when the map holds no light at all. */
pm_sky_map *pm_sky_map_create(int width, int height, const float *rgb, char *err, size_t err_size);
/* The same, taking the malloc'ed texels over (freed on failure too) instead of copying them. */
pm_sky_map *pm_sky_map_adopt(int width, int height, float *rgb, char *err, size_t err_size);
/* The bytes a map of width x height texels takes: its texels and its sampling tables, and what
 * building them holds for a while; for the memory limit before a file is decoded. */
uint64_t pm_sky_map_bytes(int width, int height);
/* pmview's default environment: a bright zenith fading to a dimmer horizon above a grey ground,
 * so that a lit white object stands out from the background. */
pm_sky_map *pm_sky_map_gradient(char *err, size_t err_size);
void pm_sky_map_free(pm_sky_map *m);
/* Turns the map by `degrees` about +Y (counter-clockwise seen from above: what lay along -Z then
 * lies along -X for 90) for every lookup, sample and pdf. The angle is taken modulo 360, and a
 * whole turn is no turn at all, so 360 gives the unrotated map bit for bit. */
void pm_sky_map_rotate(pm_sky_map *m, double degrees);

vec3 pm_sky_map_radiance(const pm_sky_map *m, vec3 dir);
/* A direction toward the sky drawn by luminance x solid angle; returns its radiance, *pdf per steradian. */
vec3 pm_sky_map_sample(const pm_sky_map *m, float u1, float u2, vec3 *dir, float *pdf);
float pm_sky_map_pdf(const pm_sky_map *m, vec3 dir);
/* The two numbers pm_sky_map_sample turns into dir (its mapping turned back). */
void pm_sky_map_numbers(const pm_sky_map *m, vec3 dir, float *u1, float *u2);

#endif

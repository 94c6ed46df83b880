/* sky.c: equirectangular environment maps: clamping their texels, building the sampling distribution, lookup, sampling, the default gradient. */
#include "sky.h"
#include "memory.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "defaults.h"

void pm_sky_map_free(pm_sky_map *m) {
    if (!m) return;
    pm_memory_release(m->admitted);
    free(m->rgb);
    free(m->row_cdf);
    free(m->column_cdf);
    free(m->row_cut);
    free(m->column_cut);
    free(m->band_cos);
    free(m);
}

/* Solid angle of one texel of row `row`: the band between its two polar angles, split in width. */
static double texel_solid_angle(const pm_sky_map *m, int row) {
    return 2.0 * PM_PI / m->width * (m->band_cos[row] - m->band_cos[row + 1]);
}

static double texel_weight(const float *rgb) { return ((double)rgb[0] + rgb[1] + rgb[2]) * (1.0 / 3.0); }

/* Scales a texel down to PM_MAX_EMISSION in its largest component, as the scene clamps emission
 * (hue kept; +Inf counts as the largest float, NaN and negative components read as 0): a float
 * film could not sum more, and the sampler's sums would overflow. True when it had to, except
 * for finite negatives (the ringing of a resampled map), which need no warning. */
static bool clamp_texel(float *t) {
    bool changed = false;
    float m = 0.f;
    for (int c = 0; c < 3; c++) {
        if (!isfinite(t[c])) changed = true;
        if (!(t[c] > 0.f)) t[c] = 0.f;
        if (t[c] > FLT_MAX) t[c] = FLT_MAX;
        if (t[c] > m) m = t[c];
    }
    if (m > PM_MAX_EMISSION) {
        double scale = PM_MAX_EMISSION / (double)m;
        for (int c = 0; c < 3; c++) t[c] = (float)(t[c] * scale);
        changed = true;
    }
    return changed;
}

uint64_t pm_sky_map_bytes(int width, int height) {
    uint64_t w = width > 0 ? (uint64_t)width : 0, h = height > 0 ? (uint64_t)height : 0;
    /* texels, each row's column cdf and its cut points, the row cdf and its, the bands' cosines,
     * and the row sums while the cdfs are built */
    return sizeof(pm_sky_map) + 3 * sizeof(float) * w * h + sizeof(float) * h * (w + 1) + sizeof(uint32_t) * h * w +
           sizeof(float) * (h + 1) + sizeof(uint32_t) * h + sizeof(double) * (h + 1) + sizeof(double) * h;
}

pm_sky_map *pm_sky_map_create(int width, int height, const float *rgb, char *err, size_t err_size) {
    if (width < 1 || height < 1 || (uint64_t)width * (uint64_t)height > PM_SKY_MAX_TEXELS) {
        snprintf(err, err_size, "environment map of %dx%d texels is not usable", width, height);
        return NULL;
    }
    size_t bytes = sizeof(float) * 3 * (size_t)width * (size_t)height;
    float *copy = pm_malloc(bytes, "environment map");
    if (!copy) {
        snprintf(err, err_size, "out of memory (environment map, %zu bytes)", bytes);
        return NULL;
    }
    memcpy(copy, rgb, bytes);
    return pm_sky_map_adopt(width, height, copy, err, err_size);
}

pm_sky_map *pm_sky_map_adopt(int width, int height, float *rgb, char *err, size_t err_size) {
    if (width < 1 || height < 1 || (uint64_t)width * (uint64_t)height > PM_SKY_MAX_TEXELS) {
        free(rgb);
        snprintf(err, err_size, "environment map of %dx%d texels is not usable", width, height);
        return NULL;
    }
    size_t n = (size_t)width * height;
    pm_sky_map *m = pm_calloc(1, sizeof *m, "environment map");
    double *row_sum = NULL;
    if (m) {
        m->rgb = rgb;
        rgb = NULL;
        m->row_cdf = pm_malloc(sizeof(float) * ((size_t)height + 1), "environment map");
        m->column_cdf = pm_malloc(sizeof(float) * (size_t)height * ((size_t)width + 1), "environment map");
        m->row_cut = pm_malloc(sizeof(uint32_t) * (size_t)height, "environment map");
        m->column_cut = pm_malloc(sizeof(uint32_t) * (size_t)height * (size_t)width, "environment map");
        m->band_cos = pm_malloc(sizeof(double) * ((size_t)height + 1), "environment map");
        row_sum = pm_malloc(sizeof(double) * (size_t)height, "environment map");
    }
    if (!m || !m->row_cdf || !m->column_cdf || !m->row_cut || !m->column_cut || !m->band_cos || !row_sum) {
        free(rgb);
        free(row_sum);
        pm_sky_map_free(m);
        snprintf(err, err_size, "out of memory (environment map, %llu bytes)", (unsigned long long)pm_sky_map_bytes(width, height));
        return NULL;
    }
    m->width = width;
    m->height = height;
    /* read by every sample and density: a table, not two cosines a call */
    for (int y = 0; y <= height; y++) m->band_cos[y] = cos(PM_PI * y / height);
    for (size_t i = 0; i < n; i++) m->clamped += clamp_texel(m->rgb + 3 * i);
    /* Sums in double (2^28 texels of at most 1e20 stay far inside its range), stored normalised as
     * floats; a row of zero weight keeps a uniform column cdf (it is never picked, and lookups
     * need no special case) */
    double total = 0.0, mean[3] = {0, 0, 0}, peak = 0.0;
    m->row_cdf[0] = 0.f;
    for (int y = 0; y < height; y++) {
        double omega = texel_solid_angle(m, y);
        float *cdf = m->column_cdf + (size_t)y * (width + 1);
        const float *row = m->rgb + 3 * (size_t)y * width;
        double run = 0.0;
        for (int x = 0; x < width; x++) {
            double weight = texel_weight(row + 3 * x);
            run += weight;
            peak = fmax(peak, weight);
            for (int c = 0; c < 3; c++) mean[c] += row[3 * x + c] * omega;
        }
        /* a second pass, so that the partial sums reach the division in double rather than stored
         * in the float cdf first (a row of texels near the float limit overflowed it: inf / inf) */
        double partial = 0.0;
        cdf[0] = 0.f;
        for (int x = 0; x < width; x++) {
            partial += texel_weight(row + 3 * x);
            cdf[x + 1] = run > 0.0 ? (float)(partial / run) : (float)(x + 1) / width;
        }
        cdf[width] = 1.f;
        pm_cdf_cut_points(cdf, (uint32_t)width, m->column_cut + (size_t)y * width);
        row_sum[y] = run * omega;
        total += row_sum[y];
    }
    if (!(total > 0.0)) {
        free(row_sum);
        pm_sky_map_free(m);
        snprintf(err, err_size, "the environment map is black: it would light nothing");
        return NULL;
    }
    double run = 0.0;
    for (int y = 0; y < height; y++) {
        run += row_sum[y];
        m->row_cdf[y + 1] = (float)(run / total);
    }
    m->row_cdf[height] = 1.f;
    pm_cdf_cut_points(m->row_cdf, (uint32_t)height, m->row_cut);
    free(row_sum);
    m->mean = v3((float)(mean[0] / (4.0 * PM_PI)), (float)(mean[1] / (4.0 * PM_PI)), (float)(mean[2] / (4.0 * PM_PI)));
    m->peak_over_mean = (float)(peak / ((mean[0] + mean[1] + mean[2]) / (3.0 * 4.0 * PM_PI))); /* total > 0: the mean is too */
    return m;
}

void pm_sky_map_rotate(pm_sky_map *m, double degrees) {
    double turn = fmod(degrees, 360.0);
    if (turn < 0.0) turn += 360.0;
    m->rotated = isfinite(turn) && turn != 0.0;
    if (!m->rotated) return;
    /* the quarter turns exactly, so that 90 maps axes onto axes */
    static const double quarter_cos[4] = {1, 0, -1, 0}, quarter_sin[4] = {0, 1, 0, -1};
    if (turn == floor(turn) && (int)turn % 90 == 0) {
        m->turn_cos = quarter_cos[(int)turn / 90];
        m->turn_sin = quarter_sin[(int)turn / 90];
    } else {
        m->turn_cos = cos(turn * (PM_PI / 180.0));
        m->turn_sin = sin(turn * (PM_PI / 180.0));
    }
}

/* A world direction in the map's own frame (the turn undone), and back. Counter-clockwise seen
 * from +Y: -Z goes to -X. */
static vec3 into_map(const pm_sky_map *m, vec3 d) {
    if (!m->rotated) return d;
    double c = m->turn_cos, s = m->turn_sin;
    return v3((float)(c * d.x - s * d.z), d.y, (float)(s * d.x + c * d.z));
}

static vec3 out_of_map(const pm_sky_map *m, vec3 d) {
    if (!m->rotated) return d;
    double c = m->turn_cos, s = m->turn_sin;
    return v3((float)(c * d.x + s * d.z), d.y, (float)(-s * d.x + c * d.z));
}

static void texel_of(const pm_sky_map *m, vec3 dir, int *x, int *y) {
    dir = into_map(m, dir);
    float len = v3_length(dir);
    float cy = len > 0.f ? dir.y / len : 1.f;
    cy = cy < -1.f ? -1.f : (cy > 1.f ? 1.f : cy);
    float u = 0.5f + atan2f(dir.x, -dir.z) * (0.5f * PM_INV_PI), v = acosf(cy) * PM_INV_PI;
    int ix = (int)(u * m->width), iy = (int)(v * m->height);
    *x = ix < 0 ? 0 : (ix >= m->width ? m->width - 1 : ix);
    *y = iy < 0 ? 0 : (iy >= m->height ? m->height - 1 : iy);
}

vec3 pm_sky_map_radiance(const pm_sky_map *m, vec3 dir) {
    int x, y;
    texel_of(m, dir, &x, &y);
    const float *t = m->rgb + 3 * ((size_t)y * m->width + x);
    return v3(t[0], t[1], t[2]);
}

float pm_sky_map_pdf(const pm_sky_map *m, vec3 dir) {
    int x, y;
    texel_of(m, dir, &x, &y);
    const float *cdf = m->column_cdf + (size_t)y * (m->width + 1);
    double p = (double)(m->row_cdf[y + 1] - m->row_cdf[y]) * (double)(cdf[x + 1] - cdf[x]);
    double omega = texel_solid_angle(m, y);
    return omega > 0.0 ? (float)(p / omega) : 0.f;
}

void pm_sky_map_numbers(const pm_sky_map *m, vec3 dir, float *u1, float *u2) {
    int x, y;
    texel_of(m, dir, &x, &y);
    dir = into_map(m, dir);
    float len = v3_length(dir), cy = len > 0.f ? dir.y / len : 1.f;
    double c0 = m->band_cos[y], c1 = m->band_cos[y + 1];
    double v = c1 != c0 ? (cy - c0) / (c1 - c0) : 0.5, w = (0.5 + atan2(dir.x, -dir.z) * (0.5 / PM_PI)) * m->width - x;
    v = v < 0.0 ? 0.0 : (v > 1.0 ? 1.0 : v);
    w = w < 0.0 ? 0.0 : (w > 1.0 ? 1.0 : w);
    const float *cdf = m->column_cdf + (size_t)y * (m->width + 1);
    *u1 = (float)fmin(m->row_cdf[y] + v * (m->row_cdf[y + 1] - m->row_cdf[y]), 0x1.fffffep-1);
    *u2 = (float)fmin(cdf[x] + w * (cdf[x + 1] - cdf[x]), 0x1.fffffep-1);
}

vec3 pm_sky_map_sample(const pm_sky_map *m, float u1, float u2, vec3 *dir, float *pdf) {
    int y = (int)pm_cdf_interval_cut(m->row_cdf, m->row_cut, (uint32_t)m->height, u1);
    float row_p = m->row_cdf[y + 1] - m->row_cdf[y];
    float v = row_p > 0.f ? (u1 - m->row_cdf[y]) / row_p : 0.5f; /* reused: uniform within the row's slice */
    const float *cdf = m->column_cdf + (size_t)y * (m->width + 1);
    int x = (int)pm_cdf_interval_cut(cdf, m->column_cut + (size_t)y * m->width, (uint32_t)m->width, u2);
    float col_p = cdf[x + 1] - cdf[x];
    float w = col_p > 0.f ? (u2 - cdf[x]) / col_p : 0.5f;
    v = v < 0.f ? 0.f : (v > 1.f ? 1.f : v);
    w = w < 0.f ? 0.f : (w > 1.f ? 1.f : w);
    /* uniform in solid angle within the texel: cos(theta) uniform across the band, phi uniform */
    double c0 = m->band_cos[y], c1 = m->band_cos[y + 1];
    double cos_t = c0 + (c1 - c0) * v, sin_t = sqrt(fmax(0.0, 1.0 - cos_t * cos_t));
    double phi = ((x + w) / m->width - 0.5) * 2.0 * PM_PI;
    *dir = out_of_map(m, v3((float)(sin_t * sin(phi)), (float)cos_t, (float)(-sin_t * cos(phi))));
    double omega = texel_solid_angle(m, y);
    *pdf = omega > 0.0 ? (float)((double)row_p * col_p / omega) : 0.f;
    const float *t = m->rgb + 3 * ((size_t)y * m->width + x);
    return v3(t[0], t[1], t[2]);
}

pm_sky_map *pm_sky_map_gradient(char *err, size_t err_size) {
    enum { W = 4, H = 256 };
    float rgb[W * H * 3];
    for (int y = 0; y < H; y++) {
        /* elevation of the row's centre: +pi/2 at the zenith, -pi/2 at the nadir */
        double elevation = 0.5 * PM_PI - PM_PI * (y + 0.5) / H;
        double s = sin(elevation);
        double l = s > 0.0 ? PM_SKY_HORIZON + (PM_SKY_ZENITH - PM_SKY_HORIZON) * s : PM_SKY_GROUND;
        for (int x = 0; x < W; x++)
            for (int c = 0; c < 3; c++) rgb[3 * (y * W + x) + c] = (float)l;
    }
    return pm_sky_map_create(W, H, rgb, err, err_size);
}

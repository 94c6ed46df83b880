/* film.c: allocation, clearing and resolving of the per-component accumulation buffers and progressive photon statistics. */
#include "film.h"
#include "memory.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

const pm_component pm_slot_component[PM_SLOT_COUNT] = {PM_CAUSTIC, PM_INDIRECT, PM_SPECULAR, PM_SPECULAR};

bool pm_film_init(pm_film *f, int width, int height, const bool enabled[PM_COMPONENT_COUNT]) {
    memset(f, 0, sizeof *f);
    if (width <= 0 || height <= 0) return false;
    f->width = width;
    f->height = height;
    size_t n = 3 * (size_t)width * height;
    uint64_t bytes = n / 3;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) bytes += enabled[c] ? n * sizeof(float) : 0;
    if (!pm_memory_admit(bytes, "film")) return false;
    f->admitted = bytes;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        if (!enabled[c]) continue;
        f->sum[c] = pm_calloc(n, sizeof(float), "film");
        if (!f->sum[c]) { pm_film_free(f); return false; }
    }
    f->ahead = pm_calloc(n / 3, 1, "film");
    if (!f->ahead) { pm_film_free(f); return false; }
    return true;
}

bool pm_film_enable_ppm(pm_film *f, const bool slot_enabled[PM_SLOT_COUNT]) {
    size_t n = (size_t)f->width * f->height;
    for (int k = 0; k < PM_SLOT_COUNT; k++) {
        if (!slot_enabled[k] || f->ppm[k]) continue;
        if (!f->sum[pm_slot_component[k]]) return false; /* a slot feeds a component that must exist */
        if (!pm_memory_admit((uint64_t)n * sizeof(pm_ppm_stat), "progressive photon statistics")) return false;
        f->admitted += (uint64_t)n * sizeof(pm_ppm_stat);
        f->ppm[k] = pm_calloc(n, sizeof(pm_ppm_stat), "progressive photon statistics");
        if (!f->ppm[k]) return false;
    }
    return true;
}

void pm_film_free(pm_film *f) {
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) free(f->sum[c]);
    for (int k = 0; k < PM_SLOT_COUNT; k++) free(f->ppm[k]);
    pm_memory_release(f->admitted);
    free(f->ahead);
    memset(f, 0, sizeof *f);
}

void pm_film_clear(pm_film *f) {
    size_t n = 3 * (size_t)f->width * f->height;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++)
        if (f->sum[c]) memset(f->sum[c], 0, n * sizeof(float));
    for (int k = 0; k < PM_SLOT_COUNT; k++)
        if (f->ppm[k]) memset(f->ppm[k], 0, (n / 3) * sizeof(pm_ppm_stat));
    if (f->ahead) memset(f->ahead, 0, n / 3);
    f->samples = 0;
    f->photon_passes = 0;
    f->ragged = false;
}

void pm_film_mark_ahead(pm_film *f, int x0, int y0, int x1, int y1, unsigned what) {
    if (!f->ahead) return;
    for (int y = y0; y < y1; y++)
        for (int x = x0; x < x1; x++) f->ahead[(size_t)y * f->width + x] |= (uint8_t)what;
    f->ragged = true;
}

static inline unsigned ahead_of(const pm_film *f, size_t pixel) { return f->ragged && f->ahead ? f->ahead[pixel] : 0u; }

uint32_t pm_film_samples_at(const pm_film *f, size_t pixel) {
    return f->samples + (ahead_of(f, pixel) & PM_FILM_AHEAD_SAMPLE ? 1u : 0u);
}

size_t pm_film_pixels_ahead(const pm_film *f) {
    size_t n = 0, pixels = (size_t)f->width * f->height;
    for (size_t i = 0; f->ragged && f->ahead && i < pixels; i++) n += f->ahead[i] & PM_FILM_AHEAD_SAMPLE;
    return n;
}

void pm_film_resolve(const pm_film *f, pm_component c, float *out) {
    size_t pixels = (size_t)f->width * f->height, n = 3 * pixels;
    if (!f->sum[c] || (f->samples == 0 && !f->ragged)) { memset(out, 0, n * sizeof(float)); return; }
    if (!f->ragged) {
        float inv = 1.f / (float)f->samples;
        for (size_t i = 0; i < n; i++) out[i] = f->sum[c][i] * inv;
    } else {
        for (size_t i = 0; i < pixels; i++) {
            uint32_t samples = pm_film_samples_at(f, i);
            float inv = samples ? 1.f / (float)samples : 0.f;
            for (int ch = 0; ch < 3; ch++) out[3 * i + ch] = f->sum[c][3 * i + ch] * inv;
        }
    }
    for (int k = 0; k < PM_SLOT_COUNT; k++) {
        if (pm_slot_component[k] != c || !f->ppm[k]) continue;
        const pm_ppm_stat *st = f->ppm[k];
        for (size_t i = 0; i < pixels; i++) {
            uint32_t passes = f->photon_passes + (ahead_of(f, i) & PM_FILM_AHEAD_PHOTON_PASS ? 1u : 0u);
            if (!(st[i].r2 > 0.0) || !passes) continue;
            double scale = 1.0 / (PM_PI * st[i].r2 * (double)passes);
            /* the statistics are doubles: their estimate is clamped into float range, never an Inf */
            for (int ch = 0; ch < 3; ch++) out[3 * i + ch] = (float)fmin(out[3 * i + ch] + st[i].tau[ch] * scale, FLT_MAX);
        }
    }
}

bool pm_film_add(pm_film *f, pm_component c, size_t pixel, vec3 v) {
    float *px = f->sum[c] + 3 * pixel;
    vec3 sum = v3(px[0] + v.x, px[1] + v.y, px[2] + v.z);
    if (!v3_is_finite(v) || !v3_is_finite(sum)) return false;
    px[0] = sum.x;
    px[1] = sum.y;
    px[2] = sum.z;
    return true;
}

bool pm_film_resolve_total(const pm_film *f, float *out) {
    size_t n = 3 * (size_t)f->width * f->height;
    memset(out, 0, n * sizeof(float));
    float *part = pm_malloc(n * sizeof(float), "image");
    if (!part) return false;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        if (!f->sum[c]) continue;
        pm_film_resolve(f, (pm_component)c, part);
        for (size_t i = 0; i < n; i++) out[i] += part[i];
    }
    free(part);
    return true;
}

size_t pm_film_bytes(const pm_film *f) {
    size_t n = 0;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++)
        if (f->sum[c]) n += 3 * (size_t)f->width * f->height * sizeof(float);
    for (int k = 0; k < PM_SLOT_COUNT; k++)
        if (f->ppm[k]) n += (size_t)f->width * f->height * sizeof(pm_ppm_stat);
    if (f->ahead) n += (size_t)f->width * f->height;
    return n;
}

pm_image_error pm_image_compare(const float *rgb, const float *const ref[3], size_t pixels, const unsigned char *mask) {
    pm_image_error e = {0, 0, {0, 0, 0}, {0, 0, 0}, 0};
    for (size_t i = 0; i < pixels; i++) {
        if (mask && !mask[i]) continue;
        e.pixels++;
        for (int c = 0; c < 3; c++) {
            double x = rgb[3 * i + c], r = ref[c][i];
            e.relmse += (x - r) * (x - r) / (r * r + 0.01);
            e.mse += (x - r) * (x - r);
            e.ours[c] += x;
            e.ref[c] += r;
        }
    }
    e.relmse /= 3.0 * (double)(e.pixels ? e.pixels : 1);
    e.mse /= 3.0 * (double)(e.pixels ? e.pixels : 1);
    return e;
}

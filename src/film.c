/* film.c: allocation, clearing and resolving of the per-component accumulation buffers and progressive photon statistics. */
#include "film.h"
#include "memory.h"

#include <assert.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

const pm_component pm_slot_component[PM_SLOT_COUNT] = {PM_CAUSTIC, PM_INDIRECT, PM_SPECULAR, PM_SPECULAR};

/* Bytes a component (sums and their low bits) or a statistics slot holds. */
static uint64_t component_bytes(size_t pixels) { return (uint64_t)pixels * 3 * (sizeof(float) + sizeof(int16_t)); }
static uint64_t slot_bytes(size_t pixels) { return (uint64_t)pixels * sizeof(pm_ppm_stat); }

/* A sum is a float and its low bits: an int16 in units of 2^-16 of the float's last place, 40
 * significant bits in all. Adding a sample rounds the exact total once to those 40 bits (where a
 * float sum rounds it to 24), so the sum of 10^6 samples of a constant is off by at most 10^6
 * roundings of 2^-41 of it, under 10^-6, while a float sum is percents off. */
static inline double low_unit(float hi) {
    uint32_t b;
    memcpy(&b, &hi, sizeof b);
    int e = (int)((b >> 23) & 0xffu);
    if (e == 0) e = 1; /* zero and the subnormals: their last place is 2^-149 */
    uint64_t bits = (uint64_t)(e - 150 - 16 + 1023) << 52; /* the last place is 2^(e - 150) */
    double unit;
    memcpy(&unit, &bits, sizeof unit);
    return unit;
}

static inline double value_of(float hi, int16_t low) { return low ? (double)hi + low * low_unit(hi) : (double)hi; }

/* The float nearest v, and what it leaves of v in low bits (a power-of-two scale: exact). */
static inline float split(double v, int16_t *low) {
    float hi = (float)v;
    long q = lrint((v - (double)hi) / low_unit(hi));
    *low = (int16_t)(q > INT16_MAX ? INT16_MAX : (q < -INT16_MAX ? -INT16_MAX : q));
    return hi;
}

bool pm_film_init(pm_film *f, int width, int height, const bool enabled[PM_COMPONENT_COUNT]) {
    memset(f, 0, sizeof *f);
    if (width <= 0 || height <= 0) return false;
    f->width = width;
    f->height = height;
    size_t pixels = (size_t)width * height, n = 3 * pixels;
    uint64_t bytes = pixels;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) bytes += enabled[c] ? component_bytes(pixels) : 0;
    if (!pm_memory_admit(bytes, "film")) return false;
    f->admitted = bytes;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        if (!enabled[c]) continue;
        f->sum[c] = pm_calloc(n, sizeof(float), "film");
        f->low[c] = f->sum[c] ? pm_calloc(n, sizeof(int16_t), "film") : NULL;
        if (!f->low[c]) { pm_film_free(f); return false; }
    }
    f->ahead = pm_calloc(pixels, 1, "film");
    if (!f->ahead) { pm_film_free(f); return false; }
    return true;
}

bool pm_film_enable_ppm(pm_film *f, const bool slot_enabled[PM_SLOT_COUNT]) {
    size_t n = (size_t)f->width * f->height;
    for (int k = 0; k < PM_SLOT_COUNT; k++) {
        if (!slot_enabled[k] || f->ppm[k]) continue;
        if (!f->sum[pm_slot_component[k]]) return false; /* a slot feeds a component that must exist */
        if (!pm_memory_admit(slot_bytes(n), "progressive photon statistics")) return false;
        f->admitted += slot_bytes(n);
        f->ppm[k] = pm_calloc(n, sizeof(pm_ppm_stat), "progressive photon statistics");
        if (!f->ppm[k]) return false;
    }
    return true;
}

void pm_film_free(pm_film *f) {
    pm_film_close_copy(f);
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        free(f->sum[c]);
        free(f->low[c]);
    }
    for (int k = 0; k < PM_SLOT_COUNT; k++) free(f->ppm[k]);
    pm_memory_release(f->admitted + f->copy_reserved);
    free(f->ahead);
    memset(f, 0, sizeof *f);
}

void pm_film_clear(pm_film *f) {
    size_t n = 3 * (size_t)f->width * f->height;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        if (f->sum[c]) memset(f->sum[c], 0, n * sizeof(float));
        if (f->low[c]) memset(f->low[c], 0, n * sizeof(int16_t));
    }
    for (int k = 0; k < PM_SLOT_COUNT; k++)
        if (f->ppm[k]) memset(f->ppm[k], 0, (n / 3) * sizeof(pm_ppm_stat));
    if (f->ahead) memset(f->ahead, 0, n / 3);
    f->samples = 0;
    f->photon_passes = 0;
    f->ragged = false;
}

size_t pm_film_copy_bytes(const pm_film *f) {
    size_t pixels = (size_t)f->width * f->height, n = 0;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++)
        n += (f->sum[c] ? 3 * pixels * sizeof(float) : 0) + (f->low[c] ? 3 * pixels * sizeof(int16_t) : 0);
    for (int k = 0; k < PM_SLOT_COUNT; k++) n += f->ppm[k] ? (size_t)slot_bytes(pixels) : 0;
    return n;
}

bool pm_film_can_restore(const pm_film *f) { return f->copy_open; }

bool pm_film_reserve_copy(pm_film *f) {
    uint64_t bytes = pm_film_copy_bytes(f);
    if (f->copy_reserved >= bytes) return true;
    if (!pm_memory_admit(bytes - f->copy_reserved, "film (the copy a cancel restores)")) return false;
    f->copy_reserved = bytes;
    return true;
}

bool pm_film_open_copy(pm_film *f) {
    if (f->copy_open) return true;
    uint64_t bytes = pm_film_copy_bytes(f);
    if (f->copy_reserved < bytes) {
        if (!pm_memory_admit(bytes, "film (the copy a cancel restores)")) return false;
        f->copy_admitted = bytes;
    }
    f->copy_open = true;
    size_t pixels = (size_t)f->width * f->height;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        if (!f->sum[c]) continue;
        f->saved_sum[c] = pm_malloc(3 * pixels * sizeof(float), "film (the copy a cancel restores)");
        if (!f->saved_sum[c]) { pm_film_close_copy(f); return false; }
        if (!f->low[c]) continue;
        f->saved_low[c] = pm_malloc(3 * pixels * sizeof(int16_t), "film (the copy a cancel restores)");
        if (!f->saved_low[c]) { pm_film_close_copy(f); return false; }
    }
    for (int k = 0; k < PM_SLOT_COUNT; k++) {
        if (!f->ppm[k]) continue;
        f->saved_ppm[k] = pm_malloc(pixels * sizeof(pm_ppm_stat), "film (the copy a cancel restores)");
        if (!f->saved_ppm[k]) { pm_film_close_copy(f); return false; }
    }
    return true;
}

void pm_film_close_copy(pm_film *f) {
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        free(f->saved_sum[c]);
        free(f->saved_low[c]);
        f->saved_sum[c] = NULL;
        f->saved_low[c] = NULL;
    }
    for (int k = 0; k < PM_SLOT_COUNT; k++) {
        free(f->saved_ppm[k]);
        f->saved_ppm[k] = NULL;
    }
    pm_memory_release(f->copy_admitted);
    f->copy_admitted = 0;
    f->copy_open = false;
}

/* Copies the rectangle's rows of every buffer from the film to its saved copy (save) or back. */
static void copy_rect(pm_film *f, int x0, int y0, int x1, int y1, bool save) {
    if (x1 <= x0 || y1 <= y0 || !f->copy_open) return;
    size_t w = (size_t)(x1 - x0);
    for (int y = y0; y < y1; y++) {
        size_t first = (size_t)y * f->width + x0;
        for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
            if (!f->saved_sum[c]) continue;
            float *live = f->sum[c] + 3 * first, *kept = f->saved_sum[c] + 3 * first;
            memcpy(save ? kept : live, save ? live : kept, 3 * w * sizeof(float));
            if (!f->saved_low[c]) continue;
            int16_t *live_low = f->low[c] + 3 * first, *kept_low = f->saved_low[c] + 3 * first;
            memcpy(save ? kept_low : live_low, save ? live_low : kept_low, 3 * w * sizeof(int16_t));
        }
        for (int k = 0; k < PM_SLOT_COUNT; k++) {
            if (!f->saved_ppm[k]) continue;
            memcpy(save ? f->saved_ppm[k] + first : f->ppm[k] + first, save ? f->ppm[k] + first : f->saved_ppm[k] + first,
                   w * sizeof(pm_ppm_stat));
        }
    }
}

void pm_film_save_rect(pm_film *f, int x0, int y0, int x1, int y1) { copy_rect(f, x0, y0, x1, y1, true); }
void pm_film_restore_rect(pm_film *f, int x0, int y0, int x1, int y1) { copy_rect(f, x0, y0, x1, y1, false); }

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

/* Component c's radiance into out (add: onto what out holds), each pixel by its own counts. The
 * statistics are doubles: their estimate is clamped into float range, never an Inf. */
static void resolve_into(const pm_film *f, pm_component c, float *out, bool add) {
    size_t pixels = (size_t)f->width * f->height;
    if (!f->sum[c] || (f->samples == 0 && !f->ragged)) {
        if (!add) memset(out, 0, 3 * pixels * sizeof(float));
        return;
    }
    const pm_ppm_stat *slot[PM_SLOT_COUNT];
    int slots = 0;
    for (int k = 0; k < PM_SLOT_COUNT; k++)
        if (pm_slot_component[k] == c && f->ppm[k]) slot[slots++] = f->ppm[k];
    /* the sum and its low bits make one double, divided and rounded once: the mean keeps float's
     * precision however many samples were added */
    const float *sum = f->sum[c];
    const int16_t *low = f->low[c];
    double inv_even = f->samples ? 1.0 / (double)f->samples : 0.0;
    if (!slots && !f->ragged && low) {
        /* the common case as straight loops: a window resolves every frame */
        size_t n = 3 * pixels;
        if (add)
            for (size_t i = 0; i < n; i++) out[i] += (float)(value_of(sum[i], low[i]) * inv_even);
        else
            for (size_t i = 0; i < n; i++) out[i] = (float)(value_of(sum[i], low[i]) * inv_even);
        return;
    }
    for (size_t i = 0; i < pixels; i++) {
        unsigned ahead = ahead_of(f, i);
        double inv = inv_even;
        if (ahead & PM_FILM_AHEAD_SAMPLE) inv = 1.0 / (double)(f->samples + 1u);
        float v[3];
        for (int ch = 0; ch < 3; ch++) v[ch] = (float)((low ? value_of(sum[3 * i + ch], low[3 * i + ch]) : sum[3 * i + ch]) * inv);
        uint32_t passes = f->photon_passes + (ahead & PM_FILM_AHEAD_PHOTON_PASS ? 1u : 0u);
        for (int k = 0; k < slots && passes; k++) {
            const pm_ppm_stat *st = &slot[k][i];
            if (!(st->r2 > 0.0)) continue;
            double scale = 1.0 / (PM_PI * st->r2 * (double)passes);
            for (int ch = 0; ch < 3; ch++) v[ch] = (float)fmin(v[ch] + st->tau[ch] * scale, FLT_MAX);
        }
        for (int ch = 0; ch < 3; ch++) out[3 * i + ch] = add ? out[3 * i + ch] + v[ch] : v[ch];
    }
}

void pm_film_resolve(const pm_film *f, pm_component c, float *out) { resolve_into(f, c, out, false); }

void pm_film_fold_statistics(pm_film *f, pm_ppm_slot k) {
    if (!f->ppm[k]) return;
    pm_component c = pm_slot_component[k];
    assert(f->sum[c]); /* a slot's component is enabled with it (pm_film_enable_ppm) */
    size_t pixels = (size_t)f->width * f->height;
    for (size_t i = 0; i < pixels; i++) {
        pm_ppm_stat *st = &f->ppm[k][i];
        uint32_t passes = f->photon_passes + (ahead_of(f, i) & PM_FILM_AHEAD_PHOTON_PASS ? 1u : 0u);
        uint32_t samples = pm_film_samples_at(f, i);
        if (st->r2 > 0.0 && passes && samples) {
            double scale = (double)samples / (PM_PI * st->r2 * (double)passes);
            vec3 v = {(float)fmin(st->tau[0] * scale, FLT_MAX), (float)fmin(st->tau[1] * scale, FLT_MAX),
                      (float)fmin(st->tau[2] * scale, FLT_MAX)};
            pm_film_add(f, c, i, v);
        }
        memset(st, 0, sizeof *st);
    }
}

bool pm_film_resolve_total(const pm_film *f, float *out) {
    memset(out, 0, 3 * (size_t)f->width * f->height * sizeof(float));
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) resolve_into(f, (pm_component)c, out, true);
    return true;
}

bool pm_film_add(pm_film *f, pm_component c, size_t pixel, vec3 v) {
    float *px = f->sum[c] + 3 * pixel;
    int16_t *lo = f->low[c] ? f->low[c] + 3 * pixel : NULL;
    if (!v3_is_finite(v)) return false;
    const float add[3] = {v.x, v.y, v.z};
    float hi[3];
    int16_t bits[3] = {0, 0, 0};
    for (int ch = 0; ch < 3; ch++) {
        /* the exact total (a 40-bit sum plus a float fits a double's 53 bits but for far smaller
         * samples), rounded once */
        double total = (lo ? value_of(px[ch], lo[ch]) : (double)px[ch]) + add[ch];
        hi[ch] = lo ? split(total, &bits[ch]) : (float)total;
        if (!isfinite(hi[ch])) return false;
    }
    for (int ch = 0; ch < 3; ch++) {
        px[ch] = hi[ch];
        if (lo) lo[ch] = bits[ch];
    }
    return true;
}

double pm_film_sum_at(const pm_film *f, pm_component c, size_t i) {
    return f->low[c] ? value_of(f->sum[c][i], f->low[c][i]) : (double)f->sum[c][i];
}

size_t pm_film_bytes(const pm_film *f) {
    size_t n = 0, pixels = (size_t)f->width * f->height;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        n += f->sum[c] ? 3 * pixels * sizeof(float) : 0;
        n += f->low[c] ? 3 * pixels * sizeof(int16_t) : 0;
    }
    for (int k = 0; k < PM_SLOT_COUNT; k++) n += f->ppm[k] ? pixels * sizeof(pm_ppm_stat) : 0;
    if (f->ahead) n += pixels;
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

/* ---- the additive form ---- */

enum { PACK_HEADER = 2, SLOT_FIELDS = 7 };

static int enabled_components(const pm_film *f) {
    int n = 0;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) n += f->sum[c] != NULL;
    return n;
}
static int enabled_slots(const pm_film *f) {
    int n = 0;
    for (int k = 0; k < PM_SLOT_COUNT; k++) n += f->ppm[k] != NULL;
    return n;
}

size_t pm_film_packed_count(const pm_film *f) {
    size_t pixels = (size_t)f->width * f->height;
    return PACK_HEADER + pixels * (1 + 3 * (size_t)enabled_components(f) + SLOT_FIELDS * (size_t)enabled_slots(f));
}

void pm_film_pack(const pm_film *f, double *out) {
    size_t pixels = (size_t)f->width * f->height;
    out[0] = f->samples;
    out[1] = f->photon_passes;
    double *counts = out + PACK_HEADER, *next = counts + pixels;
    for (size_t i = 0; i < pixels; i++) counts[i] = pm_film_samples_at(f, i);
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        if (!f->sum[c]) continue;
        for (size_t i = 0; i < 3 * pixels; i++) next[i] = pm_film_sum_at(f, (pm_component)c, i);
        next += 3 * pixels;
    }
    for (int k = 0; k < PM_SLOT_COUNT; k++) {
        if (!f->ppm[k]) continue;
        double *passes = next, *s = next + pixels, *n = s + 3 * pixels, *r2 = n + pixels, *has = r2 + pixels;
        for (size_t i = 0; i < pixels; i++) {
            const pm_ppm_stat *st = &f->ppm[k][i];
            bool set = st->r2 > 0.0;
            passes[i] = f->photon_passes + (ahead_of(f, i) & PM_FILM_AHEAD_PHOTON_PASS ? 1u : 0u);
            for (int ch = 0; ch < 3; ch++) s[3 * i + ch] = set ? st->tau[ch] / st->r2 : 0.0;
            n[i] = st->n;
            r2[i] = set ? st->r2 : 0.0;
            has[i] = set ? 1.0 : 0.0;
        }
        next += SLOT_FIELDS * pixels;
    }
}

void pm_film_unpack(pm_film *f, const double *in) {
    size_t pixels = (size_t)f->width * f->height;
    pm_film_clear(f);
    const double *counts = in + PACK_HEADER, *next = counts + pixels;
    bool any = false;
    for (size_t i = 0; i < pixels && !any; i++) any = counts[i] > 0.0;
    /* the uniform count every pixel is rescaled to: a pixel holding n samples of sum S reads S / n */
    double samples = in[0] >= 1.0 ? in[0] : (any ? 1.0 : 0.0);
    f->samples = (uint32_t)samples;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        if (!f->sum[c]) continue;
        for (size_t i = 0; i < pixels; i++) {
            double scale = counts[i] > 0.0 ? samples / counts[i] : 0.0;
            for (int ch = 0; ch < 3; ch++) {
                double v = fmin(fmax(next[3 * i + ch] * scale, -FLT_MAX), FLT_MAX);
                /* the low bits keep what rounding to float lost */
                if (f->low[c]) f->sum[c][3 * i + ch] = split(v, &f->low[c][3 * i + ch]);
                else f->sum[c][3 * i + ch] = (float)v;
            }
        }
        next += 3 * pixels;
    }
    double passes_total = in[1];
    for (int k = 0; k < PM_SLOT_COUNT; k++) {
        if (!f->ppm[k]) continue;
        const double *passes = next, *s = next + pixels, *n = s + 3 * pixels, *r2 = n + pixels, *has = r2 + pixels;
        for (size_t i = 0; i < pixels; i++) {
            pm_ppm_stat *st = &f->ppm[k][i];
            if (!(has[i] > 0.0) || !(passes[i] > 0.0)) continue;
            if (passes_total < 1.0) passes_total = 1.0;
            st->r2 = r2[i] / has[i];
            st->n = n[i];
            for (int ch = 0; ch < 3; ch++) st->tau[ch] = (float)fmin(s[3 * i + ch] * st->r2 * passes_total / passes[i], FLT_MAX);
        }
        next += SLOT_FIELDS * pixels;
    }
    f->photon_passes = (uint32_t)passes_total;
}

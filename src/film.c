/* film.c: allocation, clearing and resolving of the per-component accumulation buffers and progressive photon statistics. */
#include "film.h"
#include "memory.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

const pm_component pm_slot_component[PM_SLOT_COUNT] = {PM_CAUSTIC, PM_INDIRECT, PM_SPECULAR, PM_SPECULAR};

/* Bytes a component (sums, compensation, and their saved copy) or a statistics slot (and its copy) holds. */
static uint64_t component_bytes(size_t pixels) { return (uint64_t)pixels * 3 * sizeof(float) * 4; }
static uint64_t slot_bytes(size_t pixels) { return (uint64_t)pixels * sizeof(pm_ppm_stat) * 2; }

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
        f->carry[c] = f->sum[c] ? pm_calloc(n, sizeof(float), "film") : NULL;
        f->saved_sum[c] = f->carry[c] ? pm_malloc(n * sizeof(float), "film (the copy a cancel restores)") : NULL;
        f->saved_carry[c] = f->saved_sum[c] ? pm_malloc(n * sizeof(float), "film (the copy a cancel restores)") : NULL;
        if (!f->saved_carry[c]) { pm_film_free(f); return false; }
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
        f->saved_ppm[k] = pm_malloc(n * sizeof(pm_ppm_stat), "progressive photon statistics (the copy a cancel restores)");
        if (!f->saved_ppm[k]) {
            free(f->ppm[k]);
            f->ppm[k] = NULL;
            return false;
        }
    }
    return true;
}

void pm_film_free(pm_film *f) {
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        free(f->sum[c]);
        free(f->carry[c]);
        free(f->saved_sum[c]);
        free(f->saved_carry[c]);
    }
    for (int k = 0; k < PM_SLOT_COUNT; k++) {
        free(f->ppm[k]);
        free(f->saved_ppm[k]);
    }
    pm_memory_release(f->admitted);
    free(f->ahead);
    memset(f, 0, sizeof *f);
}

void pm_film_clear(pm_film *f) {
    size_t n = 3 * (size_t)f->width * f->height;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        if (f->sum[c]) memset(f->sum[c], 0, n * sizeof(float));
        if (f->carry[c]) memset(f->carry[c], 0, n * sizeof(float));
    }
    for (int k = 0; k < PM_SLOT_COUNT; k++)
        if (f->ppm[k]) memset(f->ppm[k], 0, (n / 3) * sizeof(pm_ppm_stat));
    if (f->ahead) memset(f->ahead, 0, n / 3);
    f->samples = 0;
    f->photon_passes = 0;
    f->ragged = false;
}

void pm_film_drop_restore(pm_film *f) {
    size_t pixels = (size_t)f->width * f->height;
    uint64_t freed = 0;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        freed += (f->saved_sum[c] ? 1u : 0u) * (uint64_t)pixels * 3 * sizeof(float);
        freed += (f->saved_carry[c] ? 1u : 0u) * (uint64_t)pixels * 3 * sizeof(float);
        free(f->saved_sum[c]);
        free(f->saved_carry[c]);
        f->saved_sum[c] = f->saved_carry[c] = NULL;
    }
    for (int k = 0; k < PM_SLOT_COUNT; k++) {
        freed += (f->saved_ppm[k] ? 1u : 0u) * (uint64_t)pixels * sizeof(pm_ppm_stat);
        free(f->saved_ppm[k]);
        f->saved_ppm[k] = NULL;
    }
    if (freed > f->admitted) freed = f->admitted;
    pm_memory_release(freed);
    f->admitted -= freed;
}

bool pm_film_can_restore(const pm_film *f) {
    for (int c = 0; c < PM_COMPONENT_COUNT; c++)
        if (f->sum[c] && (!f->carry[c] || !f->saved_sum[c] || !f->saved_carry[c])) return false;
    for (int k = 0; k < PM_SLOT_COUNT; k++)
        if (f->ppm[k] && !f->saved_ppm[k]) return false;
    return true;
}

/* Copies the rectangle's rows of every buffer from the film to its saved copy (save) or back. */
static void copy_rect(pm_film *f, int x0, int y0, int x1, int y1, bool save) {
    if (x1 <= x0 || y1 <= y0) return;
    size_t w = (size_t)(x1 - x0);
    for (int y = y0; y < y1; y++) {
        size_t first = (size_t)y * f->width + x0;
        for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
            if (!f->sum[c] || !f->saved_sum[c] || !f->carry[c] || !f->saved_carry[c]) continue;
            float *live[2] = {f->sum[c] + 3 * first, f->carry[c] + 3 * first};
            float *kept[2] = {f->saved_sum[c] + 3 * first, f->saved_carry[c] + 3 * first};
            for (int b = 0; b < 2; b++) memcpy(save ? kept[b] : live[b], save ? live[b] : kept[b], 3 * w * sizeof(float));
        }
        for (int k = 0; k < PM_SLOT_COUNT; k++) {
            if (!f->ppm[k] || !f->saved_ppm[k]) continue;
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
    /* sum - carry rounds once to the float nearest the compensated sum: the mean keeps float's
     * precision however many samples were added */
    const float *sum = f->sum[c], *carry = f->carry[c];
    float inv_even = f->samples ? 1.f / (float)f->samples : 0.f;
    if (!slots && !f->ragged && carry) {
        /* the common case as straight loops the compiler vectorises: a window resolves every frame */
        size_t n = 3 * pixels;
        if (add)
            for (size_t i = 0; i < n; i++) out[i] += (sum[i] - carry[i]) * inv_even;
        else
            for (size_t i = 0; i < n; i++) out[i] = (sum[i] - carry[i]) * inv_even;
        return;
    }
    for (size_t i = 0; i < pixels; i++) {
        unsigned ahead = ahead_of(f, i);
        float inv = inv_even;
        if (ahead & PM_FILM_AHEAD_SAMPLE) inv = 1.f / (float)(f->samples + 1u);
        float v[3];
        for (int ch = 0; ch < 3; ch++) v[ch] = (sum[3 * i + ch] - (carry ? carry[3 * i + ch] : 0.f)) * inv;
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

bool pm_film_resolve_total(const pm_film *f, float *out) {
    memset(out, 0, 3 * (size_t)f->width * f->height * sizeof(float));
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) resolve_into(f, (pm_component)c, out, true);
    return true;
}

bool pm_film_add(pm_film *f, pm_component c, size_t pixel, vec3 v) {
    float *px = f->sum[c] + 3 * pixel, *cp = f->carry[c] ? f->carry[c] + 3 * pixel : NULL;
    if (!v3_is_finite(v)) return false;
    float add[3] = {v.x, v.y, v.z}, sum[3], carry[3] = {0.f, 0.f, 0.f};
    for (int ch = 0; ch < 3; ch++) {
        /* Kahan: y is the sample less what the last addition lost; what this one loses goes to carry */
        float y = add[ch] - (cp ? cp[ch] : 0.f);
        sum[ch] = px[ch] + y;
        if (cp) carry[ch] = (sum[ch] - px[ch]) - y;
        if (!isfinite(sum[ch]) || !isfinite(carry[ch])) return false;
    }
    for (int ch = 0; ch < 3; ch++) {
        px[ch] = sum[ch];
        if (cp) cp[ch] = carry[ch];
    }
    return true;
}

double pm_film_sum_at(const pm_film *f, pm_component c, size_t i) {
    return (double)f->sum[c][i] - (f->carry[c] ? (double)f->carry[c][i] : 0.0);
}

size_t pm_film_bytes(const pm_film *f) {
    size_t n = 0, pixels = (size_t)f->width * f->height;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        float *const buffers[4] = {f->sum[c], f->carry[c], f->saved_sum[c], f->saved_carry[c]};
        for (int b = 0; b < 4; b++) n += buffers[b] ? 3 * pixels * sizeof(float) : 0;
    }
    for (int k = 0; k < PM_SLOT_COUNT; k++) {
        if (f->ppm[k]) n += pixels * sizeof(pm_ppm_stat);
        if (f->saved_ppm[k]) n += pixels * sizeof(pm_ppm_stat);
    }
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
                double v = next[3 * i + ch] * scale;
                float rounded = (float)fmin(fmax(v, -FLT_MAX), FLT_MAX);
                f->sum[c][3 * i + ch] = rounded;
                /* the true sum is sum - carry: the carry keeps what rounding to float lost */
                if (f->carry[c]) f->carry[c][3 * i + ch] = (float)((double)rounded - v);
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
            for (int ch = 0; ch < 3; ch++) st->tau[ch] = s[3 * i + ch] * st->r2 * passes_total / passes[i];
        }
        next += SLOT_FIELDS * pixels;
    }
    f->photon_passes = (uint32_t)passes_total;
}

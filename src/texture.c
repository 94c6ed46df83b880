/* texture.c: textures: bilinear and nearest lookups with the wrap modes, mip levels built and read by footprint, alpha. */
#include "scene.h"
#include "memory.h"

#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

static float srgb_table[256];
static pthread_once_t srgb_table_once = PTHREAD_ONCE_INIT; /* filled once, before any thread reads it */
static void init_srgb_table(void) {
    for (int i = 0; i < 256; i++) srgb_table[i] = pm_srgb_to_linear(i / 255.f);
}

/* floorf of a finite float without a libm call: from 2^23 up every float is an integer. */
static inline float floor_finite(float x) {
    if (!(fabsf(x) < 8388608.f)) return x;
    float t = (float)(int)x;
    return t > x ? t - 1.f : t;
}

/* One axis of a lookup: the two texels around coordinate c (in [0, 1] across the texture) with
 * the wrap mode, and the weight of the second. The coordinate is first brought into one period
 * (two for MIRROR, [-1, 2] for CLAMP), so the texel index needs compares, not an integer division:
 * this runs four times for every texture of every hit. */
static inline void wrap_axis(float c, int n, int mode, int *i0, int *i1, float *frac) {
    if (mode == PM_WRAP_CLAMP) c = pm_minf(pm_maxf(c, -1.f), 2.f);
    else if (mode == PM_WRAP_MIRROR) c -= 2.f * floor_finite(0.5f * c); /* [0, 2] */
    else c -= floor_finite(c);                                         /* [0, 1] */
    float x = c * (float)n - 0.5f, fx = floor_finite(x);
    int x0 = (int)fx, x1 = x0 + 1;
    *frac = x - fx;
    if (mode == PM_WRAP_CLAMP) {
        *i0 = x0 < 0 ? 0 : (x0 >= n ? n - 1 : x0);
        *i1 = x1 < 0 ? 0 : (x1 >= n ? n - 1 : x1);
    } else if (mode == PM_WRAP_MIRROR) {
        /* x0 in [-1, 2n - 1], x1 in [0, 2n]: into [0, 2n), then folded at n */
        int m0 = x0 < 0 ? x0 + 2 * n : x0, m1 = x1 >= 2 * n ? x1 - 2 * n : x1;
        *i0 = m0 < n ? m0 : 2 * n - 1 - m0;
        *i1 = m1 < n ? m1 : 2 * n - 1 - m1;
    } else {
        /* x0 in [-1, n - 1], x1 in [0, n] */
        *i0 = x0 < 0 ? x0 + n : x0;
        *i1 = x1 >= n ? x1 - n : x1;
    }
}

/* The four texels around (u, v) and their bilinear weights, with the texture's wrap modes, in an
 * image of w x h texels (level 0 or a mip level): the footprint of every lookup (colour, data and
 * alpha). u and v are finite. */
typedef struct { size_t texel[4]; float weight[4]; } bilinear_taps;
static inline bilinear_taps bilinear_in(int w, int h, int wrap_s, int wrap_t, float u, float v) {
    int xa, xb, ya, yb;
    float ax, ay;
    wrap_axis(u, w, wrap_s, &xa, &xb, &ax);
    wrap_axis(v, h, wrap_t, &ya, &yb, &ay);
    bilinear_taps b = {{(size_t)ya * w + xa, (size_t)ya * w + xb, (size_t)yb * w + xa, (size_t)yb * w + xb},
                       {(1.f - ax) * (1.f - ay), ax * (1.f - ay), (1.f - ax) * ay, ax * ay}};
    return b;
}
static bilinear_taps bilinear(const pm_texture *t, float u, float v) {
    return bilinear_in(t->width, t->height, t->wrap_s, t->wrap_t, u, v);
}

/* Bilinear RGB in one image of w x h texels with t's wrap modes. */
static inline vec3 image_bilinear(const pm_texture *t, const uint8_t *rgba, int w, int h, float u, float v, bool srgb) {
    bilinear_taps b = bilinear_in(w, h, t->wrap_s, t->wrap_t, u, v);
    vec3 sum = v3s(0.f);
    for (int k = 0; k < 4; k++) {
        const uint8_t *p = rgba + 4 * b.texel[k];
        vec3 c = srgb ? v3(srgb_table[p[0]], srgb_table[p[1]], srgb_table[p[2]])
                      : v3(p[0] * (1.f / 255.f), p[1] * (1.f / 255.f), p[2] * (1.f / 255.f));
        sum = v3_madd(sum, c, b.weight[k]);
    }
    return sum;
}

/* The texel of one image under (u, v) (a sampler's NEAREST): of the two bilinear taps on each axis,
 * the one whose centre is nearer. */
static inline size_t nearest_texel(const pm_texture *t, int w, int h, float u, float v) {
    int xa, xb, ya, yb;
    float ax, ay;
    wrap_axis(u, w, t->wrap_s, &xa, &xb, &ax);
    wrap_axis(v, h, t->wrap_t, &ya, &yb, &ay);
    return (size_t)(ay < 0.5f ? ya : yb) * w + (ax < 0.5f ? xa : xb);
}
static inline vec3 image_nearest(const pm_texture *t, const uint8_t *rgba, int w, int h, float u, float v, bool srgb) {
    const uint8_t *p = rgba + 4 * nearest_texel(t, w, h, u, v);
    return srgb ? v3(srgb_table[p[0]], srgb_table[p[1]], srgb_table[p[2]])
                : v3(p[0] * (1.f / 255.f), p[1] * (1.f / 255.f), p[2] * (1.f / 255.f));
}
/* One image read with the texel filter `nearest` or bilinear. */
static inline vec3 image_read(const pm_texture *t, const uint8_t *rgba, int w, int h, float u, float v, bool srgb, bool nearest) {
    return nearest ? image_nearest(t, rgba, w, h, u, v, srgb) : image_bilinear(t, rgba, w, h, u, v, srgb);
}

/* Level 0 under the magnification filter. */
static vec3 texture_bilinear(const pm_texture *t, float u, float v, bool srgb) {
    pthread_once(&srgb_table_once, init_srgb_table);
    if (!t->rgba || t->width <= 0 || t->height <= 0 || !isfinite(u) || !isfinite(v)) return v3s(1.f);
    return image_read(t, t->rgba, t->width, t->height, u, v, srgb, t->mag_nearest);
}

vec3 pm_texture_lookup(const pm_texture *t, float u, float v) { return texture_bilinear(t, u, v, true); }
vec3 pm_texture_lookup_data(const pm_texture *t, float u, float v) { return texture_bilinear(t, u, v, false); }

/* Level k of t as an image (level 0 is rgba). */
static inline const uint8_t *level_texels(const pm_texture *t, int k, int *w, int *h) {
    if (k == 0) {
        *w = t->width;
        *h = t->height;
        return t->rgba;
    }
    *w = t->level_width[k];
    *h = t->level_height[k];
    return t->levels + t->level_offset[k];
}

vec3 pm_texture_filtered(const pm_texture *t, float u, float v, float texels, bool srgb) {
    /* a footprint of at most a texel (or 0, or NaN) is level 0 exactly */
    if (!(texels > 1.f) || t->level_count <= 1 || !t->levels) return texture_bilinear(t, u, v, srgb);
    pthread_once(&srgb_table_once, init_srgb_table);
    if (!t->rgba || t->width <= 0 || t->height <= 0 || !isfinite(u) || !isfinite(v)) return v3s(1.f);
    int top = t->level_count - 1, w, h, min = t->min_filter;
    bool nearest = min == PM_MIN_NEAREST || min == PM_MIN_NEAREST_MIPMAP_NEAREST || min == PM_MIN_NEAREST_MIPMAP_LINEAR;
    if (min == PM_MIN_NEAREST || min == PM_MIN_LINEAR) /* no mipmapping asked for: level 0 */
        return image_read(t, t->rgba, t->width, t->height, u, v, srgb, nearest);
    float level = log2f(texels); /* > 0; +inf for an infinite footprint */
    if (min == PM_MIN_NEAREST_MIPMAP_NEAREST || min == PM_MIN_LINEAR_MIPMAP_NEAREST)
        level = floor_finite(level + 0.5f); /* the nearest level */
    if (!(level < (float)top)) {
        const uint8_t *p = level_texels(t, top, &w, &h);
        return image_read(t, p, w, h, u, v, srgb, nearest);
    }
    int k = (int)level;
    float f = level - (float)k;
    const uint8_t *p0 = level_texels(t, k, &w, &h);
    vec3 a = image_read(t, p0, w, h, u, v, srgb, nearest);
    if (f == 0.f) return a;
    const uint8_t *p1 = level_texels(t, k + 1, &w, &h);
    vec3 b = image_read(t, p1, w, h, u, v, srgb, nearest);
    return v3_add(v3_scale(a, 1.f - f), v3_scale(b, f));
}

/* The tables a level's build decodes and re-encodes with: its own, so that building levels while
 * loading touches nothing the lookups share (the lookups' table is set up by the first lookup). */
enum { LINEAR_STEPS = 65536 };
typedef struct {
    float decode[256];                   /* sRGB byte -> linear */
    uint8_t nearest[LINEAR_STEPS + 1];   /* the sRGB byte nearest to linear i / LINEAR_STEPS */
} srgb_codec;
static uint8_t nearest_srgb_byte_from(const float decode[256], float x, int c) {
    while (c < 255 && fabsf(decode[c + 1] - x) < fabsf(decode[c] - x)) c++;
    while (c > 0 && fabsf(decode[c - 1] - x) < fabsf(decode[c] - x)) c--;
    return (uint8_t)c;
}
static void srgb_codec_make(srgb_codec *k) {
    for (int i = 0; i < 256; i++) k->decode[i] = pm_srgb_to_linear(i / 255.f);
    int c = 0;
    for (int i = 0; i <= LINEAR_STEPS; i++) k->nearest[i] = (uint8_t)(c = nearest_srgb_byte_from(k->decode, (float)i / LINEAR_STEPS, c));
}
/* The nearest byte to within 1 / (2 LINEAR_STEPS) in linear value: a value that close to the
 * midpoint of two bytes may take the farther one. */
static inline uint8_t nearest_srgb_byte(const srgb_codec *k, float x) {
    return k->nearest[(int)(pm_clamp01(x) * LINEAR_STEPS + 0.5f)];
}

/* One axis of a halving from n texels to m: texel i of the smaller level covers the source
 * interval [i n / m, (i + 1) n / m), and each source texel it overlaps weighs its share of that
 * interval. Every source texel's shares add up to one texel's worth whatever n is (odd sizes
 * included), so each level keeps the mean of the one before. */
typedef struct { int first, count; float weight[4]; } box_taps;
static void box_axis(int n, int m, box_taps *taps) {
    for (int i = 0; i < m; i++) {
        double lo = (double)i * n / m, hi = (double)(i + 1) * n / m;
        box_taps *b = &taps[i];
        b->first = (int)floor(lo);
        b->count = 0;
        for (int j = b->first; j < n && (double)j < hi && b->count < 4; j++) {
            double overlap = fmin(hi, j + 1.0) - fmax(lo, (double)j);
            b->weight[b->count++] = (float)(overlap * m / n);
        }
    }
}

/* One texel of a level from the source texels p[0..n) with weights w (summing to 1): colour by
 * srgb (NULL: data bytes), see pm_texture_build_levels. */
static inline void box_texel(const uint8_t *const *p, const float *w, int n, const srgb_codec *srgb, uint8_t *q) {
    float colour[3] = {0.f, 0.f, 0.f}, plain[3] = {0.f, 0.f, 0.f}, coverage = 0.f;
    for (int k = 0; k < n; k++) {
        float a = p[k][3] * (1.f / 255.f);
        for (int c = 0; c < 3; c++) {
            float value = srgb ? srgb->decode[p[k][c]] : p[k][c] * (1.f / 255.f);
            plain[c] += w[k] * value;
            colour[c] += w[k] * a * value;
        }
        coverage += w[k] * a;
    }
    for (int c = 0; c < 3; c++) {
        /* colour textures: what the cut-outs leave, where anything is left */
        float value = srgb && coverage > 0.f ? colour[c] / coverage : plain[c];
        q[c] = srgb ? nearest_srgb_byte(srgb, value) : (uint8_t)(pm_clamp01(value) * 255.f + 0.5f);
    }
    q[3] = (uint8_t)(pm_clamp01(coverage) * 255.f + 0.5f);
}

/* Level dst (dw x dh) from level src (sw x sh), box-filtered; an even halving (the common case,
 * and the whole cost of an 8K texture's levels) reads its 2 x 2 blocks directly. */
static void halve_level(const uint8_t *src, int sw, int sh, uint8_t *dst, int dw, int dh, const box_taps *xs,
                        const box_taps *ys, const srgb_codec *srgb) {
    if (sw == 2 * dw && sh == 2 * dh) {
        for (int y = 0; y < dh; y++) {
            const uint8_t *row0 = src + 4 * (size_t)(2 * y) * sw, *row1 = row0 + 4 * (size_t)sw;
            uint8_t *q = dst + 4 * (size_t)y * dw;
            for (int x = 0; x < dw; x++, q += 4) {
                const uint8_t *p[4] = {row0 + 8 * x, row0 + 8 * x + 4, row1 + 8 * x, row1 + 8 * x + 4};
                if (!srgb) {
                    /* the mean of four bytes, rounded to nearest (halves up) */
                    for (int c = 0; c < 4; c++) q[c] = (uint8_t)((p[0][c] + p[1][c] + p[2][c] + p[3][c] + 2) >> 2);
                    continue;
                }
                static const float quarter[4] = {0.25f, 0.25f, 0.25f, 0.25f};
                box_texel(p, quarter, 4, srgb, q);
            }
        }
        return;
    }
    for (int y = 0; y < dh; y++)
        for (int x = 0; x < dw; x++) {
            const box_taps *bx = &xs[x], *by = &ys[y];
            const uint8_t *p[16];
            float w[16];
            int n = 0;
            for (int j = 0; j < by->count; j++)
                for (int i = 0; i < bx->count; i++) {
                    p[n] = src + 4 * ((size_t)(by->first + j) * sw + (size_t)(bx->first + i));
                    w[n++] = by->weight[j] * bx->weight[i];
                }
            box_texel(p, w, n, srgb, dst + 4 * ((size_t)y * dw + x));
        }
}

bool pm_texture_build_levels(pm_texture *t, bool srgb, uint64_t *admitted) {
    if (t->levels || !t->rgba || t->width <= 0 || t->height <= 0) return true; /* built, or nothing to build */
    int count = 1, w = t->width, h = t->height;
    size_t bytes = 0;
    t->level_width[0] = w;
    t->level_height[0] = h;
    t->level_offset[0] = 0;
    while ((w > 1 || h > 1) && count < PM_TEXTURE_MAX_LEVELS) {
        w = w > 1 ? w / 2 : 1;
        h = h > 1 ? h / 2 : 1;
        t->level_width[count] = w;
        t->level_height[count] = h;
        t->level_offset[count] = bytes;
        bytes += 4 * (size_t)w * (size_t)h;
        count++;
    }
    t->level_count = 1;
    if (count == 1) return true;
    if (!pm_memory_admit(bytes, "texture mip levels")) return false;
    uint8_t *levels = pm_malloc(bytes, "texture mip levels");
    int largest = t->width > t->height ? t->width : t->height;
    box_taps *taps = levels ? pm_malloc(2 * sizeof *taps * (size_t)largest, "texture mip levels") : NULL;
    srgb_codec *codec = taps && srgb ? pm_malloc(sizeof *codec, "texture mip levels") : NULL;
    if (!taps || (srgb && !codec)) {
        free(taps);
        free(levels);
        pm_memory_release(bytes);
        return false;
    }
    if (codec) srgb_codec_make(codec);
    for (int k = 1; k < count; k++) {
        int sw = t->level_width[k - 1], sh = t->level_height[k - 1], dw = t->level_width[k], dh = t->level_height[k];
        const uint8_t *src = k == 1 ? t->rgba : levels + t->level_offset[k - 1];
        box_axis(sw, dw, taps);
        box_axis(sh, dh, taps + largest);
        halve_level(src, sw, sh, levels + t->level_offset[k], dw, dh, taps, taps + largest, codec);
    }
    free(taps);
    free(codec);
    t->levels = levels;
    t->level_count = count;
    *admitted += bytes;
    return true;
}

void pm_texture_prefetch(const pm_texture *t, float u, float v) {
    if (!t->rgba || t->width <= 0 || t->height <= 0 || !isfinite(u) || !isfinite(v)) return;
    bilinear_taps b = bilinear(t, u, v); /* NEAREST reads one of these four */
    for (int k = 0; k < 4; k++) __builtin_prefetch(t->rgba + 4 * b.texel[k]);
}

float pm_texture_alpha(const pm_texture *t, float u, float v) {
    if (!t->rgba || t->width <= 0 || t->height <= 0 || !isfinite(u) || !isfinite(v)) return 1.f;
    if (t->mag_nearest) return t->rgba[4 * nearest_texel(t, t->width, t->height, u, v) + 3] * (1.f / 255.f);
    bilinear_taps b = bilinear(t, u, v);
    float sum = 0.f;
    for (int k = 0; k < 4; k++) sum += t->rgba[4 * b.texel[k] + 3] * b.weight[k];
    return sum * (1.f / 255.f);
}

void pm_texture_channel_bounds(const pm_texture *t, uint8_t lo[4], uint8_t hi[4]) {
    size_t bytes = 4 * (size_t)t->width * (size_t)t->height, i = 0;
    /* sixteen running bounds in one vector, four texels' channels side by side (GCC's vector
     * extensions: at -O2 GCC leaves the plain loop byte by byte, 2 GB/s) */
    typedef uint8_t bytes16 __attribute__((vector_size(16)));
    bytes16 low, high;
    memset(&low, 255, sizeof low);
    memset(&high, 0, sizeof high);
    for (; i + 16 <= bytes; i += 16) {
        bytes16 x;
        memcpy(&x, t->rgba + i, sizeof x);
        bytes16 below = (bytes16)(x < low), above = (bytes16)(x > high);
        low = (low & ~below) | (x & below);
        high = (high & ~above) | (x & above);
    }
    uint8_t l[16], h[16];
    memcpy(l, &low, sizeof l);
    memcpy(h, &high, sizeof h);
    for (; i < bytes; i++) { /* the last texels (fewer than four): byte i is channel i % 4 */
        uint8_t x = t->rgba[i];
        l[i % 16] = x < l[i % 16] ? x : l[i % 16];
        h[i % 16] = x > h[i % 16] ? x : h[i % 16];
    }
    for (int c = 0; c < 4; c++) {
        lo[c] = 255, hi[c] = 0;
        for (int k = c; k < 16; k += 4) {
            lo[c] = l[k] < lo[c] ? l[k] : lo[c];
            hi[c] = h[k] > hi[c] ? h[k] : hi[c];
        }
    }
}

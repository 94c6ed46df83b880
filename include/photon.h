/* photon.h: the compact photon record (20 bytes) and its encoding: position, octahedral normal and direction, RGBE power.
 *
 * Position stays full float (the estimates are sensitive to it); the incident direction is a
 * 16-bit octahedral code (about 1 degree), the surface normal a 14-bit one (about 2 degrees:
 * it only decides "same surface, same side"), and the remaining 2 bits say how the photon got
 * there (direct, caustic, indirect); power is Ward's shared-exponent RGBE (1% precision).
 */
#ifndef PM_PHOTON_H
#define PM_PHOTON_H

#include <stdint.h>
#include "pm_math.h"

typedef struct {
    float pos[3];
    uint16_t normal_path; /* bits 0-13: octahedral normal (7+7 bits), 14-15: path tag */
    uint16_t direction;  /* octahedral code of the direction the photon travelled */
    uint8_t power[4];    /* RGBE */
} pm_photon;

_Static_assert(sizeof(pm_photon) == 20, "photon record must stay 20 bytes");

/* The record's two octahedral codes at once, the surface normal at 7 bits per axis and the
 * direction at 8, in one SSE register (GCC and clang vector extensions): lanes (normal x,
 * direction x, normal y, direction y), each with the same operations a scalar encoder makes on
 * that axis. Every record is encoded in the photon pass's inner loop, where two scalar encoders
 * took a tenth of its time.
 * A vector is scaled to |x| + |y| + |z| = 1; the lower half (z < 0) is folded over the diagonals,
 * (x, y) -> (sign(x) (1 - |y|), sign(y) (1 - |x|)), by bit selects, not branches (every record's
 * direction points up or down at random); each axis is then rounded to levels = 2^bits - 1 steps
 * over [-1, 1]. A zero or NaN vector gets the centre code (x = y = 0). */
typedef uint16_t pm_u8_ __attribute__((vector_size(16))); /* eight 16-bit lanes */
static inline void pm_oct_encode_pair(vec3 normal, vec3 direction, uint16_t *normal_code, uint16_t *direction_code) {
    const pm_u4_ magnitude_bits = {0x7fffffffu, 0x7fffffffu, 0x7fffffffu, 0x7fffffffu};
    pm_f4_ xy = {normal.x, direction.x, normal.y, direction.y}, z = {normal.z, direction.z, normal.z, direction.z};
    pm_f4_ axy = (pm_f4_)((pm_u4_)xy & magnitude_bits), az = (pm_f4_)((pm_u4_)z & magnitude_bits);
    pm_f4_ ayx = PM_SHUFFLE(axy, axy, 2, 3, 0, 1);
    pm_f4_ sum = axy + ayx + az; /* |x| + |y| + |z| in every lane (a + b is b + a, bit for bit) */
    pm_i4_ usable = sum > 0.f;   /* false for NaN too */
    pm_f4_ uv = xy * (1.f / sum);
    pm_f4_ auv = (pm_f4_)((pm_u4_)uv & magnitude_bits), avu = PM_SHUFFLE(auv, auv, 2, 3, 0, 1);
    pm_u4_ fold = (pm_u4_)(1.f - avu) | ((pm_u4_)uv & ~magnitude_bits); /* copysign: 1 - |v| >= 0 takes u's sign */
    pm_u4_ lower = (pm_u4_)(z < 0.f);
    uv = (pm_f4_)((lower & fold) | (~lower & (pm_u4_)uv));
    const pm_f4_ levels = {127.f, 255.f, 127.f, 255.f};
    const pm_i4_ mask = {127, 255, 127, 255}, centre = {64, 128, 64, 128};
    pm_i4_ q = __builtin_convertvector((uv * 0.5f + 0.5f) * levels + 0.5f, pm_i4_) & mask; /* truncated: >= 0 */
    q = (usable & q) | (~usable & centre);
    /* the y halves moved up by 7 and 8 bits, by a 16-bit multiply (SSE2 has no 32-bit one): 255 x 256 fits */
    pm_i4_ shifted = (pm_i4_)((pm_u8_)q * (pm_u8_){1, 0, 1, 0, 128, 0, 256, 0});
    pm_i4_ code = shifted | PM_SHUFFLE(shifted, shifted, 2, 3, 0, 1);
    *normal_code = (uint16_t)code[0];
    *direction_code = (uint16_t)code[1];
}

/* An octahedral code decoded without normalising: the direction is right, the length in [1/sqrt(3), 1]. */
static inline __attribute__((always_inline)) vec3 pm_oct_decode_unnormalised(uint16_t code, int bits) {
    int mask = (1 << bits) - 1;
    float scale = 2.f / (float)mask;
    float x = (float)(code & mask) * scale - 1.f, y = (float)((code >> bits) & mask) * scale - 1.f;
    float z = 1.f - fabsf(x) - fabsf(y);
    /* The lower half's fold by bit selects, not branches: a gathered photon's direction lies in
     * either half at random, and the branch mispredicted half the time. copysignf gives exactly
     * (1 - |y|) x sign(x): x and y are never -0 here (they come out of a subtraction). */
    float fx = copysignf(1.f - fabsf(y), x), fy = copysignf(1.f - fabsf(x), y);
    bool fold = z < 0.f;
    return v3(pm_selectf(fold, fx, x), pm_selectf(fold, fy, y), z);
}

static inline vec3 pm_oct_decode_bits(uint16_t code, int bits) { return v3_normalize(pm_oct_decode_unnormalised(code, bits)); }

static inline vec3 pm_oct_decode(uint16_t code) { return pm_oct_decode_bits(code, 8); }

/* 2^e for a normal float exponent, -126 <= e <= 127, built from its bits. */
static inline float pm_pow2i(int e) {
    uint32_t b = (uint32_t)(e + 127) << 23;
    float f;
    memcpy(&f, &b, 4);
    return f;
}

static inline void pm_rgbe_encode(vec3 c, uint8_t out[4]) {
    float m = v3_max_component(c);
    if (!(m > 1e-32f) || !isfinite(m)) { out[0] = out[1] = out[2] = out[3] = 0; return; }
    /* m is a normal float here: frexp's exponent read from the bits, without a libm call */
    uint32_t mb;
    memcpy(&mb, &m, 4);
    int e = (int)((mb >> 23) & 0xffu) - 126; /* m = f x 2^e with f in [0.5, 1) */
    float scale = pm_pow2i(8 - e);
    /* rounding to nearest halves the quantisation bias of truncation */
    float r = pm_minf(c.x * scale + 0.5f, 255.f), g = pm_minf(c.y * scale + 0.5f, 255.f), b = pm_minf(c.z * scale + 0.5f, 255.f);
    out[0] = (uint8_t)pm_maxf(r, 0.f);
    out[1] = (uint8_t)pm_maxf(g, 0.f);
    out[2] = (uint8_t)pm_maxf(b, 0.f);
    out[3] = (uint8_t)(e + 128);
}

static inline vec3 pm_rgbe_decode(const uint8_t in[4]) {
    if (in[3] == 0) return v3s(0.f);
    int e = (int)in[3] - (128 + 8);
    float f = e >= -126 ? pm_pow2i(e) : ldexpf(1.f, e);
    return v3(in[0] * f, in[1] * f, in[2] * f);
}

static inline void pm_photon_set(pm_photon *ph, vec3 p, vec3 normal, vec3 direction, vec3 power, int path) {
    ph->pos[0] = p.x;
    ph->pos[1] = p.y;
    ph->pos[2] = p.z;
    uint16_t normal_code;
    pm_oct_encode_pair(normal, direction, &normal_code, &ph->direction);
    ph->normal_path = (uint16_t)(normal_code | ((path & 3) << 14));
    pm_rgbe_encode(power, ph->power);
}

static inline vec3 pm_photon_normal(const pm_photon *ph) { return pm_oct_decode_bits(ph->normal_path & 0x3fff, 7); }
static inline int pm_photon_path(const pm_photon *ph) { return ph->normal_path >> 14; }
static inline vec3 pm_photon_direction(const pm_photon *ph) { return pm_oct_decode(ph->direction); }
static inline vec3 pm_photon_power(const pm_photon *ph) { return pm_rgbe_decode(ph->power); }

static inline vec3 pm_photon_position(const pm_photon *ph) { return v3(ph->pos[0], ph->pos[1], ph->pos[2]); }

/* Whether a photon counts for a surface point facing n: its path tag is in path_mask, it arrived
 * from the side n faces, and its surface's normal is within about 25 degrees (cos 0.9) of n, so
 * photons on the back of a thin wall or on another surface across a corner count for nothing.
 * The same test as pm_photon_estimate's, without a square root. */
static inline __attribute__((always_inline)) bool pm_photon_counts_for(const pm_photon *ph, vec3 n, unsigned path_mask) {
    if (!((path_mask >> (ph->normal_path >> 14)) & 1u)) return false;
    if (v3_dot(pm_oct_decode_unnormalised(ph->direction, 8), n) >= 0.f) return false;
    vec3 pn = pm_oct_decode_unnormalised(ph->normal_path & 0x3fff, 7);
    float c = v3_dot(pn, n);
    return c > 0.f && c * c >= 0.81f * v3_dot(pn, pn);
}

#endif

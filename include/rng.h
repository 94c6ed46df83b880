/* rng.h: PCG32 random streams, seeded by hashing (seed, stream, index) so images never depend on thread count.
 *
 * Every pixel sample and every photon gets its own stream from pm_rng_for(seed, a, b):
 * which thread or tile runs it does not change a single number.
 */
#ifndef PM_RNG_H
#define PM_RNG_H

#include <stdint.h>

typedef struct { uint64_t state, inc; } pm_rng;

static inline uint64_t pm_hash64(uint64_t x) {
    x ^= x >> 30; x *= 0xbf58476d1ce4e5b9ULL;
    x ^= x >> 27; x *= 0x94d049bb133111ebULL;
    x ^= x >> 31;
    return x;
}

static inline uint32_t pm_rng_u32(pm_rng *r) {
    uint64_t old = r->state;
    r->state = old * 6364136223846793005ULL + r->inc;
    uint32_t xorshifted = (uint32_t)(((old >> 18u) ^ old) >> 27u);
    uint32_t rot = (uint32_t)(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((-rot) & 31));
}

/* Uniform float in [0, 1): 24 random bits, so 1.0 is never returned. */
static inline float pm_rng_float(pm_rng *r) { return (float)(pm_rng_u32(r) >> 8) * (1.f / 16777216.f); }

/* What pm_rng_for(seed, a, b) computes from (seed, a) alone: a loop over b (the photons of a
 * pass) makes it once with pm_rng_family_for and each stream with pm_rng_member, the same numbers. */
typedef struct { uint64_t inc, mix; } pm_rng_family;

static inline pm_rng_family pm_rng_family_for(uint64_t seed, uint64_t a) {
    pm_rng_family f;
    f.inc = (pm_hash64(seed ^ pm_hash64(a + 0x9e3779b97f4a7c15ULL)) << 1u) | 1u;
    f.mix = pm_hash64(seed + 0x632be59bd9b4e019ULL);
    return f;
}

static inline pm_rng pm_rng_member(pm_rng_family f, uint64_t b) {
    pm_rng r;
    r.inc = f.inc;
    r.state = f.inc; /* one step from state 0 */
    r.state += pm_hash64(b ^ f.mix);
    pm_rng_u32(&r);
    return r;
}

static inline pm_rng pm_rng_for(uint64_t seed, uint64_t a, uint64_t b) { return pm_rng_member(pm_rng_family_for(seed, a), b); }

#endif

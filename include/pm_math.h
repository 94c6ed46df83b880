/* pm_math.h: small vector maths, colour helpers and scale-robust ray offsets shared by every stage.
 *
 * Header-only and inline: these run per ray and per photon. vec3 is three floats;
 * colours use the same type (x=R, y=G, z=B).
 */
#ifndef PM_MATH_H
#define PM_MATH_H

#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#define PM_PI 3.14159265358979323846f
#define PM_INV_PI 0.31830988618379067154f

typedef struct { float x, y, z; } vec3;

/* Plain compares, so they compile to one instruction: fminf/fmaxf are library calls unless NaN
 * handling is given up for the whole program, and these never see NaN (inputs are validated). */
static inline float pm_minf(float a, float b) { return a < b ? a : b; }
static inline float pm_maxf(float a, float b) { return a > b ? a : b; }

/* The last i < n with cdf[i] <= u, for a nondecreasing cdf with cdf[0] <= u: the interval of a
 * sampled CDF that holds u (0 when n is 0 or u is NaN). Each of its log2 n steps is a compare and
 * a select, not a branch: u is random, so a branch would be mispredicted half the time (one pick
 * per photon, per light sample). */
static inline uint32_t pm_cdf_interval(const float *cdf, uint32_t n, float u) {
    uint32_t lo = 0;
    while (n > 1) {
        uint32_t half = n / 2;
        lo = cdf[lo + half] <= u ? lo + half : lo;
        n -= half;
    }
    return lo;
}

/* A cut-point table for a CDF of n intervals (Chen and Asau 1974): cut[j] is pm_cdf_interval at
 * u = j / n, for j < n. A pick then starts at its cell's cut and steps to the right interval: one
 * load and, in expectation over u, at most two compares, where the binary search makes log2 n
 * compares, each waiting for the last one's load (8 on an emissive sphere of 224 triangles: a
 * fifth of a photon's emission; 21 on a sky map of 2048 x 1024 texels, 14% of a render). */
static inline void pm_cdf_cut_points(const float *cdf, uint32_t n, uint32_t *cut) {
    uint32_t lo = 0; /* one walk up the cdf: the j / n rise with j (a sky map's rows hold millions of texels) */
    for (uint32_t j = 0; j < n; j++) {
        float u = (float)((double)j / n);
        while (lo + 1 < n && cdf[lo + 1] <= u) lo++;
        cut[j] = lo;
    }
}

enum { PM_CDF_SEARCH_MAX = 16 };

/* The cut point a pick at u starts from: cell floor(u n) of the table, the last for u = 1 (and
 * the first for a NaN or negative u). */
static inline uint32_t pm_cdf_cut_slot(uint32_t n, float u) {
    float x = u * (float)n;
    return !(x >= 0.f) ? 0 : x < (float)n ? (uint32_t)x : n - 1;
}

/* pm_cdf_interval's answer, the very same interval (its steps go both ways, so a cell's cut that
 * float rounding put past u is walked back), from the cut points of pm_cdf_cut_points. */
static inline uint32_t pm_cdf_interval_cut(const float *cdf, const uint32_t *cut, uint32_t n, float u) {
    /* a short search costs less than the cut's conversion and extra load: a CDF within a cache
     * line or two stays with it (the branch goes one way for a whole table) */
    if (n <= PM_CDF_SEARCH_MAX) return pm_cdf_interval(cdf, n, u);
    if (!(u * (float)n >= 0.f)) return 0; /* as the search: 0 for a NaN (or negative) u */
    uint32_t lo = cut[pm_cdf_cut_slot(n, u)];
    /* the one step most picks take, as a select (whether u passes the cell's first interval is
     * random, a branch on it mispredicted); the loops after it rarely run */
    lo += lo + 1 < n && cdf[lo + 1] <= u;
    while (lo + 1 < n && cdf[lo + 1] <= u) lo++;
    while (lo > 0 && cdf[lo] > u) lo--;
    return lo;
}

static inline vec3 v3(float x, float y, float z) { vec3 r = {x, y, z}; return r; }
static inline vec3 v3s(float s) { return v3(s, s, s); }
static inline vec3 v3_add(vec3 a, vec3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline vec3 v3_sub(vec3 a, vec3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline vec3 v3_mul(vec3 a, vec3 b) { return v3(a.x * b.x, a.y * b.y, a.z * b.z); }
static inline vec3 v3_scale(vec3 a, float s) { return v3(a.x * s, a.y * s, a.z * s); }
static inline vec3 v3_madd(vec3 a, vec3 b, float s) { return v3(a.x + b.x * s, a.y + b.y * s, a.z + b.z * s); }
static inline vec3 v3_neg(vec3 a) { return v3(-a.x, -a.y, -a.z); }
static inline float v3_dot(vec3 a, vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline vec3 v3_cross(vec3 a, vec3 b) {
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline float v3_length(vec3 a) { return sqrtf(v3_dot(a, a)); }
static inline vec3 v3_normalize(vec3 a) {
    float l = v3_length(a);
    return l > 0.f ? v3_scale(a, 1.f / l) : v3(0.f, 0.f, 1.f);
}
static inline vec3 v3_min(vec3 a, vec3 b) { return v3(pm_minf(a.x, b.x), pm_minf(a.y, b.y), pm_minf(a.z, b.z)); }
static inline vec3 v3_max(vec3 a, vec3 b) { return v3(pm_maxf(a.x, b.x), pm_maxf(a.y, b.y), pm_maxf(a.z, b.z)); }
static inline float v3_max_component(vec3 a) { return pm_maxf(a.x, pm_maxf(a.y, a.z)); }
static inline float v3_average(vec3 a) { return (a.x + a.y + a.z) * (1.f / 3.f); }
static inline bool v3_is_black(vec3 a) { return a.x == 0.f && a.y == 0.f && a.z == 0.f; }
static inline bool v3_is_finite(vec3 a) { return isfinite(a.x) && isfinite(a.y) && isfinite(a.z); }
static inline float v3_get(vec3 a, int i) { return i == 0 ? a.x : (i == 1 ? a.y : a.z); }
/* Rec. 709 luminance: the scalar used to pick lights by power. */
static inline float v3_luminance(vec3 c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }

/* Orthonormal basis around a unit normal (Duff et al. 2017, branchless). */
static inline void v3_basis(vec3 n, vec3 *t, vec3 *b) {
    float sign = copysignf(1.f, n.z);
    float a = -1.f / (sign + n.z);
    float bb = n.x * n.y * a;
    *t = v3(1.f + sign * n.x * n.x * a, sign * bb, -sign * n.x);
    *b = v3(bb, sign + n.y * n.y * a, -n.y);
}

/* The point at barycentrics (b1, b2) of the triangle p0 p1 p2 (b1 and b2 weigh p1 and p2). */
static inline vec3 pm_barycentric_point(vec3 p0, vec3 p1, vec3 p2, float b1, float b2) {
    return v3_add(v3_add(v3_scale(p0, 1.f - b1 - b2), v3_scale(p1, b1)), v3_scale(p2, b2));
}

static inline vec3 v3_reflect(vec3 d, vec3 n) { return v3_sub(d, v3_scale(n, 2.f * v3_dot(d, n))); }

/* c ? a : b by bit masks: GCC compiles a float ?: to a branch, which a random condition
 * mispredicts half the time. */
static inline float pm_selectf(bool c, float a, float b) {
    uint32_t m = 0u - (uint32_t)c, ua, ub;
    memcpy(&ua, &a, 4);
    memcpy(&ub, &b, 4);
    ua = (ua & m) | (ub & ~m);
    memcpy(&a, &ua, 4);
    return a;
}

/* sin and cos of x for |x| <= pi/4: the degree-8 Taylor polynomials, accurate to 3e-7 there. */
static inline void pm_sincos_eighth(float x, float *s, float *c) {
    float x2 = x * x;
    *s = x * (1.f - x2 * (1.f / 6.f - x2 * (1.f / 120.f - x2 * (1.f / 5040.f))));
    *c = 1.f - x2 * (0.5f - x2 * (1.f / 24.f - x2 * (1.f / 720.f - x2 * (1.f / 40320.f))));
}

/* sin and cos of 2 pi u for u in [0, 1), within a few float ulps, without a libm call (every
 * diffuse bounce and gather ray needs one). The quadrant comes from u; within it the angle is
 * centred on pi/4, where degree-8 Taylor polynomials are accurate to 3e-7. */
static inline void pm_sincos_turn(float u, float *s, float *c) {
    float q4 = u * 4.f;
    int q = (int)q4;
    float sx, cx;
    pm_sincos_eighth((q4 - (float)q - 0.5f) * (PM_PI / 2.f), &sx, &cx); /* |x| <= pi/4 */
    const float h = 0.70710678118654752f; /* angle = x + pi/4 inside the quadrant */
    float sa = h * (sx + cx), ca = h * (cx - sx);
    /* quadrant q & 3 = 0: (sa, ca), 1: (ca, -sa), 2: (-sa, -ca), 3: (-ca, sa), by bit selects and
     * sign flips: the quadrant is random, and a branch on it would be mispredicted half the time */
    uint32_t sb, cb;
    memcpy(&sb, &sa, 4);
    memcpy(&cb, &ca, 4);
    uint32_t swap = 0u - (uint32_t)(q & 1);
    uint32_t sin_bits = ((cb & swap) | (sb & ~swap)) ^ ((uint32_t)(q & 2) << 30);
    uint32_t cos_bits = ((sb & swap) | (cb & ~swap)) ^ ((uint32_t)((q + 1) & 2) << 30);
    memcpy(s, &sin_bits, 4);
    memcpy(c, &cos_bits, 4);
}

/* Cosine-distributed direction around n from two uniform numbers. */
static inline vec3 pm_sample_cosine(vec3 n, float u1, float u2) {
    float r = sqrtf(u1), sin_phi, cos_phi;
    pm_sincos_turn(u2, &sin_phi, &cos_phi);
    float x = r * cos_phi, y = r * sin_phi, z = sqrtf(pm_maxf(0.f, 1.f - u1));
    vec3 t, b;
    v3_basis(n, &t, &b);
    return v3_add(v3_add(v3_scale(t, x), v3_scale(b, y)), v3_scale(n, z));
}

/* Uniform point on the unit disc (concentric mapping keeps strata compact). Which half of the
 * square a point lies in is random, so the two cases are selects, not
 * branches (a branch here was mispredicted half the time: every sun and sky photon starts on a
 * disc), and the angle's sine and cosine come from pm_sincos_eighth, not libm: the case |a| > |b|
 * has phi = theta, the other phi = pi/2 - theta, with theta = pi/4 x the smaller over the larger,
 * so the second swaps sine and cosine. At the centre r = 0 and the point is (0, 0). */
static inline void pm_sample_disc(float u1, float u2, float *x, float *y) {
    float a = 2.f * u1 - 1.f, b = 2.f * u2 - 1.f;
    bool wide = a * a > b * b;
    float r = pm_selectf(wide, a, b), other = pm_selectf(wide, b, a);
    float s, c; /* r = 0 only where other = 0 too: theta 0 there, not 0 / 0 */
    pm_sincos_eighth((PM_PI / 4.f) * (other / pm_selectf(r != 0.f, r, 1.f)), &s, &c);
    *x = r * pm_selectf(wide, c, s);
    *y = r * pm_selectf(wide, s, c);
}

static inline vec3 pm_sample_sphere(float u1, float u2) {
    float z = 1.f - 2.f * u1, r = sqrtf(pm_maxf(0.f, 1.f - z * z)), sin_phi, cos_phi;
    pm_sincos_turn(u2, &sin_phi, &cos_phi);
    return v3(r * cos_phi, r * sin_phi, z);
}

/* atan(t) for t in [-1, 1], within 3e-7 (a polynomial fit on [0, 1]): a guide cell's pick, at
 * every light vertex's weighing, where atan2f took a twentieth of the time. */
static inline float pm_atan_unit(float t) {
    float a = fabsf(t), a2 = a * a;
    float r = a * (0.99997726f + a2 * (-0.33262347f + a2 * (0.19354346f + a2 * (-0.11643287f + a2 * (0.05265332f - 0.01172120f * a2)))));
    return t < 0.f ? -r : r;
}

/* The turn of a direction's azimuth in the frame (x, y): in [0, 1), within 3e-7 of atan2's
 * (pm_atan_unit, folded by octant). */
static inline float pm_azimuth_turn(float x, float y) {
    float ax = fabsf(x), ay = fabsf(y), lo = pm_minf(ax, ay), hi = pm_maxf(ax, ay);
    float a = pm_atan_unit(hi > 0.f ? lo / hi : 0.f);
    if (ay > ax) a = (float)(PM_PI / 2.0) - a;
    if (x < 0.f) a = (float)PM_PI - a;
    if (y < 0.f) a = -a;
    float turn = a * (float)(0.5 / PM_PI);
    return turn < 0.f ? turn + 1.f : (turn >= 1.f ? 0.f : turn);
}

/* The two numbers pm_sample_sphere turns into the unit direction w. */
static inline void pm_sphere_numbers(vec3 w, float *u1, float *u2) {
    *u1 = pm_minf(pm_maxf(0.5f * (1.f - w.z), 0.f), 0.99999994f); /* the float below 1 */
    *u2 = pm_azimuth_turn(w.x, w.y);
}

/* Moves a surface point off its surface along the geometric normal n by a few float ulps of
 * the point's own coordinates, so the offset is right at any distance from the origin. Hit
 * points are interpolated from the triangle's vertices (not o + t d), so their error is a few
 * ulps and 32 ulps clear it with margin; far from the origin a larger offset would step
 * across small rooms
 * (integer-ulp offsetting, Waechter & Binder, Ray Tracing Gems ch. 6). Near the origin,
 * where ulps vanish, a step relative to the scene's size `scale` takes over, so a scene
 * scaled by 1e-3 or 1e3 behaves exactly like the unit one. */
/* Per coordinate: p's bits moved by (int)(32 n) ulps away from or toward zero as n says, or, where
 * |p| < scale / 32, p + scale / 65536 n. The three coordinates go in one SSE register (GCC and
 * clang vector extensions), each lane with exactly the scalar operations: every ray's origin
 * comes through here, and lane by lane it costs about half the instructions. */
typedef float pm_f4_ __attribute__((vector_size(16)));
typedef uint32_t pm_u4_ __attribute__((vector_size(16)));
typedef int32_t pm_i4_ __attribute__((vector_size(16)));
/* Lanes i, j, k, l of a's and b's eight (0-3 a's, 4-7 b's): GCC and clang name and shape the
 * builtin differently (make fuzz builds with clang). */
#ifdef __clang__
#define PM_SHUFFLE(a, b, i, j, k, l) __builtin_shufflevector(a, b, i, j, k, l)
#else
#define PM_SHUFFLE(a, b, i, j, k, l) __builtin_shuffle(a, b, (pm_i4_){i, j, k, l})
#endif
static inline vec3 pm_offset_ray_origin(vec3 p, vec3 n, float scale) {
    pm_f4_ vp = {p.x, p.y, p.z, 0.f}, vn = {n.x, n.y, n.z, 0.f};
    pm_u4_ of = (pm_u4_)__builtin_convertvector(vn * 32.f, pm_i4_); /* truncated, as (int32_t) does */
    pm_u4_ negative = (pm_u4_)(vp < 0.f);                              /* all ones where p < 0 */
    pm_u4_ moved = (pm_u4_)vp + ((of ^ negative) - negative);          /* -of there, else +of */
    pm_f4_ magnitude = (pm_f4_)((pm_u4_)vp & 0x7fffffffu);
    pm_u4_ near_zero = (pm_u4_)(magnitude < scale * (1.f / 32.f));
    pm_f4_ stepped = vp + scale * (1.f / 65536.f) * vn;
    pm_f4_ r = (pm_f4_)((near_zero & (pm_u4_)stepped) | (~near_zero & moved));
    return v3(r[0], r[1], r[2]);
}

/* sRGB transfer functions (IEC 61966-2-1). */
static inline float pm_srgb_to_linear(float c) {
    return c <= 0.04045f ? c / 12.92f : powf((c + 0.055f) / 1.055f, 2.4f);
}
static inline float pm_linear_to_srgb(float c) {
    return c <= 0.0031308f ? c * 12.92f : 1.055f * powf(c, 1.f / 2.4f) - 0.055f;
}

#endif

/* test_math.c: the shared maths of pm_math.h, photon.h and rng.h: the libm-free sincos, cosine and disc sampling moments, min/max, CDF search, uniform floats, ray offsets, octahedral codes, pinned streams. */
#include "photon.h"
#include "pm_math.h"
#include "rng.h"
#include "testing.h"

/* pm_offset_ray_origin one coordinate at a time, the scalar definition: the vector form
 * must give the same bits (the sum wraps in unsigned arithmetic: -0 with a negative n would
 * overflow an int, in a result the near-zero step replaces anyway) */
static float offset_reference(float p, float n, float scale) {
    int32_t of = (int32_t)(32.f * n);
    uint32_t bits;
    memcpy(&bits, &p, 4);
    bits += (uint32_t)((p < 0.f) ? -of : of);
    float moved;
    memcpy(&moved, &bits, 4);
    return fabsf(p) < scale * (1.f / 32.f) ? p + scale * (1.f / 65536.f) * n : moved;
}

/* The octahedral decode as its definition reads, with the lower half's fold as a branch: the
 * branch-free form in photon.h must give the same bits for every code. */
static vec3 oct_decode_reference(uint16_t code, int bits) {
    int mask = (1 << bits) - 1;
    float scale = 2.f / (float)mask;
    float x = (float)(code & mask) * scale - 1.f, y = (float)((code >> bits) & mask) * scale - 1.f;
    float z = 1.f - fabsf(x) - fabsf(y);
    if (z < 0.f) {
        float ox = (1.f - fabsf(y)) * (x >= 0.f ? 1.f : -1.f);
        float oy = (1.f - fabsf(x)) * (y >= 0.f ? 1.f : -1.f);
        x = ox;
        y = oy;
    }
    return v3(x, y, z);
}

/* The octahedral encode as its definition reads, one vector at a time with the fold as a branch:
 * pm_oct_encode_pair must give the same code for every vector. */
static uint16_t oct_encode_reference(vec3 n, int bits) {
    int mask = (1 << bits) - 1;
    float s = fabsf(n.x) + fabsf(n.y) + fabsf(n.z);
    if (!(s > 0.f)) return (uint16_t)(((mask + 1) / 2) | (((mask + 1) / 2) << bits));
    float inv = 1.f / s, x = n.x * inv, y = n.y * inv;
    if (n.z < 0.f) {
        float ox = copysignf(1.f - fabsf(y), x), oy = copysignf(1.f - fabsf(x), y);
        x = ox;
        y = oy;
    }
    int qx = (int)((x * 0.5f + 0.5f) * (float)mask + 0.5f), qy = (int)((y * 0.5f + 0.5f) * (float)mask + 0.5f);
    return (uint16_t)((qx & mask) | ((qy & mask) << bits));
}

/* Both codes of a record from pm_oct_encode_pair against the reference; false where either differs. */
static bool pair_matches(vec3 normal, vec3 direction) {
    uint16_t n7, d8;
    pm_oct_encode_pair(normal, direction, &n7, &d8);
    return n7 == oct_encode_reference(normal, 7) && d8 == oct_encode_reference(direction, 8);
}

static void test_octahedral_codes(void) {
    /* encodes: random unit and unnormalised vectors, the axes and diagonals with either zero's
     * sign (the fold's seams), zero and NaN */
    pm_rng e = pm_rng_for(4, 4, 4);
    long encodes_differ = 0, encodes = 0;
    for (int i = 0; i < 200000; i++) {
        float scale = i % 2 ? 1.f : ldexpf(1.f, (int)(pm_rng_float(&e) * 40.f) - 20);
        vec3 a = v3_scale(v3(pm_rng_float(&e) - 0.5f, pm_rng_float(&e) - 0.5f, pm_rng_float(&e) - 0.5f), scale);
        vec3 b = v3_normalize(v3(pm_rng_float(&e) - 0.5f, pm_rng_float(&e) - 0.5f, pm_rng_float(&e) - 0.5f));
        encodes_differ += !pair_matches(a, b) + !pair_matches(b, a);
        encodes += 2;
    }
    const float special[] = {0.f, -0.f, 1.f, -1.f, 0.5f, -0.5f, NAN};
    enum { SPECIALS = sizeof special / sizeof special[0] };
    for (int i = 0; i < SPECIALS * SPECIALS * SPECIALS; i++) {
        vec3 v = v3(special[i % SPECIALS], special[i / SPECIALS % SPECIALS], special[i / (SPECIALS * SPECIALS)]);
        encodes_differ += !pair_matches(v, v3(0.f, 0.f, 1.f)) + !pair_matches(v3(0.f, -1.f, 0.f), v);
        encodes += 2;
    }
    CHECK(encodes_differ == 0, "%ld of %ld octahedral encodes differ from the reference", encodes_differ, encodes);
    long differ = 0;
    for (int bits = 7; bits <= 8; bits++)
        for (uint32_t code = 0; code < (1u << (2 * bits)); code++) {
            vec3 want = oct_decode_reference((uint16_t)code, bits), got = pm_oct_decode_unnormalised((uint16_t)code, bits);
            differ += memcmp(&want, &got, sizeof want) != 0;
        }
    CHECK(differ == 0, "%ld octahedral codes decode to other bits than the reference", differ);
    /* round trip: a unit vector comes back within the code's resolution (8 bits: about 1 degree) */
    pm_rng g = pm_rng_for(9, 8, 7);
    double worst[2] = {0, 0};
    for (int i = 0; i < 100000; i++) {
        vec3 n = v3_normalize(v3(pm_rng_float(&g) - 0.5f, pm_rng_float(&g) - 0.5f, pm_rng_float(&g) - 0.5f));
        for (int k = 0; k < 2; k++) {
            int bits = 7 + k;
            uint16_t code[2];
            pm_oct_encode_pair(n, n, &code[0], &code[1]);
            vec3 back = pm_oct_decode_bits(code[k], bits);
            double angle = acos(fmin(1.0, (double)v3_dot(n, back))) * 180.0 / 3.14159265358979323846;
            if (angle > worst[k]) worst[k] = angle;
        }
    }
    CHECK(worst[0] < 2.5 && worst[1] < 1.25, "octahedral round trip off by %.3f (7 bits), %.3f (8 bits) degrees", worst[0], worst[1]);
    printf("octahedral round trip: at most %.3f degrees at 7 bits, %.3f at 8\n", worst[0], worst[1]);
}

/* pm_cdf_interval and pm_cdf_interval_cut against a linear scan (the last i < n with cdf[i] <= u)
 * on CDFs of every size to 40, normalized (as the renderer's) or not, with runs of equal entries
 * (lights of no power) and u on, between and past the entries and next to the cut points' j / n */
static void test_cdf_interval(void) {
    pm_rng rng = pm_rng_for(5, 1, 2);
    long differ = 0, differ_cut = 0, cases = 0;
    for (uint32_t n = 0; n <= 40; n++) {
        for (int trial = 0; trial < 50; trial++) {
            float cdf[41];
            uint32_t cut[40];
            cdf[0] = 0.f;
            for (uint32_t i = 1; i <= n; i++) cdf[i] = cdf[i - 1] + (pm_rng_float(&rng) < 0.3f ? 0.f : pm_rng_float(&rng));
            if (trial % 2 && n && cdf[n] > 0.f)
                for (uint32_t i = 1; i <= n; i++) cdf[i] = i == n ? 1.f : cdf[i] / cdf[n];
            /* equal intervals (equal emitters): each entry on a cut point, where u * n rounded up
             * to j from below j / n (n = 19, j = 9) starts past u and must step back */
            if (trial == 0)
                for (uint32_t i = 1; i <= n; i++) cdf[i] = (float)((double)i / n);
            pm_cdf_cut_points(cdf, n, cut);
            for (int k = 0; k < 60; k++) {
                float u = k < 20   ? cdf[(uint32_t)(pm_rng_float(&rng) * (float)(n + 1))]
                          : k < 40 ? pm_rng_float(&rng) * (cdf[n] + 0.1f)
                                   : nextafterf((float)((double)((k / 2) % (n + 1)) / (n ? n : 1)), k % 2 ? 2.f : -1.f);
                uint32_t expect = 0;
                for (uint32_t i = 0; i < n; i++)
                    if (cdf[i] <= u) expect = i;
                differ += pm_cdf_interval(cdf, n, u) != expect;
                differ_cut += pm_cdf_interval_cut(cdf, cut, n, u) != expect;
                cases++;
            }
        }
    }
    CHECK(differ == 0, "pm_cdf_interval differs from a linear scan in %ld of %ld cases", differ, cases);
    CHECK(differ_cut == 0, "pm_cdf_interval_cut differs from a linear scan in %ld of %ld cases", differ_cut, cases);
    float one[2] = {0.f, 1.f};
    uint32_t cut_one[1] = {0};
    CHECK(pm_cdf_interval(one, 1, 0.5f) == 0 && pm_cdf_interval(one, 0, 0.5f) == 0 && pm_cdf_interval(one, 1, NAN) == 0,
          "one interval, none, NaN");
    float zero_first[4] = {0.f, 0.f, 0.f, 1.f}; /* two intervals of no width first: a NaN still picks 0, as the search */
    uint32_t cut_three[3];
    pm_cdf_cut_points(zero_first, 3, cut_three);
    CHECK(pm_cdf_interval_cut(one, cut_one, 1, 0.5f) == 0 && pm_cdf_interval_cut(zero_first, cut_three, 3, NAN) == 0 &&
              pm_cdf_interval_cut(zero_first, cut_three, 3, 0.f) == 2,
          "cut points: one interval, NaN, u = 0 past intervals of no width");
}

int main(void) {
    test_cdf_interval();
    test_octahedral_codes();
    /* sin and cos of 2 pi u on a dense grid, and at the quadrant seams */
    double worst = 0;
    for (int i = 0; i < (1 << 20); i++) {
        float u = (float)i / (1 << 20), s, c;
        pm_sincos_turn(u, &s, &c);
        double a = 2.0 * 3.14159265358979323846 * u;
        double e = fmax(fabs(s - sin(a)), fabs(c - cos(a)));
        if (e > worst) worst = e;
    }
    CHECK(worst < 5e-7, "pm_sincos_turn off by %g", worst);
    float s, c;
    pm_sincos_turn(0.25f, &s, &c);
    CHECK(fabsf(s - 1.f) < 1e-6f && fabsf(c) < 1e-6f, "quarter turn: sin %g cos %g", s, c);
    pm_sincos_turn(0.9999999f, &s, &c);
    CHECK(fabsf(c - 1.f) < 1e-6f && fabsf(s) < 1e-5f, "a whole turn less an ulp: sin %g cos %g", s, c);

    /* cosine sampling around a tilted normal: unit length, in the hemisphere, E[cos] = 2/3,
     * E[cos^2] = 1/2, and no preferred azimuth (the tangent components average to zero) */
    vec3 n = v3_normalize(v3(0.3f, -0.5f, 0.8f)), t, b;
    v3_basis(n, &t, &b);
    pm_rng rng = pm_rng_for(1, 2, 3);
    double m1 = 0, m2 = 0, mt = 0, mb = 0;
    int bad = 0, N = 400000;
    for (int i = 0; i < N; i++) {
        vec3 d = pm_sample_cosine(n, pm_rng_float(&rng), pm_rng_float(&rng));
        float cz = v3_dot(d, n);
        if (fabsf(v3_length(d) - 1.f) > 1e-5f || cz < 0.f) bad++;
        m1 += cz;
        m2 += cz * cz;
        mt += v3_dot(d, t);
        mb += v3_dot(d, b);
    }
    CHECK(bad == 0, "%d cosine samples not unit or below the surface", bad);
    CHECK_NEAR(m1 / N, 2.0 / 3.0, 0.003, 0, "E[cos theta] of cosine sampling");
    CHECK_NEAR(m2 / N, 0.5, 0.004, 0, "E[cos^2 theta] of cosine sampling");
    CHECK(fabs(mt / N) < 0.004 && fabs(mb / N) < 0.004, "no preferred azimuth (%g, %g)", mt / N, mb / N);

    /* uniform disc: E[r^2] = 1/2, inside the unit disc */
    double r2 = 0;
    bad = 0;
    for (int i = 0; i < N; i++) {
        float x, y;
        pm_sample_disc(pm_rng_float(&rng), pm_rng_float(&rng), &x, &y);
        if (x * x + y * y > 1.f + 1e-6f) bad++;
        r2 += x * x + y * y;
    }
    CHECK(bad == 0, "%d disc samples outside the disc", bad);
    CHECK_NEAR(r2 / N, 0.5, 0.004, 0, "E[r^2] of the disc");

    /* uniform floats never reach 1, min/max compare as expected */
    pm_rng edge = {~0ULL, 1};
    float top = 0.f;
    for (int i = 0; i < 1000; i++) top = pm_maxf(top, pm_rng_float(&edge));
    CHECK(top < 1.f, "pm_rng_float returned %g", top);
    CHECK(pm_minf(-1.f, 2.f) == -1.f && pm_maxf(-1.f, 2.f) == 2.f && pm_maxf(0.f, -0.f) == 0.f, "min/max");

    /* ray offsets: the same bits as the per-coordinate form, from 1e-18 to 1e18, with zeros of
     * both signs, axis normals and points under the scale step */
    pm_rng g = pm_rng_for(3, 4, 5);
    int offset_bad = 0;
    for (int i = 0; i < 200000; i++) {
        float mag = ldexpf(1.f, (int)(pm_rng_u32(&g) % 120) - 60);
        vec3 p = v3((pm_rng_float(&g) - 0.5f) * mag, (pm_rng_float(&g) - 0.5f) * mag, (pm_rng_float(&g) - 0.5f) * mag);
        if (i % 7 == 0) p.y = 0.f;
        if (i % 11 == 0) p.z = -0.f;
        vec3 n = v3_normalize(v3(pm_rng_float(&g) - 0.5f, pm_rng_float(&g) - 0.5f, pm_rng_float(&g) - 0.5f));
        if (i % 13 == 0) n = v3(0.f, 0.f, (i & 1) ? 1.f : -1.f);
        float scale = ldexpf(1.f, (int)(pm_rng_u32(&g) % 40) - 20);
        vec3 got = pm_offset_ray_origin(p, n, scale);
        float want[3] = {offset_reference(p.x, n.x, scale), offset_reference(p.y, n.y, scale), offset_reference(p.z, n.z, scale)};
        offset_bad += memcmp(&got.x, &want[0], 4) != 0 || memcmp(&got.y, &want[1], 4) != 0 || memcmp(&got.z, &want[2], 4) != 0;
    }
    CHECK(offset_bad == 0, "%d of 200000 ray offsets differ from the per-coordinate form", offset_bad);

    /* streams are pinned: every image depends on these numbers (pm_rng_for is made of
     * pm_rng_family_for and pm_rng_member, which the photon pass calls apart) */
    const uint32_t pinned[6] = {0x5f94a6f6u, 0x135be165u, 0x306cd232u, 0x4093ed5du, 0xeb903fccu, 0xea9836d8u};
    pm_rng one = pm_rng_for(7, 0x61, 12345), other = pm_rng_member(pm_rng_family_for(0xdeadbeefULL, 0x51), 0);
    uint32_t drawn[6] = {pm_rng_u32(&one), pm_rng_u32(&one), pm_rng_u32(&one), pm_rng_u32(&one), pm_rng_u32(&other), pm_rng_u32(&other)};
    CHECK(memcmp(drawn, pinned, sizeof pinned) == 0, "streams moved: %08x %08x %08x %08x %08x %08x", drawn[0], drawn[1],
          drawn[2], drawn[3], drawn[4], drawn[5]);
    return pm_test_done("test_math");
}

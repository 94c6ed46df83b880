/* test_accel.c: hit distances and self-intersection-free ray offsets at any scale and far from the origin. */
#include "accel.h"
#include "camera.h"
#include "rng.h"
#include "scene_builder.h"
#include "testing.h"

/* A closed cube room of half-size `scale` centred at `center`. */
static void check_scale(float scale, vec3 center) {
    pm_scene s;
    memset(&s, 0, sizeof s);
    uint32_t m = sb_lambert(&s, v3s(0.5f));
    sb_box(&s, v3_sub(center, v3s(scale)), v3_add(center, v3s(scale)), m, true);
    /* a floating plate inside, so rays also start next to other geometry */
    sb_quad(&s, v3_add(center, v3(-0.5f * scale, 0, -0.5f * scale)), v3_add(center, v3(-0.5f * scale, 0, 0.5f * scale)),
            v3_add(center, v3(0.5f * scale, 0, 0.5f * scale)), v3_add(center, v3(0.5f * scale, 0, -0.5f * scale)), m);
    pm_scene_finalize(&s, false, NULL);
    char err[256];
    pm_accel *a = pm_accel_create(&s, err, sizeof err);
    CHECK(a != NULL, "accel: %s", err);
    if (!a) return;

    /* Hit distances: from the centre straight up to the ceiling at distance scale. */
    pm_hit h;
    /* distances are exact to the float spacing of the coordinates, no better */
    float far = fmaxf(fabsf(center.x), fmaxf(fabsf(center.y), fabsf(center.z))) + scale;
    double ulp_tol = 8.0 * (nextafterf(far, INFINITY) - far);
    vec3 from = v3_add(center, v3(0.1f * scale, 0.25f * scale, 0.2f * scale));
    bool hit = pm_accel_intersect(a, from, v3(0, 1, 0), INFINITY, &h);
    CHECK(hit, "ray up from inside must hit the ceiling (scale %g)", scale);
    if (hit) CHECK_NEAR(h.t, 0.75 * scale, 1e-5, ulp_tol, "distance to the ceiling");
    hit = pm_accel_intersect(a, from, v3(0, -1, 0), INFINITY, &h);
    CHECK(hit, "ray down must hit the plate");
    if (hit) {
        CHECK_NEAR(h.t, 0.25 * scale, 1e-5, ulp_tol, "distance to the plate");
        pm_surface sf;
        pm_scene_surface(&s, h.tri, h.b1, h.b2, &sf);
        CHECK_NEAR(sf.p.y, center.y, 1e-6, ulp_tol, "hit point from barycentrics lies on the plate");
    }
    CHECK(!pm_accel_intersect(a, from, v3(0, 1, 0), 0.5f * scale, &h), "tmax must cut the ray short");
    CHECK(pm_accel_occluded(a, from, v3(0, 1, 0), 0.8f * scale), "occluded up to 0.8");
    CHECK(!pm_accel_occluded(a, from, v3(0, 1, 0), 0.7f * scale), "not occluded up to 0.7");

    /* Random walk inside the closed room: every bounce from an offset origin must hit another
     * surface at a real distance (no self-hit at t ~ 0, no escape through the walls). */
    int escapes = 0, self_hits = 0, bounces = 0;
    pm_rng rng = pm_rng_for(7, 1, 2);
    for (int path = 0; path < 400; path++) {
        vec3 o = v3_add(center, v3_scale(v3(pm_rng_float(&rng) - 0.5f, pm_rng_float(&rng) * 0.5f + 0.2f,
                                            pm_rng_float(&rng) - 0.5f), scale));
        vec3 d = pm_sample_sphere(pm_rng_float(&rng), pm_rng_float(&rng));
        for (int b = 0; b < 25; b++) {
            if (!pm_accel_intersect(a, o, d, INFINITY, &h)) { if (getenv("PM_DEBUG")) fprintf(stderr, "escape b=%d o=%.9g %.9g %.9g d=%g %g %g\n", b, o.x, o.y, o.z, d.x, d.y, d.z); escapes++; break; }
            bounces++;
            pm_surface sf;
            pm_scene_surface(&s, h.tri, h.b1, h.b2, &sf);
            vec3 n = v3_dot(sf.ng, d) < 0.f ? sf.ng : v3_neg(sf.ng);
            o = pm_surface_origin(&sf, n, s.ray_scale);
            d = pm_sample_cosine(n, pm_rng_float(&rng), pm_rng_float(&rng));
            /* grazing directions are the hard case for offsets */
            if (b % 5 == 4) d = v3_normalize(v3_madd(d, n, -0.999f * v3_dot(d, n)));
            pm_hit next;
            if (pm_accel_intersect(a, o, d, INFINITY, &next) && next.tri == h.tri && next.t < 1e-4f * scale) self_hits++;
        }
    }
    CHECK(escapes == 0, "%d of 400 random walks escaped the closed room (scale %g, centre %g)", escapes, scale, center.x);
    CHECK(self_hits == 0, "%d self-intersections in %d bounces (scale %g, centre %g)", self_hits, bounces, scale, center.x);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

/* Rays crossing a tessellated glass-like sphere: in through one side, out through the other.
 * Offsets must put each new origin on the side the ray leaves to, whatever the triangle's
 * orientation: a curved surface is where a sloppy in-plane nudge leaves the origin behind. */
static void check_sphere_crossings(float radius, vec3 center) {
    pm_scene s;
    memset(&s, 0, sizeof s);
    uint32_t m = sb_material(&s, v3s(1.f), 0.f, 0.f, 1.f, v3s(0.f), false);
    sb_sphere(&s, center, radius, 64, m);
    pm_scene_finalize(&s, false, NULL);
    char err[256];
    pm_accel *a = pm_accel_create(&s, err, sizeof err);
    CHECK(a != NULL, "accel: %s", err);
    if (!a) return;
    int crossings = 0, wrong_side = 0, stuck = 0;
    pm_rng rng = pm_rng_for(9, 3, 4);
    for (int i = 0; i < 4000; i++) {
        vec3 target = v3_add(center, v3_scale(pm_sample_sphere(pm_rng_float(&rng), pm_rng_float(&rng)), 0.9f * radius));
        vec3 o = v3_add(center, v3_scale(pm_sample_sphere(pm_rng_float(&rng), pm_rng_float(&rng)), 3.f * radius));
        vec3 d = v3_normalize(v3_sub(target, o));
        for (int side = 0; side < 2; side++) {
            pm_hit h;
            if (!pm_accel_intersect(a, o, d, INFINITY, &h)) { stuck++; break; }
            pm_surface sf;
            pm_scene_surface(&s, h.tri, h.b1, h.b2, &sf);
            vec3 beyond = v3_dot(sf.ng, d) > 0.f ? sf.ng : v3_neg(sf.ng); /* the side the ray goes on to */
            o = pm_surface_origin(&sf, beyond, s.ray_scale);
            if (v3_dot(v3_sub(o, sf.p), beyond) <= 0.f) wrong_side++;
            /* leave in a random direction on that side, down to grazing */
            d = pm_sample_cosine(beyond, pm_rng_float(&rng), pm_rng_float(&rng));
            if (i % 4 == 3) d = v3_normalize(v3_madd(d, beyond, -0.99f * v3_dot(d, beyond)));
            pm_hit next;
            bool again = pm_accel_intersect(a, o, d, INFINITY, &next);
            if (side == 0 && (!again || (next.tri == h.tri && next.t < 1e-3f * radius))) stuck++;
            if (side == 1 && again) stuck++; /* outside a convex ball, nothing is left to hit */
            if (side == 0 && again) d = v3_normalize(v3_sub(v3_add(o, v3_scale(d, next.t)), o));
            crossings++;
        }
    }
    CHECK(wrong_side == 0, "%d of %d offset origins on the wrong side of a sphere (radius %g, centre %g)", wrong_side,
          crossings, radius, center.x);
    CHECK(stuck == 0, "%d of %d crossings re-hit their own triangle or missed the far side (radius %g, centre %g)", stuck,
          crossings, radius, center.x);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

/* Rays Embree cannot take (a coordinate beyond 1.8e18, NaN) are answered without it: Debian's
 * Embree asserts on them and would abort the process. Scenes reaching that far are refused. */
static void check_out_of_range(void) {
    pm_scene s;
    memset(&s, 0, sizeof s);
    sb_quad(&s, v3(-1, -1, 0), v3(1, -1, 0), v3(1, 1, 0), v3(-1, 1, 0), sb_lambert(&s, v3s(0.5f)));
    pm_accel *a = sb_finish(&s);
    if (!a) return;
    pm_hit hit;
    CHECK(pm_accel_intersect(a, v3(0, 0, 5), v3(0, 0, -1), INFINITY, &hit), "an ordinary ray hits the quad");
    CHECK(!pm_accel_intersect(a, v3(0, 0, 1e20f), v3(0, 0, -1), INFINITY, &hit), "a ray from 1e20 is a miss");
    CHECK(pm_accel_occluded(a, v3(0, 0, 1e20f), v3(0, 0, -1), 1e21f), "a shadow ray from 1e20 is blocked");
    CHECK(!pm_accel_intersect(a, v3(0, 0, 5), v3(NAN, 0, -1), INFINITY, &hit), "a NaN direction is a miss");
    CHECK(!pm_accel_intersect(a, v3(0, 0, 5), v3(0, 0, -1), NAN, &hit), "a NaN tmax is a miss");
    pm_accel_destroy(a);
    for (uint32_t v = 0; v < s.vertex_count; v++) s.positions[v].x *= 1e19f;
    pm_scene_finalize(&s, false, NULL);
    char err[256] = "";
    a = pm_accel_create(&s, err, sizeof err);
    printf("a quad 2e19 wide: %s\n", err);
    CHECK(!a && strstr(err, "beyond the 1.8e+18 Embree can trace"), "a scene reaching 1e19 is refused: %s", err);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

/* Packets (pm_accel_intersect_packets), coherent (camera rays) or not (photons in flight), answer
 * exactly as single rays do: the same hits, distances and barycentrics, bit for bit, through a
 * BLEND pane's stochastic alpha test, for rays Embree cannot take, and for a count that is not a
 * multiple of the packet. */
static void check_packets(bool coherent) {
    pm_scene s;
    memset(&s, 0, sizeof s);
    uint32_t m = sb_lambert(&s, v3s(0.5f)), pane = sb_lambert(&s, v3s(0.5f));
    sb_box(&s, v3s(-1.f), v3s(1.f), m, true);
    sb_sphere(&s, v3(0.3f, -0.4f, 0.1f), 0.35f, 24, m);
    sb_quad(&s, v3(-0.8f, -0.8f, 0.2f), v3(0.8f, -0.8f, 0.2f), v3(0.8f, 0.8f, 0.2f), v3(-0.8f, 0.8f, 0.2f), pane);
    s.materials[pane].alpha_mode = PM_ALPHA_BLEND;
    s.materials[pane].alpha = 0.5f;
    pm_accel *a = sb_finish(&s);
    if (!a) return;
    enum { N = 8 * 40 + 3 };
    vec3 o[N], d[N];
    bool hit[N];
    pm_hit hits[N];
    pm_rng rng = pm_rng_for(11, 0, 0);
    pm_camera cam = sb_camera(v3(0.f, 0.f, 0.95f), v3(0.f, 0.f, 0.f), v3(0.f, 1.f, 0.f), 60.f);
    for (int i = 0; i < N; i++) {
        if (i < N / 2) { /* a camera's rays, 4 x 2 blocks over a small image */
            int block = i / 8, x = 4 * (block % 5) + i % 4, y = 2 * (block / 5) + (i % 8) / 4;
            pm_camera_ray(&cam, 20, 20, x + pm_rng_float(&rng), y + pm_rng_float(&rng), &o[i], &d[i]);
        } else { /* scattered rays from anywhere in the room */
            o[i] = v3(1.8f * pm_rng_float(&rng) - 0.9f, 1.8f * pm_rng_float(&rng) - 0.9f, 1.8f * pm_rng_float(&rng) - 0.9f);
            d[i] = v3_normalize(v3(pm_rng_float(&rng) - 0.5f, pm_rng_float(&rng) - 0.5f, pm_rng_float(&rng) - 0.5f));
        }
    }
    o[N / 2 + 5] = v3(0.f, 0.f, 1e20f);
    d[N / 2 + 9] = v3(NAN, 0.f, -1.f);
    pm_accel_intersect_packets(a, N, o, d, coherent, hit, hits);
    int differ = 0, hits_seen = 0, pane_hits = 0;
    for (int i = 0; i < N; i++) {
        pm_hit h;
        bool single = pm_accel_intersect(a, o[i], d[i], INFINITY, &h);
        hits_seen += single;
        if (single) pane_hits += s.triangle_material[h.tri] == pane;
        if (single != hit[i] || (single && (memcmp(&h.t, &hits[i].t, 4) || h.tri != hits[i].tri ||
                                            memcmp(&h.b1, &hits[i].b1, 4) || memcmp(&h.b2, &hits[i].b2, 4))))
            differ++;
    }
    printf("%s packets: %d rays, %d hits (%d on the pane), %d differ from single rays\n", coherent ? "coherent" : "incoherent",
           N, hits_seen, pane_hits, differ);
    CHECK(differ == 0, "packets must answer as single rays: %d differ", differ);
    CHECK(hits_seen == N - 2, "every ray in range hits the closed room: %d of %d", hits_seen, N - 2);
    CHECK(!hit[N / 2 + 5] && !hit[N / 2 + 9], "rays Embree cannot take are misses in a packet too");
    CHECK(pane_hits > 20 && pane_hits < N / 2, "the BLEND pane stops some rays and lets others through: %d", pane_hits);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

int main(void) {
    check_packets(true);
    check_packets(false);
    check_out_of_range();
    check_sphere_crossings(0.3f, v3(0.f, 0.35f, 0.f));
    check_sphere_crossings(0.3f, v3(3.f, -2.f, 1.f));
    check_sphere_crossings(300.f, v3(1e4f, 0.f, 0.f));
    check_sphere_crossings(3e-4f, v3(0.f, 0.f, 0.f));
    check_scale(1.f, v3s(0.f));
    check_scale(1e-3f, v3s(0.f));
    check_scale(1e3f, v3s(0.f));
    check_scale(1.f, v3(1e5f, 1e5f, -1e5f));
    check_scale(1e-3f, v3(1e5f * 1e-3f, 0.f, 1e5f * 1e-3f));
    check_scale(1e3f, v3(1e5f, 1e5f, 1e5f));
    /* the 1e5-translated room at 1e-3 scale: features of 1 mm at 100 km would need double
     * precision; a renderer in float can only promise the mm room at 100 m */
    check_scale(1e-3f, v3(100.f, 100.f, 100.f));
    return pm_test_done("test_accel");
}

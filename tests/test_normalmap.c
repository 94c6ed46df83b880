/* test_normalmap.c: normal maps as shading normals: the tilt a texel asks for, the guard that keeps ns on ng's side, and a white furnace that a bumpy map never brightens. */
#include <stdlib.h>
#include <string.h>

#include "accel.h"
#include "defaults.h"
#include "film.h"
#include "progressive.h"
#include "rng.h"
#include "scene_builder.h"
#include "progressive_harness.h"
#include "testing.h"

/* Gives the scene one w x h texture from rgba (copied) and returns its index. */
static int add_texture(pm_scene *s, int w, int h, const uint8_t *rgba) {
    s->textures = sb_grow(s->textures, s->texture_count, sizeof *s->textures);
    pm_texture t;
    memset(&t, 0, sizeof t);
    t.width = w;
    t.height = h;
    t.rgba = malloc(4 * (size_t)w * h);
    if (!t.rgba) abort();
    memcpy(t.rgba, rgba, 4 * (size_t)w * h);
    t.wrap_s = t.wrap_t = PM_WRAP_REPEAT;
    s->textures[s->texture_count] = t;
    return (int)s->texture_count++;
}

/* UVs and tangents for every vertex: (u, v) from the two coordinates across each triangle's
 * face, the tangent any unit vector in the face with w = hand. */
static void add_uvs_and_tangents(pm_scene *s, float hand) {
    s->uvs = calloc(2 * (size_t)s->vertex_count, sizeof(float));
    s->tangents = calloc(4 * (size_t)s->vertex_count, sizeof(float));
    if (!s->uvs || !s->tangents) abort();
    for (uint32_t tri = 0; tri < s->triangle_count; tri++) {
        const uint32_t *ix = s->indices + 3 * (size_t)tri;
        vec3 n = s->normals[ix[0]], t, b;
        v3_basis(n, &t, &b);
        for (int k = 0; k < 3; k++) {
            vec3 p = s->positions[ix[k]];
            s->uvs[2 * ix[k]] = v3_dot(p, t);
            s->uvs[2 * ix[k] + 1] = v3_dot(p, b);
            float *out = s->tangents + 4 * (size_t)ix[k];
            out[0] = t.x;
            out[1] = t.y;
            out[2] = t.z;
            out[3] = hand;
        }
    }
}

/* The unit quad in z = 0 with tangent +x and the given w, its material normal-mapped by one texel. */
static void texel_quad(pm_scene *s, const uint8_t texel[4], float scale, float hand) {
    memset(s, 0, sizeof *s);
    uint32_t m = sb_lambert(s, v3s(0.5f));
    sb_quad(s, v3(0, 0, 0), v3(1, 0, 0), v3(1, 1, 0), v3(0, 1, 0), m);
    s->uvs = calloc(2 * (size_t)s->vertex_count, sizeof(float));
    s->tangents = calloc(4 * (size_t)s->vertex_count, sizeof(float));
    if (!s->uvs || !s->tangents) abort();
    for (uint32_t v = 0; v < s->vertex_count; v++) {
        s->uvs[2 * v] = s->positions[v].x;
        s->uvs[2 * v + 1] = 1.f - s->positions[v].y;
        s->tangents[4 * v] = 1.f;
        s->tangents[4 * v + 3] = hand;
    }
    s->materials[m].normal_texture = add_texture(s, 1, 1, texel);
    s->materials[m].normal_scale = scale;
}

/* What the texel asks for in the frame T = +x, B = hand x (+y), N = +z: (x s, y s, z) normalized. */
static vec3 expected_normal(const uint8_t texel[4], float scale, float hand) {
    double x = (2.0 * texel[0] / 255.0 - 1.0) * scale, y = (2.0 * texel[1] / 255.0 - 1.0) * scale * hand,
           z = 2.0 * texel[2] / 255.0 - 1.0, len = sqrt(x * x + y * y + z * z);
    return v3((float)(x / len), (float)(y / len), (float)(z / len));
}

static double angle_degrees(vec3 a, vec3 b) { return acos(fmax(-1.0, fmin(1.0, v3_dot(a, b)))) * 180.0 / PM_PI; }

static void test_tilts(void) {
    static const struct { uint8_t texel[4]; float scale, hand; double degrees; const char *what; } cases[] = {
        {{128, 128, 255, 255}, 1.f, 1.f, 0.0, "flat texel"},
        {{218, 128, 218, 255}, 1.f, 1.f, 45.0, "x = z: 45 degrees toward +T"},
        {{218, 128, 218, 255}, 0.5f, 1.f, 26.565, "the same at scale 0.5: atan(0.5)"},
        {{38, 128, 218, 255}, 1.f, 1.f, 45.0, "x = -z: 45 degrees toward -T"},
        {{128, 218, 218, 255}, 1.f, 1.f, 45.0, "y = z, w = +1: toward +B = +y"},
        {{128, 218, 218, 255}, 1.f, -1.f, 45.0, "y = z, w = -1: toward -y"},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        pm_scene s;
        texel_quad(&s, cases[c].texel, cases[c].scale, cases[c].hand);
        pm_scene_finalize(&s, false, NULL);
        vec3 want = expected_normal(cases[c].texel, cases[c].scale, cases[c].hand);
        for (uint32_t tri = 0; tri < 2; tri++) {
            pm_surface sf;
            pm_scene_surface(&s, tri, 0.25f, 0.35f, &sf);
            double tilt = angle_degrees(sf.ns, v3(0, 0, 1));
            CHECK(v3_length(v3_sub(sf.ns, want)) < 1e-4f && fabs(tilt - cases[c].degrees) < 0.5,
                  "%s: ns (%.4f %.4f %.4f) tilted %.2f degrees, want (%.4f %.4f %.4f) at %.2f", cases[c].what, sf.ns.x,
                  sf.ns.y, sf.ns.z, tilt, want.x, want.y, want.z, cases[c].degrees);
        }
        if (c == 1 || c == 4 || c == 5) {
            pm_surface sf;
            pm_scene_surface(&s, 0, 0.25f, 0.35f, &sf);
            printf("%-36s ns = (%+.4f %+.4f %+.4f), %.2f degrees from the normal\n", cases[c].what, sf.ns.x, sf.ns.y,
                   sf.ns.z, angle_degrees(sf.ns, v3(0, 0, 1)));
        }
        pm_scene_free(&s);
    }
}

/* A texel pointing (nearly) along the surface, or under it, is pulled back to exactly
 * PM_NORMAL_MAP_MIN_COS above the plane with its azimuth; and no texel, scale or bent vertex normal
 * ever gives dot(ns, ng) below it. */
static void test_guard(void) {
    static const uint8_t grazing[4] = {255, 128, 128, 255}, under[4] = {255, 128, 0, 255};
    for (int k = 0; k < 2; k++) {
        pm_scene s;
        texel_quad(&s, k ? under : grazing, 1.f, 1.f);
        pm_scene_finalize(&s, false, NULL);
        pm_surface sf;
        pm_scene_surface(&s, 0, 0.3f, 0.3f, &sf);
        CHECK(fabsf(v3_dot(sf.ns, sf.ng) - PM_NORMAL_MAP_MIN_COS) < 1e-5f && sf.ns.x > 0.99f && fabsf(v3_length(sf.ns) - 1.f) < 1e-5f,
              "%s texel: ns (%g %g %g) must sit at cos %g above the plane toward +T", k ? "under-surface" : "grazing",
              sf.ns.x, sf.ns.y, sf.ns.z, PM_NORMAL_MAP_MIN_COS);
        pm_scene_free(&s);
    }
    pm_rng rng = pm_rng_for(7, 0, 0);
    float worst = 1.f;
    for (int trial = 0; trial < 2000; trial++) {
        uint8_t texel[4] = {(uint8_t)(pm_rng_float(&rng) * 256.f), (uint8_t)(pm_rng_float(&rng) * 256.f),
                            (uint8_t)(pm_rng_float(&rng) * 256.f), 255};
        pm_scene s;
        texel_quad(&s, texel, 4.f * pm_rng_float(&rng), pm_rng_float(&rng) < 0.5f ? -1.f : 1.f);
        /* vertex normals bent up to ~70 degrees off the face, tangents anywhere */
        for (uint32_t v = 0; v < s.vertex_count; v++) {
            s.normals[v] = v3_normalize(v3(2.f * pm_rng_float(&rng) - 1.f, 2.f * pm_rng_float(&rng) - 1.f, 0.4f));
            for (int k = 0; k < 3; k++) s.tangents[4 * v + k] = 2.f * pm_rng_float(&rng) - 1.f;
        }
        pm_scene_finalize(&s, false, NULL);
        for (uint32_t tri = 0; tri < 2; tri++) {
            pm_surface sf;
            pm_scene_surface(&s, tri, pm_rng_float(&rng) * 0.5f, pm_rng_float(&rng) * 0.5f, &sf);
            worst = pm_minf(worst, v3_dot(sf.ns, sf.ng));
            CHECK(isfinite(sf.ns.x) && fabsf(v3_length(sf.ns) - 1.f) < 1e-4f, "ns not unit: (%g %g %g)", sf.ns.x, sf.ns.y, sf.ns.z);
        }
        pm_scene_free(&s);
    }
    CHECK(worst >= PM_NORMAL_MAP_MIN_COS - 1e-5f, "smallest dot(ns, ng) over random texels %g < %g", worst, PM_NORMAL_MAP_MIN_COS);
    printf("guard: smallest dot(ns, ng) over 4000 random normal-mapped points %.5f (floor %.2f)\n", worst, PM_NORMAL_MAP_MIN_COS);
}

/* White furnace: a closed box whose walls emit Le and reflect rho, L = Le / (1 - rho) everywhere.
 * With a bumpy map on every wall the shading normals tilt; the integrators drop directions under
 * the geometric plane, so the answer can only drop, never rise. Returns the image mean. */
static double furnace_mean(bool bumpy, int iterations) {
    enum { W = 32, H = 32, T = 16 };
    const float rho = 0.5f, le = 0.5f;
    pm_scene s;
    memset(&s, 0, sizeof s);
    uint32_t m = sb_material(&s, v3s(rho), 0, 1, 0, v3s(le), false);
    sb_box(&s, v3(-1, -1, -1), v3(1, 1, 1), m, true);
    if (bumpy) {
        add_uvs_and_tangents(&s, 1.f);
        /* texels tilted up to 60 degrees in every direction */
        uint8_t rgba[4 * T * T];
        pm_rng rng = pm_rng_for(3, 0, 0);
        for (int i = 0; i < T * T; i++) {
            float theta = 60.f * PM_PI / 180.f * sqrtf(pm_rng_float(&rng)), phi = 2.f * PM_PI * pm_rng_float(&rng);
            vec3 n = v3(sinf(theta) * cosf(phi), sinf(theta) * sinf(phi), cosf(theta));
            rgba[4 * i] = (uint8_t)lroundf((n.x * 0.5f + 0.5f) * 255.f);
            rgba[4 * i + 1] = (uint8_t)lroundf((n.y * 0.5f + 0.5f) * 255.f);
            rgba[4 * i + 2] = (uint8_t)lroundf((n.z * 0.5f + 0.5f) * 255.f);
            rgba[4 * i + 3] = 255;
        }
        s.materials[m].normal_texture = add_texture(&s, T, T, rgba);
        s.materials[m].normal_scale = 1.f;
    }
    pm_accel *a = sb_finish(&s);
    if (bumpy) {
        /* the map really bends the shading normals: their mean tilt over the walls */
        double tilt = 0.0;
        pm_rng rng = pm_rng_for(5, 0, 0);
        for (int i = 0; i < 1000; i++) {
            pm_surface sf;
            uint32_t tri = (uint32_t)(pm_rng_float(&rng) * s.triangle_count) % s.triangle_count;
            pm_scene_surface(&s, tri, 0.5f * pm_rng_float(&rng), 0.5f * pm_rng_float(&rng), &sf);
            tilt += angle_degrees(sf.ns, sf.ng) / 1000.0;
        }
        printf("bumpy furnace: mean tilt of ns from ng %.1f degrees\n", tilt);
        CHECK(tilt > 20.0, "the bumpy map must tilt the shading normals (mean %.1f degrees)", tilt);
    }
    pm_camera cam = sb_camera(v3(0, 0, 0.5f), v3(0.3f, -0.2f, -1), v3(0, 1, 0), 60.f);
    float *total = malloc(sizeof(float) * 3 * W * H);
    if (!total) abort();
    pm_progressive_settings ps = default_settings(W, H);
    session r;
    double got = 0.0;
    if (start(&r, &s, a, &cam, W, H, &ps)) {
        iterate(&r, iterations);
        pm_film_resolve_total(r.film, total);
        got = mean_of(total, 3 * W * H);
        stop(&r);
    }
    free(total);
    pm_accel_destroy(a);
    pm_scene_free(&s);
    return got;
}

static void test_furnace(void) {
    const double want = 0.5 / (1.0 - 0.5), tolerance = 0.02; /* the flat furnace's noise at this size is well under 1% */
    const int iterations = 96;
    double flat = furnace_mean(false, iterations), bumpy = furnace_mean(true, iterations);
    printf("furnace rho 0.5 Le 0.5 (answer %.3f), %d iterations at 32x32: flat walls %.4f (%+.2f%%), bumpy normal map %.4f (%+.2f%%)\n",
           want, iterations, flat, 100.0 * (flat / want - 1.0), bumpy, 100.0 * (bumpy / want - 1.0));
    CHECK(fabs(flat - want) < tolerance * want, "flat furnace %.4f, want %.4f within %.0f%%", flat, want, 100 * tolerance);
    CHECK(bumpy <= want * (1.0 + tolerance), "the normal map brightened the furnace: %.4f > %.4f + %.0f%%", bumpy, want,
          100 * tolerance);
    CHECK(bumpy >= 0.8 * want, "the normal map darkened the furnace too much: %.4f < 80%% of %.4f", bumpy, want);
}

int main(void) {
    test_tilts();
    test_guard();
    test_furnace();
    return pm_test_done("test_normalmap");
}

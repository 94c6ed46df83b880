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

/* ns at (x, y) of texel_quad's unit quad (triangles (0,0)(1,0)(1,1) and (0,0)(1,1)(0,1)). */
static vec3 quad_normal_at(const pm_scene *s, float x, float y) {
    pm_surface sf;
    if (y <= x) pm_scene_surface(s, 0, x - y, y, &sf);
    else pm_scene_surface(s, 1, x, y - x, &sf);
    return sf.ns;
}

/* The angle between unit vectors from their chord: acos loses everything under ~0.03 degrees in float. */
static double chord_degrees(vec3 a, vec3 b) { return 2.0 * asin(fmin(1.0, 0.5 * v3_length(v3_sub(a, b)))) * 180.0 / PM_PI; }

static uint8_t slope_byte(float x) { return (uint8_t)lroundf((x + 1.f) * 127.5f); }

/* KHR_texture_transform on a normal texture: a 2 x 2 picture of tilted texels turned (or mirrored)
 * as a picture, with the UV transform that puts every point of it back where it was, must give
 * the same world normals as the picture read plainly. The turned picture's texels are turned
 * too (they are vectors along the image's right and up), so a renderer that does not turn the
 * tangent frame reads them in the wrong directions. a[] is the UV map u' = A u (entries -1, 0, 1). */
static void test_rotated_transform(void) {
    static const uint8_t picture[2][2][4] = {{{218, 128, 218, 255}, {128, 200, 230, 255}},
                                             {{60, 90, 220, 255}, {170, 40, 210, 255}}};
    static const struct { float a[4]; const char *what; } cases[] = {
        {{0, 1, -1, 0}, "rotation +90 degrees"},
        {{-1, 0, 0, -1}, "rotation 180 degrees"},
        {{0, -1, 1, 0}, "rotation -90 degrees"},
        {{-1, 0, 0, 1}, "scale (-1, 1): mirrored"},
        {{0, -1, -1, 0}, "rotation +90 degrees, scale (-1, 1)"},
    };
    pm_scene plain;
    texel_quad(&plain, picture[0][0], 1.f, 1.f);
    free(plain.textures[0].rgba);
    plain.textures[0].rgba = malloc(16);
    if (!plain.textures[0].rgba) abort();
    memcpy(plain.textures[0].rgba, picture, 16);
    plain.textures[0].width = plain.textures[0].height = 2;
    pm_scene_finalize(&plain, false, NULL);
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        const float *a = cases[c].a;
        /* the turned picture: texel (row, col) at u' holds the plain texel at u = A^-1 u' = A^T u',
         * its slope (x, y) along (right, up) = (+u, -v) turned by F A F, F = diag(1, -1) */
        uint8_t turned[2][2][4];
        for (int row = 0; row < 2; row++)
            for (int col = 0; col < 2; col++) {
                float u1 = (col + 0.5f) / 2.f, v1 = (row + 0.5f) / 2.f;
                float u = a[0] * u1 + a[2] * v1, v = a[1] * u1 + a[3] * v1;
                u -= floorf(u);
                v -= floorf(v);
                const uint8_t *src = picture[(int)(v * 2.f)][(int)(u * 2.f)];
                float x = src[0] / 127.5f - 1.f, y = src[1] / 127.5f - 1.f;
                turned[row][col][0] = slope_byte(a[0] * x - a[1] * y);
                turned[row][col][1] = slope_byte(-a[2] * x + a[3] * y);
                turned[row][col][2] = src[2];
                turned[row][col][3] = 255;
            }
        pm_scene s;
        texel_quad(&s, picture[0][0], 1.f, 1.f);
        memcpy(s.textures[0].rgba = realloc(s.textures[0].rgba, 16), turned, 16);
        s.textures[0].width = s.textures[0].height = 2;
        pm_uv_transform *t = &s.materials[0].normal_transform;
        t->transformed = true;
        t->m[0] = a[0];
        t->m[1] = a[1];
        t->m[3] = a[2];
        t->m[4] = a[3];
        pm_scene_finalize(&s, false, NULL);
        double worst = 0.0, naive = 0.0;
        pm_rng rng = pm_rng_for(11, (uint32_t)c, 0);
        for (int i = 0; i < 64; i++) {
            float x = 0.02f + 0.96f * pm_rng_float(&rng), y = 0.02f + 0.96f * pm_rng_float(&rng);
            vec3 want = quad_normal_at(&plain, x, y), got = quad_normal_at(&s, x, y);
            worst = fmax(worst, chord_degrees(want, got));
            /* what reading the turned texel in the untransformed frame would give */
            pm_uv_transform saved = *t;
            t->transformed = false;
            float u = x, v = 1.f - y, u1 = a[0] * u + a[1] * v, v1 = a[2] * u + a[3] * v;
            vec3 untransformed_frame = quad_normal_at(&s, u1 - floorf(u1), 1.f - (v1 - floorf(v1)));
            *t = saved;
            naive = fmax(naive, angle_degrees(want, untransformed_frame));
        }
        printf("normal texture %-36s: worst angle to the plain picture's normal %.4f degrees (frame not turned: %.1f)\n",
               cases[c].what, worst, naive);
        CHECK(worst < 0.001, "%s: world normals differ from the plain picture's by up to %.3f degrees", cases[c].what, worst);
        CHECK(naive > 10.0, "%s: the case must tell a turned frame from an unturned one (%.1f degrees)", cases[c].what, naive);
        pm_scene_free(&s);
    }
    pm_scene_free(&plain);

    /* any angle, with a uniform tiling scale: a flat-topped slope turned by 30 degrees, within
     * the texel bytes' rounding (1/255 of a slope is about 0.3 degrees here) */
    const float angle = 30.f * PM_PI / 180.f, tiling = 3.f, slope_x = 0.6f, slope_y = -0.3f;
    const uint8_t plain_texel[4] = {slope_byte(slope_x), slope_byte(slope_y), 200, 255};
    float cs = cosf(angle), sn = sinf(angle);
    /* F A F with A = R(angle) S: the slope as the transformed texture stores it, over the tiling */
    float tx = cs * slope_x - sn * slope_y, ty = sn * slope_x + cs * slope_y;
    const uint8_t turned_texel[4] = {slope_byte(tx), slope_byte(ty), 200, 255};
    pm_scene a, b;
    texel_quad(&a, plain_texel, 1.f, 1.f);
    texel_quad(&b, turned_texel, 1.f, 1.f);
    pm_uv_transform *t = &b.materials[0].normal_transform;
    *t = (pm_uv_transform){true, {cs * tiling, sn * tiling, 0.25f, -sn * tiling, cs * tiling, 0.5f}};
    pm_scene_finalize(&a, false, NULL);
    pm_scene_finalize(&b, false, NULL);
    double err = chord_degrees(quad_normal_at(&a, 0.3f, 0.6f), quad_normal_at(&b, 0.3f, 0.6f));
    printf("normal texture rotated 30 degrees, tiled x3: %.3f degrees from the plain texel's normal\n", err);
    CHECK(err < 0.5, "30-degree rotation: %.3f degrees from the plain normal", err);
    pm_scene_free(&a);
    pm_scene_free(&b);
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
    test_rotated_transform();
    test_furnace();
    return pm_test_done("test_normalmap");
}

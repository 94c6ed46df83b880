/* test_samplers.c: a glTF sampler's magFilter and minFilter: NEAREST gives exact texels, LINEAR blends, and each minFilter reads the mip levels it names; against texel arithmetic done here in double.
 *
 * Textures are read as data (bytes / 255) so the expected values need no sRGB table; one sRGB
 * check shows NEAREST never blends an encoded colour either. Points lie off texel centres and off
 * texel edges, where NEAREST and LINEAR differ.
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "memory.h"
#include "scene.h"
#include "scene_builder.h"
#include "testing.h"

/* A checker of one-texel squares, red channel 255 where x + y is even, a ramp in green, alpha
 * 255 or 0 with red. */
static void checker(pm_texture *t) {
    for (int y = 0; y < t->height; y++)
        for (int x = 0; x < t->width; x++) {
            uint8_t *p = t->rgba + 4 * ((size_t)y * t->width + x);
            p[0] = (x + y) & 1 ? 0 : 255;
            p[1] = (uint8_t)(40 * x + 10 * y);
            p[2] = 7;
            p[3] = p[0];
        }
}

/* REPEAT index of coordinate c over n texels, as glTF's samplers fold it. */
static int repeat_index(double c, int n) {
    long i = (long)floor(c * n);
    return (int)(((i % n) + n) % n);
}

/* The red and green channels of an image (w x h, 4 bytes a texel) at (u, v), REPEAT: NEAREST is the
 * texel the point lies in, LINEAR the four around it weighted by distance to their centres. */
static void expected(const uint8_t *rgba, int w, int h, double u, double v, bool nearest, double out[2]) {
    if (nearest) {
        const uint8_t *p = rgba + 4 * ((size_t)repeat_index(v, h) * w + repeat_index(u, w));
        out[0] = p[0] / 255.0;
        out[1] = p[1] / 255.0;
        return;
    }
    double x = u * w - 0.5, y = v * h - 0.5, fx = x - floor(x), fy = y - floor(y);
    int x0 = (int)floor(x), y0 = (int)floor(y);
    out[0] = out[1] = 0.0;
    for (int dy = 0; dy < 2; dy++)
        for (int dx = 0; dx < 2; dx++) {
            int xi = ((x0 + dx) % w + w) % w, yi = ((y0 + dy) % h + h) % h;
            double weight = (dx ? fx : 1.0 - fx) * (dy ? fy : 1.0 - fy);
            const uint8_t *p = rgba + 4 * ((size_t)yi * w + xi);
            out[0] += weight * p[0] / 255.0;
            out[1] += weight * p[1] / 255.0;
        }
}

/* Magnification: the 2 x 2 checker over many off-centre points, NEAREST exactly the texel (colour,
 * sRGB colour and alpha), LINEAR the blend; both through the plain lookup and a footprint under a texel. */
static void test_magnification(void) {
    double worst[2] = {0, 0}, blend_seen = 0.0;
    for (int nearest = 0; nearest < 2; nearest++) {
        pm_texture t = sb_texture(2, 2, PM_WRAP_REPEAT);
        checker(&t);
        t.mag_nearest = nearest;
        for (int i = 0; i < 17; i++)
            for (int j = 0; j < 13; j++) {
                double u = -1.0 + 3.0 * (i + 0.31) / 17.0, v = -0.5 + 2.0 * (j + 0.57) / 13.0;
                double want[2];
                expected(t.rgba, 2, 2, u, v, nearest, want);
                vec3 got = pm_texture_lookup_data(&t, (float)u, (float)v);
                vec3 small = pm_texture_filtered(&t, (float)u, (float)v, 0.7f, false);
                float alpha = pm_texture_alpha(&t, (float)u, (float)v);
                double err = fmax(fmax(fabs(got.x - want[0]), fabs(got.y - want[1])),
                                  fmax(fabs(small.x - want[0]), fabs(alpha - want[0])));
                worst[nearest] = fmax(worst[nearest], err);
                if (!nearest) blend_seen = fmax(blend_seen, fmin(want[0], 1.0 - want[0]));
                if (nearest) {
                    vec3 c = pm_texture_lookup(&t, (float)u, (float)v);
                    CHECK(c.x == (want[0] > 0.5 ? 1.f : 0.f) && c.z == pm_srgb_to_linear(7.f / 255.f),
                          "NEAREST sRGB at (%g, %g): (%g, %g), want the texel's %g", u, v, c.x, c.z, want[0]);
                }
            }
        free(t.rgba);
    }
    printf("2x2 checker magnified: NEAREST worst error %.2g (exact texels), LINEAR worst error %.2g, LINEAR blends up to %.3f of the way\n",
           worst[1], worst[0], blend_seen);
    /* exact up to bytes / 255 in float */
    CHECK(worst[1] < 1e-6, "NEAREST must give the texel's value exactly (worst error %g)", worst[1]);
    CHECK(worst[0] < 1e-5, "LINEAR must give the bilinear blend (worst error %g)", worst[0]);
    CHECK(blend_seen > 0.3, "the LINEAR points must fall between texels (largest blend %g)", blend_seen);
}

/* Minification of an 8 x 8 checker (level 1 is 4 x 4 grey): each minFilter against the level it
 * names, read here from the texture's own levels with the texel filter it names. */
static void test_minification(void) {
    static const struct { int filter; const char *name; } filters[] = {
        {PM_MIN_DEFAULT, "default (LINEAR_MIPMAP_LINEAR)"},
        {PM_MIN_NEAREST, "NEAREST"},
        {PM_MIN_LINEAR, "LINEAR"},
        {PM_MIN_NEAREST_MIPMAP_NEAREST, "NEAREST_MIPMAP_NEAREST"},
        {PM_MIN_LINEAR_MIPMAP_NEAREST, "LINEAR_MIPMAP_NEAREST"},
        {PM_MIN_NEAREST_MIPMAP_LINEAR, "NEAREST_MIPMAP_LINEAR"},
        {PM_MIN_LINEAR_MIPMAP_LINEAR, "LINEAR_MIPMAP_LINEAR"},
    };
    const float footprints[3] = {1.7f, 2.9f, 5.3f}; /* log2: 0.77, 1.54, 2.41 */
    for (size_t f = 0; f < sizeof filters / sizeof filters[0]; f++) {
        pm_texture t = sb_texture(8, 8, PM_WRAP_REPEAT);
        checker(&t);
        uint64_t admitted = 0;
        CHECK(pm_texture_build_levels(&t, false, &admitted) && t.level_count == 4, "levels for the 8 x 8 checker");
        t.min_filter = filters[f].filter;
        int min = filters[f].filter;
        bool nearest_texel = min == PM_MIN_NEAREST || min == PM_MIN_NEAREST_MIPMAP_NEAREST || min == PM_MIN_NEAREST_MIPMAP_LINEAR;
        double worst = 0.0;
        for (int k = 0; k < 3; k++)
            for (int i = 0; i < 9; i++) {
                double u = (i + 0.23) / 9.0, v = (i * 5 % 9 + 0.61) / 9.0, level = log2((double)footprints[k]);
                /* the levels the filter reads and their weights */
                int lo = 0, hi = 0;
                double f_hi = 0.0;
                if (min == PM_MIN_NEAREST_MIPMAP_NEAREST || min == PM_MIN_LINEAR_MIPMAP_NEAREST) {
                    lo = hi = (int)floor(level + 0.5);
                } else if (min != PM_MIN_NEAREST && min != PM_MIN_LINEAR) {
                    lo = (int)floor(level);
                    hi = lo + 1;
                    f_hi = level - lo;
                }
                double want[2] = {0, 0};
                for (int side = 0; side < 2; side++) {
                    int l = side ? hi : lo;
                    double weight = side ? f_hi : 1.0 - f_hi, part[2];
                    const uint8_t *img = l == 0 ? t.rgba : t.levels + t.level_offset[l];
                    int w = l == 0 ? t.width : t.level_width[l], h = l == 0 ? t.height : t.level_height[l];
                    expected(img, w, h, u, v, nearest_texel, part);
                    want[0] += weight * part[0];
                    want[1] += weight * part[1];
                }
                vec3 got = pm_texture_filtered(&t, (float)u, (float)v, footprints[k], false);
                worst = fmax(worst, fmax(fabs(got.x - want[0]), fabs(got.y - want[1])));
            }
        printf("8x8 checker minified, minFilter %-30s: worst error against its levels %.2g\n", filters[f].name, worst);
        CHECK(worst < 1e-5, "minFilter %s: worst error %g", filters[f].name, worst);
        /* NEAREST without mipmaps aliases: a point inside a white texel stays exactly white */
        if (min == PM_MIN_NEAREST) {
            vec3 c = pm_texture_filtered(&t, 0.5f / 8.f + 0.01f, 0.5f / 8.f + 0.02f, 5.3f, false);
            CHECK(c.x == 1.f, "minFilter NEAREST reads level 0's texel (%g)", c.x);
        }
        if (min == PM_MIN_DEFAULT) {
            vec3 c = pm_texture_filtered(&t, 0.5f / 8.f + 0.01f, 0.5f / 8.f + 0.02f, 2.f, false);
            CHECK(fabsf(c.x - 0.5f) < 0.01f, "the default filter reads level 1's grey at a footprint of 2 texels (%g)", c.x);
        }
        pm_memory_release(admitted);
        free(t.rgba);
        free(t.levels);
    }
}

/* A material's base colour through pm_scene_surface: NEAREST reaches the hit, not only the lookup. */
static void test_surface(void) {
    pm_scene s;
    memset(&s, 0, sizeof s);
    uint32_t m = sb_lambert(&s, v3s(1.f));
    sb_quad(&s, v3(0, 0, 0), v3(1, 0, 0), v3(1, 1, 0), v3(0, 1, 0), m);
    s.uvs = calloc(2 * (size_t)s.vertex_count, sizeof(float));
    s.textures = calloc(1, sizeof *s.textures);
    if (!s.uvs || !s.textures) abort();
    for (uint32_t i = 0; i < s.vertex_count; i++) {
        s.uvs[2 * i] = s.positions[i].x;
        s.uvs[2 * i + 1] = s.positions[i].y;
    }
    s.textures[0] = sb_texture(2, 2, PM_WRAP_REPEAT);
    checker(&s.textures[0]);
    s.textures[0].mag_nearest = true;
    s.texture_count = 1;
    s.materials[m].base_color_texture = 0;
    s.materials[m].alpha_mode = PM_ALPHA_MASK;
    s.materials[m].alpha_cutoff = 0.5f;
    pm_scene_finalize(&s, false, NULL);
    pm_surface sf;
    pm_scene_surface(&s, 0, 0.4f, 0.1f, &sf); /* (x, y) = (0.5, 0.1): texel (1, 0), black, alpha 0 */
    float black = sf.kd.x;
    pm_scene_surface(&s, 0, 0.2f, 0.1f, &sf); /* (0.3, 0.1): texel (0, 0), white */
    float white = sf.kd.x;
    float cut = pm_scene_alpha_at(&s, 0, 0.4f, 0.1f), kept = pm_scene_alpha_at(&s, 0, 0.2f, 0.1f);
    printf("surface with a NEAREST checker: albedo %g and %g, coverage %g and %g\n", white, black, kept, cut);
    CHECK(white == 1.f && black == 0.f && kept == 1.f && cut == 0.f, "NEAREST at the surface: %g %g %g %g", white, black, kept, cut);
    pm_scene_free(&s);
}

int main(void) {
    test_magnification();
    test_minification();
    test_surface();
    return pm_test_done("test_samplers");
}

/* test_texture_footprint.c: mip levels and footprint lookups: a checker seen over many texels resolves to its mean, footprint 0 is the level-0 lookup bit for bit, every level keeps the base level's mean, cut-outs keep their coverage.
 *
 * A one-texel black and white checker has mean 0.5 (linear, either encoding: sRGB 255 and 0
 * decode to 1 and 0). Read at one point over a footprint of 64 texels it must give that mean
 * within what one byte of the level's encoding can hold (the re-encoding rounds to the nearest
 * byte: half a step, at most 0.0045 for sRGB near 0.5, 0.002 for data); read at level 0 the same
 * points give 0 or 1 (aliasing), which the test checks too, so the filtered answer is not level
 * 0's by chance. Each level of a random texture keeps the base level's mean to within half a byte
 * step per level built, plus the sRGB encoder's 1/65536 (box weights that sum to one texel per
 * source texel, whatever the size).
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "accel.h"
#include "memory.h"
#include "rng.h"
#include "scene.h"
#include "scene_builder.h"
#include "testing.h"

static void checker(pm_texture *t) {
    for (int y = 0; y < t->height; y++)
        for (int x = 0; x < t->width; x++) {
            uint8_t v = (x + y) & 1 ? 255 : 0, *p = t->rgba + 4 * ((size_t)y * t->width + x);
            p[0] = p[1] = p[2] = v;
            p[3] = 255;
        }
}

/* The mean of channel 0 of one level in linear values. */
static double level_mean(const pm_texture *t, int k, bool srgb) {
    const uint8_t *p = k == 0 ? t->rgba : t->levels + t->level_offset[k];
    size_t n = (size_t)t->level_width[k] * t->level_height[k];
    double sum = 0.0;
    for (size_t i = 0; i < n; i++) sum += srgb ? pm_srgb_to_linear(p[4 * i] / 255.f) : p[4 * i] / 255.0;
    return sum / (double)n;
}

/* The largest gap between two neighbouring sRGB bytes' linear values: what one byte step can be. */
static double srgb_step(void) {
    double worst = 0.0;
    for (int i = 0; i < 255; i++) worst = fmax(worst, pm_srgb_to_linear((i + 1) / 255.f) - pm_srgb_to_linear(i / 255.f));
    return worst;
}

static void checker_resolves_to_mean(void) {
    for (int srgb = 0; srgb < 2; srgb++) {
        pm_texture t = sb_texture(256, 256, PM_WRAP_REPEAT);
        checker(&t);
        uint64_t admitted = 0;
        CHECK(pm_texture_build_levels(&t, srgb, &admitted), "levels built");
        CHECK(t.level_count == 9, "256 x 256 has 9 levels, got %d", t.level_count);
        CHECK(admitted == 4 * (128 * 128 + 64 * 64 + 32 * 32 + 16 * 16 + 8 * 8 + 4 * 4 + 2 * 2 + 1), "admitted %llu bytes",
              (unsigned long long)admitted);
        pm_rng rng = pm_rng_for(3, srgb, 0);
        double worst = 0.0, level0_spread = 0.0;
        for (int i = 0; i < 2000; i++) {
            /* texel centres, where a level-0 lookup reads one texel alone */
            float u = ((float)(pm_rng_u32(&rng) % 256) + 0.5f) / 256.f, v = ((float)(pm_rng_u32(&rng) % 256) + 0.5f) / 256.f;
            float texels = 64.f + 100.f * pm_rng_float(&rng); /* between levels 6 and 7.4: trilinear */
            vec3 c = pm_texture_filtered(&t, u, v, texels, srgb);
            worst = fmax(worst, fmax(fabs(c.x - 0.5), fmax(fabs(c.y - 0.5), fabs(c.z - 0.5))));
            vec3 point = pm_texture_filtered(&t, u, v, 0.f, srgb);
            level0_spread = fmax(level0_spread, fabs(point.x - 0.5));
        }
        double tolerance = srgb ? 0.0045 : 0.002;
        printf("%s checker over 64-164 texels: %.5f from 0.5; level 0: %.3f\n", srgb ? "sRGB" : "data", worst, level0_spread);
        CHECK(worst <= tolerance, "%s checker over 64-164 texels: %.5f from 0.5 (tolerance %.4f)", srgb ? "sRGB" : "data",
              worst, tolerance);
        CHECK(level0_spread > 0.49, "level 0 at texel centres aliases to 0 or 1: %.3f from the mean", level0_spread);
        /* a footprint past the coarsest level reads the 1 x 1 level */
        vec3 far = pm_texture_filtered(&t, 0.3f, 0.7f, 1e9f, srgb);
        CHECK(fabs(far.x - 0.5) <= tolerance, "an enormous footprint: %.5f", far.x);
        free(t.rgba);
        free(t.levels);
        pm_memory_release(admitted);
    }
}

/* Footprints of at most a texel read level 0: the same bits as pm_texture_lookup(_data). */
static void small_footprint_is_level_zero(void) {
    pm_texture t = sb_texture(37, 23, PM_WRAP_MIRROR);
    pm_rng rng = pm_rng_for(4, 0, 0);
    for (int i = 0; i < 4 * 37 * 23; i++) t.rgba[i] = (uint8_t)(pm_rng_u32(&rng) & 255);
    uint64_t admitted = 0;
    CHECK(pm_texture_build_levels(&t, true, &admitted), "levels built");
    int differ = 0;
    for (int i = 0; i < 5000; i++) {
        float u = (pm_rng_float(&rng) - 0.5f) * 6.f, v = (pm_rng_float(&rng) - 0.5f) * 6.f;
        float texels = (i % 3) == 0 ? 0.f : ((i % 3) == 1 ? 1.f : pm_rng_float(&rng));
        vec3 a = pm_texture_filtered(&t, u, v, texels, true), b = pm_texture_lookup(&t, u, v);
        vec3 c = pm_texture_filtered(&t, u, v, texels, false), d = pm_texture_lookup_data(&t, u, v);
        differ += memcmp(&a, &b, sizeof a) != 0 || memcmp(&c, &d, sizeof c) != 0;
    }
    CHECK(differ == 0, "%d lookups with a footprint of at most one texel differ from level 0", differ);
    /* and a footprint of two texels does not read level 0 alone: the test can tell them apart */
    int same = 0;
    for (int i = 0; i < 200; i++) {
        float u = pm_rng_float(&rng), v = pm_rng_float(&rng);
        vec3 a = pm_texture_filtered(&t, u, v, 2.f, false), b = pm_texture_lookup_data(&t, u, v);
        same += memcmp(&a, &b, sizeof a) == 0;
    }
    CHECK(same < 20, "%d of 200 two-texel lookups equal level 0", same);
    free(t.rgba);
    free(t.levels);
    pm_memory_release(admitted);
}

static void levels_keep_the_mean(void) {
    const int sizes[][2] = {{256, 256}, {37, 23}, {1, 5}, {255, 2}, {3, 3}, {64, 1}};
    double step = srgb_step();
    pm_rng rng = pm_rng_for(5, 0, 0);
    for (size_t si = 0; si < sizeof sizes / sizeof *sizes; si++)
        for (int srgb = 0; srgb < 2; srgb++) {
            pm_texture t = sb_texture(sizes[si][0], sizes[si][1], PM_WRAP_REPEAT);
            size_t n = (size_t)t.width * t.height;
            for (size_t i = 0; i < n; i++) {
                t.rgba[4 * i] = t.rgba[4 * i + 1] = t.rgba[4 * i + 2] = (uint8_t)(pm_rng_u32(&rng) & 255);
                t.rgba[4 * i + 3] = 255;
            }
            uint64_t admitted = 0;
            CHECK(pm_texture_build_levels(&t, srgb, &admitted), "levels built");
            int expect = 1;
            for (int w = t.width, h = t.height; w > 1 || h > 1; w = w > 1 ? w / 2 : 1, h = h > 1 ? h / 2 : 1) expect++;
            CHECK(t.level_count == expect, "%dx%d: %d levels, expected %d", t.width, t.height, t.level_count, expect);
            CHECK(t.level_width[t.level_count - 1] == 1 && t.level_height[t.level_count - 1] == 1, "%dx%d ends at 1 x 1",
                  t.width, t.height);
            double base = level_mean(&t, 0, srgb), half_step = srgb ? 0.5 * step : 0.5 / 255.0;
            for (int k = 1; k < t.level_count; k++) {
                double mean = level_mean(&t, k, srgb);
                CHECK(fabs(mean - base) <= k * (half_step + 1.0 / 65536.0), "%dx%d %s level %d mean %.5f, base %.5f", t.width, t.height,
                      srgb ? "sRGB" : "data", k, mean, base);
            }
            free(t.rgba);
            free(t.levels);
            pm_memory_release(admitted);
        }
}

/* A MASK cut-out: a disc of opaque white texels on transparent black ones. Coverage (the alpha
 * test) reads level 0 before and after the levels are built, at every point; a distant look at
 * the colour stays white (the cut-out texels' black does not bleed in), where a plain average
 * would darken it to the disc's share. */
static void cutouts_keep_coverage(void) {
    pm_scene s;
    memset(&s, 0, sizeof s);
    uint32_t m = sb_lambert(&s, v3s(1.f));
    s.materials[m].alpha_mode = PM_ALPHA_MASK;
    s.materials[m].alpha = 1.f;
    s.materials[m].alpha_cutoff = 0.5f;
    s.textures = calloc(1, sizeof *s.textures);
    s.textures[0] = sb_texture(64, 64, PM_WRAP_CLAMP);
    s.texture_count = 1;
    s.materials[m].base_color_texture = 0;
    int opaque = 0;
    for (int y = 0; y < 64; y++)
        for (int x = 0; x < 64; x++) {
            bool in = (x - 31.5) * (x - 31.5) + (y - 31.5) * (y - 31.5) < 20.0 * 20.0;
            uint8_t *p = s.textures[0].rgba + 4 * (y * 64 + x);
            p[0] = p[1] = p[2] = in ? 255 : 0;
            p[3] = in ? 255 : 0;
            opaque += in;
        }
    /* a 2 x 2 square at z = 0, uv across it: 64 texels over 2 units */
    sb_quad(&s, v3(-1, -1, 0), v3(1, -1, 0), v3(1, 1, 0), v3(-1, 1, 0), m);
    s.uvs = malloc(2 * sizeof(float) * s.vertex_count);
    for (uint32_t i = 0; i < s.vertex_count; i++) {
        s.uvs[2 * i] = 0.5f * (s.positions[i].x + 1.f);
        s.uvs[2 * i + 1] = 0.5f * (1.f - s.positions[i].y);
    }
    enum { N = 200 };
    static float before[2][N][N];
    for (int i = 0; i < N; i++)
        for (int j = 0; j < N; j++)
            for (uint32_t t = 0; t < 2; t++) before[t][i][j] = pm_scene_alpha_at(&s, t, (i + 0.5f) / N * 0.5f, (j + 0.5f) / N * 0.5f);
    pm_accel *a = sb_finish(&s);
    CHECK(a != NULL, "scene built");
    CHECK(s.textures[0].level_count == 7 && s.uv_density, "finalize built 7 levels (%d) and the UV densities",
          s.textures[0].level_count);
    if (s.uv_density) CHECK_NEAR(s.uv_density[0], 0.5, 1e-6, 0, "UV density: sqrt(1 / 4)");
    int changed = 0, covered = 0;
    for (int i = 0; i < N; i++)
        for (int j = 0; j < N; j++)
            for (uint32_t t = 0; t < 2; t++) {
                float b1 = (i + 0.5f) / N * 0.5f, b2 = (j + 0.5f) / N * 0.5f, alpha = pm_scene_alpha_at(&s, t, b1, b2);
                changed += memcmp(&alpha, &before[t][i][j], sizeof alpha) != 0;
                covered += alpha >= 0.5f;
            }
    printf("cut-out: %d of %d points covered\n", covered, 2 * N * N);
    CHECK(changed == 0, "%d alpha tests changed with the levels built", changed);
    CHECK(covered > 0 && covered < 2 * N * N, "some points cut out, some not (%d)", covered);
    /* the colour at the disc's centre seen over the whole texture (level 6, 1 x 1): white */
    pm_surface sf;
    pm_scene_surface_footprint(&s, 0, 0.25f, 0.25f, 4.f, v3(0, 0, -1), &sf);
    CHECK(fabs(sf.kd.x - 1.0) <= 0.005, "cut-out texels do not darken a distant look: %.4f (disc %.3f of the texels)",
          sf.kd.x, opaque / 4096.0);
    /* and at footprint 0 the surface is the level-0 one, bit for bit */
    pm_surface plain, zero;
    pm_scene_surface(&s, 0, 0.2f, 0.3f, &plain);
    pm_scene_surface_footprint(&s, 0, 0.2f, 0.3f, 0.f, v3(0, 0, -1), &zero);
    CHECK(memcmp(&plain.kd, &zero.kd, sizeof plain.kd) == 0, "width 0 is pm_scene_surface");
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

/* Through the scene: a 2 x 2 checker square (256 texels across) seen along its normal with a
 * cone 0.5 wide covers 64 texels, so kd is the mean; seen at grazing incidence (cos 1/16) the
 * footprint is 4 times wider, and still the mean. */
static void scene_footprint(void) {
    pm_scene s;
    memset(&s, 0, sizeof s);
    uint32_t m = sb_lambert(&s, v3s(1.f));
    s.textures = calloc(1, sizeof *s.textures);
    s.textures[0] = sb_texture(256, 256, PM_WRAP_REPEAT);
    checker(&s.textures[0]);
    s.texture_count = 1;
    s.materials[m].base_color_texture = 0;
    sb_quad(&s, v3(-1, -1, 0), v3(1, -1, 0), v3(1, 1, 0), v3(-1, 1, 0), m);
    s.uvs = malloc(2 * sizeof(float) * s.vertex_count);
    for (uint32_t i = 0; i < s.vertex_count; i++) {
        s.uvs[2 * i] = 0.5f * (s.positions[i].x + 1.f);
        s.uvs[2 * i + 1] = 0.5f * (1.f - s.positions[i].y);
    }
    pm_accel *a = sb_finish(&s);
    CHECK(a != NULL, "scene built");
    pm_rng rng = pm_rng_for(6, 0, 0);
    double worst = 0.0, worst_grazing = 0.0, level0 = 0.0;
    vec3 grazing = v3_normalize(v3(sqrtf(1.f - 1.f / 256.f), 0.f, -1.f / 16.f));
    for (int i = 0; i < 500; i++) {
        float b1 = 0.5f * pm_rng_float(&rng), b2 = 0.5f * pm_rng_float(&rng);
        pm_surface sf;
        pm_scene_surface_footprint(&s, i & 1, b1, b2, 0.5f, v3(0, 0, -1), &sf);
        worst = fmax(worst, fabs(sf.kd.x - 0.5));
        pm_scene_surface_footprint(&s, i & 1, b1, b2, 0.5f, grazing, &sf);
        worst_grazing = fmax(worst_grazing, fabs(sf.kd.x - 0.5));
        pm_scene_surface(&s, i & 1, b1, b2, &sf);
        level0 = fmax(level0, fabs(sf.kd.x - 0.5));
    }
    printf("scene: kd %.5f from 0.5 (normal), %.5f (grazing), level 0 %.3f\n", worst, worst_grazing, level0);
    CHECK(worst <= 0.0045, "kd over a 64-texel footprint: %.5f from 0.5", worst);
    CHECK(worst_grazing <= 0.0045, "kd at grazing incidence: %.5f from 0.5", worst_grazing);
    CHECK(level0 > 0.3, "level 0 at the same points strays %.3f from the mean", level0);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

int main(void) {
    checker_resolves_to_mean();
    small_footprint_is_level_zero();
    levels_keep_the_mean();
    cutouts_keep_coverage();
    scene_footprint();
    return pm_test_done("test_texture_footprint");
}

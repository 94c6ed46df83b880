/* test_texture_threads.c: a textured scene (sRGB base colour) rendered on 4 and 1 threads gives the same image bit for bit, and shows its texture (also run under TSan, where the first sRGB lookups of the process happen on 4 threads at once).
 *
 * The checker floor's two texels are sRGB 255 and 128: decoded, albedos 0.9 x 1 and 0.9 x 0.2158.
 * The floor's direct light under a point light is albedo/pi x I cos / d^2, so the ratio of the
 * two halves measures the decode the table holds (0.2158, not 128/255 = 0.502).
 * Nothing decodes an sRGB texel before the 4-thread render (an emission texture would: the
 * scene set-up averages it on this thread), so under TSan the table's set-up is raced for: a
 * lazy fill, `if (table[255] == 0) fill()`, would race here, and TSan reports it.
 */
#include <stdlib.h>
#include <string.h>

#include "accel.h"
#include "defaults.h"
#include "film.h"
#include "progressive.h"
#include "progressive_harness.h"
#include "scene_builder.h"
#include "testing.h"

enum { W = 48, H = 32 };

static uint32_t add_texture(pm_scene *s, int width, int height, const uint8_t *grey) {
    s->textures = realloc(s->textures, (s->texture_count + 1) * sizeof *s->textures);
    pm_texture *t = &s->textures[s->texture_count];
    memset(t, 0, sizeof *t);
    t->width = width;
    t->height = height;
    t->wrap_s = t->wrap_t = PM_WRAP_CLAMP;
    t->rgba = malloc(4 * (size_t)width * height);
    for (int i = 0; i < width * height; i++) {
        t->rgba[4 * i] = t->rgba[4 * i + 1] = t->rgba[4 * i + 2] = grey[i];
        t->rgba[4 * i + 3] = 255;
    }
    return s->texture_count++;
}

/* uvs of the last quad's six vertices (a b c, a c d) */
static void set_last_quad_uv(pm_scene *s, const float uv[4][2]) {
    s->uvs = realloc(s->uvs, 2 * sizeof(float) * s->vertex_count);
    const int corner[6] = {0, 1, 2, 0, 2, 3};
    for (int k = 0; k < 6; k++) {
        uint32_t v = s->vertex_count - 6 + k;
        s->uvs[2 * v] = uv[corner[k]][0];
        s->uvs[2 * v + 1] = uv[corner[k]][1];
    }
}

/* A floor whose left half (x < 0) reads texel 255 and right half texel 128 (clamped, the texel
 * centres at u = 0.25 and 0.75 reached by u in [0, 0.25] and [0.75, 1]) under a point light. */
static pm_accel *build(pm_scene *s) {
    memset(s, 0, sizeof *s);
    uint32_t floor = sb_material(s, v3s(0.9f), 0, 1, 0, v3s(0), false);
    const uint8_t checker[2] = {255, 128};
    s->materials[floor].base_color_texture = (int)add_texture(s, 2, 1, checker);
    s->uvs = calloc(1, sizeof(float));
    sb_quad(s, v3(-1, 0, 1), v3(0, 0, 1), v3(0, 0, -1), v3(-1, 0, -1), floor);
    set_last_quad_uv(s, (const float[4][2]){{0, 0.5f}, {0.25f, 0.5f}, {0.25f, 0.5f}, {0, 0.5f}});
    sb_quad(s, v3(0, 0, 1), v3(1, 0, 1), v3(1, 0, -1), v3(0, 0, -1), floor);
    set_last_quad_uv(s, (const float[4][2]){{0.75f, 0.5f}, {1, 0.5f}, {1, 0.5f}, {0.75f, 0.5f}});
    sb_point_light(s, v3(0, 2, 0), v3s(4.f));
    return sb_finish(s);
}

static float *render(const pm_scene *s, const pm_accel *a, const pm_camera *cam, int threads) {
    pm_progressive_settings ps = {.seed = 9, .threads = threads, .photons = 3000, .caustic_photons = 3000,
                                  .alpha = PM_DEFAULT_ALPHA, .indirect = PM_INDIRECT_GATHER,
                                  .max_specular_depth = 8, .max_photon_bounces = 16};
    session r;
    if (!start(&r, s, a, cam, W, H, &ps)) return NULL;
    CHECK(iterate_passes(&r, 2), "iterations");
    float *direct = malloc(sizeof(float) * 3 * W * H), *total = malloc(sizeof(float) * 3 * W * H);
    pm_film_resolve(r.film, PM_DIRECT, direct);
    pm_film_resolve_total(r.film, total);
    stop(&r);
    /* the direct layer after the total: callers get both in one buffer */
    float *both = malloc(sizeof(float) * 6 * W * H);
    memcpy(both, total, sizeof(float) * 3 * W * H);
    memcpy(both + 3 * W * H, direct, sizeof(float) * 3 * W * H);
    free(direct);
    free(total);
    return both;
}

int main(void) {
    pm_scene s;
    pm_accel *a = build(&s);
    if (!a) return pm_test_done("test_texture_threads");
    CHECK(s.analysis.has_textures, "the scene counts as textured");
    /* looking straight down at the floor: the left half of the image is x < 0 */
    pm_camera cam = sb_camera(v3(0, 1.6f, 0.001f), v3(0, 0, 0), v3(0, 0, -1), 60.f);
    /* four threads first: their lookups are the first of the process */
    float *four = render(&s, a, &cam, 4), *one = render(&s, a, &cam, 1);
    if (one && four) {
        CHECK(memcmp(one, four, sizeof(float) * 6 * W * H) == 0, "the image differs between 1 and 4 threads");
        /* direct light on the floor at two mirror-image pixels near the centre row: same geometry, the texel differs */
        const float *direct = one + 3 * W * H;
        int y = H / 2, xl = W / 2 - 6, xr = W / 2 + 5;
        double left = direct[3 * (y * W + xl)], right = direct[3 * (y * W + xr)];
        double want = pm_srgb_to_linear(128.f / 255.f);
        printf("criterion: 1 and 4 threads give the same image; the texel ratio right/left %.4f = sRGB decode of 128 %.4f\n",
               right / left, want);
        CHECK(left > 0, "the lit floor has direct light (%g)", left);
        CHECK_NEAR(right / left, want, 0.02, 0, "the texture's right/left direct-light ratio (sRGB decoded)");
    }
    free(one);
    free(four);
    pm_accel_destroy(a);
    pm_scene_free(&s);
    return pm_test_done("test_texture_threads");
}

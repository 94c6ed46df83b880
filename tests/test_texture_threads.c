/* test_texture_threads.c: a textured scene (sRGB base colour) rendered on 4 and 1 threads gives the same image bit for bit, and shows its texture; a model's images decode and their mip levels build side by side, each texture its own (also run under TSan, where the first sRGB lookups of the process happen on 4 threads at once).
 *
 * The checker floor's two texels are sRGB 255 and 128: decoded, albedos 0.9 x 1 and 0.9 x 0.2158.
 * The floor's direct light under a point light is albedo/pi x I cos / d^2, so the ratio of the
 * two halves measures the decode the table holds (0.2158, not 128/255 = 0.502).
 * Nothing decodes an sRGB texel before the 4-thread render (an emission texture would: the
 * scene set-up averages it on this thread), so under TSan the table's set-up is raced for: a
 * lazy fill, `if (table[255] == 0) fill()`, would race here, and TSan reports it.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <stb/stb_image_write.h>

#include "accel.h"
#include "defaults.h"
#include "film.h"
#include "loader.h"
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

/* A GLB of one triangle whose material names IMAGES textures (base colour, emissive,
 * metallic-roughness, normal), each a PNG of its own colour in the BIN chunk: the loader decodes
 * them in one parallel-for and finalize builds their levels in another. Each texture must hold its
 * own image's colour at every level (a decode or level written into another's would not), under
 * TSan with no race reported. */
enum { IMAGES = 4, SIDE = 96 };
typedef struct { unsigned char *data; int size; } png_bytes;
static void append_png(void *ctx, void *data, int size) {
    png_bytes *b = ctx;
    b->data = realloc(b->data, (size_t)(b->size + size));
    if (!b->data) abort();
    memcpy(b->data + b->size, data, (size_t)size);
    b->size += size;
}

static void loaded_side_by_side(void) {
    static const float geometry[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, /* uv */ 0, 0, 1, 0, 0, 1};
    static const uint16_t indices[] = {0, 1, 2};
    unsigned char *png[IMAGES];
    int png_size[IMAGES];
    uint8_t *texels = malloc(4 * SIDE * SIDE);
    for (int i = 0; i < IMAGES; i++) {
        for (int k = 0; k < SIDE * SIDE; k++) {
            texels[4 * k] = (uint8_t)(40 + 50 * i), texels[4 * k + 1] = (uint8_t)(200 - 40 * i);
            texels[4 * k + 2] = (uint8_t)(17 * i + 3), texels[4 * k + 3] = 255;
        }
        png_bytes b = {NULL, 0};
        if (!stbi_write_png_to_func(append_png, &b, SIDE, SIDE, 4, texels, 4 * SIDE)) abort();
        png[i] = b.data, png_size[i] = b.size;
    }
    free(texels);
    /* BIN: positions, uvs, indices (padded), then the PNGs, each view 4-byte aligned */
    size_t offset[IMAGES + 3], at = 0;
    size_t sizes[IMAGES + 3] = {36, 24, 6};
    for (int i = 0; i < IMAGES; i++) sizes[3 + i] = (size_t)png_size[i];
    for (int v = 0; v < IMAGES + 3; v++) offset[v] = at, at += (sizes[v] + 3) & ~(size_t)3;
    uint8_t *bin = calloc(1, at);
    memcpy(bin + offset[0], geometry, 36);
    memcpy(bin + offset[1], geometry + 9, 24);
    memcpy(bin + offset[2], indices, 6);
    for (int i = 0; i < IMAGES; i++) memcpy(bin + offset[3 + i], png[i], (size_t)png_size[i]);
    char json[4096];
    int n = snprintf(json, sizeof json,
                     "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"byteLength\":%zu}],\"bufferViews\":["
                     "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":36},{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":24},"
                     "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":6}",
                     at, offset[0], offset[1], offset[2]);
    for (int i = 0; i < IMAGES; i++)
        n += snprintf(json + n, sizeof json - (size_t)n, ",{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%d}", offset[3 + i], png_size[i]);
    n += snprintf(json + n, sizeof json - (size_t)n,
                  "],\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"min\":[0,0,0],"
                  "\"max\":[1,1,0]},{\"bufferView\":1,\"componentType\":5126,\"count\":3,\"type\":\"VEC2\"},"
                  "{\"bufferView\":2,\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}],\"images\":[");
    for (int i = 0; i < IMAGES; i++)
        n += snprintf(json + n, sizeof json - (size_t)n, "%s{\"bufferView\":%d,\"mimeType\":\"image/png\"}", i ? "," : "", 3 + i);
    n += snprintf(json + n, sizeof json - (size_t)n, "],\"textures\":[");
    for (int i = 0; i < IMAGES; i++) n += snprintf(json + n, sizeof json - (size_t)n, "%s{\"source\":%d}", i ? "," : "", i);
    n += snprintf(json + n, sizeof json - (size_t)n,
                  "],\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0},"
                  "\"metallicRoughnessTexture\":{\"index\":2}},\"emissiveFactor\":[1,1,1],\"emissiveTexture\":{\"index\":1},"
                  "\"normalTexture\":{\"index\":3}}],\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,"
                  "\"TEXCOORD_0\":1},\"indices\":2,\"material\":0}]}],\"nodes\":[{\"mesh\":0}],\"scenes\":[{\"nodes\":[0]}],"
                  "\"scene\":0}");
    while (n % 4) json[n++] = ' ';
    size_t total = 12 + 8 + (size_t)n + 8 + at;
    uint8_t *glb = malloc(total);
    uint32_t header[5] = {0x46546C67u, 2, (uint32_t)total, (uint32_t)n, 0x4E4F534Au}, bin_header[2] = {(uint32_t)at, 0x004E4942u};
    memcpy(glb, header, 20);
    memcpy(glb + 20, json, (size_t)n);
    memcpy(glb + 20 + n, bin_header, 8);
    memcpy(glb + 28 + n, bin, at);
    pm_scene s;
    pm_load_report report;
    char err[512] = "";
    bool loaded = pm_load_gltf_memory(glb, total, "side-by-side.glb", true, &s, &report, err, sizeof err);
    CHECK(loaded, "the model of %d textures loads: %s", IMAGES, err);
    if (loaded) {
        CHECK(pm_scene_finalize(&s, true, NULL), "finalize builds the levels");
        CHECK(s.texture_count == IMAGES, "textures %u, want %d", s.texture_count, IMAGES);
        int wrong = 0;
        for (uint32_t t = 0; t < s.texture_count && t < IMAGES; t++) {
            const pm_texture *x = &s.textures[t];
            /* the loader keeps the textures in the order the material names them: find the image by its colour */
            int image = (x->rgba[0] - 40) / 50;
            wrong += image < 0 || image >= IMAGES || x->level_count < 7;
            for (int l = 0; l < x->level_count; l++) {
                const uint8_t *texel = l ? x->levels + x->level_offset[l] : x->rgba;
                wrong += abs(texel[0] - (40 + 50 * image)) > 1 || abs(texel[1] - (200 - 40 * image)) > 1 ||
                         abs(texel[2] - (17 * image + 3)) > 1;
            }
        }
        CHECK(wrong == 0, "%d textures or levels hold another image's colour (or too few levels)", wrong);
        pm_scene_free(&s);
    }
    for (int i = 0; i < IMAGES; i++) free(png[i]);
    free(bin);
    free(glb);
}

int main(void) {
    loaded_side_by_side();
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

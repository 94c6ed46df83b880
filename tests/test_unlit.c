/* test_unlit.c: KHR_materials_unlit: the camera sees exactly base colour x texture, directly and in a mirror, in every mode; the surface lights nothing (photons, gathers and paths meet a black absorber).
 *
 * Scene: a white floor lit by a point light, an unlit panel standing on it, a mirror strip on the
 * floor and a mirror behind the camera. The
 * pixels that see the panel must read its base colour exactly (no light involved, so no noise);
 * the floor must read the same as with the panel made a black Lambert absorber, and far less
 * than with the panel an emitter of the same colour (what "lighting nothing" rules out).
 */
#include <stdlib.h>
#include <string.h>

#include "accel.h"
#include "film.h"
#include "scene_builder.h"
#include "session_harness.h"
#include "testing.h"

enum { W = 32, H = 32, SAMPLES = 16 };
enum { PANEL_UNLIT = 0, PANEL_BLACK = 1, PANEL_EMITTER = 2 };
static const vec3 panel_factor = {0.9f, 0.6f, 0.3f};
static const uint8_t panel_texel[4] = {200, 128, 255, 255}; /* sRGB */
static const float mirror_reflectance = 0.9f;

/* The panel (x in [-1, 1], y in [0, 2] at z = 0, facing +z), its material as `kind`, textured by
 * one sRGB texel times panel_factor; a floor y = 0 in front of it; a point light. */
static pm_accel *build(pm_scene *s, int kind) {
    memset(s, 0, sizeof *s);
    uint32_t floor_material = sb_lambert(s, v3s(0.8f));
    sb_quad(s, v3(-4, 0, -4), v3(-4, 0, 4), v3(4, 0, 4), v3(4, 0, -4), floor_material);
    vec3 emission = kind == PANEL_EMITTER ? v3_mul(panel_factor, v3(pm_srgb_to_linear(200 / 255.f), pm_srgb_to_linear(128 / 255.f), 1.f))
                                          : v3s(0.f);
    uint32_t panel = sb_material(s, kind == PANEL_UNLIT ? panel_factor : v3s(0.f), 0, 1, 0, emission, false);
    uint32_t first = s->vertex_count;
    sb_quad(s, v3(-1, 0, 0), v3(1, 0, 0), v3(1, 2, 0), v3(-1, 2, 0), panel);
    /* a mirror strip on the floor in front of the panel (metal, roughness 0: reflectance 0.9) */
    uint32_t mirror = sb_material(s, v3s(mirror_reflectance), 1, 0, 0, v3s(0.f), false);
    sb_quad(s, v3(-2, 0.001f, 0.5f), v3(-2, 0.001f, 1.5f), v3(2, 0.001f, 1.5f), v3(2, 0.001f, 0.5f), mirror);
    /* and one behind the camera facing the panel: the floor sees the panel in it (diffuse, then
     * specular, then the panel: a path that must find no light there) */
    sb_quad(s, v3(3, 0, 6), v3(-3, 0, 6), v3(-3, 3, 6), v3(3, 3, 6), mirror);
    if (kind == PANEL_UNLIT) {
        s->materials[panel].unlit = true;
        s->uvs = calloc(2 * (size_t)s->vertex_count, sizeof(float));
        s->textures = calloc(1, sizeof *s->textures);
        if (!s->uvs || !s->textures) abort();
        for (uint32_t v = first; v < first + 6; v++) s->uvs[2 * v] = s->uvs[2 * v + 1] = 0.5f;
        s->textures[0].width = s->textures[0].height = 1;
        s->textures[0].rgba = malloc(4);
        if (!s->textures[0].rgba) abort();
        memcpy(s->textures[0].rgba, panel_texel, 4);
        s->texture_count = 1;
        s->materials[panel].base_color_texture = 0;
    }
    sb_point_light(s, v3(0, 3, 3), v3s(6.f));
    pm_scene_finalize(s, false, NULL);
    char err[256];
    pm_accel *a = pm_accel_create(s, err, sizeof err);
    CHECK(a != NULL, "accel: %s", err);
    return a;
}

/* The total image of `mode` from a camera in front of the panel looking at it and down at the floor.
 * The progressive mode's final gathering takes its light from `gather`: left to learn, it measures
 * noise and cost, which the panel's kind changes (a black panel holds visible points, an unlit one
 * none), and the two floors would differ by their choices; with each source forced they compare
 * sample for sample. */
static float *render(const pm_scene *s, const pm_accel *a, pm_mode mode, pm_gather_choice gather) {
    pm_session_config config = mode_config(mode, W, H, 9, 2);
    config.progressive.gather = gather;
    if (mode == PM_MODE_CLASSIC) {
        pm_photon_settings photons = {.global_photons = 20000, .caustic_photons = 0, .seed = 4, .threads = 2,
                                      .max_bounces = PM_DEFAULT_MAX_PHOTON_BOUNCES};
        with_photons(&config, &photons, config.eye.global_estimate, config.eye.caustic_estimate);
    }
    pm_camera cam = sb_camera(v3(0, 1.5f, 4), v3(0, 0.6f, 0), v3(0, 1, 0), 50.f);
    pm_session *session = render_session(s, a, &cam, &config, SAMPLES);
    float *img = malloc(sizeof(float) * 3 * W * H);
    if (!img) abort();
    memset(img, 0, sizeof(float) * 3 * W * H);
    if (session) pm_film_resolve_total(pm_session_film(session), img);
    pm_session_destroy(session);
    return img;
}

int main(void) {
    const vec3 want = v3_mul(panel_factor, v3(pm_srgb_to_linear(200 / 255.f), pm_srgb_to_linear(128 / 255.f), 1.f));
    static const pm_mode modes[4] = {PM_MODE_PROGRESSIVE, PM_MODE_PROGRESSIVE, PM_MODE_CLASSIC, PM_MODE_PATHTRACE};
    static const pm_gather_choice gathers[4] = {PM_GATHER_FORCE_PHOTONS, PM_GATHER_FORCE_PATH, PM_GATHER_AUTO, PM_GATHER_AUTO};
    static const char *const names[4] = {"progressive", "prog., path", "classic", "path tracer"};
    pm_scene scenes[3];
    pm_accel *accels[3];
    for (int k = 0; k < 3; k++) accels[k] = build(&scenes[k], k);
    CHECK(scenes[PANEL_UNLIT].analysis.has_unlit && scenes[PANEL_UNLIT].emitter_count == 0 &&
              scenes[PANEL_UNLIT].analysis.component_possible[PM_DIRECT] &&
              !scenes[PANEL_UNLIT].materials[1].may_diffuse,
          "the unlit panel: analysis flag, no emitter, no lobe");
    /* what each pixel sees, traced once by the scene itself: the whole pixel (its four corners) on
     * the panel, on the panel in the mirror, or on the floor; else mixed */
    enum { MIXED, PANEL, PANEL_IN_MIRROR, FLOOR };
    pm_camera cam = sb_camera(v3(0, 1.5f, 4), v3(0, 0.6f, 0), v3(0, 1, 0), 50.f);
    int sees[W * H], counts[4] = {0, 0, 0, 0};
    /* the mirror is glTF's smooth metal: Schlick's reflectance at the angle each pixel's corners see it */
    static float schlick_lo[W * H], schlick_hi[W * H];
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            int corner_kind[4];
            for (int c = 0; c < 4; c++) {
                vec3 o, d;
                pm_camera_ray(&cam, W, H, x + (c & 1), y + (c >> 1), &o, &d);
                pm_hit h;
                corner_kind[c] = MIXED;
                if (!pm_accel_intersect(accels[0], o, d, INFINITY, &h)) continue;
                uint32_t m = scenes[0].triangle_material[h.tri];
                if (m == 0) corner_kind[c] = FLOOR;
                else if (m == 1) corner_kind[c] = PANEL;
                else if (m == 2) {
                    vec3 p = v3_madd(o, d, h.t), r = v3(d.x, -d.y, d.z);
                    pm_hit g;
                    if (pm_accel_intersect(accels[0], v3(p.x, p.y + 1e-3f, p.z), r, INFINITY, &g) && scenes[0].triangle_material[g.tri] == 1)
                        corner_kind[c] = PANEL_IN_MIRROR;
                    double f = mirror_reflectance + (1.0 - mirror_reflectance) * pow(1.0 + d.y / v3_length(d), 5.0);
                    schlick_lo[y * W + x] = c == 0 ? (float)f : fminf(schlick_lo[y * W + x], (float)f);
                    schlick_hi[y * W + x] = c == 0 ? (float)f : fmaxf(schlick_hi[y * W + x], (float)f);
                }
            }
            int k = corner_kind[0];
            for (int c = 1; c < 4; c++)
                if (corner_kind[c] != k) k = MIXED;
            sees[y * W + x] = k;
            counts[k]++;
        }
    CHECK(counts[PANEL] > 50 && counts[PANEL_IN_MIRROR] > 20 && counts[FLOOR] > 50,
          "the view holds the panel (%d pixels), its reflection (%d) and the floor (%d)", counts[PANEL], counts[PANEL_IN_MIRROR],
          counts[FLOOR]);
    for (int mode = 0; mode < 4; mode++) {
        float *img[3];
        for (int k = 0; k < 3; k++) img[k] = render(&scenes[k], accels[k], modes[mode], gathers[mode]);
        double worst_panel = 0.0, worst_mirror = 0.0, floor_sum[3] = {0, 0, 0};
        for (int i = 0; i < W * H; i++) {
            const float *p = img[PANEL_UNLIT] + 3 * i;
            if (sees[i] == PANEL)
                worst_panel = fmax(worst_panel, fmax(fabs(p[0] - want.x), fmax(fabs(p[1] - want.y), fabs(p[2] - want.z))));
            else if (sees[i] == PANEL_IN_MIRROR)
                for (int k = 0; k < 3; k++) { /* outside the reflectance range over the pixel, by how much */
                    double lo = v3_get(want, k) * schlick_lo[i], hi = v3_get(want, k) * schlick_hi[i];
                    worst_mirror = fmax(worst_mirror, fmax(lo - p[k], p[k] - hi));
                }
            else if (sees[i] == FLOOR)
                for (int k = 0; k < 3; k++) floor_sum[k] += (img[k][3 * i] + img[k][3 * i + 1] + img[k][3 * i + 2]) / 3.0;
        }
        printf("%-12s unlit panel: worst error %.2g against base colour (%.4f %.4f %.4f), %.2g in the mirror; floor: %.6f with it, "
               "%.6f with a black panel, %.6f with an emitting one\n",
               names[mode], worst_panel, want.x, want.y, want.z, worst_mirror, floor_sum[0], floor_sum[1], floor_sum[2]);
        CHECK(worst_panel < 1e-5, "%s: the camera sees the unlit colour exactly (worst error %g)", names[mode], worst_panel);
        CHECK(worst_mirror < 1e-5, "%s: the mirror shows it times its Schlick reflectance (worst error %g)", names[mode], worst_mirror);
        CHECK(fabs(floor_sum[PANEL_UNLIT] - floor_sum[PANEL_BLACK]) <= 1e-4 * floor_sum[PANEL_BLACK],
              "%s: the floor as with a black panel: %g against %g", names[mode], floor_sum[PANEL_UNLIT], floor_sum[PANEL_BLACK]);
        CHECK(floor_sum[PANEL_EMITTER] > 1.1 * floor_sum[PANEL_BLACK], "%s: an emitting panel must light the floor (%g, black %g)",
              names[mode], floor_sum[PANEL_EMITTER], floor_sum[PANEL_BLACK]);
        for (int k = 0; k < 3; k++) free(img[k]);
    }
    for (int k = 0; k < 3; k++) {
        pm_accel_destroy(accels[k]);
        pm_scene_free(&scenes[k]);
    }
    /* a closed white room reflects everything unless it is unlit (the slow-room warning reads this) */
    pm_scene room;
    memset(&room, 0, sizeof room);
    uint32_t white = sb_lambert(&room, v3s(1.f));
    sb_box(&room, v3s(-1.f), v3s(1.f), white, true);
    double lit_room = pm_scene_reflective_area_fraction(&room, 0.98f);
    room.materials[white].unlit = true;
    double unlit_room = pm_scene_reflective_area_fraction(&room, 0.98f);
    CHECK(lit_room == 1.0 && unlit_room == 0.0, "reflective area: white room %g, unlit white room %g", lit_room, unlit_room);
    pm_scene_free(&room);
    return pm_test_done("test_unlit");
}

/* test_cutout_emitter.c: an emissive quad half cut out (MASK texture, or BLEND at alpha 0.5) emits half its light: emitter power, photon flux and direct light against analytic values. */
#include <stdlib.h>
#include <string.h>

#include "accel.h"
#include "camera.h"
#include "defaults.h"
#include "film.h"
#include "photonmap.h"
#include "scene_builder.h"
#include "session_harness.h"
#include "testing.h"

enum { LAMP_OPAQUE = 0, LAMP_MASK_LEFT_CUT = 1, LAMP_BLEND_HALF = 2 };
static const char *const lamp_names[3] = {"opaque lamp", "MASK lamp, left half cut", "BLEND lamp at alpha 0.5"};
static const float lamp_radiance = 2.f, lamp_height = 1.f, floor_albedo = 0.5f, floor_half = 100.f;

/* A unit lamp (x, z in [-0.5, 0.5]) at lamp_height facing down over a wide floor. The MASK lamp's
 * base colour texture is 2 x 1 texels, alpha 0 then 255, clamped, with u running along x: the
 * bilinear alpha crosses the cutoff 0.5 exactly at x = 0, so the lamp keeps x in [0, 0.5]. */
static pm_accel *build(pm_scene *s, int kind) {
    memset(s, 0, sizeof *s);
    uint32_t floor_material = sb_lambert(s, v3s(floor_albedo));
    float f = floor_half;
    sb_quad(s, v3(-f, 0, -f), v3(-f, 0, f), v3(f, 0, f), v3(f, 0, -f), floor_material);
    uint32_t lamp = sb_material(s, v3s(0.f), 0, 1, 0, v3s(lamp_radiance), false);
    uint32_t first = s->vertex_count;
    float h = lamp_height;
    sb_quad(s, v3(-0.5f, h, -0.5f), v3(0.5f, h, -0.5f), v3(0.5f, h, 0.5f), v3(-0.5f, h, 0.5f), lamp);
    s->uvs = calloc(2 * (size_t)s->vertex_count, sizeof(float));
    if (!s->uvs) abort();
    for (uint32_t v = first; v < s->vertex_count; v++) {
        s->uvs[2 * v] = s->positions[v].x + 0.5f;
        s->uvs[2 * v + 1] = 0.5f;
    }
    pm_material *m = &s->materials[lamp];
    if (kind == LAMP_MASK_LEFT_CUT) {
        s->textures = calloc(1, sizeof *s->textures);
        if (!s->textures) abort();
        pm_texture *t = &s->textures[0];
        t->width = 2;
        t->height = 1;
        t->wrap_s = t->wrap_t = PM_WRAP_CLAMP;
        t->rgba = calloc(8, 1);
        if (!t->rgba) abort();
        t->rgba[3] = 0;
        t->rgba[7] = 255;
        s->texture_count = 1;
        m->base_color_texture = 0;
        m->alpha_mode = PM_ALPHA_MASK;
        m->alpha_cutoff = 0.5f;
    } else if (kind == LAMP_BLEND_HALF) {
        m->alpha_mode = PM_ALPHA_BLEND;
        m->alpha = 0.5f;
    }
    pm_scene_finalize(s, false, NULL);
    char err[256];
    pm_accel *a = pm_accel_create(s, err, sizeof err);
    CHECK(a != NULL, "accel: %s", err);
    return a;
}

/* Irradiance at p (normal +y) from a Lambertian polygon of radiance L (Lambert's formula: L/2 times
 * the sum over edges of the angle they subtend times the cosine of their plane's normal with n). */
static double polygon_irradiance(vec3 p, const double corners[][3], int n, double radiance) {
    double sum = 0.0;
    for (int i = 0; i < n; i++) {
        const double *a = corners[i], *b = corners[(i + 1) % n];
        double va[3] = {a[0] - p.x, a[1] - p.y, a[2] - p.z}, vb[3] = {b[0] - p.x, b[1] - p.y, b[2] - p.z};
        double la = sqrt(va[0] * va[0] + va[1] * va[1] + va[2] * va[2]), lb = sqrt(vb[0] * vb[0] + vb[1] * vb[1] + vb[2] * vb[2]);
        double c[3] = {va[1] * vb[2] - va[2] * vb[1], va[2] * vb[0] - va[0] * vb[2], va[0] * vb[1] - va[1] * vb[0]};
        double lc = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
        double angle = acos(fmax(-1.0, fmin(1.0, (va[0] * vb[0] + va[1] * vb[1] + va[2] * vb[2]) / (la * lb))));
        if (lc > 0.0) sum += angle * c[1] / lc; /* n = +y */
    }
    return 0.5 * radiance * fabs(sum);
}

/* What the floor at p receives from the lamp kind leaves: the kept half [0, 0.5] x [-0.5, 0.5] for
 * MASK, half the whole lamp for BLEND, the whole lamp when opaque. */
static double lamp_irradiance(vec3 p, int kind) {
    double h = lamp_height;
    double whole[4][3] = {{-0.5, h, -0.5}, {0.5, h, -0.5}, {0.5, h, 0.5}, {-0.5, h, 0.5}};
    double kept[4][3] = {{0.0, h, -0.5}, {0.5, h, -0.5}, {0.5, h, 0.5}, {0.0, h, 0.5}};
    if (kind == LAMP_MASK_LEFT_CUT) return polygon_irradiance(p, kept, 4, lamp_radiance);
    return polygon_irradiance(p, whole, 4, lamp_radiance) * (kind == LAMP_BLEND_HALF ? 0.5 : 1.0);
}

/* The direct layer of a camera under the lamp looking straight down, against the analytic
 * radiance albedo / pi x E at each pixel's centre, summed over the image's left half (x < 0 on
 * the floor) and right half separately: got[side], want[side]. */
static void direct_halves(const pm_scene *s, const pm_accel *a, int kind, double got[2], double want[2]) {
    enum { W = 32, H = 32 };
    pm_session_config config = mode_config(PM_MODE_CLASSIC, W, H, 7, 2);
    pm_camera cam = sb_camera(v3(0, 0.9f, 0), v3(0, 0, 0), v3(0, 0, -1), 90.f);
    pm_session *session = render_session(s, a, &cam, &config, 64);
    float *img = malloc(sizeof(float) * 3 * W * H);
    got[0] = got[1] = want[0] = want[1] = 0.0;
    if (session && img) {
        pm_film_resolve(pm_session_film(session), PM_DIRECT, img);
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                vec3 o, d;
                pm_camera_ray(&cam, W, H, x + 0.5f, y + 0.5f, &o, &d);
                vec3 p = v3_madd(o, d, -o.y / d.y);
                int side = p.x < 0.f ? 0 : 1;
                const float *px = img + 3 * (size_t)(y * W + x);
                got[side] += (px[0] + px[1] + px[2]) / 3.0;
                want[side] += floor_albedo / PM_PI * lamp_irradiance(p, kind);
            }
    }
    free(img);
    pm_session_destroy(session);
}

int main(void) {
    const double lamp_area = 1.0, whole_power = PM_PI * lamp_radiance * lamp_area;
    /* the floor's share of a small downward lamp's flux: 1 - h^2 / (h^2 + R^2) for a point at
     * height h over a disc of radius R, and the square floor holds more than its inscribed disc */
    const double floor_share = 1.0 - lamp_height * lamp_height / (lamp_height * lamp_height + floor_half * floor_half);
    double photon_flux[3] = {0, 0, 0};
    for (int kind = 0; kind < 3; kind++) {
        pm_scene s;
        pm_accel *a = build(&s, kind);
        if (!a) break;
        double want_power = kind == LAMP_OPAQUE ? whole_power : 0.5 * whole_power;
        /* emitter power: the pick distribution's total, from 64 stratified points per triangle, so
         * a cut edge crossing the triangles is only approximated (the estimates below divide by
         * the pick probability and stay exact); a lamp whose cut-outs were ignored would read 2x */
        printf("%-26s emitter power %.4f, analytic %.4f\n", lamp_names[kind], s.emitter_power, want_power);
        CHECK_NEAR(s.emitter_power, want_power, kind == LAMP_MASK_LEFT_CUT ? 0.1 : 1e-4, 0, "emitter power");
        /* photons: the flux the floor receives, every photon's first hit (the black lamp absorbs
         * what the floor sends back up, and nothing else is there) */
        pm_photon_settings ps = {.global_photons = 100000, .seed = 3, .threads = 2, .max_bounces = 1};
        pm_photon_maps maps;
        if (pm_photon_maps_build(&s, a, &ps, &maps, NULL)) {
            for (size_t i = 0; i < maps.global.count; i++) {
                pm_photon *ph = &maps.global.photons[i];
                if (pm_photon_position(ph).y < 0.5f) photon_flux[kind] += v3_average(pm_photon_power(ph));
            }
            pm_photon_maps_free(&maps);
        } else {
            CHECK(false, "photon maps for the %s", lamp_names[kind]);
        }
        printf("%-26s photon flux on the floor %.4f, analytic %.4f\n", lamp_names[kind], photon_flux[kind],
               want_power * floor_share);
        CHECK_NEAR(photon_flux[kind], want_power * floor_share, 0.01, 0, "photon flux on the floor");
        /* direct light by light samples, per half of the floor: the MASK lamp's kept half lies over x > 0 */
        double got[2], want[2];
        direct_halves(&s, a, kind, got, want);
        printf("%-26s direct light, left half %.3f (analytic %.3f), right half %.3f (analytic %.3f)\n", lamp_names[kind],
               got[0], want[0], got[1], want[1]);
        CHECK_NEAR(got[0], want[0], 0.03, 0, "direct light on the floor's left half");
        CHECK_NEAR(got[1], want[1], 0.03, 0, "direct light on the floor's right half");
        pm_accel_destroy(a);
        pm_scene_free(&s);
    }
    CHECK_NEAR(photon_flux[LAMP_MASK_LEFT_CUT] / photon_flux[LAMP_OPAQUE], 0.5, 0.01, 0, "MASK lamp's flux over the opaque one's");
    CHECK_NEAR(photon_flux[LAMP_BLEND_HALF] / photon_flux[LAMP_OPAQUE], 0.5, 0.01, 0, "BLEND lamp's flux over the opaque one's");
    return pm_test_done("test_cutout_emitter");
}

/* test_alpha.c: glTF alpha modes against analytic answers: MASK cut-outs, BLEND panes transmitting 1 - alpha, no filter for opaque scenes.
 *
 * One layout throughout: a point light of intensity I at (0, 2, 0), a square "pane" |x|, |z| <= 1
 * at y = 1 facing up, and a Lambert floor at y = 0. The MASK pane's alpha texture is two texels,
 * alpha 0 and 1, clamped, with u = (x + 1) / 2: bilinear alpha crosses the 0.5 cutoff at x = 0,
 * so the pane is cut out for x < 0 and opaque for x > 0. Every expected value below is computed
 * from that geometry alone (irradiance I cos / d^2, solid angles of rectangles), never by pmview.
 */
#include "accel.h"
#include "eye.h"
#include "film.h"
#include "photonmap.h"
#include "progressive_harness.h"
#include "scene_builder.h"
#include "session_harness.h"
#include "testing.h"

#define W 32
#define H 32

static const float light_i = 10.f, rho_floor = 0.6f, rho_pane = 0.5f;
static const vec3 light_pos = {0.f, 2.f, 0.f};

/* The scene: pane material mode with BLEND alpha `blend_alpha` (MASK uses the texture). */
static void build(pm_scene *s, pm_alpha_mode mode, float blend_alpha) {
    memset(s, 0, sizeof *s);
    uint32_t floor_m = sb_lambert(s, v3s(rho_floor));
    uint32_t pane_m = sb_lambert(s, v3s(rho_pane));
    sb_quad(s, v3(-20, 0, -20), v3(-20, 0, 20), v3(20, 0, 20), v3(20, 0, -20), floor_m);
    sb_quad(s, v3(-1, 1, -1), v3(-1, 1, 1), v3(1, 1, 1), v3(1, 1, -1), pane_m);
    sb_point_light(s, light_pos, v3s(light_i));
    s->uvs = malloc(2 * sizeof(float) * s->vertex_count);
    for (uint32_t i = 0; i < s->vertex_count; i++) {
        s->uvs[2 * i] = (s->positions[i].x + 1.f) * 0.5f;
        s->uvs[2 * i + 1] = (s->positions[i].z + 1.f) * 0.5f;
    }
    pm_material *m = &s->materials[pane_m];
    m->alpha_mode = mode;
    if (mode == PM_ALPHA_MASK) {
        s->textures = calloc(1, sizeof *s->textures);
        s->texture_count = 1;
        pm_texture *t = s->textures;
        t->width = 2;
        t->height = 1;
        t->wrap_s = t->wrap_t = PM_WRAP_CLAMP;
        t->rgba = malloc(8);
        const uint8_t texels[8] = {255, 255, 255, 0, 255, 255, 255, 255}; /* white: alpha must not tint */
        memcpy(t->rgba, texels, 8);
        m->base_color_texture = 0;
        m->alpha_cutoff = 0.5f;
    } else {
        m->alpha = blend_alpha;
    }
    pm_scene_finalize(s, false, NULL);
}

/* What a ray (o, d) sees in the direct component, in expectation: the first surface's albedo/pi x
 * I cos / d^2 x the transmittance from it to the light; a BLEND pane is hit with probability
 * alpha, and the ray to the light crosses it independently. */
static bool pane_covers(float x, float z) { return fabsf(x) <= 1.f && fabsf(z) <= 1.f; }
static double transmittance_to_light(vec3 p, pm_alpha_mode mode, float alpha) {
    if (p.y >= 1.f) return 1.0;
    float t = (1.f - p.y) / (light_pos.y - p.y);
    float x = p.x + t * (light_pos.x - p.x), z = p.z + t * (light_pos.z - p.z);
    if (!pane_covers(x, z)) return 1.0;
    if (mode == PM_ALPHA_MASK) return x < 0.f ? 1.0 : 0.0;
    return 1.0 - alpha;
}
static double lit_radiance(vec3 p, float rho, pm_alpha_mode mode, float alpha) {
    vec3 to_light = v3_sub(light_pos, p);
    double d2 = v3_dot(to_light, to_light), cos_t = to_light.y / sqrt(d2);
    return rho / PM_PI * light_i * cos_t / d2 * transmittance_to_light(p, mode, alpha);
}
static double expected_radiance(vec3 o, vec3 d, pm_alpha_mode mode, float alpha) {
    double floor_l = 0.0;
    if (d.y < 0.f) floor_l = lit_radiance(v3_madd(o, d, -o.y / d.y), rho_floor, mode, alpha);
    if (o.y > 1.f && d.y < 0.f) {
        vec3 q = v3_madd(o, d, (1.f - o.y) / d.y);
        if (pane_covers(q.x, q.z)) {
            double pane_l = lit_radiance(q, rho_pane, mode, alpha);
            if (mode == PM_ALPHA_MASK) return q.x < 0.f ? floor_l : pane_l;
            return alpha * pane_l + (1.0 - alpha) * floor_l;
        }
    }
    return floor_l;
}

/* The pixel's expectation: expected_radiance averaged over a 16 x 16 grid of its camera rays. */
static double expected_pixel(const pm_camera *cam, int x, int y, pm_alpha_mode mode, float alpha) {
    const int n = 16;
    double sum = 0.0;
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) {
            vec3 o, d;
            pm_camera_ray(cam, W, H, x + (i + 0.5f) / n, y + (j + 0.5f) / n, &o, &d);
            sum += expected_radiance(o, d, mode, alpha);
        }
    return sum / (n * n);
}

/* The classic mode's eye pass alone (no photon maps), seed 7: direct light and alpha crossings. */
static pm_session *render(const pm_scene *s, const pm_accel *a, const pm_camera *cam, int iterations, int threads) {
    pm_session_config config = mode_config(PM_MODE_CLASSIC, W, H, 7, threads);
    config.eye.max_specular_depth = 8;
    return render_session(s, a, cam, &config, (uint32_t)iterations);
}

static double pixel_direct(const pm_film *f, int x, int y) {
    const float *p = f->sum[PM_DIRECT] + 3 * ((size_t)y * W + x);
    return (p[0] + p[1] + p[2]) / (3.0 * f->samples);
}

/* Power of the first-hit (direct) photons stored on the floor inside x0 < x < x1, |z| < 2. */
static double floor_direct_power(const pm_kdtree *t, float x0, float x1, size_t *count) {
    double sum = 0.0;
    *count = 0;
    for (size_t i = 0; i < t->count; i++) {
        const pm_photon *ph = &t->photons[i];
        if (pm_photon_path(ph) != PM_PATH_DIRECT || fabsf(ph->pos[1]) > 1e-3f) continue;
        if (!(ph->pos[0] > x0 && ph->pos[0] < x1 && fabsf(ph->pos[2]) < 2.f)) continue;
        sum += v3_average(pm_photon_power(ph));
        (*count)++;
    }
    return sum;
}

static bool trace_photons(const pm_scene *s, const pm_accel *a, uint64_t photons, pm_photon_maps *maps) {
    pm_photon_settings ps;
    memset(&ps, 0, sizeof ps);
    ps.global_photons = photons;
    ps.seed = 11;
    ps.threads = 2;
    ps.max_bounces = 8;
    pm_photon_stats st;
    memset(&st, 0, sizeof st);
    return pm_photon_maps_build(s, a, &ps, maps, &st);
}

static pm_accel *make_accel(const pm_scene *s) {
    char err[256];
    pm_accel *a = pm_accel_create(s, err, sizeof err);
    CHECK(a != NULL, "accel: %s", err);
    return a;
}

/* Solid angle, seen from a point at height h above a plane, of the rectangle [0, a] x [0, b]
 * with a corner at the foot of the perpendicular. */
static double corner_rectangle_solid_angle(double h, double a, double b) { return atan(a * b / (h * sqrt(h * h + a * a + b * b))); }

/* MASK: texture alpha is linear and bilinear; shadow rays, camera rays and photons all pass the
 * cut-out half and stop at the opaque half. */
static void mask_cutout(void) {
    pm_scene s;
    build(&s, PM_ALPHA_MASK, 1.f);
    const pm_texture *t = &s.textures[0];
    CHECK_NEAR(pm_texture_alpha(t, 0.5f, 0.5f), 0.5, 1e-6, 0, "alpha between the texels: linear, bilinear");
    CHECK_NEAR(pm_texture_alpha(t, 0.375f, 0.5f), 0.25, 1e-6, 0, "alpha a quarter of the way");
    CHECK_NEAR(pm_texture_alpha(t, 0.1f, 0.5f), 0.0, 0, 0, "alpha clamped at the transparent texel");
    CHECK(s.analysis.has_non_opaque, "analysis: the scene has a non-opaque material");
    pm_accel *a = make_accel(&s);
    if (!a) return;
    CHECK(pm_accel_alpha_tested_triangles(a) == 2, "the pane's two triangles are alpha tested (%u)",
          pm_accel_alpha_tested_triangles(a));

    /* Single rays: straight down through the hole reaches the floor; through the opaque half it
     * stops at the pane; an occlusion query agrees. */
    pm_hit h;
    CHECK(pm_accel_intersect(a, v3(-0.5f, 3, 0.2f), v3(0, -1, 0), INFINITY, &h) && fabsf(h.t - 3.f) < 1e-4f,
          "ray through the hole hits the floor (t %g)", h.t);
    CHECK(pm_accel_intersect(a, v3(0.5f, 3, 0.2f), v3(0, -1, 0), INFINITY, &h) && fabsf(h.t - 2.f) < 1e-4f &&
              s.triangle_material[h.tri] == 1,
          "ray onto the opaque half hits the pane (t %g, triangle %u)", h.t, h.tri);
    CHECK(!pm_accel_occluded(a, v3(-0.5f, 0.01f, 0.2f), v3(0, 1, 0), 1.9f), "no occlusion up through the hole");
    CHECK(pm_accel_occluded(a, v3(0.5f, 0.01f, 0.2f), v3(0, 1, 0), 1.9f), "occluded by the opaque half");

    /* Eye pass below the pane: the floor is lit as if nothing were there behind the hole and black in
     * the opaque half's shadow. */
    pm_camera below = sb_camera(v3(0, 0.9f, 0), v3(0, 0, 0), v3(0, 0, -1), 110.f);
    pm_session *r = render(&s, a, &below, 256, 2);
    if (!r) return;
    const pm_film *f = pm_session_film(r);
    int lit_pixels[4][2] = {{3, 16}, {8, 4}, {12, 28}, {6, 20}}, shadow_pixels[4][2] = {{28, 16}, {20, 4}, {24, 27}, {18, 16}};
    for (int k = 0; k < 4; k++) {
        int x = lit_pixels[k][0], y = lit_pixels[k][1];
        double want = expected_pixel(&below, x, y, PM_ALPHA_MASK, 1.f);
        CHECK(want > 0.05, "test set-up: pixel %d,%d sees lit floor (%g)", x, y, want);
        CHECK_NEAR(pixel_direct(f, x, y), want, 0.01, 0, "floor behind the hole: unoccluded direct light");
        x = shadow_pixels[k][0], y = shadow_pixels[k][1];
        CHECK(expected_pixel(&below, x, y, PM_ALPHA_MASK, 1.f) == 0.0, "test set-up: pixel %d,%d in the shadow", x, y);
        CHECK(pixel_direct(f, x, y) == 0.0, "floor behind the opaque half: no direct light (pixel %d,%d: %g)", x, y,
              pixel_direct(f, x, y));
    }
    pm_session_destroy(r);

    /* Eye pass above: camera rays see the floor through the hole and the pane's top elsewhere. */
    pm_camera above = sb_camera(v3(0, 3, 0.f), v3(0, 0, 0), v3(0, 0, -1), 40.f);
    if (!(r = render(&s, a, &above, 256, 2))) return;
    f = pm_session_film(r);
    int pixels[4][2] = {{5, 16}, {26, 16}, {9, 6}, {22, 25}};
    for (int k = 0; k < 4; k++) {
        int x = pixels[k][0], y = pixels[k][1];
        double want = expected_pixel(&above, x, y, PM_ALPHA_MASK, 1.f);
        CHECK_NEAR(pixel_direct(f, x, y), want, 0.01, 0, x < W / 2 ? "floor seen through the hole" : "pane seen at its opaque half");
    }
    double floor_through = expected_pixel(&above, 5, 16, PM_ALPHA_MASK, 1.f), pane_top = expected_pixel(&above, 26, 16, PM_ALPHA_MASK, 1.f);
    CHECK(fabs(floor_through - pane_top) > 0.2 * pane_top, "test set-up: floor and pane differ (%g, %g)", floor_through, pane_top);
    pm_session_destroy(r);

    /* Photons: first-hit power on the floor behind the hole is I x (solid angle of the hole,
     * [-1, 0] x [-1, 1] one unit below the light: two unit corner squares, 2 atan(1/sqrt 3) = pi/3);
     * behind the opaque half no photon arrives directly. */
    pm_photon_maps maps;
    if (trace_photons(&s, a, 400000, &maps)) {
        size_t through, blocked;
        double p_through = floor_direct_power(&maps.global, -2.f, 0.f, &through);
        double p_blocked = floor_direct_power(&maps.global, 0.f, 2.f, &blocked);
        double want = light_i * 2.0 * corner_rectangle_solid_angle(1.0, 1.0, 1.0);
        CHECK_NEAR(p_through, want, 0.02, 0, "photon power on the floor through the hole = I x solid angle");
        CHECK(blocked == 0 && p_blocked == 0.0, "no direct photon behind the opaque half (%zu, power %g; %zu through)",
              blocked, p_blocked, through);
        pm_photon_maps_free(&maps);
    } else CHECK(0, "photon pass failed");
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

/* BLEND: a pane of alpha a transmits 1 - a of the light, measured by photons and by the eye pass's
 * shadow rays; a camera ray and the shadow ray from where it lands decide independently. */
static void blend_pane(void) {
    const float alpha = 0.3f;
    pm_scene s;
    build(&s, PM_ALPHA_BLEND, alpha);
    CHECK(s.analysis.has_non_opaque, "analysis: the BLEND pane is non-opaque");
    pm_accel *a = make_accel(&s);
    if (!a) return;
    CHECK(pm_accel_alpha_tested_triangles(a) == 2, "BLEND pane alpha tested (%u)", pm_accel_alpha_tested_triangles(a));

    /* Photons: direct power on the floor in the pane's shadow (|x|, |z| < 2) = (1 - a) I x the
     * pane's solid angle (four unit corner squares, 2 pi / 3). 400k photons: about 47k arrive,
     * binomial noise 0.45%; tolerance 2%. */
    pm_photon_maps maps;
    if (trace_photons(&s, a, 400000, &maps)) {
        size_t through;
        double power = floor_direct_power(&maps.global, -2.f, 2.f, &through);
        double open = light_i * 4.0 * corner_rectangle_solid_angle(1.0, 1.0, 1.0);
        CHECK_NEAR(power / open, 1.0 - alpha, 0.02, 0, "photons: the pane transmits 1 - alpha of the light's power");
        printf("blend photons: %zu arrived, transmitted fraction %.4f (want %.4f)\n", through, power / open, 1.0 - alpha);
        pm_photon_maps_free(&maps);
    } else CHECK(0, "photon pass failed");

    /* Eye pass below the pane: every visible floor point is in its shadow, so the direct light is
     * (1 - a) of the unoccluded value; summed over the image (1024 pixels x 256 samples, noise
     * about 0.2%), tolerance 1.5%. */
    pm_camera below = sb_camera(v3(0, 0.9f, 0), v3(0, 0, 0), v3(0, 0, -1), 110.f);
    pm_session *r = render(&s, a, &below, 256, 2);
    if (!r) return;
    const pm_film *f = pm_session_film(r);
    double got = 0.0, unoccluded = 0.0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            got += pixel_direct(f, x, y);
            unoccluded += expected_pixel(&below, x, y, PM_ALPHA_BLEND, 0.f); /* a pane of alpha 0: none */
        }
    CHECK_NEAR(got / unoccluded, 1.0 - alpha, 0.015, 0, "shadow rays: the pane transmits 1 - alpha of the direct light");
    printf("blend direct light: transmitted fraction %.4f (want %.4f)\n", got / unoccluded, 1.0 - alpha);
    pm_session_destroy(r);

    /* Eye pass above: alpha x the pane + (1 - a) x the floor, itself lit through the pane with
     * 1 - a: (1 - a)^2 only if the camera ray and the shadow ray decide independently. */
    pm_camera above = sb_camera(v3(0, 3, 0.f), v3(0, 0, 0), v3(0, 0, -1), 40.f);
    if (!(r = render(&s, a, &above, 256, 2))) return;
    f = pm_session_film(r);
    double want = 0.0;
    got = 0.0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            got += pixel_direct(f, x, y);
            want += expected_pixel(&above, x, y, PM_ALPHA_BLEND, alpha);
        }
    CHECK_NEAR(got, want, 0.015, 0, "seen through the pane: a L_pane + (1-a)^2 L_floor (independent crossings)");
    pm_session *one = render(&s, a, &above, 4, 1), *two = render(&s, a, &above, 4, 2);
    CHECK(one && two && memcmp(pm_session_film(one)->sum[PM_DIRECT], pm_session_film(two)->sum[PM_DIRECT], 3 * sizeof(float) * W * H) == 0,
          "BLEND decisions do not depend on the thread count");
    pm_session_destroy(r);
    pm_session_destroy(one);
    pm_session_destroy(two);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

/* An opaque scene, and a MASK material that can never cut (alpha 1, no texture), install no filter. */
static void opaque_has_no_filter(void) {
    for (int variant = 0; variant < 3; variant++) {
        pm_scene s;
        build(&s, variant == 2 ? PM_ALPHA_BLEND : PM_ALPHA_OPAQUE, 1.f);
        if (variant == 1) {
            s.materials[1].alpha_mode = PM_ALPHA_MASK;
            s.materials[1].alpha = 1.f;
            pm_scene_finalize(&s, false, NULL);
        }
        CHECK(!s.analysis.has_non_opaque, "variant %d: analysis finds nothing see-through", variant);
        pm_accel *a = make_accel(&s);
        if (a) {
            CHECK(pm_accel_alpha_tested_triangles(a) == 0, "variant %d: no alpha filter (%u triangles)", variant,
                  pm_accel_alpha_tested_triangles(a));
            pm_hit h;
            CHECK(pm_accel_intersect(a, v3(-0.5f, 3, 0.2f), v3(0, -1, 0), INFINITY, &h) && fabsf(h.t - 2.f) < 1e-4f &&
                      h.tri >= 2,
                  "variant %d: the pane blocks (t %g, triangle %u)", variant, h.t, h.tri);
            pm_accel_destroy(a);
        }
        pm_scene_free(&s);
    }
}

/* The scene's one texture, `width` x 1 texels of the given alphas (black: the lamp's colour is its
 * emission), clamped; vertices from `first` on get u = (x + 1) / 2, so the texture spans |x| <= 1. */
static void lamp_alpha_texture(pm_scene *s, uint32_t first, int width, const uint8_t *alphas) {
    s->uvs = calloc(2 * (size_t)s->vertex_count, sizeof(float));
    for (uint32_t i = first; i < s->vertex_count; i++) s->uvs[2 * i] = (s->positions[i].x + 1.f) * 0.5f;
    s->textures = calloc(1, sizeof *s->textures);
    s->texture_count = 1;
    pm_texture *t = s->textures;
    t->width = width;
    t->height = 1;
    t->wrap_s = t->wrap_t = PM_WRAP_CLAMP;
    t->rgba = calloc(4 * (size_t)width, 1);
    for (int i = 0; i < width; i++) t->rgba[4 * i + 3] = alphas[i];
}

/* A lamp (a quad at y = 2.5 facing down, in a room 6 x 3 x 6) with cut-outs lights the room as
 * what it keeps: with a MASK texture cutting its left half away, as an opaque lamp of its right
 * half; BLEND at alpha 0.5, as an opaque lamp of half its emission. Light samples and photons pick
 * points on an emitter by area, so a cut-out point must send nothing; a ray that hits the lamp
 * has passed the alpha test already. The progressive default's direct layers, seen by a camera
 * under the lamp looking down, must agree, and for MASK the indirect layers too (a BLEND lamp also
 * lets half the room's light through where an opaque one absorbs it: 10% more indirect light,
 * rightly). Before emitters knew their cut-outs, both lamps lit the floor twice as brightly. */
static void emissive_cutout(void) {
    enum { SIDE = 32 };
    const char *names[2] = {"MASK, left half cut", "BLEND alpha 0.5"};
    for (int variant = 0; variant < 2; variant++) {
        double mean[2][2] = {{0, 0}, {0, 0}}; /* [cut-out lamp, its opaque equal][direct, indirect] */
        for (int k = 0; k < 2; k++) {
            pm_scene s;
            memset(&s, 0, sizeof s);
            uint32_t walls = sb_lambert(&s, v3s(rho_floor));
            sb_box(&s, v3(-3.f, 0.f, -3.f), v3(3.f, 3.f, 3.f), walls, true);
            float x0 = (variant == 0 && k == 1) ? 0.f : -1.f; /* the MASK lamp's equal: its right half */
            vec3 emission = v3s(variant == 1 && k == 1 ? 2.f : 4.f); /* the BLEND lamp's: half the light */
            uint32_t lamp = sb_material(&s, v3s(0.f), 0, 1, 0, emission, false);
            uint32_t first_lamp_vertex = s.vertex_count;
            sb_quad(&s, v3(x0, 2.5f, -1.f), v3(1.f, 2.5f, -1.f), v3(1.f, 2.5f, 1.f), v3(x0, 2.5f, 1.f), lamp);
            if (k == 0) {
                pm_material *m = &s.materials[lamp];
                if (variant == 0) {
                    const uint8_t alphas[2] = {0, 255};
                    lamp_alpha_texture(&s, first_lamp_vertex, 2, alphas);
                    m->base_color_texture = 0;
                    m->alpha_mode = PM_ALPHA_MASK;
                } else {
                    m->alpha_mode = PM_ALPHA_BLEND;
                    m->alpha = 0.5f;
                }
            }
            pm_accel *a = sb_finish(&s);
            if (!a) return;
            pm_camera cam = sb_camera(v3(0.f, 1.f, 0.f), v3(0.f, 0.f, 0.f), v3(0.f, 0.f, -1.f), 90.f);
            pm_progressive_settings ps = default_settings(SIDE, SIDE);
            session r;
            float *img = malloc(sizeof(float) * 3 * SIDE * SIDE);
            if (start(&r, &s, a, &cam, SIDE, SIDE, &ps) && iterate(&r, 64)) {
                pm_film_resolve(r.film, PM_DIRECT, img);
                mean[k][0] = mean_of(img, 3 * SIDE * SIDE);
                pm_film_resolve(r.film, PM_INDIRECT, img);
                mean[k][1] = mean_of(img, 3 * SIDE * SIDE);
            }
            stop(&r);
            free(img);
            pm_accel_destroy(a);
            pm_scene_free(&s);
        }
        printf("emitter %s: direct %.5f against its opaque equal's %.5f, indirect %.5f against %.5f\n", names[variant],
               mean[0][0], mean[1][0], mean[0][1], mean[1][1]);
        CHECK(mean[1][0] > 0.0 && fabs(mean[0][0] / mean[1][0] - 1.0) < 0.02, "%s: direct light as the lamp it keeps",
              names[variant]);
        if (variant == 0)
            CHECK(mean[1][1] > 0.0 && fabs(mean[0][1] / mean[1][1] - 1.0) < 0.04, "%s: indirect light as the lamp it keeps",
                  names[variant]);
    }
}

/* A lamp that a MASK texture of 32 texels covers only along a strip 1/32 wide: the 64 points that
 * average an emitter's power all miss it, and it must stay a light (it did not, for a while). */
static void thin_emitter_strip(void) {
    pm_scene s;
    memset(&s, 0, sizeof s);
    uint32_t lamp = sb_material(&s, v3s(0.f), 0, 1, 0, v3s(4.f), false);
    sb_quad(&s, v3(-1.f, 2.5f, -1.f), v3(1.f, 2.5f, -1.f), v3(1.f, 2.5f, 1.f), v3(-1.f, 2.5f, 1.f), lamp);
    uint8_t alphas[32] = {0};
    alphas[3] = 255; /* texel 3 alone is opaque */
    lamp_alpha_texture(&s, 0, 32, alphas);
    s.materials[lamp].base_color_texture = 0;
    s.materials[lamp].alpha_mode = PM_ALPHA_MASK;
    pm_scene_finalize(&s, false, NULL);
    printf("lamp covered along a thin strip: %u emitter triangles\n", s.emitter_count);
    CHECK(s.emitter_count == 2 && !v3_is_black(s.emitter_radiance[0]), "a thinly covered lamp stays a light (%u)",
          s.emitter_count);
    pm_scene_free(&s);
}

int main(void) {
    thin_emitter_strip();
    emissive_cutout();
    mask_cutout();
    blend_pane();
    opaque_has_no_filter();
    return pm_test_done("test_alpha");
}

/* test_hard_geometry.c: hard-case scenes of issue 11, each with its criterion printed and measured: thin and coplanar walls do not leak, ior 1.0 glass is invisible, ior 2.4 glass (total internal reflection) keeps a furnace at 1, a point light inside a glass ball lights the floor as the bare light does. */
#include <stdlib.h>
#include <string.h>

#include "eye.h"
#include "progressive_harness.h"
#include "scatter.h"

enum { W = 32, H = 32 };

static double last_component_sum[PM_COMPONENT_COUNT]; /* of the last render_total's image, per component */

/* Renders `iterations` progressive iterations and returns the resolved total (3*W*H floats). */
static float *render_total(const pm_scene *s, const pm_accel *a, const pm_camera *cam, uint64_t photons, int iterations) {
    pm_progressive_settings ps = default_settings(W, H);
    ps.photons = ps.caustic_photons = photons;
    session r;
    if (!start(&r, s, a, cam, W, H, &ps)) return NULL;
    float *img = NULL;
    if (iterate(&r, iterations)) {
        img = malloc(sizeof(float) * 3 * W * H);
        for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
            pm_film_resolve(r.film, (pm_component)c, img);
            last_component_sum[c] = 0;
            for (size_t i = 0; i < 3 * W * H; i++) last_component_sum[c] += img[i];
        }
        pm_film_resolve_total(r.film, img);
    }
    stop(&r);
    return img;
}

static size_t count_nonfinite(const float *img) {
    size_t n = 0;
    for (size_t i = 0; i < 3 * W * H; i++) n += !isfinite(img[i]);
    return n;
}

/* ---- thin and coplanar walls
 * A closed room split in two by a wall; a point light and an emissive patch in the left half,
 * the camera in the right half. Every light path into the right half must cross the wall, so
 * its image must be exactly black; the same camera without the wall sees light (the control). */
typedef enum { WALL_NONE, WALL_THIN_BOX, WALL_SHEET, WALL_COPLANAR } wall_kind;

static void build_split_room(pm_scene *s, wall_kind wall, float thickness) {
    memset(s, 0, sizeof *s);
    uint32_t white = sb_lambert(s, v3s(0.8f)), grey = sb_lambert(s, v3s(0.5f)), red = sb_lambert(s, v3(0.7f, 0.1f, 0.1f));
    uint32_t lamp = sb_material(s, v3s(0.f), 0, 1, 0, v3s(20.f), false);
    sb_box(s, v3(-2, 0, -1), v3(2, 2, 1), white, true);
    /* the left floor doubled by a coplanar, overlapping grey quad (z-fighting geometry) */
    sb_quad(s, v3(-2, 0, -1), v3(-2, 0, 1), v3(0, 0, 1), v3(0, 0, -1), grey);
    sb_quad(s, v3(-1.2f, 1.99f, -0.2f), v3(-0.8f, 1.99f, -0.2f), v3(-0.8f, 1.99f, 0.2f), v3(-1.2f, 1.99f, 0.2f), lamp);
    sb_point_light(s, v3(-1, 1, 0.3f), v3s(3.f));
    float h = 0.5f * thickness;
    switch (wall) {
    case WALL_NONE: break;
    case WALL_THIN_BOX: /* a closed slab, faces out, reaching into the floor, ceiling and side walls */
        sb_box(s, v3(-h, -0.01f, -1.01f), v3(h, 2.01f, 1.01f), white, false);
        break;
    case WALL_SHEET: { /* one double-sided sheet of zero thickness */
        uint32_t sheet = sb_material(s, v3s(0.8f), 0, 1, 0, v3s(0), true);
        sb_quad(s, v3(0, -0.01f, -1.01f), v3(0, -0.01f, 1.01f), v3(0, 2.01f, 1.01f), v3(0, 2.01f, -1.01f), sheet);
        break;
    }
    case WALL_COPLANAR: /* two sheets in the same plane facing opposite ways, overlapping half-way, plus a red patch on the lit face */
        sb_quad(s, v3(0, -0.01f, -1.01f), v3(0, -0.01f, 0.5f), v3(0, 2.01f, 0.5f), v3(0, 2.01f, -1.01f), white);
        sb_quad(s, v3(0, -0.01f, -0.5f), v3(0, 2.01f, -0.5f), v3(0, 2.01f, 1.01f), v3(0, -0.01f, 1.01f), white);
        sb_quad(s, v3(0, -0.01f, -1.01f), v3(0, -0.01f, 1.01f), v3(0, 2.01f, 1.01f), v3(0, 2.01f, -1.01f), red);
        sb_quad(s, v3(0, -0.01f, -1.01f), v3(0, 2.01f, -1.01f), v3(0, 2.01f, 1.01f), v3(0, -0.01f, 1.01f), white);
        break;
    }
}

static double image_sum(const float *img) { return mean_of(img, 3 * W * H) * (3 * W * H); }

/* Sums of the dark view's components after `iterations`: [0] direct + specular + caustic, [1] indirect. */
static void dark_components(const pm_scene *s, const pm_accel *a, const pm_camera *cam, double initial_radius,
                            int iterations, double sums[2]) {
    pm_progressive_settings ps = default_settings(W, H);
    ps.photons = ps.caustic_photons = 20000;
    ps.initial_radius = initial_radius;
    session r;
    sums[0] = sums[1] = -1;
    if (!start(&r, s, a, cam, W, H, &ps)) return;
    if (iterate(&r, iterations)) {
        float *layer = malloc(sizeof(float) * 3 * W * H);
        sums[0] = sums[1] = 0;
        for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
            pm_film_resolve(r.film, (pm_component)c, layer);
            sums[c == PM_INDIRECT] += image_sum(layer);
        }
        free(layer);
    }
    stop(&r);
}

/* Stored photons (both maps) with x beyond `limit`: photons that crossed the wall. */
static size_t photons_beyond(const pm_scene *s, const pm_accel *a, float limit, size_t *stored) {
    pm_photon_settings ps = {.global_photons = 40000, .caustic_photons = 0, .seed = 3, .threads = 2, .max_bounces = 64};
    pm_photon_maps maps;
    size_t beyond = 0;
    *stored = 0;
    CHECK(pm_photon_maps_build(s, a, &ps, &maps, NULL), "photon maps");
    const pm_kdtree *trees[2] = {&maps.global, &maps.caustic};
    for (int t = 0; t < 2; t++)
        for (size_t i = 0; i < trees[t]->count; i++) {
            (*stored)++;
            if (trees[t]->photons[i].pos[0] > limit) beyond++;
        }
    pm_photon_maps_free(&maps);
    return beyond;
}

static void thin_walls(void) {
    printf("criterion (thin walls): with every light left of a wall, (a) no stored photon lies right of it, (b) the right "
           "half's direct, specular and caustic light is exactly 0, (c) so is its indirect light, though photon discs reach "
           "across the wall where it meets floor, ceiling and sides (they are clipped at the wall), and with a radius "
           "below the wall's thickness; without the wall the right half is lit\n");
    pm_camera dark_view = sb_camera(v3(1.9f, 1, 0), v3(-1, 0.8f, 0), v3(0, 1, 0), 80.f);
    pm_camera lit_view = sb_camera(v3(-1.9f, 1, 0), v3(1, 0.8f, 0), v3(0, 1, 0), 80.f);
    const struct { wall_kind kind; float thickness; const char *name; } cases[] = {
        {WALL_NONE, 0, "no wall (control)"}, {WALL_THIN_BOX, 1e-2f, "slab 1e-2 thick"},
        {WALL_THIN_BOX, 1e-5f, "slab 1e-5 thick"}, {WALL_SHEET, 0, "double-sided sheet"},
        {WALL_COPLANAR, 0, "coplanar overlapping sheets"}};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        pm_scene s;
        build_split_room(&s, cases[c].kind, cases[c].thickness);
        pm_accel *a = sb_finish(&s);
        if (!a) { pm_scene_free(&s); continue; }
        size_t stored = 0, beyond = photons_beyond(&s, a, 0.5f * cases[c].thickness, &stored);
        double dark[2];
        dark_components(&s, a, &dark_view, 0.0, 3, dark);
        float *lit = render_total(&s, a, &lit_view, 20000, 3);
        double lit_sum = lit ? image_sum(lit) : 0;
        printf("  %-28s photons right of the wall %zu of %zu; right half: direct+specular+caustic %.6g, indirect %.6g "
               "(%.3f%% of the left half's %.6g)\n", cases[c].name, beyond, stored, dark[0], dark[1],
               100.0 * dark[1] / lit_sum, lit_sum);
        CHECK(lit_sum > 1.0, "%s: the lit half is lit (%g)", cases[c].name, lit_sum);
        if (cases[c].kind == WALL_NONE) {
            CHECK(beyond > stored / 10, "control: without the wall photons reach the right half (%zu)", beyond);
            CHECK(dark[0] > 0.1 * lit_sum, "control: without the wall the right half is lit (%g)", dark[0]);
        } else {
            CHECK(stored > 1000 && beyond == 0, "%s: %zu photons crossed the wall", cases[c].name, beyond);
            CHECK(dark[0] == 0.0, "%s: direct, specular or caustic light leaks through the wall (%g)", cases[c].name, dark[0]);
            /* the estimates are clipped at the wall (clip.h): not a trace of the lit half's photons */
            CHECK(dark[1] == 0.0, "%s: indirect light leaks through the wall (%g; the lit half has %g)", cases[c].name,
                  dark[1], lit_sum);
        }
        if (cases[c].kind == WALL_THIN_BOX && cases[c].thickness >= 1e-2f) {
            double small[2];
            dark_components(&s, a, &dark_view, 0.4 * cases[c].thickness, 3, small);
            printf("  %-28s with the initial radius 0.4 x its thickness: right half %.6g + %.6g\n", cases[c].name,
                   small[0], small[1]);
            CHECK(small[0] == 0.0 && small[1] == 0.0, "%s: a radius below the thickness still leaks (%g, %g)",
                  cases[c].name, small[0], small[1]);
        }
        free(lit);
        pm_accel_destroy(a);
        pm_scene_free(&s);
    }
}

/* ---- glass of ior 1.0 and 2.4 */

/* A floor and a back wall under a point light; optionally a glass ball between them and the
 * camera, out of the light's way (no shadow ray crosses it). */
static pm_accel *build_glass_scene(pm_scene *s, bool ball, float ior) {
    memset(s, 0, sizeof *s);
    uint32_t floor = sb_lambert(s, v3(0.8f, 0.7f, 0.5f)), wall = sb_lambert(s, v3(0.3f, 0.5f, 0.8f));
    sb_quad(s, v3(-3, 0, -2), v3(-3, 0, 1.2f), v3(3, 0, 1.2f), v3(3, 0, -2), floor);
    sb_quad(s, v3(-3, 0, -2), v3(3, 0, -2), v3(3, 3, -2), v3(-3, 3, -2), wall);
    sb_point_light(s, v3(0.5f, 3, -1.5f), v3s(10.f));
    if (ball) {
        uint32_t glass = sb_material(s, v3s(1.f), 0, 0, 1, v3s(0), false);
        s->materials[glass].ior = ior;
        sb_sphere(s, v3(0, 0.9f, 1.7f), 0.45f, 24, glass);
    }
    return sb_finish(s);
}

static void glass_ior_one(void) {
    printf("criterion (ior 1.0): a glass ball of ior 1.0 in front of the camera is invisible: the image with it equals "
           "the image without it (direct and specular light, no photons: relMSE < 1e-4, mean within 0.1%%)\n");
    pm_camera cam = sb_camera(v3(0, 1.1f, 3.2f), v3(0, 0.6f, 0), v3(0, 1, 0), 50.f);
    pm_scene with, without;
    pm_accel *aw = build_glass_scene(&with, true, 1.0f), *ao = build_glass_scene(&without, false, 1.0f);
    float *img_with = aw ? render_total(&with, aw, &cam, 0, 4) : NULL;
    float *img_without = ao ? render_total(&without, ao, &cam, 0, 4) : NULL;
    if (img_with && img_without) {
        /* the pixels that see the ball at all, found by tracing the camera rays */
        size_t ball_pixels = 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                vec3 o, d;
                pm_camera_ray(&cam, W, H, x + 0.5f, y + 0.5f, &o, &d);
                pm_hit hit;
                if (pm_accel_intersect(aw, o, d, 1e30f, &hit) && with.triangle_material[hit.tri] == 2) ball_pixels++;
            }
        float *planes[3];
        for (int c = 0; c < 3; c++) {
            planes[c] = malloc(sizeof(float) * W * H);
            for (int i = 0; i < W * H; i++) planes[c][i] = img_without[3 * i + c];
        }
        pm_image_error e = pm_image_compare(img_with, (const float *const *)planes, (size_t)W * H, NULL);
        double ratio = (e.ours[0] + e.ours[1] + e.ours[2]) / (e.ref[0] + e.ref[1] + e.ref[2]);
        printf("  ball covers %zu of %d pixels; relMSE %.3g, mean ratio %.6f\n", ball_pixels, W * H, e.relmse, ratio);
        CHECK(ball_pixels > (size_t)W * H / 10, "the ball covers a good part of the view (%zu pixels)", ball_pixels);
        CHECK(e.relmse < 1e-4, "ior 1.0 glass changes the image: relMSE %g", e.relmse);
        CHECK_NEAR(ratio, 1.0, 1e-3, 0, "ior 1.0: mean with the ball / without");
        for (int c = 0; c < 3; c++) free(planes[c]);
    }
    free(img_with);
    free(img_without);
    pm_accel_destroy(aw);
    pm_accel_destroy(ao);
    pm_scene_free(&with);
    pm_scene_free(&without);
}

/* A surface record of glass (ior n) facing +z at the origin, for pm_scatter_specular. */
static pm_surface glass_surface(float n) {
    pm_surface sf;
    memset(&sf, 0, sizeof sf);
    sf.ng = sf.ns = v3(0, 0, 1);
    sf.kt = v3s(1.f);
    sf.ior = n;
    sf.centroid = v3(0.1f, 0.1f, 0);
    return sf;
}

static void glass_ior_high(void) {
    const float n = 2.4f;
    double critical = asin(1.0 / n) * 180.0 / PM_PI;
    printf("criterion (ior 2.4, scattering): from inside, past the critical angle %.2f deg every sample reflects "
           "(total internal reflection, weight 1); head-on the reflected fraction is ((n-1)/(n+1))^2 = %.5f\n",
           critical, pow((n - 1) / (n + 1), 2));
    pm_surface sf = glass_surface(n);
    pm_rng rng = pm_rng_for(7, 0, 0);
    const int samples = 20000;
    /* arriving from inside (below the face) at 30 degrees from the normal: beyond the critical angle */
    double angle = 30.0 * PM_PI / 180.0;
    vec3 d = v3((float)sin(angle), 0, (float)cos(angle));
    int reflected = 0, bad_weight = 0;
    for (int i = 0; i < samples; i++) {
        pm_specular_sample out;
        if (!pm_scatter_specular(&sf, d, &rng, 1.f, &out)) continue;
        if (!out.transmitted && fabsf(out.direction.z + d.z) < 1e-6f && fabsf(out.direction.x - d.x) < 1e-6f) reflected++;
        if (fabsf(out.weight.x - 1.f) > 1e-6f || out.radiance_scale != 1.f) bad_weight++;
    }
    printf("  30 deg from inside: %d of %d reflected\n", reflected, samples);
    CHECK(reflected == samples && bad_weight == 0, "total internal reflection: %d of %d reflected, %d bad weights", reflected,
          samples, bad_weight);
    /* head-on from inside: Fresnel at normal incidence */
    int back = 0;
    for (int i = 0; i < samples; i++) {
        pm_specular_sample out;
        if (pm_scatter_specular(&sf, v3(0, 0, 1), &rng, 1.f, &out) && !out.transmitted) back++;
    }
    double want = pow((n - 1) / (n + 1), 2), sigma = sqrt(want * (1 - want) / samples);
    printf("  head-on from inside: reflected fraction %.5f (3 sigma %.5f)\n", (double)back / samples, 3 * sigma);
    CHECK_NEAR((double)back / samples, want, 0, 3 * sigma, "ior 2.4 reflectance at normal incidence");

    printf("criterion (ior 2.4, furnace): a lossless ior-2.4 cube (rays entering one face meet the side faces past the "
           "critical angle) and ball in a uniform environment of radiance 1 read 1 on average (within 4 standard errors)\n");
    pm_scene s;
    memset(&s, 0, sizeof s);
    uint32_t glass = sb_material(&s, v3s(1.f), 0, 0, 1, v3s(0), false);
    s.materials[glass].ior = n;
    sb_box(&s, v3(-0.9f, -0.4f, -0.4f), v3(-0.1f, 0.4f, 0.4f), glass, false);
    sb_sphere(&s, v3(0.5f, 0, 0), 0.4f, 24, glass);
    pm_scene_finalize(&s, false, NULL);
    pm_scene_set_sky(&s, true, v3s(1.f), NULL);
    char err[256];
    pm_accel *a = pm_accel_create(&s, err, sizeof err);
    CHECK(a != NULL, "accel: %s", err);
    if (a) {
        pm_camera cam = sb_camera(v3(0.4f, 1.3f, 1.8f), v3(0.1f, 0, 0), v3(0, 1, 0), 50.f);
        const int iterations = 16;
        float *img = render_total(&s, a, &cam, 0, iterations);
        if (img) {
            /* eye paths past depth 4 meet roulette (survival 0.95 at throughput 1): single samples are
             * 0 or 1/0.95^k, unbiased, so the mean is tested against its standard error */
            double mean = 0, square = 0, lowest = 1e30;
            size_t through_sky = 0;
            for (int i = 0; i < W * H; i++) {
                double v = img[3 * i + 1];
                mean += v;
                square += v * v;
                lowest = fmin(lowest, v);
                through_sky += v == 1.0;
            }
            mean /= W * H;
            double se = sqrt(fmax(0.0, square / (W * H) - mean * mean) / (W * H));
            printf("  furnace: mean %.5f, standard error %.5f, %zu pixels exactly 1, lowest pixel %.4f, non-finite %zu\n",
                   mean, se, through_sky, lowest, count_nonfinite(img));
            CHECK(count_nonfinite(img) == 0 && lowest >= 0.0, "ior 2.4 furnace: finite, non-negative pixels");
            CHECK(se < 0.01, "the furnace mean is measured to 1%% (standard error %g)", se);
            CHECK_NEAR(mean, 1.0, 0, 4 * se + 1e-4, "ior 2.4 furnace mean (4 standard errors)");
            free(img);
        }
        pm_accel_destroy(a);
    }
    pm_scene_free(&s);
}

/* ---- a point light inside a glass ball
 * The ball's vertex normals are radial and the light sits at its centre: every ray meets the
 * glass head-on, so all the light leaves undeviated (Fresnel reflections cross the centre and
 * leave on the other side). The floor must receive what the bare light gives it, now entirely
 * as caustic photons. */
static pm_accel *build_light_in_ball(pm_scene *s, bool ball) {
    memset(s, 0, sizeof *s);
    uint32_t floor = sb_lambert(s, v3s(0.5f));
    sb_quad(s, v3(-4, 0, -4), v3(-4, 0, 4), v3(4, 0, 4), v3(4, 0, -4), floor);
    vec3 centre = v3(0, 1, 0);
    sb_point_light(s, centre, v3s(2.f));
    if (ball) {
        uint32_t glass = sb_material(s, v3s(1.f), 0, 0, 1, v3s(0), false);
        uint32_t first = s->vertex_count;
        sb_sphere(s, centre, 0.3f, 32, glass);
        for (uint32_t v = first; v < s->vertex_count; v++) s->normals[v] = v3_normalize(v3_sub(s->positions[v], centre));
    }
    return sb_finish(s);
}

static void light_in_glass_ball(void) {
    printf("criterion (light in a glass ball): the image is finite and the floor around the ball is as bright as under the "
           "bare light (mean over the floor pixels within 2%%), all of it from caustic photons (direct 0)\n");
    pm_camera cam = sb_camera(v3(0, 2.4f, 0.01f), v3(0, 0, 0), v3(0, 0, -1), 70.f);
    pm_scene with, bare;
    pm_accel *aw = build_light_in_ball(&with, true), *ab = build_light_in_ball(&bare, false);
    float *img_with = aw ? render_total(&with, aw, &cam, 40000, 6) : NULL;
    double direct_with = last_component_sum[PM_DIRECT], caustic_with = last_component_sum[PM_CAUSTIC];
    float *img_bare = ab ? render_total(&bare, ab, &cam, 40000, 6) : NULL;
    if (img_with && img_bare) {
        double sum_with = 0, sum_bare = 0;
        size_t floor_pixels = 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                vec3 o, d;
                pm_camera_ray(&cam, W, H, x + 0.5f, y + 0.5f, &o, &d);
                pm_hit hit;
                /* whole pixels clear of the ball: its silhouette plus a pixel's margin */
                bool clear = true;
                for (int k = 0; k < 9 && clear; k++) {
                    pm_camera_ray(&cam, W, H, x + (k % 3) * 0.5f, y + (k / 3) * 0.5f, &o, &d);
                    clear = pm_accel_intersect(aw, o, d, 1e30f, &hit) && with.triangle_material[hit.tri] == 0;
                }
                if (!clear) continue;
                floor_pixels++;
                for (int c = 0; c < 3; c++) {
                    sum_with += img_with[3 * (y * W + x) + c];
                    sum_bare += img_bare[3 * (y * W + x) + c];
                }
            }
        size_t bad = count_nonfinite(img_with);
        double ratio = sum_with / sum_bare;
        printf("  %zu floor pixels: mean with the ball %.6f, bare light %.6f, ratio %.5f; non-finite %zu\n", floor_pixels,
               sum_with / (3.0 * floor_pixels), sum_bare / (3.0 * floor_pixels), ratio, bad);
        printf("  with the ball: direct %.6g, caustic %.6g (image sums)\n", direct_with, caustic_with);
        CHECK(bad == 0, "the light in the ball gives %zu non-finite values", bad);
        CHECK(direct_with == 0.0 && caustic_with > 0.0, "inside glass the light reaches the floor as caustics only");
        CHECK(floor_pixels > (size_t)W * H / 2, "most of the view is floor (%zu pixels)", floor_pixels);
        CHECK_NEAR(ratio, 1.0, 0.02, 0, "floor brightness, light in the ball / bare light");
    }
    free(img_with);
    free(img_bare);
    pm_accel_destroy(aw);
    pm_accel_destroy(ab);
    pm_scene_free(&with);
    pm_scene_free(&bare);
}

int main(void) {
    thin_walls();
    glass_ior_one();
    glass_ior_high();
    light_in_glass_ball();
    return pm_test_done("test_hard_geometry");
}

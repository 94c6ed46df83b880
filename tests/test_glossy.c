/* test_glossy.c: rough metal spheres (the GGX lobe) against a converged Mitsuba 3 reference, progressive and classic modes.
 *
 * scenes/glossy-spheres.gltf: white metal spheres of roughness 0.3 and 0.7 on a tinted floor
 * under a lamp; tests/ref/glossy_path_64.exr is Mitsuba's path tracer with roughconductor
 * (ideal conductor = white Schlick, GGX alpha = roughness^2; see tests/ref/README.md). The
 * residual difference expected from the models: Mitsuba's Smith term is separable, pmview's
 * height-correlated, which reflects at most 0.2% more at roughness 0.3, and at 0.7 0.6%, 2.7%
 * and 6.7% more at view cosines 0.7, 0.4, 0.2; the sphere tolerances (3-4%) allow for it.
 */
#include <stdlib.h>
#include <string.h>

#include "accel.h"
#include "eye.h"
#include "film.h"
#include "image_io.h"
#include "loader.h"
#include "photonmap.h"
#include "progressive_harness.h"
#include "reference_image.h"
#include "session_harness.h"
#include "testing.h"

enum { W = 64, H = 64, REGIONS = 2 };

/* Pixels whose centre and four corners all see the sphere of the given alpha: its interior, so the
 * silhouette's mixed pixels do not blur the comparison. */
static void sphere_mask(const pm_scene *s, const pm_accel *a, const pm_camera *cam, float alpha, unsigned char *mask) {
    static const float offsets[5][2] = {{0.5f, 0.5f}, {0.02f, 0.02f}, {0.98f, 0.02f}, {0.02f, 0.98f}, {0.98f, 0.98f}};
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            bool all = true;
            for (int k = 0; k < 5 && all; k++) {
                vec3 o, d;
                pm_camera_ray(cam, W, H, x + offsets[k][0], y + offsets[k][1], &o, &d);
                pm_hit h;
                pm_surface sf;
                all = pm_accel_intersect(a, o, d, INFINITY, &h);
                if (all) {
                    pm_scene_surface(s, h.tri, h.b1, h.b2, &sf);
                    all = sf.glossy && fabsf(sf.brdf.alpha - alpha) < 1e-3f;
                }
            }
            mask[y * W + x] = all;
        }
}

static void compare(const char *what, const float *ours, const float *const ref[3], unsigned char *masks[REGIONS],
                    double max_relmse, double max_mean, double max_sphere) {
    pm_image_error e = pm_image_compare(ours, ref, (size_t)W * H, NULL);
    printf("%s: relMSE %.5f, mean ratio R %.4f G %.4f B %.4f\n", what, e.relmse, e.ours[0] / e.ref[0], e.ours[1] / e.ref[1],
           e.ours[2] / e.ref[2]);
    CHECK(e.relmse <= max_relmse, "%s: relMSE %g above %g", what, e.relmse, max_relmse);
    for (int c = 0; c < 3; c++) CHECK_NEAR(e.ours[c], e.ref[c], max_mean, 0, what);
    const char *names[REGIONS] = {"roughness 0.3 sphere", "roughness 0.7 sphere"};
    for (int r = 0; r < REGIONS; r++) {
        pm_image_error m = pm_image_compare(ours, ref, (size_t)W * H, masks[r]);
        double ratio = (m.ours[0] + m.ours[1] + m.ours[2]) / (m.ref[0] + m.ref[1] + m.ref[2]);
        printf("  %s (%zu pixels): mean ratio %.4f, relMSE %.5f\n", names[r], m.pixels, ratio, m.relmse);
        CHECK(m.pixels >= 150, "%s: the sphere covers enough pixels (%zu)", names[r], m.pixels);
        CHECK_NEAR(ratio, 1.0, max_sphere, 0, names[r]);
    }
}

/* scenes/glossy-spheres.gltf, loaded (false, reported, when it cannot be). */
static bool load_spheres(pm_scene *s) {
    pm_load_report rep;
    char err[1024];
    memset(s, 0, sizeof *s);
    bool ok = pm_load_gltf("scenes/glossy-spheres.gltf", true, s, &rep, err, sizeof err);
    CHECK(ok, "%s", err);
    return ok;
}

/* The noise of the default mode where both spheres are smooth metal (roughness 0.1, GGX alpha
 * 0.01): relMSE between the images of two seeds, 128 iterations each. Gather rays that end on such
 * a lobe and read photons there, each weighted by a lobe that peaks at 1/(pi alpha^2), made
 * fireflies on the floor: 0.39 between these seeds; going on through the lobe as near-specular
 * (vertex.h), 0.017 with emitters found by the continuing ray alone, 0.0058 with direct light by MIS
 * at the lobe. */
static void smooth_metal_noise(void) {
    pm_scene s;
    if (!load_spheres(&s)) return;
    for (uint32_t m = 0; m < s.material_count; m++)
        if (s.materials[m].metallic > 0.f) s.materials[m].roughness = 0.1f;
    pm_accel *a = sb_finish(&s);
    pm_camera cam = s.cameras[0];
    float *img[2] = {malloc(sizeof(float) * 3 * W * H), malloc(sizeof(float) * 3 * W * H)};
    bool ok = true;
    for (int k = 0; k < 2; k++) {
        pm_progressive_settings ps = default_settings(W, H);
        ps.seed = 1 + (uint64_t)k;
        session r;
        ok = ok && start(&r, &s, a, &cam, W, H, &ps) && iterate(&r, 128);
        if (ok) pm_film_resolve_total(r.film, img[k]);
        stop(&r);
    }
    CHECK(ok, "both seeds rendered");
    if (ok) {
        float *planes[3];
        for (int c = 0; c < 3; c++) {
            planes[c] = malloc(sizeof(float) * W * H);
            for (int i = 0; i < W * H; i++) planes[c][i] = img[1][3 * i + c];
        }
        pm_image_error e = pm_image_compare(img[0], (const float *const *)planes, (size_t)W * H, NULL);
        printf("roughness 0.1 metal, 128 iterations: relMSE between two seeds %.4f\n", e.relmse);
        CHECK(e.relmse < 0.05, "smooth metal must not make fireflies: relMSE between seeds %g", e.relmse);
        for (int c = 0; c < 3; c++) free(planes[c]);
    }
    free(img[0]);
    free(img[1]);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

/* Light from a point light off a sharp lobe onto the floor (the spheres at roughness 0.3, GGX
 * alpha 0.09, the lamp replaced by a point light): a gather ray that goes on through such a lobe
 * cannot meet a point light; the caustic photons carry it, as off a mirror. The indirect layer against the
 * path tracer's, at 32x32: 0.99 of it; without that shadow ray, 0.67. */
static void point_light_through_lobe(void) {
    enum { SMALL = 32 };
    pm_scene s;
    if (!load_spheres(&s)) return;
    for (uint32_t m = 0; m < s.material_count; m++) {
        if (s.materials[m].metallic > 0.f) s.materials[m].roughness = 0.3f;
        s.materials[m].emission = v3s(0.f);
    }
    sb_point_light(&s, v3(0.f, 2.4f, -0.5f), v3(12.f, 11.4f, 10.8f));
    pm_accel *a = sb_finish(&s);
    CHECK(s.emitter_count == 0 && s.light_count == 1, "the lamp is replaced by a point light");
    pm_camera cam = s.cameras[0];
    float *img = malloc(sizeof(float) * 3 * SMALL * SMALL);
    double mean[3] = {0, 0, 0}; /* default, --indirect photons, path tracer */
    bool ok = true;
    /* the progressive default and --indirect photons, then the path tracer (unbiased, with a
     * shadow ray at every glossy vertex) */
    for (int k = 0; k < 2; k++) {
        pm_progressive_settings ps = default_settings(SMALL, SMALL);
        if (k == 1) ps.indirect = PM_INDIRECT_PHOTONS;
        session r;
        ok = ok && start(&r, &s, a, &cam, SMALL, SMALL, &ps) && iterate(&r, 512);
        if (ok) {
            pm_film_resolve(r.film, PM_INDIRECT, img);
            mean[k] = mean_of(img, 3 * SMALL * SMALL);
        }
        stop(&r);
    }
    pm_session_config config = mode_config(PM_MODE_PATHTRACE, SMALL, SMALL, 2, 2);
    pm_session *traced = ok ? render_session(&s, a, &cam, &config, 2048) : NULL;
    ok = ok && traced;
    if (ok) {
        pm_film_resolve(pm_session_film(traced), PM_INDIRECT, img);
        mean[2] = mean_of(img, 3 * SMALL * SMALL);
    }
    pm_session_destroy(traced);
    CHECK(ok, "the three renders ran");
    double pt = mean[2] > 0.0 ? mean[2] : 1.0;
    printf("point light off roughness 0.3 metal: indirect layer %.5f, with --indirect photons %.5f, path tracer's %.5f "
           "(ratios %.3f, %.3f)\n", mean[0], mean[1], mean[2], mean[0] / pt, mean[1] / pt);
    CHECK(mean[2] > 0.0 && fabs(mean[0] / pt - 1.0) < 0.05, "indirect light via a sharp lobe: ratio %g", mean[0] / pt);
    /* the spheres' visible points start from a radius their curvature bounds (0.74 of the path
     * tracer's with the density radius of 0.99 on spheres of radius 0.5) */
    CHECK(mean[2] > 0.0 && fabs(mean[1] / pt - 1.0) < 0.05, "--indirect photons on curved metal: ratio %g", mean[1] / pt);
    free(img);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

int main(void) {
    point_light_through_lobe();
    smooth_metal_noise();
    pm_reference_image reference;
    if (!load_ref("tests/ref/glossy_path_64.exr", &reference)) return pm_test_done("test_glossy");
    const float *const ref[3] = {reference.rgb[0], reference.rgb[1], reference.rgb[2]};
    CHECK(reference.width == W && reference.height == H, "reference size %dx%d", reference.width, reference.height);
    pm_scene s;
    if (!load_spheres(&s)) return pm_test_done("test_glossy");
    pm_accel *a = sb_finish(&s);
    CHECK(s.analysis.has_glossy && !s.analysis.has_mirror, "the spheres are glossy, not mirrors");
    pm_camera cam = s.cameras[0];
    unsigned char *masks[REGIONS] = {malloc(W * H), malloc(W * H)};
    sphere_mask(&s, a, &cam, 0.09f, masks[0]);
    sphere_mask(&s, a, &cam, 0.49f, masks[1]);
    float *img = malloc(sizeof(float) * 3 * W * H);

    /* the default mode with final gathering, a fixed number of iterations. Paths go on through the
     * roughness 0.3 sphere's near-specular lobe (vertex.h): reading photons there instead, each
     * weighted by the lobe, gives relMSE 0.0026 (speckles on the floor beside it), gather rays alone
     * going on 0.0015, every path going on with direct light by MIS at the lobe 0.00087 */
    pm_progressive_settings ps = default_settings(W, H);
    session r;
    if (start(&r, &s, a, &cam, W, H, &ps) && iterate(&r, 512)) {
        pm_film_resolve_total(r.film, img);
        compare("progressive, 512 iterations, vs Mitsuba path", img, ref, masks, 0.002, 0.02, 0.03);
    }
    stop(&r);

    /* indirect light from photons at the visible points: each photon weighted by the lobe. Seeds
     * 1-5 at 256 iterations: relMSE 0.00087-0.00099, channel means within 0.45%, the spheres 0.976
     * to 0.999 and 1.003 to 1.012 of the reference's */
    ps.indirect = PM_INDIRECT_PHOTONS;
    if (start(&r, &s, a, &cam, W, H, &ps) && iterate(&r, 256)) {
        pm_film_resolve_total(r.film, img);
        compare("progressive --indirect photons, 256 iterations", img, ref, masks, 0.02, 0.03, 0.04);
    }
    stop(&r);

    /* the classic mode: maps built once, gather rays sampled from the lobe */
    pm_photon_settings phs = {.global_photons = 200000, .caustic_photons = 0, .seed = 1, .threads = 2, .max_bounces = 32,
                              .projection_maps = true, .irradiance_stride = 4,
                              .irradiance_estimate = {PM_KERNEL_DISC, 64, 0.1f * s.ray_scale, 7u}};
    pm_session_config config = mode_config(PM_MODE_CLASSIC, W, H, 5, 2);
    config.eye.max_specular_depth = 16;
    with_photons(&config, &phs, phs.irradiance_estimate, phs.irradiance_estimate);
    config.eye.gather_rays = 1;
    pm_session *classic = render_session(&s, a, &cam, &config, 256);
    if (classic) {
        pm_film_resolve_total(pm_session_film(classic), img);
        compare("classic, 256 iterations", img, ref, masks, 0.02, 0.03, 0.04);
    }
    pm_session_destroy(classic);

    free(img);
    for (int k = 0; k < REGIONS; k++) free(masks[k]);
    pm_reference_free(&reference);
    pm_accel_destroy(a);
    pm_scene_free(&s);
    return pm_test_done("test_glossy");
}

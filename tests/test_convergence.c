/* test_convergence.c: the progressive mode converging to known answers: white furnaces and the committed references, with the error's log-log slope. */
/* Run from the optimised build (tests/run_tests.sh): hundreds of iterations of the same code test_progressive runs under ASan. */
#include <stdlib.h>
#include <string.h>

#include "accel.h"
#include "defaults.h"
#include "eye.h"
#include "film.h"
#include "image_io.h"
#include "loader.h"
#include "photonmap.h"
#include "progressive.h"
#include "scene_builder.h"
#include "progressive_harness.h"
#include "testing.h"

/* White furnace: a closed box whose walls emit Le and reflect rho: L = Le / (1 - rho) everywhere.
 * Returns the relative error of the image mean after `iterations` (the progressive mode's: photon
 * passes, each read by the eye passes the mode chooses; the classic mode's: eye passes). */
static double furnace_error(float rho, pm_indirect_mode indirect, int iterations, bool classic) {
    pm_scene s;
    pm_camera cam;
    const float le = 0.5f;
    pm_accel *a = sb_furnace(&s, rho, le, &cam);
    enum { W = 64, H = 64 };
    float *total = malloc(sizeof(float) * 3 * W * H);
    double want = le / (1.0 - rho), got;
    if (classic) {
        /* the classic mode as a user gets it at this size: default photon counts, k and radii */
        pm_photon_settings ps = {.global_photons = PM_MIN_DEFAULT_PHOTONS, .caustic_photons = PM_MIN_DEFAULT_PHOTONS,
                                 .seed = 1, .threads = 2, .max_bounces = PM_DEFAULT_MAX_PHOTON_BOUNCES,
                                 .projection_maps = true, .irradiance_stride = PM_DEFAULT_IRRADIANCE_STRIDE};
        pm_estimate_settings global = {PM_KERNEL_DISC, PM_DEFAULT_K_GLOBAL, PM_DEFAULT_GLOBAL_RADIUS * s.ray_scale, 7u};
        ps.irradiance_estimate = global;
        pm_photon_maps maps;
        CHECK(pm_photon_maps_build(&s, a, &ps, &maps, NULL), "classic maps");
        pm_film film;
        pm_film_init(&film, W, H, s.analysis.component_possible);
        pm_eye_settings es;
        memset(&es, 0, sizeof es);
        es.seed = 1;
        es.threads = 2;
        es.max_specular_depth = PM_DEFAULT_MAX_SPECULAR_DEPTH;
        es.maps = &maps;
        es.global_estimate = global;
        es.caustic_estimate = (pm_estimate_settings){PM_KERNEL_DISC, PM_DEFAULT_K_CAUSTIC, PM_DEFAULT_CAUSTIC_RADIUS * s.ray_scale, 7u};
        es.gather_rays = PM_DEFAULT_GATHER_RAYS;
        for (int i = 0; i < iterations; i++) pm_eye_iterate(&s, a, &cam, &es, i, &film, NULL);
        pm_film_resolve_total(&film, total);
        got = mean_of(total, 3 * W * H);
        pm_film_free(&film);
        pm_photon_maps_free(&maps);
    } else {
        pm_progressive_settings ps = default_settings(W, H);
        ps.indirect = indirect;
        session r;
        if (start(&r, &s, a, &cam, W, H, &ps)) {
            iterate_passes(&r, (uint32_t)iterations);
            pm_film_resolve_total(r.film, total);
            CHECK(r.film->ppm[PM_SLOT_CAUSTIC] == NULL && r.film->sum[PM_CAUSTIC] == NULL,
                  "furnace: no mirror or glass, so no caustic statistics and no caustic buffer");
        }
        got = mean_of(total, 3 * W * H);
        stop(&r);
    }
    printf("furnace rho %.2f %s: mean %.5f, expected %.5f, error %+.3f%% after %d iterations\n", rho,
           classic ? "classic" : (indirect == PM_INDIRECT_GATHER ? "progressive gather" : "progressive photons"), got,
           want, 100.0 * (got / want - 1.0), iterations);
    free(total);
    pm_accel_destroy(a);
    pm_scene_free(&s);
    return got / want - 1.0;
}

/* The default (final gathering) within 0.3%, closer than the classic mode; reading indirect light
 * at the visible points (--indirect photons) keeps a bias at the box's edges, where the visible
 * points' discs hang over the wall, that shrinks only as fast as the radius (N^-1/6 at alpha
 * 2/3): checked within 1.5% and that it shrinks. */
static void test_furnace(void) {
    const float rhos[2] = {0.5f, 0.95f};
    for (int k = 0; k < 2; k++) {
        double classic = furnace_error(rhos[k], PM_INDIRECT_GATHER, 64, true);
        double e = furnace_error(rhos[k], PM_INDIRECT_GATHER, 400, false);
        CHECK(fabs(e) <= 0.003, "furnace rho %g, gather: error %+.4f%% beyond 0.3%%", rhos[k], 100 * e);
        /* the classic mode's bias shows where light bounces long (rho 0.95); at rho 0.5 it is within noise */
        if (rhos[k] > 0.9f)
            CHECK(fabs(e) < fabs(classic), "furnace rho %g: progressive (%+.4f%%) not closer than classic (%+.4f%%)", rhos[k],
                  100 * e, 100 * classic);
    }
    double early = furnace_error(0.5f, PM_INDIRECT_PHOTONS, 25, false), late = furnace_error(0.5f, PM_INDIRECT_PHOTONS, 400, false);
    CHECK(fabs(late) <= 0.015 && fabs(late) < fabs(early), "furnace, photons at the visible points: %+.3f%% after 25, %+.3f%% after 400",
          100 * early, 100 * late);
}

/* ---- against the committed Mitsuba references ---- */

typedef struct { float *rgb[3]; int w, h; } reference;

static bool load_reference(const char *path, reference *ref) {
    static const char *const names[3] = {"R", "G", "B"};
    char err[256];
    for (int c = 0; c < 3; c++) {
        ref->rgb[c] = pm_read_exr_channel(path, names[c], &ref->w, &ref->h, err, sizeof err);
        if (!ref->rgb[c]) { CHECK(false, "reference: %s", err); return false; }
    }
    return true;
}

/* Least-squares slope of log(y) against log(x). */
static double loglog_slope(const double *x, const double *y, int n) {
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (int i = 0; i < n; i++) {
        double lx = log(x[i]), ly = log(y[i]);
        sx += lx; sy += ly; sxx += lx * lx; sxy += lx * ly;
    }
    return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

/* Renders `path` progressively at the reference's size and measures relMSE at 1, 2, 4, ...
 * iterations (over the pixels of mask_fn's mask, or all); the fitted slope over the later half
 * must be near theory's MSE ~ N^-(2/3) at alpha 2/3 (the variance term; the bias term falls as fast). */
static void test_reference_slope(const char *scene_path, const char *ref_path, int max_iterations, bool caustic_region,
                                 double max_final_relmse) {
    pm_scene s;
    pm_load_report rep;
    char err[512];
    reference ref;
    memset(&ref, 0, sizeof ref);
    if (!pm_load_gltf(scene_path, true, &s, &rep, err, sizeof err)) { CHECK(false, "load: %s", err); return; }
    if (!load_reference(ref_path, &ref)) { pm_scene_free(&s); return; }
    pm_scene_finalize(&s, true, NULL);
    pm_accel *a = pm_accel_create(&s, err, sizeof err);
    pm_camera cam = s.cameras[0];
    int w = ref.w, h = ref.h;
    pm_progressive_settings ps = default_settings(w, h);
    ps.eye_passes = 1; /* an iteration a photon pass: the theory's N */
    session r;
    if (!start(&r, &s, a, &cam, w, h, &ps)) return;
    size_t n = (size_t)w * h;
    float *direct = malloc(sizeof(float) * 3 * n), *specular = malloc(sizeof(float) * 3 * n);
    unsigned char *mask = NULL;
    const float *const planes[3] = {ref.rgb[0], ref.rgb[1], ref.rgb[2]};
    double xs[16], ys[16];
    float *snapshots[16];
    int points = 0;
    for (int it = 1; it <= max_iterations && points < 16; it *= 2) {
        iterate(&r, it - (int)r.film->samples);
        snapshots[points] = malloc(sizeof(float) * 3 * n);
        pm_film_resolve_total(r.film, snapshots[points]);
        xs[points++] = it;
    }
    if (caustic_region) {
        /* the floor in the light's full shadow (direct and specular exactly zero in every sample of
         * the whole run), lit by the caustic alone */
        mask = calloc(n, 1);
        pm_film_resolve(r.film, PM_DIRECT, direct);
        pm_film_resolve(r.film, PM_SPECULAR, specular);
        for (size_t i = 0; i < n; i++) mask[i] = direct[3 * i] == 0.f && specular[3 * i] == 0.f && ref.rgb[0][i] > 0.f;
        /* the 5x5 pixels at the ball's focus are left out: an irradiance singularity, where a
         * pixel's value depends on how a density estimate spreads it (tests/caustic_region.h) */
        size_t focus = 0;
        for (size_t i = 1; i < n; i++) if (ref.rgb[0][i] > ref.rgb[0][focus]) focus = i;
        for (int dy = -2; dy <= 2; dy++)
            for (int dx = -2; dx <= 2; dx++) {
                long x = (long)(focus % (size_t)w) + dx, y = (long)(focus / (size_t)w) + dy;
                if (x >= 0 && y >= 0 && x < w && y < h) mask[y * w + x] = 0;
            }
    }
    for (int k = 0; k < points; k++) {
        pm_image_error e = pm_image_compare(snapshots[k], planes, n, mask);
        ys[k] = e.relmse;
        printf("%s: %g iterations, relMSE %.6f (%zu pixels), mean ratio %.4f\n", scene_path, xs[k], e.relmse, e.pixels,
               (e.ours[0] + e.ours[1] + e.ours[2]) / (e.ref[0] + e.ref[1] + e.ref[2]));
        free(snapshots[k]);
    }
    int half = points / 2;
    double slope = loglog_slope(xs + half, ys + half, points - half);
    printf("%s: log-log slope of relMSE over iterations %g..%g: %.3f (theory about -0.67 at alpha 2/3)\n", scene_path,
           xs[half], xs[points - 1], slope);
    CHECK(ys[points - 1] < 0.25 * ys[0], "%s: error did not fall: %g at 1 iteration, %g at %g", scene_path, ys[0],
          ys[points - 1], xs[points - 1]);
    CHECK(slope < -0.4 && slope > -1.2, "%s: slope %.3f not near theory's -2/3", scene_path, slope);
    if (max_final_relmse > 0.0)
        CHECK(ys[points - 1] <= max_final_relmse, "%s: relMSE %g at %g iterations, above %g", scene_path, ys[points - 1],
              xs[points - 1], max_final_relmse);
    free(direct);
    free(specular);
    free(mask);
    stop(&r);
    for (int c = 0; c < 3; c++) free(ref.rgb[c]);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

int main(void) {
    test_furnace();
    test_reference_slope("scenes/cornell-box.gltf", "tests/ref/cornell_path_64.exr", 128, false, 0.0);
    test_reference_slope("scenes/caustic.gltf", "tests/ref/caustic_ptracer_64.exr", 256, true, 0.0);
    /* a room lit by a point light: gather points trace its light (0.0024 at 256 iterations; 0.0037
     * when they read it from first-hit photons) */
    test_reference_slope("scenes/point-room.gltf", "tests/ref/point_room_path_64.exr", 256, false, 0.003);
    return pm_test_done("test_convergence");
}

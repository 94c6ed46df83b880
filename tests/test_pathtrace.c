/* test_pathtrace.c: the path tracer (--mode pathtrace) against the white furnace, the Mitsuba Cornell references and the photon modes' component split; thread independence; EXR layers.
 *
 * Everything runs through the render session, as the window and snapshots drive it. Run
 * optimised (tests/run_tests.sh): a few hundred samples per pixel; tests/test_log.sh runs the
 * same code under ASan/UBSan through build/asan/pmview.
 */
#include <stdlib.h>
#include <string.h>

#include "accel.h"
#include "defaults.h"
#include "film.h"
#include "image_io.h"
#include "loader.h"
#include "scene_builder.h"
#include "session.h"
#include "reference_image.h"
#include "testing.h"

static pm_session_config pathtrace_config(int w, int h, uint64_t seed, int threads) {
    pm_session_config c;
    memset(&c, 0, sizeof c);
    c.mode = PM_MODE_PATHTRACE;
    c.width = w;
    c.height = h;
    c.eye.seed = seed;
    c.eye.threads = threads;
    c.eye.max_specular_depth = PM_DEFAULT_MAX_SPECULAR_DEPTH;
    return c;
}

/* A session run for `iterations`; NULL (and a failed check) when it cannot start. */
static pm_session *run(const pm_scene *s, const pm_accel *a, const pm_camera *cam, const pm_session_config *c, int iterations) {
    char err[256];
    pm_session *session = pm_session_create(s, a, cam, c, err, sizeof err);
    CHECK(session != NULL, "session: %s", err);
    for (int i = 0; session && i < iterations; i++) CHECK(pm_session_iterate(session, 0), "iteration %d", i);
    return session;
}

static double mean_of(const float *x, size_t n) {
    double sum = 0;
    for (size_t i = 0; i < n; i++) sum += x[i];
    return sum / (double)n;
}

/* White furnace: a closed box whose walls emit Le and reflect rho: L = Le / (1 - rho) everywhere. */
static void furnace(float rho, int iterations) {
    pm_scene s;
    pm_camera cam;
    const float le = 0.5f;
    pm_accel *a = sb_furnace(&s, rho, le, &cam);
    enum { W = 32, H = 32 };
    pm_session_config c = pathtrace_config(W, H, 1, 2);
    pm_session *session = run(&s, a, &cam, &c, iterations);
    if (session) {
        float *total = malloc(sizeof(float) * 3 * W * H);
        pm_film_resolve_total(pm_session_film(session), total);
        double got = mean_of(total, 3 * W * H), want = le / (1.0 - rho);
        printf("furnace rho %.2f: mean %.5f, expected %.5f, error %+.3f%% after %d iterations\n", rho, got, want,
               100.0 * (got / want - 1.0), iterations);
        CHECK_NEAR(got, want, 0.005, 0, "path-traced furnace within 0.5%");
        const pm_film *f = pm_session_film(session);
        CHECK(f->sum[PM_CAUSTIC] == NULL && f->sum[PM_SPECULAR] == NULL, "no mirror or glass: no caustic or specular buffer");
        free(total);
        pm_session_destroy(session);
    }
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

typedef struct {
    pm_scene scene;
    pm_accel *accel;
    pm_camera camera;
} loaded;

static bool load(const char *path, int w, int h, loaded *l) {
    char err[1024];
    pm_load_report rep;
    memset(l, 0, sizeof *l);
    if (!pm_load_gltf(path, true, &l->scene, &rep, err, sizeof err)) { CHECK(false, "%s", err); return false; }
    pm_scene_finalize(&l->scene, true, NULL);
    l->accel = pm_accel_create(&l->scene, err, sizeof err);
    CHECK(l->accel != NULL, "accel: %s", err);
    l->camera = l->scene.camera_count ? l->scene.cameras[0] : pm_scene_auto_camera(&l->scene, (float)w / h);
    return l->accel != NULL;
}

static void unload(loaded *l) {
    pm_accel_destroy(l->accel);
    pm_scene_free(&l->scene);
}

/* The Cornell box (mirror and glass balls, an area lamp) against Mitsuba's path tracer, judged by
 * our own noise: two independent halves a, b give the expected relMSE of their mean against the
 * converged image r, mean((a-b)^2 / (r^2 + 0.01)) / 4 (E[(a-b)^2] / 4 is the variance of the
 * mean), and the measured relMSE against the reference must not exceed it by more than chance and
 * the reference's own noise allow. (tests/ref/README.md divides by the halves' own mean instead,
 * which caustic fireflies saturate: a firefly in one half scores 1 however bright it is.) The direct layer is compared with Mitsuba's direct integrator
 * where the first hits were all diffuse (specular layer 0), as tests/test_reference.c does. */
static void cornell(const pm_reference_image *path_ref, const pm_reference_image *direct_ref, int half_iterations) {
    int W = path_ref->width, H = path_ref->height;
    size_t n = (size_t)W * H;
    loaded l;
    if (!load("scenes/cornell-box.gltf", W, H, &l)) return;
    float *half[2] = {malloc(sizeof(float) * 3 * n), malloc(sizeof(float) * 3 * n)};
    float *direct = malloc(sizeof(float) * 3 * n), *spec = malloc(sizeof(float) * 3 * n), *mean = malloc(sizeof(float) * 3 * n);
    for (int k = 0; k < 2; k++) {
        pm_session_config c = pathtrace_config(W, H, 101 + k, 2);
        pm_session *session = run(&l.scene, l.accel, &l.camera, &c, half_iterations);
        if (!session) continue;
        const pm_film *f = pm_session_film(session);
        pm_film_resolve_total(f, half[k]);
        pm_film_resolve(f, PM_DIRECT, direct);
        if (k == 0) pm_film_resolve(f, PM_SPECULAR, spec);
        for (size_t i = 0; i < 3 * n; i++) mean[i] = k ? 0.5f * (mean[i] + direct[i]) : direct[i];
        pm_session_destroy(session);
    }
    /* the direct layer of both halves (in mean) where the first hits were all diffuse */
    unsigned char *mask = malloc(n);
    for (size_t i = 0; i < n; i++) mask[i] = spec[3 * i] == 0.f && spec[3 * i + 1] == 0.f && spec[3 * i + 2] == 0.f;
    if (direct_ref) {
        pm_image_error e = pm_image_compare(mean, (const float *const *)direct_ref->rgb, n, mask);
        printf("direct layer vs Mitsuba direct: relMSE %.6f, mean ratio R %.4f G %.4f B %.4f over %zu pixels\n", e.relmse,
               e.ours[0] / e.ref[0], e.ours[1] / e.ref[1], e.ours[2] / e.ref[2], e.pixels);
        CHECK(e.pixels > n / 4, "the mask keeps enough pixels (%zu)", e.pixels);
        CHECK(e.relmse < 0.0004, "direct layer relMSE %g above 0.0004 (seeds 101-501: 0.00019-0.00026)", e.relmse);
        for (int c = 0; c < 3; c++) CHECK_NEAR(e.ours[c], e.ref[c], 0.01, 0, "direct layer mean vs Mitsuba direct");
    }
    double noise = 0;
    for (size_t i = 0; i < 3 * n; i++) {
        double a = half[0][i], b = half[1][i], m = 0.5 * (a + b);
        mean[i] = (float)m;
        double r = path_ref->rgb[i % 3][i / 3];
        noise += (a - b) * (a - b) / (r * r + 0.01);
    }
    noise /= 4.0 * 3.0 * (double)n;
    pm_image_error e = pm_image_compare(mean, (const float *const *)path_ref->rgb, n, NULL);
    printf("total vs Mitsuba path, %d samples per pixel: relMSE %.5f, own noise %.5f, mean ratio R %.4f G %.4f B %.4f\n",
           2 * half_iterations, e.relmse, noise, e.ours[0] / e.ref[0], e.ours[1] / e.ref[1], e.ours[2] / e.ref[2]);
    /* both are dominated by a few caustic fireflies, so each varies by tens of percent between
     * seeds; the reference's own relMSE is 2e-5 */
    CHECK(e.relmse <= 1.5 * noise + 1e-3, "relMSE %g against an own noise of %g", e.relmse, noise);
    for (int c = 0; c < 3; c++) CHECK_NEAR(e.ours[c], e.ref[c], 0.01, 0, "total mean vs Mitsuba path, within 1%");
    free(mask);
    free(half[0]);
    free(half[1]);
    free(direct);
    free(spec);
    free(mean);
    unload(&l);
}

/* The split into components matches the progressive photon mapper's on the Cornell box: the mean
 * of each layer (the caustic under the glass ball, L S+ D; the indirect light, the rest) agrees.
 * Small and short: the photon estimates blur, but a blur keeps a layer's mean. */
static void split_matches_progressive(void) {
    enum { W = 32, H = 32, PT_ITERATIONS = 256, PPM_ITERATIONS = 64 };
    size_t n = (size_t)W * H;
    loaded l;
    if (!load("scenes/cornell-box.gltf", W, H, &l)) return;
    pm_session_config pt = pathtrace_config(W, H, 7, 2), ppm;
    memset(&ppm, 0, sizeof ppm);
    ppm.mode = PM_MODE_PROGRESSIVE;
    ppm.width = W;
    ppm.height = H;
    ppm.progressive.seed = 7;
    ppm.progressive.threads = 2;
    ppm.progressive.photons = ppm.progressive.caustic_photons = 20000;
    ppm.progressive.alpha = PM_DEFAULT_ALPHA;
    ppm.progressive.indirect = PM_INDIRECT_GATHER;
    ppm.progressive.max_specular_depth = PM_DEFAULT_MAX_SPECULAR_DEPTH;
    ppm.progressive.max_photon_bounces = PM_DEFAULT_MAX_PHOTON_BOUNCES;
    pm_session *a = run(&l.scene, l.accel, &l.camera, &pt, PT_ITERATIONS);
    pm_session *b = run(&l.scene, l.accel, &l.camera, &ppm, PPM_ITERATIONS);
    float *x = malloc(sizeof(float) * 3 * n), *y = malloc(sizeof(float) * 3 * n);
    /* At 64 iterations the progressive caustic is still about 10% low (its radii are wide; at 256
     * it is 3% low, at 64x64 and 256 iterations 0.4%), and the path tracer's caustic fireflies
     * leave a few percent of noise. A caustic path filed as indirect instead would empty the
     * caustic layer and raise the indirect one by 14%. */
    static const double tolerance[PM_COMPONENT_COUNT] = {0.04, 0.10, 0.25, 0.08};
    for (int c = 0; a && b && c < PM_COMPONENT_COUNT; c++) {
        pm_film_resolve(pm_session_film(a), (pm_component)c, x);
        pm_film_resolve(pm_session_film(b), (pm_component)c, y);
        double mx = mean_of(x, 3 * n), my = mean_of(y, 3 * n);
        printf("%-9s path tracer %.5f, progressive %.5f, ratio %.4f\n", pm_component_names[c], mx, my, mx / my);
        CHECK(my > 0.001, "the %s layer is not empty", pm_component_names[c]);
        CHECK_NEAR(mx, my, tolerance[c], 0, pm_component_names[c]);
    }
    free(x);
    free(y);
    pm_session_destroy(a);
    pm_session_destroy(b);
    unload(&l);
}

/* The same image at 1 and 2 threads, bit for bit; and the EXR's total is the sum of its layers. */
static void threads_and_layers(void) {
    enum { W = 24, H = 20, ITERATIONS = 3 };
    size_t n = (size_t)W * H;
    loaded l;
    if (!load("scenes/cornell-box.gltf", W, H, &l)) return;
    pm_session_config one = pathtrace_config(W, H, 3, 1), two = pathtrace_config(W, H, 3, 2);
    pm_session *a = run(&l.scene, l.accel, &l.camera, &one, ITERATIONS);
    pm_session *b = run(&l.scene, l.accel, &l.camera, &two, ITERATIONS);
    for (int c = 0; a && b && c < PM_COMPONENT_COUNT; c++) {
        const pm_film *fa = pm_session_film(a), *fb = pm_session_film(b);
        CHECK(fa->sum[c] != NULL, "the Cornell box has every component");
        if (fa->sum[c] && fb->sum[c])
            CHECK(memcmp(fa->sum[c], fb->sum[c], sizeof(float) * 3 * n) == 0, "%s layer: 1 and 2 threads differ", pm_component_names[c]);
    }
    if (a) {
        char err[512];
        const char *path = "build/test_pathtrace_layers.exr";
        CHECK(pm_write_exr(path, pm_session_film(a), err, sizeof err), "%s", err);
        static const char *const rgb[3] = {"R", "G", "B"};
        for (int k = 0; k < 3; k++) {
            int w, h;
            float *total = pm_read_exr_channel(path, rgb[k], &w, &h, err, sizeof err);
            float *layer[PM_COMPONENT_COUNT];
            for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
                char name[32];
                snprintf(name, sizeof name, "%s.%s", pm_component_names[c], rgb[k]);
                layer[c] = pm_read_exr_channel(path, name, &w, &h, err, sizeof err);
            }
            if (total && layer[0] && layer[1] && layer[2] && layer[3]) {
                double worst = 0, sum_total = 0;
                for (size_t i = 0; i < n; i++) {
                    double s = (double)layer[0][i] + layer[1][i] + layer[2][i] + layer[3][i];
                    worst = fmax(worst, fabs(s - total[i]) / fmax(1e-6, fabs(total[i])));
                    sum_total += total[i];
                }
                CHECK(worst < 1e-5, "channel %s: the layers sum to the total (worst relative difference %g)", rgb[k], worst);
                CHECK(sum_total > 0, "channel %s is lit", rgb[k]);
            } else {
                CHECK(false, "EXR channels missing: %s", err);
            }
            free(total);
            for (int c = 0; c < PM_COMPONENT_COUNT; c++) free(layer[c]);
        }
        remove(path);
    }
    pm_session_destroy(a);
    pm_session_destroy(b);
    unload(&l);
}

int main(void) {
    furnace(0.5f, 128);
    furnace(0.8f, 128);
    threads_and_layers();
    split_matches_progressive();
    pm_reference_image path_ref, direct_ref;
    if (load_ref("tests/ref/cornell_path_64.exr", &path_ref)) {
        bool have_direct = load_ref("tests/ref/cornell_direct_64.exr", &direct_ref);
        cornell(&path_ref, have_direct ? &direct_ref : NULL, 128);
        if (have_direct) pm_reference_free(&direct_ref);
        pm_reference_free(&path_ref);
    }
    return pm_test_done("test_pathtrace");
}

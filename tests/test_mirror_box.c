/* test_mirror_box.c: long specular chains under the one survival rule: a closed box of emissive 0.99 mirrors reads the sum of its mirror chains in every mode, against a chain traced in double (checked against Mitsuba 3 at constant reflectance).
 *
 * The box's six walls face inward, emit LE and are perfect mirrors (glTF metallic 1, roughness 0,
 * baseColor 0.99: Schlick's reflectance F = 0.99 + 0.01 (1 - cos)^5). Every ray from the camera
 * bounces forever, each wall adding LE times the reflectance so far; at a constant 0.99 every
 * pixel would converge to LE / (1 - 0.99) = 100 LE, with 100 bounces on average and a long tail:
 * 37% of the light comes after bounce 100, 13% after 200. In a box a reflection only flips one
 * component of the direction, so each wall's cosine stays the same along a chain, and
 * chain_reference sums the chain in double, pixel by pixel (4 x 4 points each, 3000 bounces);
 * with F held at 0.99 it must give Mitsuba's image (tests/ref/mirror_box.txt), which checks it.
 * A chain ended by a depth cap instead of roulette loses that tail (a cap of 64, the eye paths'
 * old one, reads 47% of the light; the check below keeps such a cap visible), and a survival
 * probability below reflectance^2 leaves the estimate with infinite variance.
 *
 * Reference: tests/ref/mirror_box.txt, Mitsuba 3's path integrator on the same box, run to 3000
 * bounces without roulette (tools/mitsuba_mirror_box.py). Criterion: the image mean of each of
 * the three modes (progressive, classic, path tracing, through the session) within 1% of it per
 * channel; at 32x32 and 128 samples a pixel the estimate's own noise is about 0.3% (a chain's
 * length is geometric: its relative spread per sample is about 1).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "accel.h"
#include "defaults.h"
#include "film.h"
#include "scene_builder.h"
#include "session.h"
#include "testing.h"

enum { W = 32, H = 32, ITERATIONS = 128 };
static const vec3 LE = {0.01f, 0.02f, 0.005f}; /* as in tools/mitsuba_mirror_box.py */

/* The reference's mean R G B: the last line of tests/ref/mirror_box.txt. */
static bool read_reference(double rgb[3]) {
    FILE *f = fopen("tests/ref/mirror_box.txt", "r");
    if (!f) return false;
    char line[512];
    bool found = false;
    while (fgets(line, sizeof line, f))
        if (line[0] != '#' && sscanf(line, "%lf %lf %lf", &rgb[0], &rgb[1], &rgb[2]) == 3) found = true;
    fclose(f);
    return found;
}

/* The image means of the box's mirror chains seen by cam, W x H pixels of 4 x 4 points, summed in
 * double to 3000 bounces: with reflectance r at every wall (constant) and with Schlick's from r
 * (schlick). Both sums follow the same chain: a wall's cosine, and so its reflectance, stays the
 * same along it. */
static void chain_reference(const pm_camera *cam, double r, double constant[3], double schlick[3]) {
    double sum_constant = 0.0, sum_schlick = 0.0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            for (int k = 0; k < 16; k++) {
                vec3 o, dir;
                pm_camera_ray(cam, W, H, x + (k % 4 + 0.5f) / 4.f, y + (k / 4 + 0.5f) / 4.f, &o, &dir);
                double p[3] = {o.x, o.y, o.z}, d[3] = {dir.x, dir.y, dir.z}, f[3];
                double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]), throughput_constant = 1.0, throughput_schlick = 1.0;
                double radiance_constant = 0.0, radiance_schlick = 0.0;
                for (int a = 0; a < 3; a++) {
                    d[a] /= len;
                    f[a] = r + (1.0 - r) * pow(1.0 - fabs(d[a]), 5.0);
                }
                double inv[3] = {1.0 / d[0], 1.0 / d[1], 1.0 / d[2]}; /* read only where d is not 0 */
                for (int bounce = 0; bounce < 3000; bounce++) {
                    int wall = -1;
                    double t = INFINITY;
                    for (int a = 0; a < 3; a++) {
                        if (d[a] == 0.0) continue;
                        double ta = ((d[a] > 0.0 ? 1.0 : -1.0) - p[a]) * inv[a];
                        if (ta < t) { t = ta; wall = a; }
                    }
                    for (int a = 0; a < 3; a++) p[a] += t * d[a];
                    radiance_constant += throughput_constant; /* times LE below */
                    radiance_schlick += throughput_schlick;
                    throughput_constant *= r;
                    throughput_schlick *= f[wall];
                    d[wall] = -d[wall];
                    inv[wall] = -inv[wall];
                }
                sum_constant += radiance_constant;
                sum_schlick += radiance_schlick;
            }
    const double le[3] = {LE.x, LE.y, LE.z};
    for (int k = 0; k < 3; k++) {
        constant[k] = le[k] * sum_constant / (16.0 * W * H);
        schlick[k] = le[k] * sum_schlick / (16.0 * W * H);
    }
}

static pm_session_config config_for(pm_mode mode, const pm_scene *s, int max_specular_depth) {
    pm_session_config c;
    pm_session_config_defaults(&c, mode, W, H, 1, 2);
    c.progressive.max_specular_depth = c.eye.max_specular_depth = max_specular_depth;
    c.classic_photon_pass = mode == PM_MODE_CLASSIC &&
                            (s->analysis.component_possible[PM_CAUSTIC] || s->analysis.component_possible[PM_INDIRECT]);
    c.classic_photons.global_photons = c.classic_photons.caustic_photons = 10000;
    return c;
}

/* The image mean per channel after `samples` samples a pixel; false when the session fails. */
static bool render_mean(const pm_scene *s, const pm_accel *a, const pm_camera *cam, const pm_session_config *c, uint32_t samples,
                        double mean[3]) {
    char err[256];
    pm_session *session = pm_session_create(s, a, cam, c, err, sizeof err);
    CHECK(session != NULL, "session: %s", err);
    if (!session) return false;
    bool ok = true;
    while (ok && pm_session_film(session)->samples < samples) ok = pm_session_iterate(session, samples - pm_session_film(session)->samples);
    CHECK(ok, "iterations");
    float *total = malloc(sizeof(float) * 3 * W * H);
    pm_film_resolve_total(pm_session_film(session), total);
    mean[0] = mean[1] = mean[2] = 0.0;
    for (int i = 0; i < W * H; i++)
        for (int k = 0; k < 3; k++) mean[k] += total[3 * i + k] / (double)(W * H);
    free(total);
    pm_session_destroy(session);
    return ok;
}

int main(void) {
    double reference[3];
    CHECK(read_reference(reference), "tests/ref/mirror_box.txt: three numbers (run from the repository root)");
    if (!read_reference(reference)) return pm_test_done("test_mirror_box");
    const double series[3] = {LE.x / (1.0 - 0.99), LE.y / (1.0 - 0.99), LE.z / (1.0 - 0.99)};
    for (int k = 0; k < 3; k++) CHECK_NEAR(reference[k], series[k], 1e-4, 0, "the reference is the series LE / (1 - R)");

    pm_scene s;
    memset(&s, 0, sizeof s);
    uint32_t mirror = sb_material(&s, v3s(0.99f), 1.f, 0.f, 0.f, LE, false);
    sb_box(&s, v3(-1, -1, -1), v3(1, 1, 1), mirror, true);
    pm_accel *a = sb_finish(&s);
    pm_camera cam = sb_camera(v3(0, 0, 0.5f), v3(0.3f, -0.2f, -1), v3(0, 1, 0), 60.f);
    /* the chain summed in double: at a constant 0.99 Mitsuba's image, with Schlick the reference */
    double constant[3], mitsuba[3] = {reference[0], reference[1], reference[2]};
    chain_reference(&cam, 0.99, constant, reference);
    printf("chains in double: constant 0.99 %.5f %.5f %.5f (Mitsuba %.5f %.5f %.5f); Schlick %.5f %.5f %.5f\n", constant[0],
           constant[1], constant[2], mitsuba[0], mitsuba[1], mitsuba[2], reference[0], reference[1], reference[2]);
    for (int k = 0; k < 3; k++) CHECK_NEAR(constant[k], mitsuba[k], 1e-4, 0, "the chain at constant 0.99 is Mitsuba's image");
    for (int k = 0; k < 3; k++) CHECK(reference[k] > 1.01 * mitsuba[k], "Schlick's rise toward grazing walls shows");

    static const pm_mode modes[] = {PM_MODE_PROGRESSIVE, PM_MODE_CLASSIC, PM_MODE_PATHTRACE};
    static const char *names[] = {"progressive", "classic", "pathtrace"};
    for (int m = 0; a && m < 3; m++) {
        pm_session_config c = config_for(modes[m], &s, PM_DEFAULT_MAX_SPECULAR_DEPTH);
        double mean[3];
        if (!render_mean(&s, a, &cam, &c, ITERATIONS, mean)) continue;
        printf("%-11s mean %.5f %.5f %.5f, reference %.5f %.5f %.5f, ratio %.4f %.4f %.4f\n", names[m], mean[0], mean[1],
               mean[2], reference[0], reference[1], reference[2], mean[0] / reference[0], mean[1] / reference[1],
               mean[2] / reference[2]);
        for (int k = 0; k < 3; k++)
            CHECK(fabs(mean[k] - reference[k]) <= 0.01 * reference[k], "%s: channel %d within 1%% of the Schlick chains (%.5f, %.5f)",
                  names[m], k, mean[k], reference[k]);
    }

    /* The same chains cut at 64 bounces lose the tail: 1 - 0.99^65 = 48% of the light is all a
     * capped chain can read, so a cap that ends chains before roulette does cannot pass above.
     * A capped chain's spread is small: 32 samples a pixel read 45.8% to 46.1% at seeds 1-5. */
    if (a) {
        pm_session_config c = config_for(PM_MODE_CLASSIC, &s, 64);
        double mean[3];
        if (render_mean(&s, a, &cam, &c, 32, mean)) {
            printf("classic, chains cut at 64 bounces: mean %.5f (%.1f%% of the reference)\n", mean[0], 100.0 * mean[0] / reference[0]);
            CHECK(mean[0] < 0.6 * reference[0], "a 64-bounce cap loses the chains' tail (%.3f of the reference)", mean[0] / reference[0]);
        }
    }
    pm_accel_destroy(a);
    pm_scene_free(&s);
    return pm_test_done("test_mirror_box");
}

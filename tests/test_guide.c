/* test_guide.c: the learned emission guide stays unbiased (flux on a marked square and an unmarked one against the analytic irradiance x area) and sends far more photons where the marks are; the marks themselves.
 *
 * A large floor lit by a directional light (and by a point light, whose directions are guided
 * instead of its starts): every photon's first hit is a record on the floor, whose summed power
 * over a square is that square's flux, E cos(theta) A for the sun, I cos(theta) / d^2 integrated
 * for the point light. The guide learns from marks set on one square only; the flux must stay the
 * same on that square and on an unmarked one (the defensive share keeps it reachable), while the
 * marked square gets many times the photons.
 */
#include <stdlib.h>
#include <string.h>

#include "accel.h"
#include "defaults.h"
#include "guide.h"
#include "photonmap.h"
#include "scene_builder.h"
#include "testing.h"

typedef struct { float x0, z0, size; } square;

static bool inside(const square *q, vec3 p) { return p.x >= q->x0 && p.x < q->x0 + q->size && p.z >= q->z0 && p.z < q->z0 + q->size; }

typedef struct {
    double flux_mean[2], flux_error[2]; /* per square: mean of the passes' flux, its standard error */
    double records[2];                  /* records per pass in each square */
} outcome;

/* Passes 0..passes-1 of `photons` each; the guide (when given) learns from the marks after each. */
static outcome run(pm_photon_tracer *t, int passes, uint64_t photons, const square sq[2], int skip) {
    pm_photon_buffer buffer = {0};
    pm_photon_stats stats;
    memset(&stats, 0, sizeof stats);
    double sum[2] = {0, 0}, sum2[2] = {0, 0}, records[2] = {0, 0};
    int counted = 0;
    for (int pass = 0; pass < passes; pass++) {
        CHECK(pm_photon_tracer_trace_into(t, false, photons, 1000 + (uint64_t)pass, &buffer, &stats), "pass %d", pass);
        if (pass < skip) continue;
        counted++;
        for (int k = 0; k < 2; k++) {
            double flux = 0.0;
            for (size_t i = 0; i < buffer.count; i++) {
                const pm_photon *ph = &buffer.data[i];
                if (!inside(&sq[k], pm_photon_position(ph)) || pm_photon_normal(ph).y < 0.f) continue; /* the upper face */
                flux += v3_average(pm_photon_power(ph));
                records[k]++;
            }
            sum[k] += flux;
            sum2[k] += flux * flux;
        }
    }
    outcome o;
    for (int k = 0; k < 2; k++) {
        o.flux_mean[k] = sum[k] / counted;
        double var = (sum2[k] / counted - o.flux_mean[k] * o.flux_mean[k]) * counted / (counted - 1.0);
        o.flux_error[k] = sqrt(fmax(var, 0.0) / counted);
        o.records[k] = records[k] / counted;
    }
    free(buffer.data);
    return o;
}

/* The flux a point light of intensity i at height h above (0, 0) sends onto the square, by a fine
 * midpoint sum of i cos / d^2. */
static double point_flux(double i, double h, const square *q) {
    enum { N = 400 };
    double sum = 0.0, cell = q->size / N;
    for (int a = 0; a < N; a++)
        for (int b = 0; b < N; b++) {
            double x = q->x0 + (a + 0.5) * cell, z = q->z0 + (b + 0.5) * cell, d2 = x * x + z * z + h * h;
            sum += i * h / (d2 * sqrt(d2)) * cell * cell;
        }
    return sum;
}

static void check_light(const char *name, pm_scene *s, pm_accel *a, const double analytic[2], const square sq[2]) {
    enum { PASSES = 60, SKIP = 4 };
    const uint64_t photons = 40000;
    pm_photon_settings ps = {.global_photons = photons, .seed = 7, .threads = 2, .max_bounces = 1};
    pm_photon_tracer *t = pm_photon_tracer_create(s, a, &ps);
    CHECK(t != NULL, "tracer");
    if (!t) return;
    outcome plain = run(t, PASSES, photons, sq, SKIP);
    pm_marks marks;
    pm_guide guide;
    CHECK(pm_marks_init(&marks) && pm_guide_init(&guide, pm_photon_tracer_guided_sources(t)), "guide");
    CHECK(pm_photon_tracer_guided_sources(t) == (s->sky ? 2 : s->light_count), "%s: every light guided (%u)", name,
          pm_photon_tracer_guided_sources(t));
    pm_marks_clear(&marks, 0.1f);
    for (float x = sq[0].x0 + 0.05f; x < sq[0].x0 + sq[0].size; x += 0.1f)
        for (float z = sq[0].z0 + 0.05f; z < sq[0].z0 + sq[0].size; z += 0.1f) pm_marks_set(&marks, v3(x, 0, z), v3(0, 1, 0));
    CHECK(marks.any && pm_marks_test(&marks, v3(sq[0].x0 + 0.3f, 0, sq[0].z0 + 0.3f)) &&
              !pm_marks_test(&marks, v3(sq[1].x0 + 0.3f, 0, sq[1].z0 + 0.3f)),
          "%s: the marked square is marked, the other is not", name);
    CHECK(pm_photon_tracer_set_guide(t, &guide, &marks), "set guide");
    outcome guided = run(t, PASSES, photons, sq, SKIP);
    for (int k = 0; k < 2; k++) {
        const char *which = k == 0 ? "marked" : "unmarked";
        printf("%s, %s square: analytic flux %.5f; unguided %.5f +- %.5f (%.0f records a pass); guided %.5f +- %.5f (%.0f records)\n",
               name, which, analytic[k], plain.flux_mean[k], plain.flux_error[k], plain.records[k], guided.flux_mean[k],
               guided.flux_error[k], guided.records[k]);
        /* the records' RGBE power rounds to 1%: a 0.5% allowance beside four standard errors */
        CHECK(fabs(plain.flux_mean[k] - analytic[k]) <= 4.0 * plain.flux_error[k] + 0.005 * analytic[k],
              "%s, %s square: unguided flux %g, analytic %g", name, which, plain.flux_mean[k], analytic[k]);
        CHECK(fabs(guided.flux_mean[k] - analytic[k]) <= 4.0 * guided.flux_error[k] + 0.005 * analytic[k],
              "%s, %s square: guided flux %g (+- %g), analytic %g: the guide must not bias", name, which,
              guided.flux_mean[k], guided.flux_error[k], analytic[k]);
    }
    CHECK(guided.records[0] > 8.0 * plain.records[0], "%s: the guide sends photons where the marks are (%.0f against %.0f a pass)",
          name, guided.records[0], plain.records[0]);
    CHECK(guided.records[1] > 0.0, "%s: the unmarked square still gets photons", name);
    /* a restart forgets what was learned */
    pm_guide_reset(&guide);
    CHECK(guide.emitted[0] == 0 && guide.cdf[1] > 0.f && fabsf(guide.cdf[1] - 1.f / PM_GUIDE_CELL_COUNT) < 1e-6f,
          "%s: a reset guide is uniform", name);
    pm_photon_tracer_destroy(t);
    pm_guide_free(&guide);
    pm_marks_free(&marks);
}

int main(void) {
    pm_scene s;
    memset(&s, 0, sizeof s);
    uint32_t floor = sb_lambert(&s, v3s(0.5f));
    sb_quad(&s, v3(-10, 0, -10), v3(-10, 0, 10), v3(10, 0, 10), v3(10, 0, -10), floor);
    s.lights = calloc(1, sizeof *s.lights);
    s.lights[0].type = PM_LIGHT_DIRECTIONAL;
    vec3 dir = v3_normalize(v3(0.3f, -1.f, 0.2f));
    s.lights[0].direction = dir;
    s.lights[0].intensity = v3s(2.f);
    s.light_count = 1;
    pm_accel *a = sb_finish(&s);
    const square sq[2] = {{1.0f, -2.0f, 1.0f}, {-6.0f, 4.0f, 1.0f}};
    double sun = 2.0 * fabs(dir.y) * 1.0;
    const double sun_flux[2] = {sun, sun};
    check_light("sun", &s, a, sun_flux, sq);

    s.lights[0].type = PM_LIGHT_POINT;
    s.lights[0].position = v3(0, 3, 0);
    s.lights[0].intensity = v3s(5.f);
    const double point[2] = {point_flux(5.0, 3.0, &sq[0]), point_flux(5.0, 3.0, &sq[1])};
    check_light("point light", &s, a, point, sq);
    /* both at once: the guided pass also picks between the lights by what they are learned to send
     * where the marks are */
    s.lights = realloc(s.lights, 2 * sizeof *s.lights);
    s.lights[1] = s.lights[0];
    s.lights[0].type = PM_LIGHT_DIRECTIONAL;
    s.lights[0].intensity = v3s(2.f);
    s.light_count = 2;
    const double both[2] = {sun + point[0], sun + point[1]};
    check_light("sun and point light", &s, a, both, sq);
    /* a uniform sky of radiance 1 alone: irradiance pi on the floor's upper face; its directions and
     * its starts are guided apart */
    s.light_count = 0;
    pm_scene_set_sky(&s, true, v3s(1.f), NULL);
    const double sky[2] = {PM_PI, PM_PI};
    check_light("sky", &s, a, sky, sq);
    pm_accel_destroy(a);
    pm_scene_free(&s);
    return pm_test_done("test_guide");
}

/* test_grazing.c: hard case of scale: grazing light on a large plane (every lit pixel rho/pi E cos(theta), no shadow acne, no NaN).
 *
 * A Lambert plane 2e4 units across, seen from 2 units above it out to its far edge (hits up to
 * 1e4 away, where a float's spacing is 1e-3), lit by a directional light 85 and 89.5 degrees
 * from its normal. Nothing can shadow the plane, so every pixel that sees only the plane has the
 * radiance rho/pi x E cos(theta) exactly, whatever the sample: a shadow ray that hits the plane it
 * leaves from (acne, the usual failure at grazing angles and large distances) darkens it, a NaN is
 * dropped and counted. The criterion: every such pixel within 0.1% of the answer, none dropped,
 * the sky above the horizon black.
 */
#include "accel.h"
#include "eye.h"
#include "film.h"
#include "scene_builder.h"
#include "session_harness.h"
#include "testing.h"

#define W 48
#define H 48

/* Whether the camera rays through the pixel's four corners all hit the plane y = 0 inside |x|, |z| < half. */
static bool pixel_sees_only_plane(const pm_camera *c, int x, int y, float half) {
    for (int k = 0; k < 4; k++) {
        vec3 o, d;
        pm_camera_ray(c, W, H, (float)(x + (k & 1)), (float)(y + (k >> 1)), &o, &d);
        if (!(d.y < 0.f)) return false;
        double t = -o.y / d.y, px = o.x + t * d.x, pz = o.z + t * d.z;
        if (fabs(px) >= half * 0.999 || fabs(pz) >= half * 0.999) return false;
    }
    return true;
}

static void grazing(float theta_degrees) {
    const float half = 1e4f, rho = 0.5f, irradiance = 100.f;
    pm_scene s;
    memset(&s, 0, sizeof s);
    uint32_t m = sb_lambert(&s, v3s(rho));
    sb_quad(&s, v3(-half, 0, -half), v3(-half, 0, half), v3(half, 0, half), v3(half, 0, -half), m);
    float theta = theta_degrees * PM_PI / 180.f;
    s.lights = sb_grow(s.lights, s.light_count, sizeof *s.lights);
    pm_light sun;
    memset(&sun, 0, sizeof sun);
    sun.type = PM_LIGHT_DIRECTIONAL;
    sun.direction = v3_normalize(v3(sinf(theta) * 0.6f, -cosf(theta), sinf(theta) * 0.8f)); /* travels down, askew */
    sun.intensity = v3s(irradiance);
    s.lights[s.light_count++] = sun;
    pm_accel *a = sb_finish(&s);
    if (!a) { pm_scene_free(&s); return; }
    pm_camera cam = sb_camera(v3(3.f, 2.f, 5.f), v3(3.f, 0.f, -60.f), v3(0, 1, 0), 60.f);

    pm_session_config config = mode_config(PM_MODE_CLASSIC, W, H, 7, 2);
    config.eye.max_specular_depth = 8;
    const int iterations = 4;
    pm_session *session = render_session(&s, a, &cam, &config, iterations);
    if (!session) { pm_accel_destroy(a); pm_scene_free(&s); return; }
    const pm_film *film = pm_session_film(session);
    const pm_eye_stats stats = *pm_session_eye_stats(session);

    double want = rho / PM_PI * irradiance * -sun.direction.y; /* E cos(theta) reflected by Lambert */
    int checked = 0, off = 0, sky = 0, sky_lit = 0;
    double worst = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            const float *p = film->sum[PM_DIRECT] + 3 * ((size_t)y * W + x);
            double got = p[0] / iterations;
            if (pixel_sees_only_plane(&cam, x, y, half)) {
                checked++;
                double err = fabs(got - want) / want;
                worst = fmax(worst, err);
                if (!(err <= 1e-3)) off++;
            } else {
                vec3 o, d;
                pm_camera_ray(&cam, W, H, x + 0.5f, y + 0.5f, &o, &d);
                if (d.y > 0.01f) { /* well above the horizon */
                    sky++;
                    if (p[0] != 0.f) sky_lit++;
                }
            }
        }
    printf("theta %.1f deg: %d plane pixels, want %.6g, worst relative error %.2e, %d off; %d sky pixels\n",
           theta_degrees, checked, want, worst, off, sky);
    CHECK(checked > W * H / 3, "theta %g: only %d pixels see the plane", theta_degrees, checked);
    CHECK(off == 0, "theta %g: %d of %d plane pixels differ from rho/pi E cos(theta) = %g by over 0.1%% (worst %.3g): "
          "shadow acne or lost light", theta_degrees, off, checked, want, worst);
    CHECK(sky > 0 && sky_lit == 0, "theta %g: %d of %d sky pixels not black", theta_degrees, sky_lit, sky);
    CHECK(stats.dropped_samples == 0, "theta %g: %llu NaN/Inf samples dropped", theta_degrees,
          (unsigned long long)stats.dropped_samples);
    pm_session_destroy(session);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

int main(void) {
    grazing(85.f);
    grazing(89.5f);
    return pm_test_done("test_grazing");
}

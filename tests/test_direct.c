/* test_direct.c: the eye pass against analytic answers: inverse-square point light, emission seen directly, sky irradiance. */
#include <stdlib.h>

#include "accel.h"
#include "eye.h"
#include "film.h"
#include "scene_builder.h"
#include "session_harness.h"
#include "testing.h"

#define W 32
#define H 32

typedef struct {
    pm_scene scene;
    pm_accel *accel;
    pm_session *session;
    const pm_film *film; /* the session's */
    pm_camera camera;
} rig;

static void rig_render(rig *r, int iterations, int threads) {
    pm_scene_finalize(&r->scene, false, NULL);
    char err[256];
    r->accel = pm_accel_create(&r->scene, err, sizeof err);
    pm_session_config config = mode_config(PM_MODE_CLASSIC, W, H, 42, threads);
    config.eye.max_specular_depth = 8;
    r->session = render_session(&r->scene, r->accel, &r->camera, &config, (uint32_t)iterations);
    if (!r->session) exit(pm_test_done("test_direct"));
    r->film = pm_session_film(r->session);
}

static vec3 pixel_mean(const rig *r, pm_component c, int x, int y) {
    const float *p = r->film->sum[c] + 3 * ((size_t)y * W + x);
    return v3_scale(v3(p[0], p[1], p[2]), 1.f / r->film->samples);
}

static void rig_free(rig *r) {
    pm_session_destroy(r->session);
    pm_accel_destroy(r->accel);
    pm_scene_free(&r->scene);
}

/* L = rho/pi * I cos(theta) / d^2, averaged over the pixel's footprint (box filter) by
 * integrating the analytic formula on a fine grid of the same camera rays. */
static void point_light_over_plane(void) {
    rig r;
    memset(&r, 0, sizeof r);
    const float rho = 0.6f, h = 1.5f, intensity = 10.f;
    uint32_t m = sb_lambert(&r.scene, v3s(rho));
    sb_quad(&r.scene, v3(-20, 0, -20), v3(-20, 0, 20), v3(20, 0, 20), v3(20, 0, -20), m);
    sb_point_light(&r.scene, v3(0.3f, h, -0.2f), v3(intensity, intensity * 0.5f, intensity * 0.25f));
    r.camera = sb_camera(v3(0.5f, 4.f, 3.f), v3(0, 0, 0), v3(0, 1, 0), 50.f);
    rig_render(&r, 400, 2);
    CHECK(r.film->sum[PM_SPECULAR] == NULL && r.film->sum[PM_CAUSTIC] == NULL, "no buffer for components a Lambert plane cannot have");
    int pixels[5][2] = {{16, 16}, {4, 5}, {28, 9}, {10, 27}, {25, 25}};
    for (int k = 0; k < 5; k++) {
        int x = pixels[k][0], y = pixels[k][1];
        double want[3] = {0, 0, 0};
        const int n = 24;
        for (int i = 0; i < n; i++)
            for (int j = 0; j < n; j++) {
                vec3 o, d;
                pm_camera_ray(&r.camera, W, H, x + (i + 0.5f) / n, y + (j + 0.5f) / n, &o, &d);
                float t = -o.y / d.y;
                vec3 p = v3_madd(o, d, t), to_light = v3_sub(r.scene.lights[0].position, p);
                float d2 = v3_dot(to_light, to_light), cos_t = to_light.y / sqrtf(d2);
                float l = rho / PM_PI * cos_t / d2;
                want[0] += l * intensity; want[1] += l * intensity * 0.5f; want[2] += l * intensity * 0.25f;
            }
        vec3 got = pixel_mean(&r, PM_DIRECT, x, y);
        CHECK_NEAR(got.x, want[0] / (n * n), 0.01, 0, "point light R (inverse-square law)");
        CHECK_NEAR(got.y, want[1] / (n * n), 0.01, 0, "point light G");
        CHECK_NEAR(got.z, want[2] / (n * n), 0.01, 0, "point light B");
    }
    rig_free(&r);
}

/* A camera looking at the front face of an emitter sees exactly its radiance; the back face of a
 * single-sided emitter is black, of a double-sided one equal. */
static void emission_seen_directly(void) {
    for (int sided = 0; sided < 2; sided++)
        for (int from_back = 0; from_back < 2; from_back++) {
            rig r;
            memset(&r, 0, sizeof r);
            vec3 le = v3(3.f, 2.f, 0.5f);
            uint32_t m = sb_material(&r.scene, v3s(0.f), 0, 1, 0, le, sided == 1);
            sb_quad(&r.scene, v3(-1, -1, 0), v3(1, -1, 0), v3(1, 1, 0), v3(-1, 1, 0), m); /* faces +z */
            r.camera = sb_camera(v3(0, 0, from_back ? -3.f : 3.f), v3(0, 0, 0), v3(0, 1, 0), 20.f);
            rig_render(&r, 4, 1);
            vec3 got = pixel_mean(&r, PM_DIRECT, W / 2, H / 2);
            vec3 want = (from_back && !sided) ? v3s(0.f) : le;
            CHECK_NEAR(got.x, want.x, 1e-6, 0, "emitted R seen directly");
            CHECK_NEAR(got.y, want.y, 1e-6, 0, "emitted G seen directly");
            CHECK_NEAR(got.z, want.z, 1e-6, 0, "emitted B seen directly");
            rig_free(&r);
        }
}

/* A plane of albedo rho under a uniform sky of radiance 1: E = pi, L = rho (seen from above),
 * and the camera sees the sky itself where the plane is not. */
static void sky_over_plane(void) {
    rig r;
    memset(&r, 0, sizeof r);
    const float rho = 0.7f;
    uint32_t m = sb_lambert(&r.scene, v3s(rho));
    sb_quad(&r.scene, v3(-1e3f, 0, -1e3f), v3(-1e3f, 0, 1e3f), v3(1e3f, 0, 1e3f), v3(1e3f, 0, -1e3f), m);
    r.camera = sb_camera(v3(0, 2, 0.01f), v3(0, 0, 0), v3(0, 0, -1), 30.f);
    r.scene.sky = false;
    pm_scene_finalize(&r.scene, true, NULL); /* adds the default sky */
    CHECK(r.scene.sky && r.scene.sky_radiance.x == 1.f, "a scene without lights gets the white sky");
    rig_render(&r, 256, 2);
    double sum = 0;
    for (int y = 8; y < 24; y++)
        for (int x = 8; x < 24; x++) sum += v3_average(pixel_mean(&r, PM_DIRECT, x, y));
    CHECK_NEAR(sum / 256.0, rho, 0.01, 0, "sky-lit plane radiance = albedo x sky radiance");
    rig_free(&r);
}

/* A mirror at 45 degrees shows an emitter: the specular component carries reflectance x Le,
 * and direct stays empty for those pixels. */
static void emitter_seen_in_mirror(void) {
    rig r;
    memset(&r, 0, sizeof r);
    vec3 le = v3s(2.f);
    float refl = 0.8f;
    uint32_t mirror = sb_material(&r.scene, v3s(refl), 1, 0, 0, v3s(0), false);
    uint32_t lamp = sb_material(&r.scene, v3s(0), 0, 1, 0, le, true);
    /* mirror plane y = -z (normal (0,1,1)/sqrt2) reflects the -z looking camera up to +y */
    sb_quad(&r.scene, v3(-5, -5, 5), v3(5, -5, 5), v3(5, 5, -5), v3(-5, 5, -5), mirror);
    sb_quad(&r.scene, v3(-50, 10, 50), v3(50, 10, 50), v3(50, 10, -50), v3(-50, 10, -50), lamp);
    r.camera = sb_camera(v3(0, 0, 3), v3(0, 0, 0), v3(0, 1, 0), 10.f);
    rig_render(&r, 2, 1);
    vec3 spec = pixel_mean(&r, PM_SPECULAR, W / 2, H / 2), direct = pixel_mean(&r, PM_DIRECT, W / 2, H / 2);
    /* glTF's smooth metal: Schlick's reflectance, here at 45 degrees */
    double schlick = refl + (1.0 - refl) * pow(1.0 - sqrt(0.5), 5.0);
    CHECK_NEAR(spec.x, schlick * le.x, 2e-5, 0, "emitter seen in a mirror goes to specular");
    CHECK_NEAR(direct.x, 0.0, 0, 1e-7, "nothing of it in direct");
    rig_free(&r);
}

int main(void) {
    point_light_over_plane();
    emission_seen_directly();
    sky_over_plane();
    emitter_seen_in_mirror();
    return pm_test_done("test_direct");
}

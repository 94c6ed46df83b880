/* test_volume.c: KHR_materials_volume against Beer-Lambert: the loader's coefficient, light seen through an absorbing slab, photons through it. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "accel.h"
#include "eye.h"
#include "film.h"
#include "loader.h"
#include "photonmap.h"
#include "scene_builder.h"
#include "session_harness.h"
#include "testing.h"

/* One triangle whose material has the given KHR_materials_volume object (JSON text). */
static bool load_volume(const char *volume, pm_scene *s, char *err, size_t err_size) {
    static const char positions_base64[] = "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"; /* (0,0,0) (1,0,0) (0,1,0) */
    char path[64];
    snprintf(path, sizeof path, "/tmp/pm_test_volume_%ld.gltf", (long)getpid());
    FILE *f = fopen(path, "w");
    if (!f) return false;
    fprintf(f,
            "{\"asset\":{\"version\":\"2.0\"},\"extensionsUsed\":[\"KHR_materials_volume\",\"KHR_materials_transmission\"],"
            "\"buffers\":[{\"byteLength\":36,\"uri\":\"data:application/octet-stream;base64,%s\"}],"
            "\"bufferViews\":[{\"buffer\":0,\"byteLength\":36}],"
            "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]}],"
            "\"materials\":[{\"extensions\":{\"KHR_materials_transmission\":{\"transmissionFactor\":1},"
            "\"KHR_materials_volume\":%s}}],"
            "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"material\":0}]}],"
            "\"nodes\":[{\"mesh\":0}],\"scenes\":[{\"nodes\":[0]}],\"scene\":0}\n",
            positions_base64, volume);
    fclose(f);
    pm_load_report r;
    bool ok = pm_load_gltf(path, true, s, &r, err, err_size);
    remove(path);
    return ok;
}

static void loader_coefficient(void) {
    pm_scene s;
    char err[512];
    bool ok = load_volume("{\"thicknessFactor\":0.5,\"attenuationDistance\":2,\"attenuationColor\":[0.5,0.25,1]}", &s, err, sizeof err);
    CHECK(ok, "volume material loads: %s", err);
    if (ok) {
        vec3 a = s.materials[0].attenuation;
        CHECK_NEAR(a.x, log(2.0) / 2, 1e-5, 0, "sigma = -ln(color) / distance (R)");
        CHECK_NEAR(a.y, log(4.0) / 2, 1e-5, 0, "sigma = -ln(color) / distance (G)");
        CHECK_NEAR(a.z, 0, 0, 1e-7, "colour 1 absorbs nothing (B)");
        pm_scene_free(&s);
    }
    ok = load_volume("{\"thicknessFactor\":0,\"attenuationDistance\":2,\"attenuationColor\":[0.5,0.5,0.5]}", &s, err, sizeof err);
    CHECK(ok && v3_is_black(s.materials[0].attenuation), "thickness 0 is thin-walled: no volume");
    if (ok) pm_scene_free(&s);
    ok = load_volume("{\"thicknessFactor\":1,\"attenuationColor\":[0.5,0.5,0.5]}", &s, err, sizeof err);
    CHECK(ok && v3_is_black(s.materials[0].attenuation), "no attenuationDistance: infinite, nothing absorbed");
    if (ok) pm_scene_free(&s);
    ok = load_volume("{\"thicknessFactor\":1,\"attenuationDistance\":1,\"attenuationColor\":[0.5,0.5]}", &s, err, sizeof err);
    CHECK(!ok && strstr(err, "attenuationColor"), "a colour of 2 numbers is refused, naming the field: %s", err);
    if (ok) pm_scene_free(&s);
    ok = load_volume("{\"thicknessFactor\":1,\"attenuationDistance\":-1}", &s, err, sizeof err);
    CHECK(!ok && strstr(err, "attenuationDistance"), "a negative distance is refused: %s", err);
    if (ok) pm_scene_free(&s);
}

/* A slab of clear glass of ior 1 (no refraction, no Fresnel) and thickness L, sigma per channel:
 * an emitter seen through it reads Le exp(-sigma L), and photons through it carry that fraction. */
/* The slab (glass of ior 1 between y = 1 and 1 + L) over a floor, with a point light above it,
 * and with a lamp (a quad facing down at y = 4) when asked. */
static pm_accel *slab_scene(pm_scene *s, float L, vec3 sigma, bool lamp) {
    memset(s, 0, sizeof *s);
    uint32_t glass = sb_material(s, v3s(1.f), 0, 0, 1, v3s(0), false);
    s->materials[glass].ior = 1.f;
    s->materials[glass].attenuation = sigma;
    uint32_t floor_m = sb_lambert(s, v3s(0.5f));
    sb_box(s, v3(-5, 1, -5), v3(5, 1 + L, 5), glass, false);
    sb_quad(s, v3(-20, 0, -20), v3(-20, 0, 20), v3(20, 0, 20), v3(20, 0, -20), floor_m);
    if (lamp) {
        uint32_t m = sb_material(s, v3s(0), 0, 1, 0, v3s(1.f), false);
        sb_quad(s, v3(-20, 4, -20), v3(20, 4, -20), v3(20, 4, 20), v3(-20, 4, 20), m);
    } else {
        sb_point_light(s, v3(0, 3, 0), v3s(10.f));
    }
    pm_scene_finalize(s, false, NULL);
    char err[256];
    pm_accel *a = pm_accel_create(s, err, sizeof err);
    CHECK(a != NULL, "accel: %s", err);
    return a;
}

/* A slab of clear glass of ior 1 (no refraction, no Fresnel) and thickness L, sigma per channel:
 * an emitter seen through it reads Le exp(-sigma L), and photons through it carry that fraction. */
static void slab(void) {
    const float L = 0.5f;
    const vec3 sigma = v3(0.8f, 2.f, 0.f);
    for (int absorbing = 0; absorbing < 2; absorbing++) {
        vec3 want = absorbing ? v3(expf(-sigma.x * L), expf(-sigma.y * L), 1.f) : v3s(1.f);
        pm_scene s;
        pm_accel *a = slab_scene(&s, L, absorbing ? sigma : v3s(0.f), true);
        /* a camera just above the floor looking up through the slab at the lamp */
        pm_camera cam = sb_camera(v3(0, 0.5f, 0), v3(0, 4, 0), v3(0, 0, -1), 5.f);
        pm_session_config config = mode_config(PM_MODE_CLASSIC, 8, 8, 3, 2);
        config.eye.max_specular_depth = 8;
        pm_session *session = render_session(&s, a, &cam, &config, 1);
        const pm_film *film = session ? pm_session_film(session) : NULL;
        const float nothing[3] = {-1.f, -1.f, -1.f}; /* fails every check below */
        const float *px = film && film->sum[PM_SPECULAR] ? film->sum[PM_SPECULAR] + 3 * (4 * 8 + 4) : nothing;
        /* 0.5%: ray origins step off each face by about 1.5e-5 of the scene's extent (40 here),
         * which shortens the path inside by 6e-4 */
        CHECK_NEAR(px[0], want.x, 5e-3, 0, absorbing ? "lamp through the slab: Le exp(-sigma L) (R)" : "clear slab: Le (R)");
        CHECK_NEAR(px[1], want.y, 5e-3, 0, absorbing ? "lamp through the slab: Le exp(-sigma L) (G)" : "clear slab: Le (G)");
        CHECK_NEAR(px[2], want.z, 5e-3, 0, "a channel with sigma 0 passes whole (B)");
        pm_session_destroy(session);
        pm_accel_destroy(a);
        pm_scene_free(&s);

        /* caustic photons from the point light through the slab onto a small floor patch below it */
        a = slab_scene(&s, L, absorbing ? sigma : v3s(0.f), false);
        pm_photon_settings ps;
        memset(&ps, 0, sizeof ps);
        ps.seed = 4;
        ps.threads = 2;
        ps.max_bounces = 8;
        ps.projection_maps = true;
        pm_photon_tracer *t = pm_photon_tracer_create(&s, a, &ps);
        pm_photon_buffer buf = {NULL, 0, 0};
        pm_photon_stats st;
        memset(&st, 0, sizeof st);
        CHECK(t && pm_photon_tracer_trace_into(t, true, 2000000, 1, &buf, &st), "caustic pass");
        double power[3] = {0, 0, 0};
        const float half = 0.5f;
        for (size_t i = 0; t && i < buf.count; i++) {
            vec3 p = pm_photon_position(&buf.data[i]);
            if (fabsf(p.y) > 1e-3f || fabsf(p.x) > half || fabsf(p.z) > half) continue;
            vec3 w = pm_photon_power(&buf.data[i]);
            power[0] += w.x;
            power[1] += w.y;
            power[2] += w.z;
        }
        /* the patch's irradiance integrated: I cos / r^2, each ray through the slab along L / cos */
        double want_power[3] = {0, 0, 0};
        const int n = 200;
        for (int i = 0; i < n; i++)
            for (int j = 0; j < n; j++) {
                double x = -half + (i + 0.5) * 2 * half / n, z = -half + (j + 0.5) * 2 * half / n;
                double r2 = x * x + z * z + 9.0, c = 3.0 / sqrt(r2), e = 10.0 * c / r2 * (2 * half / n) * (2 * half / n);
                double path = absorbing ? L / c : 0.0;
                want_power[0] += e * exp(-sigma.x * path);
                want_power[1] += e * exp(-sigma.y * path);
                want_power[2] += e * exp(-sigma.z * path);
            }
        CHECK_NEAR(power[0], want_power[0], 0.02, 0, "photons through the slab: I cos/r^2 exp(-sigma L/cos) over the patch (R)");
        CHECK_NEAR(power[1], want_power[1], 0.02, 0, "photons through the slab (G)");
        CHECK_NEAR(power[2], want_power[2], 0.02, 0, "photons through the slab (B)");
        free(buf.data);
        pm_photon_tracer_destroy(t);
        pm_accel_destroy(a);
        pm_scene_free(&s);
    }
}

int main(void) {
    loader_coefficient();
    slab();
    return pm_test_done("test_volume");
}

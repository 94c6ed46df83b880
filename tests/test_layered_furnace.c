/* test_layered_furnace.c: a closed box of clearcoated, sheened walls rendered by the photon modes and the path tracer: photons estimate the layered lobe as paths do, and the furnace stays within its albedo bounds. */
#include <stdlib.h>
#include <string.h>

#include "accel.h"
#include "brdf.h"
#include "defaults.h"
#include "film.h"
#include "scene_builder.h"
#include "progressive_harness.h"
#include "rng.h"
#include "session.h"
#include "testing.h"

enum { W = 16, H = 16 };

static double image_mean(pm_session *session) {
    float *total = malloc(sizeof(float) * 3 * W * H);
    if (!total) abort();
    pm_film_resolve_total(pm_session_film(session), total);
    double m = mean_of(total, 3 * W * H);
    free(total);
    return m;
}

/* The lobe's directional albedo over cosines: its least and greatest (sampled, many directions). */
static void albedo_range(const pm_brdf *b, double *lo, double *hi) {
    *lo = 1e9;
    *hi = 0.0;
    pm_rng rng = pm_rng_for(11, 0, 0);
    for (int k = 0; k <= 20; k++) {
        float c = pm_maxf(0.02f, k / 20.f), s = sqrtf(1.f - c * c);
        vec3 wo = v3(s, 0.f, c), n = v3(0, 0, 1);
        double sum = 0.0;
        const int count = 20000;
        for (int i = 0; i < count; i++) {
            vec3 wi, f;
            float pdf;
            if (pm_brdf_sample(b, n, wo, pm_rng_float(&rng), pm_rng_float(&rng), pm_rng_float(&rng), &wi, &f, &pdf))
                sum += v3_average(f) * wi.z / pdf;
        }
        *lo = fmin(*lo, sum / count);
        *hi = fmax(*hi, sum / count);
    }
}

int main(void) {
    const float le = 0.5f;
    pm_scene s;
    memset(&s, 0, sizeof s);
    uint32_t m = sb_material(&s, v3s(0.6f), 0.f, 1.f, 0.f, v3s(le), false);
    pm_material *mat = &s.materials[m];
    mat->layered = true;
    pm_material_layers *l = &mat->layers;
    l->specular = 1.f;
    l->specular_color = v3s(1.f);
    l->sheen_color = v3(0.9f, 0.7f, 0.5f);
    l->sheen_roughness = 0.5f;
    l->clearcoat = 1.f;
    l->clearcoat_roughness = 0.4f;
    pm_texture_ref *refs[] = {&l->specular_texture, &l->specular_color_texture, &l->sheen_color_texture,
                              &l->sheen_roughness_texture, &l->clearcoat_texture, &l->clearcoat_roughness_texture,
                              &l->clearcoat_normal_texture};
    for (size_t k = 0; k < sizeof refs / sizeof *refs; k++) refs[k]->texture = -1;
    sb_box(&s, v3(-1, -1, -1), v3(1, 1, 1), m, true);
    pm_accel *a = sb_finish(&s);
    CHECK(s.materials[m].may_glossy && !s.materials[m].may_diffuse, "layered walls are the glossy lobe");
    pm_camera cam = sb_camera(v3(0, 0, 0.5f), v3(0.3f, -0.2f, -1), v3(0, 1, 0), 60.f);

    pm_brdf b = pm_brdf_at(v3s(0.6f), 0.f, 1.f, 0.f);
    pm_brdf_add_layers(&b, 1.f, v3s(1.f), l->sheen_color, l->sheen_roughness, l->clearcoat, l->clearcoat_roughness);
    double lo, hi;
    albedo_range(&b, &lo, &hi);

    pm_session_config pt;
    pm_session_config_defaults(&pt, PM_MODE_PATHTRACE, W, H, 5, 2);
    char err[256];
    pm_session *path = pm_session_create(&s, a, &cam, &pt, err, sizeof err);
    CHECK(path != NULL, "path tracer: %s", err);
    for (int i = 0; path && i < 48; i++) CHECK(pm_session_iterate(path, 0), "path iteration %d", i);
    double traced = path ? image_mean(path) : 0.0;

    pm_progressive_settings ps = default_settings(W, H);
    ps.photons = 4000;
    session r;
    double photons = 0.0;
    if (start(&r, &s, a, &cam, W, H, &ps)) {
        iterate(&r, 48);
        photons = image_mean(r.session);
        stop(&r);
    }
    /* each bounce multiplies by an albedo within [lo, hi]: L between le / (1 - lo) and le / (1 - hi) */
    printf("layered furnace (Lambert 0.6, sheen, coat): albedo %.4f..%.4f, bounds %.4f..%.4f; path tracer %.4f, progressive %.4f (ratio %.4f)\n",
           lo, hi, le / (1 - lo), le / (1 - hi), traced, photons, photons / traced);
    CHECK(traced >= 0.98 * le / (1 - lo) && traced <= 1.02 * le / (1 - hi), "path tracer within the albedo bounds");
    CHECK(photons >= 0.97 * le / (1 - lo) && photons <= 1.03 * le / (1 - hi), "progressive within the albedo bounds");
    CHECK_NEAR(photons, traced, 0.03, 0, "photons estimate the layered lobe as paths do");
    if (path) pm_session_destroy(path);
    pm_accel_destroy(a);
    pm_scene_free(&s);
    return pm_test_done("test_layered_furnace");
}

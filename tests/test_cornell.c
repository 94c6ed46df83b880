/* test_cornell.c: the default scene end to end: expected colours, no NaN or negative value, each component where its first vertex puts it, layers summing to the EXR total. */
#define _DEFAULT_SOURCE /* mkstemps */
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "accel.h"
#include "defaults.h"
#include "eye.h"
#include "film.h"
#include "image_io.h"
#include "loader.h"
#include "photonmap.h"
#include "session_harness.h"
#include "testing.h"

#define W 48
#define H 48

static vec3 region_mean(const float *img, int x0, int y0, int x1, int y1) {
    double s[3] = {0, 0, 0};
    int n = 0;
    for (int y = y0; y < y1; y++)
        for (int x = x0; x < x1; x++, n++)
            for (int c = 0; c < 3; c++) s[c] += img[3 * (y * W + x) + c];
    return v3((float)(s[0] / n), (float)(s[1] / n), (float)(s[2] / n));
}

int main(void) {
    pm_scene s;
    pm_load_report rep;
    char err[1024];
    if (!pm_load_gltf("scenes/cornell-box.gltf", true, &s, &rep, err, sizeof err)) {
        CHECK(false, "load: %s", err);
        return pm_test_done("test_cornell");
    }
    pm_scene_finalize(&s, true, NULL);
    CHECK(s.camera_count >= 1, "the Cornell box ships a camera");
    CHECK(s.emitter_count > 0 && !s.sky, "lit by its ceiling lamp, no default sky");
    CHECK(s.analysis.has_mirror && s.analysis.has_glass && s.analysis.caustics_possible, "mirror and glass balls: caustics possible");
    /* the photon pass's lean hit record (and its shading part) holds what pm_scene_surface does,
     * bit for bit, on every triangle: plain walls, the smooth mirror and glass balls, the lamp */
    int lean_bad = 0, lean_plain = 0;
    for (uint32_t t = 0; t < s.triangle_count; t++)
        for (int k = 0; k < 4; k++) {
            float b1 = (k & 1) ? 0.7f : 0.15f, b2 = (k & 2) ? 0.2f : 0.05f;
            pm_surface full, lean;
            memset(&lean, 0, sizeof lean);
            pm_scene_surface(&s, t, b1, b2, &full);
            if (pm_scene_surface_lean(&s, t, b1, b2, &lean)) {
                lean_plain++;
                pm_scene_surface_shading(&s, t, b1, b2, &lean);
            }
            bool same = !memcmp(&full.p, &lean.p, sizeof full.p) && !memcmp(&full.ng, &lean.ng, sizeof full.ng) &&
                        !memcmp(&full.ns, &lean.ns, sizeof full.ns) && !memcmp(&full.centroid, &lean.centroid, sizeof full.centroid) &&
                        full.material == lean.material && !memcmp(&full.kd, &lean.kd, sizeof full.kd) &&
                        !memcmp(&full.ks, &lean.ks, sizeof full.ks) && !memcmp(&full.kt, &lean.kt, sizeof full.kt) &&
                        full.glossy == lean.glossy && full.ior == lean.ior && full.thin == lean.thin &&
                        (!full.glossy || !memcmp(&full.brdf, &lean.brdf, sizeof full.brdf));
            lean_bad += !same;
        }
    CHECK(lean_bad == 0 && lean_plain == 4 * (int)s.triangle_count, "lean hit records: %d differ from pm_scene_surface, %d of %u plain",
          lean_bad, lean_plain, 4 * s.triangle_count);
    pm_accel *a = pm_accel_create(&s, err, sizeof err);
    pm_photon_settings ps = {.global_photons = 100000, .caustic_photons = 100000, .seed = 1, .threads = 2,
                             .max_bounces = PM_DEFAULT_MAX_PHOTON_BOUNCES, .projection_maps = true};
    pm_session_config config = mode_config(PM_MODE_CLASSIC, W, H, 1, 2);
    config.eye.max_specular_depth = 12;
    with_photons(&config, &ps, (pm_estimate_settings){PM_KERNEL_DISC, 64, 0.1f * s.ray_scale, 7u},
                 (pm_estimate_settings){PM_KERNEL_DISC, 64, 0.025f * s.ray_scale, 7u});
    config.eye.gather_rays = 1;
    pm_camera cam = s.cameras[0];
    pm_session *session = render_session(&s, a, &cam, &config, 16);
    if (!session) return pm_test_done("test_cornell");
    const pm_photon_maps *maps = pm_session_classic_maps(session);
    CHECK(maps->caustic.count > 0 && maps->global.count > 0, "both maps built");
    const pm_film *film = pm_session_film(session);
    pm_eye_stats st = *pm_session_eye_stats(session);
    CHECK(st.dropped_samples == 0, "%llu samples were NaN or infinite", (unsigned long long)st.dropped_samples);

    float *total = malloc(sizeof(float) * 3 * W * H), *layer = malloc(sizeof(float) * 3 * W * H);
    pm_film_resolve_total(film, total);
    int bad = 0;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        pm_film_resolve(film, c, layer);
        for (int i = 0; i < 3 * W * H; i++) bad += !(layer[i] >= 0.f) || !isfinite(layer[i]);
    }
    CHECK(bad == 0, "%d NaN, infinite or negative values in the layers", bad);
    vec3 left = region_mean(total, 1, H / 3, W / 10, 2 * H / 3), right = region_mean(total, W - W / 10, H / 3, W - 1, 2 * H / 3);
    vec3 floor_ = region_mean(total, W / 3, H - H / 12, 2 * W / 3, H - 1);
    CHECK(left.x > 2.f * left.y && left.x > 2.f * left.z, "left wall is red (%g %g %g)", left.x, left.y, left.z);
    CHECK(right.y > 1.5f * right.x && right.y > 1.5f * right.z, "right wall is green (%g %g %g)", right.x, right.y, right.z);
    CHECK(v3_average(floor_) > 0.05f, "floor is lit (%g)", v3_average(floor_));
    float *comp_sum[PM_COMPONENT_COUNT];
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) comp_sum[c] = film->sum[c];
    CHECK(comp_sum[PM_CAUSTIC] && comp_sum[PM_INDIRECT] && comp_sum[PM_SPECULAR], "all four components allocated");
    double caustic_energy = 0, indirect_energy = 0;
    pm_film_resolve(film, PM_CAUSTIC, layer);
    for (int i = 0; i < 3 * W * H; i++) caustic_energy += layer[i];
    pm_film_resolve(film, PM_INDIRECT, layer);
    for (int i = 0; i < 3 * W * H; i++) indirect_energy += layer[i];
    CHECK(caustic_energy > 0 && indirect_energy > 0, "caustic %g and indirect %g are non-zero", caustic_energy, indirect_energy);

    /* The split by first eye vertex, pixel by pixel: where every ray of a pixel (centre and four
     * corners) first meets the same kind of surface, the layers that vertex rules out hold exactly
     * nothing, and the lamp seen directly is its emission and nothing else. */
    enum { LAMP, MIRROR_OR_GLASS, DIFFUSE, MIXED_PIXEL };
    int counts[3] = {0, 0, 0}, misfiled[3] = {0, 0, 0};
    vec3 lamp_radiance = v3s(0.f);
    float *layers[PM_COMPONENT_COUNT];
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        layers[c] = malloc(sizeof(float) * 3 * W * H);
        pm_film_resolve(film, c, layers[c]);
    }
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            int kind = -1;
            static const float at[5][2] = {{0.5f, 0.5f}, {0.f, 0.f}, {1.f, 0.f}, {0.f, 1.f}, {1.f, 1.f}};
            for (int k = 0; k < 5 && kind != MIXED_PIXEL; k++) {
                vec3 o, d;
                pm_camera_ray(&cam, W, H, x + at[k][0], y + at[k][1], &o, &d);
                pm_hit hit;
                int this_kind = MIXED_PIXEL;
                if (pm_accel_intersect(a, o, d, INFINITY, &hit)) {
                    pm_surface sf;
                    pm_scene_surface(&s, hit.tri, hit.b1, hit.b2, &sf);
                    if (!v3_is_black(sf.emission)) { this_kind = LAMP; lamp_radiance = sf.emission; }
                    else if (v3_is_black(sf.kd)) this_kind = MIRROR_OR_GLASS;
                    else if (v3_is_black(sf.ks) && v3_is_black(sf.kt)) this_kind = DIFFUSE;
                }
                kind = kind < 0 || kind == this_kind ? this_kind : MIXED_PIXEL;
            }
            if (kind == MIXED_PIXEL) continue;
            counts[kind]++;
            size_t i = 3 * ((size_t)y * W + x);
            for (int ch = 0; ch < 3; ch++) {
                float direct = layers[PM_DIRECT][i + ch], spec = layers[PM_SPECULAR][i + ch];
                float caustic = layers[PM_CAUSTIC][i + ch], indirect = layers[PM_INDIRECT][i + ch];
                bool ok = true;
                if (kind == LAMP) ok = spec == 0.f && caustic == 0.f && indirect == 0.f &&
                                       fabsf(direct - v3_get(lamp_radiance, ch)) <= 1e-4f * v3_get(lamp_radiance, ch);
                if (kind == MIRROR_OR_GLASS) ok = direct == 0.f && caustic == 0.f && indirect == 0.f && spec >= 0.f;
                if (kind == DIFFUSE) ok = spec == 0.f;
                if (!ok) { misfiled[kind]++; break; }
            }
        }
    CHECK(counts[LAMP] >= 4 && counts[MIRROR_OR_GLASS] >= 40 && counts[DIFFUSE] >= 1000,
          "pixels of each kind: lamp %d, mirror or glass %d, diffuse %d", counts[LAMP], counts[MIRROR_OR_GLASS], counts[DIFFUSE]);
    CHECK(misfiled[LAMP] == 0, "%d lamp pixels are not exactly its emission in the direct layer", misfiled[LAMP]);
    CHECK(misfiled[MIRROR_OR_GLASS] == 0, "%d pixels seeing a mirror or glass first have direct, caustic or indirect light",
          misfiled[MIRROR_OR_GLASS]);
    CHECK(misfiled[DIFFUSE] == 0, "%d pixels seeing a diffuse wall first have specular light", misfiled[DIFFUSE]);
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) free(layers[c]);

    /* EXR: the layers read back sum to the total */
    char path[] = "/tmp/pmview-cornell-XXXXXX.exr";
    int fd = mkstemps(path, 4);
    if (fd >= 0) close(fd);
    CHECK(pm_write_exr(path, film, err, sizeof err), "write EXR: %s", err);
    int w, h;
    const char *names[3] = {"R", "G", "B"};
    for (int c = 0; c < 3; c++) {
        float *t = pm_read_exr_channel(path, names[c], &w, &h, err, sizeof err);
        CHECK(t && w == W && h == H, "read %s: %s", names[c], err);
        if (!t) continue;
        double max_diff = 0;
        float *parts[PM_COMPONENT_COUNT];
        for (int k = 0; k < PM_COMPONENT_COUNT; k++) {
            char name[32];
            snprintf(name, sizeof name, "%s.%s", pm_component_names[k], names[c]);
            parts[k] = pm_read_exr_channel(path, name, &w, &h, err, sizeof err);
            CHECK(parts[k] != NULL, "layer %s: %s", name, err);
        }
        for (int i = 0; i < W * H; i++) {
            double sum = 0;
            for (int k = 0; k < PM_COMPONENT_COUNT; k++) sum += parts[k] ? parts[k][i] : 0;
            double d = fabs(sum - t[i]) / (fabs(t[i]) + 1e-6);
            if (d > max_diff) max_diff = d;
        }
        CHECK(max_diff < 1e-5, "layers sum to the total in channel %s (max rel diff %g)", names[c], max_diff);
        for (int k = 0; k < PM_COMPONENT_COUNT; k++) free(parts[k]);
        free(t);
    }
    unlink(path);
    free(total);
    free(layer);
    pm_session_destroy(session);
    pm_accel_destroy(a);
    pm_scene_free(&s);
    return pm_test_done("test_cornell");
}

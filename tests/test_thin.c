/* test_thin.c: thin-walled transmission (KHR_materials_transmission without a volume): the loader's choice, a window seen through unshifted, photons and direct light across it, a solid slab that refracts. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "accel.h"
#include "film.h"
#include "loader.h"
#include "photonmap.h"
#include "scene_builder.h"
#include "session_harness.h"
#include "testing.h"

/* Unpolarised Fresnel reflectance from air into a dielectric of index n at incidence cos_i, from
 * Snell's law and the two amplitude ratios (written out here, not the renderer's function). */
static double fresnel(double cos_i, double n) {
    double sin_t = sqrt(fmax(0.0, 1.0 - cos_i * cos_i)) / n, cos_t = sqrt(1.0 - sin_t * sin_t);
    double rs = (cos_i - n * cos_t) / (cos_i + n * cos_t), rp = (n * cos_i - cos_t) / (n * cos_i + cos_t);
    return 0.5 * (rs * rs + rp * rp);
}

/* One triangle whose material is base colour (1, 0.75, 0.5), transmission 1 and ior 1.5, with the
 * KHR_materials_volume object `volume` (JSON text, NULL for none). */
static bool load_pane_material(const char *volume, pm_scene *s) {
    static const char positions_base64[] = "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"; /* (0,0,0) (1,0,0) (0,1,0) */
    char json[2048], extension[256] = "";
    if (volume) snprintf(extension, sizeof extension, ",\"KHR_materials_volume\":%s", volume);
    snprintf(json, sizeof json,
             "{\"asset\":{\"version\":\"2.0\"},\"extensionsUsed\":[\"KHR_materials_volume\",\"KHR_materials_transmission\"],"
             "\"buffers\":[{\"byteLength\":36,\"uri\":\"data:application/octet-stream;base64,%s\"}],"
             "\"bufferViews\":[{\"buffer\":0,\"byteLength\":36}],"
             "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]}],"
             "\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorFactor\":[1,0.75,0.5,1],\"metallicFactor\":0,\"roughnessFactor\":0},"
             "\"extensions\":{\"KHR_materials_transmission\":{\"transmissionFactor\":1}%s}}],"
             "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"material\":0}]}],"
             "\"nodes\":[{\"mesh\":0}],\"scenes\":[{\"nodes\":[0]}],\"scene\":0}",
             positions_base64, extension);
    pm_load_report r;
    char err[512];
    bool ok = pm_load_gltf_memory(json, strlen(json), "pane.gltf", true, s, &r, err, sizeof err);
    CHECK(ok, "pane material loads (%s): %s", volume ? volume : "no volume", err);
    if (ok) pm_scene_finalize(s, false, NULL);
    return ok;
}

/* The loaded materials: [0] no volume, [1] a volume of thickness 0, [2] a volume of thickness 0.5. */
static pm_material loaded[3];

static void loader_choice(void) {
    const char *volumes[3] = {NULL, "{\"thicknessFactor\":0,\"attenuationDistance\":2}", "{\"thicknessFactor\":0.5}"};
    for (int k = 0; k < 3; k++) {
        pm_scene s;
        memset(&loaded[k], 0, sizeof loaded[k]);
        if (!load_pane_material(volumes[k], &s)) continue;
        loaded[k] = s.materials[0];
        CHECK(s.materials[0].thin_walled == (k < 2), "material %d: thin-walled %d, want %d", k, s.materials[0].thin_walled, k < 2);
        CHECK(s.analysis.has_glass && s.analysis.has_thin_glass == (k < 2), "material %d: analysis has_thin_glass %d", k,
              s.analysis.has_thin_glass);
        pm_scene_free(&s);
    }
    /* an opaque scene has no thin glass: its shadow rays stay pm_accel_occluded */
    pm_scene s;
    memset(&s, 0, sizeof s);
    uint32_t m = sb_lambert(&s, v3s(0.5f));
    sb_quad(&s, v3(-1, 0, -1), v3(-1, 0, 1), v3(1, 0, 1), v3(1, 0, -1), m);
    s.materials[m].thin_walled = true; /* no transmission: nothing to cross */
    sb_point_light(&s, v3(0, 1, 0), v3s(1));
    pm_accel_destroy(sb_finish(&s));
    CHECK(!s.analysis.has_thin_glass, "a thin-walled material without transmission is no thin glass");
    pm_scene_free(&s);
}

/* The roughness window_scene gives its panes (the loaded ones say roughnessFactor 0). */
static float pane_roughness = 0.f;

/* A pane material as the loader made it (textures none), given to a builder scene. */
static uint32_t add_loaded(pm_scene *s, const pm_material *m) {
    uint32_t i = sb_material(s, v3s(0), 0, 1, 0, v3s(0), false);
    pm_material copy = *m;
    copy.used = false;
    copy.roughness = pane_roughness;
    s->materials[i] = copy;
    return i;
}

enum { PANE_NONE, PANE_THIN, PANE_THICK_ZERO, PANE_SLAB };
#define SLAB 1.f /* the slab's thickness */

/* An emitter of radiance 1 over x < 0 of the plane z = 0 (facing +z), black beyond its edge x = 0,
 * seen by an orthographic camera along (sin theta, 0, -cos theta) through a pane at z = 1 (a
 * single quad), a solid slab z in [1, 1 + SLAB], or nothing. */
static pm_accel *window_scene(pm_scene *s, int pane, float theta, pm_camera *cam) {
    memset(s, 0, sizeof *s);
    uint32_t lamp = sb_material(s, v3s(0), 0, 1, 0, v3s(1), false);
    sb_quad(s, v3(-10, -10, 0), v3(0, -10, 0), v3(0, 10, 0), v3(-10, 10, 0), lamp);
    if (pane == PANE_THIN || pane == PANE_THICK_ZERO) {
        uint32_t m = add_loaded(s, &loaded[pane == PANE_THIN ? 0 : 1]);
        sb_quad(s, v3(-20, -20, 1), v3(20, -20, 1), v3(20, 20, 1), v3(-20, 20, 1), m);
    } else if (pane == PANE_SLAB) {
        uint32_t m = add_loaded(s, &loaded[2]);
        sb_box(s, v3(-20, -20, 1), v3(20, 20, 1 + SLAB), m, false);
    }
    vec3 forward = v3(sinf(theta), 0, -cosf(theta));
    *cam = sb_camera(v3_scale(forward, -6.f), v3s(0), v3(0, 1, 0), 30.f);
    cam->orthographic = true;
    cam->ymag = 0.25f;
    return sb_finish(s);
}

enum { WIN_W = 64, WIN_H = 16, WIN_SAMPLES = 48 };

/* The window's image (all components, eye passes only: emission through the specular chain). */
static void window_image(int pane, float theta, float *out) {
    pm_scene s;
    pm_camera cam;
    pm_accel *a = window_scene(&s, pane, theta, &cam);
    pm_session_config config = mode_config(PM_MODE_CLASSIC, WIN_W, WIN_H, 7, 2);
    config.eye.max_specular_depth = 8;
    pm_session *session = render_session(&s, a, &cam, &config, WIN_SAMPLES);
    if (session) pm_film_resolve_total(pm_session_film(session), out);
    else memset(out, 0, sizeof(float) * 3 * WIN_W * WIN_H);
    pm_session_destroy(session);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

/* Where the emitter's edge is across the image, in pixels from the left: the bright width of the
 * rows' mean profile over its plateau (the mean of the 8 leftmost columns), channel c. */
static double edge_column(const float *img, int c) {
    double profile[WIN_W] = {0}, plateau = 0, width = 0;
    for (int y = 0; y < WIN_H; y++)
        for (int x = 0; x < WIN_W; x++) profile[x] += img[3 * (y * WIN_W + x) + c] / WIN_H;
    for (int x = 0; x < 8; x++) plateau += profile[x] / 8;
    for (int x = 0; x < WIN_W; x++) width += profile[x] / plateau;
    return width;
}

static void window(void) {
    static float none[3 * WIN_W * WIN_H], thin[3 * WIN_W * WIN_H], zero[3 * WIN_W * WIN_H], slab[3 * WIN_W * WIN_H];
    const double tint[3] = {1.0, 0.75, 0.5};
    for (int angle = 0; angle < 2; angle++) {
        float theta = angle ? 0.7853982f : 0.f;
        double want = 1.0 - fresnel(cos(theta), 1.5); /* (1 - F0) = 0.96 head-on */
        window_image(PANE_NONE, theta, none);
        window_image(PANE_THIN, theta, thin);
        window_image(PANE_THICK_ZERO, theta, zero);
        /* per pixel: dark where the bare emitter is dark (the same jitter: a shifted edge would
         * light some), and kt (1 - F) of it where it is lit, within the Fresnel choice's noise */
        int dark_lit = 0, far = 0, lit = 0, differ = 0;
        double sum[3] = {0, 0, 0}, ref[3] = {0, 0, 0};
        for (int i = 0; i < WIN_W * WIN_H; i++)
            for (int c = 0; c < 3; c++) {
                float n = none[3 * i + c], t = thin[3 * i + c];
                differ += t != zero[3 * i + c];
                if (n == 0.f) { dark_lit += t != 0.f; continue; }
                lit++;
                sum[c] += t;
                ref[c] += n;
                /* a sample is kt or 0 with probability F: the mean of 48 is within 5 sigma of kt (1 - F) */
                double sigma = n * tint[c] * sqrt(want * (1 - want) / WIN_SAMPLES);
                if (n > 0.25f && fabs(t - n * tint[c] * want) > 5 * sigma + 1e-6) far++;
            }
        CHECK(dark_lit == 0, "theta %d deg: %d dark pixel channels of the bare emitter are lit through the pane", angle * 45, dark_lit);
        CHECK(far == 0 && lit > 0, "theta %d deg: %d of %d lit pixel channels off kt (1 - F) of the bare image", angle * 45, far, lit);
        CHECK(differ == 0, "theta %d deg: a volume of thickness 0 renders as no volume (%d channels differ)", angle * 45, differ);
        for (int c = 0; c < 3; c++) {
            char what[96];
            snprintf(what, sizeof what, "theta %d deg: the pane's mean over the lit pixels = kt (1 - F(theta)) (channel %d)", angle * 45, c);
            CHECK_NEAR(sum[c] / ref[c], tint[c] * want, 0.01, 0, what);
        }
        /* the edge seen through the thin pane stands where it stands without it */
        CHECK_NEAR(edge_column(thin, 0), edge_column(none, 0), 0, 0.3, "the edge through the thin pane is not shifted (pixels)");
        if (angle) {
            /* a solid slab shifts a ray seen at theta sideways by L sin(theta) (1 - cos(theta) / sqrt(n^2 - sin^2(theta))) */
            window_image(PANE_SLAB, theta, slab);
            double shift = SLAB * sin(theta) * (1.0 - cos(theta) / sqrt(2.25 - sin(theta) * sin(theta)));
            double pixel = 2.0 * 0.25 / WIN_H; /* orthographic: the image is 2 ymag high */
            CHECK_NEAR(edge_column(slab, 0) - edge_column(none, 0), shift / pixel, 0.03, 0,
                       "the slab shifts the edge by Snell's displacement (pixels)");
            printf("edge at 45 deg: bare %.2f px, thin pane %.2f px, slab %.2f px (Snell: +%.2f px)\n", edge_column(none, 0),
                   edge_column(thin, 0), edge_column(slab, 0), shift / pixel);
        }
    }
}

/* How many columns of the rows' mean profile lie between 10% and 90% of the plateau: the width of
 * the edge's blur, in pixels. */
static int edge_blur(const float *img) {
    double profile[WIN_W] = {0}, plateau = 0;
    for (int y = 0; y < WIN_H; y++)
        for (int x = 0; x < WIN_W; x++) profile[x] += img[3 * (y * WIN_W + x)] / WIN_H;
    for (int x = 0; x < 8; x++) plateau += profile[x] / 8;
    int n = 0;
    for (int x = 0; x < WIN_W; x++) n += profile[x] > 0.1 * plateau && profile[x] < 0.9 * plateau;
    return n;
}

/* A rough thin pane (GGX microfacet transmission, glTF's thin-walled BTDF) blurs the emitter's edge
 * behind it, more as its roughness grows, and keeps about the light a smooth pane lets through
 * (the blur moves it; the microfacets' shadowing loses a little). */
static void rough_window(void) {
    static float img[3][3 * WIN_W * WIN_H];
    const float roughness[3] = {0.f, 0.3f, 0.6f};
    int blur[3];
    double width[3];
    for (int k = 0; k < 3; k++) {
        pane_roughness = roughness[k];
        window_image(PANE_THIN, 0.f, img[k]);
        blur[k] = edge_blur(img[k]);
        width[k] = edge_column(img[k], 0);
    }
    pane_roughness = 0.f;
    printf("rough thin pane: edge blur %d / %d / %d px, lit width %.2f / %.2f / %.2f px at roughness 0 / 0.3 / 0.6\n", blur[0],
           blur[1], blur[2], width[0], width[1], width[2]);
    CHECK(blur[0] <= 2, "a smooth pane leaves the edge sharp (%d px)", blur[0]);
    CHECK(blur[1] >= blur[0] + 2, "roughness 0.3 blurs the edge (%d px against %d)", blur[1], blur[0]);
    CHECK(blur[2] >= blur[1] + 4, "roughness 0.6 blurs it more (%d px against %d)", blur[2], blur[1]);
    CHECK_NEAR(width[1], width[0], 0.05, 0, "roughness 0.3 moves the light, keeps about all of it");
}

/* A point light of intensity 10 (or a lamp of radiance 1 over [-20, 20]^2) at height 3 over a
 * floor of albedo 0.5, a horizontal thin pane (the loaded material) at height 1.5 between them
 * when `pane`, emitting PANE_GLOW from both faces when `glowing`. */
#define PANE_GLOW 0.3f
static pm_accel *floor_scene(pm_scene *s, bool pane, bool lamp, bool glowing) {
    memset(s, 0, sizeof *s);
    uint32_t floor_m = sb_lambert(s, v3s(0.5f));
    sb_quad(s, v3(-20, 0, -20), v3(-20, 0, 20), v3(20, 0, 20), v3(20, 0, -20), floor_m);
    if (pane) {
        uint32_t m = add_loaded(s, &loaded[0]);
        if (glowing) {
            s->materials[m].emission = v3s(PANE_GLOW);
            s->materials[m].double_sided = true;
        }
        sb_quad(s, v3(-20, 1.5f, -20), v3(-20, 1.5f, 20), v3(20, 1.5f, 20), v3(20, 1.5f, -20), m);
    }
    if (lamp) {
        uint32_t m = sb_material(s, v3s(0), 0, 1, 0, v3s(1.f), false);
        sb_quad(s, v3(-20, 3, -20), v3(20, 3, -20), v3(20, 3, 20), v3(-20, 3, 20), m);
    } else {
        sb_point_light(s, v3(0, 3, 0), v3s(10.f));
    }
    return sb_finish(s);
}

/* Photons from the point light on the floor patch |x|, |z| < 1: what a straight line brings,
 * times kt (1 - F(theta)) across the pane, all of them direct light; the caustic pass stores none. */
static void photons(void) {
    const double tint[3] = {1.0, 0.75, 0.5};
    for (int pane = 0; pane < 2; pane++) {
        pm_scene s;
        pm_accel *a = floor_scene(&s, pane, false, false);
        pm_photon_settings ps;
        memset(&ps, 0, sizeof ps);
        ps.seed = 5;
        ps.threads = 2;
        ps.max_bounces = 8;
        ps.projection_maps = true;
        pm_photon_tracer *t = pm_photon_tracer_create(&s, a, &ps);
        pm_photon_buffer buf = {NULL, 0, 0};
        pm_photon_stats st;
        memset(&st, 0, sizeof st);
        CHECK(t && pm_photon_tracer_trace_into(t, false, 300000, 1, &buf, &st), "global pass");
        double power[3] = {0, 0, 0};
        int not_direct = 0;
        for (size_t i = 0; t && i < buf.count; i++) {
            vec3 p = pm_photon_position(&buf.data[i]);
            if (fabsf(p.y) > 1e-3f) continue;
            if (fabsf(p.x) < 1.f && fabsf(p.z) < 1.f) {
                vec3 w = pm_photon_power(&buf.data[i]);
                power[0] += w.x;
                power[1] += w.y;
                power[2] += w.z;
            }
            /* the floor's first hits (straight from the light or across the pane) are direct; the
             * floor -> pane -> floor ones are indirect */
            if (pm_photon_path(&buf.data[i]) == PM_PATH_CAUSTIC) not_direct++;
        }
        CHECK(not_direct == 0, "pane %d: %d floor photons tagged caustic", pane, not_direct);
        double want[3] = {0, 0, 0};
        const int n = 200;
        for (int i = 0; i < n; i++)
            for (int j = 0; j < n; j++) {
                double x = -1 + (i + 0.5) * 2.0 / n, z = -1 + (j + 0.5) * 2.0 / n;
                double r2 = x * x + z * z + 9.0, c = 3.0 / sqrt(r2), e = 10.0 * c / r2 * (2.0 / n) * (2.0 / n);
                for (int k = 0; k < 3; k++) want[k] += e * (pane ? tint[k] * (1.0 - fresnel(c, 1.5)) : 1.0);
            }
        for (int k = 0; k < 3; k++) {
            char what[96];
            snprintf(what, sizeof what, "pane %d: photon power on the patch = I cos/r^2 x kt (1 - F) (channel %d)", pane, k);
            CHECK_NEAR(power[k], want[k], 0.03, 0, what);
        }
        if (pane) printf("photons on the patch: %.4f of %.4f (no pane: %.4f)\n", power[1], want[1], want[1] / tint[1]);
        free(buf.data);
        buf = (pm_photon_buffer){NULL, 0, 0};
        /* the caustic pass: photons cross the pane straight (no caustic) or reflect off it into the void */
        CHECK(t && pm_photon_tracer_trace_into(t, true, 100000, 2, &buf, &st), "caustic pass");
        CHECK(buf.count == 0, "pane %d: the caustic pass stores %zu photons (none expected)", pane, buf.count);
        free(buf.data);
        pm_photon_tracer_destroy(t);
        pm_accel_destroy(a);
        pm_scene_free(&s);
    }
}

/* The irradiance at floor point (px, 0, pz) across the pane, divided by kt: from the point light
 * I cos / r^2 (1 - F), from the lamp (radiance 1 over [-20, 20]^2 at height 3) its integral. */
static double irradiance_across(double px, double pz, bool lamp) {
    if (!lamp) {
        double r2 = px * px + pz * pz + 9.0, c = 3.0 / sqrt(r2);
        return 10.0 * c / r2 * (1.0 - fresnel(c, 1.5));
    }
    const int n = 240;
    double e = 0, cell = 40.0 / n;
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) {
            double x = -20 + (i + 0.5) * cell - px, z = -20 + (j + 0.5) * cell - pz, r2 = x * x + z * z + 9.0;
            double c = 3.0 / sqrt(r2);
            e += c * c / r2 * (1.0 - fresnel(c, 1.5)) * cell * cell;
        }
    return e;
}

/* The irradiance at (px, 0, pz) from the glowing pane itself (radiance PANE_GLOW, height 1.5). */
static double irradiance_from_pane(double px, double pz) {
    const int n = 240;
    double e = 0, cell = 40.0 / n;
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) {
            double x = -20 + (i + 0.5) * cell - px, z = -20 + (j + 0.5) * cell - pz, r2 = x * x + z * z + 2.25;
            e += PANE_GLOW * 2.25 / (r2 * r2) * cell * cell;
        }
    return e;
}

/* Direct light on the floor under the pane, seen by a camera between them looking down: rho/pi
 * times the light across the pane, by next-event estimation and (for the lamp) its MIS partner,
 * the material's own sample, which crosses the pane too. Path tracer and progressive mode alike;
 * nothing of it may come again as a caustic (the sample that crossed the pane on to the light is
 * not a specular path, nor the photon that crossed it to the floor). */
static void direct_across(void) {
    const double tint[3] = {1.0, 0.75, 0.5};
    enum { SIDE = 16 };
    pm_camera cam = sb_camera(v3(0, 1, 0), v3(0, 0, 0), v3(0, 0, -1), 60.f);
    for (int light = 0; light < 3; light++) {
        bool lamp = light > 0, glowing = light == 2;
        /* the analytic image's mean, each pixel at its centre's floor point: tint[c] x want + glow */
        double want = 0, glow = 0;
        for (int y = 0; y < SIDE; y++)
            for (int x = 0; x < SIDE; x++) {
                vec3 o, d;
                pm_camera_ray(&cam, SIDE, SIDE, x + 0.5f, y + 0.5f, &o, &d);
                double t = -o.y / d.y, px = o.x + t * d.x, pz = o.z + t * d.z;
                want += 0.5 / PM_PI * irradiance_across(px, pz, lamp) / (SIDE * SIDE);
                if (glowing) glow += 0.5 / PM_PI * irradiance_from_pane(px, pz) / (SIDE * SIDE);
            }
        for (int mode = 0; mode < 2; mode++) {
            pm_scene s;
            pm_accel *a = floor_scene(&s, true, lamp, glowing);
            pm_session_config config = mode_config(mode ? PM_MODE_PROGRESSIVE : PM_MODE_PATHTRACE, SIDE, SIDE, 11, 2);
            pm_session *session = render_session(&s, a, &cam, &config, lamp ? 64 : 8);
            const char *light = glowing ? "lamp and glowing pane" : lamp ? "lamp" : "point light", *how = mode ? "progressive" : "path tracer";
            if (session) {
                const pm_film *f = pm_session_film(session);
                static float direct[3 * SIDE * SIDE], caustic[3 * SIDE * SIDE];
                pm_film_resolve(f, PM_DIRECT, direct);
                pm_film_resolve(f, PM_CAUSTIC, caustic);
                double mean[3] = {0, 0, 0}, caustic_sum = 0;
                for (int i = 0; i < SIDE * SIDE; i++)
                    for (int c = 0; c < 3; c++) {
                        mean[c] += direct[3 * i + c] / (SIDE * SIDE);
                        caustic_sum += caustic[3 * i + c];
                    }
                for (int c = 0; c < 3; c++) {
                    char what[128];
                    snprintf(what, sizeof what, "%s, %s: floor's direct light = rho/pi kt (1 - F) across the pane (channel %d)",
                             light, how, c);
                    CHECK_NEAR(mean[c], tint[c] * want + glow, lamp ? 0.02 : 0.003, 0, what);
                }
                CHECK(caustic_sum == 0.0, "%s, %s: the caustic layer is %g (light across the pane counted twice)", light, how,
                      caustic_sum);
                printf("%s, %s: direct light across the pane %.5f (analytic %.5f)\n", light, how, mean[1], tint[1] * want + glow);
            }
            pm_session_destroy(session);
            pm_accel_destroy(a);
            pm_scene_free(&s);
        }
    }
}

/* A white furnace (walls of albedo 0.5 emitting 0.5: radiance 1 everywhere) with a lossless thin
 * pane (white, transmission 1) across the view: the pane reflects F and lets 1 - F through,
 * absorbs and emits nothing, so every pixel, seen through it or not, stays 1 in every mode. Light
 * counted twice across the pane (as direct light and again as a specular path) or not at all
 * would show. */
static void furnace(void) {
    for (int mode = 0; mode < 3; mode++) {
        pm_scene s;
        pm_camera cam;
        pm_accel_destroy(sb_furnace(&s, 0.5f, 0.5f, &cam));
        pm_material white = loaded[0];
        white.base_color = v3s(1.f);
        uint32_t m = add_loaded(&s, &white);
        sb_quad(&s, v3(-0.7f, -0.7f, -0.3f), v3(0.7f, -0.7f, -0.3f), v3(0.7f, 0.7f, -0.3f), v3(-0.7f, 0.7f, -0.3f), m);
        pm_accel *a = sb_finish(&s);
        cam = sb_camera(v3(0, 0, 0.8f), v3(0, 0, -1), v3(0, 1, 0), 60.f);
        pm_mode modes[3] = {PM_MODE_PATHTRACE, PM_MODE_PROGRESSIVE, PM_MODE_CLASSIC};
        pm_session_config config = mode_config(modes[mode], 16, 16, 3, 2);
        if (modes[mode] == PM_MODE_CLASSIC) {
            pm_photon_settings ps;
            memset(&ps, 0, sizeof ps);
            ps.global_photons = 200000;
            ps.caustic_photons = 100000;
            ps.seed = 5;
            ps.threads = 2;
            ps.max_bounces = PM_DEFAULT_MAX_PHOTON_BOUNCES;
            ps.projection_maps = true;
            pm_estimate_settings estimate = {PM_KERNEL_DISC, 100, 0.3f, 7u};
            with_photons(&config, &ps, estimate, estimate);
            config.eye.indirect = PM_INDIRECT_GATHER;
            config.eye.gather_rays = 4;
        }
        pm_session *session = render_session(&s, a, &cam, &config, mode == 2 ? 16 : 32);
        if (session) {
            static float total[3 * 256];
            pm_film_resolve_total(pm_session_film(session), total);
            double mean = 0;
            for (int i = 0; i < 256; i++) mean += total[3 * i + 1] / 256.0;
            const char *names[3] = {"path tracer", "progressive", "classic"};
            char what[96];
            snprintf(what, sizeof what, "furnace with a thin pane, %s: every pixel Le / (1 - rho) = 1", names[mode]);
            CHECK_NEAR(mean, 1.0, 0.03, 0, what);
            printf("furnace with a thin pane, %s: %.4f\n", names[mode], mean);
        }
        pm_session_destroy(session);
        pm_accel_destroy(a);
        pm_scene_free(&s);
    }
}

/* Shadow photons beside a pane over half the floor (x < 0): their verdicts decide the open half
 * without rays, and behind the pane (records behind glass are uncertain) rays measure its
 * transmittance, so the image is the ray-only one, bit for bit. */
static void shadow_photons(void) {
    pm_scene s;
    memset(&s, 0, sizeof s);
    uint32_t floor_m = sb_lambert(&s, v3s(0.5f));
    sb_quad(&s, v3(-20, 0, -20), v3(-20, 0, 20), v3(20, 0, 20), v3(20, 0, -20), floor_m);
    uint32_t m = add_loaded(&s, &loaded[0]);
    sb_quad(&s, v3(-20, 1.5f, -20), v3(-20, 1.5f, 20), v3(0, 1.5f, 20), v3(0, 1.5f, -20), m);
    sb_point_light(&s, v3(0.5f, 3, 0), v3s(10.f));
    pm_accel *a = sb_finish(&s);
    pm_camera cam = sb_camera(v3(0, 1, 3), v3(0, 0, 0), v3(0, 1, 0), 60.f);
    static float image[2][3 * 32 * 32];
    uint64_t saved = 0;
    for (int k = 0; k < 2; k++) {
        pm_session_config config = mode_config(PM_MODE_PATHTRACE, 32, 32, 9, 2);
        config.shadow.mode = k ? PM_SHADOW_ON : PM_SHADOW_OFF;
        pm_session *session = render_session(&s, a, &cam, &config, 2);
        if (session) {
            pm_film_resolve(pm_session_film(session), PM_DIRECT, image[k]);
            if (k) saved = pm_session_eye_stats(session)->shadow_rays_saved;
        }
        pm_session_destroy(session);
    }
    CHECK(!memcmp(image[0], image[1], sizeof image[0]), "shadow photons with a thin pane: the ray-only image, bit for bit");
    CHECK(saved > 0, "shadow photons decided some light samples without a ray (%llu)", (unsigned long long)saved);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

/* A point light of intensity 10 at (0, 3, 0) over a floor of albedo 0.5; at height 1.5 a black
 * board with a slit |x| < 0.5 that a thin pane of roughness pane_roughness covers. Across a
 * smooth pane the floor is lit on |x| < 1 alone, by direct light; a rough pane scatters: its
 * light spreads past the slit's shadow edge, reaches the floor as a caustic (a specular bounce, not
 * direct light), and a shadow ray through the pane is no path light takes. */
static pm_accel *slit_scene(pm_scene *s) {
    memset(s, 0, sizeof *s);
    uint32_t floor_m = sb_lambert(s, v3s(0.5f)), board = sb_lambert(s, v3s(0.f));
    sb_quad(s, v3(-20, 0, -20), v3(-20, 0, 20), v3(20, 0, 20), v3(20, 0, -20), floor_m);
    sb_quad(s, v3(-20, 1.5f, -20), v3(-20, 1.5f, 20), v3(-0.5f, 1.5f, 20), v3(-0.5f, 1.5f, -20), board);
    sb_quad(s, v3(0.5f, 1.5f, -20), v3(0.5f, 1.5f, 20), v3(20, 1.5f, 20), v3(20, 1.5f, -20), board);
    uint32_t m = add_loaded(s, &loaded[0]);
    sb_quad(s, v3(-0.5f, 1.5f, -20), v3(-0.5f, 1.5f, 20), v3(0.5f, 1.5f, 20), v3(0.5f, 1.5f, -20), m);
    sb_point_light(s, v3(0, 3, 0), v3s(10.f));
    return sb_finish(s);
}

static void rough_slit(void) {
    const float roughness[3] = {0.f, 0.3f, 0.6f};
    double inside[3] = {0, 0, 0}, spill[3] = {0, 0, 0}, direct_layer[3] = {0, 0, 0};
    size_t direct_tagged[3] = {0, 0, 0}, floor_photons[3] = {0, 0, 0};
    for (int k = 0; k < 3; k++) {
        pane_roughness = roughness[k];
        pm_scene s;
        pm_accel *a = slit_scene(&s);
        pm_photon_settings ps;
        memset(&ps, 0, sizeof ps);
        ps.seed = 7;
        ps.threads = 2;
        ps.max_bounces = 8;
        ps.projection_maps = true;
        pm_photon_tracer *t = pm_photon_tracer_create(&s, a, &ps);
        pm_photon_buffer buf = {NULL, 0, 0};
        pm_photon_stats st;
        memset(&st, 0, sizeof st);
        CHECK(t && pm_photon_tracer_trace_into(t, false, 300000, 1, &buf, &st), "slit: global pass");
        for (size_t i = 0; t && i < buf.count; i++) {
            vec3 p = pm_photon_position(&buf.data[i]);
            /* the floor's first hits (floor -> pane -> floor is indirect light) */
            if (fabsf(p.y) > 1e-3f || pm_photon_path(&buf.data[i]) == PM_PATH_INDIRECT) continue;
            double g = pm_photon_power(&buf.data[i]).y;
            floor_photons[k]++;
            if (fabsf(p.x) < 1.f) inside[k] += g;
            else if (fabsf(p.x) > 1.1f) spill[k] += g;
            if (pm_photon_path(&buf.data[i]) == PM_PATH_DIRECT) direct_tagged[k]++;
        }
        free(buf.data);
        pm_photon_tracer_destroy(t);
        /* the floor's direct light seen from under the board (|x| < 1.15): next-event estimation only */
        pm_camera cam = sb_camera(v3(0, 1, 0), v3(0, 0, 0), v3(0, 0, -1), 60.f);
        pm_session_config config = mode_config(PM_MODE_PATHTRACE, 16, 16, 3, 2);
        pm_session *session = render_session(&s, a, &cam, &config, 4);
        if (session) {
            static float direct[3 * 16 * 16];
            pm_film_resolve(pm_session_film(session), PM_DIRECT, direct);
            for (int i = 0; i < 256; i++) direct_layer[k] += direct[3 * i + 1] / 256.0;
        }
        pm_session_destroy(session);
        pm_accel_destroy(a);
        pm_scene_free(&s);
    }
    pane_roughness = 0.f;
    for (int k = 0; k < 3; k++)
        printf("slit under a pane of roughness %.1f: floor photon power (green) %.4f within the slit's shadow edge, %.4f past it;"
               " %zu of %zu floor photons direct; direct layer under the slit %.4f\n",
               roughness[k], inside[k], spill[k], direct_tagged[k], floor_photons[k], direct_layer[k]);
    CHECK(spill[0] == 0.0 && direct_tagged[0] == floor_photons[0] && floor_photons[0] > 0,
          "smooth pane: every floor photon within the slit's shadow edge, all direct light");
    CHECK(direct_layer[0] > 0.1, "smooth pane: shadow rays cross it (direct layer %g)", direct_layer[0]);
    for (int k = 1; k < 3; k++) {
        CHECK(direct_tagged[k] == 0, "roughness %.1f: light across the pane is no direct light (%zu photons tagged direct)",
              roughness[k], direct_tagged[k]);
        CHECK(direct_layer[k] == 0.0, "roughness %.1f: shadow rays stop at a rough pane (direct layer %g)", roughness[k],
              direct_layer[k]);
        /* nothing is gained; single-scattering GGX loses what light between microfacets would
         * bring back, more the rougher and the more grazing (the slit runs to grazing angles along
         * z): measured 5% at roughness 0.3, 22% at 0.6 */
        double total = inside[k] + spill[k], smooth = inside[0], least = k == 1 ? 0.9 : 0.7;
        CHECK(total <= smooth * 1.01 && total >= smooth * least, "roughness %.1f: the light across keeps its power (%g of %g)",
              roughness[k], total, smooth);
    }
    CHECK(spill[1] > 0.01 * inside[1], "roughness 0.3 spreads light past the slit's shadow edge (%g of %g)", spill[1], inside[1]);
    CHECK(spill[2] > 2.0 * spill[1], "roughness 0.6 spreads more (%g against %g)", spill[2], spill[1]);
}

int main(void) {
    loader_choice();
    rough_window();
    rough_slit();
    window();
    photons();
    direct_across();
    furnace();
    shadow_photons();
    return pm_test_done("test_thin");
}

/* test_emission.c: emission follows the emissive texture: emitter selection, power, direct light and photons against hand-computed answers. */
#include <stdlib.h>
#include <string.h>

#include "accel.h"
#include "defaults.h"
#include "eye.h"
#include "film.h"
#include "photonmap.h"
#include "scene_builder.h"
#include "session_harness.h"
#include "testing.h"

/* A 4x1 texture, clamped: white, white, black, black (sRGB 255 and 0 decode to 1 and 0). */
static uint32_t add_half_white_texture(pm_scene *s) {
    s->textures = realloc(s->textures, (s->texture_count + 1) * sizeof *s->textures);
    pm_texture *t = &s->textures[s->texture_count];
    memset(t, 0, sizeof *t);
    t->width = 4;
    t->height = 1;
    t->wrap_s = t->wrap_t = PM_WRAP_CLAMP;
    t->rgba = malloc(16);
    for (int i = 0; i < 4; i++) {
        uint8_t v = i < 2 ? 255 : 0;
        t->rgba[4 * i] = t->rgba[4 * i + 1] = t->rgba[4 * i + 2] = v;
        t->rgba[4 * i + 3] = 255;
    }
    return s->texture_count++;
}

/* Sets the uv of the last quad's six vertices (two triangles a,b,c and a,c,d) to u in [u0, u1]. */
static void set_last_quad_u(pm_scene *s, float u0, float u1) {
    s->uvs = realloc(s->uvs, 2 * sizeof(float) * s->vertex_count);
    const float us[6] = {u0, u1, u1, u0, u1, u0}; /* a b c, a c d: a=u0 b=u1 c=u1 d=u0 */
    for (int k = 0; k < 6; k++) {
        uint32_t v = s->vertex_count - 6 + k;
        s->uvs[2 * v] = us[k];
        s->uvs[2 * v + 1] = 0.5f;
    }
}

/* A white floor under a ceiling lamp. textured: the lamp is a textured emitter over a white (u in
 * [0, 0.3]) and a black (u in [0.8, 1]) part of its texture; plain: only the lit part, no texture.
 * Both must light the floor the same. */
static pm_accel *build(pm_scene *s, bool textured, bool whole_texture) {
    memset(s, 0, sizeof *s);
    uint32_t white = sb_lambert(s, v3s(0.5f));
    sb_quad(s, v3(-2, 0, -2), v3(-2, 0, 2), v3(2, 0, 2), v3(2, 0, -2), white);
    /* emitting downward: counter-clockwise seen from below */
    uint32_t lamp = sb_material(s, v3s(0.f), 0, 1, 0, v3(3.f, 2.f, 1.f), false);
    if (textured) s->materials[lamp].emission_texture = (int)add_half_white_texture(s);
    s->uvs = calloc(2 * s->vertex_count, sizeof(float));
    sb_quad(s, v3(-0.5f, 1, -0.5f), v3(0.5f, 1, -0.5f), v3(0.5f, 1, 0.5f), v3(-0.5f, 1, 0.5f), lamp);
    set_last_quad_u(s, 0.f, whole_texture ? 1.f : 0.3f);
    if (textured && !whole_texture) {
        sb_quad(s, v3(1.0f, 1, -0.5f), v3(1.6f, 1, -0.5f), v3(1.6f, 1, 0.5f), v3(1.0f, 1, 0.5f), lamp);
        set_last_quad_u(s, 0.8f, 1.f);
    }
    pm_scene_finalize(s, false, NULL);
    char err[256];
    pm_accel *a = pm_accel_create(s, err, sizeof err);
    CHECK(a != NULL, "accel: %s", err);
    return a;
}

/* The image's mean in component c: the classic mode's eye pass alone, 64 samples. */
static double image_mean(const pm_scene *s, const pm_accel *a, pm_component c) {
    enum { W = 24, H = 24 };
    pm_session_config config = mode_config(PM_MODE_CLASSIC, W, H, 5, 2);
    config.eye.max_specular_depth = 8;
    pm_camera cam = sb_camera(v3(0, 0.6f, 2.5f), v3(0, 0, 0), v3(0, 1, 0), 60.f);
    pm_session *session = render_session(s, a, &cam, &config, 64);
    float *img = malloc(sizeof(float) * 3 * W * H);
    double sum = 0;
    CHECK(img != NULL, "image_mean: out of memory");
    if (session && img) {
        pm_film_resolve(pm_session_film(session), c, img);
        for (int i = 0; i < 3 * W * H; i++) sum += img[i];
    }
    free(img);
    pm_session_destroy(session);
    return sum / (3 * W * H);
}

int main(void) {
    pm_scene textured, plain;
    pm_accel *at = build(&textured, true, false), *ap = build(&plain, false, false);
    /* the black part emits nothing: only the lit quad's two triangles are emitters */
    CHECK(textured.emitter_count == 2, "emitters: %u (the black-textured quad must not be one)", textured.emitter_count);
    CHECK(textured.analysis.has_textures, "an emissive texture counts as a texture");
    /* power: pi x area x luminance of the white part's radiance (3, 2, 1), the same as the plain lamp */
    double want_power = PM_PI * 1.0 * v3_luminance(v3(3, 2, 1));
    CHECK_NEAR(textured.emitter_power, want_power, 1e-4, 0, "textured emitter power");
    CHECK_NEAR(plain.emitter_power, want_power, 1e-4, 0, "plain emitter power");
    vec3 e = pm_scene_emission_at(&textured, textured.emitters[0], 0.3f, 0.3f);
    CHECK(fabsf(e.x - 3.f) < 1e-4f && fabsf(e.y - 2.f) < 1e-4f && fabsf(e.z - 1.f) < 1e-4f,
          "radiance on the white part is the factor (%g %g %g)", e.x, e.y, e.z);
    vec3 dark = pm_scene_emission_at(&textured, textured.triangle_count - 1, 0.3f, 0.3f);
    CHECK(v3_is_black(dark), "radiance on the black part is zero (%g %g %g)", dark.x, dark.y, dark.z);

    /* direct light on the floor: the same as the untextured lamp's, within the noise of 64 samples */
    double direct_t = image_mean(&textured, at, PM_DIRECT), direct_p = image_mean(&plain, ap, PM_DIRECT);
    printf("direct light: textured lamp %.5f, plain lamp %.5f\n", direct_t, direct_p);
    CHECK_NEAR(direct_t, direct_p, 0.02, 0, "direct light of the textured lamp");

    /* photons: the textured lamp sends out the plain lamp's flux, and the floor receives the same */
    pm_photon_settings ps = {.global_photons = 200000, .seed = 2, .threads = 2, .max_bounces = PM_DEFAULT_MAX_PHOTON_BOUNCES};
    pm_photon_maps mt, mp;
    CHECK(pm_photon_maps_build(&textured, at, &ps, &mt, NULL) && pm_photon_maps_build(&plain, ap, &ps, &mp, NULL), "maps");
    double power_t = 0, power_p = 0;
    for (size_t i = 0; i < mt.global.count; i++) power_t += v3_average(pm_photon_power(&mt.global.photons[i]));
    for (size_t i = 0; i < mp.global.count; i++) power_p += v3_average(pm_photon_power(&mp.global.photons[i]));
    printf("photon power on the floor: textured lamp %.5f, plain lamp %.5f\n", power_t, power_p);
    CHECK_NEAR(power_t, power_p, 0.01, 0, "photon power of the textured lamp");
    /* a lamp over the whole texture: white, a bilinear ramp, black; exactly half its area's worth
     * of light (the texture's mean over u in [0, 1] is 1/2), however the light is measured */
    pm_scene half;
    pm_accel *ah = build(&half, true, true);
    CHECK_NEAR(half.emitter_power, 0.5 * want_power, 0.02, 0, "half-lit lamp: power from the texture's mean");
    double direct_h = image_mean(&half, ah, PM_DIRECT);
    pm_photon_maps mh;
    CHECK(pm_photon_maps_build(&half, ah, &ps, &mh, NULL), "maps");
    double power_h = 0;
    for (size_t i = 0; i < mh.global.count; i++) power_h += v3_average(pm_photon_power(&mh.global.photons[i]));
    printf("half-lit lamp: emitter power %.4f (plain %.4f), direct light %.5f, photon power on the floor %.5f\n",
           half.emitter_power, want_power, direct_h, power_h);
    /* the lit half sits off-centre, so the floor's share of its light differs a little from the
     * centred lamp's: a generous tolerance, but far from 1 (texture ignored) or 0 */
    CHECK(direct_h > 0.4 * direct_p && direct_h < 0.6 * direct_p, "half-lit lamp: direct light %g, plain %g", direct_h, direct_p);
    CHECK(power_h > 0.45 * power_p && power_h < 0.55 * power_p, "half-lit lamp: photon power %g, plain %g", power_h, power_p);
    pm_photon_maps_free(&mh);
    pm_accel_destroy(ah);
    pm_scene_free(&half);
    pm_photon_maps_free(&mt);
    pm_photon_maps_free(&mp);
    pm_accel_destroy(at);
    pm_accel_destroy(ap);
    pm_scene_free(&textured);
    pm_scene_free(&plain);
    return pm_test_done("test_emission");
}

/* test_sky.c: environment maps against exact answers: the sampler's density, a plane's irradiance under a map (eye pass and photons), texels past the float range clamped, orthographic cameras and framing. */
#include "accel.h"
#include "eye.h"
#include "film.h"
#include "photonmap.h"
#include "rng.h"
#include "scene_builder.h"
#include "defaults.h"
#include "session_harness.h"
#include "sky.h"
#include "testing.h"

/* A map with strong structure: a small bright patch (a sun) over a dim, coloured background. */
static pm_sky_map *sun_map(void) {
    enum { W = 64, H = 32 };
    static float rgb[W * H * 3];
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            float *t = rgb + 3 * (y * W + x);
            bool sun = y == 6 && (x == 40 || x == 41);
            t[0] = sun ? 400.f : 0.2f + 0.01f * x;
            t[1] = sun ? 380.f : 0.3f;
            t[2] = sun ? 300.f : 0.5f - 0.01f * y;
        }
    char err[256];
    pm_sky_map *m = pm_sky_map_create(W, H, rgb, err, sizeof err);
    CHECK(m != NULL, "map: %s", err);
    return m;
}

/* The irradiance a surface facing up receives from the map, exactly: per texel, radiance times
 * the texel's integral of cos(theta) over its solid angle (sin 2t / 2 over the band, phi across). */
static vec3 exact_irradiance_up(const pm_sky_map *m) {
    double e[3] = {0, 0, 0};
    for (int y = 0; y < m->height; y++) {
        double t0 = PM_PI * y / m->height, t1 = PM_PI * (y + 1) / m->height;
        if (t0 >= 0.5 * PM_PI) break;
        if (t1 > 0.5 * PM_PI) t1 = 0.5 * PM_PI;
        double band = 0.5 * (sin(t1) * sin(t1) - sin(t0) * sin(t0)) * 2.0 * PM_PI / m->width;
        for (int x = 0; x < m->width; x++)
            for (int c = 0; c < 3; c++) e[c] += m->rgb[3 * (y * m->width + x) + c] * band;
    }
    return v3((float)e[0], (float)e[1], (float)e[2]);
}

/* Every sample's pdf is pm_sky_map_pdf at its direction, its radiance the lookup there, and
 * E[L / pdf] is the map's integral, 4 pi x mean. */
static void sampler_matches_density(void) {
    pm_sky_map *m = sun_map();
    if (!m) return;
    pm_rng rng = pm_rng_for(3, 0, 0);
    double sum[3] = {0, 0, 0}, worst = 0;
    const int n = 400000;
    for (int i = 0; i < n; i++) {
        vec3 dir;
        float pdf;
        vec3 l = pm_sky_map_sample(m, pm_rng_float(&rng), pm_rng_float(&rng), &dir, &pdf);
        float again = pm_sky_map_pdf(m, dir);
        vec3 looked = pm_sky_map_radiance(m, dir);
        if (i < 20000) worst = fmax(worst, fabs(again - pdf) / pdf + fabs(looked.x - l.x) / l.x);
        sum[0] += l.x / pdf;
        sum[1] += l.y / pdf;
        sum[2] += l.z / pdf;
    }
    CHECK(worst < 1e-3, "pdf and radiance of a sample match the lookups at its direction (worst %.2g)", worst);
    CHECK_NEAR(sum[0] / n, 4 * PM_PI * m->mean.x, 1e-3, 0, "E[L/pdf] = the map's integral (R)");
    CHECK_NEAR(sum[2] / n, 4 * PM_PI * m->mean.z, 1e-3, 0, "E[L/pdf] = the map's integral (B)");
    /* the density integrates to 1: the pdf at each texel's centre times the texel's solid angle */
    double total = 0;
    for (int y = 0; y < m->height; y++) {
        double t0 = PM_PI * y / m->height, t1 = PM_PI * (y + 1) / m->height, tc = 0.5 * (t0 + t1);
        double omega = 2.0 * PM_PI / m->width * (cos(t0) - cos(t1));
        for (int x = 0; x < m->width; x++) {
            double phi = ((x + 0.5) / m->width - 0.5) * 2.0 * PM_PI;
            vec3 d = v3((float)(sin(tc) * sin(phi)), (float)cos(tc), (float)(-sin(tc) * cos(phi)));
            total += pm_sky_map_pdf(m, d) * omega;
        }
    }
    CHECK_NEAR(total, 1.0, 1e-4, 0, "the sampling density integrates to one");
    pm_sky_map_free(m);
}

/* A large plane of albedo rho under map m (the plane takes it): radiance rho/pi x E, E exact from
 * the texels, by the eye pass (map samples and cosine rays under MIS) within eye_rel, and the same
 * irradiance from the map's photons within photon_rel; nothing dropped as non-finite on the way.
 * measured: the eye pass's radiance and the photons' irradiance (R, G, B), for comparisons. */
static void plane_under(pm_sky_map *m, const char *name, int photons, double eye_rel, double photon_rel,
                        double measured[2][3]) {
    pm_scene s;
    memset(&s, 0, sizeof s);
    const float rho = 0.5f;
    uint32_t mat = sb_lambert(&s, v3s(rho));
    sb_quad(&s, v3(-1e3f, 0, -1e3f), v3(-1e3f, 0, 1e3f), v3(1e3f, 0, 1e3f), v3(1e3f, 0, -1e3f), mat);
    pm_scene_finalize(&s, false, NULL);
    pm_scene_set_sky(&s, true, v3s(1.f), m);
    CHECK(s.analysis.has_sky && s.analysis.component_possible[PM_DIRECT], "%s: the analysis sees the new sky", name);
    vec3 e = exact_irradiance_up(m);
    char err[256];
    pm_accel *a = pm_accel_create(&s, err, sizeof err);
    pm_camera cam = sb_camera(v3(0, 2, 0.01f), v3(0, 0, 0), v3(0, 0, -1), 20.f);
    pm_session_config config = mode_config(PM_MODE_CLASSIC, 16, 16, 5, 2);
    config.eye.max_specular_depth = 4;
    pm_session *session = render_session(&s, a, &cam, &config, 256);
    double sum[3] = {0, 0, 0};
    if (session) {
        const pm_film *film = pm_session_film(session);
        for (int i = 0; i < 256; i++)
            for (int c = 0; c < 3; c++) sum[c] += film->sum[PM_DIRECT][3 * i + c] / film->samples;
        CHECK(pm_session_eye_stats(session)->dropped_samples == 0, "%s: %llu eye samples dropped as not finite", name,
              (unsigned long long)pm_session_eye_stats(session)->dropped_samples);
    }
    pm_session_destroy(session);
    CHECK_NEAR(sum[0] / 256, rho / PM_PI * e.x, eye_rel, 0, "plane under the map: radiance = rho/pi x E (R)");
    CHECK_NEAR(sum[2] / 256, rho / PM_PI * e.z, eye_rel, 0, "plane under the map: radiance = rho/pi x E (B)");

    /* photons from the map: the direct photons on a patch of the plane carry E x area */
    pm_photon_settings ps;
    memset(&ps, 0, sizeof ps);
    ps.seed = 9;
    ps.threads = 2;
    ps.max_bounces = 4;
    pm_photon_tracer *t = pm_photon_tracer_create(&s, a, &ps);
    pm_photon_buffer buf = {NULL, 0, 0};
    pm_photon_stats st;
    memset(&st, 0, sizeof st);
    CHECK(t && pm_photon_tracer_trace_into(t, false, (uint64_t)photons, 1, &buf, &st), "%s: photon pass", name);
    CHECK(st.dropped == 0, "%s: %llu photons dropped as not finite", name, (unsigned long long)st.dropped);
    const float half = 100.f; /* well inside the plane and the disc the sky's photons start from */
    double power[3] = {0, 0, 0};
    for (size_t i = 0; i < buf.count; i++) {
        vec3 p = pm_photon_position(&buf.data[i]);
        /* the ground half of the map lights the plane's underside: count the top only */
        if (pm_photon_path(&buf.data[i]) != PM_PATH_DIRECT || fabsf(p.x) > half || fabsf(p.z) > half ||
            pm_photon_normal(&buf.data[i]).y < 0.f)
            continue;
        vec3 w = pm_photon_power(&buf.data[i]);
        power[0] += w.x;
        power[1] += w.y;
        power[2] += w.z;
    }
    double area = 4.0 * half * half;
    CHECK_NEAR(power[0] / area, e.x, photon_rel, 0, "photons from the map: irradiance on the patch (R)");
    CHECK_NEAR(power[2] / area, e.z, photon_rel, 0, "photons from the map: irradiance on the patch (B)");
    for (int c = 0; measured && c < 3; c++) {
        measured[0][c] = sum[c] / 256;
        measured[1][c] = power[c] / area;
    }
    free(buf.data);
    pm_photon_tracer_destroy(t);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

static void plane_under_map(void) {
    pm_sky_map *m = sun_map();
    if (m) plane_under(m, "sun map", 2000000, 0.01, 0.03, NULL);
}

/* W x H texels of radiance `value`, texel (hx, hy) (row 0 = the zenith) set to `hot` when hx >= 0. */
static float *flat_texels(int w, int h, float value, int hx, int hy, const float hot[3]) {
    float *rgb = malloc(sizeof(float) * 3 * w * h);
    for (int i = 0; i < 3 * w * h; i++) rgb[i] = value;
    if (hx >= 0)
        for (int c = 0; c < 3; c++) rgb[3 * (hy * w + hx) + c] = hot[c];
    return rgb;
}

/* Texels past a float film's range are clamped as emission is (PM_MAX_EMISSION), counted for the
 * warning, and the sampling distribution stays a density. Unclamped, a single texel at 3e38 (its channel sum
 * overflows a float) would leave a cdf of NaN: no sky sample, no photon; a map of 1e38 everywhere
 * would overflow L / pdf, dropping most samples. Clamped, both light a plane exactly, nothing dropped. */
static void clamped_maps(void) {
    enum { W = 32, H = 16 };
    char err[256];
    /* one hot texel above the horizon (row 2: 22.5 to 33.75 degrees from the zenith) on radiance 1 */
    const float hot[3] = {3e38f, 3e38f, 3e38f};
    float *rgb = flat_texels(W, H, 1.f, 5, 2, hot);
    pm_sky_map *m = pm_sky_map_create(W, H, rgb, err, sizeof err);
    free(rgb);
    CHECK(m != NULL, "one hot texel: %s", err);
    if (m) {
        CHECK(m->clamped == 1, "one hot texel: %zu clamped, want 1", m->clamped);
        const float *t = m->rgb + 3 * (2 * W + 5);
        CHECK(t[0] == PM_MAX_EMISSION && t[1] == PM_MAX_EMISSION && t[2] == PM_MAX_EMISSION,
              "the hot texel clamped to %g (got %g %g %g)", (double)PM_MAX_EMISSION, t[0], t[1], t[2]);
        bool finite = true;
        for (int i = 0; i <= H; i++) finite = finite && isfinite(m->row_cdf[i]) && (i == 0 || m->row_cdf[i] >= m->row_cdf[i - 1]);
        for (int i = 0; i < H * (W + 1); i++) finite = finite && isfinite(m->column_cdf[i]);
        CHECK(finite, "the sampling tables are finite and rising");
        /* nearly every sample is the hot texel, and its pdf there is its share over its solid angle */
        vec3 dir;
        float pdf;
        vec3 l = pm_sky_map_sample(m, 0.1f, 0.2f, &dir, &pdf);
        double omega = 2.0 * PM_PI / W * (cos(PM_PI * 2 / H) - cos(PM_PI * 3 / H));
        CHECK(l.x == PM_MAX_EMISSION && pdf > 0.f, "a sample finds the hot texel (L %g, pdf %g)", l.x, pdf);
        CHECK_NEAR(pdf, 1.0 / omega, 1e-4, 0, "its pdf: all the weight over the texel's solid angle");
        plane_under(m, "one hot texel", 2000000, 0.01, 0.03, NULL);
    }

    /* 1e38 everywhere: a uniform map of PM_MAX_EMISSION, sampled uniformly, lights the plane
     * as a uniform map of 1 does, times PM_MAX_EMISSION (the same seeds draw the same directions;
     * a photon's power is RGBE, rounded differently at each scale); photons from every direction
     * are noisy: 6% is over 4 sigma at 2M photons */
    double one[2][3], limit[2][3];
    rgb = flat_texels(W, H, 1.f, -1, 0, NULL);
    m = pm_sky_map_create(W, H, rgb, err, sizeof err);
    free(rgb);
    CHECK(m != NULL && m->clamped == 0, "a uniform map of 1: %s", err);
    if (m) plane_under(m, "uniform 1", 2000000, 0.01, 0.06, one);
    rgb = flat_texels(W, H, 1e38f, -1, 0, NULL);
    m = pm_sky_map_create(W, H, rgb, err, sizeof err);
    free(rgb);
    CHECK(m != NULL, "1e38 everywhere: %s", err);
    if (m) {
        CHECK(m->clamped == W * H, "1e38 everywhere: %zu clamped, want %d", m->clamped, W * H);
        CHECK_NEAR(m->mean.x, PM_MAX_EMISSION, 1e-5, 0, "the mean radiance is the limit");
        CHECK_NEAR(pm_sky_map_pdf(m, v3(0.3f, 0.5f, -0.2f)), 1.0 / (4.0 * PM_PI), 1e-4, 0, "uniform density 1/4pi");
        plane_under(m, "1e38 everywhere", 2000000, 0.01, 0.06, limit);
        for (int k = 0; k < 2; k++)
            CHECK_NEAR(limit[k][1], PM_MAX_EMISSION * one[k][1], k ? 0.004 : 1e-4, 0,
                       k ? "1e38 everywhere: the photons' irradiance is the uniform map's times the limit"
                         : "1e38 everywhere: the eye pass's radiance is the uniform map's times the limit");
    }

    /* non-finite texels: NaN and -Inf to 0, +Inf to the limit with the hue kept; finite negatives
     * to 0 without being counted */
    rgb = flat_texels(4, 2, 1.f, -1, 0, NULL);
    rgb[0] = NAN;
    rgb[3] = INFINITY;
    rgb[4] = 1.f;
    rgb[5] = 0.f;
    rgb[6] = -INFINITY;
    rgb[9] = -0.5f;
    m = pm_sky_map_create(4, 2, rgb, err, sizeof err);
    free(rgb);
    CHECK(m != NULL, "non-finite texels: %s", err);
    if (m) {
        CHECK(m->clamped == 3, "NaN, +Inf and -Inf texels counted: %zu, want 3", m->clamped);
        CHECK(m->rgb[0] == 0.f && m->rgb[6] == 0.f && m->rgb[9] == 0.f, "NaN, -Inf and negatives read as 0");
        CHECK(m->rgb[3] == PM_MAX_EMISSION && m->rgb[4] < 1e-15f && m->rgb[5] == 0.f,
              "+Inf as the limit, the other channels scaled with it (%g %g %g)", m->rgb[3], m->rgb[4], m->rgb[5]);
        pm_sky_map_free(m);
    }
    CHECK(pm_sky_map_bytes(16384, 16384) > ((uint64_t)4 << 30) && pm_sky_map_bytes(4096, 2048) > 128 * 1000 * 1000,
          "the memory estimate counts 16 bytes a texel and more");
}

/* The gradient: brighter overhead than at the horizon, so a white top stands out against it. */
static void gradient_default(void) {
    char err[256];
    pm_sky_map *m = pm_sky_map_gradient(err, sizeof err);
    CHECK(m != NULL, "gradient: %s", err);
    if (!m) return;
    vec3 e = exact_irradiance_up(m);
    float horizon = pm_sky_map_radiance(m, v3(0, 0.01f, -1)).x;
    CHECK(e.x / PM_PI > 2.f * horizon, "a white top (%.3f) is over twice the horizon (%.3f)", e.x / PM_PI, horizon);
    CHECK(pm_sky_map_radiance(m, v3(0, 1, 0)).x > pm_sky_map_radiance(m, v3(0, -1, 0)).x, "sky over ground");
    pm_sky_map_free(m);
}

/* An orthographic camera: parallel rays, and a square of side 1 under a view 4 units tall
 * covers exactly a quarter of the image's height; framing fits a long thin model tightly. */
static void orthographic_and_framing(void) {
    pm_scene s;
    memset(&s, 0, sizeof s);
    uint32_t mat = sb_lambert(&s, v3s(0.5f));
    sb_quad(&s, v3(-0.5f, -0.5f, 0), v3(0.5f, -0.5f, 0), v3(0.5f, 0.5f, 0), v3(-0.5f, 0.5f, 0), mat);
    pm_scene_finalize(&s, false, NULL);
    char err[256];
    pm_accel *a = pm_accel_create(&s, err, sizeof err);
    pm_camera cam = sb_camera(v3(0, 0, 5), v3(0, 0, 0), v3(0, 1, 0), 30.f);
    cam.orthographic = true;
    cam.ymag = 2.f;
    int hits = 0, bent = 0;
    const int n = 64;
    for (int y = 0; y < n; y++)
        for (int x = 0; x < n; x++) {
            vec3 o, d;
            pm_camera_ray(&cam, n, n, x + 0.5f, y + 0.5f, &o, &d);
            bent += !(d.x == 0.f && d.y == 0.f && d.z == -1.f);
            pm_hit h;
            hits += pm_accel_intersect(a, o, d, INFINITY, &h);
        }
    CHECK(bent == 0, "orthographic rays are all along forward (%d are not)", bent);
    CHECK(hits == (n / 4) * (n / 4), "the unit square covers a quarter of each side: %d pixels, want %d", hits, n * n / 16);
    CHECK_NEAR(pm_camera_pixel_size(&cam, n, 123.f), 4.0 / n, 1e-6, 0, "orthographic pixel size");
    pm_accel_destroy(a);
    pm_scene_free(&s);

    /* a rod 10 long and 0.2 thick: its bounding sphere is 25x its thickness; the fitted view
     * keeps every vertex inside and the rod reaches near the frame's edges */
    memset(&s, 0, sizeof s);
    mat = sb_lambert(&s, v3s(0.5f));
    sb_box(&s, v3(-5, -0.1f, -0.1f), v3(5, 0.1f, 0.1f), mat, false);
    pm_scene_finalize(&s, false, NULL);
    for (int ortho = 0; ortho < 2; ortho++) {
        pm_camera c = pm_scene_auto_camera(&s, 1.f);
        if (ortho) {
            c.orthographic = true;
            c = pm_scene_fit_camera(&s, c, 1.f);
        }
        float lo = 1e9f, hi = -1e9f;
        for (uint32_t i = 0; i < s.vertex_count; i++) {
            /* the vertex's image x in [-1, 1] */
            vec3 d = v3_sub(s.positions[i], c.position);
            float along = v3_dot(d, c.forward), x = v3_dot(d, c.right);
            float sx = ortho ? x / c.ymag : x / (along * tanf(0.5f * c.yfov));
            lo = fminf(lo, sx);
            hi = fmaxf(hi, sx);
            CHECK(along > 0.f, "every vertex in front of the camera");
        }
        CHECK(lo >= -1.f && hi <= 1.f, "%s: every vertex in view (x from %.3f to %.3f)", ortho ? "orthographic" : "perspective", lo, hi);
        CHECK(hi - lo > 1.6f, "%s: the rod fills the frame's width (%.2f of 2)", ortho ? "orthographic" : "perspective", hi - lo);
    }
    pm_scene_free(&s);
}

/* A turned map (--sky-rotate): its samples' pdf and radiance are the lookups at their
 * directions, what the unturned map shows along -Z the turned one shows along -X (90), a
 * direction turned 37 degrees reads what the unturned map reads before the turn, and a whole
 * turn is no turn. */
static void turned_map(void) {
    pm_sky_map *plain = sun_map(), *turned = sun_map(), *whole = sun_map();
    if (!plain || !turned || !whole) return;
    pm_sky_map_rotate(whole, -720.0);
    CHECK(!whole->rotated, "-720 degrees is no turn");
    pm_sky_map_rotate(turned, 90.0);
    vec3 a = pm_sky_map_radiance(plain, v3(0.f, 0.3f, -1.f)), b = pm_sky_map_radiance(turned, v3(-1.f, 0.3f, 0.f));
    CHECK(a.x == b.x && a.z == b.z, "turned 90: -X reads what -Z read (%g, %g)", (double)a.x, (double)b.x);
    pm_sky_map_rotate(turned, 37.0 + 360.0);
    double c = cos(37.0 * PM_PI / 180.0), sn = sin(37.0 * PM_PI / 180.0);
    pm_rng rng = pm_rng_for(5, 0, 0);
    double worst = 0, moved = 0;
    int differ = 0;
    for (int i = 0; i < 20000; i++) {
        vec3 dir;
        float pdf;
        vec3 l = pm_sky_map_sample(turned, pm_rng_float(&rng), pm_rng_float(&rng), &dir, &pdf);
        worst = fmax(worst, fabs(pm_sky_map_pdf(turned, dir) - pdf) / pdf + fabs(pm_sky_map_radiance(turned, dir).x - l.x) / l.x);
        /* the same direction before the turn, counter-clockwise seen from +Y */
        vec3 before = v3((float)(c * dir.x - sn * dir.z), dir.y, (float)(sn * dir.x + c * dir.z));
        moved = fmax(moved, fabs(pm_sky_map_pdf(plain, before) - pdf) / pdf);
        differ += pm_sky_map_pdf(plain, dir) != pdf;
    }
    CHECK(worst < 1e-3, "turned map: a sample's pdf and radiance are the lookups at its direction (worst %.2g)", worst);
    CHECK(moved < 1e-3, "turned map: the density at a direction is the unturned one's before the turn (worst %.2g)", moved);
    CHECK(differ > 1000, "turned map: the density has moved (%d of 20000 samples read another pdf unturned)", differ);
    pm_sky_map_free(plain);
    pm_sky_map_free(turned);
    pm_sky_map_free(whole);
}

int main(void) {
    sampler_matches_density();
    turned_map();
    plane_under_map();
    clamped_maps();
    gradient_default();
    orthographic_and_framing();
    return pm_test_done("test_sky");
}

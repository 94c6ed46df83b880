/* test_photons.c: the photon pass against known answers: furnace, inverse-square, power bookkeeping, caustic energy, maps only where needed, waves against one photon at a time. */
#include "accel.h"
#include "defaults.h"
#include "eye.h"
#include "film.h"
#include "photonmap.h"
#include "rng.h"
#include "scene_builder.h"
#include "session_harness.h"
#include "testing.h"
#include "vertex.h"

static pm_photon_settings photon_settings(uint64_t global, uint64_t caustic) {
    pm_photon_settings p;
    memset(&p, 0, sizeof p);
    p.global_photons = global;
    p.caustic_photons = caustic;
    p.seed = 5;
    p.threads = 2;
    p.max_bounces = PM_DEFAULT_MAX_PHOTON_BOUNCES; /* what users get: a lower cap would darken the furnace */
    p.projection_maps = true;
    return p;
}

static size_t stored_count(const pm_kdtree *t, int path) {
    size_t n = 0;
    for (size_t i = 0; i < t->count; i++) n += path < 0 || pm_photon_path(&t->photons[i]) == path;
    return n;
}

static vec3 stored_power(const pm_kdtree *t, int path) {
    double sum[3] = {0, 0, 0};
    for (size_t i = 0; i < t->count; i++) {
        if (path >= 0 && pm_photon_path(&t->photons[i]) != path) continue;
        vec3 p = pm_photon_power(&t->photons[i]);
        sum[0] += p.x; sum[1] += p.y; sum[2] += p.z;
    }
    return v3((float)sum[0], (float)sum[1], (float)sum[2]);
}

/* A point light inside a closed box of albedo rho: every photon's first hit is stored with all
 * of its power (sum = 4 pi I), and Russian roulette makes the later hits carry rho/(1-rho) of it. */
static void power_bookkeeping(void) {
    pm_scene s;
    memset(&s, 0, sizeof s);
    vec3 rho = v3(0.7f, 0.6f, 0.45f), intensity = v3(2.f, 3.f, 4.f);
    sb_box(&s, v3(-1, -1, -1), v3(1, 1, 1), sb_lambert(&s, rho), true);
    sb_point_light(&s, v3(0.2f, 0.1f, -0.3f), intensity);
    pm_accel *a = sb_finish(&s);
    pm_photon_settings ps = photon_settings(400000, 100000); /* caustic photons asked for, none may be built */
    pm_photon_maps maps;
    pm_photon_stats st;
    CHECK(!s.analysis.caustics_possible, "no specular surface: the analysis rules caustics out");
    CHECK(pm_photon_maps_build(&s, a, &ps, &maps, &st), "build");
    CHECK(maps.caustic.count == 0 && maps.caustic_emitted == 0 && st.stored_caustic == 0 && st.emitted == 400000,
          "no specular surface: no caustic pass, no caustic map (%zu photons, %llu emitted of %llu)", maps.caustic.count,
          (unsigned long long)maps.caustic_emitted, (unsigned long long)st.emitted);
    vec3 first = stored_power(&maps.global, PM_PATH_DIRECT), later = stored_power(&maps.global, PM_PATH_INDIRECT);
    for (int c = 0; c < 3; c++) {
        float phi = 4.f * PM_PI * v3_get(intensity, c), r = v3_get(rho, c);
        CHECK_NEAR(v3_get(first, c), phi, 0.005, 0, "first-hit stored power = light power");
        CHECK_NEAR(v3_get(later, c), phi * r / (1.f - r), 0.02, 0, "Russian roulette: later hits carry rho/(1-rho) of it");
    }
    CHECK(stored_power(&maps.global, PM_PATH_CAUSTIC).x == 0.f, "no caustic-tagged photon without specular surfaces");
    pm_photon_maps_free(&maps);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

/* Irradiance from the global map's direct photons under a point light: E = I cos / d^2. */
static void inverse_square(void) {
    pm_scene s;
    memset(&s, 0, sizeof s);
    const float h = 1.5f, intensity = 7.f;
    sb_quad(&s, v3(-30, 0, -30), v3(-30, 0, 30), v3(30, 0, 30), v3(30, 0, -30), sb_lambert(&s, v3s(0.5f)));
    sb_point_light(&s, v3(0, h, 0), v3s(intensity));
    pm_accel *a = sb_finish(&s);
    pm_photon_settings ps = photon_settings(2000000, 0);
    pm_photon_maps maps;
    CHECK(pm_photon_maps_build(&s, a, &ps, &maps, NULL), "build");
    pm_estimate_settings est = {PM_KERNEL_DISC, 1000, 1.f, 1u << PM_PATH_DIRECT};
    float radii[3] = {0.f, 0.8f, 1.6f};
    for (int r = 0; r < 3; r++) {
        double sum = 0;
        int n = r == 0 ? 1 : 8;
        for (int i = 0; i < n; i++) {
            float phi = 2.f * PM_PI * i / n;
            vec3 p = v3(radii[r] * cosf(phi), 0, radii[r] * sinf(phi));
            sum += pm_photon_estimate(&maps.global, p, v3(0, 1, 0), &est, NULL).x;
        }
        float d2 = h * h + radii[r] * radii[r];
        CHECK_NEAR(sum / n, intensity * h / sqrtf(d2) / d2, r == 0 ? 0.05 : 0.03, 0, "photon irradiance vs inverse-square law");
    }
    est.kernel = PM_KERNEL_GAUSSIAN;
    CHECK_NEAR(pm_photon_estimate(&maps.global, v3(0.5f, 0, 0), v3(0, 1, 0), &est, NULL).x,
               intensity * h / powf(h * h + 0.25f, 1.5f), 0.06, 0, "Gaussian kernel is normalised");
    est.kernel = PM_KERNEL_CONE;
    CHECK_NEAR(pm_photon_estimate(&maps.global, v3(0.5f, 0, 0), v3(0, 1, 0), &est, NULL).x,
               intensity * h / powf(h * h + 0.25f, 1.5f), 0.06, 0, "cone kernel is normalised");
    CHECK(pm_photon_estimate(&maps.global, v3(0.5f, 0, 0), v3(0, -1, 0), &est, NULL).x == 0.f,
          "photons arriving at the other side do not count");
    pm_photon_maps_free(&maps);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

static void add_sphere(pm_scene *s, vec3 c, float r, uint32_t m, int nu, int nv) {
    for (int i = 0; i < nv; i++)
        for (int j = 0; j < nu; j++) {
            vec3 p[4];
            for (int k = 0; k < 4; k++) {
                float th = PM_PI * (i + (k >> 1)) / nv, ph = 2.f * PM_PI * (j + ((k & 1) ^ (k >> 1))) / nu;
                p[k] = v3_add(c, v3_scale(v3(sinf(th) * cosf(ph), cosf(th), sinf(th) * sinf(ph)), r));
            }
            /* outward winding; smooth normals */
            uint32_t base = s->vertex_count;
            sb_quad(s, p[0], p[1], p[2], p[3], m);
            for (int v = 0; v < 6; v++) s->normals[base + v] = v3_normalize(v3_sub(s->positions[base + v], c));
        }
}

/* Glass ball in a closed white box under a point light: all the power that enters the ball
 * ends on a diffuse wall (glass is lossless), so the caustic map's power is I x the ball's solid
 * angle; and the focus under the ball is brighter than the lit floor around it. */
static void glass_ball_caustic(void) {
    pm_scene s;
    memset(&s, 0, sizeof s);
    sb_box(&s, v3(-2, 0, -2), v3(2, 3, 2), sb_lambert(&s, v3s(0.5f)), true);
    uint32_t glass = sb_material(&s, v3s(1.f), 0, 0, 1, v3s(0), false);
    vec3 c = v3(0, 0.6f, 0), light = v3(0, 2.5f, 0);
    float r = 0.4f, intensity = 10.f;
    add_sphere(&s, c, r, glass, 96, 48);
    sb_point_light(&s, light, v3s(intensity));
    pm_accel *a = sb_finish(&s);
    CHECK(s.analysis.caustics_possible, "glass + light + diffuse: caustics possible");
    pm_photon_settings ps = photon_settings(0, 300000);
    pm_photon_maps maps;
    CHECK(pm_photon_maps_build(&s, a, &ps, &maps, NULL), "build");
    CHECK(maps.projection_fraction > 0.0 && maps.projection_fraction < 0.2, "projection map covers the ball only (%g)",
          maps.projection_fraction);
    float d = v3_length(v3_sub(c, light)), omega = 2.f * PM_PI * (1.f - sqrtf(1.f - (r / d) * (r / d)));
    /* the tessellated ball is a little smaller than the sphere: allow 1.5% */
    CHECK_NEAR(stored_power(&maps.caustic, -1).x, intensity * omega, 0.015, 0, "caustic power = power through the ball");
    pm_estimate_settings est = {PM_KERNEL_DISC, 100, 0.2f, 7u};
    float focus = pm_photon_estimate(&maps.caustic, v3(0, 0, 0), v3(0, 1, 0), &est, NULL).x;
    float floor_direct = intensity * 2.5f / powf(2.5f * 2.5f + 0.8f * 0.8f, 1.5f);
    CHECK(focus > 3.f * floor_direct, "caustic focus %g must outshine the lit floor nearby %g", focus, floor_direct);
    pm_photon_maps_free(&maps);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

/* Random walks in double through the box [-1, 1]^3 whose walls reflect kd = rho (1 - m) by Lambert and
 * m x Schlick(rho, cos) as a mirror (glTF's metallic m, roughness 0): the references of the mixed
 * walls, whose mirrors reflect more toward grazing angles than the constant m rho the closed forms
 * assume. box_step moves p along unit d to the next wall and returns its axis. */
static int box_step(double p[3], const double d[3]) {
    int wall = 0;
    double t = INFINITY;
    for (int a = 0; a < 3; a++)
        if (d[a] != 0.0) {
            double ta = ((d[a] > 0.0 ? 1.0 : -1.0) - p[a]) / d[a];
            if (ta < t) { t = ta; wall = a; }
        }
    for (int a = 0; a < 3; a++) p[a] += t * d[a];
    return wall;
}
/* The next direction at wall `wall` (d arriving): the mirror's, or a cosine direction about the inward normal. */
static void box_bounce(double d[3], int wall, bool mirror, pm_rng *rng) {
    double inward = d[wall] > 0.0 ? -1.0 : 1.0;
    if (mirror) { d[wall] = -d[wall]; return; }
    double u1 = pm_rng_float(rng), u2 = pm_rng_float(rng), r = sqrt(u1), phi = 2.0 * 3.14159265358979 * u2;
    double x = r * cos(phi), y = r * sin(phi), z = sqrt(fmax(0.0, 1.0 - u1));
    int a1 = (wall + 1) % 3, a2 = (wall + 2) % 3;
    d[wall] = inward * z;
    d[a1] = x;
    d[a2] = y;
}
static double mirror_schlick(double m, double rho, double c) { return m * (rho + (1.0 - rho) * pow(1.0 - c, 5.0)); }

/* The white furnace's mean radiance seen by cam (16 x 16 pixels, jittered), walls emitting le: analog walks. */
static double furnace_walk(const pm_camera *cam, double rho, double m, double le, int paths) {
    pm_rng rng = pm_rng_for(21, 22, 23);
    double sum = 0.0;
    for (int i = 0; i < paths; i++) {
        vec3 o, dir;
        pm_camera_ray(cam, 16, 16, 16.f * pm_rng_float(&rng), 16.f * pm_rng_float(&rng), &o, &dir);
        double p[3] = {o.x, o.y, o.z}, d[3] = {dir.x, dir.y, dir.z}, len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        for (int a = 0; a < 3; a++) d[a] /= len;
        for (;;) {
            int wall = box_step(p, d);
            sum += le;
            double ks = mirror_schlick(m, rho, fabs(d[wall])), kd = rho * (1.0 - m), u = pm_rng_float(&rng);
            if (u >= ks + kd) break;
            box_bounce(d, wall, u < ks, &rng);
        }
    }
    return sum / paths;
}

/* Photons from a point at `from`: the power (per unit emitted, per channel) arriving at later hits and
 * at hits after one or more mirror bounces straight from the light (the caustic map's). */
static void photon_walk(vec3 from, vec3 rho, double m, int photons, double later[3], double caustic[3]) {
    pm_rng rng = pm_rng_for(31, 32, 33);
    for (int c = 0; c < 3; c++) later[c] = caustic[c] = 0.0;
    for (int i = 0; i < photons; i++) {
        double z = 1.0 - 2.0 * pm_rng_float(&rng), phi = 2.0 * 3.14159265358979 * pm_rng_float(&rng), s = sqrt(fmax(0.0, 1.0 - z * z));
        double p[3] = {from.x, from.y, from.z}, d[3] = {s * cos(phi), s * sin(phi), z}, w[3] = {1, 1, 1};
        bool specular_chain = true;
        for (int bounce = 0;; bounce++) {
            int wall = box_step(p, d);
            if (bounce > 0)
                for (int c = 0; c < 3; c++) {
                    later[c] += w[c];
                    if (specular_chain) caustic[c] += w[c];
                }
            /* each branch with probability 1/2, weighted; roulette on the largest channel */
            bool mirror = pm_rng_float(&rng) < 0.5f;
            double q = 0.0;
            for (int c = 0; c < 3; c++) {
                double r = v3_get(rho, c);
                w[c] *= 2.0 * (mirror ? mirror_schlick(m, r, fabs(d[wall])) : r * (1.0 - m));
                q = fmax(q, w[c]);
            }
            q = fmin(q, 1.0);
            if (pm_rng_float(&rng) >= q) break;
            for (int c = 0; c < 3; c++) w[c] /= q;
            specular_chain = specular_chain && mirror;
            box_bounce(d, wall, mirror, &rng);
        }
    }
    for (int c = 0; c < 3; c++) {
        later[c] /= photons;
        caustic[c] /= photons;
    }
}

/* White furnace: a closed box whose walls all emit Le and reflect rho: L = Le / (1 - rho).
 * Gathering from precomputed irradiance (stride > 0) must give the same answer as full estimates:
 * both from the same photons at albedo 0.5, full estimates where paths are longest (0.95),
 * precomputed irradiance in a bright room with mirrors (0.8, metallic 0.5). Precomputing at 0.95
 * as well would show again what 0.8 shows, on the most records of all (20 a photon): 8.5 s of
 * processor time, four fifths of what the four here take together. */
static void white_furnace(float rho, int irradiance_stride, float metallic) {
    pm_scene s;
    memset(&s, 0, sizeof s);
    const float le = 0.5f;
    /* metallic 0.5, roughness 0 (a rougher metal would be the glossy lobe): half Lambert, half
     * mirror, albedo rho in all */
    uint32_t m = sb_material(&s, v3s(rho), metallic, metallic > 0.f ? 0.f : 1.f, 0, v3s(le), false);
    sb_box(&s, v3(-1, -1, -1), v3(1, 1, 1), m, true);
    pm_accel *a = sb_finish(&s);
    /* The records (their trees, the precomputed irradiance's 100-photon estimate at every 4th)
     * cost the most in the bright rooms, where a photon leaves 1/(1 - rho) records: 5 to 20 at
     * albedo 0.8 to 0.95, so half the photons there still store more records than 300k do at
     * albedo 0.5. An estimate reads 100 photons however many there are, and the image's mean
     * spreads as the roulette's count of records does: at albedo 0.95 it reads about 1% high, and
     * at photon seeds 5-16 (the film's 3-14) it read +0.62..+1.61% with 150k photons (+0.70..+1.40%
     * with 300k) against the bound of 2%, every pixel's indirect layer -1.6..+4.8% of its value
     * (-1.2..+4.5%) against 10%. */
    uint64_t photons = rho >= 0.8f ? 150000 : 300000;
    pm_photon_settings ps = photon_settings(photons, photons);
    ps.irradiance_stride = irradiance_stride;
    ps.irradiance_estimate = (pm_estimate_settings){PM_KERNEL_DISC, 100, 0.3f, 7u};
    pm_session_config config = mode_config(PM_MODE_CLASSIC, 16, 16, 3, 2);
    pm_estimate_settings estimate = {PM_KERNEL_DISC, 100, 0.3f, 7u};
    with_photons(&config, &ps, estimate, estimate);
    config.eye.indirect = PM_INDIRECT_GATHER;
    config.eye.gather_rays = 4;
    pm_camera cam = sb_camera(v3(0, 0, 0.5f), v3(0.3f, -0.2f, -1), v3(0, 1, 0), 60.f);
    pm_session *session = render_session(&s, a, &cam, &config, 64);
    if (!session) { pm_accel_destroy(a); pm_scene_free(&s); return; }
    const pm_photon_maps *maps = pm_session_classic_maps(session);
    CHECK(maps->irradiance.count == (irradiance_stride ? (maps->global.count + irradiance_stride - 1) / irradiance_stride : 0),
          "irradiance points: one per %d global photons (%zu of %zu)", irradiance_stride, maps->irradiance.count,
          maps->global.count);
    const pm_film *film = pm_session_film(session);
    float *total = malloc(sizeof(float) * 3 * 16 * 16);
    pm_film_resolve_total(film, total);
    double sum = 0, lo = INFINITY, hi = 0;
    for (int i = 0; i < 3 * 16 * 16; i++) sum += total[i];
    double want = le / (1.f - rho);
    /* with a mirror share, Schlick's rise toward grazing angles: the walks' mean (the closed form
     * below still serves the indirect layer's 10% check) */
    double mean_want = metallic > 0.f ? furnace_walk(&cam, rho, metallic, le, 400000) : want;
    /* Every pixel's indirect layer, the photon maps' part, against its own analytic value: the
     * surfaces receive L = Le/(1-rho) from everywhere, of which Le is emission (direct light at the
     * pixel) and Le ks/(1-ks) arrives through mirror chains from emission (the caustic layer), so
     * the indirect layer is kd (L - Le - Le ks/(1-ks)). The direct layer's own per-pixel noise
     * (area sampling of emitters a hair away across a corner) is left to the mean. */
    float kd = rho * (1.f - metallic), ks = rho * metallic;
    double want_indirect = kd * (want - le - le * ks / (1.f - ks));
    pm_film_resolve(film, PM_INDIRECT, total);
    for (int i = 0; i < 3 * 16 * 16; i++) {
        lo = fmin(lo, total[i]);
        hi = fmax(hi, total[i]);
    }
    printf("white furnace rho %.2f, metallic %.1f, precompute stride %d: mean %.5f (expected %.5f), indirect %.4f..%.4f (expected %.4f)\n",
           rho, metallic, irradiance_stride, sum / (3 * 16 * 16), want, lo, hi, want_indirect);
    if (metallic > 0.f) printf("  mirror walls: walks in double give a mean of %.5f\n", mean_want);
    CHECK_NEAR(sum / (3 * 16 * 16), mean_want, 0.02, 0, "white furnace mean (see the line above)");
    CHECK(lo > 0.9 * want_indirect && hi < 1.1 * want_indirect, "white furnace: every pixel's indirect within 10%% (%g..%g, expected %g)",
          lo, hi, want_indirect);
    free(total);
    pm_session_destroy(session);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

/* The 20-byte record: shared-exponent power within half a step of 1/256 of its largest channel
 * (at any magnitude), directions (8 bits per axis) and normals (7 bits) within the octahedral
 * codes' resolution. */
static void record_round_trip(void) {
    pm_rng rng = pm_rng_for(5, 5, 5);
    int power_bad = 0, exponent_bad = 0, direction_bad = 0, normal_bad = 0;
    for (int i = 0; i < 20000; i++) {
        float mag = ldexpf(1.f, (int)(pm_rng_float(&rng) * 200.f) - 100);
        vec3 c = v3_scale(v3(pm_rng_float(&rng), pm_rng_float(&rng), pm_rng_float(&rng)), mag);
        vec3 d = pm_sample_sphere(pm_rng_float(&rng), pm_rng_float(&rng)), n = pm_sample_sphere(pm_rng_float(&rng), pm_rng_float(&rng));
        pm_photon ph;
        pm_photon_set(&ph, v3(1, 2, 3), n, d, c, PM_PATH_INDIRECT);
        vec3 back = pm_photon_power(&ph);
        float m = v3_max_component(c), step = m / 128.f; /* 1/256 of [m/2, m) scaled to m: at most m/256 per step */
        if (fabsf(back.x - c.x) > 0.5f * step || fabsf(back.y - c.y) > 0.5f * step || fabsf(back.z - c.z) > 0.5f * step) power_bad++;
        int e;
        frexpf(m, &e);
        if (m > 1e-32f && ph.power[3] != e + 128) exponent_bad++;
        if (v3_dot(pm_photon_direction(&ph), d) < cosf(0.018f)) direction_bad++; /* worst seen in 2M: 0.0165 rad */
        if (v3_dot(pm_photon_normal(&ph), n) < cosf(0.036f)) normal_bad++;    /* 7 bits: 0.0331 rad */
        if (pm_photon_path(&ph) != PM_PATH_INDIRECT) normal_bad++;
    }
    CHECK(power_bad == 0, "%d of 20000 powers off by more than half a quantisation step", power_bad);
    CHECK(exponent_bad == 0, "%d of 20000 shared exponents differ from frexp's", exponent_bad);
    CHECK(direction_bad == 0, "%d of 20000 directions off by more than 0.018 rad", direction_bad);
    CHECK(normal_bad == 0, "%d of 20000 normals (or path tags) off", normal_bad);
    pm_photon z;
    pm_photon_set(&z, v3(0, 0, 0), v3(0, 0, 1), v3(0, 0, -1), v3s(0.f), PM_PATH_DIRECT);
    CHECK(v3_is_black(pm_photon_power(&z)), "zero power stays zero");
}

/* More lights than any fixed table would hold: every one is a source, picked by power, and the
 * first-hit power still sums to the lights' total. */
static void many_lights(void) {
    pm_scene s;
    memset(&s, 0, sizeof s);
    sb_box(&s, v3(-1, -1, -1), v3(1, 1, 1), sb_lambert(&s, v3s(0.5f)), true);
    pm_rng rng = pm_rng_for(8, 8, 8);
    double total = 0;
    for (int i = 0; i < 5000; i++) {
        float intensity = 0.01f + pm_rng_float(&rng);
        total += 4.0 * PM_PI * intensity;
        sb_point_light(&s, v3(1.8f * pm_rng_float(&rng) - 0.9f, 1.8f * pm_rng_float(&rng) - 0.9f, 1.8f * pm_rng_float(&rng) - 0.9f),
                       v3s(intensity));
    }
    pm_accel *a = sb_finish(&s);
    pm_photon_settings ps = photon_settings(200000, 0);
    pm_photon_maps maps;
    CHECK(pm_photon_maps_build(&s, a, &ps, &maps, NULL), "5000 lights: build");
    CHECK_NEAR(stored_power(&maps.global, PM_PATH_DIRECT).x, total, 0.01, 0, "5000 lights: first-hit power = their total");
    pm_photon_maps_free(&maps);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

/* A glass ball on a floor lit by a directional light, or by the sky: with projection maps the
 * caustic pass starts photons only on the ball's projected disc, and must store the same caustic
 * power as a pass that starts them everywhere (both unbiased), with far fewer photons wasted. */
static void parallel_light_projection(bool sky) {
    pm_scene s;
    memset(&s, 0, sizeof s);
    uint32_t floor_m = sb_lambert(&s, v3s(0.5f));
    /* a small floor keeps the ball a fair share of the unaimed starts, so both sides are precise */
    sb_quad(&s, v3(-2, 0, 2), v3(2, 0, 2), v3(2, 0, -2), v3(-2, 0, -2), floor_m);
    add_sphere(&s, v3(0.3f, 0.6f, -0.2f), 0.4f, sb_material(&s, v3s(1.f), 0, 0, 1, v3s(0), false), 48, 24);
    if (sky) {
        s.sky = true;
        s.sky_radiance = v3s(1.f);
    } else {
        s.lights = sb_grow(s.lights, s.light_count, sizeof *s.lights);
        memset(&s.lights[0], 0, sizeof s.lights[0]);
        s.lights[0].type = PM_LIGHT_DIRECTIONAL;
        s.lights[0].direction = v3_normalize(v3(0.3f, -1.f, 0.2f));
        s.lights[0].intensity = v3s(3.f);
        s.light_count = 1;
    }
    pm_accel *a = sb_finish(&s);
    const char *what = sky ? "sky" : "directional light";
    pm_photon_settings aimed = photon_settings(0, 200000), everywhere = photon_settings(0, 2000000);
    everywhere.projection_maps = false;
    pm_photon_maps m1, m2;
    CHECK(pm_photon_maps_build(&s, a, &aimed, &m1, NULL) && pm_photon_maps_build(&s, a, &everywhere, &m2, NULL), "%s: build", what);
    double p1 = stored_power(&m1.caustic, -1).x, p2 = stored_power(&m2.caustic, -1).x;
    printf("%s: caustic power %.4f aimed (%zu photons of 200k, fraction %.4f), %.4f everywhere (%zu of 2M)\n", what, p1,
           m1.caustic.count, m1.projection_fraction, p2, m2.caustic.count);
    CHECK(m1.projection_fraction < 0.5, "%s: the projection keeps a part of the disc (%g)", what, m1.projection_fraction);
    CHECK(m2.caustic.count > 10000 && (double)m1.caustic.count / 200000 > 5.0 * m2.caustic.count / 2000000,
          "%s: aimed photons reach the ball far more often (%zu of 200k against %zu of 2M)", what, m1.caustic.count,
          m2.caustic.count);
    CHECK_NEAR(p1, p2, 0.03, 0, sky ? "sky: aimed caustic power = unaimed" : "directional: aimed caustic power = unaimed");
    pm_photon_maps_free(&m1);
    pm_photon_maps_free(&m2);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

/* Point lights around several glass balls, one close enough to a light that its cone is wide,
 * one far: each light's projection map (one per light, built in parallel) must keep every
 * direction that reaches a ball, so the aimed caustic power equals the unaimed one. */
static void point_lights_projection(void) {
    pm_scene s;
    memset(&s, 0, sizeof s);
    sb_quad(&s, v3(-3, 0, 3), v3(3, 0, 3), v3(3, 0, -3), v3(-3, 0, -3), sb_lambert(&s, v3s(0.5f)));
    uint32_t glass = sb_material(&s, v3s(1.f), 0, 0, 1, v3s(0), false);
    add_sphere(&s, v3(0.f, 0.5f, 0.f), 0.4f, glass, 32, 16);
    add_sphere(&s, v3(1.2f, 0.9f, -0.8f), 0.3f, glass, 32, 16);
    add_sphere(&s, v3(-1.5f, 1.6f, 0.9f), 0.35f, glass, 32, 16);
    add_sphere(&s, v3(2.2f, 0.3f, 2.0f), 0.25f, glass, 32, 16);
    sb_point_light(&s, v3(0.2f, 2.f, 0.1f), v3s(1.f));
    sb_point_light(&s, v3(-1.5f, 2.3f, 0.9f), v3s(2.f)); /* 0.7 above a ball of 0.35: a wide cone */
    sb_point_light(&s, v3(1.8f, 1.2f, -1.5f), v3s(1.5f));
    pm_accel *a = sb_finish(&s);
    pm_photon_settings aimed = photon_settings(0, 200000), everywhere = photon_settings(0, 2000000);
    everywhere.projection_maps = false;
    pm_photon_maps m1, m2;
    CHECK(pm_photon_maps_build(&s, a, &aimed, &m1, NULL) && pm_photon_maps_build(&s, a, &everywhere, &m2, NULL),
          "point lights: build");
    double p1 = stored_power(&m1.caustic, -1).x, p2 = stored_power(&m2.caustic, -1).x;
    printf("point lights: caustic power %.4f aimed (%zu photons of 200k, fraction %.4f), %.4f everywhere (%zu of 2M)\n", p1,
           m1.caustic.count, m1.projection_fraction, p2, m2.caustic.count);
    CHECK(m1.projection_fraction > 0.0 && m1.projection_fraction < 0.5, "point lights: the maps keep a part of the sphere (%g)",
          m1.projection_fraction);
    CHECK_NEAR(p1, p2, 0.03, 0, "point lights: aimed caustic power = unaimed");
    pm_photon_maps_free(&m1);
    pm_photon_maps_free(&m2);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

/* The vertex step in both orders of its roulette, on a surface part Lambert, part mirror: drawn
 * before the sample (ended_unsampled, the photons' order) or after it (the eye's), the share of
 * paths that go on is q = min(PM_MAX_SURVIVAL, kd + ks averaged) and the weight they carry (0 for
 * an ended path) has the albedo kd + ks per channel as its mean, in both. A path ended in the
 * photons' order drew no sample: what an absorbed photon saves. */
static void roulette_orders_agree(void) {
    pm_surface sf;
    memset(&sf, 0, sizeof sf);
    sf.ng = sf.ns = v3(0.f, 0.f, 1.f);
    sf.p = sf.centroid = v3(0.1f, 0.2f, 0.f);
    sf.kd = v3(0.5f, 0.3f, 0.1f);
    sf.ks = v3s(0.2f);
    sf.ks_grazing = 0.2f; /* no Schlick rise: the mirror reflects 0.2 at every angle */
    sf.ior = 1.5f;
    vec3 d = v3_normalize(v3(0.3f, 0.f, -1.f)), albedo = v3_add(sf.kd, sf.ks);
    const int n = 200000;
    for (int order = 0; order < 2; order++) {
        pm_vertex_policy policy = {.roulette_from = 0, .ended_unsampled = order == 0};
        pm_rng rng = pm_rng_for(11, (uint64_t)order, 0);
        double sum[3] = {0, 0, 0};
        int went_on = 0, ended_sampled = 0;
        for (int i = 0; i < n; i++) {
            pm_vertex_ray ray;
            if (pm_vertex_step(&sf, d, 0, &policy, &rng, 1.f, &ray)) {
                went_on++;
                sum[0] += ray.weight.x;
                sum[1] += ray.weight.y;
                sum[2] += ray.weight.z;
            } else {
                ended_sampled += ray.sampled;
            }
        }
        const char *name = order == 0 ? "survival before the sample" : "survival after the sample";
        printf("vertex step, %s: %.4f of paths go on (q %.4f), mean weight %.4f %.4f %.4f (albedo %.2f %.2f %.2f)\n", name,
               (double)went_on / n, (double)v3_average(albedo), sum[0] / n, sum[1] / n, sum[2] / n, albedo.x, albedo.y, albedo.z);
        CHECK_NEAR((double)went_on / n, v3_average(albedo), 0, 0.006, "vertex step: the share of paths going on is q");
        for (int c = 0; c < 3; c++) CHECK_NEAR(sum[c] / n, v3_get(albedo, c), 0.02, 0, "vertex step: the mean weight is the albedo");
        if (order == 0) CHECK(ended_sampled == 0, "vertex step: %d paths ended before the sample drew one", ended_sampled);
        else CHECK(ended_sampled > n / 4, "vertex step: paths ended after the sample drew one (%d)", ended_sampled);
    }
}

/* Both branches of the roulette: walls half Lambert, half mirror (metallic 0.5, roughness 0),
 * reflectance rho in all. Every wall has a diffuse part, so the global map stores
 * every hit; whichever branch a photon takes, the later hits must carry rho/(1-rho) of the
 * light's power per channel, and the caustic map (first diffuse hit after a mirror bounce)
 * holds the power that went through one or more mirror bounces first. */
static void roulette_both_branches(void) {
    pm_scene s;
    memset(&s, 0, sizeof s);
    vec3 rho = v3(0.7f, 0.6f, 0.45f), intensity = v3(2.f, 3.f, 4.f);
    sb_box(&s, v3(-1, -1, -1), v3(1, 1, 1), sb_material(&s, rho, 0.5f, 0.f, 0, v3s(0), false), true);
    sb_point_light(&s, v3(0.2f, 0.1f, -0.3f), intensity);
    pm_accel *a = sb_finish(&s);
    pm_photon_settings ps = photon_settings(400000, 400000);
    ps.projection_maps = false; /* the box is all mirror: aiming has nothing to leave out */
    pm_photon_maps maps;
    CHECK(pm_photon_maps_build(&s, a, &ps, &maps, NULL), "build");
    vec3 first = stored_power(&maps.global, PM_PATH_DIRECT);
    vec3 later = v3_add(stored_power(&maps.global, PM_PATH_INDIRECT), stored_power(&maps.global, PM_PATH_CAUSTIC));
    vec3 caustic = stored_power(&maps.caustic, -1);
    /* the walls' mirrors follow Schlick (glTF's smooth metal share): walks in double give what a
     * constant m rho would give in closed form, rho/(1-rho) and m/(1-m) */
    double walk_later[3], walk_caustic[3];
    photon_walk(v3(0.2f, 0.1f, -0.3f), rho, 0.5, 400000, walk_later, walk_caustic);
    for (int c = 0; c < 3; c++) {
        float phi = 4.f * PM_PI * v3_get(intensity, c);
        printf("mixed walls channel %d: later %.4f (walks %.4f), caustic %.4f (walks %.4f) of the light's power\n", c,
               v3_get(later, c) / phi, walk_later[c], v3_get(caustic, c) / phi, walk_caustic[c]);
        CHECK_NEAR(v3_get(first, c), phi, 0.005, 0, "mixed walls: first-hit stored power = light power");
        CHECK_NEAR(v3_get(later, c), phi * walk_later[c], 0.02, 0, "mixed walls: later hits carry what the walks carry, both branches");
        /* a caustic map photon took k >= 1 mirror bounces then arrived */
        CHECK_NEAR(v3_get(caustic, c), phi * walk_caustic[c], 0.03, 0, "mixed walls: caustic map power = the walks' mirror chains");
    }
    /* The global pass's photons end their mirror chains where they choose the Lambert share; the
     * caustic pass's go on by the mirror share alone, their power multiplied by its share of the
     * albedo, so at the same power (above) its chains store several times the records: about
     * T/(1-T) against s/(1-s) a photon, T the albedo and s the mirror share of it */
    size_t global_chains = stored_count(&maps.global, PM_PATH_CAUSTIC), caustic_chains = stored_count(&maps.caustic, -1);
    printf("mixed walls: %zu caustic map records against %zu mirror-chain records of the global pass, as many photons\n",
           caustic_chains, global_chains);
    CHECK(caustic_chains > 2 * global_chains, "mixed walls: caustic photons go on where the Lambert share would end them (%zu records against %zu)",
          caustic_chains, global_chains);
    pm_photon_maps_free(&maps);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

static int compare_records(const void *a, const void *b) { return memcmp(a, b, sizeof(pm_photon)); }
static int compare_splats(const void *a, const void *b) { return memcmp(a, b, sizeof(pm_camera_splat)); }

/* Waves (PM_PHOTON_WAVE photons side by side) against the plain tracer, one photon's path after
 * another (wave 1), an odd wave of 7, and waves that prefetch their hits' triangles, texels and
 * photons' emitters and waves that do not (a mesh, textures or emitter tables larger than the
 * caches prefetch by default; this mesh's 0.7 MB and this texture's 1 MB do): the same records
 * and camera splats, bit for bit, only in another order, and the same ray count, in both kinds of
 * pass, on a room with glass, a mirror, rough metal, an area light and a point light (every branch
 * of a bounce), its walls and the metal's roughness textured. */
static void waves_change_only_order(void) {
    pm_scene s;
    memset(&s, 0, sizeof s);
    sb_box(&s, v3(-2, 0, -2), v3(2, 3, 2), sb_lambert(&s, v3(0.7f, 0.6f, 0.5f)), true);
    add_sphere(&s, v3(-0.9f, 0.5f, 0.f), 0.45f, sb_material(&s, v3s(1.f), 0, 0, 1, v3s(0), false), 48, 24);
    add_sphere(&s, v3(0.2f, 0.5f, 0.6f), 0.4f, sb_material(&s, v3s(0.9f), 1, 0, 0, v3s(0), false), 48, 24);
    add_sphere(&s, v3(0.9f, 0.5f, -0.5f), 0.4f, sb_material(&s, v3(0.9f, 0.7f, 0.4f), 1, 0.5f, 0, v3s(0), false), 48, 24);
    /* the area light as 3 x 3 quads: 18 emitters, past PM_CDF_SEARCH_MAX, picked by cut points and
     * (prefetching) asked for ahead of their photons */
    uint32_t lamp = sb_material(&s, v3s(0.f), 0, 1, 0, v3s(8.f), false);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            float x0 = -0.4f + 0.8f * i / 3, x1 = -0.4f + 0.8f * (i + 1) / 3, z0 = -0.4f + 0.8f * j / 3, z1 = -0.4f + 0.8f * (j + 1) / 3;
            sb_quad(&s, v3(x0, 2.99f, z0), v3(x1, 2.99f, z0), v3(x1, 2.99f, z1), v3(x0, 2.99f, z1), lamp);
        }
    sb_point_light(&s, v3(1.2f, 2.4f, 1.2f), v3s(3.f));
    /* one 512 x 512 texture of stripes (colour on the walls, roughness on the metal), UVs from the positions */
    s.uvs = malloc(2 * sizeof(float) * s.vertex_count);
    s.textures = calloc(1, sizeof *s.textures);
    if (!s.uvs || !s.textures) abort();
    for (uint32_t i = 0; i < s.vertex_count; i++) {
        s.uvs[2 * i] = 0.37f * (s.positions[i].x + s.positions[i].z);
        s.uvs[2 * i + 1] = 0.41f * s.positions[i].y;
    }
    s.textures[0] = sb_texture(512, 512, PM_WRAP_REPEAT);
    s.texture_count = 1;
    for (size_t i = 0; i < 4 * (size_t)512 * 512; i++) s.textures[0].rgba[i] = (uint8_t)(96 + (i * 37 / 64) % 160);
    s.materials[0].base_color_texture = 0;
    s.materials[3].metallic_roughness_texture = 0;
    pm_accel *a = sb_finish(&s);
    pm_camera cam = sb_camera(v3(0.f, 1.5f, 1.95f), v3(0.f, 0.8f, 0.f), v3(0.f, 1.f, 0.f), 70.f);
    enum { RUNS = 4 };
    int waves[RUNS] = {1, 7, 0, 0};
    uint64_t prefetch_bytes[RUNS] = {0, 0, UINT64_MAX, 1}; /* default, default, never, always */
    const char *prefetching[RUNS] = {"", "", " not prefetching", " prefetching"};
    pm_photon_buffer records[2][RUNS];
    pm_splat_buffer splats[RUNS];
    uint64_t rays[2][RUNS];
    memset(records, 0, sizeof records);
    memset(splats, 0, sizeof splats);
    bool ok = true;
    for (int w = 0; w < RUNS; w++) {
        pm_photon_settings ps = photon_settings(0, 0);
        ps.wave = waves[w];
        ps.prefetch_bytes = prefetch_bytes[w];
        pm_photon_tracer *t = pm_photon_tracer_create(&s, a, &ps);
        ok = ok && t;
        if (!t) break;
        pm_photon_tracer_set_splats(t, &cam, 64, 48, &splats[w]);
        for (int caustic = 0; caustic < 2; caustic++) {
            pm_photon_stats st;
            memset(&st, 0, sizeof st);
            ok = ok && pm_photon_tracer_trace_into(t, caustic, 40000, 9, &records[caustic][w], &st);
            rays[caustic][w] = st.rays;
            qsort(records[caustic][w].data, records[caustic][w].count, sizeof(pm_photon), compare_records);
        }
        qsort(splats[w].data, splats[w].count, sizeof(pm_camera_splat), compare_splats);
        pm_photon_tracer_destroy(t);
    }
    CHECK(ok, "four tracers and their passes");
    for (int caustic = 0; ok && caustic < 2; caustic++) {
        size_t n = records[caustic][0].count;
        printf("waves: %s pass, %zu records, %llu rays with one photon at a time\n", caustic ? "caustic" : "global", n,
               (unsigned long long)rays[caustic][0]);
        CHECK(n > 1000, "the %s pass stores photons (%zu)", caustic ? "caustic" : "global", n);
        for (int w = 1; w < RUNS; w++) {
            CHECK(records[caustic][w].count == n && rays[caustic][w] == rays[caustic][0] &&
                      !memcmp(records[caustic][w].data, records[caustic][0].data, n * sizeof(pm_photon)),
                  "wave %d%s: the same %s records and rays as one photon at a time (%zu of %zu records, %llu of %llu rays)",
                  waves[w], prefetching[w], caustic ? "caustic" : "global", records[caustic][w].count, n, (unsigned long long)rays[caustic][w],
                  (unsigned long long)rays[caustic][0]);
        }
    }
    CHECK(splats[0].count > 100, "caustic photons seen by the camera (%zu splats)", splats[0].count);
    for (int w = 1; ok && w < RUNS; w++)
        CHECK(splats[w].count == splats[0].count && !memcmp(splats[w].data, splats[0].data, splats[0].count * sizeof(pm_camera_splat)),
              "wave %d%s: the same camera splats (%zu of %zu)", waves[w], prefetching[w], splats[w].count,
              splats[0].count);
    for (int w = 0; w < RUNS; w++) {
        free(records[0][w].data);
        free(records[1][w].data);
        free(splats[w].data);
    }
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

int main(void) {
    waves_change_only_order();
    record_round_trip();
    roulette_both_branches();
    roulette_orders_agree();
    parallel_light_projection(false);
    parallel_light_projection(true);
    point_lights_projection();
    many_lights();
    power_bookkeeping();
    inverse_square();
    glass_ball_caustic();
    white_furnace(0.5f, 0, 0.f);
    white_furnace(0.95f, 0, 0.f);
    white_furnace(0.5f, 4, 0.f);
    white_furnace(0.8f, 4, 0.5f);
    return pm_test_done("test_photons");
}

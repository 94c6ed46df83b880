/* test_progressive.c: the progressive mode's invariants: thin walls, only the passes a scene needs, threads, restarts, scale, eye passes (the 10^4-iteration run and the eye passes' search: test_progressive_long.c). */
#include <stdlib.h>
#include <string.h>

#include "accel.h"
#include "defaults.h"
#include "eye.h"
#include "film.h"
#include "image_io.h"
#include "loader.h"
#include "photonmap.h"
#include "progressive.h"
#include "scene_builder.h"
#include "progressive_harness.h"
#include "testing.h"

/* ---- thin walls, analysis, threads, scale, long runs ---- */

/* A single double-sided quad between a lit room half and a dark one: photons on its lit face
 * must never count on its dark face, though both share the same positions. */
static void test_thin_wall(void) {
    pm_scene s;
    memset(&s, 0, sizeof s);
    uint32_t white = sb_material(&s, v3s(0.8f), 0, 1, 0, v3s(0), true);
    /* the thin wall at z = 0, and a facing wall at z = 1 on the lit side that bounces light back */
    sb_quad(&s, v3(-1, -1, 0), v3(1, -1, 0), v3(1, 1, 0), v3(-1, 1, 0), white);
    sb_quad(&s, v3(-1, -1, 1), v3(-1, 1, 1), v3(1, 1, 1), v3(1, -1, 1), white);
    sb_point_light(&s, v3(0, 0, 0.5f), v3s(1.f));
    pm_accel *a = sb_finish(&s);
    CHECK(s.analysis.interreflection_possible, "two facing walls: interreflection possible");
    enum { W = 16, H = 16 };
    float *img = malloc(sizeof(float) * 3 * W * H);
    for (int mode = 0; mode < 2; mode++) {
        pm_progressive_settings ps = default_settings(W, H);
        ps.indirect = mode == 0 ? PM_INDIRECT_PHOTONS : PM_INDIRECT_GATHER;
        /* a radius far larger than the gap between the faces: only the side test can keep them apart */
        ps.initial_radius = 0.3;
        double lit = 0, dark = 0;
        for (int side = 0; side < 2; side++) {
            pm_camera cam = side == 0 ? sb_camera(v3(0, 0, 0.9f), v3(0, 0, 0), v3(0, 1, 0), 40.f)
                                      : sb_camera(v3(0, 0, -1.5f), v3(0, 0, 0), v3(0, 1, 0), 40.f);
            session r;
            if (!start(&r, &s, a, &cam, W, H, &ps)) break;
            iterate(&r, 16);
            pm_film_resolve(r.film, PM_INDIRECT, img);
            *(side == 0 ? &lit : &dark) = mean_of(img, 3 * W * H);
            stop(&r);
        }
        printf("thin wall (%s): indirect on the lit face %.5f, on the dark face %.3g\n", mode ? "gather" : "photons", lit, dark);
        CHECK(lit > 0.001, "the lit face receives indirect light (%g)", lit);
        CHECK(dark == 0.0, "the dark face of a thin wall stays black (%g)", dark);
    }
    free(img);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

/* Only what the scene needs: a single plane can never receive light reflected from itself. */
static void test_no_photon_pass_when_useless(void) {
    pm_scene s;
    memset(&s, 0, sizeof s);
    uint32_t white = sb_lambert(&s, v3s(0.8f));
    sb_quad(&s, v3(-1, 0, -1), v3(-1, 0, 1), v3(1, 0, 1), v3(1, 0, -1), white);
    sb_point_light(&s, v3(0, 1, 0), v3s(1.f));
    pm_accel *a = sb_finish(&s);
    CHECK(!s.analysis.interreflection_possible && !s.analysis.caustics_possible, "one plane: no second diffuse bounce, no caustic");
    pm_camera cam = sb_camera(v3(0, 2, 2), v3(0, 0, 0), v3(0, 1, 0), 40.f);
    pm_progressive_settings ps = default_settings(8, 8);
    session r;
    if (start(&r, &s, a, &cam, 8, 8, &ps)) {
        CHECK(!pm_progressive_uses_photons(r.p), "no photon pass for a single lit plane");
        CHECK(r.film->sum[PM_CAUSTIC] == NULL && r.film->sum[PM_INDIRECT] == NULL, "no caustic or indirect buffers");
        for (int k = 0; k < PM_SLOT_COUNT; k++) CHECK(r.film->ppm[k] == NULL, "no statistics slot %d", k);
        iterate(&r, 2);
        CHECK(pm_progressive_get_stats(r.p)->photons.emitted == 0, "no photon emitted");
        stop(&r);
    }
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

/* The same room at 10^-3 and 10^3 times the size renders the same image: after 16 iterations at
 * seeds 1-6 the pixels differed from scale 1's by 0.0005-0.0007 of the mean on average and the
 * means by at most 0.06%, far inside the bounds (2% and 1%). */
static void test_scale_invariance(void) {
    enum { W = 24, H = 24 };
    float *img[3];
    const float scales[3] = {1.f, 1e-3f, 1e3f};
    for (int i = 0; i < 3; i++) {
        pm_scene s;
        pm_camera cam;
        pm_accel *a = scaled_room(&s, scales[i], &cam);
        img[i] = malloc(sizeof(float) * 3 * W * H);
        pm_progressive_settings ps = default_settings(W, H);
        session r;
        if (start(&r, &s, a, &cam, W, H, &ps)) {
            iterate(&r, 16);
            pm_film_resolve_total(r.film, img[i]);
            pm_radius_summary rad = pm_progressive_radii(r.p, r.film);
            printf("scale %g: mean %.5f, mean radius / scale %.5f\n", scales[i], mean_of(img[i], 3 * W * H),
                   rad.mean / scales[i]);
            stop(&r);
        }
        pm_accel_destroy(a);
        pm_scene_free(&s);
    }
    const float *const planes_unused[3] = {NULL, NULL, NULL};
    (void)planes_unused;
    for (int i = 1; i < 3; i++) {
        double d = 0, m = mean_of(img[0], 3 * W * H);
        for (int k = 0; k < 3 * W * H; k++) d += fabs(img[i][k] - img[0][k]);
        d /= 3.0 * W * H;
        CHECK(d < 0.02 * m, "scale %g: mean absolute difference %g against %g at scale 1", scales[i], d, m);
        CHECK_NEAR(mean_of(img[i], 3 * W * H), m, 0.01, 0, "image mean at another scale");
    }
    for (int i = 0; i < 3; i++) free(img[i]);
}

static void test_threads_identical(void) {
    pm_scene s;
    pm_camera cam;
    pm_accel *a = scaled_room(&s, 1.f, &cam);
    enum { W = 20, H = 16 };
    float *img[2];
    uint32_t passes[2] = {0, 0};
    for (int t = 0; t < 2; t++) {
        pm_progressive_settings ps = default_settings(W, H);
        ps.threads = t + 1;
        img[t] = malloc(sizeof(float) * 3 * W * H);
        session r;
        if (start(&r, &s, a, &cam, W, H, &ps)) {
            /* past the probe's first iterations: the automatic eye passes are chosen, from counts */
            iterate(&r, 40);
            passes[t] = r.film->photon_passes;
            pm_film_resolve_total(r.film, img[t]);
            stop(&r);
        }
    }
    CHECK(passes[0] == passes[1] && passes[0] < 2 * PM_PPM_PROBE_ITERATIONS + 1,
          "1 and 2 threads: the same photon passes (%u, %u), eye passes chosen past the probe's", passes[0], passes[1]);
    CHECK(memcmp(img[0], img[1], sizeof(float) * 3 * W * H) == 0, "1 and 2 threads give the same image, bit for bit");
    free(img[0]);
    free(img[1]);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

static void test_restart(void) {
    pm_scene s;
    pm_camera cam;
    pm_accel *a = scaled_room(&s, 1.f, &cam);
    enum { W = 12, H = 12 };
    pm_progressive_settings ps = default_settings(W, H);
    ps.indirect = PM_INDIRECT_PHOTONS;
    session r;
    if (!start(&r, &s, a, &cam, W, H, &ps)) return;
    iterate(&r, 3);
    float *first = malloc(sizeof(float) * 3 * W * H), *again = malloc(sizeof(float) * 3 * W * H);
    pm_film_resolve_total(r.film, first);
    pm_ppm_stat *slot = r.film->ppm[PM_SLOT_INDIRECT];
    pm_session_restart(r.session, &cam);
    CHECK(r.film->samples == 0 && r.film->ppm[PM_SLOT_INDIRECT] == slot, "restart keeps the buffers and clears the count");
    iterate(&r, 3);
    pm_film_resolve_total(r.film, again);
    CHECK(memcmp(first, again, sizeof(float) * 3 * W * H) == 0, "after a restart the same iterations give the same image");
    free(first);
    free(again);
    stop(&r);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

/* The first iteration after a start or a restart emits PM_PPM_FIRST_PHOTON_FRACTION of the
 * photons, and the radii start from a whole iteration's density all the same: the final-gather
 * radius after it is at most the one recomputed here from the scene's mean density of the stored
 * photons, scaled to a whole iteration (the density where the camera looks may be higher). */
static void test_first_iteration_photons(void) {
    pm_scene s;
    pm_camera cam;
    pm_accel *a = scaled_room(&s, 1.f, &cam);
    enum { W = 16, H = 16 };
    pm_progressive_settings ps = default_settings(W, H);
    ps.eye_passes = 1; /* an iteration per sample: photons counted per iteration */
    session r;
    if (!start(&r, &s, a, &cam, W, H, &ps)) return;
    uint64_t whole = pm_progressive_photons_per_iteration(r.p);
    CHECK(whole == ps.photons + ps.caustic_photons, "a glass ball and a room: both passes (%llu photons)", (unsigned long long)whole);
    uint64_t global_first = (uint64_t)(PM_PPM_FIRST_PHOTON_FRACTION * (double)ps.photons);
    uint64_t first = global_first + (uint64_t)(PM_PPM_FIRST_PHOTON_FRACTION * (double)ps.caustic_photons);
    iterate(&r, 1);
    const pm_progressive_stats *st = pm_progressive_get_stats(r.p);
    CHECK(st->photons.emitted == first, "the first iteration emits %llu of %llu (%llu)", (unsigned long long)first,
          (unsigned long long)whole, (unsigned long long)st->photons.emitted);
    double area = 0.0;
    for (uint32_t t = 0; t < s.triangle_count; t++) {
        const pm_material *m = &s.materials[s.triangle_material[t]];
        if (m->may_diffuse || m->may_glossy) area += pm_triangle_area(&s, t);
    }
    /* a disc holding PM_PPM_GATHER_PHOTONS of a whole iteration's stored photons, shrunk once */
    double stored_whole = (double)st->photons.stored_global * (double)ps.photons / (double)global_first;
    double want = sqrt(PM_PPM_GATHER_PHOTONS * area / (PM_PI * stored_whole) * (1.0 + ps.alpha) / 2.0);
    double got = pm_progressive_radii(r.p, r.film).gather;
    /* the radius comes from the density where the camera looks, and is never wider than the mean's */
    CHECK(got <= want + 1e-6 && got > 0.2 * want, "final-gather radius after the first iteration %g: from a whole "
          "iteration's density, at most the mean density's %g", got, want);
    iterate(&r, 2);
    CHECK(st->photons.emitted == first + 2 * whole, "later iterations emit the whole count (%llu)",
          (unsigned long long)st->photons.emitted);
    pm_session_restart(r.session, &cam);
    iterate(&r, 1);
    /* a restart clears the statistics too */
    CHECK(st->photons.emitted == first, "the first iteration after a restart emits the first count again (%llu)",
          (unsigned long long)st->photons.emitted);
    stop(&r);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

/* Where the first discs are narrowed to the photon density (dense caustics, bright corners), the
 * half first iteration must narrow them as a whole one would: the radii after it agree with a run
 * whose first iteration emits every photon (without the scaling they come out about sqrt 2 wider). */
static void test_first_iteration_radii(void) {
    pm_scene s;
    pm_camera cam;
    pm_accel *a = scaled_room(&s, 1.f, &cam);
    enum { W = 32, H = 32 };
    pm_radius_summary radii[2];
    for (int k = 0; k < 2; k++) {
        pm_progressive_settings ps = default_settings(W, H);
        ps.indirect = PM_INDIRECT_PHOTONS;
        ps.caustic_by_statistics = true;
        ps.photons = ps.caustic_photons = 400000; /* dense: most first discs hold more than they start with */
        ps.first_photon_fraction = k == 0 ? 1.0 : PM_PPM_FIRST_PHOTON_FRACTION;
        session r;
        if (!start(&r, &s, a, &cam, W, H, &ps)) break;
        iterate(&r, 1);
        radii[k] = pm_progressive_radii(r.p, r.film);
        stop(&r);
    }
    printf("first-iteration radii: whole first iteration mean %.5f min %.5f; %.2f of the photons: mean %.5f min %.5f\n",
           radii[0].mean, radii[0].min, PM_PPM_FIRST_PHOTON_FRACTION, radii[1].mean, radii[1].min);
    CHECK_NEAR(radii[1].initial_mean, radii[0].initial_mean, 0.03, 0, "mean first radius with fewer first photons");
    CHECK_NEAR(radii[1].mean, radii[0].mean, 0.03, 0, "mean radius after the first iteration with fewer first photons");
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

/* A room lit by a point light. Gather points trace its light, and the global passes store none
 * of its first hits: with photons stopped at their first hit nothing is stored, yet the light of
 * one bounce is found, and it is the same light that visible points read from second-hit photons
 * with --indirect photons (a path that neither stores nor traces: the bounce counted twice or not
 * at all would read 2 or 0). At seeds 1-6 the two read 0.965-1.028 of each other (0.965-1.016
 * with twice the iterations), so 10% is about 3 times the largest difference seen. */
static void test_gather_traces_punctual_light(void) {
    pm_scene s;
    memset(&s, 0, sizeof s);
    uint32_t white = sb_lambert(&s, v3s(0.6f)), red = sb_lambert(&s, v3(0.7f, 0.2f, 0.1f));
    sb_box(&s, v3(-1, -1, -1), v3(1, 1, 1), white, true);
    sb_quad(&s, v3(-0.99f, -1, -1), v3(-0.99f, 1, -1), v3(-0.99f, 1, 1), v3(-0.99f, -1, 1), red);
    sb_point_light(&s, v3(0.3f, 0.8f, -0.2f), v3s(2.f));
    pm_accel *a = sb_finish(&s);
    pm_camera cam = sb_camera(v3(0, 0, 0.95f), v3(0, -0.3f, -1), v3(0, 1, 0), 70.f);
    enum { W = 16, H = 16 };
    /* gathering with every bounce, gathering with first hits only, photons at visible points after one bounce */
    double indirect[3] = {0, 0, 0};
    float *img = malloc(sizeof(float) * 3 * W * H);
    for (int run = 0; run < 3 && img; run++) {
        pm_progressive_settings ps = default_settings(W, H);
        ps.gather = PM_GATHER_FORCE_PHOTONS; /* the photons' bounces are what is measured */
        if (run > 0) ps.max_photon_bounces = run;
        if (run == 2) ps.indirect = PM_INDIRECT_PHOTONS;
        session r;
        if (!start(&r, &s, a, &cam, W, H, &ps)) break;
        iterate(&r, run == 2 ? 128 : 32);
        pm_film_resolve(r.film, PM_INDIRECT, img);
        indirect[run] = mean_of(img, 3 * W * H);
        const pm_progressive_stats *st = pm_progressive_get_stats(r.p);
        if (run == 1)
            CHECK(st->photons.stored_global == 0, "first hits of a point light are not stored (%llu)",
                  (unsigned long long)st->photons.stored_global);
        else
            CHECK(st->photons.stored_global > 0, "later hits are (%llu)", (unsigned long long)st->photons.stored_global);
        stop(&r);
    }
    printf("point-lit room: indirect light of one bounce %.5f traced at gather points, %.5f from photons; all bounces %.5f\n",
           indirect[1], indirect[2], indirect[0]);
    CHECK(indirect[2] > 0.0 && fabs(indirect[1] / indirect[2] - 1.0) < 0.1,
          "one bounce traced at gather points %.5f, read from photons %.5f", indirect[1], indirect[2]);
    CHECK(indirect[1] < 0.7 * indirect[0], "more bounces add light: %.5f of %.5f", indirect[1], indirect[0]);
    free(img);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

/* A room lit by a point light and a mirror on one wall: the mirror's image of the light lights the
 * room, light no path from the camera finds (neither a shadow ray nor a sampled direction crosses
 * the mirror to a point). Where the path tracer gathers, the global photons of that light (tagged
 * PM_PATH_PUNCTUAL_SPECULAR, stored alone in its iterations) are read at its first diffuse vertex:
 * the indirect layer must hold what gathering from the photons holds. Without them it lacks the
 * mirror image's light past the first bounce (measured: 0.74 of it). At seeds 1-6 the two read
 * 0.999-1.011 of each other after 96 iterations (1.000-1.003 after 192): 4% is 3.7 times the
 * largest difference seen. */
static void test_path_gather_reads_punctual_specular(void) {
    pm_scene s;
    memset(&s, 0, sizeof s);
    uint32_t white = sb_lambert(&s, v3s(0.6f)), mirror = sb_material(&s, v3s(0.95f), 1, 0, 0, v3s(0), false);
    sb_box(&s, v3(-1, -1, -1), v3(1, 1, 1), white, true);
    sb_quad(&s, v3(0.99f, -1, -1), v3(0.99f, -1, 1), v3(0.99f, 1, 1), v3(0.99f, 1, -1), mirror);
    sb_point_light(&s, v3(0.6f, 0.7f, 0.f), v3s(2.f));
    pm_accel *a = sb_finish(&s);
    pm_camera cam = sb_camera(v3(0.f, 0.f, 0.95f), v3(-0.4f, -0.3f, -1), v3(0, 1, 0), 70.f);
    enum { W = 16, H = 16 };
    double indirect[2] = {0, 0};
    uint64_t stored[2] = {0, 0};
    float *img = malloc(sizeof(float) * 3 * W * H);
    for (int run = 0; run < 2 && img; run++) {
        pm_progressive_settings ps = default_settings(W, H);
        ps.gather = run == 0 ? PM_GATHER_FORCE_PHOTONS : PM_GATHER_FORCE_PATH;
        session r;
        if (!start(&r, &s, a, &cam, W, H, &ps)) break;
        iterate(&r, 96);
        pm_film_resolve(r.film, PM_INDIRECT, img);
        indirect[run] = mean_of(img, 3 * W * H);
        stored[run] = pm_progressive_get_stats(r.p)->photons.stored_global;
        stop(&r);
    }
    printf("point light and a mirror: indirect light %.5f gathering photons, %.5f with the path tracer and the tagged "
           "photons (global records stored %llu and %llu)\n",
           indirect[0], indirect[1], (unsigned long long)stored[0], (unsigned long long)stored[1]);
    CHECK(indirect[0] > 0.0 && fabs(indirect[1] / indirect[0] - 1.0) < 0.04,
          "the path tracer's gather with the tagged photons holds the photons' indirect light: %.5f against %.5f", indirect[1],
          indirect[0]);
    CHECK(stored[1] > 0 && stored[1] < stored[0] / 2, "the path tracer's iterations store the tagged photons alone (%llu against %llu)",
          (unsigned long long)stored[1], (unsigned long long)stored[0]);
    free(img);
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

/* Several eye passes reading one photon pass. The film divides its sums by eye passes and the
 * statistics by photon passes: with the same photon passes, 1 or 4 eye passes each give the same
 * caustic splats (each splat weighed by the eye passes of its pass; exact, the weights are powers
 * of two) and the same light on average in every component, indirect light read at gather points
 * or from statistics at visible points (--indirect photons); and 4 eye passes average the noise a
 * photon pass cannot (a gather direction, a pixel's jitter): two seeds' images differ less.
 * What is weighed is the eye passes' noise, and tracing the default photons (10^4 of each kind at
 * 16x16) would take most of the time, so a pass traces 2,500 of each. At the seed pairs 1-2,
 * 3-4, ..., 23-24 the mean square difference with 4 eye passes over that with 1 read
 * 0.15-0.53 (0.17-0.61 with 10^4 photons), and the largest difference between the means with 1
 * and 4 eye passes was 3.5% (specular; 3.2% with 10^4), the indirect light's 0.8% (0.9%). */
static void test_eye_passes(void) {
    pm_scene s;
    pm_camera cam;
    pm_accel *a = scaled_room(&s, 1.f, &cam);
    enum { W = 16, H = 16, PASSES = 48, N = 3 * W * H };
    for (int mode = 0; mode < 2; mode++) {
        pm_indirect_mode indirect = mode ? PM_INDIRECT_PHOTONS : PM_INDIRECT_GATHER;
        const char *name = mode ? "photons" : "gather";
        float *img[2][2][PM_COMPONENT_COUNT]; /* [eye passes 1 or 4][seed][component] */
        for (int k = 0; k < 2; k++)
            for (int seed = 0; seed < 2; seed++) {
                pm_progressive_settings ps = default_settings(W, H);
                ps.eye_passes = k ? 4 : 1;
                ps.seed = 1 + (uint64_t)seed;
                ps.indirect = indirect;
                ps.photons = ps.caustic_photons = 2500;
                session r;
                for (int c = 0; c < PM_COMPONENT_COUNT; c++) img[k][seed][c] = calloc(N, sizeof(float));
                if (!start(&r, &s, a, &cam, W, H, &ps)) continue;
                iterate(&r, PASSES * ps.eye_passes);
                CHECK(r.film->photon_passes == PASSES && r.film->samples == PASSES * (uint32_t)ps.eye_passes,
                      "%d eye passes: %u photon passes, %u samples", ps.eye_passes, r.film->photon_passes, r.film->samples);
                for (int c = 0; c < PM_COMPONENT_COUNT; c++) pm_film_resolve(r.film, c, img[k][seed][c]);
                stop(&r);
            }
        CHECK(mean_of(img[0][0][PM_CAUSTIC], N) > 0.0 && memcmp(img[0][0][PM_CAUSTIC], img[1][0][PM_CAUSTIC], N * sizeof(float)) == 0,
              "--indirect %s: the caustic seen directly (camera splats), the same image with 1 and 4 eye passes a photon pass", name);
        for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
            double m1 = (mean_of(img[0][0][c], N) + mean_of(img[0][1][c], N)) / 2;
            double m4 = (mean_of(img[1][0][c], N) + mean_of(img[1][1][c], N)) / 2;
            printf("eye passes, --indirect %s: %-9s mean %.5f with 1 a photon pass, %.5f with 4\n", name,
                   pm_component_names[c], m1, m4);
            CHECK(fabs(m4 - m1) <= 0.05 * m1 + 1e-4, "--indirect %s, %s: the same light with 4 eye passes a photon pass (%.5f against %.5f)",
                  name, pm_component_names[c], m4, m1);
        }
        double diff[2] = {0, 0};
        for (int k = 0; k < 2; k++)
            for (int c = 0; c < PM_COMPONENT_COUNT; c++)
                for (int i = 0; i < N; i++) {
                    double d = img[k][0][c][i] - img[k][1][c][i];
                    diff[k] += d * d / N;
                }
        printf("eye passes, --indirect %s: two seeds differ by %.6f (mean square) with 1 eye pass a photon pass, %.6f with 4\n",
               name, diff[0], diff[1]);
        if (indirect == PM_INDIRECT_GATHER)
            CHECK(diff[1] < 0.6 * diff[0], "4 eye passes a photon pass average more noise: %.6f against %.6f", diff[1], diff[0]);
        for (int k = 0; k < 2; k++)
            for (int seed = 0; seed < 2; seed++)
                for (int c = 0; c < PM_COMPONENT_COUNT; c++) free(img[k][seed][c]);
    }

    /* automatic: one eye pass in the first iteration (the first image waits for nothing), never
     * past the samples asked for; what it settles on is checked against a search
     * (test_progressive_long.c) */
    pm_progressive_settings ps = default_settings(W, H);
    session r;
    if (start(&r, &s, a, &cam, W, H, &ps)) {
        CHECK(pm_session_iterate(r.session, 0) && r.film->samples == 1, "the first iteration has one eye pass (%u)",
              r.film->samples);
        CHECK(pm_session_iterate(r.session, 1) && r.film->samples == 2 && r.film->photon_passes == 2,
              "at most the samples asked for (%u samples, %u photon passes)", r.film->samples, r.film->photon_passes);
        stop(&r);
    }
    pm_accel_destroy(a);
    pm_scene_free(&s);
}

int main(void) {
    test_eye_passes();
    test_thin_wall();
    test_no_photon_pass_when_useless();
    test_threads_identical();
    test_restart();
    test_first_iteration_photons();
    test_gather_traces_punctual_light();
    test_path_gather_reads_punctual_specular();
    test_first_iteration_radii();
    test_scale_invariance();
    return pm_test_done("test_progressive");
}

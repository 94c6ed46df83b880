/* test_clip_shortcut.c: a disc the shortcut leaves unclipped (pm_clip_needless, the clearance grids) is one the probes leave unclipped too, on walls, boxes, shelves, a ball and a finely cut floor; and the shortcut answers most of the discs the probes leave open.
 *
 * The probes (pm_clip_make_probed) are the reference: they are what clip.c did before the
 * shortcut, and what it still does wherever the shortcut is unsure. Points are drawn on every
 * triangle of a room with a 1 cm wall across it, a box on the floor, a shelf hanging in the air,
 * a ball resting on the floor and a patch of floor cut into many small triangles; radii from 2 cm
 * to 80 cm. Wherever the shortcut says no probe could clip the disc, the probes, cast with eight
 * fan rotations, must find no plane and no slab. The converse is checked as a share: of the discs
 * the probes leave open (points spread by area), the shortcut must spot at least half (the room is
 * mostly open floor and wall), so a shortcut that always says "unsure" fails here.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "accel.h"
#include "clip.h"
#include "rng.h"
#include "scene_builder.h"
#include "testing.h"

static pm_accel *room(pm_scene *s) {
    memset(s, 0, sizeof *s);
    uint32_t white = sb_lambert(s, v3s(0.8f));
    /* the floor: one large quad for x < 1, a patch cut into 0.1 m squares for x in [1, 2] */
    sb_quad(s, v3(-2, 0, -2), v3(-2, 0, 2), v3(1, 0, 2), v3(1, 0, -2), white);
    for (int i = 0; i < 10; i++)
        for (int j = 0; j < 40; j++) {
            float x0 = 1.f + 0.1f * i, z0 = -2.f + 0.1f * j;
            sb_quad(s, v3(x0, 0, z0), v3(x0, 0, z0 + 0.1f), v3(x0 + 0.1f, 0, z0 + 0.1f), v3(x0 + 0.1f, 0, z0), white);
        }
    sb_quad(s, v3(-2, 2.5f, -2), v3(2, 2.5f, -2), v3(2, 2.5f, 2), v3(-2, 2.5f, 2), white);
    sb_quad(s, v3(-2, 0, -2), v3(-2, 2.5f, -2), v3(-2, 2.5f, 2), v3(-2, 0, 2), white);
    sb_quad(s, v3(2, 0, 2), v3(2, 2.5f, 2), v3(2, 2.5f, -2), v3(2, 0, -2), white);
    sb_quad(s, v3(-2, 0, 2), v3(-2, 2.5f, 2), v3(2, 2.5f, 2), v3(2, 0, 2), white);
    sb_quad(s, v3(2, 0, -2), v3(2, 2.5f, -2), v3(-2, 2.5f, -2), v3(-2, 0, -2), white);
    sb_box(s, v3(-0.005f, 0, -2), v3(0.005f, 1.2f, 0.5f), white, false); /* a 1 cm wall, not to the ceiling */
    sb_box(s, v3(-1.5f, 0, 1.0f), v3(-1.0f, 0.4f, 1.5f), white, false);  /* a box on the floor */
    sb_box(s, v3(0.5f, 1.0f, -1.8f), v3(1.5f, 1.05f, -1.2f), white, false); /* a shelf in the air */
    sb_sphere(s, v3(-1.0f, 0.3f, -1.0f), 0.3f, 24, white);                  /* a ball on the floor */
    return sb_finish(s);
}

static bool open_clip(const pm_clip *c) { return !c->planes && c->below == INFINITY && c->above == INFINITY; }

int main(void) {
    pm_scene s;
    pm_accel *a = room(&s);
    CHECK(a != NULL, "the room builds");
    if (!a) return pm_test_done("test_clip_shortcut");
    static const float radii[] = {0.02f, 0.1f, 0.3f, 0.8f};
    enum { POINTS = 3000, ROTATIONS = 8 };
    /* points spread by area, as a render's visible and gather points are */
    uint32_t triangles = s.triangle_count;
    double *cdf = malloc(sizeof(double) * (triangles + 1));
    uint32_t *point_tri = malloc(sizeof(uint32_t) * POINTS);
    vec3 *point = malloc(sizeof(vec3) * POINTS);
    if (!cdf || !point_tri || !point) abort();
    cdf[0] = 0.0;
    for (uint32_t t = 0; t < triangles; t++) {
        vec3 c[3];
        pm_scene_triangle_corners(&s, t, c);
        cdf[t + 1] = cdf[t] + 0.5 * v3_length(v3_cross(v3_sub(c[1], c[0]), v3_sub(c[2], c[0])));
    }
    pm_rng rng = pm_rng_for(7, 0, 0);
    for (int k = 0; k < POINTS; k++) {
        double x = pm_rng_float(&rng) * cdf[triangles];
        uint32_t lo = 0, hi = triangles - 1;
        while (lo < hi) {
            uint32_t mid = (lo + hi) / 2;
            if (cdf[mid + 1] <= x) lo = mid + 1;
            else hi = mid;
        }
        vec3 c[3];
        pm_scene_triangle_corners(&s, lo, c);
        float u = pm_rng_float(&rng), v = pm_rng_float(&rng);
        if (u + v > 1.f) u = 1.f - u, v = 1.f - v;
        point_tri[k] = lo;
        point[k] = v3_add(c[0], v3_add(v3_scale(v3_sub(c[1], c[0]), u), v3_scale(v3_sub(c[2], c[0]), v)));
    }
    uint64_t slab_discs = 0, slab_wrong = 0, slab_cached = 0, searched_wrong = 0;
    uint64_t discs = 0, probed_open = 0, spotted = 0, wrong = 0, cached_open = 0, cached_wrong = 0, probes_known = 0, probes_wrong = 0;
    pm_clip_cache *cache = pm_clip_cache_create(&s, a);
    CHECK(cache != NULL, "a clearance cache for a small flat scene");
    for (int pass = 0; pass < 3; pass++) /* the grids are built once a triangle has been asked about often */
        for (int k = 0; k < POINTS; k++)
            for (size_t ri = 0; ri < sizeof radii / sizeof *radii; ri++) {
                uint32_t t = point_tri[k];
                vec3 p = point[k], n = pm_scene_triangle_face_normal(&s, t);
                float r = radii[ri];
                pm_clip_known known = pm_clip_cache_lookup(cache, t, p, r);
                bool cached = known == PM_CLEAR_OPEN;
                if (pass < 2) continue;
                bool needless = pm_clip_needless(&s, a, p, n, r);
                pm_clip_known searched = pm_clip_search(&s, a, p, n, r);
                bool all_open = true;
                for (int rot = 0; rot < ROTATIONS; rot++) {
                    pm_clip clip, slab;
                    uint64_t seed = pm_hash64((uint64_t)k << 8 ^ (uint64_t)ri << 4 ^ (uint64_t)rot);
                    pm_clip_make_probed(&clip, &s, a, p, n, t, r, seed, NULL);
                    all_open &= open_clip(&clip);
                    if (known != PM_CLEAR_SLAB && searched != PM_CLEAR_SLAB) continue;
                    /* only the probes along the normal: the same clip, plane for plane */
                    pm_clip_make_slab(&slab, &s, a, p, n, t, r, seed, NULL);
                    bool same = clip.planes == 0 && slab.planes == 0 && clip.below == slab.below && clip.above == slab.above;
                    slab_discs += rot == 0;
                    slab_wrong += !same;
                    if (!same) printf("slab wrong: triangle %u, p (%g %g %g), r %g, %d planes\n", t, p.x, p.y, p.z, r, clip.planes);
                }
                slab_cached += known == PM_CLEAR_SLAB;
                searched_wrong += (searched == PM_CLEAR_OPEN) != needless;
                discs++;
                probed_open += all_open;
                spotted += all_open && needless;
                wrong += needless && !all_open;
                cached_open += cached;
                cached_wrong += cached && !all_open;
                probes_known += known == PM_CLEAR_NEAR;
                probes_wrong += known == PM_CLEAR_NEAR && needless;
                if (needless && !all_open) printf("shortcut wrong: triangle %u, p (%g %g %g), r %g\n", t, p.x, p.y, p.z, r);
            }
    free(cdf);
    free(point_tri);
    free(point);
    printf("%llu discs: the probes leave %llu open; the search spots %llu of them and is wrong %llu times; the grids %llu, wrong %llu\n",
           (unsigned long long)discs, (unsigned long long)probed_open, (unsigned long long)spotted, (unsigned long long)wrong,
           (unsigned long long)cached_open, (unsigned long long)cached_wrong);
    CHECK(wrong == 0, "the search never leaves open a disc the probes would clip (%llu)", (unsigned long long)wrong);
    CHECK(cached_wrong == 0, "the grids never leave open a disc the probes would clip (%llu)", (unsigned long long)cached_wrong);
    printf("the grids send %llu discs straight to the probes, %llu of them wrongly\n", (unsigned long long)probes_known,
           (unsigned long long)probes_wrong);
    CHECK(probes_wrong == 0, "the grids send to the probes only discs the search would send there (%llu)", (unsigned long long)probes_wrong);
    CHECK(probes_known > 0, "the grids send some discs near walls straight to the probes (%llu)", (unsigned long long)probes_known);
    printf("the fan is known to meet nothing for %llu discs (the grids %llu): their clips along the normal alone differ %llu times\n",
           (unsigned long long)slab_discs, (unsigned long long)slab_cached, (unsigned long long)slab_wrong);
    CHECK(slab_wrong == 0, "where the fan is known to meet nothing, the probes along the normal make the same clip (%llu)",
          (unsigned long long)slab_wrong);
    CHECK(slab_cached > 0 && slab_discs > slab_cached / 2, "the grids and the search find discs the fan cannot clip (%llu, %llu)",
          (unsigned long long)slab_cached, (unsigned long long)slab_discs);
    CHECK(searched_wrong == 0, "the search's open is pm_clip_needless's (%llu)", (unsigned long long)searched_wrong);
    CHECK(probed_open > discs / 4, "the room has open discs to find (%llu of %llu)", (unsigned long long)probed_open,
          (unsigned long long)discs);
    CHECK(spotted * 2 >= probed_open, "the search spots at least half of the open discs (%llu of %llu)",
          (unsigned long long)spotted, (unsigned long long)probed_open);
    CHECK(cached_open * 4 >= spotted, "the grids answer at least a quarter of what the search spots (%llu of %llu)",
          (unsigned long long)cached_open, (unsigned long long)spotted);
    /* near a wall the probes do clip, and the shortcut must leave it to them */
    vec3 up = v3(0, 1, 0);
    CHECK(!pm_clip_needless(&s, a, v3(-0.05f, 0, 0), up, 0.1f), "a floor point 4.5 cm from the 1 cm wall is left to the probes (r 0.1)");
    CHECK(pm_clip_needless(&s, a, v3(-0.5f, 0, 0), up, 0.1f), "a floor point 0.5 m from everything needs no probe (r 0.1)");
    /* the ceiling, 1 m from the nearest wall: r 0.3 reaches nothing, r 0.6 (probes to 1.2 m) reaches the wall */
    vec3 down = v3(0, -1, 0);
    CHECK(pm_clip_needless(&s, a, v3(-1.0f, 2.5f, 0.f), down, 0.3f), "the ceiling 1 m from the walls needs no probe for r 0.3");
    CHECK(!pm_clip_needless(&s, a, v3(-1.0f, 2.5f, 0.f), down, 0.6f), "the ceiling 1 m from the walls is left to the probes for r 0.6");
    pm_clip_cache_destroy(cache);
    pm_accel_destroy(a);
    pm_scene_free(&s);
    return pm_test_done("test_clip_shortcut");
}

/* test_view.c: the offscreen display against a reference computed here: composition, toggles, exposure, tonemap, bad input, orientation.
 *
 * Films are filled by hand with known sums, drawn through the real shaders (OSMesa, OpenGL 3.3
 * core) and read back; every pixel is compared with the sRGB byte computed in double, +-1 for
 * the GPU's float arithmetic and pow approximation.
 */
#include <stdint.h>
#include <string.h>

#include "film.h"
#include "view.h"
#include "testing.h"

/* The display's reference: linear value -> sRGB byte. */
static int srgb8(double x) {
    if (!(x > 0.0)) return 0;
    if (x > 1.0) x = 1.0;
    double e = x < 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055;
    return (int)floor(e * 255.0 + 0.5);
}

/* What the shader should make of one pixel's linear RGB (after scale and exposure). */
static void reference(const double lin[3], int tonemap, int out[3]) {
    double c[3];
    for (int k = 0; k < 3; k++) c[k] = lin[k] > 0.0 ? lin[k] : 0.0;
    if (tonemap) {
        double l = 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
        if (l > 0.0)
            for (int k = 0; k < 3; k++) c[k] *= 1.0 / (1.0 + l);
    }
    for (int k = 0; k < 3; k++) out[k] = srgb8(c[k]);
}

static pm_display display_all(void) {
    pm_display d;
    memset(&d, 0, sizeof d);
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) d.enabled[c] = true;
    return d;
}

static uint8_t *draw_and_read(pm_view *v, const pm_film *f, const pm_display *d) {
    uint8_t *rgba = malloc(4 * (size_t)f->width * f->height);
    memset(rgba, 0xAB, 4 * (size_t)f->width * f->height); /* a draw that writes nothing must not pass */
    pm_view_upload(v, f);
    pm_view_draw(v, d);
    pm_view_read_rgba8(v, rgba);
    return rgba;
}

/* Compares every pixel with the reference for display d; returns the number of bad pixels. */
static int compare_film(pm_view *v, const pm_film *f, const pm_display *d, const char *what) {
    uint8_t *rgba = draw_and_read(v, f, d);
    double ev_scale = exp2((double)d->exposure_ev);
    int bad = 0;
    for (int y = 0; y < f->height; y++)
        for (int x = 0; x < f->width; x++) {
            size_t i = (size_t)y * f->width + x;
            double lin[3] = {0, 0, 0};
            if (f->samples)
                for (int c = 0; c < PM_COMPONENT_COUNT; c++)
                    if (d->enabled[c] && f->sum[c])
                        for (int k = 0; k < 3; k++) lin[k] += (double)f->sum[c][3 * i + k] / f->samples * ev_scale;
            int want[3];
            reference(lin, d->tonemap, want);
            const uint8_t *got = rgba + 4 * i;
            bool ok = got[3] == 255;
            for (int k = 0; k < 3; k++) ok = ok && abs((int)got[k] - want[k]) <= 1;
            if (!ok && bad++ < 5)
                fprintf(stderr, "  %s: pixel (%d,%d) got %d %d %d %d want %d %d %d 255\n", what, x, y, got[0], got[1],
                        got[2], got[3], want[0], want[1], want[2]);
        }
    free(rgba);
    CHECK(bad == 0, "%s: %d of %d pixels differ from the reference", what, bad, f->width * f->height);
    return bad;
}

static float hash01(uint32_t x) {
    x ^= x >> 16; x *= 0x7feb352dU; x ^= x >> 15; x *= 0x846ca68bU; x ^= x >> 16;
    return (x >> 8) * (1.0f / 16777216.0f);
}

/* Sums spread over the whole display range: some black, some above 1 after scaling. */
static void fill_pattern(pm_film *f, uint32_t seed) {
    size_t n = 3 * (size_t)f->width * f->height;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++)
        if (f->sum[c])
            for (size_t i = 0; i < n; i++) {
                float u = hash01((uint32_t)(i * 4 + c) ^ seed);
                f->sum[c][i] = (u < 0.1f ? 0.f : u * u * 1.5f) * (float)f->samples;
            }
}

static pm_view *offscreen(int w, int h) {
    char err[1024] = "";
    pm_view *v = pm_view_create_offscreen(w, h, err, sizeof err);
    CHECK(v != NULL, "offscreen view %dx%d: %s", w, h, err);
    if (v) CHECK(!pm_view_is_window(v), "an offscreen view is no window");
    return v;
}

static void test_composition(void) {
    pm_view *v = offscreen(8, 4);
    if (!v) return;
    bool comps[PM_COMPONENT_COUNT] = {true, false, true, true}; /* specular absent */
    pm_film f;
    CHECK(pm_film_init(&f, 8, 4, comps), "film");
    f.samples = 4;
    /* direct: a gradient; caustic: one pixel; indirect: a constant */
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 8; x++) {
            float *p = f.sum[PM_DIRECT] + 3 * (y * 8 + x);
            p[0] = 4.f * 0.1f * x; p[1] = 4.f * 0.2f * y; p[2] = 4.f * 0.05f;
            float *q = f.sum[PM_INDIRECT] + 3 * (y * 8 + x);
            q[0] = q[1] = q[2] = 4.f * 0.02f;
        }
    f.sum[PM_CAUSTIC][3 * (2 * 8 + 5) + 0] = 4.f * 0.5f;
    f.sum[PM_CAUSTIC][3 * (2 * 8 + 5) + 2] = 4.f * 0.25f;

    pm_display d = display_all();
    compare_film(v, &f, &d, "all components");

    /* Exact bytes on one pixel, independent of the reference helper: direct (0.3,0.2,0.05) + indirect 0.02. */
    uint8_t *all = draw_and_read(v, &f, &d);
    const uint8_t *p = all + 4 * (1 * 8 + 3);
    CHECK(abs(p[0] - srgb8(0.32)) <= 1 && abs(p[1] - srgb8(0.22)) <= 1 && abs(p[2] - srgb8(0.07)) <= 1,
          "pixel (3,1) got %d %d %d want %d %d %d", p[0], p[1], p[2], srgb8(0.32), srgb8(0.22), srgb8(0.07));

    /* Toggling: indirect off changes every pixel (it is everywhere), caustic off only its pixel. */
    d.enabled[PM_INDIRECT] = false;
    compare_film(v, &f, &d, "indirect off");
    uint8_t *no_indirect = draw_and_read(v, &f, &d);
    int changed = 0;
    for (int i = 0; i < 32; i++) changed += memcmp(all + 4 * i, no_indirect + 4 * i, 4) != 0;
    CHECK(changed == 32, "indirect off changed %d of 32 pixels", changed);
    free(no_indirect);

    d = display_all();
    d.enabled[PM_CAUSTIC] = false;
    uint8_t *no_caustic = draw_and_read(v, &f, &d);
    changed = 0;
    for (int i = 0; i < 32; i++) changed += memcmp(all + 4 * i, no_caustic + 4 * i, 4) != 0;
    CHECK(changed == 1 && memcmp(all + 4 * (2 * 8 + 5), no_caustic + 4 * (2 * 8 + 5), 4) != 0,
          "caustic off changed %d pixels, want exactly (5,2)", changed);
    free(no_caustic);

    /* Specular is absent: toggling it changes nothing at all. */
    d = display_all();
    d.enabled[PM_SPECULAR] = false;
    uint8_t *no_specular = draw_and_read(v, &f, &d);
    CHECK(memcmp(all, no_specular, 4 * 32) == 0, "toggling an absent component changed the picture");
    free(no_specular);

    /* Everything off: black. */
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) d.enabled[c] = false;
    compare_film(v, &f, &d, "all off");

    /* Exposure: +1 ev doubles, -1 ev halves the linear values. */
    d = display_all();
    d.exposure_ev = 1.f;
    compare_film(v, &f, &d, "exposure +1");
    uint8_t *plus1 = draw_and_read(v, &f, &d);
    p = plus1 + 4 * (1 * 8 + 3);
    CHECK(abs(p[0] - srgb8(0.64)) <= 1 && abs(p[1] - srgb8(0.44)) <= 1 && abs(p[2] - srgb8(0.14)) <= 1,
          "+1 ev pixel (3,1) got %d %d %d want %d %d %d", p[0], p[1], p[2], srgb8(0.64), srgb8(0.44), srgb8(0.14));
    free(plus1);
    d.exposure_ev = -1.f;
    compare_film(v, &f, &d, "exposure -1");
    d.exposure_ev = -0.5f;
    d.tonemap = 1;
    compare_film(v, &f, &d, "exposure -0.5, Reinhard");
    free(all);

    /* Changing the display only redraws: a draw without upload keeps the uploaded film. */
    d = display_all();
    pm_view_upload(v, &f);
    d.enabled[PM_DIRECT] = false;
    pm_view_draw(v, &d);
    d.enabled[PM_DIRECT] = true;
    pm_view_draw(v, &d);
    uint8_t *again = malloc(4 * 32);
    pm_view_read_rgba8(v, again);
    uint8_t *ref = draw_and_read(v, &f, &d);
    CHECK(memcmp(again, ref, 4 * 32) == 0, "redraw without upload differs");
    free(again);
    free(ref);

    pm_film_free(&f);
    pm_view_destroy(v);
}

static void test_tonemap(void) {
    pm_view *v = offscreen(4, 1);
    if (!v) return;
    bool comps[PM_COMPONENT_COUNT] = {true, false, false, false};
    pm_film f;
    CHECK(pm_film_init(&f, 4, 1, comps), "film");
    f.samples = 1;
    float px[4][3] = {{1, 1, 1}, {4, 4, 4}, {2, 0, 0}, {0.05f, 0.1f, 0.2f}};
    memcpy(f.sum[PM_DIRECT], px, sizeof px);
    pm_display d = display_all();
    d.tonemap = 1;
    uint8_t *rgba = draw_and_read(v, &f, &d);
    /* luminance 1 -> 0.5, and grey stays grey */
    for (int k = 0; k < 3; k++) CHECK(abs(rgba[k] - srgb8(0.5)) <= 1, "Reinhard of 1.0: channel %d = %d, want %d", k, rgba[k], srgb8(0.5));
    for (int k = 0; k < 3; k++) CHECK(abs(rgba[4 + k] - srgb8(0.8)) <= 1, "Reinhard of 4.0: channel %d = %d, want %d", k, rgba[4 + k], srgb8(0.8));
    free(rgba);
    compare_film(v, &f, &d, "Reinhard");
    d.tonemap = 0;
    rgba = draw_and_read(v, &f, &d);
    CHECK(rgba[0] == 255 && rgba[4] == 255 && rgba[8] == 255 && rgba[9] == 0, "clamp: got %d %d %d %d", rgba[0], rgba[4],
          rgba[8], rgba[9]);
    free(rgba);
    pm_film_free(&f);
    pm_view_destroy(v);
}

static void test_bad_values(void) {
    pm_view *v = offscreen(6, 1);
    if (!v) return;
    bool comps[PM_COMPONENT_COUNT] = {true, true, false, false};
    pm_film f;
    CHECK(pm_film_init(&f, 6, 1, comps), "film");
    f.samples = 2;
    float nan = NAN, inf = INFINITY;
    float direct[6][3] = {{nan, nan, nan}, {-1.f, -0.5f, -100.f}, {inf, inf, inf}, {-inf, -inf, -inf},
                          {nan, 1.0f, -inf}, {inf, 0.f, nan}};
    memcpy(f.sum[PM_DIRECT], direct, sizeof direct);
    /* a healthy second component next to the bad values: it must still show where they are 0 */
    for (int i = 0; i < 6; i++) f.sum[PM_SPECULAR][3 * i + 1] = 0.2f * 2;
    for (int tonemap = 0; tonemap <= 1; tonemap++) {
        pm_display d = display_all();
        d.tonemap = tonemap;
        uint8_t *rgba = draw_and_read(v, &f, &d);
        int g = srgb8(tonemap ? 0.2 / (1.0 + 0.7152 * 0.2) : 0.2);
        CHECK(rgba[0] == 0 && abs(rgba[1] - g) <= 1 && rgba[2] == 0, "NaN (tonemap %d): got %d %d %d", tonemap, rgba[0], rgba[1], rgba[2]);
        CHECK(rgba[4] == 0 && abs(rgba[5] - g) <= 1 && rgba[6] == 0, "negative (tonemap %d): got %d %d %d", tonemap, rgba[4], rgba[5], rgba[6]);
        CHECK(rgba[8] == 255 && rgba[9] == 255 && rgba[10] == 255, "+inf (tonemap %d): got %d %d %d", tonemap, rgba[8], rgba[9], rgba[10]);
        CHECK(rgba[12] == 0 && abs(rgba[13] - g) <= 1 && rgba[14] == 0, "-inf (tonemap %d): got %d %d %d", tonemap, rgba[12], rgba[13], rgba[14]);
        if (!tonemap) {
            CHECK(rgba[16] == 0 && abs(rgba[17] - srgb8(0.7)) <= 1 && rgba[18] == 0, "mixed NaN/-inf: got %d %d %d", rgba[16],
                  rgba[17], rgba[18]);
            CHECK(rgba[20] == 255 && abs(rgba[21] - g) <= 1 && rgba[22] == 0, "mixed inf/NaN: got %d %d %d", rgba[20], rgba[21], rgba[22]);
        } else {
            /* +inf red dominates the luminance: red ~ 1/0.2126 clamps to 1, the rest ~ 0 */
            CHECK(rgba[20] == 255 && rgba[21] <= 1 && rgba[22] == 0, "mixed inf/NaN, Reinhard: got %d %d %d", rgba[20], rgba[21], rgba[22]);
        }
        for (int i = 0; i < 6; i++) CHECK(rgba[4 * i + 3] == 255, "alpha of pixel %d = %d", i, rgba[4 * i + 3]);
        free(rgba);
    }
    /* samples = 0 is black even with inf sums (inf * 0 must not become NaN garbage) */
    f.samples = 0;
    pm_display d = display_all();
    uint8_t *rgba = draw_and_read(v, &f, &d);
    int nonblack = 0;
    for (int i = 0; i < 6; i++) nonblack += rgba[4 * i] || rgba[4 * i + 1] || rgba[4 * i + 2] || rgba[4 * i + 3] != 255;
    CHECK(nonblack == 0, "samples = 0: %d pixels not black", nonblack);
    free(rgba);
    pm_film_free(&f);
    pm_view_destroy(v);
}

static void test_absent_and_empty(void) {
    pm_view *v = offscreen(3, 2);
    if (!v) return;
    bool none[PM_COMPONENT_COUNT] = {false, false, false, false};
    pm_film f;
    CHECK(pm_film_init(&f, 3, 2, none), "film without components");
    f.samples = 10;
    pm_display d = display_all();
    compare_film(v, &f, &d, "no components");
    pm_film_free(&f);

    /* only caustic present: the other three are black however they are toggled */
    bool caustic[PM_COMPONENT_COUNT] = {false, false, true, false};
    CHECK(pm_film_init(&f, 3, 2, caustic), "film");
    f.samples = 3;
    fill_pattern(&f, 99);
    compare_film(v, &f, &d, "caustic only");
    d.enabled[PM_CAUSTIC] = false;
    compare_film(v, &f, &d, "caustic only, toggled off");

    /* a component that disappears between uploads goes black (not the stale texture) */
    pm_film g;
    bool direct[PM_COMPONENT_COUNT] = {true, false, false, false};
    CHECK(pm_film_init(&g, 3, 2, direct), "film");
    g.samples = 1;
    fill_pattern(&g, 5);
    d = display_all();
    compare_film(v, &g, &d, "direct only after caustic");
    pm_film_free(&g);
    pm_film_free(&f);
    pm_view_destroy(v);
}

static void test_orientation(void) {
    pm_view *v = offscreen(8, 4);
    if (!v) return;
    bool comps[PM_COMPONENT_COUNT] = {true, false, false, false};
    pm_film f;
    CHECK(pm_film_init(&f, 8, 4, comps), "film");
    f.samples = 1;
    f.sum[PM_DIRECT][0] = 1.f;                        /* row 0 (top), col 0: red */
    f.sum[PM_DIRECT][3 * (0 * 8 + 7) + 1] = 1.f;      /* top right: green */
    f.sum[PM_DIRECT][3 * (3 * 8 + 0) + 2] = 1.f;      /* bottom left: blue */
    pm_display d = display_all();
    uint8_t *rgba = draw_and_read(v, &f, &d);
    const uint8_t *tl = rgba, *tr = rgba + 4 * 7, *bl = rgba + 4 * (3 * 8);
    CHECK(tl[0] == 255 && tl[1] == 0 && tl[2] == 0, "top left should be red: %d %d %d", tl[0], tl[1], tl[2]);
    CHECK(tr[0] == 0 && tr[1] == 255 && tr[2] == 0, "top right should be green: %d %d %d", tr[0], tr[1], tr[2]);
    CHECK(bl[0] == 0 && bl[1] == 0 && bl[2] == 255, "bottom left should be blue: %d %d %d", bl[0], bl[1], bl[2]);
    int lit = 0;
    for (int i = 0; i < 32; i++) lit += rgba[4 * i] || rgba[4 * i + 1] || rgba[4 * i + 2];
    CHECK(lit == 3, "%d lit pixels, want 3", lit);
    free(rgba);
    pm_film_free(&f);
    pm_view_destroy(v);
}

static void test_sizes(void) {
    static const int sizes[][2] = {{1, 1}, {333, 77}, {77, 333}, {5, 3}};
    for (size_t s = 0; s < sizeof sizes / sizeof *sizes; s++) {
        int w = sizes[s][0], h = sizes[s][1];
        pm_view *v = offscreen(w, h);
        if (!v) continue;
        bool comps[PM_COMPONENT_COUNT] = {true, true, true, true};
        pm_film f;
        CHECK(pm_film_init(&f, w, h, comps), "film %dx%d", w, h);
        f.samples = 7;
        fill_pattern(&f, (uint32_t)(w * 1000 + h));
        char what[64];
        snprintf(what, sizeof what, "%dx%d", w, h);
        pm_display d = display_all();
        compare_film(v, &f, &d, what);
        d.enabled[PM_SPECULAR] = false;
        d.tonemap = 1;
        d.exposure_ev = 0.5f;
        compare_film(v, &f, &d, what);
        pm_film_free(&f);
        pm_view_destroy(v);
    }
}

/* Two live views: each call must use its own context. */
static void test_two_views(void) {
    pm_view *a = offscreen(8, 4), *b = offscreen(3, 5);
    if (a && b) {
        bool comps[PM_COMPONENT_COUNT] = {true, false, false, true};
        pm_film fa, fb;
        CHECK(pm_film_init(&fa, 8, 4, comps) && pm_film_init(&fb, 3, 5, comps), "films");
        fa.samples = 2;
        fb.samples = 3;
        fill_pattern(&fa, 1);
        fill_pattern(&fb, 2);
        pm_display d = display_all();
        pm_view_upload(a, &fa);
        pm_view_upload(b, &fb);
        compare_film(a, &fa, &d, "first of two views");
        compare_film(b, &fb, &d, "second of two views");
        pm_film_free(&fa);
        pm_film_free(&fb);
    }
    pm_view_destroy(a);
    pm_view_destroy(b);
}

/* A film of another size than the view's: the view follows the film. */
static void test_resize(void) {
    pm_view *v = offscreen(8, 4);
    if (!v) return;
    bool comps[PM_COMPONENT_COUNT] = {true, false, false, false};
    pm_film f;
    CHECK(pm_film_init(&f, 11, 6, comps), "film");
    f.samples = 1;
    fill_pattern(&f, 3);
    pm_display d = display_all();
    compare_film(v, &f, &d, "film larger than the view");
    pm_film_free(&f);
    pm_view_destroy(v);
}

int main(void) {
    pm_view_destroy(NULL);
    char err[256] = "";
    CHECK(pm_view_create_offscreen(0, 4, err, sizeof err) == NULL && err[0], "a 0x4 view must fail with a message");
    pm_view_events ev = pm_view_poll(NULL, NULL, false, 0);
    CHECK(!ev.quit && !ev.save_png && !ev.display_changed, "poll without a view");

    test_composition();
    test_tonemap();
    test_bad_values();
    test_absent_and_empty();
    test_orientation();
    test_sizes();
    test_two_views();
    test_resize();

    pm_view *v = offscreen(2, 2);
    if (v) {
        pm_display d = display_all();
        ev = pm_view_poll(v, &d, true, 0.01);
        CHECK(!ev.quit && !ev.save_png && !ev.display_changed, "an offscreen view has no events");
        pm_view_destroy(v);
    }
    return pm_test_done("test_view");
}

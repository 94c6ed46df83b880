/* caustic_error.c: compares a pmview EXR of a point-light caustic with a reference's R,G,B over the floor in full shadow (tests/caustic_region.h).
 *
 *     ./pmview scenes/caustic.gltf --snapshot /tmp/c.exr --width 64 --height 64 --time 60
 *     build/rel/caustic_error /tmp/c.exr tests/ref/caustic_ptracer_64.exr
 *
 * An image F times the reference's size is averaged over FxF blocks first (with a box pixel
 * filter that is exactly the smaller image), so a 320x320 render compares with a 64x64 reference.
 *
 * Prints `stat caustic_error pixels=N ratio=R focus_ratio=F caustic_share=S relmse=E` (ratio: our
 * sum over the region without the focus divided by the reference's; relmse over the same pixels). Exit 1 when a file cannot be read.
 */
#include <stdio.h>
#include <stdlib.h>

#include "caustic_region.h"
#include "image_io.h"

/* Interleaves a layer's three channels; a layer the file lacks (a component the scene rules out) is zero. */
static float *read_rgb(const char *path, const char *layer, int *w, int *h, bool required) {
    static const char *const suffix[3] = {"R", "G", "B"};
    float *planes[3] = {NULL, NULL, NULL}, *rgb = NULL;
    char name[64], err[512];
    for (int c = 0; c < 3; c++) {
        snprintf(name, sizeof name, "%s%s%s", layer, *layer ? "." : "", suffix[c]);
        planes[c] = pm_read_exr_channel(path, name, w, h, err, sizeof err);
        if (!planes[c]) {
            if (required) fprintf(stderr, "caustic_error: %s\n", err);
            break;
        }
    }
    if (planes[2] || !required) {
        size_t n = (size_t)*w * *h;
        rgb = calloc(3 * n, sizeof(float));
        for (size_t i = 0; planes[2] && i < n; i++)
            for (int c = 0; c < 3; c++) rgb[3 * i + c] = planes[c][i];
    }
    for (int c = 0; c < 3; c++) free(planes[c]);
    return rgb;
}

int main(int argc, char **argv) {
    if (argc != 3) { fprintf(stderr, "usage: caustic_error OURS.exr REFERENCE.exr\n"); return 2; }
    int w = 0, h = 0, rw = 0, rh = 0;
    float *total = read_rgb(argv[1], "", &w, &h, true);
    if (!total) return 1;
    float *direct = read_rgb(argv[1], "direct", &w, &h, false), *specular = read_rgb(argv[1], "specular", &w, &h, false);
    float *caustic = read_rgb(argv[1], "caustic", &w, &h, false), *ref[3] = {NULL, NULL, NULL};
    static const char *const rgb_names[3] = {"R", "G", "B"};
    char err[512];
    bool have_ref = true;
    for (int c = 0; c < 3 && have_ref; c++) {
        ref[c] = pm_read_exr_channel(argv[2], rgb_names[c], &rw, &rh, err, sizeof err);
        if (!ref[c]) { fprintf(stderr, "caustic_error: %s\n", err); have_ref = false; }
    }
    int rc = 1;
    int f = rw > 0 && w % rw == 0 && h % rh == 0 && w / rw == h / rh ? w / rw : 1;
    if (have_ref && f > 1) {
        float **layers[4] = {&total, &direct, &specular, &caustic};
        for (int l = 0; l < 4; l++) {
            float *small = calloc(3 * (size_t)rw * rh, sizeof(float));
            for (int y = 0; y < h; y++)
                for (int x = 0; x < w; x++)
                    for (int c = 0; c < 3; c++)
                        small[3 * ((size_t)(y / f) * rw + x / f) + c] += (*layers[l])[3 * ((size_t)y * w + x) + c] / (float)(f * f);
            free(*layers[l]);
            *layers[l] = small;
        }
        w = rw;
        h = rh;
    }
    if (have_ref && (rw != w || rh != h)) {
        fprintf(stderr, "caustic_error: %s is %dx%d but %s is %dx%d\n", argv[1], w, h, argv[2], rw, rh);
    } else if (have_ref) {
        const float *const ref_planes[3] = {ref[0], ref[1], ref[2]};
        caustic_region m = caustic_region_measure(w, h, total, direct, specular, caustic, ref_planes);
        printf("stat caustic_error pixels=%zu ratio=%.4f focus_ratio=%.4f caustic_share=%.4f relmse=%.6f\n", m.pixels,
               m.ref > 0 ? m.ours / m.ref : 0.0, m.focus_ref > 0 ? m.focus_ours / m.focus_ref : 0.0,
               m.ours > 0 ? m.caustic / m.ours : 0.0, m.relmse);
        rc = 0;
    }
    free(total);
    free(direct);
    free(specular);
    free(caustic);
    for (int c = 0; c < 3; c++) free(ref[c]);
    return rc;
}

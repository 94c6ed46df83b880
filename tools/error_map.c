/* error_map.c: an EXR render and its reference as two PNGs for docs/convergence.md: the image (as the display shows it) and a false-colour map of the per-pixel error.
 *
 *   error_map IMAGE.exr REF.exr IMAGE.png ERROR.png [SCALE [EV]]   prints "relmse=X" (the image's, as pmview's)
 *   error_map --image IMAGE.exr IMAGE.png [SCALE [EV]]             the image alone (e.g. the reference)
 *   error_map --colorbar BAR.png                               the legend of the false colours
 *
 * The image is the total's R, G, B times 2^EV (default 0), clamped to 0..1 and sRGB-encoded:
 * the display's clamp tonemap at that exposure (pmview --exposure EV). The error of a pixel is its share of relMSE, the mean over its
 * channels of (x - r)^2 / (r^2 + 0.01), the measure `stat error` and --log report, drawn on a
 * log scale from 1e-4 (dark blue) to 1 and above (white) so that noise and bias of very
 * different sizes stay visible side by side. A pixel the reference leaves unknown (NaN, as
 * pmview --reference skips it) is grey and left out of the mean. SCALE enlarges each pixel to SCALE x SCALE.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "image_io.h"

#define ERROR_LOG10_MIN (-4.0)
#define ERROR_LOG10_MAX 0.0

typedef struct {
    float *rgb[3];
    int width, height;
} rgb_image;

static void free_image(rgb_image *im) {
    for (int c = 0; c < 3; c++) free(im->rgb[c]);
}

static int read_image(const char *path, rgb_image *im) {
    static const char *const names[3] = {"R", "G", "B"};
    memset(im, 0, sizeof *im);
    for (int c = 0; c < 3; c++) {
        char err[512];
        int w, h;
        im->rgb[c] = pm_read_exr_channel(path, names[c], &w, &h, err, sizeof err);
        if (!im->rgb[c]) {
            fprintf(stderr, "error_map: error: %s\n", err);
            free_image(im);
            return 0;
        }
        im->width = w;
        im->height = h;
    }
    return 1;
}

static uint8_t srgb_byte(double x) {
    x = x < 0 ? 0 : x > 1 ? 1 : x;
    double s = x < 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055;
    return (uint8_t)lround(s * 255.0);
}

/* A perceptually ordered ramp (dark blue, blue, cyan, green, yellow, red, white) at t in 0..1. */
static void ramp(double t, uint8_t out[3]) {
    static const double stops[7][3] = {{0.02, 0.02, 0.25}, {0.1, 0.25, 0.8}, {0.0, 0.7, 0.85}, {0.2, 0.75, 0.2},
                                       {0.95, 0.9, 0.1}, {0.9, 0.15, 0.1}, {1.0, 1.0, 1.0}};
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    double x = t * 6.0;
    int i = x >= 6.0 ? 5 : (int)x;
    double f = x - i;
    for (int c = 0; c < 3; c++) out[c] = (uint8_t)lround(255.0 * (stops[i][c] * (1 - f) + stops[i + 1][c] * f));
}

static int write_scaled(const char *path, int width, int height, const uint8_t *rgb, int scale) {
    int ow = width * scale, oh = height * scale;
    uint8_t *rgba = malloc((size_t)ow * oh * 4);
    if (!rgba) {
        fprintf(stderr, "error_map: error: %s: out of memory\n", path);
        return 0;
    }
    for (int y = 0; y < oh; y++)
        for (int x = 0; x < ow; x++) {
            const uint8_t *p = rgb + ((size_t)(y / scale) * width + x / scale) * 3;
            uint8_t *o = rgba + ((size_t)y * ow + x) * 4;
            o[0] = p[0], o[1] = p[1], o[2] = p[2], o[3] = 255;
        }
    char err[512];
    int ok = pm_write_png(path, ow, oh, rgba, err, sizeof err);
    if (!ok) fprintf(stderr, "error_map: error: %s\n", err);
    free(rgba);
    return ok;
}

static int write_display(const rgb_image *im, const char *path, int scale, double gain) {
    size_t n = (size_t)im->width * im->height;
    uint8_t *rgb = malloc(n * 3);
    if (!rgb) {
        fprintf(stderr, "error_map: error: %s: out of memory\n", path);
        return 0;
    }
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) {
            float v = im->rgb[c][i];
            rgb[i * 3 + c] = isfinite(v) ? srgb_byte(gain * v) : 128; /* a reference's unknown pixels: grey */
        }
    int ok = write_scaled(path, im->width, im->height, rgb, scale);
    free(rgb);
    return ok;
}

static int write_colorbar(const char *path) {
    enum { W = 256, H = 12 };
    static uint8_t rgb[W * H * 3];
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) ramp((x + 0.5) / W, rgb + ((size_t)y * W + x) * 3);
    return write_scaled(path, W, H, rgb, 1);
}

static int parse_scale(const char *s) {
    int v = atoi(s);
    return v >= 1 && v <= 16 ? v : 0;
}

/* 2^EV for an exposure in stops within +-20, else 0 (a usage error) */
static double parse_gain(const char *s) {
    char *end;
    double ev = strtod(s, &end);
    return end != s && !*end && ev >= -20 && ev <= 20 ? exp2(ev) : 0.0;
}

int main(int argc, char **argv) {
    if (argc == 3 && !strcmp(argv[1], "--colorbar")) return write_colorbar(argv[2]) ? 0 : 1;
    if (argc >= 4 && argc <= 6 && !strcmp(argv[1], "--image")) {
        int scale = argc >= 5 ? parse_scale(argv[4]) : 1;
        double gain = argc == 6 ? parse_gain(argv[5]) : 1.0;
        rgb_image im;
        if (!scale || !gain) {
            fprintf(stderr, "error_map: error: SCALE must be 1..16 and EV -20..20\n");
            return 2;
        }
        if (!read_image(argv[2], &im)) return 1;
        int ok = write_display(&im, argv[3], scale, gain);
        free_image(&im);
        return ok ? 0 : 1;
    }
    if (argc < 5 || argc > 7) {
        fprintf(stderr, "usage: error_map IMAGE.exr REF.exr IMAGE.png ERROR.png [SCALE [EV]] | --image IMAGE.exr IMAGE.png"
                        " [SCALE [EV]] | --colorbar BAR.png\n");
        return 2;
    }
    int scale = argc >= 6 ? parse_scale(argv[5]) : 1;
    double gain = argc == 7 ? parse_gain(argv[6]) : 1.0;
    if (!scale || !gain) {
        fprintf(stderr, "error_map: error: SCALE must be 1..16 and EV -20..20\n");
        return 2;
    }
    rgb_image im, ref;
    if (!read_image(argv[1], &im)) return 1;
    if (!read_image(argv[2], &ref)) {
        free_image(&im);
        return 1;
    }
    int status = 1;
    uint8_t *err_rgb = NULL;
    if (im.width != ref.width || im.height != ref.height) {
        fprintf(stderr, "error_map: error: %s: %dx%d, the reference %s is %dx%d\n", argv[1], im.width, im.height, argv[2],
                ref.width, ref.height);
        goto done;
    }
    size_t n = (size_t)im.width * im.height;
    err_rgb = malloc(n * 3);
    if (!err_rgb) {
        fprintf(stderr, "error_map: error: out of memory\n");
        goto done;
    }
    double total = 0;
    size_t known = 0;
    for (size_t i = 0; i < n; i++) {
        if (!isfinite(ref.rgb[0][i]) || !isfinite(ref.rgb[1][i]) || !isfinite(ref.rgb[2][i])) {
            memset(err_rgb + i * 3, 128, 3);
            continue;
        }
        known++;
        double e = 0;
        for (int c = 0; c < 3; c++) {
            double d = (double)im.rgb[c][i] - ref.rgb[c][i], r = ref.rgb[c][i];
            e += d * d / (r * r + 0.01);
        }
        total += e;
        e /= 3.0;
        double t = e > 0 ? (log10(e) - ERROR_LOG10_MIN) / (ERROR_LOG10_MAX - ERROR_LOG10_MIN) : 0.0;
        ramp(t, err_rgb + i * 3);
    }
    if (write_display(&im, argv[3], scale, gain) && write_scaled(argv[4], im.width, im.height, err_rgb, scale)) {
        printf("relmse=%g\n", total / (3.0 * (double)(known ? known : 1)));
        status = 0;
    }
done:
    free(err_rgb);
    free_image(&im);
    free_image(&ref);
    return status;
}

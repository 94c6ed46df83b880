/* runlog.c: the per-iteration CSV log of a snapshot (--log) and the error against a reference image (--reference). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "defaults.h"
#include "image_io.h"
#include "memory.h"
#include "progressive.h"
#include "runlog.h"

static const char *const names[3] = {"R", "G", "B"};

bool pm_reference_check(const char *path, int width, int height, char *err, size_t err_size) {
    int w = 0, h = 0;
    if (!pm_read_exr_size(path, 3, names, &w, &h, err, err_size)) return false;
    if (w == width && (height <= 0 || h == height)) return true;
    if (height > 0)
        snprintf(err, err_size, "%s: the reference is %dx%d but the image is %dx%d (use --width/--height)", path, w, h,
                 width, height);
    else
        snprintf(err, err_size, "%s: the reference is %dx%d but the image is %d wide (use --width/--height)", path, w, h,
                 width);
    return false;
}

bool pm_reference_load(const char *path, bool with_layers, pm_reference_image *ref, char *err, size_t err_size) {
    uint64_t mark = pm_memory_failure_mark(); /* what fails in this call, never an older failure */
    memset(ref, 0, sizeof *ref);
    int w = 0, h = 0;
    if (!pm_read_exr_size(path, 3, names, &w, &h, err, err_size)) return false;
    /* R, G, B, each layer's three when asked for, and the mask of unknown pixels */
    uint64_t bytes = (uint64_t)w * (uint64_t)h * ((3 + (with_layers ? 3 * PM_COMPONENT_COUNT : 0)) * sizeof(float) + 1);
    if (!pm_memory_admit(bytes, "reference image")) {
        snprintf(err, err_size, "%s: out of memory (%s)", path, pm_memory_failure_since(mark));
        return false;
    }
    ref->admitted = bytes;
    ref->width = w;
    ref->height = h;
    for (int c = 0; c < 3; c++) {
        int channel_w = 0, channel_h = 0;
        ref->rgb[c] = pm_read_exr_channel(path, names[c], &channel_w, &channel_h, err, err_size);
        if (!ref->rgb[c]) return false;
        /* each channel opens the file again: one replaced in between could give a plane of
         * another size, read below as width x height pixels */
        if (channel_w != w || channel_h != h) {
            snprintf(err, err_size, "%s: channel %s is %dx%d, the image %dx%d", path, names[c], channel_w, channel_h, w, h);
            return false;
        }
    }
    size_t n = (size_t)ref->width * ref->height, known = 0;
    for (size_t i = 0; i < n; i++) {
        bool finite = isfinite(ref->rgb[0][i]) && isfinite(ref->rgb[1][i]) && isfinite(ref->rgb[2][i]);
        if (!finite && !ref->known) {
            ref->known = pm_malloc(n, "reference mask");
            if (!ref->known) { snprintf(err, err_size, "%s: out of memory (%s)", path, pm_memory_failure_since(mark)); return false; }
            memset(ref->known, 1, i);
        }
        if (ref->known) ref->known[i] = finite;
        known += finite;
    }
    if (!known) { snprintf(err, err_size, "%s: no pixel of the reference is finite", path); return false; }
    for (int c = 0; c < PM_COMPONENT_COUNT && with_layers; c++) {
        bool complete = true;
        for (int k = 0; k < 3 && complete; k++) {
            char channel[64], ignored[256];
            int w = 0, h = 0;
            snprintf(channel, sizeof channel, "%s.%s", pm_component_names[c], names[k]);
            ref->layer[c][k] = pm_read_exr_channel(path, channel, &w, &h, ignored, sizeof ignored);
            complete = ref->layer[c][k] && w == ref->width && h == ref->height;
        }
        if (complete) continue;
        for (int k = 0; k < 3; k++) {
            free(ref->layer[c][k]);
            ref->layer[c][k] = NULL;
        }
    }
    return true;
}

void pm_reference_free(pm_reference_image *ref) {
    pm_memory_release(ref->admitted);
    ref->admitted = 0;
    free(ref->known);
    for (int c = 0; c < 3; c++) free(ref->rgb[c]);
    for (int c = 0; c < PM_COMPONENT_COUNT; c++)
        for (int k = 0; k < 3; k++) free(ref->layer[c][k]);
}

double pm_reference_relmse(const pm_film *film, const pm_reference_image *ref, float *scratch, double mean_ratio[3]) {
    pm_film_resolve_total(film, scratch);
    return pm_reference_relmse_total(scratch, ref, mean_ratio);
}

double pm_reference_relmse_total(const float *total, const pm_reference_image *ref, double mean_ratio[3]) {
    const float *const planes[3] = {ref->rgb[0], ref->rgb[1], ref->rgb[2]};
    pm_image_error e = pm_image_compare(total, planes, (size_t)ref->width * ref->height, ref->known);
    for (int c = 0; c < 3; c++) mean_ratio[c] = e.ref[c] != 0 ? e.ours[c] / e.ref[c] : 0.0;
    return e.relmse;
}

/* ---- --log: the run as CSV ---- */

static const char *const log_measures[3] = {"relmse", "rmse", "rel_bias"};

bool pm_log_wanted(uint32_t logged, uint32_t samples) {
    if (samples <= logged) return false;
    if (samples <= PM_LOG_EVERY_ITERATION_UNTIL) return true;
    uint32_t power = 1; /* the largest power of two at or below samples */
    while (power <= samples / 2) power *= 2;
    return logged < power;
}

void pm_log_header(FILE *f) {
    fputs("seconds,iterations,photons,mean_radius", f);
    for (int part = -1; part < PM_COMPONENT_COUNT; part++)
        for (int m = 0; m < 3; m++) fprintf(f, ",%s_%s", part < 0 ? "total" : pm_component_names[part], log_measures[m]);
    fputc('\n', f);
}

/* relMSE (as --reference), RMSE and relative bias (sum of ours over the reference's, minus 1, all
 * pixels and channels) of one image; three empty fields without a reference plane, an empty bias
 * when the reference is black. */
static void log_errors(FILE *f, const float *rgb, float *const planes[3], size_t pixels, const unsigned char *known) {
    if (!rgb || !planes[0]) { fputs(",,,", f); return; }
    pm_image_error e = pm_image_compare(rgb, (const float *const *)planes, pixels, known);
    double ours = e.ours[0] + e.ours[1] + e.ours[2], ref = e.ref[0] + e.ref[1] + e.ref[2];
    fprintf(f, ",%.6g,%.6g,", e.relmse, sqrt(e.mse));
    if (ref != 0) fprintf(f, "%.6g", ours / ref - 1.0);
}

void pm_log_row(FILE *f, pm_session *session, const pm_film *film, uint64_t photons, const pm_reference_image *ref,
                float *scratch, double seconds) {
    pm_progressive *p = pm_session_progressive(session);
    size_t n = (size_t)film->width * film->height;
    fprintf(f, "%.6f,%u,%llu,", seconds, film->samples, (unsigned long long)photons);
    double radius = p ? pm_progressive_radii(p, film).mean : 0.0;
    if (radius > 0) fprintf(f, "%.6g", radius);
    if (scratch) pm_film_resolve_total(film, scratch);
    log_errors(f, scratch, (float *const *)ref->rgb, n, ref->known);
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        if (scratch && ref->layer[c][0]) pm_film_resolve(film, (pm_component)c, scratch);
        log_errors(f, scratch, (float *const *)ref->layer[c], n, ref->known);
    }
    fputc('\n', f);
}

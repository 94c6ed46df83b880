/* runlog.h: the per-iteration CSV log of a snapshot (--log) and the error against a reference image (--reference).
 *
 * The log's columns: seconds, iterations, photons, mean_radius, then relMSE, RMSE and relative
 * bias of the total and of each component layer (empty fields where the reference lacks them).
 */
#ifndef PM_RUNLOG_H
#define PM_RUNLOG_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include "film.h"
#include "session.h"

/* The reference's R, G, B planes, for --reference, and (for --log) the planes of each component
 * layer it has (direct.R, ...; NULL when the file lacks one of the layer's channels). */
/* known: NULL when every pixel is compared, else 1 for the pixels whose R, G and B are finite (a
 * reference marks the pixels it cannot vouch for NaN; they are left out of every measure) */
typedef struct {
    float *rgb[3];
    float *layer[PM_COMPONENT_COUNT][3];
    unsigned char *known;
    int width, height;
    uint64_t admitted; /* bytes admitted against --max-memory (memory.h), given back by pm_reference_free */
} pm_reference_image;

/* From the header alone (no pixel decoded), before the scene is loaded and the image rendered:
 * whether path is an EXR with R, G, B of the image's size; height 0 when the image's height is not
 * known yet (it comes from the scene's camera), then only the width is compared. */
bool pm_reference_check(const char *path, int width, int height, char *err, size_t err_size);
/* False with err set when the file cannot be read, memory runs out (the estimate from the header
 * is refused above the memory limit before any pixel is decoded) or no pixel is finite; the
 * caller frees ref with pm_reference_free either way. */
bool pm_reference_load(const char *path, bool with_layers, pm_reference_image *ref, char *err, size_t err_size);
void pm_reference_free(pm_reference_image *ref);
/* relMSE = mean over pixels and channels of (x - r)^2 / (r^2 + 0.01) (the 0.01 keeps black
 * pixels from dominating), and each channel's mean over the reference's mean. scratch: 3 floats
 * a pixel. */
double pm_reference_relmse(const pm_film *film, const pm_reference_image *ref, float *scratch, double mean_ratio[3]);
/* The same for a total already resolved (RGB, 3 floats a pixel, the reference's size): the window's. */
double pm_reference_relmse_total(const float *total, const pm_reference_image *ref, double mean_ratio[3]);

/* Whether the film's sample count gets a row, the last row having been at `logged`: every count up
 * to PM_LOG_EVERY_ITERATION_UNTIL, then the first count at or past each power of two (a
 * progressive iteration may add several samples). */
bool pm_log_wanted(uint32_t logged, uint32_t samples);
void pm_log_header(FILE *f);
/* --log - writes the rows to standard output. */
static inline bool pm_log_to_stdout(const char *path) { return path && path[0] == '-' && path[1] == '\0'; }
/* One row: `film` (the session's, or a cluster's merged one) as it is after `seconds` of rendering,
 * `photons` emitted so far; the session gives the radii's mode state. scratch: 3 floats a pixel, or
 * NULL without a reference. */
void pm_log_row(FILE *f, pm_session *session, const pm_film *film, uint64_t photons, const pm_reference_image *ref,
                float *scratch, double seconds);

#endif

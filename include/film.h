/* film.h: per-component radiance accumulation (direct, specular, caustic, indirect), and the progressive photon statistics.
 *
 * A component the scene analysis rules out gets no buffer at all (sum[c] == NULL): it is
 * black by construction and costs no memory. The film stores sums of samples, each a float and
 * the bits below it (a window runs to 10^5 samples a pixel, where a plain float sum has lost the
 * low digits of every sample it adds: 10^6 samples of 0.1 summed in float come out 1% off);
 * every pixel holds the same sample count, except after a pass cut short (a deadline, a cancel), which
 * reached only some pixels: those hold one sample more, and the resolve divides each pixel by
 * its own count, so neither kind of pixel is biased. The progressive mode adds per-pixel photon
 * statistics (slots, each allocated only when the scene can use it). Everything that reads an
 * image, the view, the EXR writer, the error measures, goes through pm_film_resolve(): nothing
 * else knows how a mode accumulates. Per pixel the film holds 18 bytes a component, 20 a
 * statistics slot and one for the ahead bits: the copy a cancel puts back exists only while an
 * iteration that can be cancelled runs (pm_film_open_copy).
 */
#ifndef PM_FILM_H
#define PM_FILM_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "scene.h"

/* Stochastic progressive photon mapping statistics of one estimate at one pixel (Hachisuka and
 * Jensen 2009): photon count N, the flux tau gathered so far (already rescaled to the current
 * radius) and the squared radius; r2 == 0 until the pixel's first visible point. Floats, each
 * update computed in double and rounded once: an update rescales tau and N rather than adding a
 * small part to a large sum, so the rounding of 10^4 updates stays a random walk of relative
 * size 10^-5, far below the photons' noise (r2 is a float in the photon grid's queries anyway). */
typedef struct { float tau[3]; float n; float r2; } pm_ppm_stat;

/* Which photons and which visible points a slot gathers: caustic (L S+ D) or other indirect
 * photons, at a visible point seen directly or through specular bounces. */
typedef enum {
    PM_SLOT_CAUSTIC = 0,           /* caustic photons, first-hit visible point -> caustic */
    PM_SLOT_INDIRECT = 1,          /* indirect photons, first-hit visible point -> indirect */
    PM_SLOT_SPECULAR_CAUSTIC = 2,  /* caustic photons, visible point behind specular bounces -> specular */
    PM_SLOT_SPECULAR_INDIRECT = 3, /* indirect photons, visible point behind specular bounces -> specular */
    PM_SLOT_COUNT = 4
} pm_ppm_slot;
extern const pm_component pm_slot_component[PM_SLOT_COUNT];

/* What a pixel a cut pass reached holds beyond the film's counts (bits of pm_film.ahead). */
enum { PM_FILM_AHEAD_SAMPLE = 1, PM_FILM_AHEAD_PHOTON_PASS = 2 };

typedef struct {
    int width, height;
    float *sum[PM_COMPONENT_COUNT]; /* 3*width*height floats each, row 0 = top; NULL = always black */
    /* the bits of each sum below its float, in units of 2^-16 of the float's last place (the
     * true sum is sum + low * ulp(sum) / 65536: 40 significant bits, so 10^6 samples of a
     * constant drift less than 10^-6): NULL in a film made by hand, whose sums are taken as exact */
    int16_t *low[PM_COMPONENT_COUNT];
    uint32_t samples;               /* samples every pixel holds (eye passes that reached every pixel) */
    uint32_t photon_passes;         /* the progressive mode's photon passes every pixel's statistics hold: what they divide by */
    pm_ppm_stat *ppm[PM_SLOT_COUNT];/* width*height each, or NULL: the progressive mode's photon statistics */
    uint64_t admitted;              /* bytes admitted against --max-memory for the buffers, given back by pm_film_free */
    /* width*height PM_FILM_AHEAD_* bits (NULL in a film made by hand: never ragged): a pixel the
     * cut pass reached holds one sample more than `samples`, and one photon pass more than
     * `photon_passes` when the cut pass updated its statistics */
    uint8_t *ahead;
    bool ragged;                    /* a pass was cut: the end of a run, to be read or cleared, never passed over again */
    /* the running iteration's starting state of the pixels it has written (pm_film_save_rect),
     * for a cancel to put back: the same layout as sum, low and ppm, allocated only between
     * pm_film_open_copy and pm_film_close_copy (NULL otherwise) */
    float *saved_sum[PM_COMPONENT_COUNT];
    int16_t *saved_low[PM_COMPONENT_COUNT];
    pm_ppm_stat *saved_ppm[PM_SLOT_COUNT];
    bool copy_open;
    uint64_t copy_admitted;         /* bytes admitted for that copy while open, given back by pm_film_close_copy */
    uint64_t copy_reserved;         /* bytes admitted ahead for every copy (pm_film_reserve_copy), given back by pm_film_free */
} pm_film;

bool pm_film_init(pm_film *f, int width, int height, const bool component_enabled[PM_COMPONENT_COUNT]);
/* Adds the progressive statistics slots that are enabled (their components must be enabled). */
bool pm_film_enable_ppm(pm_film *f, const bool slot_enabled[PM_SLOT_COUNT]);
void pm_film_free(pm_film *f);
void pm_film_clear(pm_film *f);
/* The copy a cancel puts back, held only while an iteration that can be cancelled runs: opened
 * (allocated, admitted against --max-memory) before it, closed (freed) after it. False, with the
 * failure recorded in memory.c, when it does not fit; true at once when already open. */
bool pm_film_open_copy(pm_film *f);
void pm_film_close_copy(pm_film *f);
/* Admits the copy's bytes once, ahead, for a film that will run cancellable iterations (a session's):
 * running out of room is then the film's set-up error, before any rendering, and opening the copy
 * admits nothing more. False, with the refusal recorded, when they do not fit. */
bool pm_film_reserve_copy(pm_film *f);
/* Bytes that copy takes while open (what an iteration holds beside the film). */
size_t pm_film_copy_bytes(const pm_film *f);
/* Copies the pixels [x0, x1) x [y0, y1) (sums, their low bits, statistics) into the open copy
 * before an iteration first writes them, and puts them back after a cancel: the film is then
 * exactly as before the iteration. Disjoint rectangles may be saved or restored from several
 * threads at once. Nothing happens without an open copy. The counts (samples, photon_passes)
 * are the caller's to put back. */
void pm_film_save_rect(pm_film *f, int x0, int y0, int x1, int y1);
void pm_film_restore_rect(pm_film *f, int x0, int y0, int x1, int y1);
/* Whether the copy is open, so a cancel can be taken back. */
bool pm_film_can_restore(const pm_film *f);
/* A pass cut short reached the pixels [x0, x1) x [y0, y1): they hold `what` (PM_FILM_AHEAD_*)
 * beyond the film's counts, and the film is ragged. */
void pm_film_mark_ahead(pm_film *f, int x0, int y0, int x1, int y1, unsigned what);
/* The samples pixel i holds (samples, or one more where a cut pass reached it). */
uint32_t pm_film_samples_at(const pm_film *f, size_t pixel);
/* How many pixels hold a sample more than f->samples (0 unless a pass was cut). */
size_t pm_film_pixels_ahead(const pm_film *f);
/* Radiance of one component into out (3*w*h floats): the mean of its samples plus, in the
 * progressive mode, tau / (pi r^2 photon passes) of each slot that feeds it, each pixel by its
 * own counts; zeros for an absent component and where a pixel holds nothing yet. The one way an
 * image leaves the film. */
void pm_film_resolve(const pm_film *f, pm_component c, float *out);
/* Statistics slot k's estimate folded into its component's sums, as if each of a pixel's samples
 * had carried it, and the slot cleared: every pixel reads the same (to rounding), and from then on
 * only samples add to it. For a run that stops gathering that slot's photons (the progressive
 * mode's caustic trial). */
void pm_film_fold_statistics(pm_film *f, pm_ppm_slot k);
/* The sum of all components into out (3*w*h floats). It allocates nothing, so it cannot fail: the
 * true it returns is for callers written when it could. */
bool pm_film_resolve_total(const pm_film *f, float *out);
/* Bytes the film's buffers hold: per pixel, 18 a component (sums and their low bits), 20 a
 * statistics slot and the ahead byte (the copy a cancel restores is pm_film_copy_bytes, apart). */
size_t pm_film_bytes(const pm_film *f);
/* Adds radiance v to a pixel's sum of component c (which must be enabled), to 40 bits. False,
 * and nothing added, when v or the new sum is not finite: a NaN from a degenerate case must not
 * poison a pixel forever, nor a finite sample overflow it, so the film never holds an Inf
 * (callers count these as dropped samples). */
bool pm_film_add(pm_film *f, pm_component c, size_t pixel, vec3 v);
/* Channel k of the sum of samples at element i (3 * pixel + channel) of component c, in double
 * (the float and its low bits). The component must be enabled. */
double pm_film_sum_at(const pm_film *f, pm_component c, size_t i);

/* ---- the additive form: what the ranks of a cluster sum (cluster.h) ----
 * A film as doubles that add: two films' forms summed element by element, then unpacked, resolve
 * to the mean of every sample both hold and of every photon pass both made, each pixel weighed by
 * its own counts (a pixel's photon estimate is the mean of its passes' estimates, tau / R^2 summed
 * over passes: Hachisuka and Jensen's rescaled tau makes sum_passes Phi_i / (pi R_i^2) equal
 * tau / (pi R^2)). Layout: 2 header values (the samples and photon passes every pixel holds), then
 * per pixel its sample count, each enabled component's 3 sums, and per enabled statistics slot its
 * photon passes, 3 of tau / R^2, the photon count N, R^2 and 1 where R^2 is set (to average R). */
size_t pm_film_packed_count(const pm_film *f);
void pm_film_pack(const pm_film *f, double *out);
/* Makes f (built with the same components and slots as the packed films) hold what a summed form
 * describes: not ragged, every pixel's sums rescaled to the uniform counts, R^2 the mean of the
 * films that had one. */
void pm_film_unpack(pm_film *f, const double *in);

/* An image against a reference: relMSE = mean over pixels (those with mask[i] != 0, or all when
 * mask is NULL) and channels of (x - r)^2 / (r^2 + 0.01), and each channel's sums, whose ratio is
 * the mean ratio. rgb is interleaved, ref planar. The one definition --reference and the tests use. */
typedef struct {
    double relmse;
    double mse;             /* mean over the same pixels and channels of (x - r)^2 */
    double ours[3], ref[3];
    size_t pixels;
} pm_image_error;
pm_image_error pm_image_compare(const float *rgb, const float *const ref[3], size_t pixels, const unsigned char *mask);

#endif

/* fuzz_inputs_entry.h: one fuzz input through the file readers and writers besides glTF (a sky map, a reference, the EXR and PNG writers and the log's measures), shared by the libFuzzer target and the regression replay.
 *
 * The first byte picks the entry, the rest is the payload:
 *   0  a sky map as .exr: read as --sky reads it (pm_sky_prepare), sampled;
 *   1  the same as .hdr (Radiance RGBE);
 *   2  a reference as .exr with its layers (pm_reference_load, what --reference and --log read),
 *      measured against a grey film of its size;
 *   3  a film of fuzzed floats (NaN, Inf, huge and negative included): written as EXR, read back as
 *      a reference and measured as --log measures, and fuzzed bytes written as PNG.
 * The readers take paths, so a payload is written to a temporary file named with the extension the
 * reader dispatches on; the files are removed after each input. The memory limit is set to
 * PM_FUZZ_INPUT_MEMORY, as --max-memory would: a header that claims a huge image must be refused
 * from its header, before anything that size is allocated or decoded. A refused input is a normal
 * outcome; what counts is that nothing crashes, overflows, leaks or runs away.
 */
#ifndef PM_FUZZ_INPUTS_ENTRY_H
#define PM_FUZZ_INPUTS_ENTRY_H

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "film.h"
#include "image_io.h"
#include "memory.h"
#include "runlog.h"
#include "sky.h"
#include "sky_choice.h"

enum { PM_FUZZ_INPUT_SKY_EXR = 0, PM_FUZZ_INPUT_SKY_HDR = 1, PM_FUZZ_INPUT_REFERENCE = 2, PM_FUZZ_INPUT_WRITERS = 3,
       PM_FUZZ_INPUT_KINDS = 4 };
enum { PM_FUZZ_INPUT_MAX_SIDE = 16 };
#define PM_FUZZ_INPUT_MEMORY (256ull << 20)

/* What an input did: the replay test reports it. */
typedef struct {
    int kind;
    bool accepted;        /* the reader took the file (or the writers wrote it) */
    char error[512];
} pm_fuzz_input_result;

static bool pm_fuzz_write_file(const char *path, const uint8_t *data, size_t size) {
    FILE *f = fopen(path, "wb");
    if (!f) return false;
    bool ok = fwrite(data, 1, size, f) == size;
    return fclose(f) == 0 && ok;
}

static void pm_fuzz_temp_path(char *path, size_t size, const char *ext) {
    const char *dir = getenv("TMPDIR");
    snprintf(path, size, "%s/pmview-fuzz-%ld%s", dir && *dir ? dir : "/tmp", (long)getpid(), ext);
}

static void pm_fuzz_sky(const char *path, pm_fuzz_input_result *r) {
    /* as a run reads --sky: the checks and the memory estimate from the header come first; the
     * refusal is printed as the run's one error line */
    pm_sky_request request;
    memset(&request, 0, sizeof request);
    request.sky = path;
    request.scene_path = "fuzz-input.gltf";
    request.quiet = true;
    if (!pm_sky_prepare(&request) || !request.map) {
        snprintf(r->error, sizeof r->error, "%s: refused as a sky (the line above)", path);
        pm_sky_release(&request);
        return;
    }
    pm_sky_map *m = request.map;
    r->accepted = true;
    /* every lookup and sample must be finite and its pdf agree with the sampler's */
    for (int i = 0; i < 16; i++) {
        vec3 dir;
        float pdf;
        (void)pm_sky_map_sample(m, (i + 0.5f) / 16.f, (float)((i * 7) % 16 + 0.5f) / 16.f, &dir, &pdf);
        (void)pm_sky_map_radiance(m, dir);
        (void)pm_sky_map_pdf(m, dir);
    }
    pm_sky_release(&request);
}

static void pm_fuzz_reference(const char *path, pm_fuzz_input_result *r) {
    pm_reference_image ref;
    memset(&ref, 0, sizeof ref);
    if (pm_reference_load(path, true, &ref, r->error, sizeof r->error) && ref.width > 0 && ref.height > 0 &&
        (size_t)ref.width * ref.height <= 1u << 20) {
        r->accepted = true;
        bool on[PM_COMPONENT_COUNT];
        for (int c = 0; c < PM_COMPONENT_COUNT; c++) on[c] = true;
        pm_film film;
        if (pm_film_init(&film, ref.width, ref.height, on)) {
            film.samples = 1;
            for (int c = 0; c < PM_COMPONENT_COUNT; c++)
                for (size_t i = 0; i < 3 * (size_t)ref.width * ref.height; i++) film.sum[c][i] = 0.25f;
            float *scratch = malloc(sizeof(float) * 3 * (size_t)ref.width * ref.height);
            double ratio[3];
            if (scratch) (void)pm_reference_relmse(&film, &ref, scratch, ratio);
            free(scratch);
            pm_film_free(&film);
        }
    }
    pm_reference_free(&ref);
}

static void pm_fuzz_writers(const uint8_t *data, size_t size, pm_fuzz_input_result *r) {
    if (size < 3) return;
    int w = 1 + data[0] % PM_FUZZ_INPUT_MAX_SIDE, h = 1 + data[1] % PM_FUZZ_INPUT_MAX_SIDE;
    bool on[PM_COMPONENT_COUNT];
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) on[c] = (data[2] >> c) & 1u;
    data += 3;
    size -= 3;
    pm_film film;
    if (!pm_film_init(&film, w, h, on)) return;
    film.samples = 1;
    /* the sums cycle through the payload's floats, NaN, Inf and denormals as they come */
    size_t k = 0;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++)
        for (size_t i = 0; film.sum[c] && i < 3 * (size_t)w * h; i++, k += 4) {
            uint8_t b[4] = {0, 0, 0, 0};
            for (int j = 0; j < 4 && size; j++) b[j] = data[(k + j) % size];
            memcpy(&film.sum[c][i], b, 4);
        }
    char exr[256], png[256];
    pm_fuzz_temp_path(exr, sizeof exr, ".exr");
    pm_fuzz_temp_path(png, sizeof png, ".png");
    if (pm_write_exr(exr, &film, r->error, sizeof r->error)) {
        r->accepted = true;
        pm_reference_image ref;
        memset(&ref, 0, sizeof ref);
        if (pm_reference_load(exr, true, &ref, r->error, sizeof r->error)) {
            float *scratch = malloc(sizeof(float) * 3 * (size_t)w * h);
            double ratio[3];
            if (scratch) (void)pm_reference_relmse(&film, &ref, scratch, ratio);
            free(scratch);
        }
        pm_reference_free(&ref);
    }
    uint8_t *rgba = malloc(4 * (size_t)w * h);
    if (rgba) {
        for (size_t i = 0; i < 4 * (size_t)w * h; i++) rgba[i] = size ? data[i % size] : 0;
        pm_write_png(png, w, h, rgba, r->error, sizeof r->error);
        free(rgba);
    }
    unlink(exr);
    unlink(png);
    pm_film_free(&film);
}

static pm_fuzz_input_result pm_fuzz_inputs_run(const uint8_t *data, size_t size) {
    pm_fuzz_input_result r;
    memset(&r, 0, sizeof r);
    if (!size) return r;
    pm_memory_set_limit(PM_FUZZ_INPUT_MEMORY);
    r.kind = data[0] % PM_FUZZ_INPUT_KINDS;
    data++;
    size--;
    if (r.kind == PM_FUZZ_INPUT_WRITERS) {
        pm_fuzz_writers(data, size, &r);
        return r;
    }
    char path[256];
    pm_fuzz_temp_path(path, sizeof path, r.kind == PM_FUZZ_INPUT_SKY_HDR ? ".hdr" : ".exr");
    if (!pm_fuzz_write_file(path, data, size)) {
        snprintf(r.error, sizeof r.error, "%s: cannot write the temporary file", path);
        return r;
    }
    if (r.kind == PM_FUZZ_INPUT_REFERENCE) pm_fuzz_reference(path, &r);
    else pm_fuzz_sky(path, &r);
    unlink(path);
    return r;
}

#endif

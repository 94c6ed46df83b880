/* test_image_io.c: EXR layers round-trip bit for bit and sum to the total; environment maps (.exr, .hdr) decode exactly; EXR, .hdr and PNG failures are clean one-line errors; writers stay within --max-memory and never replace what they may not. */
#include "image_io.h"
#include "memory.h"
#include "testing.h"

#include <openexr.h>
#include <stb/stb_image.h>
#include <dirent.h>
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#define W 37
#define H 23

static char tmp_dir_path[128];

static const char *tmp_path(char *buf, size_t size, const char *name) {
    snprintf(buf, size, "%s/%s", tmp_dir_path, name);
    return buf;
}

static bool file_exists(const char *path) {
    struct stat st;
    return stat(path, &st) == 0;
}

static bool same_bits(float a, float b) { return memcmp(&a, &b, sizeof a) == 0; }

static bool write_bytes(const char *path, const void *data, size_t n) {
    FILE *f = fopen(path, "wb");
    if (!f) return false;
    bool ok = fwrite(data, 1, n, f) == n;
    return fclose(f) == 0 && ok;
}

static uint8_t *read_bytes(const char *path, size_t *n) {
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    uint8_t *buf = NULL;
    if (fseek(f, 0, SEEK_END) == 0) {
        long len = ftell(f);
        if (len >= 0 && fseek(f, 0, SEEK_SET) == 0 && (buf = malloc((size_t)len + 1)) != NULL) {
            *n = fread(buf, 1, (size_t)len, f);
            if (*n != (size_t)len) { free(buf); buf = NULL; }
        }
    }
    fclose(f);
    return buf;
}

/* A film whose values stress the float path: signed zeros, tiny, huge, subnormal and negative
 * values, with the caustic component absent (NULL) as the scene analysis would leave it. */
static void make_film(pm_film *film) {
    const bool enabled[PM_COMPONENT_COUNT] = {true, true, false, true};
    bool ok = pm_film_init(film, W, H, enabled);
    CHECK(ok, "film init");
    if (!ok) exit(1);
    film->samples = 3;
    const float special[] = {-0.0f, 0.0f, 1e-30f, 1e30f, -1e30f, 1e-40f, -2.5f, 0.1f, 3.0f, 65504.f, 1e-7f};
    const int nspecial = (int)(sizeof special / sizeof special[0]);
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        if (!film->sum[c]) continue;
        for (int i = 0; i < 3 * W * H; i++) {
            int pixel = i / 3, y = pixel / W, x = pixel % W;
            if ((i + 7 * c) % 5 == 0) film->sum[c][i] = special[(i / 5 + c) % nspecial];
            else film->sum[c][i] = 0.001f * (float)(x + 1) * (float)(c + 1) + 0.37f * (float)y + 0.01f * (float)(i % 3);
        }
    }
    /* a pixel where every present layer is -0: the total must still be a zero */
    for (int c = 0; c < PM_COMPONENT_COUNT; c++)
        if (film->sum[c]) film->sum[c][3 * (5 * W + 6)] = -0.0f;
}

static const char *const rgb[3] = {"R", "G", "B"};

static void test_exr_round_trip(void) {
    char path[256], err[512];
    tmp_path(path, sizeof path, "film.exr");
    pm_film film;
    make_film(&film);
    bool ok = pm_write_exr(path, &film, err, sizeof err);
    CHECK(ok, "write %s: %s", path, err);
    if (!ok) { pm_film_free(&film); return; }

    float *layer = malloc(3 * sizeof(float) * W * H), *total = malloc(3 * sizeof(float) * W * H);
    CHECK(layer && total, "out of memory");
    if (!layer || !total) exit(1);
    pm_film_resolve_total(&film, total);

    float *read[PM_COMPONENT_COUNT][3] = {{NULL}};
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        pm_film_resolve(&film, (pm_component)c, layer);
        for (int k = 0; k < 3; k++) {
            char name[32];
            snprintf(name, sizeof name, "%s.%s", pm_component_names[c], rgb[k]);
            int w = -1, h = -1;
            read[c][k] = pm_read_exr_channel(path, name, &w, &h, err, sizeof err);
            CHECK(read[c][k] != NULL, "read %s: %s", name, err);
            if (!read[c][k]) continue;
            CHECK(w == W && h == H, "%s is %dx%d, want %dx%d", name, w, h, W, H);
            int mismatches = 0, first = -1;
            for (int i = 0; i < W * H; i++)
                if (!same_bits(read[c][k][i], layer[3 * i + k])) { if (first < 0) first = i; mismatches++; }
            CHECK(mismatches == 0, "%s: %d pixels differ bitwise from the film's mean (first at %d: %g vs %g)", name,
                  mismatches, first, first >= 0 ? read[c][k][first] : 0.0, first >= 0 ? layer[3 * first + k] : 0.0);
            if (c == PM_CAUSTIC) {
                int nonzero = 0;
                for (int i = 0; i < W * H; i++) nonzero += read[c][k][i] != 0.f;
                CHECK(nonzero == 0, "absent caustic layer %s must be zeros, %d pixels are not", name, nonzero);
            }
        }
    }
    for (int k = 0; k < 3; k++) {
        int w = -1, h = -1;
        float *t = pm_read_exr_channel(path, rgb[k], &w, &h, err, sizeof err);
        CHECK(t != NULL, "read %s: %s", rgb[k], err);
        if (!t) continue;
        CHECK(w == W && h == H, "%s is %dx%d", rgb[k], w, h);
        int not_sum = 0, not_film_total = 0, first = -1;
        for (int i = 0; i < W * H; i++) {
            bool have_all = true;
            for (int c = 0; c < PM_COMPONENT_COUNT; c++) have_all = have_all && read[c][k];
            if (have_all) {
                float s = read[0][k][i];
                for (int c = 1; c < PM_COMPONENT_COUNT; c++) s += read[c][k][i];
                if (s != t[i]) { if (first < 0) first = i; not_sum++; }
            }
            if (t[i] != total[3 * i + k]) not_film_total++;
        }
        CHECK(not_sum == 0, "%s: %d pixels where the layers read back do not add up exactly to the total (first %d)",
              rgb[k], not_sum, first);
        CHECK(not_film_total == 0, "%s: %d pixels differ from pm_film_resolve_total", rgb[k], not_film_total);
        if (k == 0) {
            /* spot values: the specials reach the file unchanged */
            CHECK(t[5 * W + 6] == 0.f, "all -0 layers give a zero total, got %g", t[5 * W + 6]);
        }
        free(t);
    }
    /* spot checks that the extreme values really were in the file (not flushed or clamped) */
    bool saw_huge = false, saw_tiny = false, saw_negzero = false, saw_subnormal = false;
    for (int c = 0; c < PM_COMPONENT_COUNT; c++)
        for (int k = 0; k < 3; k++)
            for (int i = 0; read[c][k] && i < W * H; i++) {
                float v = read[c][k][i];
                saw_huge |= fabsf(v) > 1e29f;
                saw_tiny |= v > 0.f && v < 1e-29f && v > 1e-31f;
                saw_negzero |= v == 0.f && signbit(v);
                saw_subnormal |= v != 0.f && fabsf(v) < 1e-38f;
            }
    CHECK(saw_huge && saw_tiny && saw_negzero && saw_subnormal,
          "extreme values present in the file: huge %d, 1e-30 %d, -0 %d, subnormal %d", saw_huge, saw_tiny,
          saw_negzero, saw_subnormal);
    for (int c = 0; c < PM_COMPONENT_COUNT; c++)
        for (int k = 0; k < 3; k++) free(read[c][k]);

    /* The file itself: exactly the 15 channels, FLOAT, ZIP, scanline. */
    exr_context_t ctxt = NULL;
    exr_result_t rv = exr_start_read(&ctxt, path, NULL);
    CHECK(rv == EXR_ERR_SUCCESS, "open %s with the OpenEXR core library: %s", path, exr_get_default_error_message(rv));
    if (rv == EXR_ERR_SUCCESS) {
        const exr_attr_chlist_t *chl = NULL;
        exr_compression_t comp = EXR_COMPRESSION_NONE;
        exr_storage_t storage = EXR_STORAGE_TILED;
        CHECK(exr_get_channels(ctxt, 0, &chl) == EXR_ERR_SUCCESS && chl, "channel list");
        CHECK(exr_get_compression(ctxt, 0, &comp) == EXR_ERR_SUCCESS && comp == EXR_COMPRESSION_ZIP,
              "compression is ZIP (got %d)", (int)comp);
        CHECK(exr_get_storage(ctxt, 0, &storage) == EXR_ERR_SUCCESS && storage == EXR_STORAGE_SCANLINE,
              "scanline storage (got %d)", (int)storage);
        if (chl) {
            CHECK(chl->num_channels == 15, "15 channels, got %d", chl->num_channels);
            for (int n = 0; n < 3 + 3 * PM_COMPONENT_COUNT; n++) {
                char name[32];
                if (n < 3) snprintf(name, sizeof name, "%s", rgb[n]);
                else snprintf(name, sizeof name, "%s.%s", pm_component_names[(n - 3) / 3], rgb[(n - 3) % 3]);
                int found = -1;
                for (int i = 0; i < chl->num_channels; i++)
                    if (chl->entries[i].name.str && strcmp(chl->entries[i].name.str, name) == 0) found = i;
                CHECK(found >= 0, "channel %s is in the file", name);
                if (found >= 0)
                    CHECK(chl->entries[found].pixel_type == EXR_PIXEL_FLOAT, "channel %s is FLOAT (type %d)", name,
                          (int)chl->entries[found].pixel_type);
            }
        }
        exr_finish(&ctxt);
    }

    /* A missing channel fails and names the channel and the file. */
    int w = 123, h = 456;
    err[0] = '\0';
    float *none = pm_read_exr_channel(path, "albedo.R", &w, &h, err, sizeof err);
    CHECK(none == NULL, "reading a missing channel must fail");
    free(none);
    CHECK(strstr(err, "albedo.R") != NULL && strncmp(err, path, strlen(path)) == 0,
          "error names the file and the channel: \"%s\"", err);
    CHECK(strchr(err, '\n') == NULL, "one-line error: \"%s\"", err);

    /* Writing again over an existing file replaces it. */
    film.samples = 1;
    CHECK(pm_write_exr(path, &film, err, sizeof err), "rewrite %s: %s", path, err);
    float *d = pm_read_exr_channel(path, "direct.R", &w, &h, err, sizeof err);
    CHECK(d && same_bits(d[1], film.sum[PM_DIRECT][3]), "rewritten file holds the new means");
    free(d);

    /* Truncated: the header survives, the pixels do not. */
    size_t n = 0;
    uint8_t *bytes = read_bytes(path, &n);
    CHECK(bytes && n > 200, "read back %s", path);
    if (bytes && n > 200) {
        char cut[256];
        tmp_path(cut, sizeof cut, "truncated.exr");
        const size_t lengths[] = {n / 2, n - 1, 4, 0};
        for (size_t j = 0; j < sizeof lengths / sizeof lengths[0]; j++) {
            CHECK(write_bytes(cut, bytes, lengths[j]), "write %s", cut);
            err[0] = '\0';
            float *px = pm_read_exr_channel(cut, "R", &w, &h, err, sizeof err);
            CHECK(px == NULL, "a file cut to %zu of %zu bytes must not read", lengths[j], n);
            CHECK(err[0] && strncmp(err, cut, strlen(cut)) == 0 && !strchr(err, '\n'),
                  "one-line error for a truncated file: \"%s\"", err);
            free(px);
        }
        /* header intact, pixel data overwritten with garbage */
        for (size_t i = n / 2; i < n; i++) bytes[i] = (uint8_t)(i * 2654435761u >> 13);
        CHECK(write_bytes(cut, bytes, n), "write %s", cut);
        float *px = pm_read_exr_channel(cut, "R", &w, &h, err, sizeof err);
        CHECK(px == NULL, "a file with garbage chunks must not read");
        free(px);
        unlink(cut);
    }
    free(bytes);

    free(layer);
    free(total);
    pm_film_free(&film);
    unlink(path);
}

static void test_exr_failures(void) {
    char path[256], err[512];
    pm_film film;
    make_film(&film);

    /* a directory that does not exist */
    tmp_path(path, sizeof path, "no-such-dir/out.exr");
    err[0] = '\0';
    CHECK(!pm_write_exr(path, &film, err, sizeof err), "writing into a missing directory must fail");
    CHECK(strncmp(err, path, strlen(path)) == 0 && strlen(err) > strlen(path) + 2 && !strchr(err, '\n'),
          "one-line error naming the file: \"%s\"", err);
    CHECK(!file_exists(path), "nothing left behind");
    /* a tiny error buffer is filled, truncated, and not overrun */
    char small[8];
    memset(small, 'x', sizeof small);
    CHECK(!pm_write_exr(path, &film, small, 5), "still fails");
    CHECK(small[4] == '\0' && small[5] == 'x', "error truncated to the buffer");

    /* missing and garbage input files */
    tmp_path(path, sizeof path, "missing.exr");
    err[0] = '\0';
    int w, h;
    float *px = pm_read_exr_channel(path, "R", &w, &h, err, sizeof err);
    CHECK(px == NULL && strncmp(err, path, strlen(path)) == 0, "missing file: \"%s\"", err);
    free(px);

    tmp_path(path, sizeof path, "garbage.exr");
    uint8_t junk[4096];
    uint32_t state = 12345;
    for (size_t i = 0; i < sizeof junk; i++) { state = state * 1664525u + 1013904223u; junk[i] = (uint8_t)(state >> 24); }
    CHECK(write_bytes(path, junk, sizeof junk), "write %s", path);
    err[0] = '\0';
    px = pm_read_exr_channel(path, "R", &w, &h, err, sizeof err);
    CHECK(px == NULL && strncmp(err, path, strlen(path)) == 0 && !strchr(err, '\n'), "garbage file: \"%s\"", err);
    free(px);
    /* the right magic number and version, garbage after */
    junk[0] = 0x76; junk[1] = 0x2f; junk[2] = 0x31; junk[3] = 0x01;
    junk[4] = 2; junk[5] = 0; junk[6] = 0; junk[7] = 0;
    CHECK(write_bytes(path, junk, sizeof junk), "write %s", path);
    err[0] = '\0';
    px = pm_read_exr_channel(path, "R", &w, &h, err, sizeof err);
    CHECK(px == NULL && err[0], "garbage after a valid magic number: \"%s\"", err);
    free(px);
    unlink(path);

    /* the target is a directory: the write fails naming it, and the temporary file beside it goes
     * (OpenEXR's own stayed, after "Unable to rename temporary file: Success") */
    char folder[256], taken[300];
    tmp_path(folder, sizeof folder, "rename-target");
    snprintf(taken, sizeof taken, "%s/taken.exr", folder);
    mkdir(folder, 0700);
    mkdir(taken, 0700);
    err[0] = '\0';
    CHECK(!pm_write_exr(taken, &film, err, sizeof err), "writing over a directory must fail");
    CHECK(strncmp(err, taken, strlen(taken)) == 0 && strstr(err, "Is a directory") && !strchr(err, '\n'),
          "one line naming the file and the cause: \"%s\"", err);
    DIR *dir = opendir(folder);
    int entries = 0;
    for (struct dirent *e; dir && (e = readdir(dir));)
        if (strcmp(e->d_name, ".") && strcmp(e->d_name, "..")) entries++;
    if (dir) closedir(dir);
    CHECK(entries == 1, "%d entries in the folder: a temporary file was left behind", entries - 1);
    /* the same refused up front by the check main() runs before rendering, and a writable target passes */
    CHECK(!pm_check_output_path(taken, err, sizeof err) && strstr(err, "is a directory"), "check: \"%s\"", err);
    snprintf(taken, sizeof taken, "%s/missing/x.exr", folder);
    CHECK(!pm_check_output_path(taken, err, sizeof err) && strstr(err, "No such file or directory"), "check: \"%s\"", err);
    snprintf(taken, sizeof taken, "%s/new.png", folder);
    CHECK(pm_check_output_path(taken, err, sizeof err) && !file_exists(taken), "a new file in a writable folder: \"%s\"", err);
    snprintf(taken, sizeof taken, "%s/taken.exr", folder);
    rmdir(taken);
    rmdir(folder);

    /* bad arguments */
    CHECK(pm_read_exr_channel("", "R", &w, &h, err, sizeof err) == NULL, "empty path");
    pm_film empty = {0};
    tmp_path(path, sizeof path, "empty.exr");
    CHECK(!pm_write_exr(path, &empty, err, sizeof err) && !file_exists(path), "empty film: \"%s\"", err);
    pm_film_free(&film);
}

/* Files from other writers: HALF channels, an offset data window, several compressions,
 * written here with the core library, as Mitsuba 3 writes R, G, B, A. */
static bool write_half_exr(const char *path, exr_compression_t comp, const exr_attr_box2i_t *dw, int nchan,
                           const float *planes[4]) {
    static const char *const names[4] = {"R", "G", "B", "A"};
    exr_context_t ctxt = NULL;
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    bool started = false, ok = false;
    int part = 0, width = dw->max.x - dw->min.x + 1;
    exr_attr_v2f_t swc = {.x = 0.f, .y = 0.f};
    if (exr_start_write(&ctxt, path, EXR_WRITE_FILE_DIRECTLY, NULL) != EXR_ERR_SUCCESS) return false;
    exr_result_t rv = exr_add_part(ctxt, "beauty", EXR_STORAGE_SCANLINE, &part);
    if (!rv) rv = exr_initialize_required_attr(ctxt, part, dw, dw, 1.f, &swc, 1.f, EXR_LINEORDER_INCREASING_Y, comp);
    for (int c = 0; c < nchan && !rv; c++) rv = exr_add_channel(ctxt, part, names[c], EXR_PIXEL_HALF, EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    if (!rv) rv = exr_write_header(ctxt);
    int32_t lpc = 0;
    if (!rv) rv = exr_get_scanlines_per_chunk(ctxt, part, &lpc);
    for (int y = dw->min.y; !rv && y <= dw->max.y; y += lpc) {
        exr_chunk_info_t cinfo;
        rv = exr_write_scanline_chunk_info(ctxt, part, y, &cinfo);
        if (rv) break;
        rv = started ? exr_encoding_update(ctxt, part, &cinfo, &enc) : exr_encoding_initialize(ctxt, part, &cinfo, &enc);
        started = true;
        for (int i = 0; !rv && i < enc.channel_count; i++) {
            int c = 0;
            while (c < nchan - 1 && strcmp(names[c], enc.channels[i].channel_name)) c++;
            enc.channels[i].user_bytes_per_element = 4;
            enc.channels[i].user_data_type = EXR_PIXEL_FLOAT;
            enc.channels[i].user_pixel_stride = 4;
            enc.channels[i].user_line_stride = 4 * width;
            enc.channels[i].encode_from_ptr = (const uint8_t *)(planes[c] + (size_t)(y - dw->min.y) * width);
        }
        if (!rv) rv = exr_encoding_choose_default_routines(ctxt, part, &enc);
        if (!rv) rv = exr_encoding_run(ctxt, part, &enc);
    }
    ok = rv == EXR_ERR_SUCCESS;
    if (started) exr_encoding_destroy(ctxt, &enc);
    if (exr_finish(&ctxt) != EXR_ERR_SUCCESS) ok = false;
    return ok;
}

static void test_exr_half_and_windows(void) {
    enum { HW = 19, HH = 41 };
    exr_attr_box2i_t dw = {.min = {.x = -3, .y = 7}, .max = {.x = -3 + HW - 1, .y = 7 + HH - 1}};
    float *planes[4];
    for (int c = 0; c < 4; c++) {
        planes[c] = malloc(sizeof(float) * HW * HH);
        if (!planes[c]) exit(1);
        /* multiples of 1/8 below 256: exact in half precision */
        for (int i = 0; i < HW * HH; i++) planes[c][i] = (float)((i * 7 + c * 13) % 2000) / 8.f - 10.f;
    }
    const exr_compression_t comps[] = {EXR_COMPRESSION_NONE, EXR_COMPRESSION_RLE, EXR_COMPRESSION_ZIPS,
                                       EXR_COMPRESSION_ZIP, EXR_COMPRESSION_PIZ};
    const char *const comp_names[] = {"none", "rle", "zips", "zip", "piz"};
    char path[256], err[512];
    tmp_path(path, sizeof path, "half.exr");
    /* RGB and RGBA: OpenEXR picks dedicated 3- and 4-channel HALF routines */
    for (size_t j = 0; j < 2 * sizeof comps / sizeof comps[0]; j++) {
        int nchan = j % 2 ? 4 : 3;
        exr_compression_t comp = comps[j / 2];
        const char *comp_name = comp_names[j / 2];
        if (!write_half_exr(path, comp, &dw, nchan, (const float **)planes)) {
            printf("SKIP: the core library cannot write a HALF %s file here\n", comp_name);
            unlink(path);
            continue;
        }
        static const char *const names[4] = {"R", "G", "B", "A"};
        for (int c = 0; c < nchan; c++) {
            int w = 0, h = 0;
            float *px = pm_read_exr_channel(path, names[c], &w, &h, err, sizeof err);
            CHECK(px != NULL, "read HALF %s %d-channel file, channel %s: %s", comp_name, nchan, names[c], err);
            if (!px) continue;
            CHECK(w == HW && h == HH, "HALF %s size %dx%d", comp_name, w, h);
            int bad = 0;
            for (int i = 0; i < HW * HH; i++) bad += px[i] != planes[c][i];
            CHECK(bad == 0, "HALF %s %d-channel file, channel %s: %d pixels differ (row 0 = data window min y)",
                  comp_name, nchan, names[c], bad);
            free(px);
        }
        /* the same file as an environment map: R, G, B decoded together, interleaved */
        int w = 0, h = 0;
        float *env = pm_read_environment(path, &w, &h, err, sizeof err);
        CHECK(env != NULL && w == HW && h == HH, "HALF %s %d-channel file as a map: %s", comp_name, nchan, err);
        int bad = 0;
        for (int i = 0; env && i < HW * HH; i++)
            for (int c = 0; c < 3; c++) bad += env[3 * i + c] != planes[c][i];
        CHECK(bad == 0, "HALF %s %d-channel file as a map: %d values differ from the planes", comp_name, nchan, bad);
        free(env);
        unlink(path);
    }
    /* cut in half: the header still gives the size (nothing decoded), the pixels are refused */
    if (write_half_exr(path, EXR_COMPRESSION_NONE, &dw, 3, (const float **)planes)) {
        size_t n = 0;
        uint8_t *bytes = read_bytes(path, &n);
        CHECK(bytes && write_bytes(path, bytes, n / 2), "cut %s", path);
        free(bytes);
        int w = 0, h = 0;
        CHECK(pm_environment_size(path, &w, &h, err, sizeof err) && w == HW && h == HH,
              "the size of a cut EXR from its header: %dx%d (%s)", w, h, err);
        float *env = pm_read_environment(path, &w, &h, err, sizeof err);
        CHECK(env == NULL && strncmp(err, path, strlen(path)) == 0 && strstr(err, "chunk") && !strchr(err, '\n'),
              "a cut EXR map is refused naming the chunk: \"%s\"", err);
        free(env);
        unlink(path);
    }
    for (int c = 0; c < 4; c++) free(planes[c]);
}

/* A Radiance .hdr written byte by byte: header, resolution, then rows. */
static bool write_hdr(const char *path, const char *header, const uint8_t *rows, size_t n) {
    FILE *f = fopen(path, "wb");
    if (!f) return false;
    bool ok = fputs(header, f) >= 0 && fwrite(rows, 1, n, f) == n;
    return fclose(f) == 0 && ok;
}

/* .hdr maps: run-length and flat rows decoded exactly; a file cut anywhere, runs past the row,
 * a file that is not Radiance's, or a header pmview cannot use are refused with one line saying
 * what and where (stb_image read a cut file's missing rows as black and took a PNG for a map). */
static void test_hdr_maps(void) {
    char path[256], err[512];
    tmp_path(path, sizeof path, "sky.hdr");
    const char *header = "#?RADIANCE\n# a comment\nFORMAT=32-bit_rle_rgbe\nEXPOSURE=1\n\n-Y 2 +X 9\n";
    /* row 0 run-length encoded: R a run of five 128s then 64 32 16 8 literally, G a run of 128,
     * B nine literal values, exponents a run of 129 (x 2^-7); row 1 flat: nine texels (1, 2, 3) x 2^0 */
    const uint8_t rows[] = {2, 2, 0, 9,
                            128 + 5, 128, 4, 64, 32, 16, 8,
                            128 + 9, 128,
                            9, 0, 10, 20, 30, 40, 50, 60, 70, 80,
                            128 + 9, 129,
                            1, 2, 3, 136, 1, 2, 3, 136, 1, 2, 3, 136, 1, 2, 3, 136, 1, 2, 3, 136,
                            1, 2, 3, 136, 1, 2, 3, 136, 1, 2, 3, 136, 1, 2, 3, 136};
    const size_t row0 = 4 + 7 + 2 + 10 + 2;
    CHECK(write_hdr(path, header, rows, sizeof rows), "write %s", path);
    int w = 0, h = 0;
    CHECK(pm_environment_size(path, &w, &h, err, sizeof err) && w == 9 && h == 2, "size %dx%d: %s", w, h, err);
    float *px = pm_read_environment(path, &w, &h, err, sizeof err);
    CHECK(px != NULL && w == 9 && h == 2, "read the .hdr: %s", err);
    if (px) {
        static const float r0[9] = {1, 1, 1, 1, 1, 0.5f, 0.25f, 0.125f, 0.0625f};
        int bad = 0;
        for (int x = 0; x < 9; x++) {
            bad += px[3 * x] != r0[x] || px[3 * x + 1] != 1.f || px[3 * x + 2] != 10.f * x / 128.f;
            bad += px[27 + 3 * x] != 1.f || px[27 + 3 * x + 1] != 2.f || px[27 + 3 * x + 2] != 3.f;
        }
        CHECK(bad == 0, "%d texels decoded wrong", bad);
        free(px);
    }
    /* every cut: row 1 or 2 named, "no pixels" right after the header */
    for (size_t n = 0; n < sizeof rows; n++) {
        CHECK(write_hdr(path, header, rows, n), "write %s", path);
        err[0] = '\0';
        px = pm_read_environment(path, &w, &h, err, sizeof err);
        const char *want = n == 0 ? "no pixels" : (n < row0 ? "ends in row 1 of 2 (truncated)" : "ends in row 2 of 2 (truncated)");
        CHECK(px == NULL && strncmp(err, path, strlen(path)) == 0 && strstr(err, want) && !strchr(err, '\n'),
              "cut at %zu of %zu bytes: want \"%s\", got \"%s\"", n, sizeof rows, want, err);
        free(px);
    }
    CHECK(write_hdr(path, header, rows, 0), "write %s", path);
    CHECK(!pm_environment_size(path, &w, &h, err, sizeof err) && strstr(err, "no pixels"),
          "a header without pixels is refused from its header: \"%s\"", err);

    /* runs that overrun the row, and a row encoded at another width */
    uint8_t broken[sizeof rows];
    memcpy(broken, rows, sizeof rows);
    broken[4] = 128 + 10; /* a run of ten in a row of nine */
    CHECK(write_hdr(path, header, broken, sizeof broken), "write %s", path);
    px = pm_read_environment(path, &w, &h, err, sizeof err);
    CHECK(px == NULL && strstr(err, "bad run-length data in row 1 of 2"), "overrun: \"%s\"", err);
    free(px);
    memcpy(broken, rows, sizeof rows);
    broken[3] = 8;
    CHECK(write_hdr(path, header, broken, sizeof broken), "write %s", path);
    px = pm_read_environment(path, &w, &h, err, sizeof err);
    CHECK(px == NULL && strstr(err, "row 1 of 2 is encoded 8 texels wide"), "wrong width: \"%s\"", err);
    free(px);

    /* headers: #?RGBE is Radiance's too; the rest is refused, with the reason */
    CHECK(write_hdr(path, "#?RGBE\n\n-Y 2 +X 9\n", rows, sizeof rows), "write %s", path);
    px = pm_read_environment(path, &w, &h, err, sizeof err);
    CHECK(px != NULL, "#?RGBE is a Radiance signature: %s", err);
    free(px);
    static const struct { const char *header, *want; } refused[] = {
        {"\x89PNG\r\n\x1a\n", "not a Radiance .hdr file"},
        {"", "not a Radiance .hdr file"},
        {"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 2 +X 9\n", "FORMAT=32-bit_rle_xyze are not supported"},
        {"#?RADIANCE\n\n+Y 2 +X 9\n", "is not \"-Y HEIGHT +X WIDTH\""},
        {"#?RADIANCE\n\n-Y 2 +X 9 extra\n", "is not \"-Y HEIGHT +X WIDTH\""},
        {"#?RADIANCE\n\n-Y 0 +X 9\n", "not usable"},
        {"#?RADIANCE\n\n-Y 99999999999 +X 9\n", "not usable"},
        {"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n", "ends inside its header"},
    };
    for (size_t i = 0; i < sizeof refused / sizeof *refused; i++) {
        CHECK(write_hdr(path, refused[i].header, rows, strlen(refused[i].header) ? 0 : sizeof rows), "write %s", path);
        err[0] = '\0';
        bool sized = pm_environment_size(path, &w, &h, err, sizeof err);
        CHECK(!sized && strncmp(err, path, strlen(path)) == 0 && strstr(err, refused[i].want) && !strchr(err, '\n'),
              "header %zu: want \"%s\", got \"%s\"", i, refused[i].want, err);
    }
    /* a header that never ends is read no further than 64 KiB */
    FILE *f = fopen(path, "wb");
    if (f) {
        fputs("#?RADIANCE\n", f);
        for (int i = 0; i < 20000; i++) fputs("# comment\n", f);
        fclose(f);
    }
    CHECK(!pm_environment_size(path, &w, &h, err, sizeof err) && strstr(err, "does not end within 64 KiB"),
          "an endless header: \"%s\"", err);
    unlink(path);
}

/* Inputs that are not regular files are refused by what stat says, at once: opening a FIFO
 * waited for a writer forever (after the scene and its BVH were built). */
static void test_not_regular_files(void) {
    char fifo[256], dir[256], err[512];
    int w, h;
    static const char *const names[2] = {"fifo.exr", "fifo.hdr"};
    for (int i = 0; i < 2; i++) {
        tmp_path(fifo, sizeof fifo, names[i]);
        CHECK(mkfifo(fifo, 0600) == 0, "mkfifo %s", fifo);
        CHECK(!pm_environment_size(fifo, &w, &h, err, sizeof err) && strstr(err, "is a FIFO, not a regular file"),
              "a FIFO's size: \"%s\"", err);
        float *px = pm_read_environment(fifo, &w, &h, err, sizeof err);
        CHECK(px == NULL && strstr(err, "is a FIFO"), "a FIFO as a map: \"%s\"", err);
        free(px);
        if (i == 0) {
            px = pm_read_exr_channel(fifo, "R", &w, &h, err, sizeof err);
            CHECK(px == NULL && strstr(err, "is a FIFO"), "a FIFO's channel: \"%s\"", err);
            free(px);
        }
        unlink(fifo);
    }
    tmp_path(dir, sizeof dir, "folder.exr");
    CHECK(mkdir(dir, 0700) == 0, "mkdir %s", dir);
    float *px = pm_read_environment(dir, &w, &h, err, sizeof err);
    CHECK(px == NULL && strstr(err, "is a directory, not a regular file"), "a directory as a map: \"%s\"", err);
    free(px);
    rmdir(dir);
}

/* The committed Mitsuba 3 reference, when present: R, G, B read, finite, lit. */
static void test_mitsuba_reference(void) {
    const char *path = "tests/ref/cornell_direct_64.exr";
    if (!file_exists(path)) { printf("SKIP: %s not found (run from the repository root)\n", path); return; }
    char err[512];
    for (int k = 0; k < 3; k++) {
        int w = 0, h = 0;
        float *px = pm_read_exr_channel(path, rgb[k], &w, &h, err, sizeof err);
        CHECK(px != NULL, "read %s from the Mitsuba file: %s", rgb[k], err);
        if (!px) continue;
        CHECK(w > 0 && h > 0, "size %dx%d", w, h);
        int bad = 0;
        double sum = 0;
        for (int i = 0; i < w * h; i++) {
            bad += !isfinite(px[i]) || px[i] < 0.f;
            sum += px[i];
        }
        CHECK(bad == 0 && sum > 0, "%s: %d bad pixels, sum %g", rgb[k], bad, sum);
        free(px);
    }
}

static uint32_t be32(const uint8_t *p) { return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3]; }

static void test_png(void) {
    char path[256], err[512];
    tmp_path(path, sizeof path, "image.png");
    uint8_t *rgba = malloc(4 * W * H);
    if (!rgba) exit(1);
    for (int i = 0; i < 4 * W * H; i++) rgba[i] = (uint8_t)(i * 31 + i / (4 * W));
    CHECK(pm_write_png(path, W, H, rgba, err, sizeof err), "write %s: %s", path, err);
    size_t n = 0;
    uint8_t *bytes = read_bytes(path, &n);
    CHECK(bytes != NULL, "read back %s", path);
    if (bytes) {
        static const uint8_t sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
        CHECK(n > 8 + 25 + 12, "PNG size %zu", n);
        if (n > 8 + 25 + 12) {
            CHECK(memcmp(bytes, sig, 8) == 0, "PNG signature");
            CHECK(be32(bytes + 8) == 13 && memcmp(bytes + 12, "IHDR", 4) == 0, "IHDR chunk first");
            CHECK(be32(bytes + 16) == W && be32(bytes + 20) == H, "IHDR size %ux%u", be32(bytes + 16), be32(bytes + 20));
            CHECK(bytes[24] == 8 && bytes[25] == 6, "8-bit RGBA (depth %d, colour type %d)", bytes[24], bytes[25]);
            CHECK(memcmp(bytes + n - 8, "IEND", 4) == 0, "ends with IEND");
        }
        /* and the pixels decode to what was written, row 0 at the top */
        int w = 0, h = 0, comp = 0;
        uint8_t *dec = stbi_load_from_memory(bytes, (int)n, &w, &h, &comp, 4);
        CHECK(dec && w == W && h == H && comp == 4, "decode the PNG");
        if (dec && w == W && h == H) CHECK(memcmp(dec, rgba, 4 * W * H) == 0, "decoded pixels equal the input");
        if (dec) stbi_image_free(dec);
        free(bytes);
    }
    unlink(path);

    tmp_path(path, sizeof path, "no-such-dir/image.png");
    err[0] = '\0';
    CHECK(!pm_write_png(path, W, H, rgba, err, sizeof err), "PNG into a missing directory must fail");
    CHECK(strncmp(err, path, strlen(path)) == 0 && strstr(err, "No such file") && !strchr(err, '\n'),
          "one-line error with the cause: \"%s\"", err);
    CHECK(!pm_write_png(path, 0, H, rgba, err, sizeof err), "zero width must fail");
    free(rgba);
}

static bool file_holds(const char *path, const char *text) {
    size_t n = 0;
    uint8_t *bytes = read_bytes(path, &n);
    bool same = bytes && n == strlen(text) && memcmp(bytes, text, n) == 0;
    free(bytes);
    return same;
}

/* Two spellings of one file are one file, whether it exists (device and inode) or not yet
 * (resolved folders): what main() relies on to keep outputs off its inputs. */
static void test_same_file(void) {
    char a[320], b[320], folder[256];
    tmp_path(folder, sizeof folder, "same");
    mkdir(folder, 0700);
    snprintf(a, sizeof a, "%s/scene.gltf", folder);
    CHECK(write_bytes(a, "{}", 2), "write %s", a);
    snprintf(b, sizeof b, "%s/./../same/scene.gltf", folder);
    CHECK(pm_same_file(a, b), "criterion: %s and %s are the same file", a, b);
    snprintf(b, sizeof b, "%s/link.gltf", folder);
    CHECK(symlink("scene.gltf", b) == 0 && pm_same_file(b, a), "criterion: a symbolic link is the file it names");
    unlink(b);
    CHECK(link(a, b) == 0 && pm_same_file(b, a), "criterion: a hard link is the same file");
    unlink(b);
    CHECK(write_bytes(b, "{}", 2) && !pm_same_file(a, b), "two files with the same bytes are two files");
    unlink(b);
    char c[320];
    snprintf(b, sizeof b, "%s/new.csv", folder);
    snprintf(c, sizeof c, "%s/../same/new.csv", folder);
    CHECK(pm_same_file(b, c), "criterion: two spellings of a file yet to be written are the same file");
    snprintf(c, sizeof c, "%s/other.csv", folder);
    CHECK(!pm_same_file(b, c), "different new files are different");
    unlink(a);
    rmdir(folder);
}

/* The writers admit their buffers against --max-memory before they touch the target, and give
 * them back afterwards. */
static void test_writers_within_the_limit(void) {
    char path[256], err[512];
    pm_film film;
    make_film(&film);
    pm_memory_clear_failure();
    const uint64_t base = pm_memory_committed(), exr = pm_exr_write_bytes(W, H);
    CHECK(exr == 72ull * W * H, "the EXR writer takes 72 bytes a pixel: %llu", (unsigned long long)exr);
    tmp_path(path, sizeof path, "limited.exr");
    CHECK(write_bytes(path, "previous", 8), "write %s", path);
    pm_memory_set_limit(base + exr - 1);
    err[0] = '\0';
    CHECK(!pm_write_exr(path, &film, err, sizeof err), "criterion: an EXR whose buffers pass the limit is refused");
    CHECK(strstr(err, "out of memory (EXR output buffers, ") && strstr(err, "--max-memory") && !strchr(err, '\n'),
          "one line naming the buffers and --max-memory: \"%s\"", err);
    CHECK(file_holds(path, "previous"), "criterion: the refused write leaves the previous file as it was");
    CHECK(pm_memory_committed() == base, "a refusal commits nothing");
    pm_memory_clear_failure();
    pm_memory_set_limit(base + exr);
    CHECK(pm_write_exr(path, &film, err, sizeof err), "criterion: with room for exactly its buffers it writes: \"%s\"", err);
    CHECK(pm_memory_committed() == base, "criterion: the EXR writer gives its buffers back (%llu left)",
          (unsigned long long)(pm_memory_committed() - base));
    unlink(path);

    uint8_t rgba[4 * W * H];
    memset(rgba, 90, sizeof rgba);
    tmp_path(path, sizeof path, "limited.png");
    CHECK(write_bytes(path, "previous", 8), "write %s", path);
    pm_memory_set_limit(base + pm_png_write_bytes(W, H) - 1);
    err[0] = '\0';
    CHECK(!pm_write_png(path, W, H, rgba, err, sizeof err) && strstr(err, "out of memory (PNG encoder, ") &&
              strstr(err, "--max-memory"), "criterion: a PNG whose encoder passes the limit is refused: \"%s\"", err);
    CHECK(file_holds(path, "previous"), "criterion: refused before the PNG written in place is truncated");
    pm_memory_clear_failure();
    pm_memory_set_limit(base + pm_png_write_bytes(W, H));
    CHECK(pm_write_png(path, W, H, rgba, err, sizeof err) && pm_memory_committed() == base,
          "with room for the encoder it writes, and gives the room back: \"%s\"", err);
    unlink(path);
    pm_memory_set_limit(pm_memory_default_limit());
    pm_memory_clear_failure();
    pm_film_free(&film);
}

/* A read-only file is refused as a target, EXR as PNG: the EXR's rename over it would have
 * replaced what its owner protected. Root may write anything, so as root the checks run in a
 * child that has become nobody. Returns a bit per failed expectation. */
static int read_only_expectations(const char *folder) {
    char exr[300], png[300], err[512];
    snprintf(exr, sizeof exr, "%s/locked.exr", folder);
    snprintf(png, sizeof png, "%s/locked.png", folder);
    int failed = 0;
    if (pm_check_output_path(exr, err, sizeof err) || !strstr(err, "cannot write the file (Permission denied)")) failed |= 1;
    if (pm_check_output_path(png, err, sizeof err) || !strstr(err, "cannot write the file (Permission denied)")) failed |= 2;
    pm_film film;
    make_film(&film);
    if (pm_write_exr(exr, &film, err, sizeof err) || !strstr(err, "Permission denied")) failed |= 4;
    pm_film_free(&film);
    if (!file_holds(exr, "locked")) failed |= 8;
    return failed;
}

static void test_read_only_targets(void) {
    char folder[256], path[300];
    tmp_path(folder, sizeof folder, "read-only");
    mkdir(folder, 0777);
    chmod(folder, 0777); /* whatever the umask: the folder itself is writable, only the files are not */
    const char *names[2] = {"locked.exr", "locked.png"};
    for (int i = 0; i < 2; i++) {
        snprintf(path, sizeof path, "%s/%s", folder, names[i]);
        CHECK(write_bytes(path, "locked", 6) && chmod(path, 0444) == 0, "write %s", path);
    }
    int failed = -1;
    if (geteuid() != 0) {
        failed = read_only_expectations(folder);
    } else {
        chmod(tmp_dir_path, 0711); /* nobody must reach the folder */
        fflush(NULL);
        pid_t child = fork();
        if (child == 0) _exit(setgid(65534) == 0 && setuid(65534) == 0 ? read_only_expectations(folder) : 99);
        int status = 0;
        if (child > 0 && waitpid(child, &status, 0) == child && WIFEXITED(status)) failed = WEXITSTATUS(status);
        chmod(tmp_dir_path, 0700);
    }
    if (failed == 99) printf("SKIP: read-only targets: cannot become nobody to test them\n");
    else {
        printf("read-only targets%s: expectations missed: %d (a bit each)\n", geteuid() ? "" : " (as nobody)", failed);
        CHECK(!(failed & 1), "criterion: a read-only EXR target is refused by the check before rendering (%d)", failed);
        CHECK(!(failed & 2), "a read-only PNG target is refused by the check (%d)", failed);
        CHECK(!(failed & 4), "criterion: pm_write_exr refuses a read-only target (%d)", failed);
        CHECK(!(failed & 8), "criterion: the read-only EXR target is left as it was (%d)", failed);
    }
    for (int i = 0; i < 2; i++) {
        snprintf(path, sizeof path, "%s/%s", folder, names[i]);
        unlink(path);
    }
    rmdir(folder);
}

int main(void) {
    snprintf(tmp_dir_path, sizeof tmp_dir_path, "/tmp/pmview-test-image-io-%ld", (long)getpid());
    if (mkdir(tmp_dir_path, 0700) != 0) {
        fprintf(stderr, "cannot create %s\n", tmp_dir_path);
        return 1;
    }
    test_exr_round_trip();
    test_exr_failures();
    test_exr_half_and_windows();
    test_hdr_maps();
    test_not_regular_files();
    test_mitsuba_reference();
    test_png();
    test_same_file();
    test_writers_within_the_limit();
    test_read_only_targets();
    if (rmdir(tmp_dir_path) != 0) CHECK(false, "temporary directory %s left non-empty", tmp_dir_path);
    return pm_test_done("test_image_io");
}

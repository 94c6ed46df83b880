/* image_io.c: the film to a multi-layer OpenEXR file (OpenEXR C API), one EXR channel back to floats, RGBA8 to PNG. */

/*
 * EXR files always carry the same 15 FLOAT channels (R, G, B and the four component layers),
 * whether or not the scene could light a component, so scripts and tests never have to guess
 * what a file holds. The total is written as the sum of the written layers, so reading the
 * layers back and adding them in component order gives the total bit for bit.
 *
 * The OpenEXR core library reports details through a callback rather than a return value;
 * a thread-local buffer keeps the first message of the current call so every failure ends up
 * as one line, "PATH: what went wrong (library detail)", instead of text on stderr.
 */
/* realpath is XSI, beyond the POSIX level the build asks for */
#define _XOPEN_SOURCE 700
#include "image_io.h"

#include <errno.h>
#include <limits.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <openexr.h>
#include <stb/stb_image.h>
#include <stb/stb_image_write.h>

#include "memory.h"

#define PM_EXR_CHANNELS (3 + 3 * PM_COMPONENT_COUNT)

/* The file being written, for pm_remove_partial_output() from a signal handler: one writer at a
 * time holds the claim (another writes unregistered). The name lives here, and mkstemp fills it in
 * place after it is armed, so the file never exists under a name the handler cannot see. */
static char partial_path[4096];
static volatile sig_atomic_t partial_armed;
static atomic_flag partial_claimed = ATOMIC_FLAG_INIT;

void pm_remove_partial_output(void) {
    if (partial_armed) unlink(partial_path); /* async-signal-safe: a flag read and unlink */
}

static void disarm_partial(bool claimed) {
    if (!claimed) return;
    partial_armed = 0;
    atomic_flag_clear(&partial_claimed);
}

uint64_t pm_exr_write_bytes(int width, int height) {
    /* the channel planes and one resolved component */
    return (uint64_t)(PM_EXR_CHANNELS + 3) * sizeof(float) * (uint64_t)(width > 0 ? width : 0) * (uint64_t)(height > 0 ? height : 0);
}

uint64_t pm_png_write_bytes(int width, int height) {
    /* stb's filtered rows (4 bytes a pixel), its zlib stream grown by doubling (up to 8 while it
     * is copied), the file's copy of it (4), and its hash chains (at most 16384 x 16 pointers) */
    return 16 * (uint64_t)(width > 0 ? width : 0) * (uint64_t)(height > 0 ? height : 0) + (2u << 20);
}

static _Thread_local char exr_detail[256];

static void capture_exr_error(exr_const_context_t ctxt, exr_result_t code, const char *msg) {
    (void)ctxt;
    /* the first message names the cause; later ones are usually consequences of it */
    if (!exr_detail[0])
        snprintf(exr_detail, sizeof exr_detail, "%s", msg && *msg ? msg : exr_get_default_error_message(code));
}

static exr_context_initializer_t exr_initializer(void) {
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = capture_exr_error;
    exr_detail[0] = '\0';
    return init;
}

/* Messages go to a terminal or a log line: keep them to one line whatever the library said. */
static void one_line(char *err) {
    for (char *p = err; *p; p++)
        if (*p == '\n' || *p == '\r') *p = ' ';
}

static void set_error(char *err, size_t err_size, const char *path, const char *what) {
    if (!err || err_size == 0) return;
    snprintf(err, err_size, "%s: %s", path ? path : "(null)", what);
    one_line(err);
}

static void set_exr_error(char *err, size_t err_size, const char *path, const char *what, exr_result_t rv) {
    if (!err || err_size == 0) return;
    const char *detail = exr_detail[0] ? exr_detail : exr_get_default_error_message(rv);
    snprintf(err, err_size, "%s: %s (%s)", path ? path : "(null)", what, detail);
    one_line(err);
}

/* ---------------------------------------------------------------------------------------------- */

/* The folder part of path ("." for a bare name) into out. */
static void folder_of(const char *path, char *out, size_t size) {
    const char *slash = strrchr(path, '/');
    if (!slash) snprintf(out, size, ".");
    else if (slash == path) snprintf(out, size, "/");
    else snprintf(out, size, "%.*s", (int)(slash - path), path);
}

/* Creates an empty, uniquely named hidden file in path's folder: ".NAME.XXXXXX"; *armed (when
 * given) is set once temp holds the whole template, before the file can exist. */
static bool temporary_beside(const char *path, char *temp, size_t size, volatile sig_atomic_t *armed, char *err,
                             size_t err_size) {
    char folder[4096];
    folder_of(path, folder, sizeof folder);
    const char *slash = strrchr(path, '/');
    int n = snprintf(temp, size, "%s/.%s.XXXXXX", folder, slash ? slash + 1 : path);
    if (n < 0 || (size_t)n >= size) {
        temp[0] = '\0';
        set_error(err, err_size, path, "the file name is too long");
        return false;
    }
    atomic_thread_fence(memory_order_seq_cst); /* the whole name is in place before the flag says so */
    if (armed) *armed = 1;
    int fd = mkstemp(temp);
    if (fd < 0) {
        char what[4200];
        snprintf(what, sizeof what, "cannot create a file in the folder %s (%s)", folder, strerror(errno));
        if (armed) *armed = 0;
        temp[0] = '\0';
        set_error(err, err_size, path, what);
        return false;
    }
    /* mkstemp makes it private (0600); the file it becomes gets the usual permissions */
    mode_t mask = umask(0);
    umask(mask);
    fchmod(fd, 0666 & ~mask);
    close(fd);
    return true;
}

/* Whether an existing file opens for writing (nothing is truncated); else err says why. */
static bool file_takes_writing(const char *path, char *err, size_t err_size) {
    int fd = open(path, O_WRONLY | O_NOCTTY | O_NONBLOCK);
    if (fd < 0) {
        char what[320];
        snprintf(what, sizeof what, "cannot write the file (%s)", strerror(errno));
        set_error(err, err_size, path, what);
        return false;
    }
    close(fd);
    return true;
}

bool pm_check_output_path(const char *path, char *err, size_t err_size) {
    if (!path || !*path) { set_error(err, err_size, path ? path : "", "no output file name given"); return false; }
    char what[4200];
    struct stat st;
    bool exists = stat(path, &st) == 0;
    if (!exists && errno != ENOENT) {
        snprintf(what, sizeof what, "cannot write there (%s)", strerror(errno));
        set_error(err, err_size, path, what);
        return false;
    }
    if (exists && S_ISDIR(st.st_mode)) { set_error(err, err_size, path, "is a directory, not a file name"); return false; }
    bool exr = pm_has_extension(path, ".exr");
    if (exists && exr && !S_ISREG(st.st_mode)) {
        set_error(err, err_size, path, "is not a regular file (an EXR is written beside it and renamed over it)");
        return false;
    }
    /* A PNG is written in place: the file itself must take writing (not truncated here). An EXR
     * is renamed over it, which the folder alone allows: the same test keeps it from replacing a
     * file its owner made read-only. */
    if (exists && !file_takes_writing(path, err, err_size)) return false;
    if (exists && !exr) return true;
    /* a new file (or an EXR's temporary one) must be creatable in the folder: try it */
    char temp[4096];
    if (!temporary_beside(path, temp, sizeof temp, NULL, err, err_size)) return false;
    unlink(temp);
    return true;
}

bool pm_write_exr(const char *path, const pm_film *film, char *err, size_t err_size) {
    if (!path || !*path) { set_error(err, err_size, path ? path : "", "no output file name given"); return false; }
    if (!film || film->width <= 0 || film->height <= 0) {
        set_error(err, err_size, path, "cannot write an EXR of an empty film");
        return false;
    }
    const int width = film->width, height = film->height;
    if ((size_t)width > SIZE_MAX / sizeof(float) / PM_EXR_CHANNELS / (size_t)height || width > INT32_MAX / 4) {
        set_error(err, err_size, path, "image too large for an EXR file");
        return false;
    }
    const size_t npix = (size_t)width * height;

    /* Planar channels: the encoder then reads each channel with plain strides. plane[0..2] is the
     * total, plane[3 + 3c + k] component c's channel k. */
    char names[PM_EXR_CHANNELS][32];
    static const char *const rgb_names[3] = {"R", "G", "B"};
    for (int k = 0; k < 3; k++) {
        snprintf(names[k], sizeof names[k], "%s", rgb_names[k]);
        for (int c = 0; c < PM_COMPONENT_COUNT; c++)
            snprintf(names[3 + 3 * c + k], sizeof names[0], "%s.%s", pm_component_names[c], rgb_names[k]);
    }

    /* an existing target replaced by the rename must be one its owner lets us write */
    struct stat st;
    if (stat(path, &st) == 0 && S_ISREG(st.st_mode) && !file_takes_writing(path, err, err_size)) return false;
    const uint64_t buffer_bytes = pm_exr_write_bytes(width, height);
    if (!pm_memory_admit(buffer_bytes, "EXR output buffers")) {
        char what[400];
        snprintf(what, sizeof what, "out of memory (%s)", pm_memory_failure());
        set_error(err, err_size, path, what);
        return false;
    }

    bool ok = false;
    exr_context_t ctxt = NULL;
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    bool enc_started = false;
    /* the temporary file's name in the registered buffer when free, so a signal can remove it */
    const bool claimed = !atomic_flag_test_and_set(&partial_claimed);
    char own_temp[sizeof partial_path] = "";
    char *temp_path = claimed ? partial_path : own_temp;
    temp_path[0] = '\0';
    float *planes = pm_malloc(PM_EXR_CHANNELS * npix * sizeof(float), "EXR output buffers");
    float *rgb = planes ? pm_malloc(3 * npix * sizeof(float), "EXR output buffers") : NULL;
    if (!planes || !rgb) {
        char what[400];
        snprintf(what, sizeof what, "out of memory (%s)", pm_memory_failure() ? pm_memory_failure() : "EXR output buffers");
        set_error(err, err_size, path, what);
        goto done;
    }

    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        pm_film_resolve(film, (pm_component)c, rgb);
        for (int k = 0; k < 3; k++) {
            float *dst = planes + (size_t)(3 + 3 * c + k) * npix;
            for (size_t i = 0; i < npix; i++) dst[i] = rgb[3 * i + k];
        }
    }
    /* the total from the layers as written, in component order, so they add up to it exactly */
    for (int k = 0; k < 3; k++) {
        float *t = planes + (size_t)k * npix;
        for (size_t i = 0; i < npix; i++) {
            float s = planes[(size_t)(3 + k) * npix + i];
            for (int c = 1; c < PM_COMPONENT_COUNT; c++) s += planes[(size_t)(3 + 3 * c + k) * npix + i];
            t[i] = s;
        }
    }

    exr_context_initializer_t init = exr_initializer();
    /* A temporary file beside the target, renamed over it at the end: a failed write leaves any
     * previous file untouched, and the temporary file is removed on every failure (OpenEXR's own
     * temporary file outlived a failed rename) */
    if (!temporary_beside(path, temp_path, sizeof partial_path, claimed ? &partial_armed : NULL, err, err_size)) goto done;
    exr_result_t rv = exr_start_write(&ctxt, temp_path, EXR_WRITE_FILE_DIRECTLY, &init);
    if (rv != EXR_ERR_SUCCESS) { set_exr_error(err, err_size, path, "cannot create the file", rv); goto done; }

    int part = 0;
    rv = exr_add_part(ctxt, "pmview", EXR_STORAGE_SCANLINE, &part);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_initialize_required_attr_simple(ctxt, part, width, height, EXR_COMPRESSION_ZIP);
    /* zlib's fastest level: float radiance barely compresses further (a 512 x 512 snapshot: 6.89 MB
     * against 6.85 MB at the library's default), and the default took 0.3 s more to write it */
    if (rv == EXR_ERR_SUCCESS) rv = exr_set_zip_compression_level(ctxt, part, 1);
    for (int ch = 0; ch < PM_EXR_CHANNELS && rv == EXR_ERR_SUCCESS; ch++)
        rv = exr_add_channel(ctxt, part, names[ch], EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    if (rv == EXR_ERR_SUCCESS) rv = exr_write_header(ctxt);
    if (rv != EXR_ERR_SUCCESS) { set_exr_error(err, err_size, path, "cannot write the EXR header", rv); goto done; }

    int32_t lines_per_chunk = 0;
    rv = exr_get_scanlines_per_chunk(ctxt, part, &lines_per_chunk);
    if (rv != EXR_ERR_SUCCESS || lines_per_chunk <= 0) {
        set_exr_error(err, err_size, path, "cannot size the EXR chunks", rv);
        goto done;
    }

    for (int y = 0; y < height; y += lines_per_chunk) {
        exr_chunk_info_t cinfo;
        rv = exr_write_scanline_chunk_info(ctxt, part, y, &cinfo);
        if (rv == EXR_ERR_SUCCESS) {
            if (!enc_started) {
                enc_started = true;
                rv = exr_encoding_initialize(ctxt, part, &cinfo, &enc);
            } else {
                rv = exr_encoding_update(ctxt, part, &cinfo, &enc);
            }
        }
        if (rv != EXR_ERR_SUCCESS) {
            set_exr_error(err, err_size, path, "cannot prepare an EXR chunk", rv);
            goto done;
        }
        for (int i = 0; i < enc.channel_count; i++) {
            exr_coding_channel_info_t *chan = &enc.channels[i];
            int ch = 0;
            while (ch < PM_EXR_CHANNELS && strcmp(names[ch], chan->channel_name) != 0) ch++;
            if (ch == PM_EXR_CHANNELS) {
                set_error(err, err_size, path, "the EXR encoder lists a channel that was never added");
                goto done;
            }
            chan->user_bytes_per_element = 4;
            chan->user_data_type = EXR_PIXEL_FLOAT;
            chan->user_pixel_stride = 4;
            chan->user_line_stride = 4 * width;
            chan->encode_from_ptr = (const uint8_t *)(planes + (size_t)ch * npix + (size_t)cinfo.start_y * width);
        }
        /* after the pointers: the routine chosen depends on the channel layout */
        rv = exr_encoding_choose_default_routines(ctxt, part, &enc);
        if (rv == EXR_ERR_SUCCESS) rv = exr_encoding_run(ctxt, part, &enc);
        if (rv != EXR_ERR_SUCCESS) {
            set_exr_error(err, err_size, path, "cannot encode or write an EXR chunk", rv);
            goto done;
        }
    }
    ok = true;

done:
    if (enc_started) exr_encoding_destroy(ctxt, &enc);
    if (ctxt) {
        rv = exr_finish(&ctxt);
        if (ok && rv != EXR_ERR_SUCCESS) {
            set_exr_error(err, err_size, path, "cannot finish the file", rv);
            ok = false;
        }
    }
    if (ok && rename(temp_path, path) != 0) {
        char what[320];
        snprintf(what, sizeof what, "cannot replace the file (%s)", strerror(errno));
        set_error(err, err_size, path, what);
        ok = false;
    }
    if (!ok && temp_path[0]) unlink(temp_path);
    disarm_partial(claimed);
    free(rgb);
    free(planes);
    pm_memory_release(buffer_bytes);
    return ok;
}

/* ---------------------------------------------------------------------------------------------- */

static bool attr_string_is(const exr_attr_string_t *s, const char *name) {
    size_t n = strlen(name);
    return s->str && s->length >= 0 && (size_t)s->length == n && memcmp(s->str, name, n) == 0;
}

/* "B, G, R, ..." into buf, cut short if the list is long: for the missing-channel message. */
static void list_channels(const exr_attr_chlist_t *chl, char *buf, size_t size) {
    size_t used = 0;
    buf[0] = '\0';
    for (int i = 0; i < chl->num_channels && used < size; i++) {
        int n = snprintf(buf + used, size - used, "%s%.*s", i ? ", " : "", (int)chl->entries[i].name.length,
                         chl->entries[i].name.str ? chl->entries[i].name.str : "");
        if (n < 0) break;
        used += (size_t)n;
    }
}

float *pm_read_exr_channel(const char *path, const char *channel, int *width_out, int *height_out,
                           char *err, size_t err_size) {
    if (width_out) *width_out = 0;
    if (height_out) *height_out = 0;
    if (!path || !*path) { set_error(err, err_size, path ? path : "", "no input file name given"); return NULL; }
    if (!channel || !*channel) { set_error(err, err_size, path, "no channel name given"); return NULL; }

    char what[512];
    float *out = NULL;
    bool ok = false;
    exr_context_t ctxt = NULL;
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    bool dec_started = false;
    uint8_t *scratch = NULL;
    size_t scratch_size = 0;

    exr_context_initializer_t init = exr_initializer();
    exr_result_t rv = exr_start_read(&ctxt, path, &init);
    if (rv != EXR_ERR_SUCCESS) { set_exr_error(err, err_size, path, "cannot read as OpenEXR", rv); goto done; }

    const int part = 0;
    exr_storage_t storage;
    rv = exr_get_storage(ctxt, part, &storage);
    if (rv != EXR_ERR_SUCCESS) { set_exr_error(err, err_size, path, "cannot read the EXR storage type", rv); goto done; }
    if (storage != EXR_STORAGE_SCANLINE) {
        set_error(err, err_size, path, storage == EXR_STORAGE_TILED ? "tiled EXR files are not supported (scanline only)"
                                                                    : "deep EXR files are not supported (scanline only)");
        goto done;
    }

    const exr_attr_chlist_t *chl = NULL;
    rv = exr_get_channels(ctxt, part, &chl);
    if (rv != EXR_ERR_SUCCESS || !chl) { set_exr_error(err, err_size, path, "cannot read the channel list", rv); goto done; }
    const exr_attr_chlist_entry_t *entry = NULL;
    for (int i = 0; i < chl->num_channels; i++)
        if (attr_string_is(&chl->entries[i].name, channel)) entry = &chl->entries[i];
    if (!entry) {
        char have[256];
        list_channels(chl, have, sizeof have);
        snprintf(what, sizeof what, "no channel \"%s\" (the file has: %s)", channel, have);
        set_error(err, err_size, path, what);
        goto done;
    }
    if (entry->pixel_type != EXR_PIXEL_HALF && entry->pixel_type != EXR_PIXEL_FLOAT) {
        snprintf(what, sizeof what, "channel \"%s\" holds integers, not HALF or FLOAT radiance", channel);
        set_error(err, err_size, path, what);
        goto done;
    }
    if (entry->x_sampling != 1 || entry->y_sampling != 1) {
        snprintf(what, sizeof what, "channel \"%s\" is subsampled (%dx%d), which is not supported", channel,
                 entry->x_sampling, entry->y_sampling);
        set_error(err, err_size, path, what);
        goto done;
    }

    exr_attr_box2i_t dw;
    rv = exr_get_data_window(ctxt, part, &dw);
    if (rv != EXR_ERR_SUCCESS) { set_exr_error(err, err_size, path, "cannot read the data window", rv); goto done; }
    int64_t w64 = (int64_t)dw.max.x - dw.min.x + 1, h64 = (int64_t)dw.max.y - dw.min.y + 1;
    if (w64 <= 0 || h64 <= 0 || w64 > INT32_MAX / 4 || h64 > INT_MAX ||
        (uint64_t)w64 * (uint64_t)h64 > SIZE_MAX / sizeof(float)) {
        set_error(err, err_size, path, "the data window is empty or too large");
        goto done;
    }
    const int width = (int)w64, height = (int)h64;
    int32_t lines_per_chunk = 0, chunks = 0;
    rv = exr_get_scanlines_per_chunk(ctxt, part, &lines_per_chunk);
    if (rv == EXR_ERR_SUCCESS) rv = exr_get_chunk_count(ctxt, part, &chunks);
    if (rv != EXR_ERR_SUCCESS || lines_per_chunk <= 0 || chunks <= 0 ||
        (int64_t)chunks * lines_per_chunk < h64) {
        set_exr_error(err, err_size, path, "cannot size the EXR chunks", rv);
        goto done;
    }

    out = malloc((size_t)width * height * sizeof(float));
    if (!out) { set_error(err, err_size, path, "out of memory for the channel"); goto done; }

    for (int32_t k = 0; k < chunks; k++) {
        int64_t y = (int64_t)dw.min.y + (int64_t)k * lines_per_chunk;
        if (y > dw.max.y) break;
        exr_chunk_info_t cinfo;
        rv = exr_read_scanline_chunk_info(ctxt, part, (int)y, &cinfo);
        if (rv != EXR_ERR_SUCCESS) {
            snprintf(what, sizeof what, "cannot read the chunk at line %lld", (long long)y);
            set_exr_error(err, err_size, path, what, rv);
            goto done;
        }
        /* the chunk table comes from the file: never trust it to stay inside the buffer */
        if (cinfo.start_y < dw.min.y || cinfo.height <= 0 || (int64_t)cinfo.start_y + cinfo.height - 1 > dw.max.y ||
            cinfo.width != width) {
            snprintf(what, sizeof what, "the chunk at line %lld lies outside the data window", (long long)y);
            set_error(err, err_size, path, what);
            goto done;
        }
        if (!dec_started) {
            dec_started = true;
            rv = exr_decoding_initialize(ctxt, part, &cinfo, &dec);
        } else {
            rv = exr_decoding_update(ctxt, part, &cinfo, &dec);
        }
        if (rv != EXR_ERR_SUCCESS) {
            snprintf(what, sizeof what, "cannot prepare to decode the chunk at line %lld", (long long)y);
            set_exr_error(err, err_size, path, what, rv);
            goto done;
        }
        /* Every channel gets a destination, the others a scratch area: OpenEXR 3.1's fast HALF to
         * FLOAT routines write all channels of the chunk and crash on a skipped (NULL) one. */
        size_t scratch_need = 0;
        for (int i = 0; i < dec.channel_count; i++) {
            const exr_coding_channel_info_t *chan = &dec.channels[i];
            if (chan->width < 0 || chan->height < 0 || chan->bytes_per_element <= 0) {
                set_error(err, err_size, path, "a chunk has a channel of invalid size");
                goto done;
            }
            scratch_need += (size_t)chan->width * (size_t)chan->height * (size_t)chan->bytes_per_element;
        }
        if (scratch_need == 0) scratch_need = 1;
        if (scratch_need > scratch_size) {
            void *bigger = realloc(scratch, scratch_need);
            if (!bigger) { set_error(err, err_size, path, "out of memory decoding a chunk"); goto done; }
            scratch = bigger;
            scratch_size = scratch_need;
        }
        uint8_t *next_scratch = scratch;
        bool found = false;
        for (int i = 0; i < dec.channel_count; i++) {
            exr_coding_channel_info_t *chan = &dec.channels[i];
            if (strcmp(chan->channel_name, channel) != 0 || found) {
                chan->user_bytes_per_element = chan->bytes_per_element;
                chan->user_data_type = chan->data_type;
                chan->user_pixel_stride = chan->bytes_per_element;
                chan->user_line_stride = chan->width * chan->bytes_per_element;
                chan->decode_to_ptr = next_scratch;
                next_scratch += (size_t)chan->width * (size_t)chan->height * (size_t)chan->bytes_per_element;
                continue;
            }
            if (chan->width != width || chan->height != cinfo.height) {
                set_error(err, err_size, path, "a chunk's channel size disagrees with the data window");
                goto done;
            }
            found = true;
            chan->user_bytes_per_element = 4;
            chan->user_data_type = EXR_PIXEL_FLOAT;
            chan->user_pixel_stride = 4;
            chan->user_line_stride = 4 * width;
            chan->decode_to_ptr = (uint8_t *)(out + (size_t)(cinfo.start_y - dw.min.y) * width);
        }
        if (!found) {
            snprintf(what, sizeof what, "channel \"%s\" missing from the chunk at line %lld", channel, (long long)y);
            set_error(err, err_size, path, what);
            goto done;
        }
        /* after the pointers: the routine chosen depends on the output layout */
        rv = exr_decoding_choose_default_routines(ctxt, part, &dec);
        if (rv == EXR_ERR_SUCCESS) rv = exr_decoding_run(ctxt, part, &dec);
        if (rv != EXR_ERR_SUCCESS) {
            snprintf(what, sizeof what, "cannot decode the chunk at line %lld", (long long)y);
            set_exr_error(err, err_size, path, what, rv);
            goto done;
        }
    }
    if (width_out) *width_out = width;
    if (height_out) *height_out = height;
    ok = true;

done:
    if (dec_started) exr_decoding_destroy(ctxt, &dec);
    if (ctxt) exr_finish(&ctxt);
    free(scratch);
    if (!ok) { free(out); out = NULL; }
    return out;
}

/* ---------------------------------------------------------------------------------------------- */

typedef struct {
    FILE *f;
    bool failed;
    int failed_errno;
} png_sink;

static void png_write_bytes(void *context, void *data, int size) {
    png_sink *s = context;
    if (!s->failed && size > 0 && fwrite(data, 1, (size_t)size, s->f) != (size_t)size) {
        s->failed = true;
        s->failed_errno = errno;
    }
}

bool pm_write_png(const char *path, int width, int height, const uint8_t *rgba, char *err, size_t err_size) {
    if (!path || !*path) { set_error(err, err_size, path ? path : "", "no output file name given"); return false; }
    if (width <= 0 || height <= 0 || width > INT_MAX / 4 || !rgba) {
        set_error(err, err_size, path, "cannot write a PNG of an empty or oversized image");
        return false;
    }
    char what[400];
    /* stb's encoder allocates inside the library: its share is admitted for it, before the target is touched */
    const uint64_t encoder_bytes = pm_png_write_bytes(width, height);
    if (!pm_memory_admit(encoder_bytes, "PNG encoder")) {
        snprintf(what, sizeof what, "out of memory (%s)", pm_memory_failure());
        set_error(err, err_size, path, what);
        return false;
    }
    /* our own FILE rather than stbi_write_png: stb reports only "failed", errno says why */
    png_sink sink = {fopen(path, "wb"), false, 0};
    if (!sink.f) {
        pm_memory_release(encoder_bytes);
        snprintf(what, sizeof what, "cannot create the file (%s)", strerror(errno));
        set_error(err, err_size, path, what);
        return false;
    }
    /* truncated now: a signal before the end removes it rather than leave half an image */
    const bool claimed = strlen(path) < sizeof partial_path && !atomic_flag_test_and_set(&partial_claimed);
    if (claimed) {
        memcpy(partial_path, path, strlen(path) + 1);
        atomic_thread_fence(memory_order_seq_cst);
        partial_armed = 1;
    }
    int encoded = stbi_write_png_to_func(png_write_bytes, &sink, width, height, 4, rgba, 4 * width);
    pm_memory_release(encoder_bytes);
    if (fclose(sink.f) != 0 && !sink.failed) { sink.failed = true; sink.failed_errno = errno; }
    if (!encoded || sink.failed) {
        if (!encoded) snprintf(what, sizeof what, "PNG encoding failed (out of memory?)");
        else snprintf(what, sizeof what, "cannot write the file (%s)", strerror(sink.failed_errno));
        set_error(err, err_size, path, what);
        remove(path); /* a truncated PNG would look like a valid file to a quick glance */
        disarm_partial(claimed);
        return false;
    }
    disarm_partial(claimed);
    return true;
}

/* path with its folder resolved (the name kept: it need not exist yet) into out; false when the
 * folder cannot be resolved. */
static bool resolved(const char *path, char *out, size_t size) {
    char folder[4096], real[PATH_MAX];
    folder_of(path, folder, sizeof folder);
    if (!realpath(folder, real)) return false;
    const char *slash = strrchr(path, '/'), *name = slash ? slash + 1 : path;
    int n = snprintf(out, size, "%s/%s", strcmp(real, "/") ? real : "", name);
    return n >= 0 && (size_t)n < size;
}

bool pm_same_file(const char *a, const char *b) {
    if (!a || !b) return false;
    struct stat sa, sb;
    if (stat(a, &sa) == 0 && stat(b, &sb) == 0) return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
    char ra[4200], rb[4200];
    if (resolved(a, ra, sizeof ra) && resolved(b, rb, sizeof rb)) return strcmp(ra, rb) == 0;
    return strcmp(a, b) == 0;
}

bool pm_has_extension(const char *path, const char *ext) {
    size_t n = strlen(path), e = strlen(ext);
    return n > e && strcasecmp(path + n - e, ext) == 0;
}

float *pm_read_environment(const char *path, int *width, int *height, char *err, size_t err_size) {
    char inner[512];
    if (pm_has_extension(path, ".hdr")) {
        int channels = 0;
        float *data = stbi_loadf(path, width, height, &channels, 3);
        if (!data) snprintf(err, err_size, "%s: cannot read the environment map (%s)", path, stbi_failure_reason());
        if (!data) return NULL;
        /* stb's buffer goes back to stb: hand the caller its own copy */
        size_t bytes = sizeof(float) * 3 * (size_t)*width * (size_t)*height;
        float *copy = malloc(bytes);
        if (copy) memcpy(copy, data, bytes);
        else snprintf(err, err_size, "%s: out of memory (environment map, %zu bytes)", path, bytes);
        stbi_image_free(data);
        return copy;
    }
    if (!pm_has_extension(path, ".exr")) {
        snprintf(err, err_size, "%s: an environment map must be .exr or .hdr", path);
        return NULL;
    }
    static const char *const names[3] = {"R", "G", "B"};
    float *channel[3] = {NULL, NULL, NULL};
    for (int c = 0; c < 3; c++) {
        int w = 0, h = 0;
        channel[c] = pm_read_exr_channel(path, names[c], &w, &h, inner, sizeof inner);
        if (channel[c] && c > 0 && (w != *width || h != *height)) {
            snprintf(inner, sizeof inner, "channels of different sizes");
            free(channel[c]);
            channel[c] = NULL;
        }
        if (!channel[c]) {
            snprintf(err, err_size, "%s: cannot read the environment map (%s)", path, inner);
            for (int k = 0; k < c; k++) free(channel[k]);
            return NULL;
        }
        *width = w;
        *height = h;
    }
    size_t n = (size_t)*width * (size_t)*height;
    float *rgb = malloc(sizeof(float) * 3 * n);
    if (!rgb) snprintf(err, err_size, "%s: out of memory (environment map, %zu bytes)", path, sizeof(float) * 3 * n);
    for (size_t i = 0; rgb && i < n; i++)
        for (int c = 0; c < 3; c++) rgb[3 * i + c] = channel[c][i];
    for (int c = 0; c < 3; c++) free(channel[c]);
    return rgb;
}

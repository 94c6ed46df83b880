/* image_io.c: the film to a multi-layer OpenEXR file (OpenEXR C API), EXR channels and environment maps (.exr, .hdr) back to floats, RGBA8 to PNG. */

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
/* realpath is XSI and O_TMPFILE Linux's, beyond the POSIX level the build asks for */
#define _GNU_SOURCE
#include "image_io.h"
#include "output_path.h"
#include "memory.h"

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
#include <time.h>
#include <unistd.h>

#include <openexr.h>
#include <stb/stb_image_write.h>

#include "memory.h"

#define PM_EXR_CHANNELS (3 + 3 * PM_COMPONENT_COUNT)

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

static void set_exr_error(char *err, size_t err_size, const char *path, const char *what, exr_result_t rv) {
    if (!err || err_size == 0) return;
    const char *detail = exr_detail[0] ? exr_detail : exr_get_default_error_message(rv);
    char with_detail[4096 + 512];
    snprintf(with_detail, sizeof with_detail, "%s (%s)", what, detail);
    pm_io_error(err, err_size, path, with_detail);
}

/* ---------------------------------------------------------------------------------------------- */

/* An EXR's bytes into the pending file. */
typedef struct {
    int fd;
} exr_sink;

static int64_t exr_sink_write(exr_const_context_t ctxt, void *userdata, const void *buffer, uint64_t size, uint64_t offset,
                              exr_stream_error_func_ptr_t error_cb) {
    const exr_sink *sink = userdata;
    const char *bytes = buffer;
    uint64_t done = 0;
    while (done < size) {
        ssize_t n = pwrite(sink->fd, bytes + done, (size_t)(size - done), (off_t)(offset + done));
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
            /* SIGXFSZ is ignored, so a file-size limit reads EFBIG here */
            error_cb(ctxt, EXR_ERR_WRITE_IO, "%s", n < 0 ? strerror(errno) : "nothing written");
            return -1;
        }
        done += (uint64_t)n;
    }
    return (int64_t)size;
}

/* The planes as an EXR into fd: 1 written, 0 failed (err says why), -1 abandoned for a signal
 * that came during a compressed write (pm_output_hurried()). */
static int encode_exr(const char *path, int fd, int width, int height, const float *planes,
                      char names[PM_EXR_CHANNELS][32], bool compress, char *err, size_t err_size) {
    const size_t npix = (size_t)width * height;
    int result = 0;
    exr_context_t ctxt = NULL;
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    bool enc_started = false;
    exr_sink sink = {fd};
    exr_context_initializer_t init = exr_initializer();
    init.user_data = &sink;
    init.write_fn = exr_sink_write;
    exr_result_t rv = exr_start_write(&ctxt, path, EXR_WRITE_FILE_DIRECTLY, &init);
    if (rv != EXR_ERR_SUCCESS) { set_exr_error(err, err_size, path, "cannot create the file", rv); goto done; }

    int part = 0;
    rv = exr_add_part(ctxt, "pmview", EXR_STORAGE_SCANLINE, &part);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_initialize_required_attr_simple(ctxt, part, width, height, compress ? EXR_COMPRESSION_ZIP : EXR_COMPRESSION_NONE);
    /* zlib's fastest level: float radiance barely compresses further (a 512 x 512 snapshot: 6.89 MB
     * against 6.85 MB at the library's default), and the default took 0.3 s more to write it */
    if (rv == EXR_ERR_SUCCESS && compress) rv = exr_set_zip_compression_level(ctxt, part, 1);
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
        if (compress && pm_output_hurried()) { result = -1; goto done; }
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
                pm_io_error(err, err_size, path, "the EXR encoder lists a channel that was never added");
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
    result = 1;

done:
    if (enc_started) exr_encoding_destroy(ctxt, &enc);
    if (ctxt) {
        /* exr_finish writes the chunk table: of no use to an abandoned write */
        if (result == 1) {
            rv = exr_finish(&ctxt);
            if (rv != EXR_ERR_SUCCESS) {
                set_exr_error(err, err_size, path, "cannot finish the file", rv);
                result = 0;
            }
        } else {
            exr_finish(&ctxt);
        }
    }
    return result;
}

/* The layers come from the film (resolved) or, without one, from `layers` as they are. */
static bool write_exr(const char *path, int width, int height, const pm_film *film,
                      const float *const layers[PM_COMPONENT_COUNT], char *err, size_t err_size) {
    if (!path || !*path) { pm_io_error(err, err_size, path ? path : "", "no output file name given"); return false; }
    if (width <= 0 || height <= 0) {
        pm_io_error(err, err_size, path, "cannot write an EXR of an empty film");
        return false;
    }
    if ((size_t)width > SIZE_MAX / sizeof(float) / PM_EXR_CHANNELS / (size_t)height || width > INT32_MAX / 4) {
        pm_io_error(err, err_size, path, "image too large for an EXR file");
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
    if (stat(path, &st) == 0 && S_ISREG(st.st_mode) && !pm_file_takes_writing(path, err, err_size)) return false;
    const uint64_t buffer_bytes = pm_exr_write_bytes(width, height);
    const uint64_t mark = pm_memory_failure_mark(); /* what this write meets, never an older failure */
    if (!pm_memory_admit(buffer_bytes, "EXR output buffers")) {
        char what[400];
        snprintf(what, sizeof what, "out of memory (%s)", pm_memory_failure_since_or(mark, "EXR output buffers"));
        pm_io_error(err, err_size, path, what);
        return false;
    }

    bool ok = false;
    float *planes = pm_malloc(PM_EXR_CHANNELS * npix * sizeof(float), "EXR output buffers");
    float *rgb = planes ? pm_malloc(3 * npix * sizeof(float), "EXR output buffers") : NULL;
    if (!planes || !rgb) {
        char what[400];
        snprintf(what, sizeof what, "out of memory (%s)", pm_memory_failure_since_or(mark, "EXR output buffers"));
        pm_io_error(err, err_size, path, what);
        goto done;
    }

    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        if (film) pm_film_resolve(film, (pm_component)c, rgb);
        else if (layers[c]) memcpy(rgb, layers[c], 3 * npix * sizeof(float));
        else memset(rgb, 0, 3 * npix * sizeof(float));
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

    /* A file beside the target, renamed over it at the end: a failed write leaves any previous
     * file untouched, and nothing of it is left on any failure (OpenEXR's own temporary file
     * outlived a failed rename), nor after a kill (pm_pending_output) */
    pm_pending_output out;
    if (!pm_output_open(path, &out, err, err_size)) goto done;
    for (;;) {
        bool compress = !pm_output_hurried();
        int written = encode_exr(path, out.fd, width, height, planes, names, compress, err, err_size);
        if (written >= 0) {
            ok = written == 1;
            break;
        }
        /* a signal during a compressed write: the same image again, uncompressed, from the start */
        if (ftruncate(out.fd, 0) != 0) {
            char what[320];
            snprintf(what, sizeof what, "cannot write the file (%s)", strerror(errno));
            pm_io_error(err, err_size, path, what);
            break;
        }
    }
    ok = pm_output_finish(path, &out, ok, err, err_size);

done:
    free(rgb);
    free(planes);
    pm_memory_release(buffer_bytes);
    return ok;
}

bool pm_write_exr(const char *path, const pm_film *film, char *err, size_t err_size) {
    if (!film) return write_exr(path, 0, 0, NULL, NULL, err, err_size);
    return write_exr(path, film->width, film->height, film, NULL, err, err_size);
}

bool pm_write_exr_layers(const char *path, int width, int height, const float *const layers[PM_COMPONENT_COUNT], char *err,
                         size_t err_size) {
    return write_exr(path, width, height, NULL, layers, err, err_size);
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

/* Input files are opened by name: stat says first whether it is one, since opening a FIFO (as
 * OpenEXR and fopen do) waits for a writer that never comes. */
static bool regular_file(const char *path, char *err, size_t err_size) {
    struct stat st;
    char what[320];
    if (stat(path, &st) != 0) {
        snprintf(what, sizeof what, "cannot open (%s)", strerror(errno));
        pm_io_error(err, err_size, path, what);
        return false;
    }
    if (S_ISREG(st.st_mode)) return true;
    const char *kind = S_ISDIR(st.st_mode)                         ? "a directory"
                       : S_ISFIFO(st.st_mode)                      ? "a FIFO"
                       : S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode) ? "a device"
                       : S_ISSOCK(st.st_mode)                      ? "a socket"
                                                                   : "something else";
    snprintf(what, sizeof what, "is %s, not a regular file", kind);
    pm_io_error(err, err_size, path, what);
    return false;
}

/* Opens path's header and checks what pmview can read of it, before a pixel is decoded: a
 * scanline part, each of the `count` channels named as HALF or FLOAT at full resolution, a data
 * window of a usable size. On success the caller finishes *ctxt. */
static bool exr_open_checked(const char *path, int count, const char *const names[], exr_context_t *ctxt,
                             exr_attr_box2i_t *dw, int *width, int *height, char *err, size_t err_size) {
    *ctxt = NULL;
    if (!path || !*path) { pm_io_error(err, err_size, path ? path : "", "no input file name given"); return false; }
    if (!regular_file(path, err, err_size)) return false;
    char what[512];
    exr_context_initializer_t init = exr_initializer();
    exr_result_t rv = exr_start_read(ctxt, path, &init);
    if (rv != EXR_ERR_SUCCESS) { set_exr_error(err, err_size, path, "cannot read as OpenEXR", rv); goto fail; }

    const int part = 0;
    exr_storage_t storage;
    rv = exr_get_storage(*ctxt, part, &storage);
    if (rv != EXR_ERR_SUCCESS) { set_exr_error(err, err_size, path, "cannot read the EXR storage type", rv); goto fail; }
    if (storage != EXR_STORAGE_SCANLINE) {
        pm_io_error(err, err_size, path, storage == EXR_STORAGE_TILED ? "tiled EXR files are not supported (scanline only)"
                                                                    : "deep EXR files are not supported (scanline only)");
        goto fail;
    }
    const exr_attr_chlist_t *chl = NULL;
    rv = exr_get_channels(*ctxt, part, &chl);
    if (rv != EXR_ERR_SUCCESS || !chl) { set_exr_error(err, err_size, path, "cannot read the channel list", rv); goto fail; }
    for (int k = 0; k < count; k++) {
        const exr_attr_chlist_entry_t *entry = NULL;
        for (int i = 0; i < chl->num_channels; i++)
            if (attr_string_is(&chl->entries[i].name, names[k])) entry = &chl->entries[i];
        if (!entry) {
            char have[256];
            list_channels(chl, have, sizeof have);
            snprintf(what, sizeof what, "no channel \"%s\" (the file has: %s)", names[k], have);
            pm_io_error(err, err_size, path, what);
            goto fail;
        }
        if (entry->pixel_type != EXR_PIXEL_HALF && entry->pixel_type != EXR_PIXEL_FLOAT) {
            snprintf(what, sizeof what, "channel \"%s\" holds integers, not HALF or FLOAT radiance", names[k]);
            pm_io_error(err, err_size, path, what);
            goto fail;
        }
        if (entry->x_sampling != 1 || entry->y_sampling != 1) {
            snprintf(what, sizeof what, "channel \"%s\" is subsampled (%dx%d), which is not supported", names[k],
                     entry->x_sampling, entry->y_sampling);
            pm_io_error(err, err_size, path, what);
            goto fail;
        }
    }
    rv = exr_get_data_window(*ctxt, part, dw);
    if (rv != EXR_ERR_SUCCESS) { set_exr_error(err, err_size, path, "cannot read the data window", rv); goto fail; }
    int64_t w64 = (int64_t)dw->max.x - dw->min.x + 1, h64 = (int64_t)dw->max.y - dw->min.y + 1;
    if (w64 <= 0 || h64 <= 0 || w64 > INT32_MAX / 4 || h64 > INT_MAX ||
        (uint64_t)w64 * (uint64_t)h64 > SIZE_MAX / sizeof(float) / (count > 0 ? (size_t)count : 1)) {
        pm_io_error(err, err_size, path, "the data window is empty or too large");
        goto fail;
    }
    *width = (int)w64;
    *height = (int)h64;
    return true;
fail:
    if (*ctxt) exr_finish(ctxt);
    *ctxt = NULL;
    return false;
}

bool pm_read_exr_size(const char *path, int count, const char *const channels[], int *width, int *height, char *err,
                      size_t err_size) {
    exr_context_t ctxt;
    exr_attr_box2i_t dw;
    if (!exr_open_checked(path, count, channels, &ctxt, &dw, width, height, err, err_size)) return false;
    exr_finish(&ctxt);
    return true;
}

/* A chunk's channels pointed at their places: names[k] at rows + k with `count` floats a pixel (rows:
 * the chunk's first line in the output), every other channel at the growing scratch area. */
static bool route_channels(const char *path, exr_decode_pipeline_t *dec, const exr_chunk_info_t *cinfo, int count,
                           const char *const names[], int width, float *rows, uint8_t **scratch, size_t *scratch_size,
                           long long y, char *err, size_t err_size) {
    char what[512];
    /* Every channel gets a destination, the others a scratch area: OpenEXR 3.1's fast HALF to
     * FLOAT routines write all channels of the chunk and crash on a skipped (NULL) one. */
    size_t scratch_need = 0;
    for (int i = 0; i < dec->channel_count; i++) {
        const exr_coding_channel_info_t *chan = &dec->channels[i];
        if (chan->width < 0 || chan->height < 0 || chan->bytes_per_element <= 0) {
            pm_io_error(err, err_size, path, "a chunk has a channel of invalid size");
            return false;
        }
        scratch_need += (size_t)chan->width * (size_t)chan->height * (size_t)chan->bytes_per_element;
    }
    if (scratch_need == 0) scratch_need = 1;
    if (scratch_need > *scratch_size) {
        void *bigger = pm_realloc(*scratch, scratch_need, "EXR decoding scratch");
        if (!bigger) { pm_io_error(err, err_size, path, "out of memory decoding a chunk"); return false; }
        *scratch = bigger;
        *scratch_size = scratch_need;
    }
    uint8_t *next_scratch = *scratch;
    unsigned found = 0; /* bit k: names[k] has its destination (a duplicate name in the file goes to scratch) */
    for (int i = 0; i < dec->channel_count; i++) {
        exr_coding_channel_info_t *chan = &dec->channels[i];
        int k = 0;
        while (k < count && (strcmp(chan->channel_name, names[k]) != 0 || (found >> k & 1u))) k++;
        if (k == count) {
            chan->user_bytes_per_element = chan->bytes_per_element;
            chan->user_data_type = chan->data_type;
            chan->user_pixel_stride = chan->bytes_per_element;
            chan->user_line_stride = chan->width * chan->bytes_per_element;
            chan->decode_to_ptr = next_scratch;
            next_scratch += (size_t)chan->width * (size_t)chan->height * (size_t)chan->bytes_per_element;
            continue;
        }
        if (chan->width != width || chan->height != cinfo->height) {
            pm_io_error(err, err_size, path, "a chunk's channel size disagrees with the data window");
            return false;
        }
        found |= 1u << k;
        chan->user_bytes_per_element = 4;
        chan->user_data_type = EXR_PIXEL_FLOAT;
        chan->user_pixel_stride = 4 * count;
        chan->user_line_stride = 4 * count * width;
        chan->decode_to_ptr = (uint8_t *)(rows + k);
    }
    for (int k = 0; k < count; k++)
        if (!(found >> k & 1u)) {
            snprintf(what, sizeof what, "channel \"%s\" missing from the chunk at line %lld", names[k], y);
            pm_io_error(err, err_size, path, what);
            return false;
        }
    return true;
}

/* The channels named, decoded together chunk by chunk: `count` floats a pixel, in the order named. */
static float *read_exr_channels(const char *path, int count, const char *const names[], int *width_out,
                                int *height_out, char *err, size_t err_size) {
    if (width_out) *width_out = 0;
    if (height_out) *height_out = 0;
    if (count < 1 || count > 32) { pm_io_error(err, err_size, path ? path : "", "1 to 32 channels can be read at once"); return NULL; }
    for (int k = 0; k < count; k++)
        if (!names[k] || !*names[k]) { pm_io_error(err, err_size, path ? path : "", "no channel name given"); return NULL; }

    char what[512];
    float *out = NULL;
    bool ok = false;
    exr_context_t ctxt = NULL;
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    bool dec_started = false;
    uint8_t *scratch = NULL;
    size_t scratch_size = 0;
    exr_attr_box2i_t dw;
    int width = 0, height = 0;
    if (!exr_open_checked(path, count, names, &ctxt, &dw, &width, &height, err, err_size)) return NULL;

    const int part = 0;
    int32_t lines_per_chunk = 0, chunks = 0;
    exr_result_t rv = exr_get_scanlines_per_chunk(ctxt, part, &lines_per_chunk);
    if (rv == EXR_ERR_SUCCESS) rv = exr_get_chunk_count(ctxt, part, &chunks);
    if (rv != EXR_ERR_SUCCESS || lines_per_chunk <= 0 || chunks <= 0 || (int64_t)chunks * lines_per_chunk < height) {
        set_exr_error(err, err_size, path, "cannot size the EXR chunks", rv);
        goto done;
    }

    size_t out_bytes = (size_t)width * height * (size_t)count * sizeof(float);
    out = pm_malloc(out_bytes, "EXR channels");
    if (!out) {
        snprintf(what, sizeof what, "out of memory for the channels (%zu bytes)", out_bytes);
        pm_io_error(err, err_size, path, what);
        goto done;
    }

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
            pm_io_error(err, err_size, path, what);
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
        if (!route_channels(path, &dec, &cinfo, count, names, width, out + ((size_t)(cinfo.start_y - dw.min.y) * width) * count,
                            &scratch, &scratch_size, (long long)y, err, err_size))
            goto done;
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

float *pm_read_exr_channel(const char *path, const char *channel, int *width, int *height, char *err, size_t err_size) {
    if (!channel || !*channel) {
        if (width) *width = 0;
        if (height) *height = 0;
        pm_io_error(err, err_size, path ? path : "", "no channel name given");
        return NULL;
    }
    const char *const names[1] = {channel};
    return read_exr_channels(path, 1, names, width, height, err, err_size);
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
    if (!path || !*path) { pm_io_error(err, err_size, path ? path : "", "no output file name given"); return false; }
    if (width <= 0 || height <= 0 || width > INT_MAX / 4 || !rgba) {
        pm_io_error(err, err_size, path, "cannot write a PNG of an empty or oversized image");
        return false;
    }
    char what[400];
    /* stb's encoder allocates inside the library: its share is admitted for it, before the target is touched */
    const uint64_t encoder_bytes = pm_png_write_bytes(width, height);
    const uint64_t mark = pm_memory_failure_mark(); /* what this write meets, never an older failure */
    if (!pm_memory_admit(encoder_bytes, "PNG encoder")) {
        snprintf(what, sizeof what, "out of memory (%s)", pm_memory_failure_since_or(mark, "PNG encoder"));
        pm_io_error(err, err_size, path, what);
        return false;
    }
    /* a regular file (or a new one) is replaced whole at the end, as an EXR is: a kill during the
     * write leaves the previous image (a checkpoint's) and nothing else; anything else (a device,
     * a pipe) is written in place */
    struct stat st;
    const bool in_place = stat(path, &st) == 0 && !S_ISREG(st.st_mode);
    if (!in_place && !pm_file_takes_writing_if_present(path, err, err_size)) {
        pm_memory_release(encoder_bytes);
        return false;
    }
    pm_pending_output out = {.fd = -1};
    png_sink sink = {NULL, false, 0};
    if (in_place) sink.f = fopen(path, "wb");
    else if (pm_output_open(path, &out, err, err_size)) {
        sink.f = fdopen(dup(out.fd), "wb");
        if (!sink.f) pm_output_finish(path, &out, false, err, err_size);
    } else {
        pm_memory_release(encoder_bytes);
        return false;
    }
    /* our own FILE rather than stbi_write_png: stb reports only "failed", errno says why */
    if (!sink.f) {
        pm_memory_release(encoder_bytes);
        snprintf(what, sizeof what, "cannot create the file (%s)", strerror(errno));
        pm_io_error(err, err_size, path, what);
        return false;
    }
    /* in place, truncated now: a signal before the end removes it rather than leave half an image */
    const bool claimed = in_place && pm_output_claim_in_place(path);
    int encoded = stbi_write_png_to_func(png_write_bytes, &sink, width, height, 4, rgba, 4 * width);
    pm_memory_release(encoder_bytes);
    if (fclose(sink.f) != 0 && !sink.failed) { sink.failed = true; sink.failed_errno = errno; }
    if (!encoded || sink.failed) {
        if (!encoded) snprintf(what, sizeof what, "PNG encoding failed (out of memory?)");
        else snprintf(what, sizeof what, "cannot write the file (%s)", strerror(sink.failed_errno));
        pm_io_error(err, err_size, path, what);
        if (in_place) remove(path); /* a truncated PNG would look like a valid file to a quick glance */
        else pm_output_finish(path, &out, false, NULL, 0);
        pm_output_release(claimed);
        return false;
    }
    pm_output_release(claimed);
    return in_place || pm_output_finish(path, &out, true, err, err_size);
}

/* ---- Radiance .hdr (RGBE) ----
 *
 * Read here rather than by stb_image, which fills the rows of a truncated file with black and
 * takes any file for one: a header with "#?RADIANCE" or "#?RGBE", lines up to a blank one, then
 * "-Y H +X W"; each row either run-length encoded (2, 2, W as two bytes, then each of the four
 * components as runs: a count above 128 repeats the next byte count - 128 times, else that many
 * bytes follow) or flat (four bytes a texel). */

#define HDR_MAX_HEADER 65536 /* bytes: a header that long is no Radiance header */

typedef struct {
    FILE *f;
    int width, height;
} hdr_file;

/* One header line without its newline; false at the end of the file or past the header's budget. */
static bool hdr_line(FILE *f, char *line, size_t size, size_t *budget) {
    size_t n = 0;
    for (int c; (c = getc(f)) != EOF;) {
        if (*budget == 0) return false;
        (*budget)--;
        if (c == '\n') { line[n] = '\0'; return true; }
        if (n + 1 < size) line[n++] = (char)c;
    }
    return false;
}

static bool hdr_open(const char *path, hdr_file *h, char *err, size_t err_size) {
    h->f = NULL;
    if (!regular_file(path, err, err_size)) return false;
    char what[400], line[256];
    h->f = fopen(path, "rb");
    if (!h->f) {
        snprintf(what, sizeof what, "cannot open (%s)", strerror(errno));
        pm_io_error(err, err_size, path, what);
        return false;
    }
    size_t budget = HDR_MAX_HEADER;
    if (!hdr_line(h->f, line, sizeof line, &budget) || (strncmp(line, "#?RADIANCE", 10) && strncmp(line, "#?RGBE", 6))) {
        pm_io_error(err, err_size, path, "not a Radiance .hdr file (it does not begin with #?RADIANCE or #?RGBE)");
        goto fail;
    }
    for (;;) {
        if (!hdr_line(h->f, line, sizeof line, &budget)) {
            pm_io_error(err, err_size, path, budget ? "the file ends inside its header (no blank line, no resolution line)"
                                                  : "the header does not end within 64 KiB");
            goto fail;
        }
        if (!line[0]) break;
        if (!strncmp(line, "FORMAT=", 7) && strcmp(line + 7, "32-bit_rle_rgbe")) {
            snprintf(what, sizeof what, "pixels of FORMAT=%.64s are not supported (32-bit_rle_rgbe only)", line + 7);
            pm_io_error(err, err_size, path, what);
            goto fail;
        }
    }
    long rows = 0, columns = 0;
    int used = 0;
    if (!hdr_line(h->f, line, sizeof line, &budget) || sscanf(line, "-Y %ld +X %ld%n", &rows, &columns, &used) != 2 ||
        line[used] != '\0') {
        snprintf(what, sizeof what, "the resolution line \"%.64s\" is not \"-Y HEIGHT +X WIDTH\" (other orientations are not supported)",
                 line);
        pm_io_error(err, err_size, path, what);
        goto fail;
    }
    if (rows < 1 || columns < 1 || rows > INT_MAX || columns > INT32_MAX / 4 ||
        (uint64_t)rows * (uint64_t)columns > SIZE_MAX / (3 * sizeof(float))) {
        snprintf(what, sizeof what, "the resolution line claims %ldx%ld texels, which is not usable", columns, rows);
        pm_io_error(err, err_size, path, what);
        goto fail;
    }
    h->width = (int)columns;
    h->height = (int)rows;
    return true;
fail:
    fclose(h->f);
    h->f = NULL;
    return false;
}

/* Row y's texels as RGBE bytes; false (err says where) when the file ends or the runs are broken. */
static bool hdr_row(const char *path, hdr_file *h, int y, uint8_t *rgbe, char *err, size_t err_size) {
    char what[200];
    const int w = h->width;
    int lead[4];
    for (int k = 0; k < 4; k++) lead[k] = getc(h->f);
    bool nothing = y == 0 && lead[0] == EOF;
    if (lead[3] == EOF) goto truncated;
    bool encoded = w >= 8 && w < 32768 && lead[0] == 2 && lead[1] == 2 && lead[2] < 128;
    if (!encoded) {
        for (int k = 0; k < 4; k++) rgbe[k] = (uint8_t)lead[k];
        size_t rest = 4 * ((size_t)w - 1);
        if (fread(rgbe + 4, 1, rest, h->f) != rest) goto truncated;
        return true;
    }
    if ((lead[2] << 8 | lead[3]) != w) {
        snprintf(what, sizeof what, "row %d of %d is encoded %d texels wide in a map %d wide", y + 1, h->height,
                 lead[2] << 8 | lead[3], w);
        pm_io_error(err, err_size, path, what);
        return false;
    }
    for (int k = 0; k < 4; k++) {
        for (int x = 0; x < w;) {
            int count = getc(h->f), value;
            if (count == EOF) goto truncated;
            if (count > 128) {
                count -= 128;
                if ((value = getc(h->f)) == EOF) goto truncated;
                if (x + count > w) goto broken;
                for (int i = 0; i < count; i++) rgbe[4 * (x + i) + k] = (uint8_t)value;
            } else {
                if (count == 0 || x + count > w) goto broken;
                for (int i = 0; i < count; i++) {
                    if ((value = getc(h->f)) == EOF) goto truncated;
                    rgbe[4 * (x + i) + k] = (uint8_t)value;
                }
            }
            x += count;
        }
    }
    return true;
truncated:
    if (nothing) snprintf(what, sizeof what, "the file ends after its header: no pixels (truncated or empty)");
    else snprintf(what, sizeof what, "the file ends in row %d of %d (truncated)", y + 1, h->height);
    pm_io_error(err, err_size, path, what);
    return false;
broken:
    snprintf(what, sizeof what, "bad run-length data in row %d of %d", y + 1, h->height);
    pm_io_error(err, err_size, path, what);
    return false;
}

static float *read_hdr(const char *path, int *width, int *height, char *err, size_t err_size) {
    hdr_file h;
    if (!hdr_open(path, &h, err, err_size)) return NULL;
    size_t n = (size_t)h.width * h.height;
    float *rgb = pm_malloc(3 * n * sizeof(float), "environment map texels");
    uint8_t *row = pm_malloc(4 * (size_t)h.width, "environment map row");
    bool ok = rgb && row;
    if (!ok) {
        char what[200];
        snprintf(what, sizeof what, "out of memory (environment map, %zu bytes)", 3 * n * sizeof(float));
        pm_io_error(err, err_size, path, what);
    }
    for (int y = 0; ok && y < h.height; y++) {
        ok = hdr_row(path, &h, y, row, err, err_size);
        float *out = rgb + 3 * (size_t)y * h.width;
        for (int x = 0; ok && x < h.width; x++) {
            const uint8_t *t = row + 4 * x;
            /* mantissas of 8 bits under a shared exponent biased by 128 */
            float scale = t[3] ? ldexpf(1.f, t[3] - (128 + 8)) : 0.f;
            for (int c = 0; c < 3; c++) out[3 * x + c] = t[c] * scale;
        }
    }
    fclose(h.f);
    free(row);
    if (!ok) { free(rgb); return NULL; }
    *width = h.width;
    *height = h.height;
    return rgb;
}

static const char *const rgb_channels[3] = {"R", "G", "B"};

bool pm_environment_size(const char *path, int *width, int *height, char *err, size_t err_size) {
    if (pm_has_extension(path, ".hdr")) {
        hdr_file h;
        if (!hdr_open(path, &h, err, err_size)) return false;
        /* at the least one byte a texel component, or a header that ends the file */
        int first = getc(h.f);
        fclose(h.f);
        if (first == EOF) {
            pm_io_error(err, err_size, path, "the file ends after its header: no pixels (truncated or empty)");
            return false;
        }
        *width = h.width;
        *height = h.height;
        return true;
    }
    if (!pm_has_extension(path, ".exr")) {
        pm_io_error(err, err_size, path, "an environment map must be .exr or .hdr");
        return false;
    }
    return pm_read_exr_size(path, 3, rgb_channels, width, height, err, err_size);
}

float *pm_read_environment(const char *path, int *width, int *height, char *err, size_t err_size) {
    *width = *height = 0;
    if (pm_has_extension(path, ".hdr")) return read_hdr(path, width, height, err, err_size);
    if (!pm_has_extension(path, ".exr")) {
        pm_io_error(err, err_size, path, "an environment map must be .exr or .hdr");
        return NULL;
    }
    return read_exr_channels(path, 3, rgb_channels, width, height, err, err_size);
}

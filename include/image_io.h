/* image_io.h: files out of the film and the view, multi-layer OpenEXR (C API) and PNG (stb_image_write), and the EXR and .hdr files read back in.
 *
 * EXR channels: R, G, B (the total) and direct.R/G/B, specular.R/G/B, caustic.R/G/B,
 * indirect.R/G/B, linear radiance, FLOAT, ZIP compression. The layers sum to the total.
 */
#ifndef PM_IMAGE_IO_H
#define PM_IMAGE_IO_H

#include <stdbool.h>
#include <signal.h>
#include <stddef.h>
#include <stdint.h>
#include "film.h"

/* Written to a file beside path, renamed over it at the end; an existing path must be a file the
 * user may write. Its buffers (pm_exr_write_bytes) are admitted against
 * --max-memory for the time of the write. */
bool pm_write_exr(const char *path, const pm_film *film, char *err, size_t err_size);
/* The same file from already resolved layers (width*height*3 floats each, NULL = black): an image
 * published for display, written as it is shown. */
bool pm_write_exr_layers(const char *path, int width, int height, const float *const layers[PM_COMPONENT_COUNT], char *err,
                         size_t err_size);

/* What the writers take beside their input while they write, admitted by them for that time: the
 * EXR writer's channel planes (72 bytes a pixel) and stb's PNG encoder. A caller that must know
 * before rendering that its file can be written admits these first and gives them back just
 * before the write. */
uint64_t pm_exr_write_bytes(int width, int height);
uint64_t pm_png_write_bytes(int width, int height);

/* For a SIGINT or SIGTERM handler: removes the file a writer has under way (a named temporary
 * file, a PNG begun in place on a device or pipe), if any. Async-signal-safe; the handler then
 * exits. Files are written unnamed where the file system allows (O_TMPFILE) and named only once
 * whole, so a kill (SIGKILL) at any moment leaves the previous file and nothing else. */
void pm_remove_partial_output(void);
/* A signal handler's flag: once set, EXRs are written uncompressed (several times faster: the
 * image must be on disk before mpirun's SIGKILL, 1 s after its SIGTERM), and a compressed write
 * under way when it is set starts again uncompressed. NULL: none. */
void pm_output_watch(volatile sig_atomic_t *flag);

/* Whether a and b name the same file: the same device and inode when both exist, else the same
 * path once their folders are resolved (links, "./" and ".." do not hide a match). */
bool pm_same_file(const char *a, const char *b);

/* Whether an output file can be written at path, checked before any work: not a directory, an
 * existing file writable by the user (the file written beside it must not replace a read-only
 * one), and a new file creatable in its folder. On refusal
 * err holds "PATH: the cause". Creates nothing that outlives the call. */
bool pm_check_output_path(const char *path, char *err, size_t err_size);

/* Reads one channel ("R", "direct.G", ...) of a scanline EXR into a malloc'ed w*h float array
 * (row 0 = top). For tests and tools; returns NULL with err set on failure. Every input file
 * here must be a regular file (a FIFO is refused rather than waited on). */
float *pm_read_exr_channel(const char *path, const char *channel, int *width, int *height,
                           char *err, size_t err_size);
/* The data window's size from the header alone (no pixel decoded), after checking that the
 * file is a scanline EXR whose `count` channels named are HALF or FLOAT at full resolution. */
bool pm_read_exr_size(const char *path, int count, const char *const channels[], int *width, int *height, char *err,
                      size_t err_size);

/* Whether path ends in ext (".exr", ...), ignoring case, with something before it. */
bool pm_has_extension(const char *path, const char *ext);

/* An equirectangular environment map as linear RGB floats (w*h*3, row 0 = top), malloc'ed:
 * .exr (its R, G, B channels) or .hdr (Radiance RGBE). NULL with err set on failure, "PATH: what
 * (where)": a .hdr without its signature, cut short ("the file ends in row 257 of 512") or with
 * broken runs is refused, never read as black. */
float *pm_read_environment(const char *path, int *width, int *height, char *err, size_t err_size);
/* The map's size from its header alone, to estimate its memory before any pixel is decoded; a
 * .hdr with no byte after its header is refused here already. */
bool pm_environment_size(const char *path, int *width, int *height, char *err, size_t err_size);

/* rgba: width*height*4 bytes, row 0 = top. The encoder's memory (pm_png_write_bytes) is admitted
 * against --max-memory for the time of the write. */
bool pm_write_png(const char *path, int width, int height, const uint8_t *rgba, char *err, size_t err_size);

#endif

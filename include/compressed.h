/* compressed.h: decoders for glTF's compressed geometry: EXT_meshopt_compression bufferViews (libmeshoptimizer) and KHR_draco_mesh_compression streams (libdraco).
 *
 * A C interface so the loader and C tests share it; src/compressed.cpp is the one unit that sees
 * Draco's C++ API. Every function checks what the libraries assert or leave to the caller (mode,
 * stride, counts, index ranges), so corrupt or hostile input gives false and one message in err
 * ("what went wrong", without the file or object, which the caller adds), never a crash.
 */
#ifndef PM_COMPRESSED_H
#define PM_COMPRESSED_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* EXT_meshopt_compression's "mode" and "filter" strings, as numbers. */
enum { PM_MESHOPT_ATTRIBUTES, PM_MESHOPT_TRIANGLES, PM_MESHOPT_INDICES, PM_MESHOPT_MODE_UNKNOWN };
enum { PM_MESHOPT_FILTER_NONE, PM_MESHOPT_FILTER_OCTAHEDRAL, PM_MESHOPT_FILTER_QUATERNION,
       PM_MESHOPT_FILTER_EXPONENTIAL, PM_MESHOPT_FILTER_UNKNOWN };
int pm_meshopt_mode(const char *name);   /* PM_MESHOPT_MODE_UNKNOWN for any other name */
int pm_meshopt_filter(const char *name); /* PM_MESHOPT_FILTER_UNKNOWN for any other name */

/* A decoded stream may be at most this many times its compressed size: meshopt's attribute codec
 * reaches 64 (constant data) and its index codecs less, so a larger claim is a lie about count. */
#define PM_MESHOPT_MAX_RATIO 64

/* Decodes count elements of stride bytes (count * stride bytes into dst) from src, then applies
 * the filter in place. The mode, stride and filter combinations the extension allows are checked
 * first (the library asserts on the others). */
bool pm_meshopt_decode(void *dst, size_t count, size_t stride, int mode, int filter, const void *src,
                       size_t src_size, char *err, size_t err_size);

/* A Draco decode gets PM_DRACO_SECONDS + stream bytes x PM_DRACO_SECONDS_PER_BYTE (a 10 MB stream:
 * 102 s; a valid stream decodes at about 5 MB a second, the Duck's in 2 ms); past that the stream
 * is refused (libdraco trusts some counts of a corrupt stream: see compressed.cpp). */
#define PM_DRACO_SECONDS 2.0
#define PM_DRACO_SECONDS_PER_BYTE 1e-5

/* What a Draco decode may hold at most, forecast from the counts its stream states before its
 * payload and from the stream's size (each attribute component of a vertex is a byte or two of
 * the stream and about 20 bytes while it decodes; the Duck's three attributes peak at 687 KB
 * against a forecast of 3.0 MB): admitted under --max-memory before the decode starts, and the
 * decode is refused when libdraco asks for more (a corrupt count). */
#define PM_DRACO_BASE_BYTES (1ull << 20)
#define PM_DRACO_BYTES_PER_VERTEX 256ull
#define PM_DRACO_BYTES_PER_FACE 256ull
#define PM_DRACO_BYTES_PER_STREAM_BYTE 32ull
uint64_t pm_draco_forecast_bytes(uint64_t vertices, uint64_t faces, uint64_t stream_bytes);

/* A decoded Draco mesh, until pm_draco_free. */
typedef struct pm_draco_mesh pm_draco_mesh;

/* Decodes a KHR_draco_mesh_compression stream holding a triangle mesh; NULL and err on failure. */
pm_draco_mesh *pm_draco_decode(const void *src, size_t size, char *err, size_t err_size);
void pm_draco_free(pm_draco_mesh *mesh);
/* How many streams pm_draco_decode was given since the process began (tests count the loader's decodes). */
uint64_t pm_draco_decodes(void);
uint64_t pm_draco_points(const pm_draco_mesh *mesh);    /* vertices: every attribute's count */
uint64_t pm_draco_triangles(const pm_draco_mesh *mesh); /* the index count is three times this */

/* Attribute `unique_id` (the extension's attribute id), pm_draco_points elements of `components`
 * glTF components of `component_type` (5120..5126), normalized integers scaled as glTF reads
 * them, into dst (points * components * component size bytes). False if the id is absent, its
 * component count differs, or a value cannot be read. */
bool pm_draco_attribute(const pm_draco_mesh *mesh, uint32_t unique_id, int component_type, int components,
                        bool normalized, void *dst, char *err, size_t err_size);

/* The triangles' corners, 3 x pm_draco_triangles indices of component_type (5121, 5123 or 5125)
 * into dst; false when an index is not below pm_draco_points or does not fit the type. */
bool pm_draco_indices(const pm_draco_mesh *mesh, int component_type, void *dst, char *err, size_t err_size);

#ifdef __cplusplus
}
#endif

#endif

/* fuzz_compressed_entry.h: one fuzz input through the compressed-geometry decoders (src/compressed.cpp), shared by the libFuzzer target and the regression replay.
 *
 * The first byte picks the decoder, the rest is the payload:
 *   even  a KHR_draco_mesh_compression stream: pm_draco_decode, then, when it decodes, every
 *         attribute id 0..7 read as each glTF component type with 1 to 4 components (normalized
 *         and not), and the indices as each index type;
 *   odd   an EXT_meshopt_compression stream: the second byte picks the mode (mod 3) and filter
 *         (mod 4), the third the stride (1 to 64), the next two the count (little-endian, up to
 *         65535); pm_meshopt_decode into a buffer of count x stride bytes.
 * A refused stream is a normal outcome; what counts is that nothing crashes, overflows, leaks or
 * runs away (libdraco's own time budget, PM_DRACO_SECONDS, bounds a stream it spins on).
 */
#ifndef PM_FUZZ_COMPRESSED_ENTRY_H
#define PM_FUZZ_COMPRESSED_ENTRY_H

#include <stdbool.h>
#include <stdint.h>
#include <stdlib.h>

#include "compressed.h"

/* What an input did: the replay test reports it. */
typedef struct {
    bool draco;
    bool accepted; /* the stream decoded */
    char error[512];
} pm_fuzz_compressed_result;

static pm_fuzz_compressed_result pm_fuzz_compressed_run(const uint8_t *data, size_t size) {
    pm_fuzz_compressed_result r = {false, false, ""};
    if (size < 1) return r;
    const uint8_t *payload = data + 1;
    size_t length = size - 1;
    if (data[0] % 2 == 0) {
        r.draco = true;
        pm_draco_mesh *mesh = pm_draco_decode(payload, length, r.error, sizeof r.error);
        if (!mesh) return r;
        r.accepted = true;
        uint64_t points = pm_draco_points(mesh), triangles = pm_draco_triangles(mesh);
        static const int types[] = {5120, 5121, 5122, 5123, 5125, 5126}, index_types[] = {5121, 5123, 5125};
        char err[512];
        /* at most 2^20 points or triangles are read back: larger decoded meshes are checked by counts alone */
        if (points <= (1u << 20)) {
            void *out = malloc(points * 4 * 4 + 1);
            for (uint32_t id = 0; out && id < 8; id++)
                for (int t = 0; t < 6; t++)
                    for (int components = 1; components <= 4; components++)
                        for (int normalized = 0; normalized < 2; normalized++)
                            pm_draco_attribute(mesh, id, types[t], components, normalized, out, err, sizeof err);
            free(out);
        }
        if (triangles <= (1u << 20)) {
            void *out = malloc(triangles * 3 * 4 + 1);
            for (int t = 0; out && t < 3; t++) pm_draco_indices(mesh, index_types[t], out, err, sizeof err);
            free(out);
        }
        pm_draco_free(mesh);
        return r;
    }
    if (length < 4) return r;
    int mode = payload[0] % 3, filter = (payload[0] / 3) % 4;
    size_t stride = 1 + payload[1] % 64, count = (size_t)payload[2] | (size_t)payload[3] << 8;
    void *out = malloc(count * stride + 1);
    if (!out) return r;
    r.accepted = pm_meshopt_decode(out, count, stride, mode, filter, payload + 4, length - 4, r.error, sizeof r.error);
    free(out);
    return r;
}

#endif

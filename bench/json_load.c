/* json_load.c: the loader on glTF files whose JSON is large (many nodes, many accessors): load time against the time of its one JSON parse.
 *
 * Usage: build/rel/json_load [NODES [MESHES]] — prints "bench json_load ..." lines. Each file is
 * built in memory: NODES nodes (100,000) placing one triangle, or MESHES meshes (50,000) each
 * with its own bufferView and accessor over one shared buffer. Each is loaded three times; the
 * fastest load is printed with the seconds its JSON parse took. load_over_parse is the load's cost
 * in JSON parses of its own text: a load that parsed the text twice could not go under 2.
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "loader.h"

typedef struct {
    char *text;
    size_t size, capacity;
} text_buffer;

static void append(text_buffer *b, const char *format, ...) {
    for (;;) {
        va_list args;
        va_start(args, format);
        int n = vsnprintf(b->text + b->size, b->capacity - b->size, format, args);
        va_end(args);
        if (n >= 0 && (size_t)n < b->capacity - b->size) {
            b->size += (size_t)n;
            return;
        }
        b->capacity = b->capacity * 2 + (size_t)(n > 0 ? n : 0) + 4096;
        b->text = realloc(b->text, b->capacity);
        if (!b->text) {
            fprintf(stderr, "json_load: out of memory\n");
            exit(1);
        }
    }
}

static const char base64_digits[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

static void append_base64(text_buffer *b, const unsigned char *bytes, size_t size) {
    for (size_t i = 0; i < size; i += 3) {
        unsigned v = (unsigned)bytes[i] << 16 | (i + 1 < size ? (unsigned)bytes[i + 1] << 8 : 0) | (i + 2 < size ? bytes[i + 2] : 0);
        char quad[5] = {base64_digits[v >> 18 & 63], base64_digits[v >> 12 & 63],
                        i + 1 < size ? base64_digits[v >> 6 & 63] : '=', i + 2 < size ? base64_digits[v & 63] : '=', 0};
        append(b, "%s", quad);
    }
}

/* triangles: one triangle per mesh, mesh i's at x = i */
static void append_buffer(text_buffer *b, size_t triangles) {
    size_t size = triangles * 36;
    float *positions = malloc(size);
    for (size_t i = 0; i < triangles; i++) {
        float t[9] = {(float)i, 0, 0, (float)i + 1, 0, 0, (float)i, 1, 0};
        memcpy(positions + 9 * i, t, sizeof t);
    }
    append(b, "\"buffers\":[{\"byteLength\":%zu,\"uri\":\"data:application/octet-stream;base64,", size);
    append_base64(b, (const unsigned char *)positions, size);
    append(b, "\"}],");
    free(positions);
}

static text_buffer many_nodes(size_t nodes) {
    text_buffer b = {0};
    append(&b, "{\"asset\":{\"version\":\"2.0\"},");
    append_buffer(&b, 1);
    append(&b, "\"bufferViews\":[{\"buffer\":0,\"byteLength\":36}],"
               "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]}],"
               "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0}}]}],\"nodes\":[");
    for (size_t i = 0; i < nodes; i++)
        append(&b, "%s{\"name\":\"node%zu\",\"mesh\":0,\"translation\":[%g,%g,%g]}", i ? "," : "", i, (double)(i % 100) * 1.5,
               (double)(i / 100 % 100) * 1.5, (double)(i / 10000) * 1.5);
    append(&b, "],\"scenes\":[{\"nodes\":[");
    for (size_t i = 0; i < nodes; i++) append(&b, "%s%zu", i ? "," : "", i);
    append(&b, "]}],\"scene\":0}");
    return b;
}

static text_buffer many_meshes(size_t meshes) {
    text_buffer b = {0};
    append(&b, "{\"asset\":{\"version\":\"2.0\"},");
    append_buffer(&b, meshes);
    append(&b, "\"bufferViews\":[");
    for (size_t i = 0; i < meshes; i++) append(&b, "%s{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":36}", i ? "," : "", 36 * i);
    append(&b, "],\"accessors\":[");
    for (size_t i = 0; i < meshes; i++)
        append(&b, "%s{\"bufferView\":%zu,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"min\":[%zu,0,0],\"max\":[%zu,1,0]}",
               i ? "," : "", i, i, i + 1);
    append(&b, "],\"meshes\":[");
    for (size_t i = 0; i < meshes; i++) append(&b, "%s{\"primitives\":[{\"attributes\":{\"POSITION\":%zu}}]}", i ? "," : "", i);
    append(&b, "],\"nodes\":[");
    for (size_t i = 0; i < meshes; i++) append(&b, "%s{\"mesh\":%zu}", i ? "," : "", i);
    append(&b, "],\"scenes\":[{\"nodes\":[");
    for (size_t i = 0; i < meshes; i++) append(&b, "%s%zu", i ? "," : "", i);
    append(&b, "]}],\"scene\":0}");
    return b;
}

static int measure(const char *label, text_buffer b) {
    double best = 0, best_parse = 0;
    uint32_t parses = 0, triangles = 0;
    for (int run = 0; run < 3; run++) {
        pm_scene s;
        pm_load_report report;
        char err[512];
        if (!pm_load_gltf_memory(b.text, b.size, label, true, &s, &report, err, sizeof err)) {
            fprintf(stderr, "json_load: %s\n", err);
            free(b.text);
            return 1;
        }
        triangles = s.triangle_count;
        pm_scene_free(&s);
        if (run == 0 || report.seconds < best) {
            best = report.seconds;
            best_parse = report.json_seconds;
            parses = report.json_parses;
        }
    }
    printf("bench json_load scene=%s json_mb=%.1f triangles=%u load_seconds=%.3f parse_seconds=%.3f parses=%u "
           "load_over_parse=%.2f\n",
           label, b.size / 1e6, triangles, best, best_parse, parses, best_parse > 0 ? best / best_parse : 0);
    free(b.text);
    return 0;
}

int main(int argc, char **argv) {
    size_t nodes = argc > 1 ? strtoul(argv[1], NULL, 10) : 100000;
    size_t meshes = argc > 2 ? strtoul(argv[2], NULL, 10) : 50000;
    char label[64];
    snprintf(label, sizeof label, "nodes%zu.gltf", nodes);
    if (measure(label, many_nodes(nodes))) return 1;
    snprintf(label, sizeof label, "meshes%zu.gltf", meshes);
    return measure(label, many_meshes(meshes));
}

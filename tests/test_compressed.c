/* test_compressed.c: the Draco and meshopt ducks in tests/models/duck load as the plain duck does, and corrupt or lying compressed streams give one clear error. */
#define _GNU_SOURCE
#include <dirent.h>
#include <stdint.h>
#include <string.h>
#include <time.h>

#include "compressed.h"
#include "loader.h"
#include "memory.h"
#include "testing.h"

#define DUCKS "tests/models/duck/"

typedef struct {
    unsigned char *data;
    size_t size;
} bytes;

static bytes read_file(const char *path) {
    bytes b = {NULL, 0};
    FILE *f = fopen(path, "rb");
    if (!f) return b;
    fseek(f, 0, SEEK_END);
    b.size = (size_t)ftell(f);
    fseek(f, 0, SEEK_SET);
    b.data = malloc(b.size);
    if (fread(b.data, 1, b.size, f) != b.size) b.size = 0;
    fclose(f);
    return b;
}

static int thread_count(void) {
    int n = 0;
    DIR *d = opendir("/proc/self/task");
    if (!d) return -1;
    for (struct dirent *e; (e = readdir(d));) n += e->d_name[0] != '.';
    closedir(d);
    return n;
}

static double now_seconds(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + t.tv_nsec * 1e-9;
}

static uint32_t u32(const unsigned char *p) { return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24; }
static void put32(unsigned char *p, uint32_t v) { for (int i = 0; i < 4; i++) p[i] = (unsigned char)(v >> (8 * i)); }

static char *replaced(const char *json, const char *from, const char *to);

/* A GLB split into its JSON text (NUL-terminated copy) and BIN chunk (pointing into the file). The
 * base colour texture is renamed out of use: its image is then not decoded on every load below. */
typedef struct {
    char *json;
    const unsigned char *bin;
    size_t bin_size;
} glb;

static glb split(bytes file) {
    glb g = {NULL, NULL, 0};
    uint32_t json_size = u32(file.data + 12);
    char *json = calloc(json_size + 1, 1);
    memcpy(json, file.data + 20, json_size);
    g.json = replaced(json, "\"baseColorTexture\"", "\"unusedColorTexture\"");
    free(json);
    g.bin = file.data + 20 + json_size + 8;
    g.bin_size = u32(file.data + 20 + json_size);
    return g;
}

/* json with the first occurrence of `from` replaced by `to` (fresh allocation); NULL when absent. */
static char *replaced(const char *json, const char *from, const char *to) {
    const char *at = strstr(json, from);
    if (!at) return NULL;
    size_t head = (size_t)(at - json), size = strlen(json) - strlen(from) + strlen(to);
    char *out = malloc(size + 1);
    memcpy(out, json, head);
    strcpy(out + head, to);
    strcat(out, at + strlen(from));
    return out;
}

/* A GLB of this JSON and BIN chunk. */
static bytes pack(const char *json, const unsigned char *bin, size_t bin_size) {
    size_t json_size = (strlen(json) + 3) / 4 * 4;
    bytes b;
    b.size = 12 + 8 + json_size + 8 + bin_size;
    b.data = malloc(b.size);
    memcpy(b.data, "glTF", 4);
    put32(b.data + 4, 2);
    put32(b.data + 8, (uint32_t)b.size);
    put32(b.data + 12, (uint32_t)json_size);
    put32(b.data + 16, 0x4E4F534Au);
    memset(b.data + 20, ' ', json_size);
    memcpy(b.data + 20, json, strlen(json));
    put32(b.data + 20 + json_size, (uint32_t)bin_size);
    put32(b.data + 24 + json_size, 0x004E4942u);
    memcpy(b.data + 28 + json_size, bin, bin_size);
    return b;
}

/* Loads bytes; on failure *err holds the message. */
static bool load(bytes b, pm_scene *scene, char *err, size_t err_size) {
    return pm_load_gltf_memory(b.data, b.size, "duck.glb", true, scene, NULL, err, err_size);
}

/* The load of json+bin fails with one line containing `want`. */
static void check_refused(const char *what, const char *json, const glb *g, const char *want) {
    CHECK(json != NULL, "%s: the text to change is in the JSON", what);
    if (!json) return;
    bytes b = pack(json, g->bin, g->bin_size);
    pm_scene scene;
    char err[1024];
    bool ok = load(b, &scene, err, sizeof err);
    CHECK(!ok, "%s: refused", what);
    if (ok) pm_scene_free(&scene);
    else CHECK(strstr(err, want) && !strchr(err, '\n') && !strncmp(err, "duck.glb: ", 10), "%s: error names '%s': %s", what, want, err);
    free(b.data);
}

/* The file with one piece of its JSON replaced (a lie about the compressed data) is refused with `want`. */
static void check_lie(const char *what, const glb *g, const char *from, const char *to, const char *want) {
    char *lie = replaced(g->json, from, to);
    check_refused(what, lie, g, want);
    free(lie);
}

static vec3 centroid(const pm_scene *s, uint32_t t) {
    const uint32_t *i = s->indices + 3 * t;
    return v3_scale(v3_add(v3_add(s->positions[i[0]], s->positions[i[1]]), s->positions[i[2]]), 1.f / 3);
}

/* The triangle whose centroid (of `count` in `centroids`) is nearest c. */
static uint32_t nearest_triangle(const vec3 *centroids, uint32_t count, vec3 c) {
    uint32_t best = 0;
    float best_d = INFINITY;
    for (uint32_t t = 0; t < count; t++) {
        vec3 d = v3_sub(centroids[t], c);
        float dd = v3_dot(d, d);
        if (dd < best_d) best_d = dd, best = t;
    }
    return best;
}

/* Every triangle of `got` matches one of `plain` corner by corner: position, shading normal and
 * base colour UV (the material's transform applied: gltfpack dequantizes UVs through one) within
 * the quantisation tolerances; prints the largest differences. */
static void compare_ducks(const char *name, const pm_scene *got, const pm_scene *plain, double tol_position,
                          double tol_normal, double tol_uv) {
    CHECK(got->triangle_count == plain->triangle_count, "%s: %u triangles, plain %u", name, got->triangle_count, plain->triangle_count);
    vec3 lo = v3(INFINITY, INFINITY, INFINITY), hi = v3(-INFINITY, -INFINITY, -INFINITY), plo = lo, phi = hi;
    for (uint32_t v = 0; v < got->vertex_count; v++) lo = v3_min(lo, got->positions[v]), hi = v3_max(hi, got->positions[v]);
    for (uint32_t v = 0; v < plain->vertex_count; v++) plo = v3_min(plo, plain->positions[v]), phi = v3_max(phi, plain->positions[v]);
    float extent = v3_length(v3_sub(phi, plo));
    CHECK(extent > 0, "%s: plain duck has an extent", name);
    CHECK(v3_length(v3_sub(lo, plo)) <= tol_position * extent && v3_length(v3_sub(hi, phi)) <= tol_position * extent,
          "%s: bounds (%g %g %g)-(%g %g %g), plain (%g %g %g)-(%g %g %g)", name, lo.x, lo.y, lo.z, hi.x, hi.y, hi.z,
          plo.x, plo.y, plo.z, phi.x, phi.y, phi.z);
    double worst_p = 0, worst_n = 0, worst_uv = 0;
    const float corner_b[3][2] = {{0, 0}, {1, 0}, {0, 1}};
    vec3 *centroids = malloc(plain->triangle_count * sizeof *centroids);
    for (uint32_t t = 0; t < plain->triangle_count; t++) centroids[t] = centroid(plain, t);
    for (uint32_t t = 0; t < got->triangle_count; t++) {
        const uint32_t *gi = got->indices + 3 * t;
        uint32_t pt = nearest_triangle(centroids, plain->triangle_count, centroid(got, t));
        const uint32_t *pi = plain->indices + 3 * pt;
        for (int k = 0; k < 3; k++) {
            int m = 0;  /* the plain corner nearest this one */
            for (int j = 1; j < 3; j++)
                if (v3_length(v3_sub(plain->positions[pi[j]], got->positions[gi[k]])) <
                    v3_length(v3_sub(plain->positions[pi[m]], got->positions[gi[k]])))
                    m = j;
            double dp = v3_length(v3_sub(plain->positions[pi[m]], got->positions[gi[k]])) / extent;
            double dn = v3_length(v3_sub(plain->normals[pi[m]], got->normals[gi[k]]));
            float gu, gv, pu, pv;
            pm_scene_texcoord(got, t, corner_b[k][0], corner_b[k][1], 0, &got->materials[0].base_color_transform, &gu, &gv);
            pm_scene_texcoord(plain, pt, corner_b[m][0], corner_b[m][1], 0, &plain->materials[0].base_color_transform, &pu, &pv);
            double duv = hypot(gu - pu, gv - pv);
            if (dp > worst_p) worst_p = dp;
            if (dn > worst_n) worst_n = dn;
            if (duv > worst_uv) worst_uv = duv;
        }
    }
    free(centroids);
    printf("%s: largest differences from the plain duck: position %.2g of the extent, normal %.2g, uv %.2g\n", name,
           worst_p, worst_n, worst_uv);
    CHECK(worst_p <= tol_position, "%s: position differs by %g of the extent", name, worst_p);
    CHECK(worst_n <= tol_normal, "%s: normal differs by %g", name, worst_n);
    CHECK(worst_uv <= tol_uv, "%s: uv differs by %g", name, worst_uv);
}

/* Flips bytes of the compressed range [offset, offset+length) of the BIN chunk at `flips` offsets
 * spread over it: each load succeeds (the stream still decodes, to other values) or fails with one
 * line naming `want`; returns how many failed. */
static int flip_bytes(const char *what, const glb *g, size_t offset, size_t length, int flips, const char *want) {
    unsigned char *bin = malloc(g->bin_size);
    int refused = 0;
    for (int f = 0; f < flips; f++) {
        memcpy(bin, g->bin, g->bin_size);
        size_t at = offset + (size_t)f * length / (size_t)flips;
        bin[at] ^= (unsigned char)(f % 2 ? 0xFF : 0x5A);
        bytes b = pack(g->json, bin, g->bin_size);
        pm_scene scene;
        char err[1024];
        if (load(b, &scene, err, sizeof err)) {
            pm_scene_free(&scene);
        } else {
            refused++;
            CHECK(!strchr(err, '\n') && (strstr(err, want) || strstr(err, "index ")),
                  "%s: byte %zu flipped: one line naming %s or an index: %s", what, at, want, err);
        }
        free(b.data);
    }
    free(bin);
    return refused;
}

static void test_meshopt_api(void) {
    /* what the library would assert on is refused first */
    unsigned char out[64], src[16] = {0};
    char err[256];
    CHECK(!pm_meshopt_decode(out, 4, 6, PM_MESHOPT_ATTRIBUTES, PM_MESHOPT_FILTER_NONE, src, sizeof src, err, sizeof err) &&
              strstr(err, "multiple of 4"), "ATTRIBUTES stride 6: %s", err);
    CHECK(!pm_meshopt_decode(out, 4, 2, PM_MESHOPT_TRIANGLES, PM_MESHOPT_FILTER_NONE, src, sizeof src, err, sizeof err) &&
              strstr(err, "multiple of 3"), "TRIANGLES count 4: %s", err);
    CHECK(!pm_meshopt_decode(out, 3, 8, PM_MESHOPT_TRIANGLES, PM_MESHOPT_FILTER_NONE, src, sizeof src, err, sizeof err) &&
              strstr(err, "2 or 4"), "TRIANGLES stride 8: %s", err);
    CHECK(!pm_meshopt_decode(out, 4, 4, PM_MESHOPT_ATTRIBUTES, PM_MESHOPT_FILTER_QUATERNION, src, sizeof src, err, sizeof err) &&
              strstr(err, "QUATERNION"), "QUATERNION stride 4: %s", err);
    CHECK(!pm_meshopt_decode(out, 3, 2, PM_MESHOPT_INDICES, PM_MESHOPT_FILTER_OCTAHEDRAL, src, sizeof src, err, sizeof err) &&
              strstr(err, "ATTRIBUTES"), "filter on INDICES: %s", err);
    CHECK(!pm_meshopt_decode(out, 16, 4, PM_MESHOPT_ATTRIBUTES, PM_MESHOPT_FILTER_NONE, src, 0, err, sizeof err) &&
              strstr(err, "times"), "64 bytes from an empty stream: %s", err);
    CHECK(!pm_meshopt_decode(out, 4, 4, PM_MESHOPT_ATTRIBUTES, PM_MESHOPT_FILTER_NONE, src, sizeof src, err, sizeof err) &&
              strstr(err, "corrupt"), "zero bytes are no vertex stream: %s", err);
    CHECK(pm_meshopt_mode("TRIANGLES") == PM_MESHOPT_TRIANGLES && pm_meshopt_mode("triangles") == PM_MESHOPT_MODE_UNKNOWN &&
              pm_meshopt_filter("EXPONENTIAL") == PM_MESHOPT_FILTER_EXPONENTIAL, "mode and filter names");
    CHECK(!pm_draco_decode(src, sizeof src, err, sizeof err) && strstr(err, "Draco"), "zeros are no Draco stream: %s", err);
}

int main(void) {
    test_meshopt_api();

    bytes plain_file = read_file(DUCKS "duck.glb"), draco_file = read_file(DUCKS "duck-draco.glb"),
          meshopt_file = read_file(DUCKS "duck-meshopt.glb");
    if (!plain_file.size || !draco_file.size || !meshopt_file.size) {
        CHECK(0, "the ducks in " DUCKS " (run from the repository root)");
        return pm_test_done("test_compressed");
    }
    pm_scene plain, draco, meshopt;
    char err[1024];
    CHECK(load(plain_file, &plain, err, sizeof err), "plain duck: %s", err);
    CHECK(load(draco_file, &draco, err, sizeof err), "Draco duck: %s", err);
    CHECK(load(meshopt_file, &meshopt, err, sizeof err), "meshopt duck: %s", err);
    if (pm_checks_failed) return pm_test_done("test_compressed");
    CHECK(plain.triangle_count == 4212, "the Duck has 4212 triangles, got %u", plain.triangle_count);
    /* quantisation: Draco's Duck has 11-bit positions (a step of 3.5e-4 of the diagonal), gltfpack
     * 14-bit positions, 8-bit normals and 12-bit UVs; a misplaced vertex would be off by far more */
    compare_ducks("Draco duck", &draco, &plain, 5e-4, 0.03, 1e-3);
    compare_ducks("meshopt duck", &meshopt, &plain, 1e-4, 0.03, 1e-3);
    pm_scene_free(&plain);
    pm_scene_free(&draco);
    pm_scene_free(&meshopt);

    /* Draco: the stream is bufferView 0 of the packed file */
    glb d = split(draco_file);
    size_t draco_length = 0;
    CHECK(sscanf(strstr(d.json, "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":") + 55, "%zu", &draco_length) == 1 &&
              draco_length > 1000 && draco_length <= d.bin_size && !memcmp(d.bin, "DRACO", 5),
          "the Draco stream at the start of the BIN chunk (%zu bytes)", draco_length);
    int refused = flip_bytes("Draco", &d, 0, draco_length, 48, "KHR_draco_mesh_compression");
    CHECK(refused > 0, "some flipped bytes make the Draco stream unreadable (%d of 48)", refused);
    printf("Draco: %d of 48 single-byte corruptions refused, the others decode\n", refused);
    for (const char *cut = "\"byteLength\":10366"; cut; cut = NULL) {
        const char *lengths[] = {"\"byteLength\":5000", "\"byteLength\":100", "\"byteLength\":8"};
        for (int i = 0; i < 3; i++) {
            char *j = replaced(d.json, cut, lengths[i]);
            check_refused("truncated Draco stream", j, &d, "mesh 0 primitive 0 KHR_draco_mesh_compression");
            free(j);
        }
    }
    {
        /* this byte makes libdraco count 2^31-ish texture-coordinate orientation bits (8 s, 160 MB,
         * and the decode thread was left running after the time budget refused it): the memory
         * the stream's counts forecast is its decode's budget, so it is refused at the first
         * allocation past it, at once, and its thread has ended when the refusal comes */
        unsigned char *bin = malloc(d.bin_size);
        memcpy(bin, d.bin, d.bin_size);
        bin[6052] = 0xbb;
        bytes b = pack(d.json, bin, d.bin_size);
        pm_scene scene;
        int threads_before = thread_count();
        double start = now_seconds();
        bool refused = !load(b, &scene, err, sizeof err);
        double seconds = now_seconds() - start;
        CHECK(refused && strstr(err, "the Draco stream asks for more than the 2.9 MiB its counts and size allow") &&
                  strstr(err, "(mesh 0 primitive 0 KHR_draco_mesh_compression"),
              "a stream that asks libdraco for 160 MB is refused by its budget: %s", err);
        CHECK(seconds < 1.0, "the corrupt count refused in %.2f s, want under 1 s (the time budget is 2.1 s)", seconds);
        CHECK(thread_count() == threads_before, "%d threads after the refusal, %d before: the decode thread was left running",
              thread_count(), threads_before);
        CHECK(pm_memory_committed() == 0, "%llu bytes still admitted after the refusal", (unsigned long long)pm_memory_committed());
        free(b.data);
        free(bin);
    }
    {
        /* the Draco decoder's memory under --max-memory: its forecast (from the stream's vertex
         * and face counts) is admitted before the decode; a limit below it refuses the stream in
         * one line naming the decoder, a limit above it lets the duck load */
        uint64_t forecast = pm_draco_forecast_bytes(2108, 4212, draco_length);
        pm_scene scene;
        bytes textureless = pack(d.json, d.bin, d.bin_size); /* the duck's image is not what is measured */
        pm_memory_set_limit(forecast / 2);
        pm_memory_clear_failure();
        CHECK(!load(textureless, &scene, err, sizeof err) && strstr(err, "a Draco stream of 2108 vertices and 4212 triangles: out of memory") &&
                  strstr(err, "the Draco decoder") && !strchr(err, '\n'),
              "the Draco duck under a limit of half its decoder's forecast: %s", err);
        CHECK(pm_memory_committed() == 0, "%llu bytes still admitted after the refusal", (unsigned long long)pm_memory_committed());
        pm_memory_set_limit(forecast + (64u << 20));
        bool ok = load(textureless, &scene, err, sizeof err);
        free(textureless.data);
        CHECK(ok, "the Draco duck under a limit of its forecast + 64 MiB: %s", err);
        if (ok) pm_scene_free(&scene);
        CHECK(pm_memory_committed() == 0, "%llu bytes still admitted once the duck is loaded and freed",
              (unsigned long long)pm_memory_committed());

        /* a stream whose header states 50 million vertices and 100 million triangles (a large
         * stream, or a lying one): refused under 64 MiB before libdraco is asked for anything.
         * Before, libdraco took 123 MB under a 16 MB limit for a large stream. */
        unsigned char header[32] = {'D', 'R', 'A', 'C', 'O', 2, 2, 1 /* mesh */, 1 /* edgebreaker */, 0, 0,
                                    0 /* traversal */};
        size_t n = 12;
        for (uint32_t v = 50000000u; ; v >>= 7) { header[n++] = (unsigned char)((v & 0x7f) | (v > 0x7f ? 0x80 : 0)); if (v <= 0x7f) break; }
        for (uint32_t v = 100000000u; ; v >>= 7) { header[n++] = (unsigned char)((v & 0x7f) | (v > 0x7f ? 0x80 : 0)); if (v <= 0x7f) break; }
        pm_memory_set_limit(64u << 20);
        pm_memory_clear_failure();
        double start = now_seconds();
        CHECK(!pm_draco_decode(header, sizeof header, err, sizeof err) &&
                  strstr(err, "a Draco stream of 50000000 vertices and 100000000 triangles: out of memory") &&
                  strstr(err, "--max-memory"),
              "a header of 5e7 vertices and 1e8 triangles under 64 MiB: %s", err);
        CHECK(now_seconds() - start < 0.1, "refused in %.3f s: not before the decode", now_seconds() - start);
        pm_memory_set_limit(0);
    }
    {
        /* 60 primitives of the placed mesh name the one stream, and an unused mesh's 60 primitives
         * name the PNG's bytes as theirs: the stream is decoded once, the unused mesh's never.
         * Before, every primitive decoded its stream again (9,000 primitives naming the Duck
         * took half a minute) and the unused ones were refused as corrupt. */
        const char *prim = "{\"attributes\":{\"NORMAL\":1,\"POSITION\":2,\"TEXCOORD_0\":3},\"indices\":0,\"mode\":4,\"material\":0,"
                           "\"extensions\":{\"KHR_draco_mesh_compression\":{\"bufferView\":0,\"attributes\":{\"NORMAL\":0,\"POSITION\":1,\"TEXCOORD_0\":2}}}}";
        enum { COPIES = 60 };
        size_t size = 2 * COPIES * (strlen(prim) + 2) + 64;
        char *used = calloc(size, 1), *unused = calloc(size, 1);
        strcpy(used, "\"primitives\":[");
        strcpy(unused, "\"name\":\"LOD3spShape\"},{\"primitives\":[");
        for (int i = 0; i < COPIES; i++) {
            strcat(strcat(used, prim), i + 1 < COPIES ? "," : "]");
            char *other = replaced(prim, "\"bufferView\":0", "\"bufferView\":1");
            strcat(strcat(unused, other), i + 1 < COPIES ? "," : "]");
            free(other);
        }
        char from[600];
        snprintf(from, sizeof from, "\"primitives\":[%s]", prim);
        char *j1 = replaced(d.json, from, used), *j2 = j1 ? replaced(j1, "\"name\":\"LOD3spShape\"", unused) : NULL;
        CHECK(j2 != NULL, "the Draco primitive and mesh name in the JSON");
        if (j2) {
            bytes b = pack(j2, d.bin, d.bin_size);
            pm_scene scene;
            uint64_t before = pm_draco_decodes();
            bool ok = load(b, &scene, err, sizeof err);
            uint64_t decodes = pm_draco_decodes() - before;
            CHECK(ok, "%d primitives naming one stream, an unused mesh naming a PNG: %s", COPIES, ok ? "" : err);
            CHECK(decodes == 1, "%d primitives naming one stream: %llu decodes (want 1)", COPIES, (unsigned long long)decodes);
            if (ok) {
                CHECK(scene.triangle_count == COPIES * 4212u, "%u triangles (want %d copies of the Duck's 4212)", scene.triangle_count, COPIES);
                pm_scene_free(&scene);
            }
            free(b.data);
        }
        free(j1), free(j2), free(used), free(unused);
    }
    check_lie("Draco attribute accessor count 2398", &d,
              "\"componentType\":5126,\"count\":2399", "\"componentType\":5126,\"count\":2398", "but the Draco stream decodes 2399 points");
    check_lie("Draco index accessor count 12639", &d, "\"count\":12636", "\"count\":12639", "decodes 12636 indices");
    check_lie("Draco indices as bytes", &d,
              "\"componentType\":5123,\"count\":12636", "\"componentType\":5121,\"count\":12636", "does not fit componentType 5121");
    check_lie("Draco attribute id not in the stream", &d,
              "\"POSITION\":1,", "\"POSITION\":7,", "Draco attribute 7 is not in the stream");
    free(d.json);

    /* meshopt: every compressed range named in the JSON */
    glb m = split(meshopt_file);
    const char *key = "\"EXT_meshopt_compression\":{\"buffer\":0,\"byteOffset\":";
    int streams = 0;
    for (const char *at = strstr(m.json, key); at; at = strstr(at + 1, key)) {
        size_t offset, length;
        if (sscanf(at + strlen(key), "%zu,\"byteLength\":%zu", &offset, &length) != 2 || offset + length > m.bin_size) {
            CHECK(0, "a meshopt range in the JSON");
            break;
        }
        streams++;
        /* its header byte: 0xa0 for attributes, 0xe1 for triangles; a flip there is always refused */
        CHECK(flip_bytes("meshopt header", &m, offset, 1, 1, "EXT_meshopt_compression") == 1, "meshopt stream %d: a flipped header is refused", streams);
        flip_bytes("meshopt", &m, offset, length, 12, "EXT_meshopt_compression");
        char from[128], to[128];
        snprintf(from, sizeof from, "\"byteOffset\":%zu,\"byteLength\":%zu", offset, length);
        snprintf(to, sizeof to, "\"byteOffset\":%zu,\"byteLength\":%zu", offset, length / 2);
        char *j = replaced(m.json, from, to);
        check_refused("truncated meshopt stream", j, &m, "EXT_meshopt_compression");
        free(j);
    }
    CHECK(streams == 4, "the meshopt duck has 4 compressed bufferViews, found %d", streams);
    check_lie("meshopt index count 12639", &m,
              "\"mode\":\"TRIANGLES\",\"count\":12636", "\"mode\":\"TRIANGLES\",\"count\":12639", "exceeds the bufferView's byteLength");
    check_lie("meshopt index count 12633", &m,
              "\"mode\":\"TRIANGLES\",\"count\":12636", "\"mode\":\"TRIANGLES\",\"count\":12633", "bufferView 4 EXT_meshopt_compression");
    /* a claim of gigabytes from a 4722-byte stream is refused before anything is allocated */
    char *big = replaced(m.json, "{\"byteLength\":63656,", "{\"byteLength\":4000000000,");
    char *big2 = big ? replaced(big, "\"byteLength\":25272,", "\"byteLength\":3000000000,") : NULL;
    char *big3 = big2 ? replaced(big2, "\"mode\":\"TRIANGLES\",\"count\":12636", "\"mode\":\"TRIANGLES\",\"count\":1500000000") : NULL;
    check_refused("meshopt claims 3 GB", big3, &m, "is over 64 times the 4722-byte stream");
    free(big), free(big2), free(big3);
    check_lie("bufferView stride other than the stream's", &m,
              "\"byteLength\":19192,\"byteStride\":8,", "\"byteLength\":19192,\"byteStride\":12,", "byteStride 8 but the bufferView's is 12 (bufferView 2 EXT_meshopt_compression)");
    check_lie("unknown meshopt filter", &m,
              "\"filter\":\"OCTAHEDRAL\"", "\"filter\":\"OCTAGONAL\"", "unknown filter OCTAGONAL (bufferView 1 EXT_meshopt_compression)");
    /* decoded indices meet the loader's own index check: with 2000 vertices, index 2398 is out of range */
    char *fewer = strdup(m.json);
    for (int i = 0; i < 3; i++) {
        char *next = replaced(fewer, "\"count\":2399,\"type\"", "\"count\":2000,\"type\"");
        CHECK(next != NULL, "vertex accessor %d", i);
        if (!next) break;
        free(fewer);
        fewer = next;
    }
    check_refused("decoded index past the vertices", fewer, &m, ">= vertex count 2000 (mesh 0 primitive 0)");
    free(fewer);
    /* a plain bufferView cannot point into the fallback buffer, which has no bytes */
    char *lie = replaced(m.json, "{\"buffer\":1,\"byteOffset\":0,\"byteLength\":9596,\"byteStride\":4,\"target\":34962,\"extensions\":{\"EXT_meshopt_compression\":{",
                   "{\"buffer\":1,\"byteOffset\":0,\"byteLength\":9596,\"byteStride\":4,\"target\":34962,\"extensions\":{\"EXT_other\":{");
    check_refused("plain bufferView in the fallback buffer", lie, &m, "a fallback buffer without data");
    free(lie);
    free(m.json);

    free(plain_file.data);
    free(draco_file.data);
    free(meshopt_file.data);
    return pm_test_done("test_compressed");
}

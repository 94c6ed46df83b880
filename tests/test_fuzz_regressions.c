/* test_fuzz_regressions.c: replays every input in tests/fuzz/regressions/ through the glTF fuzz entry (load from memory, set-up, accel, 8x8 render) and every one in tests/fuzz/regressions-inputs/ through the file-inputs entry (sky maps, references, writers) without libFuzzer, and checks the in-memory loader against the file loader.
 *
 * Built with gcc under ASan/UBSan like every test: a regression that crashes, overflows or leaks
 * again fails here; one that runs longer than PM_FUZZ_REPLAY_SECONDS has run away again.
 */
#define _DEFAULT_SOURCE
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "fuzz/fuzz_entry.h"
#include "fuzz/fuzz_inputs_entry.h"
#include "fuzz/fuzz_compressed_entry.h"
#include "testing.h"

#define PM_FUZZ_REPLAY_SECONDS 20.0  /* libFuzzer's -timeout is 30 s (tools/run-fuzz.sh) */
#define REGRESSIONS "tests/fuzz/regressions"
#define INPUT_REGRESSIONS "tests/fuzz/regressions-inputs"
#define COMPRESSED_REGRESSIONS "tests/fuzz/regressions-compressed"

static unsigned char *read_all(const char *path, size_t *size) {
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    size_t cap = 4096, n = 0;
    unsigned char *buf = malloc(cap);
    for (size_t got; buf && (got = fread(buf + n, 1, cap - n, f)) > 0;) {
        n += got;
        if (n == cap) {
            unsigned char *bigger = realloc(buf, cap *= 2);
            if (!bigger) { free(buf); buf = NULL; }
            buf = bigger;
        }
    }
    fclose(f);
    *size = n;
    return buf;
}

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

static const char *stage_name(pm_fuzz_stage s) {
    return s == PM_FUZZ_RENDERED ? "rendered" : s == PM_FUZZ_LOADED ? "loaded, set-up refused" : "refused";
}

static int by_name(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

/* Every file of the folder, sorted (a replay order that does not depend on the file system). */
static int list_files(const char *folder, char ***names) {
    DIR *d = opendir(folder);
    *names = NULL;
    if (!d) return -1;
    int n = 0, cap = 0;
    for (struct dirent *e; (e = readdir(d));) {
        if (e->d_name[0] == '.') continue;
        if (n == cap) {
            cap = cap ? 2 * cap : 64;
            *names = realloc(*names, cap * sizeof **names);
        }
        (*names)[n++] = strdup(e->d_name);
    }
    closedir(d);
    if (n) qsort(*names, n, sizeof **names, by_name);
    return n;
}

/* The in-memory entry against the file one, and the fuzz entry on inputs whose outcome is known. */
static void check_anchors(void) {
    size_t size = 0;
    unsigned char *box = read_all("scenes/cornell-box.gltf", &size);
    CHECK(box != NULL, "scenes/cornell-box.gltf is readable");
    if (!box) return;
    pm_scene from_file, from_memory;
    char err[512];
    bool file_ok = pm_load_gltf("scenes/cornell-box.gltf", true, &from_file, NULL, err, sizeof err);
    bool memory_ok = pm_load_gltf_memory(box, size, "cornell-box.gltf", true, &from_memory, NULL, err, sizeof err);
    CHECK(file_ok && memory_ok, "the Cornell box loads from its file and from memory: %s", err);
    uint32_t file_triangles = file_ok ? from_file.triangle_count : 0;
    if (file_ok && memory_ok) {
        CHECK(from_file.triangle_count == from_memory.triangle_count && from_file.vertex_count == from_memory.vertex_count &&
                  !memcmp(from_file.positions, from_memory.positions, from_file.vertex_count * sizeof(vec3)),
              "the same triangles from memory as from the file (%u and %u)", from_file.triangle_count,
              from_memory.triangle_count);
        pm_scene_free(&from_file);
        pm_scene_free(&from_memory);
    }
    /* the same JSON in a GLB container (a JSON chunk padded with spaces, no BIN chunk: its buffers are data: URIs) */
    size_t json_length = (size + 3) & ~(size_t)3, glb_size = 12 + 8 + json_length;
    unsigned char *glb = malloc(glb_size);
    const uint32_t header[5] = {0x46546C67u, 2, (uint32_t)glb_size, (uint32_t)json_length, 0x4E4F534Au};
    for (int k = 0; k < 5; k++)
        for (int byte = 0; byte < 4; byte++) glb[4 * k + byte] = (unsigned char)(header[k] >> (8 * byte));
    memcpy(glb + 20, box, size);
    memset(glb + 20 + size, ' ', json_length - size);
    memory_ok = pm_load_gltf_memory(glb, glb_size, "cornell-box.glb", true, &from_memory, NULL, err, sizeof err);
    CHECK(memory_ok && file_triangles > 0 && from_memory.triangle_count == file_triangles,
          "the Cornell box as a GLB from memory: %s (%u triangles, %u from the file)", err,
          memory_ok ? from_memory.triangle_count : 0, file_triangles);
    if (memory_ok) pm_scene_free(&from_memory);
    pm_fuzz_result r = pm_fuzz_run(glb, glb_size);
    printf("anchor cornell-box.glb (GLB from memory): %s, %u triangles\n", stage_name(r.stage), r.triangles);
    CHECK(r.stage == PM_FUZZ_RENDERED, "the fuzz entry renders the GLB (stage %d, %s)", r.stage, r.error);
    free(glb);
    r = pm_fuzz_run(box, size);
    printf("anchor cornell-box.gltf: %s, %u triangles, %llu non-finite values\n", stage_name(r.stage), r.triangles,
           (unsigned long long)r.nonfinite_values);
    CHECK(r.stage == PM_FUZZ_RENDERED && r.triangles > 0 && r.nonfinite_values == 0,
          "the fuzz entry renders the Cornell box (stage %d, %s)", r.stage, r.error);
    r = pm_fuzz_run(box, size / 2);
    printf("anchor cornell-box.gltf cut in half: %s (%s)\n", stage_name(r.stage), r.error);
    CHECK(r.stage == PM_FUZZ_REFUSED && strstr(r.error, "JSON"), "half a file is refused as bad JSON: %s", r.error);
    free(box);

    /* an external buffer cannot be read from memory: refused, naming why */
    static const char external[] =
        "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"uri\":\"box.bin\",\"byteLength\":4}]}";
    memory_ok = pm_load_gltf_memory(external, sizeof external - 1, "external.gltf", true, &from_memory, NULL, err, sizeof err);
    printf("anchor external buffer: %s\n", err);
    CHECK(!memory_ok && strstr(err, "external.gltf: ") == err && strstr(err, "unavailable when loading from memory"),
          "an external buffer is refused from memory: %s", err);
    memory_ok = pm_load_gltf_memory("", 0, "empty.glb", true, &from_memory, NULL, err, sizeof err);
    CHECK(!memory_ok && strstr(err, "empty file"), "empty input is refused: %s", err);
}

/* The file-inputs entry on inputs whose outcome is known: the writers' round trip, a sky map it
 * wrote, garbage as a sky and as a reference. */
static void check_input_anchors(void) {
    uint8_t film[1 + 3 + 16];
    film[0] = PM_FUZZ_INPUT_WRITERS;
    film[1] = 3;  /* 4 x 2 pixels, every layer */
    film[2] = 1;
    film[3] = 15;
    for (int i = 0; i < 16; i++) film[4 + i] = (uint8_t)(i < 4 ? (i == 3 ? 0x3f : 0) : 0x20 + i); /* 0.5f, then small floats */
    pm_fuzz_input_result r = pm_fuzz_inputs_run(film, sizeof film);
    printf("anchor writers (4x2 film): %s %s\n", r.accepted ? "written and read back" : "refused", r.error);
    CHECK(r.accepted, "the writers write a 4x2 film and read it back as a reference: %s", r.error);
    static const uint8_t garbage[] = {PM_FUZZ_INPUT_SKY_EXR, 'n', 'o', 't', ' ', 'a', 'n', ' ', 'e', 'x', 'r'};
    r = pm_fuzz_inputs_run(garbage, sizeof garbage);
    printf("anchor garbage sky: %s\n", r.error);
    CHECK(!r.accepted && r.error[0], "garbage as an .exr sky is refused with a reason: %s", r.error);
    uint8_t as_reference[sizeof garbage];
    memcpy(as_reference, garbage, sizeof garbage);
    as_reference[0] = PM_FUZZ_INPUT_REFERENCE;
    r = pm_fuzz_inputs_run(as_reference, sizeof as_reference);
    CHECK(!r.accepted && r.error[0], "garbage as a reference is refused with a reason: %s", r.error);
    static const char hdr[] = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n\x80\x80\x80\x81\x40\x40\x40\x81";
    uint8_t sky[1 + sizeof hdr - 1];
    sky[0] = PM_FUZZ_INPUT_SKY_HDR;
    memcpy(sky + 1, hdr, sizeof hdr - 1);
    r = pm_fuzz_inputs_run(sky, sizeof sky);
    printf("anchor 2x1 .hdr sky: %s %s\n", r.accepted ? "accepted" : "refused", r.error);
    CHECK(r.accepted, "a 2x1 Radiance sky is read and sampled: %s", r.error);
}

/* Every input of the file-inputs regressions, each within the time limit. */
static void replay_inputs(void) {
    char **names;
    int n = list_files(INPUT_REGRESSIONS, &names);
    CHECK(n >= 0, "%s is readable (run from the project root)", INPUT_REGRESSIONS);
    int accepted = 0;
    for (int i = 0; i < n; i++) {
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", INPUT_REGRESSIONS, names[i]);
        size_t size = 0;
        unsigned char *data = read_all(path, &size);
        CHECK(data != NULL, "%s is readable", path);
        if (data) {
            double start = now();
            pm_fuzz_input_result r = pm_fuzz_inputs_run(data, size);
            double seconds = now() - start;
            accepted += r.accepted;
            printf("%-60s %6zu bytes  kind %d  %s %.2f s  %s\n", names[i], size, r.kind, r.accepted ? "accepted" : "refused",
                   seconds, r.error);
            CHECK(seconds < PM_FUZZ_REPLAY_SECONDS, "%s takes %.1f s, limit %.0f s", names[i], seconds, PM_FUZZ_REPLAY_SECONDS);
            free(data);
        }
        free(names[i]);
    }
    free(names);
    printf("replayed %d file inputs: %d accepted\n", n > 0 ? n : 0, accepted);
    pm_memory_set_limit(0); /* the glTF entry runs under the default limit */
}

/* The compressed-decoders entry: the Draco duck's stream and its meshopt index stream decode
 * through it (the seeds run-fuzz.sh gives it), the same cut short are refused with a reason, and
 * every input of its regressions folder replays within the time limit. */
static void replay_compressed(void) {
    size_t size = 0;
    unsigned char *glb = read_all("tests/models/duck/duck-draco.glb", &size);
    CHECK(glb && size > 28, "the Draco duck is readable (run from the project root)");
    if (glb && size > 28) {
        uint32_t json = (uint32_t)glb[12] | (uint32_t)glb[13] << 8 | (uint32_t)glb[14] << 16 | (uint32_t)glb[15] << 24;
        const unsigned char *stream = glb + 20 + json + 8; /* bufferView 0: 10366 bytes at the BIN chunk's start */
        size_t length = 10366;
        CHECK(20 + json + 8 + length <= size && !memcmp(stream, "DRACO", 5), "the Draco stream opens the BIN chunk");
        unsigned char *input = malloc(length + 1);
        input[0] = 0;
        memcpy(input + 1, stream, length);
        pm_fuzz_compressed_result r = pm_fuzz_compressed_run(input, length + 1);
        CHECK(r.draco && r.accepted, "the Draco duck's stream through the compressed entry: %s", r.error);
        r = pm_fuzz_compressed_run(input, 1 + length / 3);
        CHECK(r.draco && !r.accepted && r.error[0], "a third of the Draco stream is refused with a reason: %s", r.error);
        free(input);
        /* meshopt, mode and filter bytes ahead of a stream that is not one */
        static const uint8_t meshopt[] = {1, 1, 5, 12, 0, 0xe1, 1, 2, 3};
        r = pm_fuzz_compressed_run(meshopt, sizeof meshopt);
        CHECK(!r.draco && !r.accepted && r.error[0], "garbage as a meshopt stream is refused with a reason: %s", r.error);
    }
    free(glb);
    char **names;
    int n = list_files(COMPRESSED_REGRESSIONS, &names);
    CHECK(n >= 0, "%s is readable (run from the project root)", COMPRESSED_REGRESSIONS);
    for (int i = 0; i < n; i++) {
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", COMPRESSED_REGRESSIONS, names[i]);
        unsigned char *data = read_all(path, &size);
        CHECK(data != NULL, "%s is readable", path);
        if (data) {
            double start = now();
            pm_fuzz_compressed_result r = pm_fuzz_compressed_run(data, size);
            double seconds = now() - start;
            printf("%-60s %6zu bytes  %s %s %.2f s  %s\n", names[i], size, r.draco ? "Draco" : "meshopt",
                   r.accepted ? "accepted" : "refused", seconds, r.error);
            CHECK(seconds < PM_FUZZ_REPLAY_SECONDS, "%s takes %.1f s, limit %.0f s", names[i], seconds, PM_FUZZ_REPLAY_SECONDS);
            free(data);
        }
        free(names[i]);
    }
    free(names);
    printf("replayed %d compressed-stream inputs\n", n > 0 ? n : 0);
}

int main(void) {
    check_anchors();
    check_input_anchors();
    replay_inputs();
    replay_compressed();
    char **names;
    int n = list_files(REGRESSIONS, &names);
    CHECK(n >= 0, "%s is readable (run from the project root)", REGRESSIONS);
    int counts[3] = {0, 0, 0};
    double slowest = 0;
    for (int i = 0; i < n; i++) {
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", REGRESSIONS, names[i]);
        size_t size = 0;
        unsigned char *data = read_all(path, &size);
        CHECK(data != NULL, "%s is readable", path);
        if (!data) continue;
        double start = now();
        pm_fuzz_result r = pm_fuzz_run(data, size);
        double seconds = now() - start;
        if (seconds > slowest) slowest = seconds;
        counts[r.stage]++;
        printf("%-60s %6zu bytes  %-22s %.2f s%s%s\n", names[i], size, stage_name(r.stage), seconds,
               r.error[0] ? "  " : "", r.error);
        CHECK(seconds < PM_FUZZ_REPLAY_SECONDS, "%s takes %.1f s, limit %.0f s (it ran away once)", names[i], seconds,
              PM_FUZZ_REPLAY_SECONDS);
        free(data);
        free(names[i]);
    }
    free(names);
    printf("criterion: every regression input runs to its end without a sanitizer report, each within %.0f s\n",
           PM_FUZZ_REPLAY_SECONDS);
    printf("replayed %d inputs: %d refused, %d loaded but refused at set-up, %d rendered; slowest %.2f s\n", n > 0 ? n : 0,
           counts[0], counts[1], counts[2], slowest);
    return pm_test_done("test_fuzz_regressions");
}

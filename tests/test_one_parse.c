/* test_one_parse.c: the loader parses a glTF's JSON text once, and both its checks and tinygltf's Model come from that parse.
 *
 * The load report counts the parses (json_parses): one for a file that loads, one for a file the
 * preflight refuses, one for a file refused while the Model is built from the checked document,
 * none for a GLB whose container is refused before its JSON is reached. A parse outside the
 * loader's parse_json would not be counted, so the loader's source is read too: one json::parse,
 * no tinygltf JsonParse and no TinyGLTF object, whose every entry parses the text again.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "loader.h"
#include "testing.h"

/* one triangle, (0,0,0) (1,0,0) (0,1,0); BUFFER is the buffer object, EXTRA more top-level members */
#define TRIANGLE(BUFFER, NODE_MESH, EXTRA)                                                                 \
    "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[" BUFFER "],"                                          \
    "\"bufferViews\":[{\"buffer\":0,\"byteLength\":36}],"                                                  \
    "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\","             \
    "\"min\":[0,0,0],\"max\":[1,1,0]}" EXTRA "],"                                                          \
    "\"nodes\":[{\"mesh\":" NODE_MESH "}],\"scenes\":[{\"nodes\":[0]}],\"scene\":0,"
#define DATA_BUFFER "{\"byteLength\":36,\"uri\":\"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA\"}"
#define PLAIN_MESH "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0}}]}]}"

typedef struct {
    bool ok;
    char err[512];
    pm_load_report report;
    pm_scene scene;
} outcome;

static outcome load_memory(const void *bytes, size_t size, const char *name) {
    outcome o;
    memset(&o, 0, sizeof o);
    o.ok = pm_load_gltf_memory(bytes, size, name, true, &o.scene, &o.report, o.err, sizeof o.err);
    return o;
}

static void put_u32(unsigned char *p, uint32_t v) {
    for (int i = 0; i < 4; i++) p[i] = (unsigned char)(v >> (8 * i));
}

/* A GLB of json (padded with spaces) and a BIN chunk of bin_size bytes (0: none). */
static unsigned char *make_glb(const char *json, const unsigned char *bin, uint32_t bin_size, size_t *size) {
    uint32_t json_size = (uint32_t)strlen(json), json_padded = (json_size + 3) & ~3u;
    uint32_t total = 12 + 8 + json_padded + (bin_size ? 8 + bin_size : 0);
    unsigned char *g = calloc(1, total);
    memcpy(g, "glTF", 4);
    put_u32(g + 4, 2);
    put_u32(g + 8, total);
    put_u32(g + 12, json_padded);
    put_u32(g + 16, 0x4E4F534Au);
    memset(g + 20, ' ', json_padded);
    memcpy(g + 20, json, json_size);
    if (bin_size) {
        put_u32(g + 20 + json_padded, bin_size);
        put_u32(g + 24 + json_padded, 0x004E4942u);
        memcpy(g + 28 + json_padded, bin, bin_size);
    }
    *size = total;
    return g;
}

static void check_triangle(const outcome *o, const char *what) {
    CHECK(o->ok, "%s: %s", what, o->err);
    if (!o->ok) return;
    CHECK(o->scene.triangle_count == 1 && o->scene.vertex_count == 3, "%s: %u triangles, %u vertices", what,
          o->scene.triangle_count, o->scene.vertex_count);
    if (o->scene.vertex_count != 3) return;
    const float want[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    for (int v = 0; v < 3; v++) {
        vec3 p = o->scene.positions[v];
        CHECK(p.x == want[3 * v] && p.y == want[3 * v + 1] && p.z == want[3 * v + 2], "%s: vertex %d at (%g, %g, %g)",
              what, v, p.x, p.y, p.z);
    }
}

static void check_parses(const outcome *o, uint32_t want, const char *what) {
    CHECK(o->report.json_parses == want, "%s: the JSON was parsed %u times, want %u", what, o->report.json_parses, want);
    CHECK(o->report.json_seconds >= 0 && o->report.json_seconds <= o->report.seconds,
          "%s: parse %g s of a load of %g s", what, o->report.json_seconds, o->report.seconds);
}

static void check_error(const outcome *o, const char *want, const char *what) {
    CHECK(!o->ok, "%s: loaded", what);
    CHECK(strcmp(o->err, want) == 0, "%s: error \"%s\", want \"%s\"", what, o->err, want);
}

static size_t count_of(const char *text, const char *needle) {
    size_t n = 0;
    for (const char *p = strstr(text, needle); p; p = strstr(p + 1, needle)) n++;
    return n;
}

/* The loader's source: the one parse is in parse_json, and nothing hands the text to tinygltf. */
static void check_source(void) {
    FILE *f = fopen("src/gltf_loader.cpp", "rb");
    CHECK(f != NULL, "src/gltf_loader.cpp cannot be read from the repository's root");
    if (!f) return;
    fseek(f, 0, SEEK_END);
    long size = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *text = malloc((size_t)size + 1);
    size_t got = fread(text, 1, (size_t)size, f);
    fclose(f);
    text[got] = '\0';
    CHECK(count_of(text, "json::parse(") == 1, "json::parse( appears %zu times in the loader, want 1 (parse_json)",
          count_of(text, "json::parse("));
    CHECK(count_of(text, "JsonParse(") == 0, "tinygltf's JsonParse is called %zu times", count_of(text, "JsonParse("));
    /* every TinyGLTF entry (LoadASCIIFromString, LoadBinaryFromMemory, ...) parses the text itself;
     * "TinyGLTF::" only names them in comments */
    size_t objects = count_of(text, "TinyGLTF") - count_of(text, "TinyGLTF::");
    CHECK(objects == 0, "the loader names tinygltf::TinyGLTF %zu times other than as TinyGLTF::", objects);
    free(text);
}

int main(void) {
    {
        const char *json = TRIANGLE(DATA_BUFFER, "0", "") PLAIN_MESH;
        outcome o = load_memory(json, strlen(json), "triangle.gltf");
        check_triangle(&o, "a .gltf");
        check_parses(&o, 1, "a .gltf");
        pm_scene_free(&o.scene);
    }
    {
        const float positions[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
        const char *json = TRIANGLE("{\"byteLength\":36}", "0", "") PLAIN_MESH;
        size_t size;
        unsigned char *glb = make_glb(json, (const unsigned char *)positions, sizeof positions, &size);
        outcome o = load_memory(glb, size, "triangle.glb");
        check_triangle(&o, "a .glb");
        check_parses(&o, 1, "a .glb");
        pm_scene_free(&o.scene);
        /* the container refused before the JSON is reached: nothing parsed */
        put_u32(glb + 8, (uint32_t)size + 4);
        o = load_memory(glb, size, "triangle.glb");
        char want[128];
        snprintf(want, sizeof want, "triangle.glb: truncated GLB: header length %zu > file size %zu", size + 4, size);
        check_error(&o, want, "a GLB longer than its file");
        check_parses(&o, 0, "a GLB longer than its file");
        free(glb);
    }
    {
        /* refused by the preflight, on the parsed document */
        const char *json = TRIANGLE(DATA_BUFFER, "5", "") PLAIN_MESH;
        outcome o = load_memory(json, strlen(json), "bad.gltf");
        check_error(&o, "bad.gltf: mesh 5 does not exist (node 0)", "a node's mesh out of range");
        check_parses(&o, 1, "a node's mesh out of range");
    }
    {
        /* refused while the Model is built from the checked document: an index accessor without a
         * bufferView (tinygltf's own refusal, kept word for word) */
        const char *json = TRIANGLE(DATA_BUFFER, "0", ",{\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}")
            "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1}]}]}";
        outcome o = load_memory(json, strlen(json), "indices.gltf");
        check_error(&o, "indices.gltf: tinygltf: accessor[1] invalid bufferView", "indices without a bufferView");
        check_parses(&o, 1, "indices without a bufferView");
    }
    {
        const char *json = "{\"asset\":{\"version\":\"2.0\"},}";
        outcome o = load_memory(json, strlen(json), "syntax.gltf");
        CHECK(!o.ok && strstr(o.err, "syntax.gltf: JSON syntax error: ") == o.err, "a syntax error: \"%s\"", o.err);
        check_parses(&o, 1, "a syntax error");
    }
    {
        /* from a file, through the file-system hooks */
        pm_scene s;
        pm_load_report report;
        char err[512];
        bool ok = pm_load_gltf("scenes/cornell-box.gltf", true, &s, &report, err, sizeof err);
        CHECK(ok, "scenes/cornell-box.gltf: %s", err);
        CHECK(report.json_parses == 1, "scenes/cornell-box.gltf: parsed %u times", report.json_parses);
        if (ok) pm_scene_free(&s);
    }
    check_source();
    return pm_test_done("test_one_parse");
}

/* test_loader.c: the glTF loader on small files written here: transforms, winding, normals, indices, strips, textures (sets, transforms, data textures), quantized meshes, cameras, lights (spot cones), materials, clamp and repair warnings naming their object and field, rejections.
 *
 * Each test builds a glTF document in C (one mesh whose primitives' data go into a single base64
 * data: buffer), writes it into a mkdtemp folder, loads it with pm_load_gltf and checks the
 * pm_scene values against numbers worked out by hand. Rejection tests check the one-line error
 * ("PATH: what (where)") and that the scene was left empty.
 */
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "defaults.h"
#include "loader.h"
#include "testing.h"

/* In libstb; stb_image_write.h declares it only inside its implementation section. */
unsigned char *stbi_write_png_to_mem(const unsigned char *pixels, int stride_bytes, int x, int y, int n, int *out_len);

static char test_dir[64];

/* ---------------------------------------------------------------- text and files */

typedef struct {
    char *data;
    size_t size, capacity;
} text;

static void text_append(text *t, const char *fmt, ...) {
    va_list args;
    va_start(args, fmt);
    int n = vsnprintf(NULL, 0, fmt, args);
    va_end(args);
    if (t->size + (size_t)n + 1 > t->capacity) {
        t->capacity = (t->size + (size_t)n + 1) * 2;
        t->data = realloc(t->data, t->capacity);
        if (!t->data) abort();
    }
    va_start(args, fmt);
    vsnprintf(t->data + t->size, (size_t)n + 1, fmt, args);
    va_end(args);
    t->size += (size_t)n;
}

static void base64_append(text *t, const unsigned char *bytes, size_t n) {
    static const char alphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    for (size_t i = 0; i < n; i += 3) {
        uint32_t v = (uint32_t)bytes[i] << 16 | (i + 1 < n ? (uint32_t)bytes[i + 1] << 8 : 0) |
                     (i + 2 < n ? bytes[i + 2] : 0);
        char quad[5] = {alphabet[v >> 18 & 63], alphabet[v >> 12 & 63], i + 1 < n ? alphabet[v >> 6 & 63] : '=',
                        i + 2 < n ? alphabet[v & 63] : '=', 0};
        text_append(t, "%s", quad);
    }
}

static void model_path(const char *name, char *path, size_t size) { snprintf(path, size, "%s/%s", test_dir, name); }

static void write_file(const char *path, const void *data, size_t size) {
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(data, 1, size, f) != size) {
        fprintf(stderr, "cannot write %s\n", path);
        exit(1);
    }
    fclose(f);
}

/* ---------------------------------------------------------------- a one-mesh glTF builder */

typedef struct {
    const float *positions; /* 3 per vertex */
    int vertex_count;
    const float *normals;   /* NULL: no NORMAL */
    const float *uvs;       /* NULL: no TEXCOORD_0 */
    int uv_type;            /* 0: float, 5121: normalized u8 (uvs given as floats in [0,1]) */
    const uint32_t *indices;
    int index_count;
    int index_type;         /* 0: no indices, else 5121 / 5123 / 5125 */
    int mode;               /* -1: absent (triangles) */
    int material;           /* -1: absent */
} prim_spec;

typedef struct {
    const char *nodes;       /* the nodes array; default [{"mesh":0}] */
    const char *scene_nodes; /* default [0] */
    const char *materials;   /* the materials array, or NULL */
    const char *extra;       /* more top-level members, each followed by a comma, or NULL */
} doc_spec;

typedef struct {
    unsigned char bytes[1 << 16];
    size_t size;
    text views, accessors;
    int view_count;
} blob;

/* Appends bytes as a new bufferView + accessor; returns the accessor index. */
static int blob_accessor(blob *b, const void *data, size_t size, int count, int component_type, const char *type,
                         int normalized) {
    b->size = (b->size + 3) & ~(size_t)3;
    if (b->size + size > sizeof b->bytes) abort();
    memcpy(b->bytes + b->size, data, size);
    text_append(&b->views, "%s{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}", b->view_count ? "," : "", b->size,
                size);
    text_append(&b->accessors, "%s{\"bufferView\":%d,\"componentType\":%d,\"count\":%d,\"type\":\"%s\"%s}",
                b->view_count ? "," : "", b->view_count, component_type, count, type,
                normalized ? ",\"normalized\":true" : "");
    b->size += size;
    return b->view_count++;
}

static void write_model(const char *name, const prim_spec *prims, int prim_count, const doc_spec *doc) {
    blob *b = calloc(1, sizeof *b);
    text primitives = {0}, json = {0};
    for (int p = 0; p < prim_count; p++) {
        const prim_spec *s = &prims[p];
        int n = s->vertex_count;
        text_append(&primitives, "%s{\"attributes\":{\"POSITION\":%d", p ? "," : "",
                    blob_accessor(b, s->positions, 12 * (size_t)n, n, 5126, "VEC3", 0));
        if (s->normals)
            text_append(&primitives, ",\"NORMAL\":%d", blob_accessor(b, s->normals, 12 * (size_t)n, n, 5126, "VEC3", 0));
        if (s->uvs && s->uv_type == 5121) {
            unsigned char packed[256];
            for (int i = 0; i < 2 * n; i++) packed[i] = (unsigned char)lroundf(s->uvs[i] * 255.f);
            text_append(&primitives, ",\"TEXCOORD_0\":%d", blob_accessor(b, packed, 2 * (size_t)n, n, 5121, "VEC2", 1));
        } else if (s->uvs) {
            text_append(&primitives, ",\"TEXCOORD_0\":%d", blob_accessor(b, s->uvs, 8 * (size_t)n, n, 5126, "VEC2", 0));
        }
        text_append(&primitives, "}");
        if (s->index_type) {
            unsigned char packed[1024];
            size_t size = s->index_type == 5121 ? 1 : s->index_type == 5123 ? 2 : 4;
            for (int i = 0; i < s->index_count; i++) {
                uint32_t v = s->indices[i];
                uint16_t v16 = (uint16_t)v;
                uint8_t v8 = (uint8_t)v;
                memcpy(packed + size * (size_t)i, size == 1 ? (void *)&v8 : size == 2 ? (void *)&v16 : (void *)&v, size);
            }
            text_append(&primitives, ",\"indices\":%d",
                        blob_accessor(b, packed, size * (size_t)s->index_count, s->index_count, s->index_type, "SCALAR", 0));
        }
        if (s->mode >= 0) text_append(&primitives, ",\"mode\":%d", s->mode);
        if (s->material >= 0) text_append(&primitives, ",\"material\":%d", s->material);
        text_append(&primitives, "}");
    }
    text_append(&json, "{\"asset\":{\"version\":\"2.0\"},%s\"scene\":0,\"scenes\":[{\"nodes\":%s}],\"nodes\":%s,",
                doc && doc->extra ? doc->extra : "", doc && doc->scene_nodes ? doc->scene_nodes : "[0]",
                doc && doc->nodes ? doc->nodes : "[{\"mesh\":0}]");
    if (doc && doc->materials) text_append(&json, "\"materials\":%s,", doc->materials);
    text_append(&json, "\"meshes\":[{\"primitives\":[%s]}],\"buffers\":[{\"byteLength\":%zu,\"uri\":\"data:application/octet-stream;base64,",
                primitives.data, b->size);
    base64_append(&json, b->bytes, b->size);
    text_append(&json, "\"}],\"bufferViews\":[%s],\"accessors\":[%s]}", b->views.data, b->accessors.data);
    char path[256];
    model_path(name, path, sizeof path);
    write_file(path, json.data, json.size);
    free(primitives.data);
    free(json.data);
    free(b->views.data);
    free(b->accessors.data);
    free(b);
}

static bool load(const char *name, pm_scene *s, pm_load_report *report, char *err, size_t err_size) {
    char path[256];
    model_path(name, path, sizeof path);
    return pm_load_gltf(path, true, s, report, err, err_size);
}

/* Loads a file that must load; on failure prints why and returns false. */
static bool load_ok(const char *name, pm_scene *s, pm_load_report *report) {
    char err[512];
    bool ok = load(name, s, report, err, sizeof err);
    CHECK(ok, "%s failed to load: %s", name, err);
    return ok;
}

static bool scene_is_empty(const pm_scene *s) {
    pm_scene zero;
    memset(&zero, 0, sizeof zero);
    return memcmp(s, &zero, sizeof zero) == 0;
}

/* A file that must be rejected with one line "PATH: ..." containing `expect`, leaving the scene empty. */
static void check_rejected(const char *name, const char *expect) {
    char path[256], err[512];
    model_path(name, path, sizeof path);
    pm_scene s;
    pm_load_report report;
    memset(&s, 0xAB, sizeof s);
    bool ok = pm_load_gltf(path, true, &s, &report, err, sizeof err);
    CHECK(!ok, "%s loaded but must be rejected (%s)", name, expect);
    if (ok) {
        pm_scene_free(&s);
        return;
    }
    CHECK(strncmp(err, path, strlen(path)) == 0 && strncmp(err + strlen(path), ": ", 2) == 0,
          "%s: error does not start with the path: %s", name, err);
    CHECK(strstr(err, expect) != NULL, "%s: error lacks \"%s\": %s", name, expect, err);
    CHECK(strchr(err, '\n') == NULL, "%s: error has a newline: %s", name, err);
    CHECK(scene_is_empty(&s), "%s: scene not left zeroed after a failure", name);
}

/* load_ok with the warnings printed (quiet off) and caught from stderr into `warnings`, a line each. */
static bool load_warned(const char *name, pm_scene *s, pm_load_report *report, char *warnings, size_t size) {
    char path[256], log[256], err[512];
    model_path(name, path, sizeof path);
    snprintf(log, sizeof log, "%s/warnings.txt", test_dir);
    FILE *f = fopen(log, "w+");
    if (!f) abort();
    fflush(stderr);
    int saved = dup(2);
    if (saved < 0 || dup2(fileno(f), 2) < 0) abort();
    bool ok = pm_load_gltf(path, false, s, report, err, sizeof err);
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    rewind(f);
    size_t n = fread(warnings, 1, size - 1, f);
    warnings[n] = '\0';
    fclose(f);
    CHECK(ok, "%s failed to load: %s", name, err);
    return ok;
}

/* Lines in text. */
static unsigned line_count(const char *text) {
    unsigned n = 0;
    for (; *text; text++) n += *text == '\n';
    return n;
}

/* A warning line holding `expect` must be in `warnings`. */
#define CHECK_WARNED(warnings, expect) \
    CHECK(strstr((warnings), (expect)) != NULL, "no warning says \"%s\"; got:\n%s", (expect), (warnings))

static void write_text(const char *name, const char *content) {
    char path[256];
    model_path(name, path, sizeof path);
    write_file(path, content, strlen(content));
}

static vec3 tri_vertex(const pm_scene *s, uint32_t tri, int k) { return s->positions[s->indices[3 * tri + k]]; }

static vec3 tri_geometric_normal(const pm_scene *s, uint32_t tri) {
    vec3 a = tri_vertex(s, tri, 0), b = tri_vertex(s, tri, 1), c = tri_vertex(s, tri, 2);
    return v3_normalize(v3_cross(v3_sub(b, a), v3_sub(c, a)));
}

#define CHECK_VEC(got, X, Y, Z, tol, what) do { \
    vec3 g__ = (got); \
    CHECK_NEAR(g__.x, (X), 0, (tol), what " x"); \
    CHECK_NEAR(g__.y, (Y), 0, (tol), what " y"); \
    CHECK_NEAR(g__.z, (Z), 0, (tol), what " z"); \
} while (0)

static const float unit_triangle[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};

/* ---------------------------------------------------------------- tests */

static void test_transforms(void) {
    prim_spec tri = {unit_triangle, 3, NULL, NULL, 0, NULL, 0, 0, -1, -1};
    pm_scene s;
    pm_load_report r;

    doc_spec matrix = {"[{\"mesh\":0,\"matrix\":[2,0,0,0, 0,2,0,0, 0,0,2,0, 10,20,30,1]}]", NULL, NULL, NULL};
    write_model("matrix.gltf", &tri, 1, &matrix);
    if (load_ok("matrix.gltf", &s, &r)) {
        CHECK(s.triangle_count == 1 && s.vertex_count == 3, "tris %u verts %u", s.triangle_count, s.vertex_count);
        CHECK_VEC(tri_vertex(&s, 0, 0), 10, 20, 30, 0, "matrix p0");
        CHECK_VEC(tri_vertex(&s, 0, 1), 12, 20, 30, 0, "matrix p1");
        CHECK_VEC(tri_vertex(&s, 0, 2), 10, 22, 30, 0, "matrix p2");
        CHECK(s.uvs == NULL, "uvs must stay NULL without TEXCOORD_0");
        CHECK(!s.sky && s.emitters == NULL && s.emitter_count == 0, "loader must leave sky/emitters to finalize");
        pm_scene_free(&s);
    }

    /* T * R * S: scale 2, then 90 degrees about +Z, then translate (1,2,3) */
    doc_spec trs = {"[{\"mesh\":0,\"translation\":[1,2,3],\"rotation\":[0,0,0.70710678,0.70710678],\"scale\":[2,2,2]}]",
                    NULL, NULL, NULL};
    write_model("trs.gltf", &tri, 1, &trs);
    if (load_ok("trs.gltf", &s, &r)) {
        CHECK_VEC(tri_vertex(&s, 0, 0), 1, 2, 3, 1e-5, "trs p0");
        CHECK_VEC(tri_vertex(&s, 0, 1), 1, 4, 3, 1e-5, "trs p1");
        CHECK_VEC(tri_vertex(&s, 0, 2), -1, 2, 3, 1e-5, "trs p2");
        pm_scene_free(&s);
    }

    /* parent translation applies after the child's scale: (1,0,0) -> 3 -> +5 = 8 */
    doc_spec nested = {"[{\"mesh\":0,\"scale\":[3,3,3]},{\"translation\":[5,0,0],\"children\":[0]}]", "[1]", NULL, NULL};
    write_model("nested.gltf", &tri, 1, &nested);
    if (load_ok("nested.gltf", &s, &r)) {
        CHECK_VEC(tri_vertex(&s, 0, 1), 8, 0, 0, 0, "nested p1");
        CHECK_VEC(tri_vertex(&s, 0, 2), 5, 3, 0, 0, "nested p2");
        pm_scene_free(&s);
    }

    /* one mesh placed twice: stored once (mesh space), two placements, two triangle ids */
    doc_spec twice = {"[{\"mesh\":0},{\"mesh\":0,\"translation\":[0,0,-4]}]", "[0,1]", NULL, NULL};
    write_model("instanced.gltf", &tri, 1, &twice);
    if (load_ok("instanced.gltf", &s, &r)) {
        CHECK(s.triangle_count == 1 && s.vertex_count == 3, "instanced: tris %u verts %u", s.triangle_count, s.vertex_count);
        CHECK(s.placement_count == 2 && s.instanced_mesh_count == 1 && pm_scene_triangle_ids(&s) == 2,
              "instanced: placements %u meshes %u ids %u", s.placement_count, s.instanced_mesh_count, pm_scene_triangle_ids(&s));
        vec3 corners[3];
        pm_scene_triangle_corners(&s, 1, corners);
        CHECK_VEC(corners[1], 1, 0, -4, 0, "second placement p1");
        pm_scene_free(&s);
    }
    /* flattened on request: two copies of its vertices */
    {
        char path[256], err[512];
        model_path("instanced.gltf", path, sizeof path);
        pm_load_options flat = {.flatten_instances = true};
        bool ok = pm_load_gltf_with(path, &flat, true, &s, &r, err, sizeof err);
        CHECK(ok, "flattened instanced.gltf: %s", err);
        if (ok) {
            CHECK(s.triangle_count == 2 && s.vertex_count == 6 && s.placement_count == 0, "flattened: tris %u verts %u placements %u",
                  s.triangle_count, s.vertex_count, s.placement_count);
            CHECK_VEC(tri_vertex(&s, 1, 1), 1, 0, -4, 0, "second copy p1");
            pm_scene_free(&s);
        }
    }
}

static void test_mirrored_winding(void) {
    static const float up_normals[9] = {0, 0, 1, 0, 0, 1, 0, 0, 1};
    prim_spec flat = {unit_triangle, 3, NULL, NULL, 0, NULL, 0, 0, -1, -1};
    prim_spec smooth = {unit_triangle, 3, up_normals, NULL, 0, NULL, 0, 0, -1, -1};
    doc_spec mirror = {"[{\"mesh\":0,\"scale\":[-1,1,1]}]", NULL, NULL, NULL};
    pm_scene s;
    pm_load_report r;
    /* The front face (CCW, +Z) mirrored in x still faces +Z; without the index swap cross() gives -Z. */
    write_model("mirror_flat.gltf", &flat, 1, &mirror);
    if (load_ok("mirror_flat.gltf", &s, &r)) {
        CHECK_VEC(tri_geometric_normal(&s, 0), 0, 0, 1, 1e-6, "mirrored geometric normal");
        CHECK_VEC(s.normals[s.indices[0]], 0, 0, 1, 1e-6, "mirrored flat normal");
        CHECK_NEAR(tri_vertex(&s, 0, 0).x + tri_vertex(&s, 0, 1).x + tri_vertex(&s, 0, 2).x, -1, 0, 0,
                   "mirrored x coordinates sum");
        pm_scene_free(&s);
    }
    write_model("mirror_smooth.gltf", &smooth, 1, &mirror);
    if (load_ok("mirror_smooth.gltf", &s, &r)) {
        CHECK_VEC(tri_geometric_normal(&s, 0), 0, 0, 1, 1e-6, "mirrored geometric normal (with NORMAL)");
        CHECK_VEC(s.normals[0], 0, 0, 1, 1e-6, "mirrored shading normal");
        pm_scene_free(&s);
    }
}

static void test_nonuniform_scale_normals(void) {
    /* the plane x + y = 1, normal (1,1,0)/sqrt2; scaled by (2,1,1) it becomes x/2 + y = 1: normal (1,2,0)/sqrt5 */
    static const float positions[9] = {1, 0, 0, 0, 1, 0, 1, 0, 1};
    const float h = 0.70710678f;
    const float normals[9] = {h, h, 0, h, h, 0, h, h, 0};
    prim_spec p = {positions, 3, normals, NULL, 0, NULL, 0, 0, -1, -1};
    doc_spec scaled = {"[{\"mesh\":0,\"scale\":[2,1,1]}]", NULL, NULL, NULL};
    write_model("nonuniform.gltf", &p, 1, &scaled);
    pm_scene s;
    pm_load_report r;
    if (load_ok("nonuniform.gltf", &s, &r)) {
        for (int i = 0; i < 3; i++) CHECK_VEC(s.normals[i], 1 / sqrt(5.0), 2 / sqrt(5.0), 0, 1e-6, "inverse-transpose normal");
        CHECK_VEC(tri_geometric_normal(&s, 0), 1 / sqrt(5.0), 2 / sqrt(5.0), 0, 1e-6, "geometric normal agrees");
        pm_scene_free(&s);
    }
}

static void test_index_types(void) {
    static const float quad[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    static const float quad_normals[12] = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1};
    static const uint32_t indices[6] = {0, 1, 2, 0, 2, 3};
    const int types[3] = {5121, 5123, 5125};
    const char *names[3] = {"index_u8.gltf", "index_u16.gltf", "index_u32.gltf"};
    pm_scene s;
    pm_load_report r;
    for (int t = 0; t < 3; t++) {
        prim_spec p = {quad, 4, quad_normals, NULL, 0, indices, 6, types[t], -1, -1};
        write_model(names[t], &p, 1, NULL);
        if (!load_ok(names[t], &s, &r)) continue;
        CHECK(s.triangle_count == 2 && s.vertex_count == 4, "%s: tris %u verts %u", names[t], s.triangle_count,
              s.vertex_count);
        bool same = true;
        for (int i = 0; i < 6; i++) same = same && s.indices[i] == indices[i];
        CHECK(same, "%s: indices not kept", names[t]);
        CHECK_VEC(tri_vertex(&s, 1, 2), 0, 1, 0, 0, "second triangle third corner");
        pm_scene_free(&s);
    }
    static const float soup[18] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 0, 0, 1, 1, 0, 0, 1, 0};
    static const float soup_normals[18] = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1};
    prim_spec p = {soup, 6, soup_normals, NULL, 0, NULL, 0, 0, -1, -1};
    write_model("no_indices.gltf", &p, 1, NULL);
    if (load_ok("no_indices.gltf", &s, &r)) {
        CHECK(s.triangle_count == 2 && s.vertex_count == 6, "non-indexed: tris %u verts %u", s.triangle_count,
              s.vertex_count);
        CHECK(s.indices[3] == 3 && s.indices[5] == 5, "non-indexed corners %u %u", s.indices[3], s.indices[5]);
        pm_scene_free(&s);
    }
}

static void test_strips_and_fans(void) {
    static const float strip[15] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 2, 0};
    static const float fan[15] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, -1, 1, 0};
    static const float disc[15] = {0, 0, 0, 1, 0, 0, 0, 1, 0, -1, 0, 0, 0, -1, 0};
    static const uint32_t disc_indices[6] = {0, 1, 2, 3, 4, 1}; /* a full turn, closed back onto vertex 1 */
    struct { const char *name; prim_spec p; uint32_t triangles; } cases[] = {
        {"strip.gltf", {strip, 5, NULL, NULL, 0, NULL, 0, 0, 5, -1}, 3},
        {"fan.gltf", {fan, 5, NULL, NULL, 0, NULL, 0, 0, 6, -1}, 3},
        {"fan_indexed.gltf", {disc, 5, NULL, NULL, 0, disc_indices, 6, 5123, 6, -1}, 4},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        pm_scene s;
        pm_load_report r;
        write_model(cases[c].name, &cases[c].p, 1, NULL);
        if (!load_ok(cases[c].name, &s, &r)) continue;
        CHECK(s.triangle_count == cases[c].triangles, "%s: %u triangles, want %u", cases[c].name, s.triangle_count,
              cases[c].triangles);
        CHECK(s.vertex_count == 3 * cases[c].triangles, "%s: flat normals need 3 vertices per triangle, got %u",
              cases[c].name, s.vertex_count);
        for (uint32_t t = 0; t < s.triangle_count; t++)  /* every triangle keeps the CCW (+Z) winding */
            CHECK(tri_geometric_normal(&s, t).z > 0.99f, "%s: triangle %u faces %g", cases[c].name, t,
                  tri_geometric_normal(&s, t).z);
        pm_scene_free(&s);
    }
}

static void test_flat_normals(void) {
    /* two triangles folded along the y axis, sharing vertices 0 and 1: one in z=0, one in x=0 */
    static const float fold[12] = {0, 0, 0, 0, 1, 0, 1, 0, 0, 0, 0, 1};
    static const uint32_t indices[6] = {0, 2, 1, 0, 1, 3};
    prim_spec p = {fold, 4, NULL, NULL, 0, indices, 6, 5123, -1, -1};
    write_model("flat.gltf", &p, 1, NULL);
    pm_scene s;
    pm_load_report r;
    if (load_ok("flat.gltf", &s, &r)) {
        CHECK(s.vertex_count == 6, "flat normals: %u vertices, want 6 (no sharing)", s.vertex_count);
        for (int k = 0; k < 3; k++) {
            CHECK_VEC(s.normals[s.indices[k]], 0, 0, 1, 1e-6, "first face normal");
            CHECK_VEC(s.normals[s.indices[3 + k]], 1, 0, 0, 1e-6, "second face normal");
        }
        CHECK_VEC(tri_vertex(&s, 1, 2), 0, 0, 1, 0, "second triangle keeps its corner");
        pm_scene_free(&s);
    }
}

/* glTF gives a primitive without NORMAL flat normals; a NORMAL of zero length or not finite gives
 * no more, so a triangle with such a corner is flat too. The box with shared corners and all-zero
 * normals is the box without NORMAL, vertex for vertex (taking one face's normal at each shared
 * corner would darken its image to 0.65 of the box's). */
static void test_unusable_normals(void) {
    static const float corners[24] = {-1, -1, -1, 1, -1, -1, -1, 1, -1, 1, 1, -1, -1, -1, 1, 1, -1, 1, -1, 1, 1, 1, 1, 1};
    static const uint32_t box[36] = {0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6, 0, 1, 5, 0, 5, 4,
                                     2, 6, 7, 2, 7, 3, 0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5};
    static const float zeros[24] = {0};
    prim_spec bare = {corners, 8, NULL, NULL, 0, box, 36, 5123, -1, -1};
    prim_spec zero = {corners, 8, zeros, NULL, 0, box, 36, 5123, -1, -1};
    write_model("box_bare.gltf", &bare, 1, NULL);
    write_model("box_zero_normals.gltf", &zero, 1, NULL);
    pm_scene a, b;
    pm_load_report ra, rb;
    char warnings[4096];
    if (load_ok("box_bare.gltf", &a, &ra)) {
        if (load_warned("box_zero_normals.gltf", &b, &rb, warnings, sizeof warnings)) {
            CHECK(a.triangle_count == 12 && b.triangle_count == 12 && a.vertex_count == 36 && b.vertex_count == 36,
                  "triangles %u %u, vertices %u %u (want 12, 36: flat, three vertices a triangle)", a.triangle_count,
                  b.triangle_count, a.vertex_count, b.vertex_count);
            int differ = 0;
            for (uint32_t i = 0; a.triangle_count == b.triangle_count && i < 3 * a.triangle_count; i++) {
                vec3 na = a.normals[a.indices[i]], nb = b.normals[b.indices[i]], pa = a.positions[a.indices[i]],
                     pb = b.positions[b.indices[i]];
                differ += !(na.x == nb.x && na.y == nb.y && na.z == nb.z && pa.x == pb.x && pa.y == pb.y && pa.z == pb.z);
                vec3 g = tri_geometric_normal(&b, i / 3);
                differ += v3_length(v3_sub(nb, g)) > 1e-6f;
            }
            CHECK(differ == 0, "%d corners differ from the box without NORMAL or from their face", differ);
            CHECK(rb.warnings == 1 && line_count(warnings) == 1, "one warning, got %u:\n%s", rb.warnings, warnings);
            CHECK_WARNED(warnings, "mesh 0 primitive 0 NORMAL: 8 of its 8 values have zero length or are not finite (first (0, 0, 0) at vertex 0)");
            CHECK_WARNED(warnings, "the 12 triangle(s) with such a corner get flat normals, as without NORMAL");
            pm_scene_free(&b);
        }
        CHECK(ra.warnings == 0, "the box without NORMAL warns %u times", ra.warnings);
        pm_scene_free(&a);
    }

    /* a quad whose normals lean to +y, vertex 3's not a number: triangle 0-1-2 keeps the given
     * normals on shared vertices, triangle 0-2-3 is flat (+z) on three vertices of its own */
    static const float quad[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    static const uint32_t two[6] = {0, 1, 2, 0, 2, 3};
    float leaning[12] = {0, 0.6f, 0.8f, 0, 0.6f, 0.8f, 0, 0.6f, 0.8f, NAN, 0, 1};
    prim_spec mixed = {quad, 4, leaning, NULL, 0, two, 6, 5123, -1, -1};
    write_model("quad_nan_normal.gltf", &mixed, 1, NULL);
    if (load_warned("quad_nan_normal.gltf", &b, &rb, warnings, sizeof warnings)) {
        CHECK(b.triangle_count == 2 && b.vertex_count == 7, "triangles %u vertices %u (want 2, 4 shared + 3)", b.triangle_count,
              b.vertex_count);
        if (b.triangle_count == 2) {
            for (int k = 0; k < 3; k++) {
                CHECK_VEC(b.normals[b.indices[k]], 0, 0.6, 0.8, 1e-6, "smooth triangle keeps NORMAL");
                CHECK(b.indices[k] == two[k], "smooth triangle corner %d on vertex %u, want %u", k, b.indices[k], two[k]);
                CHECK_VEC(b.normals[b.indices[3 + k]], 0, 0, 1, 1e-6, "flat triangle's face normal");
                CHECK(b.indices[3 + k] >= 4, "flat triangle corner %d on shared vertex %u", k, b.indices[3 + k]);
                CHECK_VEC(tri_vertex(&b, 1, k), quad[3 * two[3 + k]], quad[3 * two[3 + k] + 1], 0, 0, "flat corner position");
            }
        }
        CHECK(rb.warnings == 1, "warnings %u:\n%s", rb.warnings, warnings);
        CHECK_WARNED(warnings, "mesh 0 primitive 0 NORMAL: 1 of its 4 values have zero length or are not finite (first (nan, 0, 1) at vertex 3)");
        CHECK_WARNED(warnings, "the 1 triangle(s) with such a corner get flat normals");
        pm_scene_free(&b);
    }

    /* a usable normal the node's transform collapses: scale (1,0,1) takes (1,0,0) to nothing, so
     * the triangle in y = 0 is flat (+y); the warning names the instance */
    static const float floor_tri[9] = {0, 0, 0, 0, 0, 1, 1, 0, 0};
    static const float sideways[9] = {1, 0, 0, 0, 1, 0, 0, 1, 0};
    prim_spec collapsing = {floor_tri, 3, sideways, NULL, 0, NULL, 0, 0, -1, -1};
    doc_spec squash = {"[{\"mesh\":0,\"scale\":[1,0,1]}]", NULL, NULL, NULL};
    write_model("collapsed_normal.gltf", &collapsing, 1, &squash);
    if (load_warned("collapsed_normal.gltf", &b, &rb, warnings, sizeof warnings)) {
        CHECK(b.triangle_count == 1, "triangles %u", b.triangle_count);
        for (int k = 0; b.triangle_count == 1 && k < 3; k++) CHECK_VEC(b.normals[b.indices[k]], 0, 1, 0, 1e-6, "flat +y");
        CHECK(rb.warnings == 1, "warnings %u:\n%s", rb.warnings, warnings);
        CHECK_WARNED(warnings, "1 NORMAL value(s) lost their direction to their node's transform (first: mesh 0 primitive 0 on node 0)");
        pm_scene_free(&b);
    }
}

/* A 1x1 RGB PNG with 16-bit channels (written with Python's zlib; stb_image_write only writes 8-bit). */
static const unsigned char png_16bit[72] = {
    0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48, 0x44, 0x52, 0x00, 0x00,
    0x00, 0x01, 0x00, 0x00, 0x00, 0x01, 0x10, 0x02, 0x00, 0x00, 0x00, 0xc0, 0xe7, 0x8f, 0x9d, 0x00, 0x00, 0x00,
    0x0f, 0x49, 0x44, 0x41, 0x54, 0x78, 0x9c, 0x63, 0xf8, 0xff, 0x9f, 0x81, 0xa1, 0x81, 0x01, 0x00, 0x0b, 0xfc,
    0x02, 0x7f, 0x88, 0x8b, 0xcd, 0xf3, 0x00, 0x00, 0x00, 0x00, 0x49, 0x45, 0x4e, 0x44, 0xae, 0x42, 0x60, 0x82};

static void append_png_image(text *t, const unsigned char *png, size_t size, bool first) {
    text_append(t, "%s{\"uri\":\"data:image/png;base64,", first ? "" : ",");
    base64_append(t, png, size);
    text_append(t, "\"}");
}

/* One image named by 60 textures (60 materials, each the base colour of one), 59 of them sampled
 * alike: the texels are copied once for those and once for the one clamped, 2 textures in the
 * scene, every material on one of them. Before, each texture copied the image (one PNG named by
 * 1,000 textures took 5.4 GB). */
static void test_shared_image(void) {
    static const unsigned char pixels[16] = {255, 0, 0, 255, 0, 255, 0, 128, 0, 0, 255, 255, 255, 255, 255, 255};
    int size = 0;
    unsigned char *png = stbi_write_png_to_mem(pixels, 8, 2, 2, 4, &size);
    CHECK(png != NULL, "stbi_write_png_to_mem failed");
    if (!png) return;
    enum { N = 60 };
    text extra = {0}, materials = {0};
    text_append(&extra, "\"images\":[");
    append_png_image(&extra, png, (size_t)size, true);
    free(png);
    text_append(&extra, "],\"samplers\":[{\"wrapS\":33071}],\"textures\":[");
    text_append(&materials, "[");
    for (int i = 0; i < N; i++) {
        text_append(&extra, "%s{\"source\":0%s}", i ? "," : "", i == N - 1 ? ",\"sampler\":0" : "");
        text_append(&materials, "%s{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":%d}}}", i ? "," : "", i);
    }
    text_append(&extra, "],");
    text_append(&materials, "]");
    /* N primitives, each with its own material: every texture is used */
    prim_spec prims[N];
    static const float uvs[6] = {0, 0, 1, 0, 0.25f, 1};
    for (int i = 0; i < N; i++) prims[i] = (prim_spec){unit_triangle, 3, NULL, uvs, 0, NULL, 0, 0, -1, i};
    doc_spec doc = {NULL, NULL, materials.data, extra.data};
    write_model("shared_image.gltf", prims, N, &doc);
    free(extra.data);
    free(materials.data);
    pm_scene s;
    pm_load_report r;
    if (load_ok("shared_image.gltf", &s, &r)) {
        CHECK(s.texture_count == 2, "one image named by %d textures, two samplings: %u textures (want 2)", N, s.texture_count);
        bool on_them = s.material_count >= N;
        for (int i = 0; on_them && i < N; i++) on_them = s.materials[i].base_color_texture == (i == N - 1 ? 1 : 0);
        CHECK(on_them, "every material's base colour on the shared texture of its sampling");
        CHECK(s.texture_count == 2 && s.textures[1].wrap_s == PM_WRAP_CLAMP && s.textures[0].wrap_s == PM_WRAP_REPEAT,
              "the clamped sampling kept apart");
        pm_scene_free(&s);
    }
}

static void test_texcoords_and_texture(void) {
    /* 2x2 RGBA: top row red, half-transparent green; bottom row blue, white */
    static const unsigned char pixels[16] = {255, 0, 0, 255, 0, 255, 0, 128, 0, 0, 255, 255, 255, 255, 255, 255};
    static const unsigned char gray[2] = {16, 128};
    int rgba_size = 0, gray_size = 0;
    unsigned char *rgba_png = stbi_write_png_to_mem(pixels, 8, 2, 2, 4, &rgba_size);
    unsigned char *gray_png = stbi_write_png_to_mem(gray, 2, 2, 1, 1, &gray_size);
    CHECK(rgba_png && gray_png, "stbi_write_png_to_mem failed");
    if (!rgba_png || !gray_png) return;
    text extra = {0};
    text_append(&extra, "\"images\":[");
    append_png_image(&extra, rgba_png, (size_t)rgba_size, true);
    append_png_image(&extra, gray_png, (size_t)gray_size, false);
    append_png_image(&extra, png_16bit, sizeof png_16bit, false);
    text_append(&extra, "],\"samplers\":[{\"wrapS\":33071,\"wrapT\":33648}],"
                        "\"textures\":[{\"source\":0,\"sampler\":0},{\"source\":1},{\"source\":2}],");
    free(rgba_png);
    free(gray_png);

    static const float uvs[6] = {0, 0, 1, 0, 0.25f, 1};
    prim_spec prims[4] = {{unit_triangle, 3, NULL, uvs, 0, NULL, 0, 0, -1, 0},
                          {unit_triangle, 3, NULL, NULL, 0, NULL, 0, 0, -1, 0},
                          {unit_triangle, 3, NULL, uvs, 0, NULL, 0, 0, -1, 1},
                          {unit_triangle, 3, NULL, uvs, 0, NULL, 0, 0, -1, 2}};
    doc_spec doc = {"[{\"mesh\":0}]", NULL,
                    "[{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0},\"metallicFactor\":0}},"
                    "{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":1}}},"
                    "{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":2}}}]",
                    extra.data};
    write_model("textured.gltf", prims, 4, &doc);
    free(extra.data);
    pm_scene s;
    pm_load_report r;
    if (load_ok("textured.gltf", &s, &r)) {
        CHECK(s.texture_count == 2, "texture_count %u (the 16-bit image must be refused)", s.texture_count);
        CHECK(s.material_count == 3, "material_count %u", s.material_count);
        if (s.texture_count == 2 && s.material_count == 3) {
            const pm_texture *t = &s.textures[s.materials[0].base_color_texture];
            CHECK(s.materials[0].base_color_texture == 0 && s.materials[0].base_color_texcoord == 0, "material 0 texture %d",
                  s.materials[0].base_color_texture);
            CHECK(t->width == 2 && t->height == 2, "texture %dx%d", t->width, t->height);
            CHECK(memcmp(t->rgba, pixels, 16) == 0, "texels differ: first %u %u %u %u, second alpha %u", t->rgba[0],
                  t->rgba[1], t->rgba[2], t->rgba[3], t->rgba[7]);
            CHECK(t->wrap_s == PM_WRAP_CLAMP && t->wrap_t == PM_WRAP_MIRROR, "wrap %d %d", t->wrap_s, t->wrap_t);
            CHECK(s.materials[1].base_color_texture == 1, "material 1 texture %d", s.materials[1].base_color_texture);
            const pm_texture *g = &s.textures[1];
            static const unsigned char gray_rgba[8] = {16, 16, 16, 255, 128, 128, 128, 255};
            CHECK(g->width == 2 && g->height == 1 && memcmp(g->rgba, gray_rgba, 8) == 0,
                  "one-channel image must expand to RGBA: %dx%d %u %u %u %u", g->width, g->height, g->rgba[0],
                  g->rgba[1], g->rgba[2], g->rgba[3]);
            CHECK(g->wrap_s == PM_WRAP_REPEAT && g->wrap_t == PM_WRAP_REPEAT, "no sampler: repeat, got %d %d", g->wrap_s,
                  g->wrap_t);
            CHECK(s.materials[2].base_color_texture == -1, "16-bit image: material 2 texture %d",
                  s.materials[2].base_color_texture);
            CHECK(r.warnings >= 1, "refusing the 16-bit image must warn");
        }
        CHECK(s.uvs != NULL, "uvs missing");
        if (s.uvs && s.triangle_count == 4) {
            uint32_t v = s.indices[2]; /* corner 2 of the first triangle: uv (0.25, 1) */
            CHECK_NEAR(s.uvs[2 * v], 0.25, 0, 0, "u of corner 2");
            CHECK_NEAR(s.uvs[2 * v + 1], 1, 0, 0, "v of corner 2");
            uint32_t w = s.indices[3 + 1]; /* second primitive has no TEXCOORD_0: (0,0) */
            CHECK(s.uvs[2 * w] == 0 && s.uvs[2 * w + 1] == 0, "uv of a primitive without TEXCOORD_0: %g %g",
                  s.uvs[2 * w], s.uvs[2 * w + 1]);
        }
        pm_scene_free(&s);
    }

    /* normalized u8 texture coordinates: 51/255 = 0.2 */
    static const float byte_uvs[6] = {0.2f, 1, 1, 0, 0, 0.6f};
    prim_spec bytes = {unit_triangle, 3, NULL, byte_uvs, 5121, NULL, 0, 0, -1, -1};
    write_model("uv_u8.gltf", &bytes, 1, NULL);
    if (load_ok("uv_u8.gltf", &s, &r)) {
        CHECK(s.uvs != NULL, "u8 uvs missing");
        if (s.uvs) {
            CHECK_NEAR(s.uvs[2 * s.indices[0]], 0.2, 0, 1e-6, "u8 u");
            CHECK_NEAR(s.uvs[2 * s.indices[2] + 1], 0.6, 0, 1e-6, "u8 v");
        }
        pm_scene_free(&s);
    }
}

static void test_cameras(void) {
    prim_spec tri = {unit_triangle, 3, NULL, NULL, 0, NULL, 0, 0, -1, -1};
    /* node 4's children in order: node 3 (camera 2), node 2 (camera 1, orthographic), node 1 (camera 0) */
    doc_spec doc = {"[{\"mesh\":0},"
                    "{\"camera\":0,\"translation\":[0,1,5],\"scale\":[2,2,2]},"
                    "{\"camera\":1},"
                    "{\"camera\":2,\"translation\":[3,0,0],\"rotation\":[0,0.70710678,0,0.70710678]},"
                    "{\"children\":[3,2,1]}]",
                    "[0,4]", NULL,
                    "\"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":0.8,\"aspectRatio\":1.5,\"znear\":0.1}},"
                    "{\"type\":\"orthographic\",\"orthographic\":{\"xmag\":1,\"ymag\":1,\"znear\":0.1,\"zfar\":10}},"
                    "{\"type\":\"perspective\",\"perspective\":{\"yfov\":0.5,\"znear\":0.01}}],"};
    write_model("cameras.gltf", &tri, 1, &doc);
    pm_scene s;
    pm_load_report r;
    if (!load_ok("cameras.gltf", &s, &r)) return;
    CHECK(s.camera_count == 3, "camera_count %u (perspective and orthographic)", s.camera_count);
    CHECK(r.warnings == 0, "three valid cameras: %u warnings", r.warnings);
    if (s.camera_count == 3) {
        const pm_camera *first = &s.cameras[0], *ortho = &s.cameras[1], *second = &s.cameras[2];
        CHECK_NEAR(first->yfov, 0.5, 0, 1e-7, "first camera in traversal order is camera 2");
        CHECK(!first->orthographic, "camera 2 is perspective");
        CHECK_NEAR(first->aspect, 0, 0, 0, "absent aspectRatio is 0");
        CHECK_VEC(first->position, 3, 0, 0, 1e-6, "camera 2 position");
        CHECK_VEC(first->forward, -1, 0, 0, 1e-6, "camera 2 forward (-Z turned 90 degrees about Y)");
        CHECK_VEC(first->up, 0, 1, 0, 1e-6, "camera 2 up");
        CHECK_VEC(first->right, 0, 0, -1, 1e-6, "camera 2 right");
        CHECK(ortho->orthographic, "camera 1 is orthographic");
        CHECK_NEAR(ortho->ymag, 1, 0, 1e-7, "orthographic ymag");
        CHECK_NEAR(ortho->aspect, 1, 0, 1e-7, "orthographic aspect = xmag / ymag");
        CHECK_VEC(ortho->forward, 0, 0, -1, 1e-7, "orthographic forward");
        CHECK_NEAR(second->yfov, 0.8, 0, 1e-7, "second camera yfov");
        CHECK_NEAR(second->aspect, 1.5, 0, 1e-7, "second camera aspect");
        CHECK_NEAR(second->znear, 0.1, 0, 1e-7, "second camera znear");
        CHECK_VEC(second->position, 0, 1, 5, 0, "camera 0 position");
        CHECK_VEC(second->forward, 0, 0, -1, 1e-7, "scaled node: forward stays unit");
        CHECK_VEC(second->up, 0, 1, 0, 1e-7, "scaled node: up stays unit");
        CHECK_VEC(second->right, 1, 0, 0, 1e-7, "camera 0 right");
    }
    pm_scene_free(&s);
}

static void test_lights(void) {
    prim_spec tri = {unit_triangle, 3, NULL, NULL, 0, NULL, 0, 0, -1, -1};
    doc_spec doc = {"[{\"mesh\":0},"
                    "{\"translation\":[1,2,3],\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}},"
                    "{\"translation\":[0,4,0],\"rotation\":[-0.70710678,0,0,0.70710678],"
                    "\"extensions\":{\"KHR_lights_punctual\":{\"light\":1}}},"
                    "{\"extensions\":{\"KHR_lights_punctual\":{\"light\":2}}},"
                    "{\"extensions\":{\"KHR_lights_punctual\":{\"light\":3}}}]",
                    "[0,1,2,3,4]", NULL,
                    "\"extensionsUsed\":[\"KHR_lights_punctual\"],"
                    "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":["
                    "{\"type\":\"point\",\"color\":[1,0.5,0.25],\"intensity\":4,\"range\":10},"
                    "{\"type\":\"spot\",\"intensity\":10,\"spot\":{\"innerConeAngle\":0.3,\"outerConeAngle\":0.6}},"
                    "{\"type\":\"directional\",\"color\":[0.5,0.5,1],\"intensity\":2},"
                    "{\"type\":\"spot\",\"spot\":{}}]}},"};
    write_model("lights.gltf", &tri, 1, &doc);
    pm_scene s;
    pm_load_report r;
    if (!load_ok("lights.gltf", &s, &r)) return;
    CHECK(s.light_count == 4, "light_count %u", s.light_count);
    if (s.light_count == 4) {
        const pm_light *point = &s.lights[0], *spot = &s.lights[1], *sun = &s.lights[2], *plain = &s.lights[3];
        CHECK(point->type == PM_LIGHT_POINT && spot->type == PM_LIGHT_SPOT && sun->type == PM_LIGHT_DIRECTIONAL,
              "types %d %d %d", point->type, spot->type, sun->type);
        CHECK_VEC(point->intensity, 4, 2, 1, 1e-6, "point intensity = color x intensity");
        CHECK_VEC(point->position, 1, 2, 3, 0, "point position");
        CHECK_NEAR(point->range, 10, 0, 0, "point range");
        CHECK_VEC(spot->intensity, 10, 10, 10, 1e-6, "spot intensity (default white)");
        CHECK_VEC(spot->position, 0, 4, 0, 0, "spot position");
        CHECK_VEC(spot->direction, 0, -1, 0, 1e-6, "spot turned -90 degrees about X points down");
        CHECK_NEAR(spot->cos_inner, cos(0.3), 0, 1e-6, "spot cos_inner");
        CHECK_NEAR(spot->cos_outer, cos(0.6), 0, 1e-6, "spot cos_outer");
        CHECK_NEAR(spot->range, 0, 0, 0, "absent range is 0");
        CHECK_VEC(sun->intensity, 1, 1, 2, 1e-6, "directional intensity");
        CHECK_VEC(sun->direction, 0, 0, -1, 1e-7, "directional light travels along -Z");
        CHECK_NEAR(plain->cos_inner, 1, 0, 1e-7, "default innerConeAngle 0");
        CHECK_NEAR(plain->cos_outer, cos(PM_PI / 4), 0, 1e-6, "default outerConeAngle pi/4");
        CHECK_VEC(plain->intensity, 1, 1, 1, 0, "default color and intensity");
    }
    pm_scene_free(&s);
}

/* KHR_lights_punctual asks 0 <= innerConeAngle < outerConeAngle <= pi/2. A cone of outer angle 0
 * or less is empty: the light is dropped; outer above pi/2 and inner below 0 are clamped; inner at
 * or above outer becomes outer (a hard edge). Each says so in a line naming the light and field. */
static void test_spot_cones(void) {
    prim_spec tri = {unit_triangle, 3, NULL, NULL, 0, NULL, 0, 0, -1, -1};
    text nodes = {0};
    text_append(&nodes, "[{\"mesh\":0}");
    for (int i = 0; i < 6; i++) text_append(&nodes, ",{\"extensions\":{\"KHR_lights_punctual\":{\"light\":%d}}}", i);
    text_append(&nodes, "]");
    doc_spec doc = {nodes.data, "[0,1,2,3,4,5,6]", NULL,
                    "\"extensionsUsed\":[\"KHR_lights_punctual\"],"
                    "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":["
                    "{\"type\":\"spot\",\"name\":\"shut\",\"spot\":{\"outerConeAngle\":0}},"
                    "{\"type\":\"spot\",\"spot\":{\"innerConeAngle\":0.2,\"outerConeAngle\":2}},"
                    "{\"type\":\"spot\",\"spot\":{\"innerConeAngle\":0.5,\"outerConeAngle\":0.5}},"
                    "{\"type\":\"spot\",\"spot\":{\"innerConeAngle\":-0.1,\"outerConeAngle\":0.4}},"
                    "{\"type\":\"spot\",\"spot\":{\"outerConeAngle\":-1}},"
                    "{\"type\":\"spot\",\"spot\":{\"innerConeAngle\":0.1,\"outerConeAngle\":0.3}}]}},"};
    write_model("spot_cones.gltf", &tri, 1, &doc);
    free(nodes.data);
    pm_scene s;
    pm_load_report r;
    char warnings[4096];
    if (!load_warned("spot_cones.gltf", &s, &r, warnings, sizeof warnings)) return;
    CHECK(s.light_count == 4, "light_count %u: the two empty cones are dropped, four stay", s.light_count);
    if (s.light_count == 4) {
        const pm_light *l = s.lights;
        CHECK_NEAR(l[0].cos_outer, 0, 0, 1e-7, "outer 2 clamped to pi/2");
        CHECK_NEAR(l[0].cos_inner, cos(0.2), 0, 1e-6, "inner 0.2 kept");
        CHECK(l[1].cos_inner == l[1].cos_outer && fabs(l[1].cos_outer - cos(0.5)) < 1e-6, "inner = outer = 0.5: cos %g %g",
              l[1].cos_inner, l[1].cos_outer);
        CHECK_NEAR(l[2].cos_inner, 1, 0, 0, "inner -0.1 clamped to 0");
        CHECK_NEAR(l[2].cos_outer, cos(0.4), 0, 1e-6, "outer 0.4 kept");
        CHECK_NEAR(l[3].cos_inner, cos(0.1), 0, 1e-6, "valid cone inner");
        CHECK_NEAR(l[3].cos_outer, cos(0.3), 0, 1e-6, "valid cone outer");
    }
    CHECK(r.warnings == 5 && line_count(warnings) == 5, "5 warnings, got %u:\n%s", r.warnings, warnings);
    CHECK_WARNED(warnings, "KHR_lights_punctual light 0 (shut) spot.outerConeAngle 0 is not above 0: its cone is empty and it emits no light; dropped");
    CHECK_WARNED(warnings, "KHR_lights_punctual light 1 spot.outerConeAngle 2 clamped to 1.5708");
    CHECK_WARNED(warnings, "KHR_lights_punctual light 2 spot.innerConeAngle 0.5 is not below outerConeAngle 0.5: set to it (a hard-edged cone)");
    CHECK_WARNED(warnings, "KHR_lights_punctual light 3 spot.innerConeAngle -0.1 clamped to 0");
    CHECK_WARNED(warnings, "KHR_lights_punctual light 4 spot.outerConeAngle -1 is not above 0");
    CHECK(strstr(warnings, "light 5") == NULL, "the valid cone warns:\n%s", warnings);
    pm_scene_free(&s);
}

/* Every clamped value is warned in one line naming its object and field, once per object and
 * field (more values of the same field are counted in that line); emission and intensities
 * above PM_MAX_EMISSION are brought down to it in the loader, hue kept, with such a line. */
static void test_clamp_warnings(void) {
    prim_spec prims[2] = {{unit_triangle, 3, NULL, NULL, 0, NULL, 0, 0, -1, 0}, {unit_triangle, 3, NULL, NULL, 0, NULL, 0, 0, -1, 1}};
    doc_spec doc = {"[{\"mesh\":0},{\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}},"
                    "{\"translation\":[0,0,2],\"extensions\":{\"KHR_lights_punctual\":{\"light\":1}}}]",
                    "[0,1,2]",
                    "[{\"name\":\"Lamp\",\"pbrMetallicRoughness\":{\"baseColorFactor\":[1.5,2,0.5,1],\"roughnessFactor\":2},"
                    "\"emissiveFactor\":[1,0.5,0],\"extensions\":{\"KHR_materials_emissive_strength\":{\"emissiveStrength\":1e40}}},"
                    "{\"pbrMetallicRoughness\":{\"metallicFactor\":-1}}]",
                    "\"extensionsUsed\":[\"KHR_lights_punctual\",\"KHR_materials_emissive_strength\"],"
                    "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":["
                    "{\"type\":\"directional\",\"name\":\"Sun\",\"intensity\":-3},"
                    "{\"type\":\"point\",\"color\":[2,0.5,0.25],\"intensity\":1e30}]}},"};
    write_model("clamps.gltf", prims, 2, &doc);
    pm_scene s;
    pm_load_report r;
    char warnings[4096];
    if (!load_warned("clamps.gltf", &s, &r, warnings, sizeof warnings)) return;
    CHECK(r.warnings == 7 && line_count(warnings) == 7, "7 warnings, got %u:\n%s", r.warnings, warnings);
    CHECK_WARNED(warnings, "material 0 (Lamp) baseColorFactor 1.5 clamped to 1 (and 1 more of its values)\n");
    CHECK_WARNED(warnings, "material 0 (Lamp) roughnessFactor 2 clamped to 1\n");
    CHECK_WARNED(warnings, "material 0 (Lamp) emission 1e+40 (emissiveFactor x emissiveStrength 1e+40) clamped to 1e+20");
    CHECK_WARNED(warnings, "material 1 metallicFactor -1 clamped to 0\n");
    CHECK_WARNED(warnings, "KHR_lights_punctual light 0 (Sun) intensity -3 clamped to 0\n");
    CHECK_WARNED(warnings, "KHR_lights_punctual light 1 color 2 clamped to 1\n");
    CHECK_WARNED(warnings, "KHR_lights_punctual light 1 intensity 1e+30 (intensity 1e+30 x color) clamped to 1e+20");
    if (s.material_count == 2 && s.light_count == 2) {
        CHECK_VEC(s.materials[0].base_color, 1, 1, 0.5, 0, "base colour clamped");
        CHECK_VEC(s.materials[0].emission, PM_MAX_EMISSION, 0.5 * PM_MAX_EMISSION, 0, 1e-6 * PM_MAX_EMISSION, "emission, hue kept");
        CHECK(s.materials[1].metallic == 0, "metallic %g", s.materials[1].metallic);
        CHECK_VEC(s.lights[0].intensity, 0, 0, 0, 0, "negative intensity clamped to 0");
        CHECK_VEC(s.lights[1].intensity, PM_MAX_EMISSION, 0.5 * PM_MAX_EMISSION, 0.25 * PM_MAX_EMISSION, 1e-6 * PM_MAX_EMISSION,
                  "intensity, hue kept");
    } else CHECK(0, "materials %u lights %u", s.material_count, s.light_count);
    pm_scene_finalize(&s, false, NULL);
    CHECK(s.clamped_emission == 0, "set-up finds %u values still to clamp", s.clamped_emission);
    pm_scene_free(&s);
}

static void test_materials(void) {
    prim_spec prims[5];
    for (int i = 0; i < 5; i++) {
        prim_spec p = {unit_triangle, 3, NULL, NULL, 0, NULL, 0, 0, -1, i < 4 ? i : -1};
        prims[i] = p;
    }
    doc_spec doc = {NULL, NULL,
                    "[{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.8,0.2,0.1,0.5],\"metallicFactor\":0}},"
                    "{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.9,0.9,0.9,1],\"metallicFactor\":1,\"roughnessFactor\":0}},"
                    "{\"pbrMetallicRoughness\":{\"metallicFactor\":0,\"roughnessFactor\":0},"
                    "\"extensions\":{\"KHR_materials_transmission\":{\"transmissionFactor\":1},\"KHR_materials_ior\":{\"ior\":1.33}}},"
                    "{\"emissiveFactor\":[1,0.5,0.25],\"doubleSided\":true,"
                    "\"extensions\":{\"KHR_materials_emissive_strength\":{\"emissiveStrength\":8}}}]",
                    "\"extensionsUsed\":[\"KHR_materials_transmission\",\"KHR_materials_ior\",\"KHR_materials_emissive_strength\"],"};
    write_model("materials.gltf", prims, 5, &doc);
    pm_scene s;
    pm_load_report r;
    if (!load_ok("materials.gltf", &s, &r)) return;
    CHECK(s.material_count == 5, "material_count %u (4 + the default one)", s.material_count);
    CHECK(s.triangle_count == 5, "triangle_count %u", s.triangle_count);
    if (s.material_count == 5 && s.triangle_count == 5) {
        const pm_material *m = s.materials;
        for (uint32_t t = 0; t < 5; t++) CHECK(s.triangle_material[t] == t, "triangle %u material %u", t, s.triangle_material[t]);
        CHECK_VEC(m[0].base_color, 0.8, 0.2, 0.1, 1e-7, "diffuse base colour (alpha ignored)");
        CHECK(m[0].metallic == 0 && m[0].roughness == 1 && m[0].transmission == 0 && m[0].ior == 1.5f,
              "diffuse: metallic %g roughness %g transmission %g ior %g", m[0].metallic, m[0].roughness,
              m[0].transmission, m[0].ior);
        CHECK(v3_is_black(m[0].emission) && !m[0].double_sided && m[0].base_color_texture == -1, "diffuse extras");
        CHECK(m[1].metallic == 1 && m[1].roughness == 0, "mirror: metallic %g roughness %g", m[1].metallic, m[1].roughness);
        CHECK_VEC(m[2].base_color, 1, 1, 1, 0, "glass default base colour");
        CHECK(m[2].transmission == 1 && fabsf(m[2].ior - 1.33f) < 1e-6f, "glass: transmission %g ior %g",
              m[2].transmission, m[2].ior);
        CHECK_VEC(m[3].emission, 8, 4, 2, 1e-6, "emission = emissiveFactor x emissiveStrength");
        CHECK(m[3].double_sided, "emissive material is double sided");
        CHECK(m[3].metallic == 1 && m[3].roughness == 1, "glTF defaults metallic 1 roughness 1");
        CHECK_VEC(m[4].base_color, 1, 1, 1, 0, "default material base colour");
        CHECK(m[4].metallic == 1 && m[4].roughness == 1 && m[4].ior == 1.5f && !m[4].double_sided &&
                  m[4].base_color_texture == -1 && v3_is_black(m[4].emission),
              "default material: metallic %g roughness %g", m[4].metallic, m[4].roughness);
    }
    pm_scene_free(&s);
}

static void test_skips(void) {
    /* a good triangle, a repeated vertex and a collinear triple */
    static const float positions[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 2, 0, 0};
    static const uint32_t indices[9] = {0, 1, 2, 1, 1, 2, 0, 1, 3};
    prim_spec mixed = {positions, 4, NULL, NULL, 0, indices, 9, 5123, -1, -1};
    write_model("degenerate.gltf", &mixed, 1, NULL);
    pm_scene s;
    pm_load_report r;
    if (load_ok("degenerate.gltf", &s, &r)) {
        CHECK(s.triangle_count == 1 && r.skipped_degenerate == 2, "tris %u degenerate %u", s.triangle_count,
              r.skipped_degenerate);
        CHECK(r.warnings >= 1, "skipping must warn");
        pm_scene_free(&s);
    }
    prim_spec with_points[3] = {{unit_triangle, 3, NULL, NULL, 0, NULL, 0, 0, 0, -1},
                                {unit_triangle, 3, NULL, NULL, 0, NULL, 0, 0, -1, -1},
                                {positions, 4, NULL, NULL, 0, NULL, 0, 0, 1, -1}};
    write_model("points.gltf", with_points, 3, NULL);
    if (load_ok("points.gltf", &s, &r)) {
        CHECK(s.triangle_count == 1 && s.vertex_count == 3, "tris %u verts %u", s.triangle_count, s.vertex_count);
        CHECK(r.skipped_primitives == 2, "skipped_primitives %u (points + lines)", r.skipped_primitives);
        pm_scene_free(&s);
    }
    write_model("only_points.gltf", with_points, 1, NULL);
    check_rejected("only_points.gltf", "nothing to render");
}

static void test_sparse(void) {
    /* POSITION without a bufferView (zeros) and two sparse substitutions: vertices 1 and 2 */
    static const unsigned char data[28] = {1, 2, 0, 0, /* u8 indices 1, 2, padding */
                                           0, 0, 0x80, 0x3f, 0, 0, 0, 0, 0, 0, 0, 0,  /* (1,0,0) */
                                           0, 0, 0, 0, 0, 0, 0x80, 0x3f, 0, 0, 0, 0}; /* (0,1,0) */
    text json = {0};
    text_append(&json, "{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
                       "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0}}]}],"
                       "\"buffers\":[{\"byteLength\":28,\"uri\":\"data:application/gltf-buffer;base64,");
    base64_append(&json, data, sizeof data);
    text_append(&json, "\"}],\"bufferViews\":[{\"buffer\":0,\"byteLength\":4},{\"buffer\":0,\"byteOffset\":4,\"byteLength\":24}],"
                       "\"accessors\":[{\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"sparse\":{\"count\":2,"
                       "\"indices\":{\"bufferView\":0,\"componentType\":5121},\"values\":{\"bufferView\":1}}}]}");
    write_text("sparse.gltf", json.data);
    pm_scene s;
    pm_load_report r;
    if (load_ok("sparse.gltf", &s, &r)) {
        CHECK(s.triangle_count == 1, "sparse triangle count %u", s.triangle_count);
        CHECK_VEC(tri_vertex(&s, 0, 0), 0, 0, 0, 0, "zero-filled vertex 0");
        CHECK_VEC(tri_vertex(&s, 0, 1), 1, 0, 0, 0, "sparse vertex 1");
        CHECK_VEC(tri_vertex(&s, 0, 2), 0, 1, 0, 0, "sparse vertex 2");
        pm_scene_free(&s);
    }
    /* the same with sparse index 5 in a 3-vertex accessor */
    char *bad_index = strstr(json.data, "base64,") + 7;
    bad_index[0] = 'B'; /* first base64 symbol: 0x01 -> 0x05 in the first byte */
    write_text("sparse_bad.gltf", json.data);
    check_rejected("sparse_bad.gltf", "sparse index 5 >= accessor count 3");
    free(json.data);
}

/* A mesh with two morph targets and default weights [0.5, 0.25]: the static pose glTF defines is
 * the base plus 0.5 x target 0 (every vertex +2 in z) plus 0.25 x target 1 (vertex 1 +4 in x), so
 * the triangle sits at z = 1 with vertex 1 at x = 2. Before, the base shape rendered (z = 0). A
 * node giving weights of its own gets one warning. */
static void test_morph_weights(void) {
    float data[27] = {0, 0, 0, 1, 0, 0, 0, 1, 0, /* base */
                      0, 0, 2, 0, 0, 2, 0, 0, 2, /* target 0: +2 z */
                      0, 0, 0, 4, 0, 0, 0, 0, 0}; /* target 1: vertex 1 +4 x */
    for (int node_weights = 0; node_weights < 2; node_weights++) {
        text json = {0};
        text_append(&json, "{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0%s}],"
                           "\"meshes\":[{\"weights\":[0.5,0.25],\"primitives\":[{\"attributes\":{\"POSITION\":0},"
                           "\"targets\":[{\"POSITION\":1},{\"POSITION\":2}]}]}],"
                           "\"buffers\":[{\"byteLength\":108,\"uri\":\"data:application/gltf-buffer;base64,",
                    node_weights ? ",\"weights\":[1,0]" : "");
        base64_append(&json, (const unsigned char *)data, sizeof data);
        text_append(&json, "\"}],\"bufferViews\":[{\"buffer\":0,\"byteLength\":36},{\"buffer\":0,\"byteOffset\":36,\"byteLength\":36},"
                           "{\"buffer\":0,\"byteOffset\":72,\"byteLength\":36}],\"accessors\":["
                           "{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]},"
                           "{\"bufferView\":1,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                           "{\"bufferView\":2,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"}]}");
        write_text("morph.gltf", json.data);
        free(json.data);
        pm_scene s;
        pm_load_report r;
        char warnings[2048];
        if (!load_warned("morph.gltf", &s, &r, warnings, sizeof warnings)) continue;
        CHECK_VEC(tri_vertex(&s, 0, 0), 0, 0, 1, 1e-6, "morphed vertex 0");
        CHECK_VEC(tri_vertex(&s, 0, 1), 2, 0, 1, 1e-6, "morphed vertex 1");
        CHECK_VEC(tri_vertex(&s, 0, 2), 0, 1, 1, 1e-6, "morphed vertex 2");
        if (node_weights)
            CHECK(line_count(warnings) == 1 && strstr(warnings, "node 0 gives mesh 0 morph weights of its own"),
                  "a node's own weights: one warning: %s", warnings);
        else
            CHECK(line_count(warnings) == 0, "mesh weights alone: no warning: %s", warnings);
        pm_scene_free(&s);
    }
}

/* NaN and infinite texture coordinates read as 0, counted in one warning line naming the first;
 * before, they were accepted silently and read an arbitrary texel. */
static void test_nonfinite_uvs(void) {
    const float uvs[6] = {0.25f, NAN, INFINITY, 0.5f, 0.75f, 0.75f};
    prim_spec p = {unit_triangle, 3, NULL, uvs, 0, NULL, 0, 0, -1, -1};
    write_model("nan_uvs.gltf", &p, 1, NULL);
    pm_scene s;
    pm_load_report r;
    char warnings[2048];
    if (!load_warned("nan_uvs.gltf", &s, &r, warnings, sizeof warnings)) return;
    bool finite = s.uvs != NULL;
    for (uint32_t i = 0; finite && i < 2 * s.vertex_count; i++) finite = isfinite(s.uvs[i]);
    CHECK(finite, "non-finite UVs: every stored UV finite");
    CHECK(s.uvs && s.uvs[0] == 0.25f && s.uvs[1] == 0.f && s.uvs[2] == 0.f && s.uvs[3] == 0.5f,
          "non-finite UVs: read as 0, the others kept");
    CHECK(line_count(warnings) == 1 && strstr(warnings, "2 non-finite texture coordinate(s) read as 0 (first: TEXCOORD_0 vertex 0, mesh 0"),
          "non-finite UVs: one warning naming the count and the first: %s", warnings);
    pm_scene_free(&s);
}

static void test_rejections(void) {
    static const uint32_t bad_indices[3] = {0, 1, 7};
    prim_spec out_of_range = {unit_triangle, 3, NULL, NULL, 0, bad_indices, 3, 5123, -1, -1};
    write_model("index_range.gltf", &out_of_range, 1, NULL);
    check_rejected("index_range.gltf", "index 7 >= vertex count 3 (mesh 0 primitive 0)");

    const float nan_triangle[9] = {0, 0, 0, NAN, 0, 0, 0, 1, 0};
    prim_spec nan = {nan_triangle, 3, NULL, NULL, 0, NULL, 0, 0, -1, -1};
    write_model("nan.gltf", &nan, 1, NULL);
    check_rejected("nan.gltf", "non-finite vertex position");

    prim_spec tri = {unit_triangle, 3, NULL, NULL, 0, NULL, 0, 0, -1, -1};
    doc_spec cycle = {"[{\"mesh\":0,\"children\":[1]},{\"children\":[0]}]", NULL, NULL, NULL};
    write_model("cycle.gltf", &tri, 1, &cycle);
    check_rejected("cycle.gltf", "cycle");

    doc_spec two_parents = {"[{\"mesh\":0},{\"children\":[0]},{\"children\":[0]}]", "[1,2]", NULL, NULL};
    write_model("two_parents.gltf", &tri, 1, &two_parents);
    check_rejected("two_parents.gltf", "node 0 is reached twice");

    /* glTF's node rules hold for every node, listed by the default scene or not: a cycle or a
     * second parent among nodes the scene never reaches is refused too (before, accepted) */
    doc_spec cycle_aside = {"[{\"mesh\":0},{\"children\":[2]},{\"children\":[1]}]", "[0]", NULL, NULL};
    write_model("cycle_aside.gltf", &tri, 1, &cycle_aside);
    check_rejected("cycle_aside.gltf", "node hierarchy contains a cycle (node 1)");
    doc_spec parents_aside = {"[{\"mesh\":0},{\"children\":[3]},{\"children\":[3]},{}]", "[0]", NULL, NULL};
    write_model("parents_aside.gltf", &tri, 1, &parents_aside);
    check_rejected("parents_aside.gltf", "node 3 is reached twice (two parents: nodes 1 and 2)");

    /* a PNG whose header claims 30000000 x 30000000 pixels (past stb_image's 2^24 a side): named by
     * its size, as a large decodable one is (before, "not a decodable PNG" and its texture dropped) */
    prim_spec textured = {unit_triangle, 3, NULL, NULL, 0, NULL, 0, 0, -1, 0};
    doc_spec huge_png = {NULL, NULL, "[{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0}}}]",
                         "\"textures\":[{\"source\":0}],\"images\":[{\"uri\":\"data:image/png;base64,"
                         "iVBORw0KGgoAAAANSUhEUgHJw4ABycOACAYAAABkid33AAAAC0lEQVR4nGNggAAAAAgAAbdYc5UAAAAASUVORK5CYII=\"}],"};
    write_model("huge_png.gltf", &textured, 1, &huge_png);
    check_rejected("huge_png.gltf", "image is 30000000x30000000 pixels, more than 268435456 (image 0)");

    /* a node matrix whose last row is not [0 0 0 1] (glTF's are affine): refused, not cut to 3x4 */
    doc_spec projective = {"[{\"mesh\":0,\"matrix\":[1,0,0,0.5,0,1,0,0,0,0,1,0,0,0,0,1]}]", NULL, NULL, NULL};
    write_model("projective.gltf", &tri, 1, &projective);
    check_rejected("projective.gltf", "matrix's last row is [0.5 0 0 1], not [0 0 0 1] (glTF node matrices are affine) (node 0)");
    doc_spec weighted = {"[{\"mesh\":0,\"matrix\":[2,0,0,0,0,2,0,0,0,0,2,0,0,0,0,2]}]", NULL, NULL, NULL};
    write_model("weighted.gltf", &tri, 1, &weighted);
    check_rejected("weighted.gltf", "matrix's last row is [0 0 0 2]");

    doc_spec unsupported = {NULL, NULL, NULL,
                            "\"extensionsUsed\":[\"EXT_pmview_unsupported\"],\"extensionsRequired\":[\"EXT_pmview_unsupported\"],"};
    write_model("unsupported.gltf", &tri, 1, &unsupported);
    check_rejected("unsupported.gltf", "required extension EXT_pmview_unsupported is not supported");

    doc_spec negative = {"[{\"mesh\":-1}]", NULL, NULL, NULL};
    write_model("negative.gltf", &tri, 1, &negative);
    check_rejected("negative.gltf", "invalid (negative) mesh index -1 (node 0)");

    /* a buffer just outside the model's folder, of the declared size: only the uri check refuses it */
    char sub[128], outside[128];
    snprintf(sub, sizeof sub, "%s/sub", test_dir);
    snprintf(outside, sizeof outside, "%s/outside.bin", test_dir);
    static const unsigned char outside_bytes[36] = {0};
    write_file(outside, outside_bytes, sizeof outside_bytes);
    CHECK(mkdir(sub, 0700) == 0, "cannot create %s", sub);
    write_text("sub/escape.gltf",
               "{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
               "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0}}]}],"
               "\"buffers\":[{\"byteLength\":36,\"uri\":\"../outside.bin\"}],"
               "\"bufferViews\":[{\"buffer\":0,\"byteLength\":36}],"
               "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"}]}");
    check_rejected("sub/escape.gltf", "escapes the model's folder (buffer 0)");
    write_text("sub/escape_encoded.gltf",
               "{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
               "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0}}]}],"
               "\"buffers\":[{\"byteLength\":36,\"uri\":\"a/%2e%2e/%2E%2E/outside.bin\"}],"
               "\"bufferViews\":[{\"buffer\":0,\"byteLength\":36}],"
               "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"}]}");
    check_rejected("sub/escape_encoded.gltf", "escapes the model's folder (buffer 0)");

    write_text("file_scheme.gltf",
               "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"byteLength\":36,\"uri\":\"file:///etc/passwd\"}]}");
    check_rejected("file_scheme.gltf", "scheme file: is not allowed");
    write_text("bad_data_uri.gltf",
               "{\"asset\":{\"version\":\"2.0\"},\"images\":[{\"uri\":\"data:image/png;base64,AA*A\"}]}");
    check_rejected("bad_data_uri.gltf", "malformed data: URI (image 0)");
    write_text("no_scene.gltf", "{\"asset\":{\"version\":\"2.0\"}}");
    check_rejected("no_scene.gltf", "nothing to render");
    write_text("empty.gltf", "");
    check_rejected("empty.gltf", "empty file");
    check_rejected("does_not_exist.gltf", "cannot open");
    char deep[400];
    memset(deep, '[', sizeof deep);
    deep[sizeof deep - 1] = 0;
    write_text("deep.gltf", deep);
    check_rejected("deep.gltf", "nested deeper");
}

/* ---------------------------------------------------------------- texture inputs and quantized meshes */

/* A unit quad in z = 0 (triangles 0-1-2 and 0-2-3), its accessors added to a blob by each test. */
static const float quad_positions[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
static const uint16_t quad_indices[6] = {0, 1, 2, 0, 2, 3};

/* Writes {"asset", BODY, buffers, bufferViews, accessors}; BODY holds every other member, no trailing comma. */
static void write_blob_model(const char *name, blob *b, const char *body) {
    text json = {0};
    text_append(&json, "{\"asset\":{\"version\":\"2.0\"},%s,\"buffers\":[{\"byteLength\":%zu,"
                       "\"uri\":\"data:application/octet-stream;base64,", body, b->size);
    base64_append(&json, b->bytes, b->size);
    text_append(&json, "\"}],\"bufferViews\":[%s],\"accessors\":[%s]}", b->views.data, b->accessors.data);
    char path[256];
    model_path(name, path, sizeof path);
    write_file(path, json.data, json.size);
    free(json.data);
    free(b->views.data);
    free(b->accessors.data);
    memset(b, 0, sizeof *b);
}

/* Appends "images":[...] of w x 1 RGBA PNGs (one per row of `rows`), then the textures (one per image) and a
 * clamping sampler, as members followed by a comma. */
static void append_strip_images(text *t, const unsigned char (*rows)[16], const int *widths, int count) {
    text_append(t, "\"images\":[");
    for (int i = 0; i < count; i++) {
        int size = 0;
        unsigned char *png = stbi_write_png_to_mem(rows[i], 4 * widths[i], widths[i], 1, 4, &size);
        if (!png) abort();
        append_png_image(t, png, (size_t)size, i == 0);
        free(png);
    }
    text_append(t, "],\"samplers\":[{\"wrapS\":33071,\"wrapT\":33071}],\"textures\":[");
    for (int i = 0; i < count; i++) text_append(t, "%s{\"source\":%d,\"sampler\":0}", i ? "," : "", i);
    text_append(t, "],");
}

/* The surface at (x, y) of the unit quad (x >= y: triangle 0, else triangle 1). */
static void quad_surface(const pm_scene *s, float x, float y, pm_surface *sf) {
    if (x >= y) pm_scene_surface(s, 0, x - y, y, sf);
    else pm_scene_surface(s, 1, x, y - x, sf);
}

/* The quad with TEXCOORD_0 = uv0 and (when given) TEXCOORD_1 = uv1, POSITION float; returns the primitive's JSON. */
static void quad_primitive(blob *b, text *prim, const float *uv0, const float *uv1, int material) {
    text_append(prim, "{\"attributes\":{\"POSITION\":%d", blob_accessor(b, quad_positions, sizeof quad_positions, 4, 5126, "VEC3", 0));
    if (uv0) text_append(prim, ",\"TEXCOORD_0\":%d", blob_accessor(b, uv0, 32, 4, 5126, "VEC2", 0));
    if (uv1) text_append(prim, ",\"TEXCOORD_1\":%d", blob_accessor(b, uv1, 32, 4, 5126, "VEC2", 0));
    text_append(prim, "},\"indices\":%d,\"material\":%d}", blob_accessor(b, quad_indices, sizeof quad_indices, 6, 5123, "SCALAR", 0),
                material);
}

/* A red|blue strip read through TEXCOORD_1 (mirrored in u against TEXCOORD_0): the colour is set 1's. Sets
 * above 1 are read through set 0 and counted as ignored inputs. */
static void test_texcoord_sets(void) {
    static const unsigned char strip[1][16] = {{255, 0, 0, 255, 0, 0, 255, 255}};
    static const int width[1] = {2};
    static const float uv0[8] = {0, 0, 1, 0, 1, 1, 0, 1}, uv1[8] = {1, 0, 0, 0, 0, 1, 1, 1};
    for (int variant = 0; variant < 3; variant++) {
        /* both textures on set 1, then on set 0 (set 1 present but unused), then on set 2 (read through set 0, warned) */
        const int set = variant == 0 ? 1 : variant == 1 ? 0 : 2;
        const bool blue = variant == 0; /* at x 0.2: set 0 reads u 0.2 (the red texel), set 1 u 0.8 (blue) */
        blob *b = calloc(1, sizeof *b);
        text body = {0}, prim = {0};
        quad_primitive(b, &prim, uv0, uv1, 0);
        append_strip_images(&body, strip, width, 1);
        text_append(&body, "\"materials\":[{\"pbrMetallicRoughness\":{\"metallicFactor\":0,"
                           "\"baseColorTexture\":{\"index\":0,\"texCoord\":%d}},"
                           "\"emissiveFactor\":[1,1,1],\"emissiveTexture\":{\"index\":0,\"texCoord\":%d},\"extensions\":{\"KHR_materials_specular\":{\"specularFactor\":0}}}],"
                           "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],\"meshes\":[{\"primitives\":[%s]}]",
                    set, set, prim.data);
        write_blob_model("texcoord1.gltf", b, body.data);
        free(body.data);
        free(prim.data);
        free(b);
        pm_scene s;
        pm_load_report r;
        if (!load_ok("texcoord1.gltf", &s, &r)) continue;
        CHECK(variant == 0 ? s.uvs1 != NULL : s.uvs1 == NULL, "variant %d: uvs1 %p (kept only when a texture reads set 1)",
              variant, (void *)s.uvs1);
        CHECK(s.materials[0].base_color_texcoord == (set == 1) && s.materials[0].emission_texcoord == (set == 1),
              "texcoords %d %d", s.materials[0].base_color_texcoord, s.materials[0].emission_texcoord);
        CHECK(r.ignored_inputs == (set == 2 ? 1u : 0u), "set %d: ignored_inputs %u (one material)", set, r.ignored_inputs);
        pm_surface sf;
        quad_surface(&s, 0.2f, 0.5f, &sf);
        CHECK_VEC(sf.kd, blue ? 0 : 1, 0, blue ? 1 : 0, 1e-5, "base colour at x 0.2");
        CHECK_VEC(sf.emission, blue ? 0 : 1, 0, blue ? 1 : 0, 1e-5, "emission at x 0.2");
        CHECK_VEC(pm_scene_emission_at(&s, 1, 0.2f, 0.3f), blue ? 0 : 1, 0, blue ? 1 : 0, 1e-5,
                  "pm_scene_emission_at at x 0.2");
        quad_surface(&s, 0.9f, 0.5f, &sf);
        CHECK_VEC(sf.kd, blue ? 1 : 0, 0, blue ? 0 : 1, 1e-5, "base colour at x 0.9");
        pm_scene_free(&s);
    }
}

/* KHR_texture_transform u' = cos u + sin v, v' = -sin u + cos v (rotation), times scale, plus offset. */
static void transform_uv(const double *offset, double rotation, const double *scale, float u, float v, float *out) {
    double c = cos(rotation), s = sin(rotation);
    out[0] = (float)(c * scale[0] * u + s * scale[1] * v + offset[0]);
    out[1] = (float)(-s * scale[0] * u + c * scale[1] * v + offset[1]);
}

/* A transformed texture (texCoord overridden to set 1) gives at every point the colour of the plain texture
 * read through pre-transformed coordinates; and a quarter turn has the sign the sample model expects. */
static void test_texture_transform(void) {
    static const unsigned char tiles[2][16] = {{255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 255, 255, 0, 255},
                                               {255, 0, 0, 255, 0, 0, 255, 255}};
    static const int widths[2] = {4, 2};
    static const float uv[8] = {0, 0, 1, 0, 1, 1, 0, 1}, junk[8] = {0.9f, 0.9f, 0.9f, 0.9f, 0.9f, 0.9f, 0.9f, 0.9f};
    const double offset[2] = {0.3, -0.2}, rotation = 0.7, scale[2] = {1.5, 0.8};
    float moved[8];
    for (int k = 0; k < 4; k++) transform_uv(offset, rotation, scale, uv[2 * k], uv[2 * k + 1], moved + 2 * k);
    for (int variant = 0; variant < 2; variant++) {
        blob *b = calloc(1, sizeof *b);
        text body = {0}, prim = {0};
        if (variant == 0) quad_primitive(b, &prim, junk, uv, 0);
        else quad_primitive(b, &prim, moved, NULL, 0);
        append_strip_images(&body, tiles, widths, 2);
        /* textures repeat here: the sampler is dropped */
        char *sampler = strstr(body.data, ",\"sampler\":0");
        memmove(sampler, sampler + 12, strlen(sampler + 12) + 1);
        body.size = strlen(body.data);
        if (variant == 0)
            text_append(&body, "\"extensionsUsed\":[\"KHR_texture_transform\"],\"materials\":[{\"pbrMetallicRoughness\":{"
                               "\"metallicFactor\":0,\"baseColorTexture\":{\"index\":0,\"extensions\":{\"KHR_texture_transform\":"
                               "{\"offset\":[0.3,-0.2],\"rotation\":0.7,\"scale\":[1.5,0.8],\"texCoord\":1}}}},\"extensions\":{\"KHR_materials_specular\":{\"specularFactor\":0}}},");
        else
            text_append(&body, "\"materials\":[{\"pbrMetallicRoughness\":{\"metallicFactor\":0,\"baseColorTexture\":{\"index\":0}},\"extensions\":{\"KHR_materials_specular\":{\"specularFactor\":0}}},");
        /* material 1: a quarter turn and offset (0, 1) of a red|blue strip, clamped */
        text_append(&body, "{\"pbrMetallicRoughness\":{\"metallicFactor\":0,\"baseColorTexture\":{\"index\":1,\"extensions\":"
                           "{\"KHR_texture_transform\":{\"offset\":[0,1],\"rotation\":1.5707963268}}}},\"extensions\":{\"KHR_materials_specular\":{\"specularFactor\":0}}}],"
                           "\"samplers\":[{\"wrapS\":33071,\"wrapT\":33071}],");
        text_append(&body, "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],\"meshes\":[{\"primitives\":[%s]}]", prim.data);
        write_blob_model(variant ? "plain_moved.gltf" : "transformed.gltf", b, body.data);
        free(body.data);
        free(prim.data);
        free(b);
    }
    pm_scene t, p;
    pm_load_report r;
    if (!load_ok("transformed.gltf", &t, &r)) return;
    CHECK(r.ignored_inputs == 0, "ignored_inputs %u with KHR_texture_transform", r.ignored_inputs);
    if (!load_ok("plain_moved.gltf", &p, &r)) {
        pm_scene_free(&t);
        return;
    }
    double worst = 0.0, spread = 0.0;
    vec3 first = v3s(-1.f);
    for (int i = 0; i < 16; i++)
        for (int j = 0; j < 16; j++) {
            float x = (i + 0.37f) / 16.f, y = (j + 0.61f) / 16.f;
            pm_surface a, c;
            quad_surface(&t, x, y, &a);
            quad_surface(&p, x, y, &c);
            for (int k = 0; k < 3; k++) worst = fmax(worst, fabs(v3_get(a.kd, k) - v3_get(c.kd, k)));
            if (first.x < 0.f) first = a.kd;
            spread = fmax(spread, v3_length(v3_sub(a.kd, first)));
        }
    CHECK(worst < 2e-4, "transformed vs pre-transformed coordinates differ by %g", worst);
    CHECK(spread > 0.5, "the test texture must vary over the quad (spread %g)", spread);
    /* quarter turn: uv (0.1, 0.8) -> (0.8, 0.9): the blue texel (the opposite sign would clamp to red) */
    if (t.material_count == 2) {
        t.triangle_material[1] = 1;
        pm_surface sf;
        quad_surface(&t, 0.1f, 0.8f, &sf);
        CHECK_VEC(sf.kd, 0, 0, 1, 1e-5, "quarter-turn transform reads the blue texel");
    }
    pm_scene_free(&t);
    pm_scene_free(&p);

    /* a malformed transform is refused with one line */
    blob *b = calloc(1, sizeof *b);
    text body = {0}, prim = {0};
    quad_primitive(b, &prim, uv, NULL, 0);
    append_strip_images(&body, tiles, widths, 1);
    text_append(&body, "\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0,\"extensions\":"
                       "{\"KHR_texture_transform\":{\"scale\":[2]}}}}}],"
                       "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],\"meshes\":[{\"primitives\":[%s]}]", prim.data);
    write_blob_model("bad_transform.gltf", b, body.data);
    free(body.data);
    free(prim.data);
    free(b);
    check_rejected("bad_transform.gltf", "KHR_texture_transform scale must be 2 numbers, got an array "
                                         "(material 0 baseColorTexture)");
}

/* B = metalness, G = roughness, linear (64 reads 0.251, not the sRGB 0.051); R of the transmission texture. */
static void test_data_textures(void) {
    static const unsigned char strips[3][16] = {{0, 64, 255, 255, 0, 200, 0, 255},    /* metal left, dielectric right */
                                                {128, 10, 10, 255, 0, 255, 255, 255}, /* transmission R: 128 | 0 */
                                                {0, 0, 0, 255, 0, 0, 0, 255}};        /* B = 0: never metal */
    static const int widths[3] = {2, 2, 2};
    static const float uv[8] = {0, 0, 1, 0, 1, 1, 0, 1};
    blob *b = calloc(1, sizeof *b);
    text body = {0}, prims = {0};
    quad_primitive(b, &prims, uv, NULL, 0); /* accessors 0-2, shared by the three meshes */
    append_strip_images(&body, strips, widths, 3);
    text_append(&body, "\"extensionsUsed\":[\"KHR_materials_transmission\",\"KHR_materials_specular\"],\"materials\":["
                       "{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.8,0.8,0.8,1],\"roughnessFactor\":0.5,"
                       "\"metallicRoughnessTexture\":{\"index\":0}},\"extensions\":{\"KHR_materials_specular\":{\"specularFactor\":0}}},"
                       "{\"pbrMetallicRoughness\":{\"metallicFactor\":0},\"extensions\":{\"KHR_materials_transmission\":"
                       "{\"transmissionFactor\":1,\"transmissionTexture\":{\"index\":1}},"
                       "\"KHR_materials_specular\":{\"specularFactor\":0}}},"
                       "{\"pbrMetallicRoughness\":{\"metallicRoughnessTexture\":{\"index\":2}},\"extensions\":{\"KHR_materials_specular\":{\"specularFactor\":0}}}],"
                       "\"scenes\":[{\"nodes\":[0,1,2]}],\"nodes\":[{\"mesh\":0},{\"mesh\":1,\"translation\":[2,0,0]},"
                       "{\"mesh\":2,\"translation\":[4,0,0]}],\"meshes\":[{\"primitives\":[%s]},", prims.data);
    /* meshes 1 and 2: the same quad with materials 1 and 2 */
    text_append(&body, "{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":1},\"indices\":2,\"material\":1}]},"
                       "{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":1},\"indices\":2,\"material\":2}]}]");
    write_blob_model("data_textures.gltf", b, body.data);
    free(body.data);
    free(prims.data);
    free(b);
    pm_scene s;
    pm_load_report r;
    if (!load_ok("data_textures.gltf", &s, &r)) return;
    CHECK(r.ignored_inputs == 0, "ignored_inputs %u with metallic-roughness and transmission textures", r.ignored_inputs);
    CHECK(s.triangle_count == 6, "triangles %u", s.triangle_count);
    if (s.triangle_count == 6 && s.material_count == 3) {
        pm_surface sf;
        quad_surface(&s, 0.2f, 0.1f, &sf); /* metal, roughness 0.5 x 64/255: the glossy lobe */
        double rough = 0.5 * 64.0 / 255.0;
        CHECK(sf.glossy, "metal half: glossy (roughness %.3f)", rough);
        CHECK_NEAR(sf.brdf.alpha, rough * rough, 1e-4, 0, "metal half: GGX alpha = (roughness x G linear)^2");
        CHECK_NEAR(sf.brdf.metallic, 1.0, 0, 1e-6, "metal half: metallic = B");
        CHECK_VEC(sf.ks, 0, 0, 0, 0, "metal half: the lobe holds the mirror share");
        CHECK_VEC(sf.kd, 0, 0, 0, 0, "metal half: and the diffuse share");
        quad_surface(&s, 0.9f, 0.1f, &sf);
        CHECK_VEC(sf.ks, 0, 0, 0, 0, "dielectric half: no mirror");
        CHECK_VEC(sf.kd, 0.8, 0.8, 0.8, 1e-5, "dielectric half: Lambert");
        pm_surface glass, opaque;
        pm_scene_surface(&s, 2, 0.1f, 0.1f, &glass); /* mesh 1, x 0.2: R 128 */
        pm_scene_surface(&s, 2, 0.8f, 0.1f, &opaque); /* x 0.9: R 0 */
        double t = 128.0 / 255.0;
        CHECK_VEC(glass.kt, t, t, t, 1e-5, "transmission half: kt = R linear");
        CHECK_VEC(glass.kd, 1 - t, 1 - t, 1 - t, 1e-5, "transmission half: the rest diffuse");
        CHECK_VEC(opaque.kt, 0, 0, 0, 0, "R 0: no glass");
        CHECK_VEC(opaque.kd, 1, 1, 1, 1e-5, "R 0: Lambert");
        pm_scene_finalize(&s, false, NULL);
        const pm_material *m = s.materials;
        CHECK(m[0].may_glossy && m[0].may_diffuse && !m[0].may_glass && !m[0].may_mirror, "material 0 lobes %d %d %d %d",
              m[0].may_diffuse, m[0].may_mirror, m[0].may_glass, m[0].may_glossy);
        CHECK(m[1].may_glass && m[1].may_diffuse && !m[1].may_mirror, "material 1 lobes %d %d %d", m[1].may_diffuse,
              m[1].may_mirror, m[1].may_glass);
        CHECK(!m[2].may_mirror && !m[2].may_glossy && m[2].may_diffuse,
              "material 2 (B 0 everywhere, metallicFactor 1) lobes %d %d %d %d", m[2].may_diffuse, m[2].may_mirror,
              m[2].may_glass, m[2].may_glossy);
        CHECK(s.analysis.has_glossy && s.analysis.has_glass && s.analysis.has_diffuse,
              "analysis: a texture-made metal and glass count (glossy %d glass %d)", s.analysis.has_glossy,
              s.analysis.has_glass);
    }
    pm_scene_free(&s);
}

/* KHR_materials_clearcoat, _sheen and _specular: factors times their texture channels (coat R,
 * coat roughness G, sheen and specular colours sRGB RGB, sheen roughness and specular A), no
 * `ignored:` warning but for clearcoatNormalTexture; a material with only a neutral sheen is Lambert. */
static void test_layer_extensions(void) {
    static const unsigned char strips[1][16] = {{128, 255, 0, 64, 255, 0, 255, 255}};
    static const int widths[1] = {2};
    static const float uv[8] = {0, 0, 1, 0, 1, 1, 0, 1};
    blob *b = calloc(1, sizeof *b);
    text body = {0}, prims = {0};
    quad_primitive(b, &prims, uv, NULL, 0);
    append_strip_images(&body, strips, widths, 1);
    text_append(&body, "\"extensionsUsed\":[\"KHR_materials_clearcoat\",\"KHR_materials_sheen\",\"KHR_materials_specular\"],"
                       "\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,0.6,0.7,1],\"roughnessFactor\":0.5},"
                       "\"extensions\":{\"KHR_materials_clearcoat\":{\"clearcoatFactor\":1,\"clearcoatTexture\":{\"index\":0},"
                       "\"clearcoatRoughnessFactor\":0.5,\"clearcoatRoughnessTexture\":{\"index\":0},"
                       "\"clearcoatNormalTexture\":{\"index\":0}},"
                       "\"KHR_materials_sheen\":{\"sheenColorFactor\":[1,0.5,0.25],\"sheenColorTexture\":{\"index\":0},"
                       "\"sheenRoughnessFactor\":0.8,\"sheenRoughnessTexture\":{\"index\":0}},"
                       "\"KHR_materials_specular\":{\"specularFactor\":0.5,\"specularTexture\":{\"index\":0},"
                       "\"specularColorFactor\":[2,1,0.5],\"specularColorTexture\":{\"index\":0}}}},"
                       "{\"pbrMetallicRoughness\":{\"metallicFactor\":0,\"baseColorFactor\":[0.4,0.4,0.4,1]},"
                       "\"extensions\":{\"KHR_materials_sheen\":{}}}],"
                       "\"scenes\":[{\"nodes\":[0,1]}],\"nodes\":[{\"mesh\":0},{\"mesh\":1,\"translation\":[2,0,0]}],"
                       "\"meshes\":[{\"primitives\":[%s]},", prims.data);
    text_append(&body, "{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":1},\"indices\":2,\"material\":1}]}]");
    write_blob_model("layers.gltf", b, body.data);
    free(body.data);
    free(prims.data);
    free(b);
    pm_scene s;
    pm_load_report r;
    if (!load_ok("layers.gltf", &s, &r)) return;
    CHECK(r.ignored_inputs == 0, "ignored_inputs %u: clearcoatNormalTexture is read", r.ignored_inputs);
    CHECK(r.warnings == 0, "warnings %u: no unsupported extension", r.warnings);
    if (s.triangle_count == 4 && s.material_count == 2) {
        const pm_material *m = s.materials;
        CHECK(m[0].layered && m[1].layered, "both materials layered");
        CHECK(m[0].layers.clearcoat == 1.f && m[0].layers.clearcoat_roughness == 0.5f && m[0].layers.sheen_roughness == 0.8f &&
                  m[0].layers.specular == 0.5f,
              "factors %g %g %g %g", m[0].layers.clearcoat, m[0].layers.clearcoat_roughness, m[0].layers.sheen_roughness,
              m[0].layers.specular);
        CHECK_VEC(m[0].layers.sheen_color, 1, 0.5, 0.25, 0, "sheenColorFactor");
        CHECK_VEC(m[0].layers.specular_color, 2, 1, 0.5, 0, "specularColorFactor");
        CHECK(m[0].layers.clearcoat_texture.texture == 0 && m[0].layers.sheen_color_texture.texture == 0 &&
                  m[0].layers.specular_color_texture.texture == 0 && m[0].layers.sheen_roughness_texture.texture == 0 &&
                  m[0].layers.specular_texture.texture == 0 && m[0].layers.clearcoat_roughness_texture.texture == 0,
              "the six textures");
        CHECK(m[1].layers.clearcoat_texture.texture == -1 && m[1].layers.sheen_color.x == 0.f && m[1].layers.specular == 1.f,
              "defaults: no texture, sheen colour 0, specular 1");
        pm_surface sf;
        quad_surface(&s, 0.2f, 0.1f, &sf); /* texel 0: R 128, G 255, B 0, A 64 */
        double r128 = 128.0 / 255.0, a64 = 64.0 / 255.0, s128 = pm_srgb_to_linear(128.f / 255.f);
        CHECK(sf.glossy && sf.brdf.layered, "layered point: the glossy lobe");
        CHECK_VEC(sf.kd, 0, 0, 0, 0, "layered point: the lobe holds the diffuse share");
        CHECK_NEAR(sf.brdf.clearcoat, r128, 1e-5, 0, "clearcoat x R");
        CHECK_NEAR(sf.brdf.clearcoat_alpha, 0.25, 1e-5, 0, "clearcoat roughness x G, squared");
        CHECK_VEC(sf.brdf.sheen_color, s128, 0.5, 0, 1e-5, "sheen colour x sRGB texel");
        /* 0.8 x A is 0.20, under the sheen's roughness floor (brdf.h), which it is raised to */
        CHECK_NEAR(sf.brdf.sheen_roughness, fmax(PM_SHEEN_MIN_ROUGHNESS, 0.8 * a64), 1e-5, 0, "sheen roughness x A, at least the floor");
        CHECK_NEAR(sf.brdf.specular, 0.5 * a64, 1e-5, 0, "specular x A");
        /* the coat's normal map (texel 0: x 0.0 -> -1, y 1.0 -> 1, z 0 -> -1, pulled back to the face)
         * bends the coat's normal, not the base's */
        CHECK(m[0].layers.clearcoat_normal_texture.texture == 0 && m[0].layers.clearcoat_normal_scale == 1.f, "coat normal texture read");
        CHECK(sf.brdf.coat_normal && v3_dot(sf.brdf.coat_n, sf.ns) < 0.9f, "the coat's own normal is bent (cos %g)",
              v3_dot(sf.brdf.coat_n, sf.ns));
        CHECK(v3_dot(sf.ns, sf.ng) > 0.9999f, "the base's shading normal is not");
        CHECK_VEC(sf.brdf.specular_f0, 0.04 * 2 * s128, 0.04, 0, 1e-6, "F0 = 0.04 x specular colour x sRGB texel");
        quad_surface(&s, 0.9f, 0.1f, &sf); /* texel 1: R 255, G 0, B 255, A 255 */
        CHECK_NEAR(sf.brdf.clearcoat, 1, 1e-6, 0, "clearcoat at R 255");
        CHECK_NEAR(sf.brdf.clearcoat_alpha, PM_GLOSSY_MIN_ALPHA, 1e-6, 0, "coat roughness 0: the smallest alpha");
        CHECK_VEC(sf.brdf.sheen_color, 1, 0, 0.25, 1e-6, "sheen colour at texel 1");
        CHECK_VEC(sf.brdf.specular_f0, 0.08, 0, 0.02, 1e-6, "F0 at texel 1");
        pm_scene_surface(&s, 2, 0.1f, 0.1f, &sf); /* material 1: a neutral sheen on Lambert */
        vec3 n = sf.ns, t, bt;
        v3_basis(n, &t, &bt);
        vec3 wo = v3_normalize(v3_add(n, v3_scale(t, 0.3f))), wi = v3_normalize(v3_add(n, v3_add(v3_scale(t, -0.5f), v3_scale(bt, 0.2f))));
        vec3 f = sf.glossy ? pm_brdf_eval(&sf.brdf, n, wo, wi) : v3s(-1.f);
        pm_brdf plain = pm_brdf_at(v3s(0.4f), 0.f, 1.f, 0.f); /* glTF's dielectric: roughness 1 by default */
        vec3 fp = pm_brdf_eval(&plain, n, wo, wi);
        CHECK_VEC(f, fp.x, fp.y, fp.z, 1e-6, "sheen colour 0 on metallic 0: the plain dielectric lobe");
        pm_scene_finalize(&s, false, NULL);
        CHECK(m[0].may_glossy && !m[0].may_diffuse && !m[0].may_mirror && !m[0].uniform_split, "material 0 lobes: glossy, textured");
        CHECK(m[1].may_glossy && !m[1].may_diffuse && m[1].uniform_split, "material 1 lobes: glossy, uniform");
    } else CHECK(0, "triangles %u materials %u", s.triangle_count, s.material_count);
    pm_scene_free(&s);
}

/* Bad layer members: one line naming the member and material; an out-of-range factor is clamped with a warning. */
static void test_layer_extensions_bad(void) {
    prim_spec tri = {unit_triangle, 3, NULL, NULL, 0, NULL, 0, 0, -1, 0};
    doc_spec bad_color = {NULL, NULL, "[{\"extensions\":{\"KHR_materials_sheen\":{\"sheenColorFactor\":[1,\"x\",0]}}}]", NULL};
    write_model("bad_sheen.gltf", &tri, 1, &bad_color);
    check_rejected("bad_sheen.gltf", "sheenColorFactor must be 3 numbers");
    doc_spec bad_factor = {NULL, NULL, "[{\"extensions\":{\"KHR_materials_clearcoat\":{\"clearcoatFactor\":true}}}]", NULL};
    write_model("bad_coat.gltf", &tri, 1, &bad_factor);
    check_rejected("bad_coat.gltf", "clearcoatFactor");
    doc_spec big = {NULL, NULL, "[{\"extensions\":{\"KHR_materials_clearcoat\":{\"clearcoatFactor\":1.5}}}]", NULL};
    write_model("big_coat.gltf", &tri, 1, &big);
    pm_scene s;
    pm_load_report r;
    if (!load_ok("big_coat.gltf", &s, &r)) return;
    CHECK(r.warnings == 1 && s.material_count >= 1 && s.materials[0].layers.clearcoat == 1.f,
          "clearcoatFactor 1.5: clamped to 1 with one warning (warnings %u)", r.warnings);
    pm_scene_free(&s);
}

/* SHORT normalized positions under a node scale and translation, BYTE normalized normals and unnormalized
 * UNSIGNED_BYTE texture coordinates load to the float version's values. */
static void test_mesh_quantization(void) {
    static const int16_t q_pos[12] = {0, 0, 0, 32767, 0, 0, 32767, 32767, -32768, 0, 32767, 16384};
    static const int8_t q_normal[12] = {0, 0, 127, 0, 0, 127, 0, -128, 127, 0, 0, 127}; /* padded to 4 bytes each */
    static const uint8_t q_uv[8] = {0, 0, 2, 0, 2, 3, 0, 3};
    const double scale[3] = {2, 3, 4}, offset[3] = {1, -1, 0.5};
    float f_pos[12], f_normal[12], f_uv[8];
    for (int v = 0; v < 4; v++)
        for (int k = 0; k < 3; k++) {
            double unit = q_pos[3 * v + k] / 32767.0;
            f_pos[3 * v + k] = (float)((unit < -1 ? -1 : unit) * scale[k] + offset[k]);
        }
    for (int i = 0; i < 8; i++) f_uv[i] = q_uv[i];
    for (int v = 0; v < 4; v++) {
        /* the normal as the node sees it: the inverse transpose of the scale, renormalized by the loader */
        double n[3] = {q_normal[3 * v] / 127.0, fmax(q_normal[3 * v + 1] / 127.0, -1.0), q_normal[3 * v + 2] / 127.0};
        for (int k = 0; k < 3; k++) f_normal[3 * v + k] = (float)(n[k] / scale[k]);
    }
    for (int quantized = 0; quantized < 2; quantized++) {
        blob *b = calloc(1, sizeof *b);
        text body = {0};
        int pos, normal, uv;
        if (quantized) {
            pos = blob_accessor(b, q_pos, sizeof q_pos, 4, 5122, "VEC3", 1);
            unsigned char padded[16];
            for (int v = 0; v < 4; v++) {
                memcpy(padded + 4 * v, q_normal + 3 * v, 3);
                padded[4 * v + 3] = 0;
            }
            normal = blob_accessor(b, padded, sizeof padded, 4, 5120, "VEC3", 1);
            uv = blob_accessor(b, q_uv, sizeof q_uv, 4, 5121, "VEC2", 0);
        } else {
            pos = blob_accessor(b, f_pos, sizeof f_pos, 4, 5126, "VEC3", 0);
            normal = blob_accessor(b, f_normal, sizeof f_normal, 4, 5126, "VEC3", 0);
            uv = blob_accessor(b, f_uv, sizeof f_uv, 4, 5126, "VEC2", 0);
        }
        int indices = blob_accessor(b, quad_indices, sizeof quad_indices, 6, 5123, "SCALAR", 0);
        text_append(&body, "%s\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0%s}],\"meshes\":[{\"primitives\":[{\"attributes\":"
                           "{\"POSITION\":%d,\"NORMAL\":%d,\"TEXCOORD_0\":%d},\"indices\":%d}]}]",
                    quantized ? "\"extensionsUsed\":[\"KHR_mesh_quantization\"],\"extensionsRequired\":[\"KHR_mesh_quantization\"]," : "",
                    quantized ? ",\"scale\":[2,3,4],\"translation\":[1,-1,0.5]" : "", pos, normal, uv, indices);
        if (quantized) {
            /* give the normals' view (view 1) its stride of 4 */
            text fixed = {0};
            char *view1 = strstr(b->views.data, "},{") + 2;
            char *close = strchr(view1, '}');
            text_append(&fixed, "%.*s,\"byteStride\":4%s", (int)(close - b->views.data), b->views.data, close);
            free(b->views.data);
            b->views = fixed;
        }
        write_blob_model(quantized ? "quantized.gltf" : "unquantized.gltf", b, body.data);
        free(body.data);
        free(b);
    }
    pm_scene q, f;
    pm_load_report r;
    if (!load_ok("quantized.gltf", &q, &r)) return;
    if (!load_ok("unquantized.gltf", &f, &r)) {
        pm_scene_free(&q);
        return;
    }
    CHECK(q.vertex_count == f.vertex_count && q.triangle_count == f.triangle_count && q.triangle_count == 2,
          "quantized %u vertices %u triangles, float %u %u", q.vertex_count, q.triangle_count, f.vertex_count,
          f.triangle_count);
    if (q.vertex_count == f.vertex_count && q.triangle_count == f.triangle_count && q.uvs && f.uvs) {
        double dp = 0, dn = 0, du = 0;
        for (uint32_t v = 0; v < q.vertex_count; v++) {
            dp = fmax(dp, v3_length(v3_sub(q.positions[v], f.positions[v])));
            dn = fmax(dn, v3_length(v3_sub(q.normals[v], f.normals[v])));
            du = fmax(du, fabs(q.uvs[2 * v] - f.uvs[2 * v]) + fabs(q.uvs[2 * v + 1] - f.uvs[2 * v + 1]));
        }
        CHECK(dp < 1e-6 && dn < 1e-6 && du == 0, "quantized vs float: positions %g normals %g uvs %g", dp, dn, du);
        CHECK(memcmp(q.indices, f.indices, 6 * sizeof(uint32_t)) == 0, "triangles differ");
        /* one value by hand: vertex 2 = (1 x 2 + 1, 1 x 3 - 1, -1 x 4 + 0.5) */
        CHECK_VEC(q.positions[q.indices[2]], 3, 2, -3.5, 1e-6, "quantized vertex 2");
    }
    pm_scene_free(&q);
    pm_scene_free(&f);

    /* without the extension, SHORT positions are refused */
    char path[256];
    model_path("quantized.gltf", path, sizeof path);
    FILE *in = fopen(path, "rb");
    char json[8192];
    size_t n = in ? fread(json, 1, sizeof json - 1, in) : 0;
    if (in) fclose(in);
    json[n] = 0;
    char *used = strstr(json, "\"extensionsUsed\"");
    char *scenes = strstr(json, "\"scenes\"");
    if (used && scenes) {
        memmove(used, scenes, strlen(scenes) + 1);
        write_text("quantized_undeclared.gltf", json);
        check_rejected("quantized_undeclared.gltf", "POSITION must be a float VEC3 (accessor 0, mesh 0 primitive 0)");
    }
}

/* normalTexture (index, texCoord, scale, transform) is read; TANGENT (float, or normalized SHORT under
 * KHR_mesh_quantization) is turned like a direction, its w flipped by a mirroring node; without TANGENT,
 * tangents follow +u of the normal texture's set, with w from the UV winding (glTF's v runs down the image,
 * the map's +y up it). A flat (128,128,255) map leaves the shading normal alone. */
static void test_normal_maps(void) {
    static const unsigned char flat_texel[1][16] = {{128, 128, 255, 255}};
    static const int width[1] = {1};
    static const float uv0[8] = {0, 1, 1, 1, 1, 0, 0, 0}; /* (x, 1 - y): the image upright on the quad */
    static const float uv1[8] = {0, 0, 0, 1, 1, 1, 1, 0}; /* (y, x): +u along +y */
    static const float normals[12] = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1};
    static const float tangents[16] = {0, 1, 0, -1, 0, 1, 0, -1, 0, 1, 0, -1, 0, 1, 0, -1};
    static const int16_t q_tangents[16] = {0, 32767, 0, -32767, 0, 32767, 0, -32767, 0, 32767, 0, -32767, 0, 32767, 0, -32767};
    blob *b = calloc(1, sizeof *b);
    text body = {0};
    int pos = blob_accessor(b, quad_positions, sizeof quad_positions, 4, 5126, "VEC3", 0);
    int t0 = blob_accessor(b, uv0, sizeof uv0, 4, 5126, "VEC2", 0), t1 = blob_accessor(b, uv1, sizeof uv1, 4, 5126, "VEC2", 0);
    int ix = blob_accessor(b, quad_indices, sizeof quad_indices, 6, 5123, "SCALAR", 0);
    int nrm = blob_accessor(b, normals, sizeof normals, 4, 5126, "VEC3", 0);
    int tf = blob_accessor(b, tangents, sizeof tangents, 4, 5126, "VEC4", 0);
    int tq = blob_accessor(b, q_tangents, sizeof q_tangents, 4, 5122, "VEC4", 1);
    append_strip_images(&body, flat_texel, width, 1);
    text_append(&body, "\"extensionsUsed\":[\"KHR_mesh_quantization\",\"KHR_texture_transform\"],"
                       "\"extensionsRequired\":[\"KHR_mesh_quantization\"],\"materials\":["
                       "{\"normalTexture\":{\"index\":0,\"scale\":0.5}},"
                       "{\"normalTexture\":{\"index\":0,\"texCoord\":1,\"extensions\":{\"KHR_texture_transform\":{\"offset\":[0.25,0]}}}},"
                       "{\"normalTexture\":{\"index\":0}}],"
                       "\"scenes\":[{\"nodes\":[0,1,2,3,4]}],\"nodes\":[{\"mesh\":0},{\"mesh\":1,\"translation\":[2,0,0]},"
                       "{\"mesh\":2,\"rotation\":[0,0,0.70710678,0.70710678]},{\"mesh\":3,\"scale\":[-1,1,1],\"translation\":[5,0,0]},{\"mesh\":4,\"translation\":[8,0,0]}],"
                       "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":%d,\"TEXCOORD_0\":%d,\"TEXCOORD_1\":%d},\"indices\":%d,\"material\":0}]},"
                       "{\"primitives\":[{\"attributes\":{\"POSITION\":%d,\"TEXCOORD_0\":%d,\"TEXCOORD_1\":%d},\"indices\":%d,\"material\":1}]},"
                       "{\"primitives\":[{\"attributes\":{\"POSITION\":%d,\"NORMAL\":%d,\"TEXCOORD_0\":%d,\"TANGENT\":%d},\"indices\":%d,\"material\":2}]},"
                       "{\"primitives\":[{\"attributes\":{\"POSITION\":%d,\"NORMAL\":%d,\"TEXCOORD_0\":%d,\"TANGENT\":%d},\"indices\":%d,\"material\":2}]},"
                       "{\"primitives\":[{\"attributes\":{\"POSITION\":%d,\"NORMAL\":%d,\"TEXCOORD_0\":%d},\"indices\":%d,\"material\":0}]}]",
                pos, t0, t1, ix, pos, t0, t1, ix, pos, nrm, t0, tf, ix, pos, nrm, t0, tq, ix, pos, nrm, t0, ix);
    write_blob_model("normalmap.gltf", b, body.data);
    free(body.data);
    free(b);
    pm_scene s;
    pm_load_report r;
    if (!load_ok("normalmap.gltf", &s, &r)) return;
    CHECK(r.ignored_inputs == 0 && r.warnings == 0, "normal maps are rendered: ignored_inputs %u warnings %u", r.ignored_inputs,
          r.warnings);
    if (s.material_count != 3 || s.triangle_count != 10 || !s.tangents) {
        CHECK(0, "materials %u triangles %u tangents %p", s.material_count, s.triangle_count, (void *)s.tangents);
        pm_scene_free(&s);
        return;
    }
    const pm_material *m = s.materials;
    CHECK(m[0].normal_texture == 0 && m[0].normal_texcoord == 0 && m[0].normal_scale == 0.5f && !m[0].normal_transform.transformed,
          "material 0: texture %d set %d scale %g", m[0].normal_texture, m[0].normal_texcoord, m[0].normal_scale);
    CHECK(m[1].normal_texture == 0 && m[1].normal_texcoord == 1 && m[1].normal_scale == 1.f && m[1].normal_transform.transformed &&
              m[1].normal_transform.m[2] == 0.25f,
          "material 1: texture %d set %d scale %g transformed %d offset %g", m[1].normal_texture, m[1].normal_texcoord,
          m[1].normal_scale, m[1].normal_transform.transformed, m[1].normal_transform.m[2]);
    CHECK(s.uvs1 != NULL, "TEXCOORD_1 is kept: the normal texture of material 1 reads it");
    /* per triangle pair: the tangent every corner must have (xyz, w) */
    static const float want[5][4] = {{1, 0, 0, 1},   /* generated from (x, 1-y) */
                                     {0, 1, 0, 1},   /* generated from set 1 (y, x): +u = +y, v = x, so w = +1 */
                                     {-1, 0, 0, -1}, /* TANGENT (0,1,0,-1) turned a quarter about z */
                                     {0, 1, 0, 1},   /* quantized TANGENT under scale (-1,1,1): w flips */
                                     {1, 0, 0, 1}};  /* generated per shared vertex (NORMAL given) */
    for (uint32_t tri = 0; tri < 10; tri++)
        for (int k = 0; k < 3; k++) {
            const float *t = s.tangents + 4 * (size_t)s.indices[3 * tri + k];
            const float *w = want[tri / 2];
            CHECK(fabsf(t[0] - w[0]) < 1e-5f && fabsf(t[1] - w[1]) < 1e-5f && fabsf(t[2] - w[2]) < 1e-5f && t[3] == w[3],
                  "triangle %u corner %d: tangent (%g %g %g %g), want (%g %g %g %g)", tri, k, t[0], t[1], t[2], t[3], w[0],
                  w[1], w[2], w[3]);
        }
    /* the flat map: ns stays the interpolated normal (128/255 is 0.0039 off centre: within 1e-2) */
    for (uint32_t tri = 0; tri < 10; tri++) {
        pm_surface sf;
        pm_scene_surface(&s, tri, 0.3f, 0.2f, &sf);
        CHECK(v3_length(v3_sub(sf.ns, v3(0, 0, 1))) < 1e-2f, "triangle %u: flat map moved ns to (%g %g %g)", tri, sf.ns.x,
              sf.ns.y, sf.ns.z);
    }
    pm_scene_free(&s);
}

/* glTF: TANGENT's w is +1 or -1. Others are read by their sign (0 and NaN as +1), in one warning
 * per primitive that counts them. */
static void test_tangent_w(void) {
    static const unsigned char flat_texel[1][16] = {{128, 128, 255, 255}};
    static const int width[1] = {1};
    static const float uv0[8] = {0, 1, 1, 1, 1, 0, 0, 0};
    static const float normals[12] = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1};
    static const float tangents[16] = {1, 0, 0, 0, 1, 0, 0, 0.5f, 1, 0, 0, -0.5f, 1, 0, 0, -1};
    blob *b = calloc(1, sizeof *b);
    text body = {0};
    int pos = blob_accessor(b, quad_positions, sizeof quad_positions, 4, 5126, "VEC3", 0);
    int t0 = blob_accessor(b, uv0, sizeof uv0, 4, 5126, "VEC2", 0);
    int ix = blob_accessor(b, quad_indices, sizeof quad_indices, 6, 5123, "SCALAR", 0);
    int nrm = blob_accessor(b, normals, sizeof normals, 4, 5126, "VEC3", 0);
    int tan = blob_accessor(b, tangents, sizeof tangents, 4, 5126, "VEC4", 0);
    append_strip_images(&body, flat_texel, width, 1);
    text_append(&body, "\"materials\":[{\"normalTexture\":{\"index\":0}}],\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
                       "\"meshes\":[{\"name\":\"panel\",\"primitives\":[{\"attributes\":{\"POSITION\":%d,\"NORMAL\":%d,"
                       "\"TEXCOORD_0\":%d,\"TANGENT\":%d},\"indices\":%d,\"material\":0}]}]",
                pos, nrm, t0, tan, ix);
    write_blob_model("tangent_w.gltf", b, body.data);
    free(body.data);
    free(b);
    pm_scene s;
    pm_load_report r;
    char warnings[4096];
    if (!load_warned("tangent_w.gltf", &s, &r, warnings, sizeof warnings)) return;
    static const float want_w[4] = {1, 1, -1, -1};
    if (s.vertex_count == 4 && s.tangents)
        for (int i = 0; i < 4; i++) CHECK(s.tangents[4 * i + 3] == want_w[i], "vertex %d: w %g, want %g", i, s.tangents[4 * i + 3], want_w[i]);
    else CHECK(0, "vertices %u tangents %p", s.vertex_count, (void *)s.tangents);
    CHECK(r.warnings == 1 && line_count(warnings) == 1, "one warning, got %u:\n%s", r.warnings, warnings);
    CHECK_WARNED(warnings, "mesh 0 (panel) primitive 0 TANGENT: 3 of its 4 w values are not +1 or -1 (first 0 at vertex 0); "
                           "read by their sign, 0 or NaN as +1\n");
    pm_scene_free(&s);
}

/* ---------------------------------------------------------------- occlusion, unlit, samplers, KTX2: issue 31 */

/* The unit quad (TEXCOORD_0 = its xy) with material 0, one 2 x 2 RGBA PNG as image 0 and texture 0
 * on sampler 0 (`sampler`, a JSON object), and `members` (more top-level members, ending in a
 * comma, or ""): the materials and whatever the case adds. */
static void write_textured_quad_with(const char *name, const unsigned char rgba[16], const char *sampler, const char *textures,
                                     const char *members);
static void write_textured_quad(const char *name, const unsigned char rgba[16], const char *sampler, const char *members) {
    write_textured_quad_with(name, rgba, sampler, "[{\"source\":0,\"sampler\":0}]", members);
}
/* The same with the textures array given (JSON). */
static void write_textured_quad_with(const char *name, const unsigned char rgba[16], const char *sampler, const char *textures,
                                     const char *members) {
    static const float uv[8] = {0, 0, 1, 0, 1, 1, 0, 1};
    blob *b = calloc(1, sizeof *b);
    text body = {0}, prim = {0};
    if (!b) abort();
    quad_primitive(b, &prim, uv, NULL, 0);
    int size = 0;
    unsigned char *png = stbi_write_png_to_mem(rgba, 8, 2, 2, 4, &size);
    if (!png) abort();
    text_append(&body, "\"images\":[");
    append_png_image(&body, png, (size_t)size, true);
    free(png);
    text_append(&body, "],\"samplers\":[%s],\"textures\":%s,%s", sampler, textures, members);
    text_append(&body, "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],\"meshes\":[{\"primitives\":[%s]}]", prim.data);
    write_blob_model(name, b, body.data);
    free(body.data);
    free(prim.data);
    free(b);
}

static const unsigned char checker_2x2[16] = {255, 255, 255, 255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255, 255};

/* An occlusion texture is left out by design (the tracer computes occlusion): counted for
 * `stat load occlusion_textures_ignored`, no warning, not an ignored input. */
static void test_occlusion_texture_silent(void) {
    write_textured_quad("occlusion.gltf", checker_2x2, "{}",
                        "\"materials\":[{\"occlusionTexture\":{\"index\":0,\"strength\":0.5},"
                        "\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0}}}],");
    pm_scene s;
    pm_load_report r;
    char warnings[2048];
    if (!load_warned("occlusion.gltf", &s, &r, warnings, sizeof warnings)) return;
    CHECK(r.occlusion_textures_ignored == 1, "occlusion_textures_ignored %u, want 1", r.occlusion_textures_ignored);
    CHECK(r.ignored_inputs == 0 && r.warnings == 0 && warnings[0] == '\0', "an occlusion texture warns nothing: %u inputs, %u warnings:\n%s",
          r.ignored_inputs, r.warnings, warnings);
    pm_scene_free(&s);
}

/* Sampler filters reach the texture: magFilter NEAREST, each minFilter, absent ones as LINEAR /
 * trilinear, and a value glTF does not define warned once and read as the default. */
static void test_sampler_filters(void) {
    static const struct { const char *sampler; bool mag_nearest; int min_filter; unsigned warnings; } cases[] = {
        {"{}", false, PM_MIN_DEFAULT, 0},
        {"{\"magFilter\":9728}", true, PM_MIN_DEFAULT, 0},
        {"{\"magFilter\":9729,\"minFilter\":9728}", false, PM_MIN_NEAREST, 0},
        {"{\"minFilter\":9729}", false, PM_MIN_LINEAR, 0},
        {"{\"magFilter\":9728,\"minFilter\":9984}", true, PM_MIN_NEAREST_MIPMAP_NEAREST, 0},
        {"{\"minFilter\":9985}", false, PM_MIN_LINEAR_MIPMAP_NEAREST, 0},
        {"{\"minFilter\":9986}", false, PM_MIN_NEAREST_MIPMAP_LINEAR, 0},
        {"{\"minFilter\":9987}", false, PM_MIN_LINEAR_MIPMAP_LINEAR, 0},
        {"{\"magFilter\":9984,\"minFilter\":1}", false, PM_MIN_DEFAULT, 2},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        write_textured_quad("filters.gltf", checker_2x2, cases[c].sampler,
                            "\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0}}}],");
        pm_scene s;
        pm_load_report r;
        char warnings[2048];
        if (!load_warned("filters.gltf", &s, &r, warnings, sizeof warnings)) continue;
        if (s.texture_count == 1)
            CHECK(s.textures[0].mag_nearest == cases[c].mag_nearest && s.textures[0].min_filter == cases[c].min_filter,
                  "sampler %s: mag_nearest %d min_filter %d, want %d %d", cases[c].sampler, s.textures[0].mag_nearest,
                  s.textures[0].min_filter, cases[c].mag_nearest, cases[c].min_filter);
        else CHECK(0, "sampler %s: %u textures", cases[c].sampler, s.texture_count);
        CHECK(r.warnings == cases[c].warnings, "sampler %s: %u warnings, want %u:\n%s", cases[c].sampler, r.warnings,
              cases[c].warnings, warnings);
        if (cases[c].warnings) {
            CHECK_WARNED(warnings, "sampler 0 magFilter 9984 is not a glTF magnification filter; using LINEAR");
            CHECK_WARNED(warnings, "sampler 0 minFilter 1 is not a glTF minification filter; using LINEAR_MIPMAP_LINEAR");
        }
        pm_scene_free(&s);
    }
    write_textured_quad("filter_type.gltf", checker_2x2, "{\"magFilter\":\"NEAREST\"}",
                        "\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0}}}],");
    check_rejected("filter_type.gltf", "magFilter");
}

/* gltfpack writes an image with neither uri nor bufferView for every image it could not read: the
 * file loads, one `ignored:` line counts them and names the first, their textures are left out
 * (the materials keep their factors), and nothing else is warned. */
static void test_sourceless_images_ignored(void) {
    write_text("sourceless.gltf",
               "{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
               "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":1},\"material\":0}]}],"
               "\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,0.25,1,1],\"baseColorTexture\":{\"index\":0}},"
               "\"emissiveTexture\":{\"index\":1}}],"
               "\"textures\":[{\"source\":1},{\"source\":2}],"
               "\"images\":[{\"name\":\"unused\"},{\"mimeType\":\"image/png\",\"name\":\"albedo\"},{\"mimeType\":\"image/jpeg\"}],"
               "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]},"
               "{\"bufferView\":1,\"componentType\":5126,\"count\":3,\"type\":\"VEC2\"}],"
               "\"bufferViews\":[{\"buffer\":0,\"byteLength\":36},{\"buffer\":0,\"byteOffset\":36,\"byteLength\":24}],"
               "\"buffers\":[{\"byteLength\":60,\"uri\":\"data:application/octet-stream;base64,"
               "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAAAAAAAAAAAAIA/AAAAAAAAAAAAAIA/\"}]}");
    pm_scene s;
    pm_load_report r;
    char warnings[2048];
    if (!load_warned("sourceless.gltf", &s, &r, warnings, sizeof warnings)) return;
    CHECK_WARNED(warnings, "ignored: 3 image(s) with neither uri nor bufferView (no data; their textures are left out), first image 0\n");
    CHECK(line_count(warnings) == 1 && r.warnings == 1, "one warning line, got %u:\n%s", r.warnings, warnings);
    CHECK(s.texture_count == 0 && s.material_count == 1 && s.materials[0].base_color_texture == -1,
          "the textures are left out: %u textures, base colour texture %d", s.texture_count,
          s.material_count ? s.materials[0].base_color_texture : -2);
    if (s.material_count) CHECK_VEC(s.materials[0].base_color, 0.5, 0.25, 1.0, 1e-7, "the base colour factor stays");
    CHECK(s.triangle_count == 1, "the triangle loads (%u)", s.triangle_count);
    pm_scene_free(&s);
}

/* What pmview leaves out is named, one `ignored:` line per kind: material extensions it does not
 * render (iridescence, anisotropy, dispersion, volume scattering, diffuse transmission), and a
 * texture whose only image is KTX2 (KHR_texture_basisu, used but not required). A KTX2 texture
 * with a PNG fallback reads the fallback; KHR_texture_basisu required is refused. */
static void test_ignored_kinds_named(void) {
    write_textured_quad("unrendered.gltf", checker_2x2, "{}",
                        "\"extensionsUsed\":[\"KHR_materials_iridescence\",\"KHR_materials_anisotropy\","
                        "\"KHR_materials_dispersion\",\"KHR_materials_volume_scatter\",\"KHR_materials_diffuse_transmission\"],"
                        "\"materials\":[{\"name\":\"film\",\"extensions\":{\"KHR_materials_iridescence\":{\"iridescenceFactor\":1},"
                        "\"KHR_materials_anisotropy\":{\"anisotropyStrength\":0.5},\"KHR_materials_dispersion\":{\"dispersion\":0.1},"
                        "\"KHR_materials_volume_scatter\":{},\"KHR_materials_diffuse_transmission\":{}}}],");
    pm_scene s;
    pm_load_report r;
    char warnings[4096];
    if (load_warned("unrendered.gltf", &s, &r, warnings, sizeof warnings)) {
        static const char *const kinds[] = {"KHR_materials_iridescence", "KHR_materials_anisotropy", "KHR_materials_dispersion",
                                            "KHR_materials_volume_scatter", "KHR_materials_diffuse_transmission"};
        char line[256];
        for (size_t k = 0; k < sizeof kinds / sizeof kinds[0]; k++) {
            snprintf(line, sizeof line, "ignored: %s in 1 material(s), first material 0 film\n", kinds[k]);
            CHECK_WARNED(warnings, line);
        }
        CHECK(r.ignored_inputs == 5 && r.warnings == 6, "5 ignored inputs (%u), a line each and the used-extension list (%u warnings):\n%s",
              r.ignored_inputs, r.warnings, warnings);
        pm_scene_free(&s);
    }

    const char *material = "\"extensionsUsed\":[\"KHR_texture_basisu\"],"
                           "\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0}}}],";
    write_textured_quad_with("ktx2_only.gltf", checker_2x2, "{}", "[{\"extensions\":{\"KHR_texture_basisu\":{\"source\":0}}}]", material);
    if (load_warned("ktx2_only.gltf", &s, &r, warnings, sizeof warnings)) {
        CHECK_WARNED(warnings, "ignored: textures whose only image is KTX2 in KHR_texture_basisu in 1 material(s), first material 0\n");
        CHECK_WARNED(warnings, "ignoring unsupported extension(s) KHR_texture_basisu (used, not required)");
        CHECK(s.texture_count == 0 && s.material_count == 1 && s.materials[0].base_color_texture == -1 && r.ignored_inputs == 1 &&
                  r.warnings == 2,
              "a KTX2-only texture is left out: %u textures, %u ignored inputs, %u warnings:\n%s", s.texture_count, r.ignored_inputs,
              r.warnings, warnings);
        pm_scene_free(&s);
    }
    write_textured_quad_with("ktx2_fallback.gltf", checker_2x2, "{}",
                             "[{\"source\":0,\"sampler\":0,\"extensions\":{\"KHR_texture_basisu\":{\"source\":0}}}]", material);
    if (load_warned("ktx2_fallback.gltf", &s, &r, warnings, sizeof warnings)) {
        CHECK(s.texture_count == 1 && s.materials[0].base_color_texture == 0 && r.ignored_inputs == 0 && r.warnings == 1,
              "a KTX2 texture with a PNG fallback reads it: %u textures, %u ignored, %u warnings:\n%s", s.texture_count,
              r.ignored_inputs, r.warnings, warnings);
        if (s.texture_count == 1) CHECK(s.textures[0].rgba[0] == 255 && s.textures[0].rgba[4] == 0, "the fallback's texels");
        pm_scene_free(&s);
    }
    write_textured_quad_with("ktx2_required.gltf", checker_2x2, "{}", "[{\"extensions\":{\"KHR_texture_basisu\":{\"source\":0}}}]",
                             "\"extensionsUsed\":[\"KHR_texture_basisu\"],\"extensionsRequired\":[\"KHR_texture_basisu\"],"
                             "\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0}}}],");
    check_rejected("ktx2_required.gltf", "required extension KHR_texture_basisu is not supported");
}

/* KHR_materials_unlit is read, not ignored: the material is unlit, its emission dropped (the
 * extension ignores every other input), and the file may require it. */
static void test_unlit_material(void) {
    write_textured_quad("unlit.gltf", checker_2x2, "{}",
                        "\"extensionsUsed\":[\"KHR_materials_unlit\"],\"extensionsRequired\":[\"KHR_materials_unlit\"],"
                        "\"materials\":[{\"extensions\":{\"KHR_materials_unlit\":{}},\"emissiveFactor\":[1,1,1],"
                        "\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,0.25,1,1],\"baseColorTexture\":{\"index\":0}}}],");
    pm_scene s;
    pm_load_report r;
    char warnings[2048];
    if (!load_warned("unlit.gltf", &s, &r, warnings, sizeof warnings)) return;
    CHECK(r.warnings == 0 && r.ignored_inputs == 0, "unlit is rendered: %u warnings, %u ignored:\n%s", r.warnings, r.ignored_inputs, warnings);
    if (s.material_count == 1) {
        const pm_material *m = &s.materials[0];
        CHECK(m->unlit && v3_is_black(m->emission) && m->base_color.x == 0.5f && m->base_color.y == 0.25f && m->base_color_texture == 0,
              "unlit material: unlit %d emission (%g %g %g) base (%g %g %g) texture %d", m->unlit, m->emission.x, m->emission.y,
              m->emission.z, m->base_color.x, m->base_color.y, m->base_color.z, m->base_color_texture);
        pm_scene_finalize(&s, false, NULL);
        CHECK(s.analysis.has_unlit && s.emitter_count == 0, "analysis unlit %d, %u emitters", s.analysis.has_unlit, s.emitter_count);
    } else CHECK(0, "material_count %u", s.material_count);
    pm_scene_free(&s);
}

/* ---------------------------------------------------------------- main */

/* Inputs pmview does not render are counted (stat load ignored_inputs) and warned once per kind;
 * alpha modes are read (mode, cutoff, the base colour factor's alpha) and so not warned about. */
static void test_ignored_inputs(void) {
    prim_spec prims[4];
    for (int i = 0; i < 4; i++) {
        prim_spec p = {unit_triangle, 3, NULL, NULL, 0, NULL, 0, 0, -1, i};
        prims[i] = p;
    }
    doc_spec doc = {NULL, NULL,
                    "[{\"name\":\"leaves\",\"alphaMode\":\"MASK\",\"alphaCutoff\":0.3,"
                    "\"pbrMetallicRoughness\":{\"baseColorFactor\":[1,1,1,0.25]}},{\"alphaMode\":\"MASK\"},"
                    "{\"alphaMode\":\"BLEND\",\"pbrMetallicRoughness\":{\"baseColorFactor\":[1,1,1,0.7]},"
                    "\"extensions\":{\"KHR_materials_iridescence\":{\"iridescenceFactor\":1}}},{}]",
                    "\"extensionsUsed\":[\"KHR_materials_iridescence\"],"};
    write_model("ignored.gltf", prims, 4, &doc);
    pm_scene s;
    pm_load_report r;
    if (!load_ok("ignored.gltf", &s, &r)) return;
    /* one iridescence use; warnings: iridescence once and the unsupported extension list */
    CHECK(r.ignored_inputs == 1, "ignored inputs %u (1 iridescence; alpha modes are rendered)", r.ignored_inputs);
    CHECK(r.warnings == 2, "warnings %u: iridescence and the unsupported extension list", r.warnings);
    if (s.material_count == 4) {
        const pm_material *m = s.materials;
        CHECK(m[0].alpha_mode == PM_ALPHA_MASK && m[0].alpha_cutoff == 0.3f && m[0].alpha == 0.25f,
              "MASK: mode %d cutoff %g alpha %g", m[0].alpha_mode, m[0].alpha_cutoff, m[0].alpha);
        CHECK(m[1].alpha_mode == PM_ALPHA_MASK && m[1].alpha_cutoff == 0.5f && m[1].alpha == 1.f,
              "MASK defaults: mode %d cutoff %g alpha %g", m[1].alpha_mode, m[1].alpha_cutoff, m[1].alpha);
        CHECK(m[2].alpha_mode == PM_ALPHA_BLEND && m[2].alpha == 0.7f, "BLEND: mode %d alpha %g", m[2].alpha_mode, m[2].alpha);
        CHECK(m[3].alpha_mode == PM_ALPHA_OPAQUE && m[3].alpha == 1.f, "default OPAQUE: mode %d alpha %g", m[3].alpha_mode,
              m[3].alpha);
        CHECK(pm_material_can_be_transparent(&s, &m[0]) && !pm_material_can_be_transparent(&s, &m[1]) &&
                  pm_material_can_be_transparent(&s, &m[2]) && !pm_material_can_be_transparent(&s, &m[3]),
              "MASK alpha 0.25 < 0.3 and BLEND 0.7 can be see-through; MASK alpha 1 and OPAQUE cannot");
        pm_scene_finalize(&s, false, NULL);
        CHECK(s.analysis.has_non_opaque, "the analysis knows the scene has non-opaque materials");
    } else CHECK(0, "material_count %u", s.material_count);
    pm_scene_free(&s);
}

/* ---------------------------------------------------------------- issue 11: what glTF forbids, any scale */

/* Members of the wrong type or length, which tinygltf 2.7 replaced by their defaults (a white
 * material, a unit light), and indices pmview does not use that still must resolve. */
static void test_wrong_types_and_indices(void) {
    prim_spec tri = {unit_triangle, 3, NULL, NULL, 0, NULL, 0, 0, -1, 0};
    static const struct { const char *name, *nodes, *materials, *extra, *expect; } cases[] = {
        {"bcf3.gltf", NULL, "[{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,0.5,0.5]}}]", NULL,
         "baseColorFactor must be 4 numbers, got 3 (material 0 pbrMetallicRoughness)"},
        {"bcf_element.gltf", NULL, "[{\"pbrMetallicRoughness\":{\"baseColorFactor\":[1,\"a\",1,1]}}]", NULL,
         "baseColorFactor must be 4 numbers, got \"a\" at [1] (material 0 pbrMetallicRoughness)"},
        {"rough_string.gltf", NULL, "[{\"pbrMetallicRoughness\":{\"roughnessFactor\":\"0.5\"}}]", NULL,
         "roughnessFactor must be a finite number, got \"0.5\" (material 0 pbrMetallicRoughness)"},
        {"metal_string.gltf", NULL, "[{\"pbrMetallicRoughness\":{\"metallicFactor\":\"0\"}}]", NULL,
         "metallicFactor must be a finite number, got \"0\" (material 0 pbrMetallicRoughness)"},
        {"pbr_array.gltf", NULL, "[{\"pbrMetallicRoughness\":[0]}]", NULL,
         "pbrMetallicRoughness must be an object, got an array (material 0)"},
        {"emissive_string.gltf", NULL, "[{\"emissiveFactor\":\"1\"}]", NULL, "emissiveFactor must be 3 numbers, got \"1\" (material 0)"},
        {"double_sided.gltf", NULL, "[{\"doubleSided\":1}]", NULL, "doubleSided must be true or false, got 1 (material 0)"},
        {"alpha_mode.gltf", NULL, "[{\"alphaMode\":\"CUTOUT\"}]", NULL,
         "alphaMode must be one of OPAQUE, MASK, BLEND, got \"CUTOUT\" (material 0)"},
        {"cutoff.gltf", NULL, "[{\"alphaCutoff\":\"0.5\"}]", NULL, "alphaCutoff must be a finite number"},
        {"ior.gltf", NULL, "[{\"extensions\":{\"KHR_materials_ior\":{\"ior\":\"1.5\"}}}]", NULL,
         "ior must be a finite number, got \"1.5\" (material 0 KHR_materials_ior)"},
        {"transmission.gltf", NULL, "[{\"extensions\":{\"KHR_materials_transmission\":{\"transmissionFactor\":[1]}}}]", NULL,
         "transmissionFactor must be a finite number, got an array (material 0 KHR_materials_transmission)"},
        {"strength.gltf", NULL, "[{\"extensions\":{\"KHR_materials_emissive_strength\":{\"emissiveStrength\":\"9\"}}}]", NULL,
         "emissiveStrength must be a finite number"},
        {"attenuation.gltf", NULL, "[{\"extensions\":{\"KHR_materials_volume\":{\"attenuationColor\":[1,1]}}}]", NULL,
         "attenuationColor must be 3 numbers, got 2 (material 0 KHR_materials_volume)"},
        {"volume_texture.gltf", NULL, "[{\"extensions\":{\"KHR_materials_volume\":{\"thicknessTexture\":{\"index\":4}}}}]", NULL,
         "texture 4 does not exist (material 0 KHR_materials_volume thicknessTexture)"},
        {"light_intensity.gltf", "[{\"mesh\":0,\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}}]", "[{}]",
         "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":[{\"type\":\"point\",\"intensity\":\"5\"}]}},",
         "intensity must be a finite number, got \"5\" (light 0)"},
        {"light_color.gltf", "[{\"mesh\":0}]", "[{}]",
         "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":[{\"type\":\"point\",\"color\":[1,1]}]}},",
         "color must be 3 numbers, got 2 (light 0)"},
        {"light_type.gltf", "[{\"mesh\":0}]", "[{}]",
         "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":[{\"type\":\"area\"}]}},",
         "type must be one of directional, point, spot, got \"area\" (light 0)"},
        {"light_spot.gltf", "[{\"mesh\":0}]", "[{}]",
         "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":[{\"type\":\"spot\",\"spot\":{\"outerConeAngle\":\"1\"}}]}},",
         "outerConeAngle must be a finite number, got \"1\" (light 0 spot)"},
        {"camera_yfov.gltf", "[{\"mesh\":0},{\"camera\":0}]", "[{}]",
         "\"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":\"1\",\"znear\":0.1}}],",
         "yfov must be a finite number, got \"1\" (camera 0 perspective)"},
        {"camera_missing.gltf", "[{\"mesh\":0}]", "[{}]", "\"cameras\":[{\"type\":\"orthographic\"}],",
         "missing orthographic object (camera 0)"},
        {"node_scale.gltf", "[{\"mesh\":0,\"scale\":\"big\"}]", "[{}]", NULL, "scale must be 3 numbers, got \"big\" (node 0)"},
        {"node_translation.gltf", "[{\"mesh\":0,\"translation\":[1,\"2\",3]}]", "[{}]", NULL,
         "translation must be 3 numbers, got \"2\" at [1] (node 0)"},
        {"skin_joint.gltf", "[{\"mesh\":0}]", "[{}]", "\"skins\":[{\"joints\":[5]}],", "node 5 does not exist (skin 0 joint 0)"},
        {"skin_matrices.gltf", "[{\"mesh\":0}]", "[{}]", "\"skins\":[{\"joints\":[0],\"inverseBindMatrices\":9}],",
         "accessor 9 does not exist (skin 0 inverseBindMatrices)"},
        {"skin_skeleton.gltf", "[{\"mesh\":0}]", "[{}]", "\"skins\":[{\"joints\":[0],\"skeleton\":3}],",
         "node 3 does not exist (skin 0 skeleton)"},
        {"animation_node.gltf", "[{\"mesh\":0}]", "[{}]",
         "\"animations\":[{\"samplers\":[{\"input\":0,\"output\":0}],"
         "\"channels\":[{\"sampler\":0,\"target\":{\"node\":9,\"path\":\"scale\"}}]}],",
         "node 9 does not exist (animation 0 channel 0 target)"},
        {"animation_sampler.gltf", "[{\"mesh\":0}]", "[{}]",
         "\"animations\":[{\"samplers\":[{\"input\":0,\"output\":0}],"
         "\"channels\":[{\"sampler\":1,\"target\":{\"node\":0,\"path\":\"scale\"}}]}],",
         "animation sampler 1 does not exist (animation 0 channel 0)"},
        {"animation_output.gltf", "[{\"mesh\":0}]", "[{}]",
         "\"animations\":[{\"samplers\":[{\"input\":0,\"output\":8}],"
         "\"channels\":[{\"sampler\":0,\"target\":{\"node\":0,\"path\":\"scale\"}}]}],",
         "accessor 8 does not exist (animation 0 sampler 0 output)"},
        {"basisu_source.gltf", "[{\"mesh\":0}]", "[{}]", "\"textures\":[{\"extensions\":{\"KHR_texture_basisu\":{\"source\":5}}}],",
         "image 5 does not exist (texture 0 KHR_texture_basisu)"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        doc_spec doc = {cases[i].nodes, NULL, cases[i].materials, cases[i].extra};
        write_model(cases[i].name, &tri, 1, &doc);
        check_rejected(cases[i].name, cases[i].expect);
    }

    /* a morph target whose accessor does not exist: the primitive is written by hand */
    write_text("morph_target.gltf",
               "{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
               "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"targets\":[{\"POSITION\":7}]}]}],"
               "\"buffers\":[{\"byteLength\":36,\"uri\":\"data:application/octet-stream;base64,"
               "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA\"}],"
               "\"bufferViews\":[{\"buffer\":0,\"byteLength\":36}],"
               "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"}]}");
    check_rejected("morph_target.gltf", "accessor 7 does not exist (mesh 0 primitive 0 morph target 0 POSITION)");

    /* the same members, well formed, alongside a skin and an animation: loads, and reads them */
    doc_spec good = {"[{\"mesh\":0,\"scale\":[2,2,2],\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}},{\"camera\":0}]", "[0,1]",
                     "[{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,0.25,1,1],\"roughnessFactor\":0.5,\"metallicFactor\":0},"
                     "\"alphaMode\":\"OPAQUE\",\"doubleSided\":true,\"emissiveFactor\":[0,0,0]}]",
                     "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":[{\"type\":\"spot\",\"color\":[1,1,1],\"intensity\":3,"
                     "\"spot\":{\"outerConeAngle\":0.5}}]}},"
                     "\"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":1,\"znear\":0.1}}],"
                     "\"skins\":[{\"joints\":[0,1],\"skeleton\":0}],"
                     "\"animations\":[{\"samplers\":[{\"input\":0,\"output\":0,\"interpolation\":\"STEP\"}],"
                     "\"channels\":[{\"sampler\":0,\"target\":{\"node\":1,\"path\":\"translation\"}}]}],"};
    write_model("typed_good.gltf", &tri, 1, &good);
    pm_scene s;
    pm_load_report r;
    if (load_ok("typed_good.gltf", &s, &r)) {
        CHECK(s.material_count == 1 && s.light_count == 1 && s.camera_count == 1, "materials %u lights %u cameras %u",
              s.material_count, s.light_count, s.camera_count);
        if (s.material_count == 1) {
            CHECK_VEC(s.materials[0].base_color, 0.5, 0.25, 1, 0, "base colour as written");
            CHECK(s.materials[0].roughness == 0.5f && s.materials[0].double_sided, "roughness %g", s.materials[0].roughness);
        }
        pm_scene_free(&s);
    }
}

/* A 2x2 24-bit BMP stored top-down (negative height): stb_image's info call reports the height
 * as -2, which an unsigned reading would take for 18446744073709551614 and refuse. */
static void test_top_down_bmp(void) {
    static const unsigned char bmp[70] = {
        'B', 'M', 70, 0, 0, 0, 0, 0, 0, 0, 54, 0, 0, 0,                  /* file header: size 70, pixels at 54 */
        40, 0, 0, 0, 2, 0, 0, 0, 0xfe, 0xff, 0xff, 0xff, 1, 0, 24, 0,      /* info header: 2 x -2, 1 plane, 24 bits */
        0, 0, 0, 0, 16, 0, 0, 0, 0x13, 0x0b, 0, 0, 0x13, 0x0b, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
        0, 0, 255, 0, 255, 0, 0, 0,         /* first row in the file = top: red, green (BGR), 2 bytes padding */
        255, 0, 0, 255, 255, 255, 0, 0};    /* bottom: blue, white */
    text extra = {0};
    text_append(&extra, "\"images\":[{\"uri\":\"data:image/bmp;base64,");
    base64_append(&extra, bmp, sizeof bmp);
    text_append(&extra, "\"}],\"textures\":[{\"source\":0}],");
    static const float uvs[6] = {0, 0, 1, 0, 0, 1};
    prim_spec tri = {unit_triangle, 3, NULL, uvs, 0, NULL, 0, 0, -1, 0};
    doc_spec doc = {NULL, NULL, "[{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0}}}]", extra.data};
    write_model("top_down_bmp.gltf", &tri, 1, &doc);
    free(extra.data);
    pm_scene s;
    pm_load_report r;
    if (!load_ok("top_down_bmp.gltf", &s, &r)) return;
    CHECK(s.texture_count == 1 && r.warnings == 0, "the BMP must decode: %u textures, %u warnings", s.texture_count, r.warnings);
    if (s.texture_count == 1) {
        const pm_texture *t = &s.textures[0];
        static const unsigned char want[16] = {255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 255, 255, 255, 255};
        CHECK(t->width == 2 && t->height == 2, "size %dx%d", t->width, t->height);
        CHECK(t->width == 2 && t->height == 2 && memcmp(t->rgba, want, 16) == 0,
              "row 0 must be the top row (red, green): %u %u %u, %u %u %u", t->rgba[0], t->rgba[1], t->rgba[2], t->rgba[4],
              t->rgba[5], t->rgba[6]);
    }
    pm_scene_free(&s);
}

/* Largest extent of the loaded vertices. */
static double loaded_extent(const pm_scene *s) {
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY}, e = 0;
    for (uint32_t v = 0; v < s->vertex_count; v++)
        for (int k = 0; k < 3; k++) {
            lo[k] = fmin(lo[k], v3_get(s->positions[v], k));
            hi[k] = fmax(hi[k], v3_get(s->positions[v], k));
        }
    for (int k = 0; k < 3; k++) e = fmax(e, hi[k] - lo[k]);
    return e;
}

/* A triangle at scales whose float cross product underflows (1e-12: its squared length is
 * 1e-48) or overflows (1e30), and beyond float's range in the file's own transform (1e-40,
 * 1e38 x the triangle): every one loads, framed near unit size by a power of two, with the
 * camera and a point light framed alike (the same irradiance). */
static void test_any_scale(void) {
    static const double scales[] = {1e-12, 1e30, 1e-40, 1e38, 1};
    for (size_t i = 0; i < sizeof scales / sizeof scales[0]; i++) {
        char nodes[512];
        snprintf(nodes, sizeof nodes,
                 "[{\"scale\":[%.17g,%.17g,%.17g],\"children\":[1,2,3]},{\"mesh\":0},"
                 "{\"camera\":0,\"translation\":[0.25,0.25,4]},"
                 "{\"translation\":[0,0,2],\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}}]",
                 scales[i], scales[i], scales[i]);
        doc_spec doc = {nodes, NULL, NULL,
                        "\"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":0.5,\"znear\":0.5}}],"
                        "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":[{\"type\":\"point\",\"intensity\":8}]}},"};
        prim_spec tri = {unit_triangle, 3, NULL, NULL, 0, NULL, 0, 0, -1, -1};
        write_model("scaled.gltf", &tri, 1, &doc);
        pm_scene s;
        pm_load_report r;
        if (!load_ok("scaled.gltf", &s, &r)) {
            fprintf(stderr, "  (scale %g)\n", scales[i]);
            continue;
        }
        double k = r.unit_scale * scales[i]; /* scene units per triangle unit */
        CHECK(s.triangle_count == 1 && r.skipped_degenerate == 0, "scale %g: %u triangles, %u degenerate", scales[i],
              s.triangle_count, r.skipped_degenerate);
        CHECK(r.unit_scale == ldexp(1.0, ilogb(r.unit_scale)), "scale %g: unit_scale %g is a power of two", scales[i], r.unit_scale);
        CHECK(scales[i] != 1 || r.unit_scale == 1, "a unit-size scene is not rescaled (unit_scale %g)", r.unit_scale);
        CHECK(k > 0.5 && k <= 2, "scale %g: the triangle spans %g scene units, want (0.5, 2]", scales[i], k);
        if (s.triangle_count == 1) {
            CHECK_NEAR(loaded_extent(&s), k, 1e-6, 0, "extent of the framed triangle");
            CHECK_VEC(tri_geometric_normal(&s, 0), 0, 0, 1, 1e-6, "geometric normal");
            CHECK_VEC(s.normals[s.indices[0]], 0, 0, 1, 1e-6, "generated shading normal");
        }
        if (s.camera_count == 1 && s.light_count == 1) {
            CHECK_VEC(s.cameras[0].position, 0.25 * k, 0.25 * k, 4 * k, 1e-6 * k, "camera framed with the scene");
            /* znear and light intensities are not scaled by node transforms (glTF), only by the framing */
            CHECK_NEAR(s.cameras[0].znear, fmin(0.5 * r.unit_scale, FLT_MAX), 1e-6, 0, "znear framed with the scene");
            CHECK_VEC(s.lights[0].position, 0, 0, 2 * k, 1e-6 * k, "light framed with the scene");
            /* the irradiance the light gives the triangle, 8 / (2 scale)^2, is kept: 8 unit_scale^2
             * over the framed distance squared; beyond what a film can sum it is clamped (with a warning) */
            double want = 8 * r.unit_scale * r.unit_scale;
            if (want <= PM_MAX_EMISSION) CHECK_NEAR(s.lights[0].intensity.x, want, 1e-6, 1e-44, "point light irradiance kept");
            else CHECK(s.lights[0].intensity.x == PM_MAX_EMISSION && r.warnings >= 1,
                       "scale %g: intensity %g, want PM_MAX_EMISSION and a warning", scales[i], s.lights[0].intensity.x);
        } else CHECK(0, "scale %g: cameras %u lights %u", scales[i], s.camera_count, s.light_count);
        pm_scene_free(&s);
    }

    /* The light scaled with the scene, 8 scale^2 (the same irradiance on the triangle at any
     * scale), is 8 x (scene units per triangle unit)^2 once framed: the framing is applied in
     * double before any float or clamp (8e76 became FLT_MAX first, 1e-60 of the irradiance, and 8e-80 became 0). */
    for (size_t i = 0; i < sizeof scales / sizeof scales[0]; i++) {
        char nodes[512], extra[512];
        snprintf(nodes, sizeof nodes,
                 "[{\"scale\":[%.17g,%.17g,%.17g],\"children\":[1,2]},{\"mesh\":0},"
                 "{\"translation\":[0,0,2],\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}}]",
                 scales[i], scales[i], scales[i]);
        snprintf(extra, sizeof extra,
                 "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":[{\"type\":\"spot\",\"spot\":{},\"intensity\":%.17g}]}},",
                 8 * scales[i] * scales[i]);
        doc_spec doc = {nodes, NULL, NULL, extra};
        prim_spec tri = {unit_triangle, 3, NULL, NULL, 0, NULL, 0, 0, -1, -1};
        write_model("scaled_light.gltf", &tri, 1, &doc);
        pm_scene s;
        pm_load_report r;
        if (!load_ok("scaled_light.gltf", &s, &r)) continue;
        double k = r.unit_scale * scales[i];
        CHECK(s.light_count == 1 && r.warnings == 0, "scale %g: lights %u warnings %u", scales[i], s.light_count, r.warnings);
        if (s.light_count == 1) CHECK_NEAR(s.lights[0].intensity.x, 8 * k * k, 1e-6, 0, "a light scaled with the scene");
        pm_scene_free(&s);
    }

    /* 1e5 from the origin at 1e-3 scale: float spacing at 1e5 (0.0078) is coarser than the
     * triangle, which collapsed; recentred, its shape survives exactly */
    doc_spec far = {"[{\"translation\":[1e5,1e5,1e5],\"scale\":[1e-3,1e-3,1e-3],\"mesh\":0}]", NULL, NULL, NULL};
    static const float right_triangle[9] = {0, 0, 0, 3, 0, 0, 0, 4, 0};
    prim_spec tri = {right_triangle, 3, NULL, NULL, 0, NULL, 0, 0, -1, -1};
    write_model("far.gltf", &tri, 1, &far);
    pm_scene s;
    pm_load_report r;
    if (load_ok("far.gltf", &s, &r)) {
        CHECK(r.recentered && r.unit_scale == 1, "recentred %d, unit_scale %g", r.recentered, r.unit_scale);
        if (s.triangle_count == 1) {
            vec3 a = tri_vertex(&s, 0, 0), b = tri_vertex(&s, 0, 1), c = tri_vertex(&s, 0, 2);
            CHECK_NEAR(v3_length(v3_sub(b, a)), 3e-3, 1e-5, 0, "edge 3e-3");
            CHECK_NEAR(v3_length(v3_sub(c, a)), 4e-3, 1e-5, 0, "edge 4e-3");
            CHECK_NEAR(v3_length(v3_sub(c, b)), 5e-3, 1e-5, 0, "hypotenuse 5e-3");
        } else CHECK(0, "far triangle count %u", s.triangle_count);
        pm_scene_free(&s);
    }

    /* a file whose every triangle is dropped says why */
    static const float collinear[9] = {0, 0, 0, 1, 0, 0, 2, 0, 0};
    prim_spec line = {collinear, 3, NULL, NULL, 0, NULL, 0, 0, -1, -1};
    write_model("all_degenerate.gltf", &line, 1, NULL);
    check_rejected("all_degenerate.gltf", "nothing to render: all 1 triangle(s) of the default scene are degenerate");
    doc_spec flat = {"[{\"mesh\":0,\"scale\":[1,0,1]}]", NULL, NULL, NULL};
    write_model("flattened.gltf", &tri, 1, &flat);
    check_rejected("flattened.gltf", "are degenerate (zero area");
}

/* A GLB: the header, then chunks given as (type, bytes, length); lengths are written as given. */
static void write_glb(const char *name, const uint32_t *types, const void *const *payloads, const uint32_t *lengths,
                      int chunks) {
    unsigned char out[4096];
    uint32_t size = 12;
    for (int c = 0; c < chunks; c++) {
        memcpy(out + size, &lengths[c], 4);
        memcpy(out + size + 4, &types[c], 4);
        memcpy(out + size + 8, payloads[c], lengths[c]);
        size += 8 + lengths[c];
    }
    uint32_t version = 2;
    memcpy(out, "glTF", 4);
    memcpy(out + 4, &version, 4);
    memcpy(out + 8, &size, 4);
    char path[256];
    model_path(name, path, sizeof path);
    write_file(path, out, size);
}

/* What the GLB container rules forbid and tinygltf 2.7 accepted: a chunk not 4-byte aligned, a
 * second BIN chunk, a GLB-stored buffer other than buffer 0, a BIN chunk over 3 bytes longer
 * than its buffer. An unknown chunk type after BIN is ignored, as the specification says. */
static void test_glb_container(void) {
    const uint32_t json_type = 0x4E4F534Au, bin_type = 0x004E4942u, other_type = 0x12345678u;
    static const char json_good[] =
        "{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0}}]}],\"buffers\":[{\"byteLength\":36}],"
        "\"bufferViews\":[{\"buffer\":0,\"byteLength\":36}],"
        "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"}]}";
    static const char json_two[] =
        "{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0}}]}],"
        "\"buffers\":[{\"byteLength\":4,\"uri\":\"data:application/octet-stream;base64,AAAAAA==\"},{\"byteLength\":36}],"
        "\"bufferViews\":[{\"buffer\":1,\"byteLength\":36}],"
        "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"}]}";
    char padded[1024], padded_two[1024];
    uint32_t length = (uint32_t)((strlen(json_good) + 3) & ~(size_t)3), length_two = (uint32_t)((strlen(json_two) + 3) & ~(size_t)3);
    memset(padded, ' ', sizeof padded);
    memcpy(padded, json_good, strlen(json_good));
    memset(padded_two, ' ', sizeof padded_two);
    memcpy(padded_two, json_two, strlen(json_two));
    unsigned char bin[44] = {0};
    memcpy(bin, unit_triangle, 36);

    uint32_t types[3] = {json_type, bin_type, other_type};
    const void *payloads[3] = {padded, bin, bin};
    uint32_t lengths[3] = {length, 36, 8};
    write_glb("glb_good.glb", types, payloads, lengths, 3);
    pm_scene s;
    pm_load_report r;
    if (load_ok("glb_good.glb", &s, &r)) {
        CHECK(s.triangle_count == 1, "GLB triangle count %u", s.triangle_count);
        pm_scene_free(&s);
    }
    uint32_t unaligned[2] = {length - 1, 36};
    write_glb("glb_unaligned.glb", types, payloads, unaligned, 2);
    check_rejected("glb_unaligned.glb", "GLB chunk 0 length");
    uint32_t second_bin[3] = {json_type, bin_type, bin_type};
    uint32_t three[3] = {length, 36, 36};
    write_glb("glb_two_bin.glb", second_bin, payloads, three, 3);
    check_rejected("glb_two_bin.glb", "GLB chunk 2 is a second BIN chunk");
    uint32_t long_bin[2] = {length, 44};
    write_glb("glb_long_bin.glb", types, payloads, long_bin, 2);
    check_rejected("glb_long_bin.glb", "byteLength 36 but the GLB BIN chunk has 44 bytes (at most 3 bytes of padding)");
    const void *payloads_two[2] = {padded_two, bin};
    uint32_t lengths_two[2] = {length_two, 36};
    write_glb("glb_buffer1.glb", types, payloads_two, lengths_two, 2);
    check_rejected("glb_buffer1.glb", "buffer 1 has no uri: only buffer 0 can be the GLB's BIN chunk");
}

/* KHR_materials_variants: --variant NAME gives each primitive the material its mappings name for
 * it; without one the file's default material; a name the file does not list fails in one line
 * naming the ones it does. */
static void test_variants(void) {
    static const char positions_base64[] = "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"; /* (0,0,0) (1,0,0) (0,1,0) */
    char json[4096];
    snprintf(json, sizeof json,
             "{\"asset\":{\"version\":\"2.0\"},\"extensionsUsed\":[\"KHR_materials_variants\"],"
             "\"extensions\":{\"KHR_materials_variants\":{\"variants\":[{\"name\":\"green\"},{\"name\":\"blue\"},{\"name\":\"plain\"}]}},"
             "\"buffers\":[{\"byteLength\":36,\"uri\":\"data:application/octet-stream;base64,%s\"}],"
             "\"bufferViews\":[{\"buffer\":0,\"byteLength\":36}],"
             "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]}],"
             "\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorFactor\":[1,0,0,1]}},"
             "{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0,1,0,1]}},{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0,0,1,1]}}],"
             "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"material\":0,\"extensions\":"
             "{\"KHR_materials_variants\":{\"mappings\":[{\"material\":1,\"variants\":[0]},{\"material\":2,\"variants\":[1]}]}}}]}],"
             "\"nodes\":[{\"mesh\":0}],\"scenes\":[{\"nodes\":[0]}],\"scene\":0}",
             positions_base64);
    const char *names[] = {NULL, "green", "blue", "plain"};
    const float want[4][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 0}}; /* plain: no mapping, the default */
    for (int k = 0; k < 4; k++) {
        pm_load_options options = {.variant = names[k]};
        pm_scene s;
        pm_load_report r;
        char err[512];
        bool ok = pm_load_gltf_memory_with(json, strlen(json), "variants.gltf", &options, true, &s, &r, err, sizeof err);
        CHECK(ok, "variant %s loads: %s", names[k] ? names[k] : "(none)", err);
        if (!ok) continue;
        CHECK(r.warnings == 0, "variant %s: KHR_materials_variants is no unsupported extension (%u warnings)",
              names[k] ? names[k] : "(none)", r.warnings);
        vec3 b = s.materials[s.triangle_material[0]].base_color;
        CHECK(b.x == want[k][0] && b.y == want[k][1] && b.z == want[k][2], "variant %s: base colour %g %g %g",
              names[k] ? names[k] : "(none)", b.x, b.y, b.z);
        /* the file's names in order, whichever variant loaded (the window's M key cycles them) */
        const char *n = s.variant_names;
        CHECK(s.variant_count == 3 && n && !strcmp(n, "green") && !strcmp(n + 6, "blue") && !strcmp(n + 11, "plain"),
              "variant %s: the scene lists the file's three variant names (%u)", names[k] ? names[k] : "(none)", s.variant_count);
        pm_scene_free(&s);
    }
    pm_load_options options = {.variant = "red"};
    pm_scene s;
    pm_load_report r;
    char err[512] = "";
    bool ok = pm_load_gltf_memory_with(json, strlen(json), "variants.gltf", &options, true, &s, &r, err, sizeof err);
    CHECK(!ok && strstr(err, "no material variant red (") && strstr(err, "green") && strstr(err, "plain"),
          "an unknown variant fails, naming the file's: %s", err);
    if (ok) pm_scene_free(&s);
}

int main(void) {
    snprintf(test_dir, sizeof test_dir, "/tmp/pmview-test-loader-XXXXXX");
    if (!mkdtemp(test_dir)) {
        perror("mkdtemp");
        return 1;
    }
    test_variants();
    test_transforms();
    test_mirrored_winding();
    test_nonuniform_scale_normals();
    test_index_types();
    test_strips_and_fans();
    test_flat_normals();
    test_unusable_normals();
    test_texcoords_and_texture();
    test_cameras();
    test_lights();
    test_spot_cones();
    test_clamp_warnings();
    test_materials();
    test_ignored_inputs();
    test_occlusion_texture_silent();
    test_sampler_filters();
    test_ignored_kinds_named();
    test_sourceless_images_ignored();
    test_unlit_material();
    test_texcoord_sets();
    test_texture_transform();
    test_data_textures();
    test_layer_extensions();
    test_layer_extensions_bad();
    test_mesh_quantization();
    test_normal_maps();
    test_tangent_w();
    test_skips();
    test_sparse();
    test_morph_weights();
    test_shared_image();
    test_nonfinite_uvs();
    test_rejections();
    test_wrong_types_and_indices();
    test_top_down_bmp();
    test_any_scale();
    test_glb_container();
    char command[128];
    snprintf(command, sizeof command, "rm -rf '%s'", test_dir);
    if (system(command) != 0) fprintf(stderr, "could not remove %s\n", test_dir);
    return pm_test_done("test_loader");
}

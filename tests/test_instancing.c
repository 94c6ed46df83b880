/* test_instancing.c: a mesh placed by several nodes, stored once and placed, against the same file flattened: hits, surfaces, alpha cut-outs, emitted power and images agree. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "image_io.h"
#include "light.h"
#include "loader.h"
#include "progressive_harness.h"

/* ---- a glTF text with its buffer as a data: URI */

static void base64(const unsigned char *in, size_t n, char *out) {
    static const char abc[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    size_t o = 0;
    for (size_t i = 0; i < n; i += 3) {
        uint32_t v = (uint32_t)in[i] << 16 | (i + 1 < n ? (uint32_t)in[i + 1] << 8 : 0) | (i + 2 < n ? in[i + 2] : 0);
        out[o++] = abc[v >> 18 & 63];
        out[o++] = abc[v >> 12 & 63];
        out[o++] = i + 1 < n ? abc[v >> 6 & 63] : '=';
        out[o++] = i + 2 < n ? abc[v & 63] : '=';
    }
    out[o] = '\0';
}

enum { RING = 8, TUBE = 6, VERTS = (RING + 1) * (TUBE + 1), TRIS = 2 * RING * TUBE };

/* A torus (radii 1 and 0.35) with normals and UVs, then a floor quad: one buffer. */
typedef struct {
    float pos[3 * VERTS], nrm[3 * VERTS], uv[2 * VERTS];
    uint32_t idx[3 * TRIS];
    float floor_pos[12];
    uint32_t floor_idx[6];
} geometry;

/* The torus's coordinates are multiplied by this (nodes can scale them back). */
static double mesh_scale = 1.0;

static void make_geometry(geometry *g) {
    for (int i = 0, v = 0; i <= RING; i++)
        for (int j = 0; j <= TUBE; j++, v++) {
            double u = 2 * PM_PI * i / RING, w = 2 * PM_PI * j / TUBE;
            double n[3] = {cos(u) * cos(w), sin(w), sin(u) * cos(w)}, c[3] = {cos(u), 0, sin(u)};
            for (int k = 0; k < 3; k++) {
                g->pos[3 * v + k] = (float)((c[k] + 0.35 * n[k]) * mesh_scale);
                g->nrm[3 * v + k] = (float)n[k];
            }
            g->uv[2 * v] = (float)i / RING;
            g->uv[2 * v + 1] = (float)j / TUBE;
        }
    int t = 0;
    for (int i = 0; i < RING; i++)
        for (int j = 0; j < TUBE; j++) {
            uint32_t p = i * (TUBE + 1) + j, q = (i + 1) * (TUBE + 1) + j, r = q + 1, s = p + 1;
            uint32_t tri[6] = {p, s, q, q, s, r};
            memcpy(g->idx + 6 * t++, tri, sizeof tri);
        }
    float floor[12] = {-6, -1, -6, 6, -1, -6, 6, -1, 6, -6, -1, 6};
    uint32_t fi[6] = {0, 3, 2, 0, 2, 1};
    memcpy(g->floor_pos, floor, sizeof floor);
    memcpy(g->floor_idx, fi, sizeof fi);
}

/* The file: the floor (node 0), a sun (node 1) and `nodes_json` placing mesh 1 (the torus), whose
 * material is `material_json`. The caller frees the text. */
static char *make_gltf_with(const char *nodes_json, const char *roots, const char *material_json, const char *sun, const char *extra) {
    geometry g;
    make_geometry(&g);
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int v = 0; v < VERTS; v++)
        for (int k = 0; k < 3; k++) {
            lo[k] = fmin(lo[k], g.pos[3 * v + k]);
            hi[k] = fmax(hi[k], g.pos[3 * v + k]);
        }
    char *b64 = malloc(4 * sizeof g / 3 + 8);
    base64((const unsigned char *)&g, sizeof g, b64);
    size_t size = strlen(b64) + 8192 + strlen(nodes_json) + strlen(extra) + strlen(material_json);
    char *text = malloc(size);
    size_t o_pos = offsetof(geometry, pos), o_nrm = offsetof(geometry, nrm), o_uv = offsetof(geometry, uv),
           o_idx = offsetof(geometry, idx), o_fp = offsetof(geometry, floor_pos), o_fi = offsetof(geometry, floor_idx);
    snprintf(text, size,
             "{\"asset\":{\"version\":\"2.0\"},\"extensionsUsed\":[\"KHR_lights_punctual\"],"
             "\"extensions\":{\"KHR_lights_punctual\":{\"lights\":[{\"type\":\"directional\",\"intensity\":%s}]}},"
             "\"scene\":0,\"scenes\":[{\"nodes\":[0,1%s]}],"
             "\"nodes\":[{\"mesh\":0},{\"rotation\":[-0.3535534,0.3535534,0.1464466,0.8535534],"
             "\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}}%s],"
             "\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.7,0.7,0.7,1],\"metallicFactor\":0}},%s],"
             "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":4},\"indices\":5,\"material\":0}]},"
             "{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"NORMAL\":1,\"TEXCOORD_0\":2},\"indices\":3,\"material\":1}]}],"
             "\"buffers\":[{\"byteLength\":%zu,\"uri\":\"data:application/octet-stream;base64,%s\"}],"
             "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
             "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},"
             "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu},{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}],"
             "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":%d,\"type\":\"VEC3\",\"min\":[%.9g,%.9g,%.9g],\"max\":[%.9g,%.9g,%.9g]},"
             "{\"bufferView\":1,\"componentType\":5126,\"count\":%d,\"type\":\"VEC3\"},"
             "{\"bufferView\":2,\"componentType\":5126,\"count\":%d,\"type\":\"VEC2\"},"
             "{\"bufferView\":3,\"componentType\":5125,\"count\":%d,\"type\":\"SCALAR\"},"
             "{\"bufferView\":4,\"componentType\":5126,\"count\":4,\"type\":\"VEC3\",\"min\":[-6,-1,-6],\"max\":[6,-1,6]},"
             "{\"bufferView\":5,\"componentType\":5125,\"count\":6,\"type\":\"SCALAR\"}]%s}",
             sun, roots, nodes_json, material_json, sizeof g, b64, o_pos, sizeof g.pos, o_nrm, sizeof g.nrm, o_uv, sizeof g.uv,
             o_idx, sizeof g.idx, o_fp, sizeof g.floor_pos, o_fi, sizeof g.floor_idx, VERTS, lo[0], lo[1], lo[2], hi[0], hi[1],
             hi[2], VERTS, VERTS, 3 * TRIS, extra);
    free(b64);
    return text;
}
static char *make_gltf(const char *nodes_json, const char *roots, const char *material_json, const char *sun) {
    return make_gltf_with(nodes_json, roots, material_json, sun, "");
}

/* `,"textures":[...],"images":[...]` with an 8 x 8 normal map of tilted texels (a PNG in a data:
 * URI), so the loader makes tangents; NULL when the PNG cannot be written. */
static char *normal_map_json(void) {
    uint8_t rgba[8 * 8 * 4];
    for (int i = 0; i < 64; i++) {
        double a = 0.7 * sin(1.3 * i), b = 0.6 * cos(0.9 * i);
        uint8_t texel[4] = {(uint8_t)(127.5 + 127 * 0.5 * a), (uint8_t)(127.5 + 127 * 0.5 * b), 230, 255};
        memcpy(rgba + 4 * i, texel, 4);
    }
    char path[] = "/tmp/pm_test_instancing_XXXXXX";
    int fd = mkstemp(path);
    if (fd < 0) return NULL;
    close(fd);
    char err[256];
    FILE *f = NULL;
    char *out = NULL;
    if (pm_write_png(path, 8, 8, rgba, err, sizeof err) && (f = fopen(path, "rb"))) {
        unsigned char bytes[8192];
        size_t n = fread(bytes, 1, sizeof bytes, f);
        char *b64 = malloc(4 * n / 3 + 8);
        base64(bytes, n, b64);
        out = malloc(strlen(b64) + 256);
        sprintf(out, ",\"textures\":[{\"source\":0}],\"images\":[{\"uri\":\"data:image/png;base64,%s\"}]", b64);
        free(b64);
        fclose(f);
    }
    remove(path);
    return out;
}

static bool load_text(const char *text, bool flatten, pm_scene *s) {
    char err[512];
    pm_load_options options = {.flatten_instances = flatten};
    bool ok = pm_load_gltf_memory_with(text, strlen(text), "instancing.gltf", &options, true, s, NULL, err, sizeof err);
    CHECK(ok, "load (%s): %s", flatten ? "flat" : "instanced", err);
    return ok;
}

/* A 4 x 4 checker texture whose alpha is 0 on the dark squares, given to the torus material (1)
 * before finalize: colour through UVs, and with MASK a cut-out, through every placement. */
static void add_checker(pm_scene *s, bool mask) {
    s->textures = calloc(1, sizeof *s->textures);
    s->texture_count = 1;
    pm_texture *t = &s->textures[0];
    t->width = t->height = 4;
    t->rgba = malloc(4 * 4 * 4);
    for (int i = 0; i < 16; i++) {
        bool dark = ((i % 4) + (i / 4)) % 2;
        uint8_t texel[4] = {dark ? 30 : 250, dark ? 60 : 200, dark ? 200 : 40, dark ? 0 : 255};
        memcpy(t->rgba + 4 * i, texel, 4);
    }
    s->materials[1].base_color_texture = 0;
    if (mask) s->materials[1].alpha_mode = PM_ALPHA_MASK;
}

/* Nested placements: a parent turned and moved, its children rotated, scaled (non-uniformly, one
 * mirrored) and moved; the flat load composes the same transforms into world space. */
static const char *placement_nodes =
    ",{\"translation\":[0.5,0.3,-0.5],\"rotation\":[0,0.258819,0,0.9659258],\"children\":[3,4,5]}"
    ",{\"mesh\":1,\"translation\":[-2.5,0,0],\"rotation\":[0.3826834,0,0,0.9238795]}"
    ",{\"mesh\":1,\"translation\":[0,0.2,1],\"scale\":[1.5,0.8,1.2],\"rotation\":[0,0,0.4794255,0.8775826]}"
    ",{\"mesh\":1,\"translation\":[2.5,0,-1],\"scale\":[-1,1,1]}";

static bool near(vec3 a, vec3 b, float tol) { return v3_length(v3_sub(a, b)) <= tol; }

/* Every ray of a grid over the view meets the same surface in both scenes: distance, point,
 * normals, texture coordinates, material and albedo. */
/* ns_tol: a normal map's tangents are generated per vertex and made orthogonal to its normal, in
 * mesh space for a stored mesh and in world space for a flattened copy; under a non-uniform scale
 * the two frames differ slightly (about 1e-2), so mapped shading normals are compared at 3e-2. */
/* Triangle tri's shading record at barycentrics near and far from its edges: the ray origin's
 * pull toward the centroid is on (centroid != p) exactly where the point lies within 4 pull steps
 * of an edge, each distance measured in double from the world corners, not from the altitudes the
 * record uses (a flat triangle's from edge_altitudes, a placed one's from its corners). Points
 * within 1e-3 of that bound either way count as agreeing. Returns the disagreements. */
static int edge_pull_disagreements(const pm_scene *s, uint32_t tri) {
    static const float at[][2] = {{0.3f, 0.3f},   {1e-7f, 0.5f}, {1e-5f, 0.4f},   {1e-4f, 0.3f},     {1e-3f, 0.2f},
                                  {0.5f, 1e-6f},  {0.6f, 3e-4f}, {0.45f, 0.5499f}, {0.2f, 0.79999f}, {0.f, 0.5f}};
    vec3 c[3];
    pm_scene_triangle_corners(s, tri, c);
    int bad = 0;
    for (size_t k = 0; k < sizeof at / sizeof at[0]; k++) {
        pm_surface sf;
        memset(&sf, 0, sizeof sf);
        pm_scene_surface_point(s, tri, at[k][0], at[k][1], pm_scene_triangle_face_normal(s, tri), &sf);
        pm_scene_surface_shading(s, tri, at[k][0], at[k][1], &sf);
        bool pulled = memcmp(&sf.centroid, &sf.p, sizeof sf.p) != 0;
        double m = fmax(fabs(sf.p.x), fmax(fabs(sf.p.y), fabs(sf.p.z)));
        double near = 4.0 * fmax(s->ray_scale / 65536.0, m * 4e-6);
        double closest = INFINITY;
        for (int e = 0; e < 3; e++) { /* edge e runs between the other two corners */
            vec3 a = c[(e + 1) % 3], b = c[(e + 2) % 3];
            double ex = (double)b.x - a.x, ey = (double)b.y - a.y, ez = (double)b.z - a.z;
            double px = (double)sf.p.x - a.x, py = (double)sf.p.y - a.y, pz = (double)sf.p.z - a.z;
            double cx = py * ez - pz * ey, cy = pz * ex - px * ez, cz = px * ey - py * ex;
            double length = sqrt(ex * ex + ey * ey + ez * ez);
            closest = fmin(closest, length > 0 ? sqrt(cx * cx + cy * cy + cz * cz) / length : 0.0);
        }
        bool expected = closest <= near;
        if (pulled != expected && fabs(closest - near) > 1e-3 * near && bad++ < 3)
            fprintf(stderr, "  triangle %u at (%g, %g): pulled %d, closest edge %g, bound %g\n", tri, at[k][0], at[k][1], pulled,
                    closest, near);
    }
    return bad;
}

static void compare_hits(const pm_scene *inst, const pm_accel *ai, const pm_scene *flat, const pm_accel *af, const char *what,
                         float ns_tol) {
    pm_camera cam = pm_scene_auto_camera(flat, 1.f);
    int n = 64, hits = 0, placed_hits = 0, bad = 0, mapped = 0, pull_bad = 0;
    float tan_half = tanf(0.5f * cam.yfov);
    for (int y = 0; y < n; y++)
        for (int x = 0; x < n; x++) {
            float sx = (2.f * (x + 0.5f) / n - 1.f) * tan_half, sy = (1.f - 2.f * (y + 0.5f) / n) * tan_half;
            vec3 d = v3_normalize(v3_add(cam.forward, v3_add(v3_scale(cam.right, sx), v3_scale(cam.up, sy))));
            pm_hit hi, hf;
            bool got_i = pm_accel_intersect(ai, cam.position, d, INFINITY, &hi);
            bool got_f = pm_accel_intersect(af, cam.position, d, INFINITY, &hf);
            if (got_i != got_f) { bad++; continue; }
            if (!got_i) continue;
            hits++;
            placed_hits += pm_scene_placement_of(inst, hi.tri) >= 0;
            pm_surface si, sf;
            pm_scene_surface(inst, hi.tri, hi.b1, hi.b2, &si);
            pm_scene_surface(flat, hf.tri, hf.b1, hf.b2, &sf);
            float tol = 2e-4f * (1.f + hf.t);
            bool same = fabsf(hi.t - hf.t) <= tol && near(si.p, sf.p, tol) && near(si.ng, sf.ng, 1e-3f) &&
                        near(si.ns, sf.ns, ns_tol) && fabsf(si.u - sf.u) < 1e-3f && fabsf(si.v - sf.v) < 1e-3f &&
                        si.material == sf.material && near(si.kd, sf.kd, 1e-3f);
            pm_surface unmapped;
            pm_scene_surface_point(inst, hi.tri, hi.b1, hi.b2, si.ng, &unmapped);
            pm_scene_surface_shading(inst, hi.tri, hi.b1, hi.b2, &unmapped);
            mapped += pm_scene_placement_of(inst, hi.tri) >= 0 && !near(unmapped.ns, si.ns, 0.1f);
            pull_bad += edge_pull_disagreements(inst, hi.tri) + edge_pull_disagreements(flat, hf.tri);
            if (!same && bad++ < 3)
                fprintf(stderr, "  %s ray (%d,%d): t %g/%g ng (%g %g %g)/(%g %g %g) ns (%g %g %g)/(%g %g %g) uv %g,%g/%g,%g\n", what, x, y,
                        hi.t, hf.t, si.ng.x, si.ng.y, si.ng.z, sf.ng.x, sf.ng.y, sf.ng.z, si.ns.x, si.ns.y, si.ns.z, sf.ns.x,
                        sf.ns.y, sf.ns.z, si.u, si.v, sf.u, sf.v);
        }
    CHECK(bad == 0, "%s: %d of %d rays differ between the instanced and the flat scene", what, bad, n * n);
    CHECK(placed_hits > 50, "%s: only %d rays met a placement (of %d hits)", what, placed_hits, hits);
    CHECK(pull_bad == 0, "%s: the origin's pull toward the centroid disagrees with the edges' distances %d times", what, pull_bad);
    if (ns_tol > 1e-3f) CHECK(mapped > placed_hits / 2, "%s: the normal map tilted only %d of %d placed hits", what, mapped, placed_hits);
}

static double rel_mse(const float *a, const float *b, size_t n) {
    double sum = 0;
    for (size_t i = 0; i < n; i++) {
        double r = 0.5 * ((double)a[i] + b[i]);
        sum += (a[i] - b[i]) * (a[i] - b[i]) / (r * r + 1e-2);
    }
    return sum / (double)n;
}

static bool render(const pm_scene *s, const pm_accel *a, uint32_t seed, int w, float *out) {
    pm_camera cam = pm_scene_auto_camera(s, 1.f);
    pm_progressive_settings ps = default_settings(w, w);
    ps.seed = seed;
    session r;
    if (!start(&r, s, a, &cam, w, w, &ps)) return false;
    bool ok = iterate(&r, 4) && pm_film_resolve_total(r.film, out);
    stop(&r);
    return ok;
}

static bool torus_only(const pm_material *m, const void *context) {
    (void)context;
    return m->base_color.y < 0.6f; /* the torus's (0.8, 0.5, 0.3); the floor is grey 0.7 */
}

static void test_same_as_flat(bool textured, bool mask, bool normal_mapped) {
    const char *what = normal_mapped ? "normal-mapped" : mask ? "alpha cut-out" : textured ? "textured" : "plain";
    char *map = normal_mapped ? normal_map_json() : NULL;
    CHECK(!normal_mapped || map, "normal map PNG");
    if (normal_mapped && !map) return;
    char *text = make_gltf_with(placement_nodes, ",2",
                                normal_mapped ? "{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.8,0.5,0.3,1],\"metallicFactor\":0},\"normalTexture\":{\"index\":0}}"
                                              : "{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.8,0.5,0.3,1],\"metallicFactor\":0}}",
                                "3", map ? map : "");
    free(map);
    pm_scene inst, flat;
    bool ok_i = load_text(text, false, &inst), ok_f = load_text(text, true, &flat);
    free(text);
    if (!ok_i || !ok_f) return;
    CHECK(inst.placement_count == 3 && inst.instanced_mesh_count == 1 && inst.triangle_count == TRIS + 2,
          "%s: %u placements, %u instanced meshes, %u stored triangles", what, inst.placement_count, inst.instanced_mesh_count,
          inst.triangle_count);
    CHECK(flat.placement_count == 0 && flat.triangle_count == 3 * TRIS + 2 && pm_scene_triangle_ids(&inst) == flat.triangle_count,
          "%s: flat %u triangles, instanced ids %u", what, flat.triangle_count, pm_scene_triangle_ids(&inst));
    if (normal_mapped)
        CHECK(inst.tangents && flat.tangents && inst.materials[1].normal_texture == 0, "%s: tangents made", what);
    if (textured) {
        add_checker(&inst, mask);
        add_checker(&flat, mask);
    }
    CHECK(pm_scene_finalize(&inst, false, NULL) && pm_scene_finalize(&flat, false, NULL), "%s: finalize", what);
    CHECK(near(inst.bounds_min, flat.bounds_min, 1e-4f) && near(inst.bounds_max, flat.bounds_max, 1e-4f), "%s: bounds", what);
    double fi = pm_scene_reflective_area_fraction(&inst, 0.6f), ff = pm_scene_reflective_area_fraction(&flat, 0.6f);
    CHECK(fabs(fi - ff) < 1e-5 && fi > 0.01 && fi < 0.99, "%s: reflective area fraction %g instanced, %g flat", what, fi, ff);
    /* by similarity (two placements) and triangle by triangle (the non-uniform one) against the flat sum */
    double ai_area = pm_scene_area_where(&inst, torus_only, NULL), af_area = pm_scene_area_where(&flat, torus_only, NULL);
    CHECK(fabs(ai_area - af_area) <= 1e-5 * af_area && af_area > 0, "%s: torus area %g instanced, %g flat", what, ai_area, af_area);
    char err[256];
    pm_accel *ai = pm_accel_create(&inst, err, sizeof err), *af = pm_accel_create(&flat, err, sizeof err);
    CHECK(ai && af, "%s: accel: %s", what, err);
    if (ai && af) {
        if (mask)
            CHECK(pm_accel_alpha_tested_triangles(ai) == TRIS && pm_accel_alpha_tested_triangles(af) == 3 * TRIS,
                  "%s: alpha-tested %u / %u", what, pm_accel_alpha_tested_triangles(ai), pm_accel_alpha_tested_triangles(af));
        compare_hits(&inst, ai, &flat, af, what, normal_mapped ? 3e-2f : 1e-3f);
        if (!textured && !normal_mapped) {
            /* the same image, same seed: its difference far below that of two seeds */
            enum { W = 48 };
            float *a = malloc(sizeof(float) * 3 * W * W), *b = malloc(sizeof(float) * 3 * W * W), *c = malloc(sizeof(float) * 3 * W * W);
            if (render(&inst, ai, 1, W, a) && render(&flat, af, 1, W, b) && render(&flat, af, 2, W, c)) {
                double same_seed = rel_mse(a, b, 3 * W * W), other_seed = rel_mse(c, b, 3 * W * W);
                CHECK(same_seed < 0.02 * other_seed, "%s: image relMSE %g against the flat scene's, seeds differing %g", what,
                      same_seed, other_seed);
            }
            free(a);
            free(b);
            free(c);
        }
    }
    pm_accel_destroy(ai);
    pm_accel_destroy(af);
    pm_scene_free(&inst);
    pm_scene_free(&flat);
}

/* An emissive mesh placed at scale 1 and at scale 2 emits 1 + 4 times one copy's power, from
 * both placements. */
static void test_scaled_emitter(void) {
    const char *glow = "{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,0.5,0.5,1],\"metallicFactor\":0},\"emissiveFactor\":[1,0.5,0.25]}";
    char *one = make_gltf(",{\"mesh\":1}", ",2", glow, "0");
    char *two = make_gltf(",{\"mesh\":1},{\"mesh\":1,\"translation\":[4,0,0],\"scale\":[2,2,2],\"rotation\":[0,0,0.7071068,0.7071068]}",
                          ",2,3", glow, "0");
    pm_scene s1, si, sf;
    bool ok = load_text(one, false, &s1) & load_text(two, false, &si) & load_text(two, true, &sf);
    free(one);
    free(two);
    if (!ok) return;
    CHECK(pm_scene_finalize(&s1, false, NULL) && pm_scene_finalize(&si, false, NULL) && pm_scene_finalize(&sf, false, NULL),
          "emitter: finalize");
    CHECK(si.placement_count == 2 && s1.placement_count == 0, "emitter: placements %u, single %u", si.placement_count, s1.placement_count);
    CHECK(si.emitter_count == 2 * TRIS && sf.emitter_count == 2 * TRIS, "emitter: %u emitters instanced, %u flat", si.emitter_count,
          sf.emitter_count);
    CHECK_NEAR(si.emitter_power, 5.0 * s1.emitter_power, 1e-4, 0, "emitter: power of a copy at scale 1 and one at scale 2");
    CHECK_NEAR(si.emitter_power, sf.emitter_power, 1e-5, 0, "emitter: instanced against flat power");
    CHECK(s1.emitter_power > 0.f, "emitter: a single copy emits");
    /* each emitter's pick probability is the same triangle's in the flat scene (ids line up) */
    double worst = 0;
    for (uint32_t k = 0; k < si.emitter_count; k++) {
        double a = pm_scene_emitter_pdf(&si, si.emitters[k]), b = pm_scene_emitter_pdf(&sf, sf.emitters[k]);
        worst = fmax(worst, fabs(a - b) / b);
        CHECK(fabsf(pm_triangle_area(&si, si.emitters[k]) - pm_triangle_area(&sf, sf.emitters[k])) <= 1e-4f * pm_triangle_area(&sf, sf.emitters[k]),
              "emitter %u: area %g instanced, %g flat", k, pm_triangle_area(&si, si.emitters[k]), pm_triangle_area(&sf, sf.emitters[k]));
        if (k > 3) break;
    }
    CHECK(worst < 1e-3, "emitter: pick probabilities differ by %g", worst);
    /* each emitter's record is its placed triangle's world geometry (corners through the placement,
     * the normal by the mirrored winding) and emission, what light samples and photon starts read */
    int records_off = 0;
    for (uint32_t k = 0; k < si.emitter_count; k++) {
        const pm_emitter *r = &si.emitter_records[k];
        pm_triangle_geometry g = pm_triangle_geometry_of(&si, si.emitters[k]);
        vec3 e = pm_scene_emitted_at(&si, si.emitters[k], 0.2f, 0.3f), q = pm_emitter_point(r, 0.2f, 0.3f);
        vec3 want = pm_triangle_point(&g, 0.2f, 0.3f);
        records_off += memcmp(&r->p0, &g.p0, sizeof(vec3)) || memcmp(&r->p2, &g.p2, sizeof(vec3)) ||
                       memcmp(&r->normal, &g.normal, sizeof(vec3)) || r->area != g.area || !r->uniform_emission ||
                       memcmp(&r->emission, &e, sizeof(vec3)) || memcmp(&q, &want, sizeof(vec3));
    }
    CHECK(records_off == 0, "emitter: %d of %u records differ from their placed triangles' geometry and emission", records_off,
          si.emitter_count);
    pm_scene_free(&s1);
    pm_scene_free(&si);
    pm_scene_free(&sf);
}

/* An unlit torus whose base colour texture reads TEXCOORD_1: the camera sees the same colour
 * through every placement as in the flat scene (the second UV set read at the stored triangle). */
static void test_unlit_second_uv_set(void) {
    char *text = make_gltf(placement_nodes, ",2", "{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.8,0.5,0.3,1],\"metallicFactor\":0}}", "3");
    pm_scene inst, flat;
    bool ok = load_text(text, false, &inst) & load_text(text, true, &flat);
    free(text);
    if (!ok) return;
    pm_scene *both[2] = {&inst, &flat};
    for (int k = 0; k < 2; k++) {
        pm_scene *s = both[k];
        add_checker(s, false);
        s->materials[1].unlit = true;
        s->materials[1].base_color_texcoord = 1;
        s->uvs1 = malloc(2 * sizeof(float) * s->vertex_count); /* set 1 = set 0 turned: u and v swapped */
        for (uint32_t v = 0; v < s->vertex_count; v++) {
            s->uvs1[2 * v] = s->uvs[2 * v + 1];
            s->uvs1[2 * v + 1] = s->uvs[2 * v];
        }
    }
    CHECK(pm_scene_finalize(&inst, false, NULL) && pm_scene_finalize(&flat, false, NULL), "unlit: finalize");
    char err[256];
    pm_accel *ai = pm_accel_create(&inst, err, sizeof err), *af = pm_accel_create(&flat, err, sizeof err);
    CHECK(ai && af, "unlit: accel: %s", err);
    if (ai && af) {
        pm_camera cam = pm_scene_auto_camera(&flat, 1.f);
        float tan_half = tanf(0.5f * cam.yfov);
        int n = 48, placed = 0, bad = 0;
        for (int y = 0; y < n; y++)
            for (int x = 0; x < n; x++) {
                float sx = (2.f * (x + 0.5f) / n - 1.f) * tan_half, sy = (1.f - 2.f * (y + 0.5f) / n) * tan_half;
                vec3 d = v3_normalize(v3_add(cam.forward, v3_add(v3_scale(cam.right, sx), v3_scale(cam.up, sy))));
                pm_hit hi, hf;
                if (!pm_accel_intersect(ai, cam.position, d, INFINITY, &hi) || !pm_accel_intersect(af, cam.position, d, INFINITY, &hf))
                    continue;
                if (pm_scene_placement_of(&inst, hi.tri) < 0) continue;
                placed++;
                pm_surface si, sf;
                pm_scene_surface_footprint(&inst, hi.tri, hi.b1, hi.b2, 0.f, d, &si);
                pm_scene_surface_footprint(&flat, hf.tri, hf.b1, hf.b2, 0.f, d, &sf);
                bad += !(si.unlit && sf.unlit && near(si.emission, sf.emission, 2e-2f));
            }
        CHECK(placed > 50 && bad == 0, "unlit: %d of %d placed hits see another colour than the flat scene's", bad, placed);
    }
    pm_accel_destroy(ai);
    pm_accel_destroy(af);
    pm_scene_free(&inst);
    pm_scene_free(&flat);
}

/* A shared mesh whose own coordinates the scene's framing would rescale (1e25, placed by nodes
 * scaling it back) is flattened, so Embree never traces those magnitudes. */
static void test_huge_mesh_flattened(void) {
    mesh_scale = 1e25;
    char *text = make_gltf(",{\"mesh\":1,\"scale\":[1e-25,1e-25,1e-25]},{\"mesh\":1,\"translation\":[3,0,0],\"scale\":[1e-25,1e-25,1e-25]}",
                           ",2,3", "{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.8,0.5,0.3,1],\"metallicFactor\":0}}", "3");
    mesh_scale = 1.0;
    pm_scene inst, flat;
    bool ok = load_text(text, false, &inst) & load_text(text, true, &flat);
    free(text);
    if (!ok) return;
    CHECK(inst.placement_count == 0 && inst.triangle_count == flat.triangle_count,
          "huge mesh: %u placements (want 0: flattened), %u triangles against %u", inst.placement_count, inst.triangle_count,
          flat.triangle_count);
    CHECK(pm_scene_finalize(&inst, false, NULL) && pm_scene_finalize(&flat, false, NULL), "huge mesh: finalize");
    char err[256];
    pm_accel *ai = pm_accel_create(&inst, err, sizeof err), *af = pm_accel_create(&flat, err, sizeof err);
    CHECK(ai && af, "huge mesh: accel: %s", err);
    if (ai && af) {
        pm_camera cam = pm_scene_auto_camera(&flat, 1.f);
        pm_hit hi, hf;
        bool got_i = pm_accel_intersect(ai, cam.position, cam.forward, INFINITY, &hi),
             got_f = pm_accel_intersect(af, cam.position, cam.forward, INFINITY, &hf);
        CHECK(got_i && got_f && hi.tri == hf.tri && fabsf(hi.t - hf.t) <= 1e-5f * hf.t, "huge mesh: the view's centre ray hits alike");
    }
    pm_accel_destroy(ai);
    pm_accel_destroy(af);
    pm_scene_free(&inst);
    pm_scene_free(&flat);
}

/* A placement Embree cannot trace through its float inverse (a scale of 1e20 or 1e-20, entries
 * of 1e30, one axis squashed by 1e-20, a shear of 1e7) flattens its mesh, and rays over the view
 * and through every placement answer as the flat file's do; moderate scales stay instanced. One
 * whose size is more than 2^62 times the unit torus's is refused alike, instanced or flat: no
 * frame keeps both within float's range. Before, Embree aborted the process (an assertion on the
 * ray it made in mesh space). */
static void test_extreme_placements(void) {
    static const struct { const char *node; bool instanced, refused; } cases[] = {
        {"{\"mesh\":1,\"translation\":[3,0,0],\"scale\":[1e20,1e20,1e20]}", false, true},
        {"{\"mesh\":1,\"translation\":[3,0,0],\"scale\":[1e-20,1e-20,1e-20]}", false, false},
        {"{\"mesh\":1,\"matrix\":[1e30,0,0,0,0,1e30,0,0,0,0,1e30,0,3,0,0,1]}", false, true},
        {"{\"mesh\":1,\"translation\":[3,0,0],\"scale\":[1e15,1e15,1e15]}", false, false},
        {"{\"mesh\":1,\"translation\":[3,0.5,0],\"scale\":[1,1e-20,1]}", false, false},
        {"{\"mesh\":1,\"matrix\":[1,0,0,0,1e7,1,0,0,0,0,1,0,3,0,0,1]}", false, false},
        {"{\"mesh\":1,\"translation\":[3,0,0],\"scale\":[2,0.5,1]}", true, false},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        char nodes[512];
        snprintf(nodes, sizeof nodes, ",{\"mesh\":1},%s", cases[c].node);
        char *text = make_gltf(nodes, ",2,3", "{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.8,0.5,0.3,1],\"metallicFactor\":0}}", "3");
        if (cases[c].refused) {
            for (int flatten = 0; flatten < 2; flatten++) {
                pm_scene s;
                char err[512] = "";
                pm_load_options options = {.flatten_instances = flatten};
                bool loaded = pm_load_gltf_memory_with(text, strlen(text), "instancing.gltf", &options, true, &s, NULL, err, sizeof err);
                CHECK(!loaded && strstr(err, "sizes span more than float can render"), "placement %s (%s): want the span refused, got %s",
                      cases[c].node, flatten ? "flat" : "instanced", loaded ? "a scene" : err);
                if (loaded) pm_scene_free(&s);
            }
            free(text);
            continue;
        }
        pm_scene inst, flat;
        bool ok = load_text(text, false, &inst) & load_text(text, true, &flat);
        free(text);
        if (!ok) continue;
        CHECK((inst.placement_count > 0) == cases[c].instanced, "placement %s: %u placements (want %s)", cases[c].node,
              inst.placement_count, cases[c].instanced ? "instanced" : "0: flattened");
        CHECK(pm_scene_finalize(&inst, false, NULL) && pm_scene_finalize(&flat, false, NULL), "placement %s: finalize", cases[c].node);
        char err[256];
        pm_accel *ai = pm_accel_create(&inst, err, sizeof err), *af = pm_accel_create(&flat, err, sizeof err);
        CHECK(ai && af, "placement %s: accel: %s", cases[c].node, err);
        int bad = 0, hits = 0;
        if (ai && af) {
            /* the view's rays, then rays from the origin in every direction, then along the x axis into the placements */
            pm_camera cam = pm_scene_auto_camera(&flat, 1.f);
            for (int i = 0; i < 32 * 32 + 256 + 2; i++) {
                vec3 o = cam.position, d;
                if (i < 32 * 32) {
                    float sx = (2.f * (i % 32 + 0.5f) / 32 - 1.f) * 0.5f, sy = (1.f - 2.f * (i / 32 + 0.5f) / 32) * 0.5f;
                    d = v3_normalize(v3_add(cam.forward, v3_add(v3_scale(cam.right, sx), v3_scale(cam.up, sy))));
                } else if (i < 32 * 32 + 256) {
                    int k = i - 32 * 32;
                    o = v3(0.f, 2.f, 0.f);
                    d = pm_sample_sphere((k % 16 + 0.5f) / 16, (k / 16 + 0.5f) / 16);
                } else {
                    o = v3(i % 2 ? -20.f : 20.f, 0.f, 0.f);
                    d = v3(i % 2 ? 1.f : -1.f, 0.f, 0.f);
                }
                pm_hit hi, hf;
                bool got_i = pm_accel_intersect(ai, o, d, INFINITY, &hi), got_f = pm_accel_intersect(af, o, d, INFINITY, &hf);
                hits += got_f;
                bad += got_i != got_f || (got_i && !(fabsf(hi.t - hf.t) <= 1e-3f * (1.f + hf.t)));
            }
        }
        CHECK(bad == 0 && hits > 0, "placement %s: %d rays answer differently from the flat file's (%d hits)", cases[c].node, bad, hits);
        pm_accel_destroy(ai);
        pm_accel_destroy(af);
        pm_scene_free(&inst);
        pm_scene_free(&flat);
    }
}

/* Two meshes placed several times each, their nodes interleaved in the file (the floor of 2
 * triangles four times, the torus three times): every triangle id's placement, found by one
 * division within its mesh (pm_scene_placement_of), is the one a search over all placements finds,
 * and the view's rays meet the same surfaces as in the flattened file. */
static void test_two_meshes_placed(void) {
    const char *nodes = ",{\"mesh\":1,\"translation\":[-2.5,0,0]},{\"mesh\":0,\"translation\":[0,-3,0]}"
                        ",{\"mesh\":1,\"translation\":[0,0.2,1],\"scale\":[1.5,0.8,1.2]},{\"mesh\":0,\"translation\":[0,-5,0]}"
                        ",{\"mesh\":1,\"translation\":[2.5,0,-1],\"scale\":[-1,1,1]},{\"mesh\":0,\"translation\":[0,-7,0]}";
    char *text = make_gltf(nodes, ",2,3,4,5,6,7", "{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.8,0.5,0.3,1],\"metallicFactor\":0}}", "3");
    pm_scene inst, flat;
    bool ok = load_text(text, false, &inst) & load_text(text, true, &flat);
    free(text);
    if (!ok) return;
    CHECK(inst.instanced_mesh_count == 2 && inst.placement_count == 7, "two meshes: %u instanced meshes, %u placements (want 2, 7)",
          inst.instanced_mesh_count, inst.placement_count);
    int wrong = 0;
    for (uint32_t id = 0; id < pm_scene_triangle_ids(&inst); id++) {
        int32_t searched = -1;
        for (uint32_t p = 0; p < inst.placement_count; p++)
            if (inst.placements[p].first_id <= id) searched = (int32_t)p;
        int32_t found;
        uint32_t stored = pm_scene_stored_triangle(&inst, id, &found);
        const pm_instanced_mesh *m = found >= 0 ? &inst.instanced_meshes[inst.placements[found].mesh] : NULL;
        bool in_mesh = m ? stored >= m->first_triangle && stored < m->first_triangle + m->triangle_count : stored == id;
        if ((found != searched || !in_mesh) && wrong++ < 3)
            fprintf(stderr, "  id %u: placement %d, searched %d, stored %u\n", id, found, searched, stored);
    }
    CHECK(wrong == 0, "two meshes: %d triangle ids map to the wrong placement or stored triangle", wrong);
    char err[256] = "";
    if (wrong) { /* the surfaces would read another mesh's corners */
        pm_scene_free(&inst);
        pm_scene_free(&flat);
        return;
    }
    CHECK(pm_scene_finalize(&inst, false, NULL) && pm_scene_finalize(&flat, false, NULL), "two meshes: finalize");
    pm_accel *ai = pm_accel_create(&inst, err, sizeof err), *af = pm_accel_create(&flat, err, sizeof err);
    CHECK(ai && af, "two meshes: accel: %s", err);
    if (ai && af) compare_hits(&inst, ai, &flat, af, "two meshes", 1e-3f);
    /* the packets' answers, coherent (in packets) and not (one by one through instances), are the single rays' */
    enum { RAYS = 300 };
    vec3 o[RAYS], d[RAYS];
    bool hit[RAYS];
    pm_hit hits[RAYS];
    for (int i = 0; i < RAYS; i++) {
        o[i] = v3(0.f, 2.f, 0.f);
        d[i] = pm_sample_sphere((i % 20 + 0.5f) / 20, (i / 20 + 0.5f) / 15);
    }
    for (int coherent = 0; ai && coherent < 2; coherent++) {
        pm_accel_intersect_packets(ai, RAYS, o, d, coherent, hit, hits);
        int differ = 0, met = 0;
        for (int i = 0; i < RAYS; i++) {
            pm_hit one;
            bool got = pm_accel_intersect(ai, o[i], d[i], INFINITY, &one);
            met += got;
            differ += got != hit[i] || (got && (one.tri != hits[i].tri || fabsf(one.t - hits[i].t) > 1e-5f * (1.f + one.t)));
        }
        CHECK(differ == 0 && met > RAYS / 4, "two meshes: %d of %d %s packet rays answer otherwise than alone (%d hits)", differ, RAYS,
              coherent ? "coherent" : "unrelated", met);
    }
    pm_accel_destroy(ai);
    pm_accel_destroy(af);
    pm_scene_free(&inst);
    pm_scene_free(&flat);
}

int main(void) {
    test_two_meshes_placed();
    test_same_as_flat(false, false, false);
    test_same_as_flat(true, false, false);
    test_same_as_flat(true, true, false);
    test_same_as_flat(false, false, true);
    test_scaled_emitter();
    test_unlit_second_uv_set();
    test_huge_mesh_flattened();
    test_extreme_placements();
    return pm_test_done("test_instancing");
}

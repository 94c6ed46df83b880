/* test_corpus.c: every file of the shared glTF corpus (PMVIEW_CORPUS) loads or is refused exactly as its README table says.
 *
 * The expectations below are the README's table, hard-coded: triangle counts of the default
 * scene (instanced, strips and fans as n-2), light and perspective-camera counts, "nothing to
 * render" for the files without triangles, and for every invalid file a one-line error that
 * starts with the file's path and names the problem. Valid scenes are also checked against the
 * pm_scene contract (finite positions, unit normals, indices and material ids in range). A walk
 * of the corpus folder makes sure no model file is left out of the table. Runs under ASan/UBSan
 * with leak detection, so a crash or a leak on any file fails the test. Without the corpus the
 * test prints SKIP and passes.
 */
#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "loader.h"
#include "testing.h"

typedef struct {
    const char *path;
    uint32_t triangles, lights, cameras, textures; /* cameras: perspective and orthographic */
} valid_case;

static const valid_case valid_cases[] = {
    {"valid/box_embedded/Box.gltf", 12, 0, 0, 0},
    {"valid/box_textured/BoxTextured.gltf", 12, 0, 0, 1},
    {"valid/box_textured_embedded/BoxTextured.gltf", 12, 0, 0, 1},
    {"valid/box_textured_glb/BoxTextured.glb", 12, 0, 0, 1},
    {"valid/cameras/Cameras.gltf", 2, 0, 2, 0}, /* table: 2 cameras, one of them orthographic */
    {"valid/cornell_box/cornellBox-2.80-Eevee-gltf.gltf", 4410, 0, 0, 2},
    {"valid/made_here_ext_scene/ext_scene.glb", 24, 2, 1, 0},
    {"valid/made_here_ext_scene/ext_scene.gltf", 24, 2, 1, 0},
    {"valid/made_here_interleaved/interleaved_quad.gltf", 2, 0, 0, 0},
    {"valid/mesh_primitive_modes/Mesh_PrimitiveMode_04.gltf", 2, 0, 0, 0},
    {"valid/mesh_primitive_modes/Mesh_PrimitiveMode_05.gltf", 2, 0, 0, 0},
    {"valid/mesh_primitive_modes/Mesh_PrimitiveMode_13.gltf", 2, 0, 0, 0},
    {"valid/mesh_primitive_modes/Mesh_PrimitiveMode_14.gltf", 2, 0, 0, 0},
    {"valid/mesh_primitive_modes/Mesh_PrimitiveMode_15.gltf", 2, 0, 0, 0},
    {"valid/multiple_scenes/MultipleScenes.gltf", 2, 0, 0, 0},
    {"valid/simple_meshes/SimpleMeshes.gltf", 2, 0, 0, 0},
    {"valid/simple_sparse_accessor/SimpleSparseAccessor.gltf", 12, 0, 0, 0},
    {"valid/triangle/Triangle.gltf", 1, 0, 0, 0},
    {"valid/triangle_without_indices/TriangleWithoutIndices.gltf", 1, 0, 0, 0},
};

typedef struct {
    const char *path;
    const char *expect; /* a piece of the one-line error */
} refused_case;

/* valid glTF with nothing to render, then the invalid files */
static const refused_case refused_cases[] = {
    {"valid/mesh_primitive_modes/Mesh_PrimitiveMode_00.gltf", "nothing to render"},
    {"valid/mesh_primitive_modes/Mesh_PrimitiveMode_01.gltf", "nothing to render"},
    {"valid/mesh_primitive_modes/Mesh_PrimitiveMode_03.gltf", "nothing to render"},
    {"valid/validator_ext_parse_only/lights_spot_valid.gltf", "nothing to render"},
    {"valid/validator_ext_parse_only/transmission_valid.gltf", "nothing to render"},
    {"invalid/accessor_unresolved_bufferview/unresolved_bufferviews.gltf", "bufferView 0 does not exist (accessor 0)"},
    {"invalid/box_with_infinites/BoxWithInfinites.glb", "non-finite vertex position"},
    {"invalid/buffer_invalid_data_uri/invalid_uri_data.gltf", "malformed data: URI (buffer 0)"},
    {"invalid/buffer_not_found/not_found.gltf", "cannot open buffer not_found.bin"},
    {"invalid/bufferview_exceeds_buffer/invalid_length.gltf", "bufferView 0 (offset 0 + length 5) exceeds buffer 0 (4 bytes)"},
    {"invalid/glb_invalid_magic/invalid_magic.glb", "not a glTF binary (bad magic)"},
    {"invalid/glb_length_mismatch/length_mismatch.glb", "header length 49 > file size 48"},
    {"invalid/glb_truncated_chunk_data/truncated_chunk_data.glb", "truncated GLB"},
    {"invalid/index_out_of_range_assimp/IndexOutOfRange.gltf", "index 255 >= vertex count 24 (mesh 0 primitive 0)"},
    {"invalid/json_invalid_syntax/invalid_syntax.gltf", "JSON syntax error"},
    {"invalid/light_unresolved/unresolved_light_no_root_ext.gltf", "light 0 does not exist (node 0"},
    {"invalid/made_here/accessor_count_exceeds_buffer.gltf", "accessor 1 needs 12000 bytes but bufferView 1 has 36"},
    {"invalid/made_here/asset_version_1.gltf", "unsupported glTF version 1.0"},
    {"invalid/made_here/bad_magic.glb", "not a glTF binary (bad magic)"},
    {"invalid/made_here/buffer_bytelength_huge.gltf", "buffer size mismatch"},
    {"invalid/made_here/bufferview_offset_past_end.gltf", "(offset 4096 + length 36) exceeds buffer 0 (44 bytes)"},
    {"invalid/made_here/empty.glb", "empty file"},
    {"invalid/made_here/empty.gltf", "empty file"},
    {"invalid/made_here/glb_version1.glb", "unsupported GLB version 1"},
    {"invalid/made_here/huge_index_count.gltf", "needs 8000000000 bytes but bufferView 0 has 8"},
    {"invalid/made_here/huge_vertex_count.gltf", "needs 48000000000 bytes but bufferView 1 has 36"},
    {"invalid/made_here/index_out_of_range.gltf", "index 7 >= vertex count 3 (mesh 0 primitive 0)"},
    {"invalid/made_here/indices_float_type.gltf", "indices must be UNSIGNED_BYTE/SHORT/INT"},
    {"invalid/made_here/inf_position.gltf", "non-finite vertex position"},
    {"invalid/made_here/json_nan_literal.gltf", "JSON syntax error"},
    {"invalid/made_here/json_syntax_error.gltf", "line 76, column 1"},
    {"invalid/made_here/meshes_but_no_scene.gltf", "nothing to render"},
    {"invalid/made_here/missing_bin.gltf", "cannot open buffer missing_buffer.bin"},
    {"invalid/made_here/nan_position.gltf", "non-finite vertex position"},
    {"invalid/made_here/negative_accessor_index.gltf", "invalid (negative) accessor index -1"},
    {"invalid/made_here/node_cycle_with_mesh.gltf", "cycle"},
    {"invalid/made_here/node_mesh_out_of_range.gltf", "mesh 5 does not exist (node 0)"},
    {"invalid/made_here/truncated.glb", "truncated GLB"},
    {"invalid/made_here/uri_absolute_path.gltf", "absolute path uri /etc/passwd is not allowed"},
    {"invalid/made_here/uri_dotdot_escapes_folder.gltf", "escapes the model's folder"},
    {"invalid/made_here/uri_path_traversal.gltf", "escapes the model's folder"},
    {"invalid/made_here/zero_nodes_scene.gltf", "nothing to render"},
    {"invalid/mesh_unresolved_positions/unresolved_positions.gltf", "accessor 0 does not exist (mesh 0 primitive 0 POSITION)"},
    {"invalid/node_infinite_transform/infinite_transform.gltf", "number overflow"},
    {"invalid/node_loop_scene/node_loop_scene.gltf", "cycle (node 0)"},
    {"invalid/scene_unresolved_default/unresolved_default_scene.gltf", "scene 0 does not exist (default scene)"},
    {"invalid/scene_unresolved_node/unresolved_node.gltf", "node 0 does not exist (scene 0)"},
};

#define COUNT(a) (sizeof(a) / sizeof((a)[0]))

/* The pm_scene contract every loaded scene must meet. */
static void check_scene_contract(const char *name, const pm_scene *s) {
    bool finite = true, unit = true, indices = true, materials = true, textures = true;
    for (uint32_t v = 0; v < s->vertex_count; v++) {
        finite = finite && v3_is_finite(s->positions[v]);
        unit = unit && fabsf(v3_length(s->normals[v]) - 1.f) < 1e-4f;
    }
    for (uint32_t i = 0; i < 3 * s->triangle_count; i++) indices = indices && s->indices[i] < s->vertex_count;
    for (uint32_t t = 0; t < s->triangle_count; t++) materials = materials && s->triangle_material[t] < s->material_count;
    for (uint32_t m = 0; m < s->material_count; m++)
        textures = textures && s->materials[m].base_color_texture < (int)s->texture_count;
    for (uint32_t t = 0; t < s->texture_count; t++)
        textures = textures && s->textures[t].width > 0 && s->textures[t].height > 0 && s->textures[t].rgba;
    CHECK(finite, "%s: non-finite position", name);
    CHECK(unit, "%s: a normal is not unit length", name);
    CHECK(indices, "%s: an index >= vertex_count", name);
    CHECK(materials, "%s: a triangle material >= material_count", name);
    CHECK(textures, "%s: a material texture index or a texture is invalid", name);
    CHECK(!s->sky && s->emitter_count == 0 && s->emitters == NULL, "%s: finalize's fields must stay zero", name);
}

static void check_valid(const char *root, const valid_case *c) {
    char path[1024], err[1024];
    snprintf(path, sizeof path, "%s/%s", root, c->path);
    pm_scene s;
    pm_load_report report;
    if (!pm_load_gltf(path, true, &s, &report, err, sizeof err)) {
        CHECK(false, "%s must load: %s", c->path, err);
        return;
    }
    CHECK(pm_scene_triangle_ids(&s) == c->triangles, "%s: %u triangles (placed), want %u", c->path, pm_scene_triangle_ids(&s), c->triangles);
    CHECK(s.light_count == c->lights, "%s: %u lights, want %u", c->path, s.light_count, c->lights);
    CHECK(s.camera_count == c->cameras, "%s: %u cameras, want %u", c->path, s.camera_count, c->cameras);
    CHECK(s.texture_count == c->textures, "%s: %u textures, want %u", c->path, s.texture_count, c->textures);
    check_scene_contract(c->path, &s);
    pm_scene_free(&s);
}

static void check_refused(const char *root, const refused_case *c) {
    char path[1024], err[1024];
    snprintf(path, sizeof path, "%s/%s", root, c->path);
    pm_scene s;
    pm_load_report report;
    bool ok = pm_load_gltf(path, true, &s, &report, err, sizeof err);
    CHECK(!ok, "%s must be refused (%s)", c->path, c->expect);
    if (ok) {
        pm_scene_free(&s);
        return;
    }
    size_t n = strlen(path);
    CHECK(strncmp(err, path, n) == 0 && strncmp(err + n, ": ", 2) == 0, "%s: error does not start with the path: %s",
          c->path, err);
    CHECK(strchr(err, '\n') == NULL && strchr(err, '\r') == NULL, "%s: error is not one line: %s", c->path, err);
    CHECK(strstr(err, c->expect) != NULL, "%s: error lacks \"%s\": %s", c->path, c->expect, err);
    CHECK(s.positions == NULL && s.triangle_count == 0 && s.materials == NULL, "%s: scene not left empty", c->path);
}

static bool listed(const char *relative) {
    for (size_t i = 0; i < COUNT(valid_cases); i++)
        if (strcmp(valid_cases[i].path, relative) == 0) return true;
    for (size_t i = 0; i < COUNT(refused_cases); i++)
        if (strcmp(refused_cases[i].path, relative) == 0) return true;
    return false;
}

static bool is_model(const char *name) {
    size_t n = strlen(name);
    return (n > 5 && strcmp(name + n - 5, ".gltf") == 0) || (n > 4 && strcmp(name + n - 4, ".glb") == 0);
}

/* Counts the model files under root/relative, reporting any the table lacks. */
static int walk_models(const char *root, const char *relative) {
    char folder[1024];
    snprintf(folder, sizeof folder, "%s/%s", root, relative);
    DIR *dir = opendir(folder);
    if (!dir) return 0;
    int count = 0;
    struct dirent *e;
    while ((e = readdir(dir)) != NULL) {
        if (e->d_name[0] == '.') continue;
        char child[1024], full[2048];
        snprintf(child, sizeof child, "%s/%s", relative, e->d_name);
        snprintf(full, sizeof full, "%s/%s", root, child);
        struct stat st;
        if (stat(full, &st) != 0) continue;
        if (S_ISDIR(st.st_mode)) {
            count += walk_models(root, child);
        } else if (is_model(e->d_name)) {
            count++;
            CHECK(listed(child), "corpus file %s is not in the test's table", child);
        }
    }
    closedir(dir);
    return count;
}

int main(void) {
    const char *root = getenv("PMVIEW_CORPUS");
    if (!root || !*root) root = "../shared/gltf-corpus";
    char readme[1024];
    snprintf(readme, sizeof readme, "%s/README.md", root);
    struct stat st;
    if (stat(readme, &st) != 0) {
        printf("SKIP: corpus not found at %s (set PMVIEW_CORPUS to the gltf-corpus folder)\n", root);
        printf("test_corpus: skipped\n");
        return 0;
    }
    for (size_t i = 0; i < COUNT(valid_cases); i++) check_valid(root, &valid_cases[i]);
    for (size_t i = 0; i < COUNT(refused_cases); i++) check_refused(root, &refused_cases[i]);
    int files = walk_models(root, "valid") + walk_models(root, "invalid");
    CHECK(files == (int)(COUNT(valid_cases) + COUNT(refused_cases)), "corpus has %d model files, the table %zu", files,
          COUNT(valid_cases) + COUNT(refused_cases));
    return pm_test_done("test_corpus");
}

/* loader.h: glTF 2.0 (.gltf/.glb) to pm_scene, with every check a renderer needs before trusting a file.
 *
 * The only place tinygltf is used (src/gltf_loader.cpp). On failure the scene is left empty,
 * nothing leaks, and err holds one line: "FILE: what (where)". Warnings (skipped primitives,
 * degenerate triangles, ignored features) go to stderr as "pmview: warning: FILE: ..." and are
 * counted in the report.
 */
#ifndef PM_LOADER_H
#define PM_LOADER_H

#include <stdbool.h>
#include <stddef.h>
#include "scene.h"

typedef struct {
    uint32_t skipped_degenerate;     /* zero-area or non-finite-normal triangles dropped */
    uint32_t skipped_primitives;     /* points / lines primitives dropped */
    uint32_t warnings;               /* warning lines printed */
    uint32_t ignored_inputs;         /* material inputs not rendered (alpha modes, normal maps, unsupported extensions...), one warning per kind */
    uint32_t occlusion_textures_ignored; /* materials with an occlusionTexture: a tracer computes occlusion, so it is not read (no warning) */
    double seconds;                  /* wall time of the load */
    double json_seconds;             /* of which parsing the JSON text */
    uint32_t json_parses;            /* times the JSON text was parsed: 1 once the container and the nesting depth pass, whether the file then loads or not */
    double unit_scale;               /* scene units per file unit: a power of two, 1 unless the file's extent was outside [2^-20, 2^20] */
    uint64_t peak_bytes;             /* the most memory the load held at once, forecast from the sizes it met (pm_memory_forecast) */
    bool recentered;                 /* the scene was moved to the origin (it lay over 2^10 extents away; see README) */
} pm_load_report;

/* What a load may do differently. A zeroed struct is the default. */
typedef struct {
    bool flatten_instances;  /* copy every placement of a mesh into world space (as if each node had its own mesh) instead of
                                storing the mesh once and placing it (scene.h, Instancing): the flat equivalent of the file */
    const char *variant;     /* KHR_materials_variants: the variant whose materials the primitives take; NULL: the file's
                                default materials. A name the file does not list fails the load, naming the ones it does */
} pm_load_options;

/* Loads and validates. Does not call pm_scene_finalize (the caller decides on the default sky).
 * quiet: do not print warnings (they are still counted). */
bool pm_load_gltf(const char *path, bool quiet, pm_scene *out, pm_load_report *report,
                  char *err, size_t err_size);

/* The same from bytes in memory (the fuzz target): name stands for the file in messages, and a
 * name ending in .glb, or bytes starting with "glTF", are read as GLB. Only data: URIs and the
 * GLB's BIN chunk can be read: a buffer that names an external file is refused, an image that
 * does is not found (a warning, its textures ignored, as for a missing image file). */
bool pm_load_gltf_memory(const void *data, size_t size, const char *name, bool quiet, pm_scene *out,
                         pm_load_report *report, char *err, size_t err_size);

/* pm_load_gltf and pm_load_gltf_memory with options (NULL: the defaults). */
bool pm_load_gltf_with(const char *path, const pm_load_options *options, bool quiet, pm_scene *out,
                       pm_load_report *report, char *err, size_t err_size);
bool pm_load_gltf_memory_with(const void *data, size_t size, const char *name, const pm_load_options *options, bool quiet,
                              pm_scene *out, pm_load_report *report, char *err, size_t err_size);

#endif

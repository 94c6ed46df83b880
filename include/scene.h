/* scene.h: the validated C scene every later stage reads, and the analysis of what it needs.
 *
 * The loader fills the geometry, materials, textures, lights and cameras in world space
 * (meshes placed once flattened, those placed several times stored once with their placements,
 * see Instancing below; transforms applied, winding fixed so the geometric normal
 * cross(p1-p0, p2-p0) always points out of the glTF front face). pm_scene_finalize() then
 * derives everything else: bounds, the emitter distribution, the default sky and the
 * analysis of which components can be non-zero. Nothing here knows about Embree or GL.
 */
#ifndef PM_SCENE_H
#define PM_SCENE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include "brdf.h"
#include "defaults.h"
#include "pm_math.h"
#include "sky.h"

enum { PM_WRAP_REPEAT = 0, PM_WRAP_CLAMP = 1, PM_WRAP_MIRROR = 2 };
/* A glTF sampler's minFilter (0, the default, is LINEAR_MIPMAP_LINEAR: trilinear by footprint).
 * The _MIPMAP_ kinds read the levels, the texel filter first, the level choice second. */
enum {
    PM_MIN_DEFAULT = 0, PM_MIN_NEAREST, PM_MIN_LINEAR, PM_MIN_NEAREST_MIPMAP_NEAREST, PM_MIN_LINEAR_MIPMAP_NEAREST,
    PM_MIN_NEAREST_MIPMAP_LINEAR, PM_MIN_LINEAR_MIPMAP_LINEAR
};

/* An 8-bit RGBA image as stored in the file (sRGB-encoded); decoded to linear on lookup.
 * pm_scene_finalize adds its mip levels (pm_texture_build_levels): level k is level k-1 box-filtered
 * to half its size (rounded down, at least 1), down to 1 x 1, in the same 8-bit encoding. A
 * texture without them (level_count 0 or 1) is read at level 0 whatever the footprint. */
typedef struct {
    int width, height;
    uint8_t *rgba;          /* width*height*4 bytes, row 0 = top of the image (glTF v=0) */
    int wrap_s, wrap_t;     /* PM_WRAP_* */
    /* the sampler's filters: magFilter NEAREST (the texel under the point, where the footprint is at
     * most a texel, and for every lookup without a footprint, alpha included) and minFilter
     * (PM_MIN_*, where the footprint is wider); zero is glTF's usual LINEAR / LINEAR_MIPMAP_LINEAR */
    bool mag_nearest;
    int min_filter;
    int level_count;        /* levels in all, level 0 (rgba) included */
    uint8_t *levels;        /* levels 1 .. level_count-1 one after another, owned; NULL without */
    int level_width[PM_TEXTURE_MAX_LEVELS], level_height[PM_TEXTURE_MAX_LEVELS];
    size_t level_offset[PM_TEXTURE_MAX_LEVELS]; /* bytes into `levels` of level k >= 1 */
} pm_texture;

/* glTF alphaMode: MASK cuts the surface out where alpha < alpha_cutoff; BLEND lets each ray
 * through with probability 1 - alpha (stochastic transparency, decided in accel). */
typedef enum { PM_ALPHA_OPAQUE = 0, PM_ALPHA_MASK = 1, PM_ALPHA_BLEND = 2 } pm_alpha_mode;

/* What KHR_texture_transform does to one texture reference's coordinates: the affine map (u', v') = (m[0] u + m[1] v + m[2], m[3] u + m[4] v + m[5]),
 * applied only when `transformed` (a zeroed struct is the identity, so builders need not set it). */
typedef struct {
    bool transformed;
    float m[6];
} pm_uv_transform;

/* A texture reference of the layer extensions: the texture (-1 none), its TEXCOORD set (0 or 1) and transform. */
typedef struct {
    int texture, texcoord;
    pm_uv_transform transform;
} pm_texture_ref;

/* KHR_materials_specular, _sheen and _clearcoat on a material (the model: brdf.h): the factors,
 * each times its texture's channel (colour textures sRGB, the others linear). */
typedef struct {
    float specular;                             /* specularFactor x specularTexture's A */
    vec3 specular_color;                        /* specularColorFactor x specularColorTexture's RGB */
    vec3 sheen_color;                           /* sheenColorFactor x sheenColorTexture's RGB */
    float sheen_roughness;                      /* sheenRoughnessFactor x sheenRoughnessTexture's A */
    float clearcoat;                            /* clearcoatFactor x clearcoatTexture's R */
    float clearcoat_roughness;                  /* clearcoatRoughnessFactor x clearcoatRoughnessTexture's G */
    pm_texture_ref specular_texture, specular_color_texture, sheen_color_texture, sheen_roughness_texture,
        clearcoat_texture, clearcoat_roughness_texture;
    /* clearcoatNormalTexture: the coat's own tangent-space normal map (read like normal_texture, x and
     * y times clearcoat_normal_scale), -1 none: the coat then takes the base's shading normal */
    pm_texture_ref clearcoat_normal_texture;
    float clearcoat_normal_scale;
} pm_material_layers;

/* glTF metallic-roughness material plus the extensions we honour; see docs/design.md (Materials) for the mapping
 * to the diffuse (D) and specular (S) coefficients used by Russian roulette. Each texture has
 * its TEXCOORD set (0 or 1; 1 reads the scene's uvs1) and its transform. */
typedef struct {
    vec3 base_color;        /* linear baseColorFactor rgb */
    int base_color_texture; /* index into scene textures, -1 none */
    int base_color_texcoord;/* which TEXCOORD_n the texture uses: 0 or 1 */
    float metallic, roughness;
    float transmission;     /* KHR_materials_transmission factor */
    float ior;              /* KHR_materials_ior, default 1.5 */
    vec3 emission;          /* emissiveFactor x KHR_materials_emissive_strength; radiance = this x the emissive texture */
    int emission_texture;   /* index into scene textures (sRGB), -1 none */
    bool double_sided;
    /* KHR_materials_volume: the attenuation coefficient per unit length (per channel) inside the
     * closed mesh this material bounds, 0 = none (no extension, or a thin-walled surface) */
    vec3 attenuation;
    /* KHR_materials_transmission without a volume (no KHR_materials_volume, or thicknessFactor 0):
     * an infinitely thin sheet, which light crosses straight, without bending (see docs/design.md,
     * Materials); false is the boundary of solid glass, refracting at ior */
    bool thin_walled;
    pm_alpha_mode alpha_mode;
    float alpha;            /* baseColorFactor[3]; coverage = this x the base colour texture's (linear) alpha */
    float alpha_cutoff;     /* MASK only, glTF default 0.5 */
    int emission_texcoord;  /* 0 or 1 */
    /* data textures, read linear (no sRGB decode): metallic x B, roughness x G; transmission x R */
    int metallic_roughness_texture, metallic_roughness_texcoord; /* -1 none */
    int transmission_texture, transmission_texcoord;             /* -1 none */
    pm_uv_transform base_color_transform, emission_transform, metallic_roughness_transform, transmission_transform;
    /* tangent-space normal map, read linear ([0,1] -> [-1,1]); x and y times normal_scale (glTF
     * normalTexture.scale). Used only when the scene has tangents; -1 none */
    int normal_texture, normal_texcoord;
    float normal_scale;
    pm_uv_transform normal_transform;
    /* some layer extension (pm_material_layers) is on the material: its points are all glossy
     * (the layered lobe, brdf.h); false: `layers` is not read */
    bool layered;
    pm_material_layers layers;
    /* derived by pm_scene_finalize: whether each lobe's weight can be non-zero at some point of
     * the material (the factors with the data textures' whole range of texel values) */
    bool may_diffuse, may_mirror, may_glass, may_glossy;
    bool may_near_specular; /* some point's glossy lobe has a part paths go on through (vertex.h, pm_vertex_near_specular_parts) */
    bool may_see_through;    /* derived too: pm_material_can_be_transparent (it reads the whole alpha texture) */
    /* KHR_materials_unlit: the camera sees base colour x its texture as it is, directly or through
     * mirrors and glass (pm_surface.emission, unlit set); everything else meets a black absorber
     * that lights nothing (see docs/design.md, Materials). Its emission factor is 0. */
    bool unlit;
    bool used;               /* derived too: some triangle has this material (the analysis counts only those) */
    /* derived by pm_scene_finalize for a material without base colour, metallic-roughness or
     * transmission texture: its split is the same at every point, so a hit copies it instead of
     * clamping and splitting the factors again (every photon bounce reads a surface) */
    bool uniform_split;
    vec3 split_kd, split_ks, split_kt;
    float split_ks_grazing;
    float split_glass_alpha;
    bool split_glossy;
    pm_brdf split_brdf;
} pm_material;

/* glTF's default material (white, fully metallic and rough, opaque, alpha cutoff 0.5, ior 1.5) with
 * no texture: what a primitive without a material gets, and where every material starts. */
static inline void pm_material_set_default(pm_material *m) {
    memset(m, 0, sizeof *m);
    m->base_color = v3(1.f, 1.f, 1.f);
    m->base_color_texture = m->emission_texture = m->metallic_roughness_texture = -1;
    m->transmission_texture = m->normal_texture = -1;
    m->normal_scale = 1.f;
    m->metallic = m->roughness = 1.f;
    m->ior = 1.5f;
    m->alpha = 1.f;
    m->alpha_cutoff = 0.5f;
}

/* Whether the material's coat has its own normal map (KHR_materials_clearcoat clearcoatNormalTexture). */
static inline bool pm_material_coat_normal_mapped(const pm_material *m) {
    return m->layered && m->layers.clearcoat > 0.f && m->layers.clearcoat_normal_texture.texture >= 0;
}
/* Whether a material reads the vertices' tangents (a normal map, its own or its coat's), and from
 * which TEXCOORD set generated tangents follow the UVs: the base normal map's, else the coat's. */
static inline bool pm_material_tangents_read(const pm_material *m) {
    return m->normal_texture >= 0 || pm_material_coat_normal_mapped(m);
}
static inline int pm_material_tangent_texcoord(const pm_material *m) {
    return m->normal_texture >= 0 ? m->normal_texcoord : m->layers.clearcoat_normal_texture.texcoord;
}

typedef enum { PM_LIGHT_POINT = 0, PM_LIGHT_SPOT = 1, PM_LIGHT_DIRECTIONAL = 2 } pm_light_type;

typedef struct {
    pm_light_type type;
    vec3 position;          /* world space (point, spot) */
    vec3 direction;         /* unit, the direction light travels: the node's -Z (spot, directional) */
    vec3 intensity;         /* color x intensity: W/sr (point, spot) or W/m^2 (directional) */
    float range;            /* 0 = infinite; glTF's range is a cut-off hint, see docs/design.md (Lights) */
    float cos_inner, cos_outer; /* spot cone, cosines of the glTF angles */
} pm_light;

typedef struct {
    vec3 position;
    vec3 forward, up, right; /* unit, right-handed: forward = node -Z, up = node +Y */
    float yfov;              /* radians, vertical (perspective) */
    float aspect;            /* glTF aspectRatio (xmag/ymag for orthographic), 0 when absent */
    float znear;
    bool orthographic;       /* parallel rays from the image plane through position */
    float ymag;              /* orthographic: half the view's height in scene units (the width follows the image) */
} pm_camera;

/* Which of the four image components a scene can make non-zero. */
typedef enum { PM_DIRECT = 0, PM_SPECULAR = 1, PM_CAUSTIC = 2, PM_INDIRECT = 3, PM_COMPONENT_COUNT = 4 } pm_component;
extern const char *const pm_component_names[PM_COMPONENT_COUNT]; /* "direct", "specular", ... */

typedef struct {
    bool has_diffuse, has_mirror, has_glass, has_textures;
    bool has_glossy;         /* some material has the GGX lobe (has_diffuse is then true too: it is a D surface) */
    bool has_near_specular;  /* some material's lobe has a near-specular part (vertex.h): paths go on through it as
                                through mirrors, so it makes caustics and the specular component as they do */
    bool has_emissive_triangles, has_punctual_lights, has_sky;
    bool has_thin_glass;     /* some material can let light straight through a thin wall: shadow rays cross it (thin.h) */
    bool has_non_opaque;     /* some triangle's material can let rays through (MASK or BLEND with alpha that can cut) */
    bool has_unlit;          /* some triangle's material is unlit: the camera sees it without any light */
    bool caustics_possible;  /* some light can reach a specular surface and then a diffuse one */
    bool interreflection_possible; /* light reflected by a diffuse surface can reach a diffuse one again */
    double receiving_area;   /* the area light can land on and be reflected from diffusely (triangles whose material has
                                a diffuse or glossy share at some point, its textures' range of metallic and transmission
                                included): the photon density that sets initial radii, the shadow photons' cell and the
                                mean light (light_peak_over_mean) divide by it */
    double light_peak_over_mean; /* the brightest light's radiance over the mean the light arrives with, the sky's and
                                    the emitters' (scene.c); punctual lights are not in it (a delta is concentrated) */
    bool light_diffuse;      /* no punctual light, and no light (sky or emitting surface) brighter than PM_DIFFUSE_LIGHT_PEAK
                                times that mean: a path's sample through any mirrors, glass and lobes meets no more than
                                that, so the path tracer finds caustics as it finds any indirect light */
    bool component_possible[PM_COMPONENT_COUNT];
} pm_scene_analysis;

/* Instancing (docs/design.md, Instancing): a mesh the file places with two or more nodes is stored
 * once, in mesh space, as a range of the scene's triangles and vertices, and each placement
 * transforms it; everything else stays flat, in world space. */
typedef struct {
    uint32_t first_triangle, triangle_count; /* stored triangles (indices, triangle_material, face_normals) */
    uint32_t first_vertex, vertex_count;     /* stored vertices */
    uint32_t first_placement, placement_count; /* its placements, consecutive in placements[] */
} pm_instanced_mesh;

typedef struct {
    uint32_t mesh;               /* index into instanced_meshes */
    uint32_t first_id;           /* the triangle id of the mesh's first triangle here (ids past the flat triangles) */
    float object_to_world[12];   /* row-major 3x4: world = M (x, y, z, 1) */
    float normal_matrix[9];      /* row-major inverse transpose of M's 3x3 part (normals) */
    float handedness;            /* 1, or -1 when M mirrors (the stored winding is then reversed in world space) */
} pm_placement;

/* One emissive triangle (in s->emitters order), all that a point picked on it reads, in one
 * record: its world corners (p0 at barycentrics (0, 0); b1, b2 weigh p1, p2), unit normal by the
 * winding and area (pm_triangle_geometry_of), and its material's emission where that is the same
 * everywhere on it (no emissive texture, no cut-out: what pm_scene_emitted_at then returns), with
 * its sides. A light sample or a photon start reads it in place of the triangle's indices, corners
 * and material, a chain of loads each waiting on the last (on an emissive mesh larger than the
 * caches, each a miss). */
typedef struct {
    vec3 p0, p1, p2, normal;
    vec3 emission;
    float area;
    bool uniform_emission, double_sided;
} pm_emitter;

typedef struct {
    /* geometry, world space */
    uint32_t vertex_count, triangle_count;
    vec3 *positions;          /* vertex_count */
    vec3 *normals;            /* vertex_count, unit shading normals (generated when absent) */
    float *uvs;               /* 2*vertex_count, or NULL when no primitive has TEXCOORD_0 */
    float *uvs1;              /* 2*vertex_count TEXCOORD_1, or NULL when no material's texture reads set 1 */
    float *tangents;          /* 4*vertex_count: unit tangent xyz (world, along +u of the normal map's set) and w = +-1,
                                 the bitangent being w cross(normal, tangent); NULL when no material has a normal map */
    uint32_t *indices;        /* 3*triangle_count */
    uint32_t *triangle_material; /* triangle_count */
    float *edge_altitudes;    /* 3*triangle_count: each stored triangle's altitudes (pm_triangle_altitudes), made with
                                 face_normals; NULL when that allocation failed */
    vec3 *face_normals;       /* triangle_count unit geometric normals (glTF front side), computed in double by
                                 pm_scene_finalize; NULL when that allocation failed (each hit then computes its own) */
    float *uv_density;        /* 2*triangle_count: sqrt(UV area / world area) of each triangle for TEXCOORD_0 and _1
                                 (0 without the set), made by pm_scene_finalize for a textured scene, else NULL: turns
                                 a footprint in world units into one in UV units (texture filtering) */
    /* Instancing: stored triangles [0, instanced_meshes[0].first_triangle) are flat (world space), the rest
     * belong to instanced meshes (mesh space). A triangle id (pm_hit.tri, emitters, every tri argument)
     * names a flat triangle by its stored index, or a placed one as placements[p].first_id + its index in
     * its mesh; pm_scene_stored_triangle maps one to the other. No placement: ids are stored indices. */
    pm_instanced_mesh *instanced_meshes; uint32_t instanced_mesh_count;
    pm_placement *placements; uint32_t placement_count;
    uint32_t triangle_id_count;  /* flat triangles plus every placement's (set by the loader with placements) */

    pm_material *materials; uint32_t material_count;
    pm_texture *textures;   uint32_t texture_count;
    pm_light *lights;       uint32_t light_count;
    pm_camera *cameras;     uint32_t camera_count;
    /* KHR_materials_variants: the file's variant names, each ended by '\0', one after another (NULL
     * when none); the window's variant key loads the file again with the next one */
    char *variant_names;    uint32_t variant_count;
    uint64_t memory_admitted; /* bytes admitted against --max-memory (geometry, texels), given back by pm_scene_free */

    bool sky;                 /* an environment around the scene: radiance sky_radiance x the map's (1 without one) */
    vec3 sky_radiance;
    pm_sky_map *sky_map;      /* owned; NULL = uniform */

    /* derived by pm_scene_finalize */
    vec3 bounds_min, bounds_max; /* every triangle */
    vec3 core_min, core_max;   /* the core (pm_scene_core): small strays far from the bulk left out */
    vec3 center; float radius; /* the core's bounding sphere: the sky's and the sun's photon disc, framing */
    float ray_scale;           /* length scale for ray offsets and default radii (largest extent of the core) */
    uint32_t *emitters;        /* triangle indices whose emission, averaged over the triangle, is not black */
    pm_emitter *emitter_records; /* emitter_count: what a point picked on each reads (pm_emitter) */
    vec3 *emitter_radiance;    /* emitter_count: each one's radiance averaged over its triangle (texture included) */
    float *emitter_cdf;        /* emitter_count+1 entries, by area x luminance x sides */
    uint32_t *emitter_cut;     /* emitter_count cut points of emitter_cdf (pm_cdf_cut_points) */
    uint32_t emitter_count;
    uint64_t emitter_admitted; /* bytes of the five tables above admitted against --max-memory, given back when they go */
    float emitter_power;       /* sum of area x luminance(radiance) x pi x sides */
    float *light_cdf;          /* light_count+1 entries by power, when there are more than PM_DIRECT_LIGHT_SAMPLES punctual lights; else NULL */
    uint32_t clamped_emission; /* materials, lights and sky whose emission finalize clamped to PM_MAX_EMISSION: the caller warns */
    pm_scene_analysis analysis;
} pm_scene;

/* Derives bounds, face normals, emitter and light distributions and analysis. add_default_sky:
 * give a scene without any light a uniform white sky (returns true in *added_sky so the caller
 * can warn). False when out of memory (pm_memory_failure names what): the scene is only freed. */
bool pm_scene_finalize(pm_scene *s, bool add_default_sky, bool *added_sky);

/* A 64-bit digest (FNV-1a) of what the loader made: geometry, placements, materials, textures'
 * texels, lights, cameras and the sky's radiance. Under mpirun every rank must hold the same
 * scene; the set-up's agreement compares the ranks' digests (pm_cluster_agree). */
uint64_t pm_scene_digest(const pm_scene *s);

/* The scene's core (scene_core.c): the bounds of its bulk, leaving out small geometry (under a
 * tenth of the surface area) lying farther than 8 core extents from the rest, so a stray helper
 * far away changes no size the renderer derives from the scene. bounds_min/max must be set;
 * false when out of memory (the core is then the whole bounds). */
bool pm_scene_core(const pm_scene *s, vec3 *core_min, vec3 *core_max);
/* The same over any triangles (the loader's, in double, before the scene exists): `next` gives
 * the corners of the next one (the first again when restart is true), false past the last;
 * `count` is how many there are. lo/hi hold the whole bounds on entry, the core on return. */
typedef struct {
    uint64_t count;
    void *context;
    bool (*next)(void *context, bool restart, double corners[9]);
} pm_core_source;
bool pm_core_bounds(const pm_core_source *src, double lo[3], double hi[3]);
void pm_scene_free(pm_scene *s);
/* The bytes of the scene's arrays, texels (mip levels included) and derived tables: what the
 * scene holds in memory (the memory forecast). */
uint64_t pm_scene_bytes(const pm_scene *s);
/* The share of the surface area whose material reflects at least `albedo` of the light (mean base
 * colour; textures not read): near 1 with albedo ~1, a closed room never absorbs light by itself. */
double pm_scene_reflective_area_fraction(const pm_scene *s, float albedo);
/* The world-space area of every triangle whose material `keep` accepts, in double: a placement that
 * is a similarity (rotation, mirror, uniform scale) counts its mesh's area times its scale squared,
 * so the sum costs stored triangles plus placements, not placed triangles. */
double pm_scene_area_where(const pm_scene *s, bool (*keep)(const pm_material *, const void *), const void *context);
/* Replaces the sky (the scene takes the map; NULL map = uniform, sky false = none) and analyses
 * the scene again: which components are possible depends on it. */
void pm_scene_set_sky(pm_scene *s, bool sky, vec3 radiance, pm_sky_map *map);

/* Radiance arriving from the environment along -dir (dir points from the scene to the sky). */
static inline vec3 pm_scene_sky(const pm_scene *s, vec3 dir) {
    return s->sky_map ? v3_mul(s->sky_radiance, pm_sky_map_radiance(s->sky_map, dir)) : s->sky_radiance;
}
/* The environment's radiance averaged over all directions. */
static inline vec3 pm_scene_sky_mean(const pm_scene *s) {
    return s->sky_map ? v3_mul(s->sky_radiance, s->sky_map->mean) : s->sky_radiance;
}

/* A camera framing the scene from the front (+Z) and a little above, for files without a camera. */
pm_camera pm_scene_auto_camera(const pm_scene *s, float aspect);
/* Keeps c's orientation and kind and moves it back from the centre of the bounds (or, for an
 * orthographic camera, sets its ymag) until every vertex is in view with a 5% margin: the model
 * fills the frame, however far its bounding sphere reaches past its silhouette. */
pm_camera pm_scene_fit_camera(const pm_scene *s, pm_camera c, float aspect);

/* ---- triangle ids (see Instancing above): every reader of a hit's triangle goes through these */

/* How many triangle ids there are: what a loop over every triangle of the world runs over. */
static inline uint32_t pm_scene_triangle_ids(const pm_scene *s) {
    return s->placement_count ? s->triangle_id_count : s->triangle_count;
}
/* Stored triangles that are flat (world space). */
static inline uint32_t pm_scene_flat_triangles(const pm_scene *s) {
    return s->instanced_mesh_count ? s->instanced_meshes[0].first_triangle : s->triangle_count;
}
/* The placement triangle id `id` lies in, -1 for a flat triangle. A mesh's placements are
 * consecutive and its ids run through them in order, each placement as many as the mesh has
 * triangles (the loader's place_instanced_meshes): the mesh is found among the few meshes, the
 * placement by one division. Every hit asks several times, and a search over thousands of
 * placements, its branches unpredictable, costs more than the rest of a photon's bounce. */
static inline int32_t pm_scene_placement_of(const pm_scene *s, uint32_t id) {
    if (!s->placement_count || id < s->placements[0].first_id) return -1;
    uint32_t lo = 0, hi = s->instanced_mesh_count - 1;
    while (lo < hi) { /* the last mesh whose first placement's first_id <= id */
        uint32_t mid = lo + (hi - lo + 1) / 2;
        if (s->placements[s->instanced_meshes[mid].first_placement].first_id <= id) lo = mid;
        else hi = mid - 1;
    }
    const pm_instanced_mesh *m = &s->instanced_meshes[lo];
    uint32_t k = m->triangle_count ? (id - s->placements[m->first_placement].first_id) / m->triangle_count : 0;
    return (int32_t)(m->first_placement + (k < m->placement_count ? k : m->placement_count - 1));
}
/* The stored triangle behind id, and its placement (-1 flat) in *placement when not NULL. */
static inline uint32_t pm_scene_stored_triangle(const pm_scene *s, uint32_t id, int32_t *placement) {
    int32_t p = pm_scene_placement_of(s, id);
    if (placement) *placement = p;
    if (p < 0) return id;
    const pm_placement *pl = &s->placements[p];
    return s->instanced_meshes[pl->mesh].first_triangle + (id - pl->first_id);
}
/* The id of stored triangle `stored` of an instanced mesh as placement p places it. */
static inline uint32_t pm_scene_placed_id(const pm_scene *s, uint32_t p, uint32_t stored) {
    const pm_placement *pl = &s->placements[p];
    return pl->first_id + (stored - s->instanced_meshes[pl->mesh].first_triangle);
}
static inline uint32_t pm_scene_triangle_material(const pm_scene *s, uint32_t id) {
    return s->triangle_material[pm_scene_stored_triangle(s, id, NULL)];
}
static inline vec3 pm_placement_point(const pm_placement *pl, vec3 p) {
    const float *m = pl->object_to_world;
    return v3(m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3], m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
              m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]);
}
static inline vec3 pm_placement_direction(const pm_placement *pl, vec3 d) {
    const float *m = pl->object_to_world;
    return v3(m[0] * d.x + m[1] * d.y + m[2] * d.z, m[4] * d.x + m[5] * d.y + m[6] * d.z, m[8] * d.x + m[9] * d.y + m[10] * d.z);
}
/* A normal through the placement, unit (not normalised first: the caller's input need not be). */
static inline vec3 pm_placement_normal(const pm_placement *pl, vec3 n) {
    const float *m = pl->normal_matrix;
    return v3_normalize(v3(m[0] * n.x + m[1] * n.y + m[2] * n.z, m[3] * n.x + m[4] * n.y + m[5] * n.z,
                           m[6] * n.x + m[7] * n.y + m[8] * n.z));
}
/* Stored triangle `stored`'s corners in world space through placement pl (-1: flat), in stored order. */
static inline void pm_scene_stored_corners(const pm_scene *s, uint32_t stored, int32_t pl, vec3 p[3]) {
    const uint32_t *ix = s->indices + 3 * (size_t)stored;
    /* the test once, not per corner: the compiler otherwise computes the placement's transform
     * beside the plain copy and selects (60 instructions a call on a flat scene, a photon hit
     * making two calls) */
    if (pl < 0) {
        for (int k = 0; k < 3; k++) p[k] = s->positions[ix[k]];
        return;
    }
    const pm_placement *placement = &s->placements[pl];
    for (int k = 0; k < 3; k++) p[k] = pm_placement_point(placement, s->positions[ix[k]]);
}
/* The triangle's corners in world space, in stored order (barycentrics b1, b2 weigh corners 1, 2). */
static inline void pm_scene_triangle_corners(const pm_scene *s, uint32_t id, vec3 p[3]) {
    int32_t pl;
    uint32_t stored = pm_scene_stored_triangle(s, id, &pl);
    pm_scene_stored_corners(s, stored, pl, p);
}
/* Stored triangle `stored`'s unit face normal through placement pl (-1: flat); face_normals must exist. */
static inline vec3 pm_scene_stored_face_normal(const pm_scene *s, uint32_t stored, int32_t pl) {
    return pl < 0 ? s->face_normals[stored] : pm_placement_normal(&s->placements[pl], s->face_normals[stored]);
}
/* Unit geometric normal in world space, glTF front side (face_normals through the placement; computed
 * from the corners when face_normals is missing). */
static inline vec3 pm_scene_triangle_face_normal(const pm_scene *s, uint32_t id) {
    int32_t pl;
    uint32_t stored = pm_scene_stored_triangle(s, id, &pl);
    if (s->face_normals) return pm_scene_stored_face_normal(s, stored, pl);
    vec3 p[3];
    pm_scene_triangle_corners(s, id, p);
    /* a mirroring placement reverses the stored winding in world space */
    return v3_scale(v3_normalize(v3_cross(v3_sub(p[1], p[0]), v3_sub(p[2], p[0]))), pl < 0 ? 1.f : s->placements[pl].handedness);
}
/* Corner k's shading normal in world space, unit. */
static inline vec3 pm_scene_triangle_vertex_normal(const pm_scene *s, uint32_t id, int k) {
    int32_t pl;
    uint32_t v = s->indices[3 * (size_t)pm_scene_stored_triangle(s, id, &pl) + k];
    return pl < 0 ? s->normals[v] : pm_placement_normal(&s->placements[pl], s->normals[v]);
}

/* A walk over every triangle id in order (flat ones, then each placement's), with its stored
 * triangle and placement, without a search per id. Start with placement = -2. */
typedef struct {
    uint32_t id, stored, left; /* left: ids in the current run, this one included */
    int32_t placement;
} pm_triangle_walk;
static inline bool pm_scene_walk_next(const pm_scene *s, pm_triangle_walk *w) {
    if (w->placement == -2) {
        w->placement = -1;
        w->id = w->stored = 0;
        w->left = pm_scene_flat_triangles(s);
    } else {
        w->id++;
        w->stored++;
        w->left--;
    }
    while (w->left == 0) {
        if (w->placement + 1 >= (int32_t)s->placement_count) return false;
        const pm_placement *pl = &s->placements[++w->placement];
        w->id = pl->first_id;
        w->stored = s->instanced_meshes[pl->mesh].first_triangle;
        w->left = s->instanced_meshes[pl->mesh].triangle_count;
    }
    return true;
}
static inline void pm_scene_walk_corners(const pm_scene *s, const pm_triangle_walk *w, vec3 p[3]) {
    const uint32_t *ix = s->indices + 3 * (size_t)w->stored;
    for (int k = 0; k < 3; k++)
        p[k] = w->placement < 0 ? s->positions[ix[k]] : pm_placement_point(&s->placements[w->placement], s->positions[ix[k]]);
}

/* Surface description at a hit, what the integrators work with. */
typedef struct {
    vec3 p;          /* position (from barycentrics, not o + t d) */
    vec3 ng;         /* geometric normal, unit, glTF front side */
    vec3 ns;         /* shading normal, unit, same side as ng (normal-mapped: dot(ns, ng) >= PM_NORMAL_MAP_MIN_COS) */
    float u, v;      /* TEXCOORD_0 as stored (each texture applies its own set and transform) */
    uint32_t material;
    vec3 kd;         /* Lambert albedo (after the material split; 0 on a glossy surface, whose brdf holds its diffuse part) */
    vec3 ks;         /* perfect-mirror reflectance at normal incidence */
    float ks_grazing;/* the mirror's reflectance at grazing angles (Schlick: ks + (ks_grazing - ks)(1 - cos)^5) */
    float glass_alpha;/* GGX alpha of the glass's microfacets (roughness^2; 0: smooth, below PM_GLOSSY_MIN_ALPHA) */
    vec3 kt;         /* dielectric weight (tint); Fresnel decides reflect vs refract */
    float ior;
    bool thin;       /* the material is thin-walled: kt crosses straight, no medium inside */
    bool glossy;     /* the glossy lobe brdf replaces kd and ks (pm_material_glossy) */
    pm_brdf brdf;    /* valid when glossy */
    vec3 emission;   /* radiance leaving the front face (both faces if double sided) */
    bool double_sided;
    bool unlit;      /* emission is an unlit material's colour: counted only on the camera's own ray and specular
                        chain, never after a diffuse or glossy bounce (it lights nothing) */
    vec3 centroid;   /* of the triangle: origins are pulled toward it, off shared edges */
} pm_surface;

/* Origin for a ray leaving the surface on the side of side_normal (ng or -ng): offset along
 * the normal and, by the same few ulps, toward the triangle's interior, so that a hit on an
 * edge shared with a wall does not start the next ray inside that wall's plane. */
vec3 pm_surface_origin(const pm_surface *sf, vec3 side_normal, float scale);

/* pm_surface_origin from the point and its triangle's centroid alone, inline (the photon pass
 * starts a ray here at every bounce and emission). The pull toward the centroid must stay in the
 * triangle's plane: pm_offset_ray_origin's per-coordinate steps (ulps here, a scale step there)
 * would bend it off the plane by more than the normal offset, and a ray leaving glass would
 * start back inside. */
static inline vec3 pm_offset_surface_origin(vec3 p, vec3 centroid, vec3 side_normal, float scale) {
    vec3 inward = v3_sub(centroid, p);
    float m = pm_maxf(fabsf(p.x), pm_maxf(fabsf(p.y), fabsf(p.z)));
    uint32_t bits;
    memcpy(&bits, &m, 4);
    bits += 32; /* m + 32 ulps (m is finite and not negative) */
    float m32;
    memcpy(&m32, &bits, 4);
    float len = v3_length(inward), step = pm_minf(0.5f * len, pm_maxf(scale * (1.f / 65536.f), m32 - m));
    vec3 q = len > 0.f ? v3_madd(p, inward, step / len) : p;
    return pm_offset_ray_origin(q, side_normal, scale);
}

/* A normal-mapped shading normal keeps at least this cosine with the geometric normal: ns never
 * tilts to or past the surface's plane, so shading cannot light its back (see pm_scene_surface). */
#define PM_NORMAL_MAP_MIN_COS 0.05f

/* Fills a surface from a triangle id and Embree-style barycentrics (b1, b2); textures are read at
 * level 0 (bilinear), as pm_scene_surface_footprint with width 0. */
void pm_scene_surface(const pm_scene *s, uint32_t tri, float b1, float b2, pm_surface *out);
/* The same for a ray along unit dir whose cone is `width` wide (world units, across the ray) at
 * the hit: each texture is read at the mip level of that footprint on the surface (see
 * pm_texture_filtered). Width 0 is pm_scene_surface, bit for bit. Alpha is not filtered:
 * coverage (pm_scene_alpha_at) is always read at level 0. */
void pm_scene_surface_footprint(const pm_scene *s, uint32_t tri, float b1, float b2, float width, vec3 dir,
                                pm_surface *out);
/* The same without the emissive texture (emission is the material's factor alone): what
 * scattering reads, for the photon pass, which never reads emission at a hit. */
void pm_scene_surface_scattering(const pm_scene *s, uint32_t tri, float b1, float b2, pm_surface *out);

/* Prefetches of what a hit's surface record reads, for a tracer that knows its next hits before it
 * makes their records (the photon pass's waves). On a mesh far larger than the caches a record
 * otherwise waits on memory several times in a row: the triangle's row (its corners' indices, its
 * material, its face normal), then its corners' positions, normals and texture coordinates, which
 * need the indices first. Stage one asks for the row; stage two, some hits later when the indices
 * have arrived, for the corners. */
/* The bytes of the arrays a surface record reads (positions, normals, texture coordinates, the
 * triangles' indices, materials, face normals and altitudes): whether they stay cached, or prefetching pays. */
static inline uint64_t pm_scene_hit_data_bytes(const pm_scene *s) {
    uint64_t per_vertex = 2 * sizeof(vec3) + (s->uvs ? 2 * sizeof(float) : 0);
    uint64_t per_triangle = 3 * sizeof(uint32_t) + sizeof(uint32_t) + (s->face_normals ? sizeof(vec3) : 0) +
                            (s->edge_altitudes ? 3 * sizeof(float) : 0);
    return per_vertex * s->vertex_count + per_triangle * s->triangle_count;
}
static inline void pm_scene_prefetch_triangle(const pm_scene *s, uint32_t tri) {
    uint32_t stored = pm_scene_stored_triangle(s, tri, NULL);
    __builtin_prefetch(s->indices + 3 * (size_t)stored);
    __builtin_prefetch(s->triangle_material + stored);
    if (s->face_normals) __builtin_prefetch(s->face_normals + stored);
    if (s->edge_altitudes) __builtin_prefetch(s->edge_altitudes + 3 * (size_t)stored);
}
static inline void pm_scene_prefetch_corners(const pm_scene *s, uint32_t tri) {
    const uint32_t *ix = s->indices + 3 * (size_t)pm_scene_stored_triangle(s, tri, NULL);
    for (int k = 0; k < 3; k++) {
        __builtin_prefetch(s->positions + ix[k]);
        __builtin_prefetch(s->normals + ix[k]);
        if (s->uvs) __builtin_prefetch(s->uvs + 2 * (size_t)ix[k]);
    }
}

/* Stage three, when the corners have arrived: the level-0 texels that the record of a hit at (b1, b2)
 * reads (pm_scene_surface_scattering: base colour, metallic-roughness, transmission, normal map, the
 * layers' textures; nothing on a material without textures). On large textures each of those reads
 * is a miss of its own: a 2048 x 2048 texture is 16 MB, and photons land anywhere on it. */
void pm_scene_prefetch_texels(const pm_scene *s, uint32_t tri, float b1, float b2);
/* The bytes of the textures' level 0 (what photon records read): whether prefetching their texels pays. */
uint64_t pm_scene_texture_bytes(const pm_scene *s);

/* A triangle's altitudes: h[i] from corner i onto the edge across it (twice the area over that
 * edge's length); 0 where the triangle has no area. */
static inline void pm_triangle_altitudes(vec3 p0, vec3 p1, vec3 p2, float h[3]) {
    float twice_area = v3_length(v3_cross(v3_sub(p1, p0), v3_sub(p2, p0)));
    float edge[3] = {v3_length(v3_sub(p2, p1)), v3_length(v3_sub(p2, p0)), v3_length(v3_sub(p1, p0))};
    for (int i = 0; i < 3; i++) h[i] = edge[i] > 0.f ? twice_area / edge[i] : 0.f;
}

/* Stored triangle `stored`'s three altitudes in world space through placement pl (-1: flat): h[i]
 * from corner i onto the edge across it, so a point's distance to that edge is b_i h[i]; 0 for a
 * degenerate triangle. Flat triangles read them from edge_altitudes; placed ones (any linear map,
 * which changes altitudes unevenly) from their corners. */
static inline void pm_scene_stored_altitudes(const pm_scene *s, uint32_t stored, int32_t pl, float h[3]) {
    if (pl < 0 && s->edge_altitudes) {
        const float *a = s->edge_altitudes + 3 * (size_t)stored;
        h[0] = a[0];
        h[1] = a[1];
        h[2] = a[2];
        return;
    }
    vec3 p[3];
    pm_scene_stored_corners(s, stored, pl, p);
    pm_triangle_altitudes(p[0], p[1], p[2], h);
}

/* The geometric part of a surface record in two steps: the point, the unit face normal ng (given)
 * and the material, then the shading normal (interpolated, on ng's side, before any normal map)
 * and the centroid. pm_scene_surface makes both; the photon pass makes the second only for a
 * path that goes on from the hit; pm_scene_stored_surface_point takes a triangle already located
 * (pm_scene_stored_triangle). */
static inline void pm_scene_stored_surface_point(const pm_scene *s, uint32_t stored, int32_t pl, float b1, float b2, vec3 ng,
                                                 pm_surface *out) {
    float b0 = 1.f - b1 - b2;
    vec3 p[3];
    pm_scene_stored_corners(s, stored, pl, p);
    out->p = v3_add(v3_add(v3_scale(p[0], b0), v3_scale(p[1], b1)), v3_scale(p[2], b2));
    out->ng = ng;
    out->material = s->triangle_material[stored];
}
static inline void pm_scene_surface_point(const pm_scene *s, uint32_t tri, float b1, float b2, vec3 ng, pm_surface *out) {
    int32_t pl;
    uint32_t stored = pm_scene_stored_triangle(s, tri, &pl); /* one placement lookup for the corners and the material */
    pm_scene_stored_surface_point(s, stored, pl, b1, b2, ng, out);
}
static inline void pm_scene_surface_shading(const pm_scene *s, uint32_t tri, float b1, float b2, pm_surface *out) {
    int32_t pl;
    uint32_t stored = pm_scene_stored_triangle(s, tri, &pl);
    const uint32_t *ix = s->indices + 3 * (size_t)stored;
    float b0 = 1.f - b1 - b2;
    vec3 n0 = s->normals[ix[0]], n1 = s->normals[ix[1]], n2 = s->normals[ix[2]];
    if (pl >= 0) { /* each corner's normal through the placement, as the flattened copy stores it, then interpolated */
        const pm_placement *placement = &s->placements[pl];
        n0 = pm_placement_normal(placement, n0);
        n1 = pm_placement_normal(placement, n1);
        n2 = pm_placement_normal(placement, n2);
    }
    /* a flat triangle's corners share one unit normal (the loader gives it vertices of its own):
     * no interpolation, no root */
    bool flat = n0.x == n1.x && n0.y == n1.y && n0.z == n1.z && n0.x == n2.x && n0.y == n2.y && n0.z == n2.z;
    vec3 n = flat ? n0 : v3_normalize(v3_add(v3_add(v3_scale(n0, b0), v3_scale(n1, b1)), v3_scale(n2, b2)));
    /* Shading normals that disagree with the winding would light back faces: trust the winding. */
    out->ns = v3_dot(n, out->ng) < 0.f ? v3_neg(n) : n;
    /* Rays leave from the point pulled toward the centroid (pm_offset_surface_origin) only near
     * the triangle's edges, where a wall sharing the edge needs it: deep inside a large triangle
     * (a floor running on under a wall) the pull could carry the origin into a wall standing on
     * it, and the ray would start inside that wall. Near: closer to an edge than four of the
     * pull's steps. The distance to edge i is b_i x the altitude onto it. */
    float m = pm_maxf(fabsf(out->p.x), pm_maxf(fabsf(out->p.y), fabsf(out->p.z)));
    float near = 4.f * pm_maxf(s->ray_scale * (1.f / 65536.f), m * 4e-6f);
    float h[3];
    pm_scene_stored_altitudes(s, stored, pl, h);
    bool inside = b0 * h[0] > near && b1 * h[1] > near && b2 * h[2] > near;
    if (inside) {
        out->centroid = out->p;
        return;
    }
    vec3 corners[3];
    pm_scene_stored_corners(s, stored, pl, corners);
    out->centroid = v3_scale(v3_add(v3_add(corners[0], corners[1]), corners[2]), 1.f / 3.f);
}

/* The fields of pm_scene_surface that light transport reads (p, ng, ns, centroid, material, kd,
 * ks, kt, glossy, brdf, ior, thin; not u, v, emission, double_sided), with the same values, for a
 * tracer that often ends its path at the hit. For a material with a uniform split and no normal
 * map in effect they are the geometry and the material's constants: inline, no texture
 * coordinate, and ns and centroid are left to pm_scene_surface_shading (returns true: the
 * caller makes them before it reads them); any other material takes pm_scene_surface_scattering (false). */
/* The scattering of a material whose split is the same at every point (uniform_split), computed
 * once at load. */
static inline void pm_material_uniform_scattering(const pm_material *m, pm_surface *out) {
    out->kd = m->split_kd;
    out->ks = m->split_ks;
    out->ks_grazing = m->split_ks_grazing;
    out->glass_alpha = m->split_glass_alpha;
    out->kt = m->split_kt;
    out->glossy = m->split_glossy;
    if (out->glossy) out->brdf = m->split_brdf;
}

static inline bool pm_scene_surface_lean(const pm_scene *s, uint32_t tri, float b1, float b2, pm_surface *out) {
    int32_t pl;
    uint32_t stored = pm_scene_stored_triangle(s, tri, &pl); /* one lookup for the material, the normal and the point */
    const pm_material *m = &s->materials[s->triangle_material[stored]];
    bool normal_mapped = m->normal_texture >= 0 && (uint32_t)m->normal_texture < s->texture_count && s->tangents;
    if (!m->uniform_split || normal_mapped || !s->face_normals) {
        pm_scene_surface_scattering(s, tri, b1, b2, out);
        return false;
    }
    pm_scene_stored_surface_point(s, stored, pl, b1, b2, pm_scene_stored_face_normal(s, stored, pl), out);
    pm_material_uniform_scattering(m, out);
    out->ior = m->ior > 0.f ? m->ior : 1.5f;
    out->thin = m->thin_walled;
    out->unlit = false;
    return true;
}

static inline float pm_clamp01(float x) { return x < 0.f ? 0.f : (x > 1.f ? 1.f : x); }

/* Whether a point with these parameters has the GGX lobe (brdf.h): some opaque share (1 - t (1 - m)
 * > 0) and either a rough metal part (m > 0 and alpha = roughness^2 at least PM_GLOSSY_MIN_ALPHA)
 * or the dielectric's specular lobe (m < 1 and specular > 0: KHR_materials_specular's
 * specularFactor x its texture, 1 without the extension). Otherwise the point is Lambert, a
 * perfect mirror and glass (pm_material_split_at): a smooth metal, or a dielectric whose
 * specular lobe its file turns off (specularFactor 0). See docs/design.md, Materials. */
static inline bool pm_glossy_at(float metallic, float roughness, float transmission, float specular) {
    float m = pm_clamp01(metallic), r = pm_clamp01(roughness);
    if (!(1.f - pm_clamp01(transmission) * (1.f - m) > 0.f)) return false;
    return (m > 0.f && r * r >= PM_GLOSSY_MIN_ALPHA) || (m < 1.f && pm_clamp01(specular) > 0.f);
}
/* The same for a material's factors alone (no data texture), without a layer extension. */
static inline bool pm_material_glossy(const pm_material *m) {
    return pm_glossy_at(m->metallic, m->roughness, m->transmission, m->layered ? m->layers.specular : 1.f);
}

/* Splits a material at a point (its base colour, metallic, roughness, transmission and dielectric
 * specular weight there, textures applied) into kd, ks, kt; see docs/design.md (Materials).
 * Inline: it runs at every hit of every path. A glossy point has kd = ks = 0: its lobe
 * (pm_brdf_at) holds both its diffuse and its specular parts, and kt its glass share. The mirror
 * follows Schlick's Fresnel: ks at normal incidence, *ks_grazing (grey) at grazing angles
 * (pm_mirror_reflectance). */
static inline void pm_material_split_at(vec3 base, float metallic, float roughness, float transmission, float specular,
                                        vec3 *kd, vec3 *ks, float *ks_grazing, vec3 *kt) {
    base = v3(pm_clamp01(base.x), pm_clamp01(base.y), pm_clamp01(base.z));
    float metal = pm_clamp01(metallic), rough = pm_clamp01(roughness);
    float glass = pm_clamp01(transmission) * (1.f - metal);
    *kt = v3_scale(base, glass);
    if (pm_glossy_at(metal, rough, transmission, specular)) {
        *kd = *ks = v3s(0.f);
        *ks_grazing = 0.f;
        return;
    }
    /* The weights sum to one, so D + S = mean(base) <= 1 at normal incidence and at most 1 at any
     * angle: Russian roulette stays valid. Below PM_GLOSSY_MIN_ALPHA the rough share is tiny and
     * scatters diffusely. */
    float diffuse = (1.f - metal) * (1.f - pm_clamp01(transmission)) + metal * rough;
    float mirror = metal * (1.f - rough);
    *kd = v3_scale(base, diffuse);
    *ks = v3_scale(base, mirror);
    *ks_grazing = mirror;
}

/* The GGX alpha of a glass share of this roughness: rough transmission (Walter et al. 2007) from
 * PM_GLOSSY_MIN_ALPHA on, 0 (smooth) below. */
static inline float pm_glass_alpha_at(float roughness) {
    float r = pm_clamp01(roughness);
    return r * r >= PM_GLOSSY_MIN_ALPHA ? r * r : 0.f;
}

/* The glossy lobe at a point for which pm_glossy_at() holds. */
static inline pm_brdf pm_brdf_at(vec3 base, float metallic, float roughness, float transmission) {
    float metal = pm_clamp01(metallic), rough = pm_clamp01(roughness);
    pm_brdf b;
    b.base = v3(pm_clamp01(base.x), pm_clamp01(base.y), pm_clamp01(base.z));
    b.metallic = metal;
    b.alpha = pm_maxf(PM_GLOSSY_MIN_ALPHA, rough * rough);
    b.weight = 1.f - pm_clamp01(transmission) * (1.f - metal);
    b.layered = false;
    b.skip = 0; /* the whole lobe */
    return b;
}
/* The layers at a point (their textures applied) added to its lobe b. */
static inline void pm_brdf_add_layers(pm_brdf *b, float specular, vec3 specular_color, vec3 sheen_color,
                                      float sheen_roughness, float clearcoat, float clearcoat_roughness) {
    b->layered = true;
    b->specular = pm_clamp01(specular);
    vec3 c = v3_scale(specular_color, 0.04f);
    b->specular_f0 = v3(pm_clamp01(c.x), pm_clamp01(c.y), pm_clamp01(c.z));
    b->sheen_color = v3(pm_clamp01(sheen_color.x), pm_clamp01(sheen_color.y), pm_clamp01(sheen_color.z));
    b->sheen_roughness = pm_maxf(PM_SHEEN_MIN_ROUGHNESS, pm_clamp01(sheen_roughness));
    b->clearcoat = pm_clamp01(clearcoat);
    float r = pm_clamp01(clearcoat_roughness);
    b->clearcoat_alpha = pm_maxf(PM_GLOSSY_MIN_ALPHA, r * r);
    b->coat_normal = false;
}
/* The same with the material's factors alone. */
static inline pm_brdf pm_material_brdf(const pm_material *m, vec3 base) {
    return pm_brdf_at(base, m->metallic, m->roughness, m->transmission);
}
/* The split with the material's factors alone (no data texture). */
static inline void pm_material_split(const pm_material *m, vec3 base, vec3 *kd, vec3 *ks, vec3 *kt) {
    float grazing;
    pm_material_split_at(base, m->metallic, m->roughness, m->transmission, m->layered ? m->layers.specular : 1.f, kd, ks,
                         &grazing, kt);
}
/* Linear RGB of a texture at (u, v) with its wrap modes, bilinear (the texel under it with magFilter NEAREST). */
vec3 pm_texture_lookup(const pm_texture *t, float u, float v);
/* RGB at (u, v) over a footprint `texels` wide (in level-0 texels): level 0 under the magFilter up to a
 * footprint of one texel (there exactly pm_texture_lookup, or _data when !srgb), beyond it as the
 * minFilter says: by default trilinear between the two levels around log2(texels); NEAREST and
 * LINEAR level 0 alone; _MIPMAP_NEAREST the level nearest log2(texels); NEAREST_ the texel under (u, v). */
vec3 pm_texture_filtered(const pm_texture *t, float u, float v, float texels, bool srgb);
/* Builds t's mip levels (replacing any): colour (srgb) textures are averaged in linear light,
 * weighted by alpha so that cut-out texels do not bleed their colour into what stays, and
 * re-encoded to the nearest sRGB byte; data textures average their bytes. Alpha is averaged plainly.
 * The bytes are admitted (pm_memory_admit) and added to *admitted; false when refused or out
 * of memory (the failure recorded, t left with level 0 alone). */
bool pm_texture_build_levels(pm_texture *t, bool srgb, uint64_t *admitted);
/* The smallest and largest byte of each channel (R, G, B, A) over level 0, in one pass. */
void pm_texture_channel_bounds(const pm_texture *t, uint8_t lo[4], uint8_t hi[4]);
/* Asks for the level-0 texels pm_texture_lookup at (u, v) reads, without reading them. */
void pm_texture_prefetch(const pm_texture *t, float u, float v);
/* The alpha channel at (u, v), bilinear like pm_texture_lookup; alpha is stored linear (no sRGB). */
float pm_texture_alpha(const pm_texture *t, float u, float v);

/* Whether a material can let a ray through anywhere: MASK whose smallest possible alpha is below
 * the cutoff, or BLEND whose smallest possible alpha is below 1 (texture alpha scanned). */
bool pm_material_can_be_transparent(const pm_scene *s, const pm_material *m);
/* The same for a data texture (metallic-roughness, transmission): texels / 255, no sRGB decode. */
vec3 pm_texture_lookup_data(const pm_texture *t, float u, float v);

/* The coordinates a texture reference reads at barycentrics (b1, b2) of triangle tri: TEXCOORD
 * set `texcoord` (0 or 1; (0, 0) when the scene has no such set), then the transform. */
void pm_scene_texcoord(const pm_scene *s, uint32_t tri, float b1, float b2, int texcoord, const pm_uv_transform *t,
                       float *u, float *v);

/* Beer-Lambert for KHR_materials_volume: the fraction of light that survives a segment of length
 * t travelled along d that ends at surface sf from its back (inside a closed mesh whose faces
 * point out, the ray leaves the medium there); 1 for a segment that ends on a front face. */
static inline vec3 pm_volume_transmittance(const pm_scene *s, const pm_surface *sf, vec3 d, float t) {
    vec3 sigma = s->materials[sf->material].attenuation;
    if (v3_is_black(sigma) || v3_dot(sf->ng, d) <= 0.f) return v3s(1.f);
    return v3(expf(-sigma.x * t), expf(-sigma.y * t), expf(-sigma.z * t));
}

/* Radiance leaving triangle tri at barycentrics (b1, b2): the material's emission times its
 * emissive texture there (one side; the caller decides which faces emit). What a ray that hit
 * the triangle sees: it has passed the alpha test already. */
vec3 pm_scene_emission_at(const pm_scene *s, uint32_t tri, float b1, float b2);
/* What the triangle sends out at (b1, b2) on average: pm_scene_emission_at times its coverage
 * there (0 where a MASK material is cut out, alpha on BLEND, as every ray crossing it sees it).
 * For whatever picks points on an emitter by area (light samples, photon emission). */
vec3 pm_scene_emitted_at(const pm_scene *s, uint32_t tri, float b1, float b2);

/* Coverage of triangle tri at barycentrics (b1, b2): the material's alpha times its base colour
 * texture's alpha there (1 for an OPAQUE material). */
float pm_scene_alpha_at(const pm_scene *s, uint32_t tri, float b1, float b2);

/* ---- shared by the scene's finalisation (scene.c) and surface evaluation (surface.c) ---- */

/* The unit normal of triangle (p0, p1, p2) by the right-hand rule, computed in double. */
vec3 pm_face_normal(vec3 p0, vec3 p1, vec3 p2);
/* The share of triangle tri at (b1, b2) that a crossing ray meets: 1 when opaque, 0 or 1 by a
 * MASK's cutoff, alpha on BLEND (pm_scene_emitted_at's factor). */
float pm_scene_coverage_at(const pm_scene *s, uint32_t tri, float b1, float b2);
/* Whether a layered material reads a texture for its layers. */
bool pm_material_layers_textured(const pm_material *m);
/* A material's point from its base colour, metallic, roughness and transmission there: the layers'
 * values (their textures read at uv over footprint when s is not NULL), then the lobe split. */
void pm_material_point(const pm_material *m, vec3 base, float metallic, float roughness, float transmission,
                       const pm_scene *s, const float uv[2][2], const float footprint[2], vec3 *kd, vec3 *ks,
                       float *ks_grazing, vec3 *kt, bool *glossy, pm_brdf *brdf);

/* Picks a punctual light by power (uniformly when the distribution could not be allocated);
 * returns its index and the probability of that pick. The scene must have a light. */
uint32_t pm_scene_pick_light(const pm_scene *s, float u, float *pick_pdf);
/* Picks an emissive triangle by power; returns its position in s->emitters (and in
 * s->emitter_records) and the probability of that pick. */
static inline uint32_t pm_scene_pick_emitter_index(const pm_scene *s, float u, float *pick_pdf) {
    uint32_t lo = pm_cdf_interval_cut(s->emitter_cdf, s->emitter_cut, s->emitter_count, u);
    *pick_pdf = s->emitter_cdf[lo + 1] - s->emitter_cdf[lo];
    return lo;
}
float pm_triangle_area(const pm_scene *s, uint32_t tri);
/* The point of an emitter at barycentrics (b1, b2). */
static inline vec3 pm_emitter_point(const pm_emitter *r, float b1, float b2) {
    return pm_barycentric_point(r->p0, r->p1, r->p2, b1, b2);
}
/* What emitter number e (a position in s->emitters) sends out at barycentrics (b1, b2). */
static inline vec3 pm_emitter_emitted_at(const pm_scene *s, uint32_t e, float b1, float b2) {
    const pm_emitter *r = &s->emitter_records[e];
    return r->uniform_emission ? r->emission : pm_scene_emitted_at(s, s->emitters[e], b1, b2);
}
/* The probability that pm_scene_pick_emitter_index picks triangle tri (0 when it emits nothing). */
float pm_scene_emitter_pdf(const pm_scene *s, uint32_t tri);

#endif

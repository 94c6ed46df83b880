/* scene_builder.h: builds small pm_scenes directly in C for tests, independent of the glTF loader.
 *
 * Every helper appends to growable arrays; sb_finish() hands the scene to pm_scene_finalize.
 */
#ifndef PM_SCENE_BUILDER_H
#define PM_SCENE_BUILDER_H

#include <stdlib.h>
#include <string.h>
#include "accel.h"
#include "scene.h"
#include "testing.h"

static inline void *sb_grow(void *p, size_t count, size_t size) { return realloc(p, (count + 1) * size); }

/* A w x h texture of zero texels (level 0 only) with one wrap mode on both axes; the caller fills
 * and frees rgba. */
static inline pm_texture sb_texture(int w, int h, int wrap) {
    pm_texture t;
    memset(&t, 0, sizeof t);
    t.width = w;
    t.height = h;
    t.wrap_s = t.wrap_t = wrap;
    t.rgba = calloc(4 * (size_t)w * h, 1);
    if (!t.rgba) abort();
    return t;
}

static inline uint32_t sb_material(pm_scene *s, vec3 base, float metallic, float roughness, float transmission,
                                   vec3 emission, bool double_sided) {
    s->materials = sb_grow(s->materials, s->material_count, sizeof *s->materials);
    pm_material m;
    pm_material_set_default(&m);
    m.base_color = base;
    m.metallic = metallic;
    m.roughness = roughness;
    m.transmission = transmission;
    m.emission = emission;
    m.double_sided = double_sided;
    /* KHR_materials_specular specularFactor 0: the builder's metallic 0 materials mean Lambert
     * (and black lamps), as in the files that say so; sb_specular turns glTF's dielectric lobe on */
    m.layered = true;
    m.layers.specular = 0.f;
    m.layers.specular_color = v3s(1.f);
    m.layers.sheen_roughness = 0.f;
    m.layers.specular_texture.texture = m.layers.specular_color_texture.texture = m.layers.sheen_color_texture.texture = -1;
    m.layers.sheen_roughness_texture.texture = m.layers.clearcoat_texture.texture = -1;
    m.layers.clearcoat_roughness_texture.texture = m.layers.clearcoat_normal_texture.texture = -1;
    m.layers.clearcoat_normal_scale = 1.f;
    s->materials[s->material_count] = m;
    return s->material_count++;
}

/* glTF's dielectric specular lobe on material m: specularFactor `factor` (1 is glTF's default). */
static inline void sb_specular(pm_scene *s, uint32_t m, float factor) { s->materials[m].layers.specular = factor; }

static inline uint32_t sb_lambert(pm_scene *s, vec3 albedo) { return sb_material(s, albedo, 0, 1, 0, v3s(0), false); }

static inline void sb_triangle(pm_scene *s, vec3 a, vec3 b, vec3 c, uint32_t material) {
    vec3 n = v3_normalize(v3_cross(v3_sub(b, a), v3_sub(c, a)));
    vec3 p[3] = {a, b, c};
    for (int k = 0; k < 3; k++) {
        s->positions = sb_grow(s->positions, s->vertex_count, sizeof(vec3));
        s->normals = sb_grow(s->normals, s->vertex_count, sizeof(vec3));
        s->positions[s->vertex_count] = p[k];
        s->normals[s->vertex_count] = n;
        s->vertex_count++;
    }
    s->indices = realloc(s->indices, 3 * sizeof(uint32_t) * (s->triangle_count + 1));
    s->triangle_material = sb_grow(s->triangle_material, s->triangle_count, sizeof(uint32_t));
    for (int k = 0; k < 3; k++) s->indices[3 * s->triangle_count + k] = s->vertex_count - 3 + k;
    s->triangle_material[s->triangle_count++] = material;
}

/* Quad a,b,c,d counter-clockwise seen from its front. */
static inline void sb_quad(pm_scene *s, vec3 a, vec3 b, vec3 c, vec3 d, uint32_t material) {
    sb_triangle(s, a, b, c, material);
    sb_triangle(s, a, c, d, material);
}

/* A UV sphere of `segments` around and segments/2 rings, faces pointing out (flat normals). */
static inline void sb_sphere(pm_scene *s, vec3 center, float radius, int segments, uint32_t material) {
    int rings = segments / 2;
    for (int r = 0; r < rings; r++)
        for (int k = 0; k < segments; k++) {
            vec3 q[4];
            for (int c = 0; c < 4; c++) {
                float th = PM_PI * (float)(r + (c >> 1)) / rings, ph = 2.f * PM_PI * (float)(k + ((c ^ (c >> 1)) & 1)) / segments;
                q[c] = v3_add(center, v3_scale(v3(sinf(th) * cosf(ph), cosf(th), sinf(th) * sinf(ph)), radius));
            }
            /* q0 (r,k) q1 (r,k+1) q2 (r+1,k+1) q3 (r+1,k): counter-clockwise seen from outside is q0,q3,q2,q1 */
            if (r > 0) sb_triangle(s, q[0], q[2], q[1], material);
            if (r < rings - 1) sb_triangle(s, q[0], q[3], q[2], material);
        }
}

/* Axis-aligned box whose faces point inward (a room) when inward is true. */
static inline void sb_box(pm_scene *s, vec3 lo, vec3 hi, uint32_t material, bool inward) {
    vec3 c[8];
    for (int i = 0; i < 8; i++) c[i] = v3(i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z);
    static const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (int f = 0; f < 6; f++) {
        const int *q = faces[f];
        if (inward) sb_quad(s, c[q[3]], c[q[2]], c[q[1]], c[q[0]], material);
        else sb_quad(s, c[q[0]], c[q[1]], c[q[2]], c[q[3]], material);
    }
}

static inline void sb_point_light(pm_scene *s, vec3 position, vec3 intensity) {
    s->lights = sb_grow(s->lights, s->light_count, sizeof *s->lights);
    pm_light l;
    memset(&l, 0, sizeof l);
    l.type = PM_LIGHT_POINT;
    l.position = position;
    l.intensity = intensity;
    s->lights[s->light_count++] = l;
}

static inline pm_camera sb_camera(vec3 position, vec3 target, vec3 up_hint, float yfov_degrees) {
    pm_camera c;
    memset(&c, 0, sizeof c);
    c.position = position;
    c.forward = v3_normalize(v3_sub(target, position));
    c.right = v3_normalize(v3_cross(c.forward, up_hint));
    c.up = v3_cross(c.right, c.forward);
    c.yfov = yfov_degrees * PM_PI / 180.f;
    c.znear = 0.01f;
    return c;
}

/* Finalizes the scene (no default sky) and builds its accel, checking that it could. */
static inline pm_accel *sb_finish(pm_scene *s) {
    pm_scene_finalize(s, false, NULL);
    char err[256];
    pm_accel *a = pm_accel_create(s, err, sizeof err);
    CHECK(a != NULL, "accel: %s", err);
    return a;
}

/* A closed box of walls of albedo rho emitting le (radiance), the camera inside it looking into a
 * corner: a white furnace, whose every pixel converges to le / (1 - rho). */
static inline pm_accel *sb_furnace(pm_scene *s, float rho, float le, pm_camera *cam) {
    memset(s, 0, sizeof *s);
    uint32_t m = sb_material(s, v3s(rho), 0, 1, 0, v3s(le), false);
    sb_box(s, v3(-1, -1, -1), v3(1, 1, 1), m, true);
    *cam = sb_camera(v3(0, 0, 0.5f), v3(0.3f, -0.2f, -1), v3(0, 1, 0), 60.f);
    return sb_finish(s);
}

#endif

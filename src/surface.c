/* surface.c: a surface point evaluated: texture coordinates and footprints, the material's textures and layers there, normal maps, emission and coverage. */
#include "scene.h"
#include "defaults.h"

#include <math.h>

/* Interpolated TEXCOORD set (0 or 1) at barycentrics; (0, 0) when the scene lacks the set. */
static void interpolated_uv(const pm_scene *s, const uint32_t *ix, float b0, float b1, float b2, int set, float *u,
                            float *v) {
    const float *uv = set == 1 ? s->uvs1 : s->uvs;
    if (!uv) {
        *u = *v = 0.f;
        return;
    }
    *u = b0 * uv[2 * ix[0]] + b1 * uv[2 * ix[1]] + b2 * uv[2 * ix[2]];
    *v = b0 * uv[2 * ix[0] + 1] + b1 * uv[2 * ix[1] + 1] + b2 * uv[2 * ix[2] + 1];
}

static inline void apply_uv_transform(const pm_uv_transform *t, float *u, float *v) {
    if (!t->transformed) return;
    float x = *u, y = *v;
    *u = t->m[0] * x + t->m[1] * y + t->m[2];
    *v = t->m[3] * x + t->m[4] * y + t->m[5];
}

void pm_scene_texcoord(const pm_scene *s, uint32_t tri, float b1, float b2, int texcoord, const pm_uv_transform *t,
                       float *u, float *v) {
    interpolated_uv(s, s->indices + 3 * (size_t)pm_scene_stored_triangle(s, tri, NULL), 1.f - b1 - b2, b1, b2, texcoord, u, v);
    apply_uv_transform(t, u, v);
}

/* A texture reference's value at a point, from the point's interpolated TEXCOORD sets and the
 * footprint there in each set's UV units (0: level 0, bilinear). */
static vec3 texture_at(const pm_scene *s, const float uv[2][2], const float footprint[2], int texture, int texcoord,
                       const pm_uv_transform *t, bool srgb) {
    if ((uint32_t)texture >= s->texture_count) return v3s(1.f); /* a material filled by hand with 0, not -1 */
    float u = uv[texcoord == 1][0], v = uv[texcoord == 1][1];
    apply_uv_transform(t, &u, &v);
    const pm_texture *tex = &s->textures[texture];
    float f = footprint[texcoord == 1];
    if (f > 0.f) {
        /* the transform scales areas by its determinant, lengths by its root */
        if (t->transformed) f *= sqrtf(fabsf(t->m[0] * t->m[4] - t->m[1] * t->m[3]));
        return pm_texture_filtered(tex, u, v, f * sqrtf((float)tex->width * (float)tex->height), srgb);
    }
    return srgb ? pm_texture_lookup(tex, u, v) : pm_texture_lookup_data(tex, u, v);
}

/* Whether a layered material reads a texture for its layers. */
enum { LAYER_TEXTURES = 7 };
static void layer_texture_refs(const pm_material *m, const pm_texture_ref *refs[LAYER_TEXTURES]) {
    const pm_material_layers *l = &m->layers;
    refs[0] = &l->specular_texture;
    refs[1] = &l->specular_color_texture;
    refs[2] = &l->sheen_color_texture;
    refs[3] = &l->sheen_roughness_texture;
    refs[4] = &l->clearcoat_texture;
    refs[5] = &l->clearcoat_roughness_texture;
    refs[6] = &l->clearcoat_normal_texture;
}

bool pm_material_layers_textured(const pm_material *m) {
    if (!m->layered) return false;
    const pm_texture_ref *refs[LAYER_TEXTURES];
    layer_texture_refs(m, refs);
    for (int k = 0; k < LAYER_TEXTURES; k++)
        if (refs[k]->texture >= 0) return true;
    return false;
}

/* A layer texture's texel (rgb, or alpha in x for `alpha`), 1 without a texture or without the point's UVs (s NULL). */
static vec3 layer_texel(const pm_scene *s, const float uv[2][2], const float footprint[2], const pm_texture_ref *r, bool srgb,
                        bool alpha) {
    if (!s || r->texture < 0 || (uint32_t)r->texture >= s->texture_count) return v3s(1.f);
    if (!alpha) return texture_at(s, uv, footprint, r->texture, r->texcoord, &r->transform, srgb);
    float u = uv[r->texcoord == 1][0], v = uv[r->texcoord == 1][1];
    apply_uv_transform(&r->transform, &u, &v);
    return v3s(pm_texture_alpha(&s->textures[r->texture], u, v));
}

/* A material's point (its base colour, metallic, roughness and transmission there, textures
 * applied): the layers' values there (their textures read when s is not NULL), then the split. A
 * point with a coat or a sheen is all the layered lobe (kt apart: kd = ks = 0); one without them
 * is glossy or not as pm_glossy_at says, with the dielectric's specular weight there, so a point
 * whose file turns that lobe off (specularFactor 0) is the plain Lambert, mirror and glass split. */
void pm_material_point(const pm_material *m, vec3 base, float metallic, float roughness, float transmission,
                       const pm_scene *s, const float uv[2][2], const float footprint[2], vec3 *kd, vec3 *ks,
                       float *ks_grazing, vec3 *kt, bool *glossy, pm_brdf *brdf) {
    if (!m->layered) {
        pm_material_split_at(base, metallic, roughness, transmission, 1.f, kd, ks, ks_grazing, kt);
        *glossy = pm_glossy_at(metallic, roughness, transmission, 1.f);
        if (*glossy) *brdf = pm_brdf_at(base, metallic, roughness, transmission);
        return;
    }
    const pm_material_layers *l = &m->layers;
    float specular = l->specular * layer_texel(s, uv, footprint, &l->specular_texture, false, true).x;
    pm_material_split_at(base, metallic, roughness, transmission, specular, kd, ks, ks_grazing, kt);
    vec3 sheen_color = v3_mul(l->sheen_color, layer_texel(s, uv, footprint, &l->sheen_color_texture, true, false));
    float clearcoat = l->clearcoat * layer_texel(s, uv, footprint, &l->clearcoat_texture, false, false).x;
    *glossy = pm_glossy_at(metallic, roughness, transmission, specular) || clearcoat > 0.f || v3_max_component(sheen_color) > 0.f;
    if (!*glossy) return;
    *kd = *ks = v3s(0.f);
    *ks_grazing = 0.f;
    *brdf = pm_brdf_at(base, metallic, roughness, transmission);
    vec3 specular_color = v3_mul(l->specular_color, layer_texel(s, uv, footprint, &l->specular_color_texture, true, false));
    float sheen_roughness = l->sheen_roughness * layer_texel(s, uv, footprint, &l->sheen_roughness_texture, false, true).x;
    float clearcoat_roughness =
        l->clearcoat_roughness * layer_texel(s, uv, footprint, &l->clearcoat_roughness_texture, false, false).y;
    pm_brdf_add_layers(brdf, specular, specular_color, sheen_color, sheen_roughness, clearcoat, clearcoat_roughness);
}

/* The share of triangle tri at (b1, b2) that a crossing ray meets: 1 when opaque, 0 or 1 by a
 * MASK's cutoff, alpha on BLEND (pm_scene_emitted_at's factor). */
float pm_scene_coverage_at(const pm_scene *s, uint32_t tri, float b1, float b2) {
    const pm_material *m = &s->materials[pm_scene_triangle_material(s, tri)];
    if (m->alpha_mode == PM_ALPHA_OPAQUE) return 1.f;
    float alpha = pm_scene_alpha_at(s, tri, b1, b2);
    return m->alpha_mode == PM_ALPHA_MASK ? (alpha >= m->alpha_cutoff ? 1.f : 0.f) : pm_clamp01(alpha);
}

bool pm_material_can_be_transparent(const pm_scene *s, const pm_material *m) {
    if (m->alpha_mode == PM_ALPHA_OPAQUE) return false;
    /* bilinear filtering never goes below the smallest texel (and coverage is never read from a mip level) */
    uint8_t least = 255;
    if (m->base_color_texture >= 0 && (uint32_t)m->base_color_texture < s->texture_count) {
        const pm_texture *t = &s->textures[m->base_color_texture];
        size_t n = t->rgba ? (size_t)t->width * (size_t)t->height : 0;
        for (size_t i = 0; i < n && least > 0; i++)
            if (t->rgba[4 * i + 3] < least) least = t->rgba[4 * i + 3];
    }
    float smallest = m->alpha * (least / 255.f);
    return m->alpha_mode == PM_ALPHA_MASK ? smallest < m->alpha_cutoff : smallest < 1.f;
}

/* A normal texel's (x, y), a slope along the texture's own axes (image right = +u', up = -v'), as the
 * same slope along the tangent frame's (+u, -v) when KHR_texture_transform maps (u, v) to (u', v') by
 * A = [m0 m1; m3 m4]. Slopes are gradients, which the chain rule carries by the transpose of the
 * map: in the (u, -v) axes that is F A^T F with F = diag(1, -1). Dividing by sqrt|det A| keeps a
 * uniform scale (tiling) from changing how steep the bumps are, so what is left is the inverse
 * of the UV rotation, with a mirror for a negative scale. */
static inline void texture_slope_to_surface(const pm_uv_transform *t, float *x, float *y) {
    float det = fabsf(t->m[0] * t->m[4] - t->m[1] * t->m[3]);
    if (!(det > 0.f) || !isfinite(det)) return;
    float k = 1.f / sqrtf(det), tx = *x, ty = *y;
    *x = k * (t->m[0] * tx - t->m[3] * ty);
    *y = k * (-t->m[1] * tx + t->m[4] * ty);
}

/* The shading normal a normal map gives at barycentrics (b0, b1, b2) of the triangle with
 * corners ix: the texel (linear, [0,1] -> [-1,1], x and y times the scale) in the frame of the
 * interpolated tangent T (orthogonalised against n), B = w cross(n, T) and n, the interpolated
 * normal already on ng's side.
 *
 * Guard against light leaks: the result is pulled back toward ng until dot(ns, ng) >=
 * PM_NORMAL_MAP_MIN_COS (keeping its azimuth around ng), so a steep texel never turns the
 * shading hemisphere under the surface. Energy: every integrator scatters about ns but drops
 * directions below the geometric plane (eye.c direct_light's shadow, emitter, sky and surface
 * rays, sample_reflection for gather rays and the visible point's gather, photonmap.c's diffuse
 * and glossy bounces), Lambert's sample weight is kd whatever ns is, and the glossy lobe (brdf.c)
 * is evaluated and sampled about ns with an albedo of at most 1 and is zero when wo or wi is
 * below ns: dropping directions only loses energy, so a normal map can darken but never
 * brighten a furnace (tests/test_normalmap.c). */
static vec3 normal_mapped(const pm_scene *s, int texture, int texcoord, const pm_uv_transform *transform, float scale,
                          const uint32_t *ix, const pm_placement *placement, const float b[3], const float uv[2][2],
                          const float footprint[2], vec3 n, vec3 ng) {
    vec3 t = v3s(0.f);
    float w = 0.f;
    for (int k = 0; k < 3; k++) {
        const float *tk = s->tangents + 4 * (size_t)ix[k];
        vec3 corner = v3(tk[0], tk[1], tk[2]);
        /* a tangent is a direction, each corner's placed and made unit as the flattened copy stores it */
        if (placement) corner = v3_normalize(pm_placement_direction(placement, corner));
        t = v3_madd(t, corner, b[k]);
        w += tk[3] * b[k];
    }
    if (placement) w *= placement->handedness; /* a mirror flips the bitangent, as in the loader */
    t = v3_sub(t, v3_scale(n, v3_dot(t, n)));
    float len = v3_length(t);
    vec3 bt;
    if (len > 1e-6f && isfinite(len)) {
        t = v3_scale(t, 1.f / len);
        bt = v3_scale(v3_cross(n, t), w < 0.f ? -1.f : 1.f);
    } else {
        v3_basis(n, &t, &bt); /* no usable tangent here: any frame around n */
    }
    vec3 c = texture_at(s, uv, footprint, texture, texcoord, transform, false);
    float x = (2.f * c.x - 1.f) * scale, y = (2.f * c.y - 1.f) * scale, z = 2.f * c.z - 1.f;
    if (transform->transformed) texture_slope_to_surface(transform, &x, &y);
    vec3 p = v3_add(v3_add(v3_scale(t, x), v3_scale(bt, y)), v3_scale(n, z));
    float plen = v3_length(p);
    if (!(plen > 0.f) || !isfinite(plen)) return n;
    p = v3_scale(p, 1.f / plen);
    float cos_g = v3_dot(p, ng);
    if (cos_g >= PM_NORMAL_MAP_MIN_COS) return p;
    vec3 side = v3_sub(p, v3_scale(ng, cos_g));
    float side_len = v3_length(side);
    if (!(side_len > 1e-6f)) return ng;
    const float c_min = PM_NORMAL_MAP_MIN_COS, s_min = sqrtf(1.f - PM_NORMAL_MAP_MIN_COS * PM_NORMAL_MAP_MIN_COS);
    return v3_add(v3_scale(ng, c_min), v3_scale(side, s_min / side_len));
}

/* pm_scene_surface_scattering for a ray along dir with a cone `width` wide at the hit; the
 * footprint in each TEXCOORD set's UV units goes to footprint[] (both 0 for width 0). */
static void surface_scattering(const pm_scene *s, uint32_t tri, float b1, float b2, float width, vec3 dir,
                               pm_surface *out, float footprint[2]) {
    int32_t placement;
    uint32_t stored = pm_scene_stored_triangle(s, tri, &placement);
    const uint32_t *ix = s->indices + 3 * (size_t)stored;
    float b0 = 1.f - b1 - b2;
    vec3 ng = s->face_normals || placement >= 0 ? pm_scene_triangle_face_normal(s, tri)
                                                : pm_face_normal(s->positions[ix[0]], s->positions[ix[1]], s->positions[ix[2]]);
    pm_scene_surface_point(s, tri, b1, b2, ng, out);
    pm_scene_surface_shading(s, tri, b1, b2, out);
    const pm_material *m = &s->materials[out->material];
    /* texture coordinates only for a textured material: every photon bounce comes through here */
    float uv[2][2] = {{0.f, 0.f}, {0.f, 0.f}};
    footprint[0] = footprint[1] = 0.f;
    if (m->base_color_texture >= 0 || m->metallic_roughness_texture >= 0 || m->transmission_texture >= 0 ||
        m->normal_texture >= 0 || m->emission_texture >= 0 || pm_material_layers_textured(m)) {
        interpolated_uv(s, ix, b0, b1, b2, 0, &uv[0][0], &uv[0][1]);
        if (s->uvs1) interpolated_uv(s, ix, b0, b1, b2, 1, &uv[1][0], &uv[1][1]);
        if (width > 0.f && s->uv_density) {
            /* the cone's cross-section on the surface: an ellipse 1/cos longer one way, taken as
             * the circle of the same area */
            float on_surface = width / sqrtf(pm_maxf(fabsf(v3_dot(ng, dir)), PM_FOOTPRINT_MIN_COS));
            if (placement >= 0) { /* the density is per mesh-space area: scale the footprint back to mesh space */
                vec3 p0 = s->positions[ix[0]], p1 = s->positions[ix[1]], p2 = s->positions[ix[2]], w[3];
                pm_scene_stored_corners(s, stored, placement, w);
                float mesh_area = v3_length(v3_cross(v3_sub(p1, p0), v3_sub(p2, p0)));
                float world_area = v3_length(v3_cross(v3_sub(w[1], w[0]), v3_sub(w[2], w[0])));
                if (world_area > 0.f) on_surface *= sqrtf(mesh_area / world_area);
            }
            footprint[0] = on_surface * s->uv_density[2 * (size_t)stored];
            footprint[1] = on_surface * s->uv_density[2 * (size_t)stored + 1];
        }
    }
    out->u = uv[0][0];
    out->v = uv[0][1];
    vec3 interpolated = out->ns; /* the coat's normal map bends the interpolated normal, not the base's map */
    if (m->normal_texture >= 0 && (uint32_t)m->normal_texture < s->texture_count && s->tangents) {
        const float b[3] = {b0, b1, b2};
        out->ns = normal_mapped(s, m->normal_texture, m->normal_texcoord, &m->normal_transform, m->normal_scale, ix,
                                placement >= 0 ? &s->placements[placement] : NULL, b, uv, footprint, out->ns, out->ng);
    }
    if (m->uniform_split) {
        pm_material_uniform_scattering(m, out);
    } else {
        vec3 base = m->base_color;
        if (m->base_color_texture >= 0)
            base = v3_mul(base, texture_at(s, uv, footprint, m->base_color_texture, m->base_color_texcoord, &m->base_color_transform, true));
        float metallic = m->metallic, roughness = m->roughness, transmission = m->transmission;
        if (m->metallic_roughness_texture >= 0) {
            vec3 mr = texture_at(s, uv, footprint, m->metallic_roughness_texture, m->metallic_roughness_texcoord,
                                 &m->metallic_roughness_transform, false);
            roughness *= mr.y;
            metallic *= mr.z;
        }
        if (m->transmission_texture >= 0 && transmission > 0.f)
            transmission *= texture_at(s, uv, footprint, m->transmission_texture, m->transmission_texcoord, &m->transmission_transform,
                                       false).x;
        pm_material_point(m, base, metallic, roughness, transmission, s, uv, footprint, &out->kd, &out->ks, &out->ks_grazing,
                       &out->kt, &out->glossy, &out->brdf);
        out->glass_alpha = pm_glass_alpha_at(roughness);
    }
    const pm_texture_ref *coat_map = &m->layers.clearcoat_normal_texture;
    if (out->glossy && out->brdf.layered && out->brdf.clearcoat > 0.f && pm_material_coat_normal_mapped(m) &&
        (uint32_t)coat_map->texture < s->texture_count && s->tangents) {
        const float b[3] = {b0, b1, b2};
        out->brdf.coat_n = normal_mapped(s, coat_map->texture, coat_map->texcoord, &coat_map->transform, m->layers.clearcoat_normal_scale,
                                         ix, placement >= 0 ? &s->placements[placement] : NULL, b, uv, footprint, interpolated,
                                         out->ng);
        out->brdf.coat_normal = true;
    }
    out->ior = m->ior > 0.f ? m->ior : 1.5f;
    out->thin = m->thin_walled;
    out->emission = m->emission; /* the factor alone: pm_scene_surface applies the texture */
    out->double_sided = m->double_sided;
    out->unlit = false;
}

static void prefetch_texture(const pm_scene *s, const float uv[2][2], int texture, int texcoord, const pm_uv_transform *t) {
    if (texture < 0 || (uint32_t)texture >= s->texture_count) return;
    float u = uv[texcoord == 1][0], v = uv[texcoord == 1][1];
    apply_uv_transform(t, &u, &v);
    pm_texture_prefetch(&s->textures[texture], u, v);
}

void pm_scene_prefetch_texels(const pm_scene *s, uint32_t tri, float b1, float b2) {
    uint32_t stored = pm_scene_stored_triangle(s, tri, NULL);
    const pm_material *m = &s->materials[s->triangle_material[stored]];
    bool normal_mapped = m->normal_texture >= 0 && s->tangents;
    if (m->uniform_split && !normal_mapped) return; /* no texture read (a coat's normal map only comes with layer textures) */
    const uint32_t *ix = s->indices + 3 * (size_t)stored;
    float b0 = 1.f - b1 - b2, uv[2][2] = {{0.f, 0.f}, {0.f, 0.f}};
    interpolated_uv(s, ix, b0, b1, b2, 0, &uv[0][0], &uv[0][1]);
    if (s->uvs1) interpolated_uv(s, ix, b0, b1, b2, 1, &uv[1][0], &uv[1][1]);
    if (normal_mapped) prefetch_texture(s, uv, m->normal_texture, m->normal_texcoord, &m->normal_transform);
    if (m->uniform_split) return;
    prefetch_texture(s, uv, m->base_color_texture, m->base_color_texcoord, &m->base_color_transform);
    prefetch_texture(s, uv, m->metallic_roughness_texture, m->metallic_roughness_texcoord, &m->metallic_roughness_transform);
    if (m->transmission > 0.f) prefetch_texture(s, uv, m->transmission_texture, m->transmission_texcoord, &m->transmission_transform);
    if (!m->layered) return;
    const pm_texture_ref *refs[LAYER_TEXTURES];
    layer_texture_refs(m, refs);
    for (int k = 0; k < LAYER_TEXTURES; k++) prefetch_texture(s, uv, refs[k]->texture, refs[k]->texcoord, &refs[k]->transform);
}

uint64_t pm_scene_texture_bytes(const pm_scene *s) {
    uint64_t bytes = 0;
    for (uint32_t i = 0; i < s->texture_count; i++)
        if (s->textures[i].rgba) bytes += 4 * (uint64_t)s->textures[i].width * (uint64_t)s->textures[i].height;
    return bytes;
}

void pm_scene_surface_scattering(const pm_scene *s, uint32_t tri, float b1, float b2, pm_surface *out) {
    float footprint[2];
    surface_scattering(s, tri, b1, b2, 0.f, v3s(0.f), out, footprint);
}

void pm_scene_surface_footprint(const pm_scene *s, uint32_t tri, float b1, float b2, float width, vec3 dir,
                                pm_surface *out) {
    float footprint[2];
    surface_scattering(s, tri, b1, b2, width, dir, out, footprint);
    const pm_material *m = &s->materials[out->material];
    /* the second UV set, for a texture of emission or of an unlit colour that reads it */
    const uint32_t *ix = s->indices + 3 * (size_t)pm_scene_stored_triangle(s, tri, NULL);
    if (m->emission_texture >= 0 && !v3_is_black(m->emission)) {
        float uv[2][2] = {{out->u, out->v}, {0.f, 0.f}};
        if (s->uvs1) interpolated_uv(s, ix, 1.f - b1 - b2, b1, b2, 1, &uv[1][0], &uv[1][1]);
        out->emission = v3_mul(m->emission, texture_at(s, uv, footprint, m->emission_texture, m->emission_texcoord,
                                                       &m->emission_transform, true));
    }
    if (m->unlit) {
        vec3 base = m->base_color;
        if (m->base_color_texture >= 0) {
            float uv[2][2] = {{out->u, out->v}, {0.f, 0.f}};
            if (s->uvs1) interpolated_uv(s, ix, 1.f - b1 - b2, b1, b2, 1, &uv[1][0], &uv[1][1]);
            base = v3_mul(base, texture_at(s, uv, footprint, m->base_color_texture, m->base_color_texcoord, &m->base_color_transform, true));
        }
        out->emission = base;
        out->unlit = true;
    }
}

void pm_scene_surface(const pm_scene *s, uint32_t tri, float b1, float b2, pm_surface *out) {
    pm_scene_surface_footprint(s, tri, b1, b2, 0.f, v3s(0.f), out);
}

vec3 pm_surface_origin(const pm_surface *sf, vec3 side_normal, float scale) {
    return pm_offset_surface_origin(sf->p, sf->centroid, side_normal, scale);
}

vec3 pm_scene_emission_at(const pm_scene *s, uint32_t tri, float b1, float b2) {
    const pm_material *m = &s->materials[pm_scene_triangle_material(s, tri)];
    if (m->emission_texture < 0 || v3_is_black(m->emission)) return m->emission;
    float u, v;
    pm_scene_texcoord(s, tri, b1, b2, m->emission_texcoord, &m->emission_transform, &u, &v);
    return v3_mul(m->emission, pm_texture_lookup(&s->textures[m->emission_texture], u, v));
}

vec3 pm_scene_emitted_at(const pm_scene *s, uint32_t tri, float b1, float b2) {
    vec3 e = pm_scene_emission_at(s, tri, b1, b2);
    return v3_is_black(e) ? e : v3_scale(e, pm_scene_coverage_at(s, tri, b1, b2));
}

float pm_scene_alpha_at(const pm_scene *s, uint32_t tri, float b1, float b2) {
    const pm_material *m = &s->materials[pm_scene_triangle_material(s, tri)];
    if (m->alpha_mode == PM_ALPHA_OPAQUE) return 1.f;
    if (m->base_color_texture < 0 || (uint32_t)m->base_color_texture >= s->texture_count) return m->alpha;
    float u, v; /* the base colour texture's own set and transform, as pm_scene_surface reads it */
    pm_scene_texcoord(s, tri, b1, b2, m->base_color_texcoord, &m->base_color_transform, &u, &v);
    return m->alpha * pm_texture_alpha(&s->textures[m->base_color_texture], u, v);
}

/* scene.c: derived scene data (bounds, emitter distribution, default sky, analysis); surfaces are evaluated in surface.c, textures read in texture.c.
 *
 * Everything here is computed from what the loader filled in, once, before any ray is cast;
 * the analysis decides which maps, passes and buffers the later stages build at all.
 */
#include "scene.h"
#include "light.h"
#include "vertex.h"
#include "memory.h"
#include "parallel.h"
#include "defaults.h"

#include <assert.h>
#include <float.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

const char *const pm_component_names[PM_COMPONENT_COUNT] = {"direct", "specular", "caustic", "indirect"};

float pm_triangle_area(const pm_scene *s, uint32_t tri) {
    vec3 p[3];
    pm_scene_triangle_corners(s, tri, p);
    return 0.5f * v3_length(v3_cross(v3_sub(p[1], p[0]), v3_sub(p[2], p[0])));
}

/* Whether every diffuse triangle lies in one plane: then light reflected diffusely once can never
 * reach a diffuse surface again (without a mirror or glass to send it back), and no map, pass or
 * buffer for indirect light is needed. Judged in double precision, relative to the scene's size. */
static bool diffuse_coplanar(const pm_scene *s) {
    bool have_plane = false;
    double n[3] = {0, 0, 0}, d = 0.0, tolerance = 1e-6 * (double)s->ray_scale;
    for (pm_triangle_walk w = {.placement = -2}; pm_scene_walk_next(s, &w);) {
        const pm_material *m = &s->materials[s->triangle_material[w.stored]];
        if (!m->may_diffuse && !m->may_glossy) continue;
        vec3 p[3];
        pm_scene_walk_corners(s, &w, p);
        if (!have_plane) {
            double e1[3] = {p[1].x - p[0].x, p[1].y - p[0].y, p[1].z - p[0].z};
            double e2[3] = {p[2].x - p[0].x, p[2].y - p[0].y, p[2].z - p[0].z};
            n[0] = e1[1] * e2[2] - e1[2] * e2[1];
            n[1] = e1[2] * e2[0] - e1[0] * e2[2];
            n[2] = e1[0] * e2[1] - e1[1] * e2[0];
            double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            if (!(len > 0.0)) continue;
            for (int k = 0; k < 3; k++) n[k] /= len;
            d = n[0] * p[0].x + n[1] * p[0].y + n[2] * p[0].z;
            have_plane = true;
        }
        for (int k = 0; k < 3; k++)
            if (fabs(n[0] * p[k].x + n[1] * p[k].y + n[2] * p[k].z - d) > tolerance) return false;
    }
    return true;
}

/* Per texture, the smallest and largest byte of each channel, read the first time a material's
 * lobe bounds ask: an atlas that many materials share is read once, not once per material and
 * channel. */
typedef struct { uint8_t lo[4], hi[4]; bool known; } channel_bounds;

/* The smallest and largest value of one channel over a texture's texels, as a fraction of 255
 * (neither bilinear filtering nor the mip levels' averages can leave this range); [1, 1] without a
 * texture, whose factor stands alone. */
static void channel_range(const pm_scene *s, channel_bounds *bounds, int texture, int channel, float *lo, float *hi) {
    *lo = *hi = 1.f;
    if (texture < 0 || (uint32_t)texture >= s->texture_count || !s->textures[texture].rgba) return;
    channel_bounds *b = &bounds[texture];
    if (!b->known) pm_texture_channel_bounds(&s->textures[texture], b->lo, b->hi);
    b->known = true;
    *lo = b->lo[channel] / 255.f;
    *hi = b->hi[channel] / 255.f;
}

/* Which lobes a material can have somewhere. Each lobe weight is linear in metallic, roughness
 * and transmission separately, so its largest value over the box of their possible values is
 * at one of the box's eight corners; the dielectric's specular weight (a factor times a
 * texture's alpha) adds a fourth axis, and a coat or a sheen makes every point glossy. */
static void material_lobes(const pm_scene *s, channel_bounds *bounds, pm_material *m) {
    float lo[4], hi[4];
    channel_range(s, bounds, m->metallic_roughness_texture, 2, &lo[0], &hi[0]);
    channel_range(s, bounds, m->metallic_roughness_texture, 1, &lo[1], &hi[1]);
    channel_range(s, bounds, m->transmission_texture, 0, &lo[2], &hi[2]);
    lo[3] = hi[3] = 1.f;
    if (m->layered) channel_range(s, bounds, m->layers.specular_texture.texture, 3, &lo[3], &hi[3]);
    const pm_material_layers *l = &m->layers;
    const float factor[4] = {m->metallic, m->roughness, m->transmission, m->layered ? l->specular : 1.f};
    bool layer_lobe = m->layered && (l->clearcoat > 0.f || v3_max_component(l->sheen_color) > 0.f);
    m->may_diffuse = m->may_mirror = m->may_glass = m->may_glossy = m->may_near_specular = false;
    /* the coat's smallest roughness: its factor's, or 0 under a texture that may darken it */
    float coat_roughness = m->layered && l->clearcoat_roughness_texture.texture < 0 ? l->clearcoat_roughness : 0.f;
    for (int corner = 0; corner < 16; corner++) {
        float x[4];
        for (int k = 0; k < 4; k++) x[k] = factor[k] * ((corner >> k & 1) ? hi[k] : lo[k]);
        vec3 kd, ks, kt;
        float grazing;
        pm_material_split_at(m->base_color, x[0], x[1], x[2], x[3], &kd, &ks, &grazing, &kt);
        bool glossy = layer_lobe || pm_glossy_at(x[0], x[1], x[2], x[3]);
        m->may_glossy |= glossy;
        if (glossy) {
            /* a lobe part sharp enough that paths go on through it (the vertex kernel's rule) */
            pm_brdf b = pm_brdf_at(m->base_color, x[0], x[1], x[2]);
            if (m->layered) pm_brdf_add_layers(&b, x[3], l->specular_color, l->sheen_color, l->sheen_roughness, l->clearcoat, coat_roughness);
            m->may_near_specular |= (pm_brdf_parts(&b) & pm_vertex_near_specular_parts(&b)) != 0;
        }
        if (!glossy) {
            m->may_diffuse |= !v3_is_black(kd);
            m->may_mirror |= !v3_is_black(ks);
        }
        m->may_glass |= !v3_is_black(kt);
    }
    m->may_see_through = pm_material_can_be_transparent(s, m);
    m->uniform_split = m->base_color_texture < 0 && m->metallic_roughness_texture < 0 && m->transmission_texture < 0 &&
                       !pm_material_layers_textured(m);
    if (m->unlit) {
        /* no lobe at all, wherever its base colour texture goes */
        m->may_diffuse = m->may_mirror = m->may_glass = m->may_glossy = m->may_near_specular = m->split_glossy = false;
        m->uniform_split = true;
        m->split_kd = m->split_ks = m->split_kt = v3s(0.f);
        m->split_ks_grazing = 0.f;
        m->split_glass_alpha = 0.f;
    } else if (m->uniform_split) {
        pm_material_point(m, m->base_color, m->metallic, m->roughness, m->transmission, NULL, NULL, NULL, &m->split_kd,
                       &m->split_ks, &m->split_ks_grazing, &m->split_kt, &m->split_glossy, &m->split_brdf);
        m->split_glass_alpha = pm_glass_alpha_at(m->roughness);
    }
}

/* The unit normal of triangle (p0, p1, p2) by the right-hand rule, computed in double: a float
 * cross product of edges underflows for tiny triangles and overflows for huge ones. */
vec3 pm_face_normal(vec3 p0, vec3 p1, vec3 p2) {
    double e1[3] = {(double)p1.x - p0.x, (double)p1.y - p0.y, (double)p1.z - p0.z};
    double e2[3] = {(double)p2.x - p0.x, (double)p2.y - p0.y, (double)p2.z - p0.z};
    double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    double scale = fmax(fabs(n[0]), fmax(fabs(n[1]), fabs(n[2])));
    if (!(scale > 0.0) || !isfinite(scale)) return v3(0.f, 0.f, 1.f);
    for (int k = 0; k < 3; k++) n[k] /= scale; /* the largest is 1 now: no overflow in the length */
    double len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    return v3((float)(n[0] / len), (float)(n[1] / len), (float)(n[2] / len));
}

static bool receives_light(const pm_material *m, const void *context) {
    (void)context;
    return m->may_diffuse || m->may_glossy;
}


/* The brightest radiance any light sends (a sky map's brightest texel, an emitting triangle's
 * radiance) over the mean radiance the scene's light arrives with: the sky's mean plus the
 * emitters' power (emitter_power, the light distribution's) spread over the surfaces that receive
 * it, power over pi x the receiving area. Luminance, as that power weighs it (the map's peak is
 * its own channels' mean over theirs). A textured emitter counts its material's factor as its
 * peak: a texel reads at most 1, and a small bright spot in a dark texture must not pass for a
 * broad light by its triangle's mean. Infinite where nothing receives. */
static double light_peak_over_mean(const pm_scene *s, double receiving) {
    double peak = 0.0, mean = 0.0;
    if (s->sky) {
        mean = v3_luminance(pm_scene_sky_mean(s));
        peak = mean * (s->sky_map ? s->sky_map->peak_over_mean : 1.0);
    }
    for (uint32_t i = 0; i < s->emitter_count; i++) {
        const pm_material *m = &s->materials[pm_scene_triangle_material(s, s->emitters[i])];
        peak = fmax(peak, v3_luminance(m->emission_texture >= 0 ? m->emission : s->emitter_radiance[i]));
    }
    if (s->emitter_power > 0.f && receiving > 0.0) mean += s->emitter_power / (PM_PI * receiving);
    return mean > 0.0 ? peak / mean : INFINITY;
}

static void analyse(pm_scene *s) {
    pm_scene_analysis *a = &s->analysis;
    memset(a, 0, sizeof *a);
    for (uint32_t i = 0; i < s->material_count; i++) {
        const pm_material *m = &s->materials[i];
        if (!m->used) continue;
        a->has_glossy |= m->may_glossy;
        a->has_diffuse |= m->may_diffuse || m->may_glossy;
        a->has_mirror |= m->may_mirror;
        a->has_glass |= m->may_glass;
        a->has_near_specular |= m->may_near_specular;
        a->has_thin_glass |= m->may_glass && m->thin_walled;
        a->has_textures |= m->base_color_texture >= 0 || m->emission_texture >= 0 ||
                           m->metallic_roughness_texture >= 0 || m->transmission_texture >= 0 ||
                           (m->normal_texture >= 0 && s->tangents) || pm_material_layers_textured(m);
        a->has_non_opaque |= pm_material_can_be_transparent(s, m);
        a->has_unlit |= m->unlit;
    }
    a->has_emissive_triangles = s->emitter_count > 0;
    a->has_punctual_lights = s->light_count > 0;
    a->has_sky = s->sky;
    a->receiving_area = pm_scene_area_where(s, receives_light, NULL);
    a->light_peak_over_mean = light_peak_over_mean(s, a->receiving_area);
    a->light_diffuse = !a->has_punctual_lights && (a->has_sky || a->has_emissive_triangles) &&
                       a->light_peak_over_mean <= PM_DIFFUSE_LIGHT_PEAK;
    bool lit = a->has_emissive_triangles || a->has_punctual_lights || a->has_sky;
    bool specular = a->has_mirror || a->has_glass || a->has_near_specular; /* paths go on through all three alike */
    a->caustics_possible = lit && specular && a->has_diffuse;
    a->interreflection_possible = a->has_diffuse && lit && (specular || !diffuse_coplanar(s));
    a->component_possible[PM_DIRECT] = a->has_emissive_triangles || a->has_sky || (a->has_diffuse && lit) || a->has_unlit;
    a->component_possible[PM_SPECULAR] = specular && (lit || a->has_unlit);
    a->component_possible[PM_CAUSTIC] = a->caustics_possible;
    a->component_possible[PM_INDIRECT] = a->interreflection_possible;
}

/* A triangle's emission averaged over its area: the factor alone, or with a texture or cut-outs
 * the mean of 64 stratified samples of what it sends out (a texture black over the triangle makes
 * it no emitter at all). Where the texture emits at the samples but cut-outs cover none of them (a
 * thin covered strip), the mean is floored at the uncovered mean over 64, a bound on what they
 * missed: the triangle stays a light, picked rarely, and the estimates stay exact (they divide by
 * the pick probability). */
static vec3 triangle_mean_emission(const pm_scene *s, uint32_t t) {
    const pm_material *m = &s->materials[pm_scene_triangle_material(s, t)];
    if (v3_is_black(m->emission) || (m->emission_texture < 0 && !m->may_see_through)) return m->emission;
    enum { N = 8 };
    vec3 sum = v3s(0.f), uncovered = v3s(0.f);
    for (int i = 0; i < N; i++)
        for (int j = 0; j < N; j++) {
            /* the square's strata folded onto the triangle: uniform in area */
            float u = (i + 0.5f) / N, v = (j + 0.5f) / N;
            if (u + v > 1.f) { u = 1.f - u; v = 1.f - v; }
            vec3 e = pm_scene_emission_at(s, t, u, v); /* one texture read for both sums */
            uncovered = v3_add(uncovered, e);
            if (!v3_is_black(e)) sum = v3_add(sum, v3_scale(e, pm_scene_coverage_at(s, t, u, v)));
        }
    vec3 mean = v3_scale(sum, 1.f / (N * N));
    return v3_is_black(mean) ? v3_scale(uncovered, 1.f / (N * N * N * N)) : mean;
}

/* The emitter tables gone, and the memory admitted for them given back. */
static void drop_emitter_tables(pm_scene *s) {
    free(s->emitters);
    free(s->emitter_cdf);
    free(s->emitter_cut);
    free(s->emitter_radiance);
    free(s->emitter_records);
    s->emitters = NULL;
    s->emitter_cdf = NULL;
    s->emitter_cut = NULL;
    s->emitter_radiance = NULL;
    s->emitter_records = NULL;
    s->emitter_count = 0;
    s->emitter_power = 0.f;
    pm_memory_release(s->emitter_admitted);
    s->emitter_admitted = 0;
}

/* False when out of memory (the failure recorded): the scene cannot be rendered without it. */
static bool build_emitters(pm_scene *s) {
    drop_emitter_tables(s);
    uint32_t candidates = 0; /* emissive placed triangles emit from every placement */
    for (pm_triangle_walk w = {.placement = -2}; pm_scene_walk_next(s, &w);)
        if (!v3_is_black(s->materials[s->triangle_material[w.stored]].emission)) candidates++;
    if (!candidates) return true;
    /* a table a placed emissive triangle: placements can make it larger than the stored geometry
     * the loader admitted, so it is admitted too (the running sums only while it is built) */
    uint64_t kept = (uint64_t)candidates * (sizeof *s->emitters + sizeof *s->emitter_radiance + sizeof *s->emitter_cdf +
                                            sizeof *s->emitter_cut + sizeof *s->emitter_records) +
                    sizeof *s->emitter_cdf,
             building = ((uint64_t)candidates + 1) * sizeof(double);
    if (!pm_memory_admit(kept + building, "emitter distribution")) return false;
    s->emitter_admitted = kept;
    s->emitters = pm_malloc(candidates * sizeof *s->emitters, "emitter distribution");
    s->emitter_radiance = pm_malloc(candidates * sizeof *s->emitter_radiance, "emitter distribution");
    s->emitter_cdf = pm_malloc((candidates + 1) * sizeof *s->emitter_cdf, "emitter distribution");
    s->emitter_cut = pm_malloc(candidates * sizeof *s->emitter_cut, "emitter distribution");
    s->emitter_records = pm_malloc(candidates * sizeof *s->emitter_records, "emitter distribution");
    double *running = pm_malloc((candidates + 1) * sizeof *running, "emitter distribution");
    if (!s->emitters || !s->emitter_radiance || !s->emitter_cdf || !s->emitter_cut || !s->emitter_records || !running) {
        free(running);
        pm_memory_release(building);
        drop_emitter_tables(s); /* and kept, admitted for them */
        return false;
    }
    double total = 0.0;
    uint32_t k = 0;
    running[0] = 0.0;
    for (pm_triangle_walk w = {.placement = -2}; pm_scene_walk_next(s, &w);) {
        uint32_t t = w.id;
        const pm_material *m = &s->materials[s->triangle_material[w.stored]];
        if (v3_is_black(m->emission)) continue;
        vec3 mean = triangle_mean_emission(s, t);
        if (v3_is_black(mean)) continue;
        /* Power by luminance, floored so a deeply coloured emitter is still sampled. */
        double w = (double)pm_triangle_area(s, t) * fmax(v3_luminance(mean), 1e-3 * v3_max_component(mean)) *
                   (m->double_sided ? 2.0 : 1.0);
        if (!(w > 0.0)) continue;
        pm_triangle_geometry g = pm_triangle_geometry_of(s, t);
        s->emitters[k] = t;
        s->emitter_radiance[k] = mean;
        /* the emission is the factor alone (pm_scene_emitted_at's) unless a texture or a cut-out varies it */
        s->emitter_records[k] = (pm_emitter){.p0 = g.p0, .p1 = g.p1, .p2 = g.p2, .normal = g.normal, .emission = m->emission,
                                             .area = g.area, .double_sided = m->double_sided,
                                             .uniform_emission = (m->emission_texture < 0 || v3_is_black(m->emission)) &&
                                                                 !m->may_see_through};
        k++;
        total += w;
        running[k] = total;
    }
    s->emitter_count = k;
    s->emitter_cdf[0] = 0.f;
    for (uint32_t i = 1; i <= k; i++) s->emitter_cdf[i] = total > 0 ? (float)(running[i] / total) : (float)i / k;
    if (k) s->emitter_cdf[k] = 1.f;
    pm_cdf_cut_points(s->emitter_cdf, k, s->emitter_cut);
    free(running);
    pm_memory_release(building);
    s->emitter_power = (float)(total * PM_PI);
    return true;
}

/* The power of a punctual light, W: a point light's 4 pi I; a spot's I times the integral of
 * glTF's falloff over its cone, 2 pi ((1 - cos_inner) + (cos_inner - cos_outer) / 3) for the
 * squared linear ramp in cos (up to the ramp's floor); a directional light's irradiance over the
 * scene's cross-section. */
static vec3 light_power(const pm_scene *s, const pm_light *l) {
    if (l->type == PM_LIGHT_DIRECTIONAL) {
        float r = s->radius > 0.f ? s->radius : 1.f;
        return v3_scale(l->intensity, PM_PI * r * r);
    }
    if (l->type == PM_LIGHT_SPOT) {
        float ramp = pm_maxf(1e-3f, l->cos_inner - l->cos_outer), cone = pm_maxf(0.f, 1.f - l->cos_outer);
        return v3_scale(l->intensity, 2.f * PM_PI * (pm_maxf(0.f, cone - ramp) + pm_minf(ramp, cone) / 3.f));
    }
    return v3_scale(l->intensity, 4.f * PM_PI);
}

/* The punctual lights' distribution by power (luminance, floored as the emitters'), for scenes
 * with more lights than direct light shades one by one (NULL with fewer: pm_scene_pick_light
 * then picks uniformly). False when out of memory. */
static bool build_light_distribution(pm_scene *s) {
    free(s->light_cdf);
    s->light_cdf = NULL;
    if (s->light_count <= PM_DIRECT_LIGHT_SAMPLES) return true;
    double *running = pm_malloc(((size_t)s->light_count + 1) * sizeof *running, "light distribution");
    s->light_cdf = running ? pm_malloc(((size_t)s->light_count + 1) * sizeof *s->light_cdf, "light distribution") : NULL;
    if (!running || !s->light_cdf) {
        free(running);
        free(s->light_cdf);
        s->light_cdf = NULL;
        return false;
    }
    double total = 0.0;
    running[0] = 0.0;
    for (uint32_t i = 0; i < s->light_count; i++) {
        vec3 p = light_power(s, &s->lights[i]);
        double w = fmax(v3_luminance(p), 1e-3 * v3_max_component(p));
        total += w > 0.0 && isfinite(w) ? w : 0.0;
        running[i + 1] = total;
    }
    for (uint32_t i = 0; i <= s->light_count; i++)
        s->light_cdf[i] = total > 0.0 ? (float)(running[i] / total) : (float)i / (float)s->light_count;
    s->light_cdf[s->light_count] = 1.f;
    free(running);
    return true;
}

uint32_t pm_scene_pick_light(const pm_scene *s, float u, float *pick_pdf) {
    uint32_t n = s->light_count;
    if (!s->light_cdf) {
        uint32_t i = (uint32_t)(u * (float)n);
        *pick_pdf = 1.f / (float)n;
        return i < n ? i : n - 1;
    }
    uint32_t lo = pm_cdf_interval(s->light_cdf, n, u);
    *pick_pdf = s->light_cdf[lo + 1] - s->light_cdf[lo];
    return lo;
}

/* Scales v down to PM_MAX_EMISSION in its largest component (hue kept); true when it had to
 * (a NaN or negative component becomes 0). */
static bool clamp_emission(vec3 *v) {
    float c[3] = {v->x, v->y, v->z}, m = 0.f;
    bool changed = false;
    for (int k = 0; k < 3; k++) {
        if (!(c[k] >= 0.f)) { c[k] = 0.f; changed = true; }
        c[k] = pm_minf(c[k], FLT_MAX); /* an infinite component as the largest float, so the hue survives */
        m = pm_maxf(m, c[k]);
    }
    if (m > PM_MAX_EMISSION) {
        double scale = PM_MAX_EMISSION / (double)m;
        for (int k = 0; k < 3; k++) c[k] = (float)(c[k] * scale);
        changed = true;
    }
    *v = v3(c[0], c[1], c[2]);
    return changed;
}

/* Twice the area of stored triangle t, in double, in its own space. */
static double stored_twice_area(const pm_scene *s, uint32_t t) {
    const uint32_t *i = &s->indices[3 * (size_t)t];
    vec3 a = s->positions[i[0]], b = s->positions[i[1]], c = s->positions[i[2]];
    double e1[3] = {(double)b.x - a.x, (double)b.y - a.y, (double)b.z - a.z};
    double e2[3] = {(double)c.x - a.x, (double)c.y - a.y, (double)c.z - a.z};
    double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2], cz = e1[0] * e2[1] - e1[1] * e2[0];
    return sqrt(cx * cx + cy * cy + cz * cz);
}

/* How much a placement scales every area when it is a similarity (a rotation, a mirror, a uniform
 * scale: columns orthogonal and of one length), else 0: its triangles must be measured one by one. */
static double similarity_area_scale(const pm_placement *pl) {
    const float *m = pl->object_to_world;
    double c[3][3] = {{m[0], m[4], m[8]}, {m[1], m[5], m[9]}, {m[2], m[6], m[10]}};
    double dot[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) dot[i][j] = c[i][0] * c[j][0] + c[i][1] * c[j][1] + c[i][2] * c[j][2];
    double tol = 1e-6 * dot[0][0];
    if (fabs(dot[1][1] - dot[0][0]) > tol || fabs(dot[2][2] - dot[0][0]) > tol || fabs(dot[0][1]) > tol ||
        fabs(dot[0][2]) > tol || fabs(dot[1][2]) > tol)
        return 0.0;
    return dot[0][0];
}

double pm_scene_area_where(const pm_scene *s, bool (*keep)(const pm_material *, const void *), const void *context) {
    double area = 0.0;
    for (uint32_t t = 0; t < pm_scene_flat_triangles(s); t++)
        if (keep(&s->materials[s->triangle_material[t]], context)) area += 0.5 * stored_twice_area(s, t);
    for (uint32_t i = 0; i < s->instanced_mesh_count; i++) {
        const pm_instanced_mesh *m = &s->instanced_meshes[i];
        double mesh_area = -1.0; /* measured in mesh space on first use */
        for (uint32_t p = m->first_placement; p < m->first_placement + m->placement_count; p++) {
            const pm_placement *pl = &s->placements[p];
            double scale = similarity_area_scale(pl);
            if (scale > 0.0) {
                if (mesh_area < 0.0) {
                    mesh_area = 0.0;
                    for (uint32_t t = m->first_triangle; t < m->first_triangle + m->triangle_count; t++)
                        if (keep(&s->materials[s->triangle_material[t]], context)) mesh_area += 0.5 * stored_twice_area(s, t);
                }
                area += scale * mesh_area;
                continue;
            }
            for (uint32_t t = m->first_triangle; t < m->first_triangle + m->triangle_count; t++) {
                if (!keep(&s->materials[s->triangle_material[t]], context)) continue;
                const uint32_t *ix = s->indices + 3 * (size_t)t;
                vec3 a = pm_placement_point(pl, s->positions[ix[0]]), b = pm_placement_point(pl, s->positions[ix[1]]),
                     c = pm_placement_point(pl, s->positions[ix[2]]);
                area += 0.5 * v3_length(v3_cross(v3_sub(b, a), v3_sub(c, a)));
            }
        }
    }
    return area;
}

static bool any_material(const pm_material *m, const void *context) { (void)m; (void)context; return true; }
static bool reflects_at_least(const pm_material *m, const void *albedo) {
    return !m->unlit && v3_average(m->base_color) >= *(const float *)albedo; /* unlit reflects nothing */
}

double pm_scene_reflective_area_fraction(const pm_scene *s, float albedo) {
    double total = pm_scene_area_where(s, any_material, NULL), reflective = pm_scene_area_where(s, reflects_at_least, &albedo);
    return total > 0.0 ? reflective / total : 0.0;
}

/* One texture's mip levels, a task of build_texture_filtering's parallel-for. */
typedef struct { pm_scene *s; bool *srgb, *built; uint64_t *admitted; } level_job;
static void build_levels_task(void *ctx, size_t i, int thread) {
    level_job *j = ctx;
    j->built[i] = pm_texture_build_levels(&j->s->textures[i], j->srgb[i], &j->admitted[i]);
}

/* What footprint filtering needs: each texture's mip levels (colour ones, read as sRGB by some
 * material's base colour, emission, sheen or specular colour, averaged in linear light; the rest as data) and each
 * triangle's UV density. False when out of memory (the failure recorded). */
static bool build_texture_filtering(pm_scene *s) {
    if (!s->texture_count) return true;
    /* the textures' levels side by side, on every core: one after another they are a tenth of a
     * textured model's load */
    bool *srgb = pm_calloc(s->texture_count, 2 * sizeof(bool), "texture levels");
    uint64_t *admitted = pm_calloc(s->texture_count, sizeof(uint64_t), "texture levels");
    if (!srgb || !admitted) { free(srgb); free(admitted); return false; }
    for (uint32_t i = 0; i < s->texture_count; i++)
        for (uint32_t k = 0; k < s->material_count; k++)
            srgb[i] |= s->materials[k].base_color_texture == (int)i || s->materials[k].emission_texture == (int)i ||
                       (s->materials[k].layered && (s->materials[k].layers.sheen_color_texture.texture == (int)i ||
                                                    s->materials[k].layers.specular_color_texture.texture == (int)i));
    level_job job = {s, srgb, srgb + s->texture_count, admitted};
    pm_parallel_for(pm_thread_count(pm_cpu_count()), s->texture_count, build_levels_task, &job);
    bool built = true;
    for (uint32_t i = 0; i < s->texture_count; i++) {
        s->memory_admitted += admitted[i];
        built &= job.built[i];
    }
    free(srgb);
    free(admitted);
    if (!built) return false;
    free(s->uv_density);
    s->uv_density = NULL;
    if (!s->uvs && !s->uvs1) return true;
    s->uv_density = pm_malloc(2 * sizeof *s->uv_density * (s->triangle_count ? s->triangle_count : 1), "texture footprints");
    if (!s->uv_density) return false;
    for (uint32_t t = 0; t < s->triangle_count; t++) {
        const uint32_t *ix = s->indices + 3 * (size_t)t;
        vec3 p0 = s->positions[ix[0]], p1 = s->positions[ix[1]], p2 = s->positions[ix[2]];
        double e1[3] = {(double)p1.x - p0.x, (double)p1.y - p0.y, (double)p1.z - p0.z};
        double e2[3] = {(double)p2.x - p0.x, (double)p2.y - p0.y, (double)p2.z - p0.z};
        double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2], cz = e1[0] * e2[1] - e1[1] * e2[0];
        double world = sqrt(cx * cx + cy * cy + cz * cz);
        for (int set = 0; set < 2; set++) {
            const float *uv = set ? s->uvs1 : s->uvs;
            double density = 0.0;
            if (uv && world > 0.0) {
                double a[2] = {(double)uv[2 * ix[1]] - uv[2 * ix[0]], (double)uv[2 * ix[1] + 1] - uv[2 * ix[0] + 1]};
                double b[2] = {(double)uv[2 * ix[2]] - uv[2 * ix[0]], (double)uv[2 * ix[2] + 1] - uv[2 * ix[0] + 1]};
                density = sqrt(fabs(a[0] * b[1] - a[1] * b[0]) / world);
            }
            s->uv_density[2 * (size_t)t + set] = isfinite(density) ? (float)density : 0.f;
        }
    }
    return true;
}

bool pm_scene_finalize(pm_scene *s, bool add_default_sky, bool *added_sky) {
    s->clamped_emission = 0;
    for (uint32_t i = 0; i < s->material_count; i++) s->clamped_emission += clamp_emission(&s->materials[i].emission);
    for (uint32_t i = 0; i < s->light_count; i++) s->clamped_emission += clamp_emission(&s->lights[i].intensity);
    if (s->sky) s->clamped_emission += clamp_emission(&s->sky_radiance);
    vec3 lo = v3s(FLT_MAX), hi = v3s(-FLT_MAX);
    for (uint32_t t = 0; t < pm_scene_flat_triangles(s); t++)
        for (int k = 0; k < 3; k++) {
            vec3 p = s->positions[s->indices[3 * (size_t)t + k]];
            lo = v3_min(lo, p);
            hi = v3_max(hi, p);
        }
    /* pm_scene_placement_of finds a placement by one division within its mesh: a mesh's placements
     * are consecutive, and each takes as many ids as the mesh has triangles, in order */
    for (uint32_t m = 0; m < s->instanced_mesh_count; m++) {
        const pm_instanced_mesh *mesh = &s->instanced_meshes[m];
        for (uint32_t k = 0; k < mesh->placement_count; k++) {
            const pm_placement *pl = &s->placements[mesh->first_placement + k];
            assert(pl->mesh == m && pl->first_id == s->placements[mesh->first_placement].first_id + k * mesh->triangle_count);
            (void)pl;
        }
    }
    for (uint32_t i = 0; i < s->placement_count; i++) { /* every vertex of each placed mesh */
        const pm_instanced_mesh *m = &s->instanced_meshes[s->placements[i].mesh];
        for (uint32_t v = m->first_vertex; v < m->first_vertex + m->vertex_count; v++) {
            vec3 p = pm_placement_point(&s->placements[i], s->positions[v]);
            lo = v3_min(lo, p);
            hi = v3_max(hi, p);
        }
    }
    if (s->triangle_count == 0) lo = hi = v3s(0.f);
    s->bounds_min = lo;
    s->bounds_max = hi;
    if (!pm_scene_core(s, &lo, &hi)) return false;
    s->core_min = lo;
    s->core_max = hi;
    s->center = v3_scale(v3_add(lo, hi), 0.5f);
    s->radius = 0.5f * v3_length(v3_sub(hi, lo));
    float extent = v3_max_component(v3_sub(hi, lo));
    s->ray_scale = extent > 0.f ? extent : 1.f;
    channel_bounds *bounds = pm_calloc(s->texture_count ? s->texture_count : 1, sizeof *bounds, "texture channel bounds");
    if (!bounds) return false;
    for (uint32_t i = 0; i < s->material_count; i++) material_lobes(s, bounds, &s->materials[i]);
    free(bounds);
    free(s->face_normals);
    s->face_normals = pm_malloc(sizeof(vec3) * (s->triangle_count ? s->triangle_count : 1), "face normals");
    if (!s->face_normals) return false;
    for (uint32_t i = 0; i < s->material_count; i++) s->materials[i].used = false;
    for (uint32_t t = 0; t < s->triangle_count; t++) s->materials[s->triangle_material[t]].used = true;
    free(s->edge_altitudes);
    s->edge_altitudes = pm_malloc(3 * sizeof(float) * (s->triangle_count ? s->triangle_count : 1), "triangle altitudes");
    for (uint32_t t = 0; t < s->triangle_count; t++) {
        const uint32_t *ix = s->indices + 3 * (size_t)t;
        s->face_normals[t] = pm_face_normal(s->positions[ix[0]], s->positions[ix[1]], s->positions[ix[2]]);
        if (s->edge_altitudes)
            pm_triangle_altitudes(s->positions[ix[0]], s->positions[ix[1]], s->positions[ix[2]], s->edge_altitudes + 3 * (size_t)t);
    }
    if (!build_emitters(s) || !build_light_distribution(s) || !build_texture_filtering(s)) return false;
    if (added_sky) *added_sky = false;
    if (add_default_sky && !s->sky && s->emitter_count == 0 && s->light_count == 0) {
        s->sky = true;
        s->sky_radiance = v3s(1.f);
        if (added_sky) *added_sky = true;
    }
    analyse(s);
    return true;
}

void pm_scene_set_sky(pm_scene *s, bool sky, vec3 radiance, pm_sky_map *map) {
    if (s->sky_map != map) pm_sky_map_free(s->sky_map);
    s->sky = sky;
    s->sky_radiance = sky ? radiance : v3s(0.f);
    s->sky_map = sky ? map : NULL;
    if (!sky && map) pm_sky_map_free(map);
    analyse(s);
}

void pm_scene_free(pm_scene *s) {
    pm_sky_map_free(s->sky_map);
    free(s->positions);
    free(s->normals);
    free(s->uvs);
    free(s->uvs1);
    free(s->tangents);
    free(s->indices);
    free(s->triangle_material);
    free(s->face_normals);
    free(s->edge_altitudes);
    free(s->materials);
    for (uint32_t i = 0; i < s->texture_count; i++) {
        free(s->textures[i].rgba);
        free(s->textures[i].levels);
    }
    free(s->uv_density);
    free(s->instanced_meshes);
    free(s->placements);
    free(s->textures);
    free(s->lights);
    free(s->cameras);
    free(s->variant_names);
    drop_emitter_tables(s);
    free(s->light_cdf);
    pm_memory_release(s->memory_admitted);
    memset(s, 0, sizeof *s);
}

uint64_t pm_scene_bytes(const pm_scene *s) {
    uint64_t v = s->vertex_count, t = s->triangle_count;
    uint64_t bytes = v * 2 * sizeof(vec3) + t * 2 * sizeof(uint32_t) + t * 3 * sizeof(uint32_t);
    if (s->uvs) bytes += v * 2 * sizeof(float);
    if (s->uvs1) bytes += v * 2 * sizeof(float);
    if (s->tangents) bytes += v * 4 * sizeof(float);
    if (s->face_normals) bytes += t * sizeof(vec3);
    if (s->edge_altitudes) bytes += t * 3 * sizeof(float);
    if (s->uv_density) bytes += t * 2 * sizeof(float);
    bytes += (uint64_t)s->material_count * sizeof(pm_material) + (uint64_t)s->light_count * sizeof(pm_light) +
             (uint64_t)s->camera_count * sizeof(pm_camera) + (uint64_t)s->texture_count * sizeof(pm_texture);
    for (uint32_t i = 0; i < s->texture_count; i++) {
        const pm_texture *x = &s->textures[i];
        bytes += 4ull * (uint64_t)x->width * (uint64_t)x->height;
        for (int k = 1; k < x->level_count; k++) bytes += 4ull * (uint64_t)x->level_width[k] * (uint64_t)x->level_height[k];
    }
    bytes += (uint64_t)s->emitter_count * (2 * sizeof(uint32_t) + sizeof(vec3) + sizeof(float) + sizeof(pm_emitter));
    if (s->light_cdf) bytes += ((uint64_t)s->light_count + 1) * sizeof(float);
    if (s->sky_map) bytes += pm_sky_map_bytes(s->sky_map->width, s->sky_map->height);
    bytes += (uint64_t)s->instanced_mesh_count * sizeof(pm_instanced_mesh) + (uint64_t)s->placement_count * sizeof(pm_placement);
    return bytes;
}

static uint64_t digest_bytes(uint64_t h, const void *data, size_t size) {
    const unsigned char *p = data;
    for (size_t i = 0; i < size; i++) h = (h ^ p[i]) * 1099511628211ull;
    return h;
}

uint64_t pm_scene_digest(const pm_scene *s) {
    uint64_t h = 14695981039346656037ull;
    uint32_t counts[] = {s->vertex_count, s->triangle_count, s->material_count, s->texture_count, s->light_count,
                         s->camera_count, s->placement_count, s->instanced_mesh_count};
    h = digest_bytes(h, counts, sizeof counts);
    if (s->positions) h = digest_bytes(h, s->positions, sizeof(vec3) * s->vertex_count);
    if (s->indices) h = digest_bytes(h, s->indices, 3 * sizeof(uint32_t) * s->triangle_count);
    if (s->triangle_material) h = digest_bytes(h, s->triangle_material, sizeof(uint32_t) * s->triangle_count);
    if (s->uvs) h = digest_bytes(h, s->uvs, 2 * sizeof(float) * s->vertex_count);
    if (s->materials) h = digest_bytes(h, s->materials, sizeof(pm_material) * s->material_count); /* zeroed before filling */
    for (uint32_t i = 0; i < s->placement_count; i++)
        h = digest_bytes(h, s->placements[i].object_to_world, sizeof s->placements[i].object_to_world);
    for (uint32_t i = 0; i < s->texture_count; i++) {
        const pm_texture *t = &s->textures[i];
        int size[2] = {t->width, t->height};
        h = digest_bytes(h, size, sizeof size);
        if (t->rgba) h = digest_bytes(h, t->rgba, 4 * (size_t)t->width * (size_t)t->height);
    }
    for (uint32_t i = 0; i < s->light_count; i++) {
        const pm_light *l = &s->lights[i];
        float f[] = {(float)l->type, l->position.x, l->position.y, l->position.z, l->direction.x, l->direction.y, l->direction.z,
                     l->intensity.x, l->intensity.y, l->intensity.z, l->range, l->cos_inner, l->cos_outer};
        h = digest_bytes(h, f, sizeof f);
    }
    for (uint32_t i = 0; i < s->camera_count; i++) {
        const pm_camera *c = &s->cameras[i];
        float f[] = {c->position.x, c->position.y, c->position.z, c->forward.x, c->forward.y, c->forward.z, c->up.x, c->up.y,
                     c->up.z, c->yfov, c->aspect, c->znear, c->orthographic ? 1.f : 0.f, c->ymag};
        h = digest_bytes(h, f, sizeof f);
    }
    float sky[] = {s->sky ? 1.f : 0.f, s->sky_radiance.x, s->sky_radiance.y, s->sky_radiance.z};
    return digest_bytes(h, sky, sizeof sky);
}

pm_camera pm_scene_auto_camera(const pm_scene *s, float aspect) {
    pm_camera c;
    memset(&c, 0, sizeof c);
    c.yfov = 45.f * PM_PI / 180.f;
    c.aspect = aspect;
    vec3 back = v3_normalize(v3(0.f, 0.25f, 1.f));
    c.forward = v3_neg(back);
    c.right = v3_normalize(v3_cross(c.forward, v3(0.f, 1.f, 0.f)));
    c.up = v3_cross(c.right, c.forward);
    return pm_scene_fit_camera(s, c, aspect);
}

pm_camera pm_scene_fit_camera(const pm_scene *s, pm_camera c, float aspect) {
    const float margin = 1.05f;
    if (!(aspect > 0.f)) aspect = c.aspect > 0.f ? c.aspect : 1.f;
    /* the core's vertices: a stray far from the bulk would shrink the model to a dot */
    vec3 center = v3_scale(v3_add(s->core_min, s->core_max), 0.5f);
    float r = s->radius > 0.f ? s->radius : 1.f;
    double tan_y = tan(0.5 * (double)c.yfov) / margin, tan_x = tan_y * aspect;
    /* in the camera's frame, from the centre: x right, y up, z toward the camera */
    double need = 0.0, half_w = 0.0, half_h = 0.0, z_max = 0.0;
    uint32_t flat_vertices = s->instanced_mesh_count ? s->instanced_meshes[0].first_vertex : s->vertex_count;
    for (uint64_t i = 0, pl = 0, v = 0; ; i++) { /* flat vertices, then each placement's */
        vec3 world;
        if (i < flat_vertices) world = s->positions[i];
        else {
            while (pl < s->placement_count && v >= s->instanced_meshes[s->placements[pl].mesh].vertex_count) { pl++; v = 0; }
            if (pl >= s->placement_count) break;
            const pm_placement *placement = &s->placements[pl];
            world = pm_placement_point(placement, s->positions[s->instanced_meshes[placement->mesh].first_vertex + v++]);
        }
        if (!(world.x >= s->core_min.x && world.y >= s->core_min.y && world.z >= s->core_min.z && world.x <= s->core_max.x &&
              world.y <= s->core_max.y && world.z <= s->core_max.z))
            continue;
        vec3 d = v3_sub(world, center);
        double x = fabs((double)v3_dot(d, c.right)), y = fabs((double)v3_dot(d, c.up)), z = -(double)v3_dot(d, c.forward);
        if (c.orthographic) {
            half_w = fmax(half_w, x);
            half_h = fmax(half_h, y);
            z_max = fmax(z_max, z);
        } else {
            need = fmax(need, fmax(z + x / tan_x, z + y / tan_y));
        }
    }
    double dist;
    if (c.orthographic) {
        c.ymag = (float)fmax(margin * fmax(half_h, half_w / aspect), 1e-6 * r);
        dist = z_max + 0.1 * r; /* in front of everything: parallel rays start at the camera */
    } else {
        dist = s->vertex_count ? need : r / sin(atan(fmin(tan_x, tan_y)));
        dist = fmax(dist, 1e-3 * r);
    }
    c.position = v3_sub(center, v3_scale(c.forward, (float)dist));
    c.znear = (float)dist * 1e-3f;
    return c;
}

float pm_scene_emitter_pdf(const pm_scene *s, uint32_t tri) {
    uint32_t lo = 0, hi = s->emitter_count; /* emitters are in triangle order */
    while (lo < hi) {
        uint32_t mid = lo + (hi - lo) / 2;
        if (s->emitters[mid] < tri) lo = mid + 1; else hi = mid;
    }
    if (lo >= s->emitter_count || s->emitters[lo] != tri) return 0.f;
    return s->emitter_cdf[lo + 1] - s->emitter_cdf[lo];
}


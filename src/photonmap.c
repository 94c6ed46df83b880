/* photonmap.c: photon emission by light power, projection maps, Russian-roulette tracing, map building, radiance estimates.
 *
 * Photons are generated in fixed chunks, each with its own random streams and its own run of
 * records in its thread's arena, merged in chunk order: the maps do not depend on the thread
 * count. A chunk is traced in waves (trace_chunk): Embree takes all of a wave's rays, then all
 * of its hits bounce, each phase one tight loop. Every photon starts
 * with its share of the light's flux (power / (photons x pick probability)); at each hit it steps
 * through the path-vertex kernel that eye paths share (vertex.h), whose Russian roulette keeps
 * that power (only rescaled per channel by colour), except on surfaces whose reflectance passes
 * PM_MAX_SURVIVAL: there survival is capped and the weight grows by the ratio, so an
 * energy-conserving scene still ends its paths in bounded time.
 * A pass given a deadline stops starting chunks when it passes and rescales what it stored by
 * photons asked / photons traced: fewer photons, the same expected power.
 */
#include "photonmap.h"

#include <float.h>
#include <assert.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "brdf.h"
#include "camera.h"
#include "clock.h"
#include "defaults.h"
#include "guide.h"
#include "memory.h"
#include "parallel.h"
#include "light.h"
#include "rng.h"
#include "scatter.h"
#include "vertex.h"

#define CHUNK 2048
#define MAX_THREADS PM_MAX_THREADS
#define PROJ_Z 64     /* projection map cells: uniform in z = cos(theta) ... */
#define PROJ_PHI 128  /* ... and in phi, so every cell has the same solid angle */

typedef enum { SOURCE_EMITTERS, SOURCE_PUNCTUAL, SOURCE_SKY } source_kind;

/* The shadow of the scene's core box on a plane across a directional light, as box_start samples
 * it: per face that faces the light, its weight (|dir . normal| x area), what a pick subtracts
 * before scaling to [0, 1), its low corner and its two edges. It depends on the direction alone,
 * so it is set once per light: per photon, the face and the point cost a few operations. */
typedef struct {
    bool usable;             /* some area across the light, finite: else the disc is taken */
    float total;             /* the shadow's area: the three weights summed */
    float below_second, below_third; /* a pick at or past them takes the y face, the z face (+inf: never) */
    float weight[3], skip[3], skip_more[3];
    vec3 corner[3], edge_a[3], edge_b[3];
} box_shadow;

/* A marked cell of a projection map, as sampling reads it: the top of its band of z and its
 * first azimuth's cosine and sine, from which a point of the cell is a short polynomial away
 * (cell_direction_from), where the cell's index would cost a sine and cosine a photon. */
typedef struct { float z_top, cos_phi, sin_phi; } projection_start;

typedef struct {
    source_kind kind;
    uint32_t light;          /* index into scene lights for SOURCE_PUNCTUAL */
    box_shadow shadow;       /* a directional light's: where its photons start (box_start) */
    vec3 power;              /* flux, W per channel */
    vec3 center;             /* where its photons leave from, for projection maps */
    float radius;            /* bounding radius of that region (0 for a point) */
    projection_start *marked; /* projection map (caustic pass): the marked cells; NULL = every direction */
    uint32_t marked_count;
    /* its slots among the emission guide's sources (guide.h), -1 where not guided: the two numbers
     * that place its photons (the start on the disc across the scene for a directional light and
     * the sky, the direction for a point or spot light), and the sky's direction */
    int guided, guided_direction;
} light_source;

typedef struct { vec3 center; float radius; } sphere;

typedef struct {
    const pm_scene *scene;
    const pm_accel *accel;
    const pm_photon_settings *settings;
    light_source *sources;
    uint32_t source_count;
    float *source_cdf;
    bool volumes;            /* some material attenuates inside its mesh (KHR_materials_volume) */
    bool prefetch_hits;      /* the mesh outgrows the caches: hits' triangles are prefetched (PM_PREFETCH_GEOMETRY_BYTES) */
    bool prefetch_texels;    /* the textures outgrow them: hits' texels are prefetched (the same bound) */
    bool prefetch_emitters;  /* the emitter tables outgrow them: photons' emitters are prefetched (the same bound) */
    bool tag_punctual_specular;  /* global records of a punctual light's light past a mirror or glass first are tagged so */
    bool only_punctual_specular; /* ... and stored alone (pm_photon_tracer_tag_punctual_specular) */
    bool caustic_pass;
    uint64_t photons;        /* emitted in this pass */
    uint64_t seed;
    /* caustic pass with projection maps: the specular objects' bounding spheres, which light
     * from a direction (directional lights, the sky) reaches through the union of their
     * projected discs (each of area pi r^2 whatever the direction) */
    const sphere *targets;
    uint32_t target_count;
    const float *target_cdf;  /* target_count+1 entries, by r^2 */
    float target_area;        /* sum of pi r^2 */
    float target_reach;       /* a start this far back along the light is outside every target */
    /* per worker thread, kept by the tracer across passes (a pass reuses their memory, no
     * allocation or page faults per iteration): each chunk appends its records to its thread's
     * arena, and the merge copies them out in chunk order */
    /* 64 bytes each, so two threads' arenas rarely share a cache line (not _Alignas: the tracer
     * comes from calloc, which promises 16) */
    struct record_arena { pm_photon *data; size_t count, capacity; char pad[40]; } arenas[MAX_THREADS];
    uint32_t *chunk_arena;    /* the thread whose arena holds a chunk's records */
    size_t *chunk_start;      /* where in that arena they begin */
    uint32_t *chunk_counts;
    bool *chunk_skipped;      /* started after the deadline */
    uint32_t *chunk_cut;      /* photons a chunk left untraced when the deadline passed during it */
    double deadline;          /* pm_now_seconds() past which no chunk starts; 0 = none */
    /* the calling thread's cancel flag (parallel.h), also looked at inside a chunk: in a room of
     * albedo 1 one chunk is 200,000 rays, and a quit or a signal must not wait for it */
    const atomic_bool *cancel;
    uint64_t traced;          /* photons the last pass traced (fewer than asked when cut) */
    /* records one pass may store: counted per chunk in steps of CHUNK (the same total at any
     * thread count) and bounded so that they fit the memory limit four times over: their merged
     * copy, the arenas (up to twice the records they hold, as they double; one set serves both
     * kinds of pass) and the other kind's merged buffer, which the progressive mode keeps */
    uint64_t record_limit;
    _Atomic uint64_t records; /* stored so far in this pass */
    atomic_bool out_of_memory;
    uint64_t dropped;         /* photons of the last pass whose power was not finite (ended, not stored) */
    bool punctual_first_hits_skipped; /* global pass: no record of a punctual light's first hit (the reader traces that light) */
    /* camera splats of the caustic pass (pm_photon_tracer_set_splats): per chunk, merged in order */
    bool splat;               /* splat_view is set */
    pm_camera_view splat_view;
    pm_splat_buffer *splat_out;
    pm_camera_splat **chunk_splats;
    uint32_t *chunk_splat_counts;
    struct { uint64_t rays, dropped; char pad[48]; } counters[MAX_THREADS];
    /* the emission guide (global pass, guide.h): where guided photons start, and per thread the
     * photons each cell emitted and the records they stored in marked cells (2 x guide_cells each) */
    const pm_guide *guide;
    const pm_marks *marks;
    uint32_t *guide_counts;
    size_t guide_cells;       /* guided sources x PM_GUIDE_CELL_COUNT */
    /* a light-vertex pass (pm_photon_tracer_trace_light_vertices): the punctual lights' photons end
     * at their first diffuse or glossy hit, kept where `vertex_region` marks (NULL: everywhere),
     * per chunk, merged in chunk order */
    bool light_vertex_pass;
    const pm_cell_values *vertex_worth;
    pm_light_vertex **chunk_vertices;
    uint32_t *chunk_vertex_counts;
    pm_light_vertex_buffer *vertex_out;
} pass;

/* Photons meet the one survival rule from their first surface on (Jensen: a photon keeps its power),
 * and an absorbed one is read no further. */
static const pm_vertex_policy photon_policy = {.roulette_from = 0, .ended_unsampled = true};
/* A caustic photon (L S+ D) is stored at a non-specular surface and goes on by its specular parts
 * only, with less power, rather than ended where it would choose N (vertex.h). */
static const pm_vertex_policy caustic_photon_policy = {.roulette_from = 0, .nonspecular_weighed = true, .ended_unsampled = true};

/* Flux of a spot: I x integral of the falloff over the cone (midpoint rule in cos theta). */
static float spot_solid_angle(const pm_light *l) {
    const int n = 4096;
    double sum = 0.0, lo = l->cos_outer, step = (1.0 - lo) / n;
    for (int i = 0; i < n; i++) {
        double c = lo + (i + 0.5) * step;
        float s = sqrtf((float)fmax(0.0, 1.0 - c * c));
        vec3 t, b;
        v3_basis(l->direction, &t, &b);
        sum += pm_spot_falloff(l, v3_add(v3_scale(l->direction, (float)c), v3_scale(t, s))) * step;
    }
    return (float)(2.0 * PM_PI * sum);
}


static box_shadow box_shadow_across(const pm_scene *s, vec3 dir);

static uint32_t build_sources(const pm_scene *s, light_source *out) {
    uint32_t n = 0;
    float R = s->radius > 0.f ? s->radius : 1.f;
    if (s->emitter_count) {
        light_source *l = &out[n++];
        memset(l, 0, sizeof *l);
        l->kind = SOURCE_EMITTERS;
        vec3 lo = v3s(FLT_MAX), hi = v3s(-FLT_MAX), power = v3s(0.f);
        for (uint32_t i = 0; i < s->emitter_count; i++) {
            uint32_t t = s->emitters[i];
            const pm_material *m = &s->materials[pm_scene_triangle_material(s, t)];
            power = v3_madd(power, s->emitter_radiance[i], PM_PI * pm_triangle_area(s, t) * (m->double_sided ? 2.f : 1.f));
            vec3 corners[3];
            pm_scene_triangle_corners(s, t, corners);
            for (int k = 0; k < 3; k++) {
                vec3 p = corners[k];
                lo = v3_min(lo, p);
                hi = v3_max(hi, p);
            }
        }
        l->power = power;
        l->center = v3_scale(v3_add(lo, hi), 0.5f);
        l->radius = 0.5f * v3_length(v3_sub(hi, lo));
    }
    for (uint32_t i = 0; i < s->light_count; i++) {
        const pm_light *pl = &s->lights[i];
        light_source *l = &out[n++];
        memset(l, 0, sizeof *l);
        l->kind = SOURCE_PUNCTUAL;
        l->light = i;
        if (pl->type == PM_LIGHT_POINT) l->power = v3_scale(pl->intensity, 4.f * PM_PI);
        else if (pl->type == PM_LIGHT_SPOT) l->power = v3_scale(pl->intensity, spot_solid_angle(pl));
        else l->power = v3_scale(pl->intensity, PM_PI * R * R);
        l->center = pl->position;
        if (pl->type == PM_LIGHT_DIRECTIONAL) l->shadow = box_shadow_across(s, pl->direction);
    }
    if (s->sky) {
        light_source *l = &out[n++];
        memset(l, 0, sizeof *l);
        l->kind = SOURCE_SKY;
        l->power = v3_scale(pm_scene_sky_mean(s), 4.f * PM_PI * PM_PI * R * R);
    }
    return n;
}

/* Specular triangles bucketed on a coarse grid: each bucket's bounding sphere stands for the
 * specular objects a projection map must cover. */
static sphere *specular_spheres(const pm_scene *s, uint32_t *count) {
    enum { G = 8 };
    vec3 lo = s->core_min, hi = s->core_max, ext = v3_sub(hi, lo);
    vec3 blo[G * G * G], bhi[G * G * G];
    bool used[G * G * G] = {false};
    for (pm_triangle_walk w = {.placement = -2}; pm_scene_walk_next(s, &w);) {
        const pm_material *m = &s->materials[s->triangle_material[w.stored]];
        if (!m->may_mirror && !m->may_glass && !m->may_near_specular) continue; /* caustic photons go on through all three */
        vec3 corners[3];
        pm_scene_walk_corners(s, &w, corners);
        vec3 p0 = corners[0], p1 = corners[1], p2 = corners[2];
        vec3 c = v3_scale(v3_add(v3_add(p0, p1), p2), 1.f / 3.f);
        /* a specular stray outside the scene's core is no target: clamped into an edge bucket it would swell its sphere */
        if (!(c.x >= lo.x && c.y >= lo.y && c.z >= lo.z && c.x <= hi.x && c.y <= hi.y && c.z <= hi.z)) continue;
        int cell[3];
        for (int a = 0; a < 3; a++) {
            float e = v3_get(ext, a);
            int g = e > 0.f ? (int)((v3_get(c, a) - v3_get(lo, a)) / e * G) : 0;
            cell[a] = g < 0 ? 0 : (g >= G ? G - 1 : g);
        }
        int b = (cell[2] * G + cell[1]) * G + cell[0];
        vec3 tlo = v3_min(p0, v3_min(p1, p2)), thi = v3_max(p0, v3_max(p1, p2));
        if (!used[b]) { used[b] = true; blo[b] = tlo; bhi[b] = thi; }
        else { blo[b] = v3_min(blo[b], tlo); bhi[b] = v3_max(bhi[b], thi); }
    }
    sphere *out = pm_malloc(sizeof(sphere) * G * G * G, "specular object bounds");
    uint32_t n = 0;
    *count = 0;
    if (!out) return NULL;
    for (int b = 0; b < G * G * G; b++)
        if (used[b]) out[n++] = (sphere){v3_scale(v3_add(blo[b], bhi[b]), 0.5f), 0.5f * v3_length(v3_sub(bhi[b], blo[b]))};
    *count = n;
    return out;
}

static vec3 cell_direction(int iz, int iphi, float fz, float fphi) {
    float z = 1.f - 2.f * ((iz + fz) / PROJ_Z), r = sqrtf(pm_maxf(0.f, 1.f - z * z));
    float sin_phi, cos_phi; /* phi = 2 pi (iphi + fphi) / PROJ_PHI */
    pm_sincos_turn((iphi + fphi) * (1.f / PROJ_PHI), &sin_phi, &cos_phi);
    return v3(r * cos_phi, r * sin_phi, z);
}

/* cell_direction(iz, iphi, fz, fphi) from the cell's projection_start: the azimuth turned on by
 * b = 2 pi fphi / PROJ_PHI < 0.05, whose sine and cosine the first terms of their series give
 * within 3e-9 */
static inline vec3 cell_direction_from(const projection_start *c, float fz, float fphi) {
    float z = c->z_top - fz * (2.f / PROJ_Z), r = sqrtf(pm_maxf(0.f, 1.f - z * z));
    float b = fphi * (2.f * PM_PI / PROJ_PHI), b2 = b * b;
    float sin_b = b * (1.f - b2 * (1.f / 6.f)), cos_b = 1.f - b2 * (0.5f - b2 * (1.f / 24.f));
    float cos_phi = c->cos_phi * cos_b - c->sin_phi * sin_b, sin_phi = c->sin_phi * cos_b + c->cos_phi * sin_b;
    return v3(r * cos_phi, r * sin_phi, z);
}

/* Sources whose photons leave from a bounded region, so a map of directions can aim them. */
static bool point_like(const pm_scene *s, const light_source *l) {
    return l->kind == SOURCE_EMITTERS || (l->kind == SOURCE_PUNCTUAL && s->lights[l->light].type != PM_LIGHT_DIRECTIONAL);
}

/* The projection map's cells, the same for every source: each cell's centre direction and its
 * angular radius (the widest corner, with a margin), and that radius's cosine and sine. */
typedef struct { vec3 centre; float angle, cos_angle, sin_angle; } projection_cell;

static projection_cell *projection_cells(void) {
    projection_cell *cells = pm_malloc(sizeof *cells * PROJ_Z * PROJ_PHI, "projection map cells");
    if (!cells) return NULL;
    for (int iz = 0; iz < PROJ_Z; iz++)
        for (int ip = 0; ip < PROJ_PHI; ip++) {
            projection_cell *c = &cells[iz * PROJ_PHI + ip];
            c->centre = cell_direction(iz, ip, 0.5f, 0.5f);
            float cell_cos = 1.f;
            for (int k = 0; k < 4; k++)
                cell_cos = pm_minf(cell_cos, v3_dot(c->centre, cell_direction(iz, ip, (float)(k & 1), (float)(k >> 1))));
            c->angle = acosf(pm_maxf(-1.f, pm_minf(1.f, cell_cos))) * 1.05f + 1e-3f;
            c->cos_angle = cosf(c->angle);
            c->sin_angle = sinf(c->angle);
        }
    return cells;
}

typedef struct {
    light_source *sources;
    const uint32_t *mapped;  /* the sources that get a map, one task each */
    const projection_cell *cells;
    const sphere *spheres;
    uint32_t sphere_count;
    atomic_bool failed;
} projection_job;

/* Marks the cells of directions from the source's region that can reach a specular sphere.
 * Conservative: each sphere is grown by the source's own radius, each cell by its angular
 * radius, so no direction that could start a caustic path is left out. A cell reaches a sphere
 * when the angle between their directions is at most the sphere's half angle plus the cell's:
 * compared as cosines (the cosine of the sum from both sides' cosines and sines, no libm call
 * per pair: with many lights and specular objects, the arc functions took seconds), and where
 * the two sides are within 1e-5 of each other, by the angles themselves, so every cell is
 * marked exactly as the angle test marks it. */
static void build_projection_map(void *ctx, size_t index, int thread) {
    projection_job *job = ctx;
    light_source *l = &job->sources[job->mapped[index]];
    l->marked = NULL;
    l->marked_count = 0;
    typedef struct { vec3 axis; float half, cos_half, sin_half; bool inside; } cone;
    cone *cones = pm_malloc(sizeof *cones * (job->sphere_count ? job->sphere_count : 1), "projection map cones");
    if (!cones) { atomic_store(&job->failed, true); return; }
    for (uint32_t i = 0; i < job->sphere_count; i++) {
        vec3 to = v3_sub(job->spheres[i].center, l->center);
        float d = v3_length(to), r = job->spheres[i].radius + l->radius;
        cones[i].inside = d <= r;
        if (cones[i].inside) continue;
        cones[i].axis = v3_scale(to, 1.f / d);
        cones[i].half = asinf(r / d);
        cones[i].sin_half = r / d;
        /* in double: near the light a sphere's sine is close to 1, and 1 - s^2 in float cancels */
        double s2 = (double)cones[i].sin_half * cones[i].sin_half;
        cones[i].cos_half = (float)sqrt(s2 < 1.0 ? 1.0 - s2 : 0.0);
    }
    uint32_t marks[PROJ_Z * PROJ_PHI], count = 0; /* 32 kB of the worker's stack; the map keeps only the marks */
    for (uint32_t cell = 0; cell < PROJ_Z * PROJ_PHI; cell++) {
        const projection_cell *c = &job->cells[cell];
        bool hit = false;
        for (uint32_t i = 0; i < job->sphere_count && !hit; i++) {
            const cone *k = &cones[i];
            if (k->inside) { hit = true; break; }
            float reach = k->half + c->angle;
            if (reach >= PM_PI) { hit = true; break; }
            float dot = v3_dot(c->centre, k->axis);
            float threshold = k->cos_half * c->cos_angle - k->sin_half * c->sin_angle;
            if (dot > threshold + 1e-5f) hit = true;
            else if (dot >= threshold - 1e-5f) hit = acosf(pm_maxf(-1.f, pm_minf(1.f, dot))) <= reach;
        }
        marks[count] = cell;
        count += hit;
    }
    free(cones);
    l->marked = pm_malloc(sizeof *l->marked * (count ? count : 1), "projection map");
    if (!l->marked) { atomic_store(&job->failed, true); return; }
    for (uint32_t i = 0; i < count; i++) {
        uint32_t iz = marks[i] / PROJ_PHI, iphi = marks[i] % PROJ_PHI;
        projection_start *m = &l->marked[i];
        m->z_top = 1.f - 2.f * ((float)iz / PROJ_Z);
        pm_sincos_turn((float)iphi * (1.f / PROJ_PHI), &m->sin_phi, &m->cos_phi);
    }
    l->marked_count = count;
}

/* A direction from the source: uniform over the marked cells when a projection map exists,
 * else uniform over the sphere. Returns the solid angle sampled (the pdf is 1 / that). */
static float sample_direction(const light_source *l, bool aimed, pm_rng *rng, vec3 *dir) {
    if (aimed) {
        /* every sphere's own direction marks its cell, so a map has a cell whenever it exists */
        assert(l->marked_count > 0);
        if (!l->marked_count) {
            *dir = v3(0.f, 0.f, 1.f);
            return 0.f; /* no flux */
        }
        uint32_t pick = (uint32_t)(pm_rng_float(rng) * l->marked_count);
        if (pick >= l->marked_count) pick = l->marked_count - 1;
        *dir = cell_direction_from(&l->marked[pick], pm_rng_float(rng), pm_rng_float(rng));
        return 4.f * PM_PI * (float)l->marked_count / (PROJ_Z * PROJ_PHI);
    }
    *dir = pm_sample_sphere(pm_rng_float(rng), pm_rng_float(rng));
    return 4.f * PM_PI;
}

/* The part of a surface record that emission needs (point, unit face normal, centroid for the
 * ray origin, emission, sides) on emitter number e, whose record is r: one photon per call, so
 * the full pm_scene_surface would cost a measurable share of the pass. */
static void emitter_point(const pass *ps, uint32_t e, const pm_emitter *r, float b1, float b2, pm_surface *sf) {
    vec3 p0 = r->p0, p1 = r->p1, p2 = r->p2;
    /* only the fields emission reads are set: clearing the whole record, once per photon, showed in profiles */
    sf->p = pm_emitter_point(r, b1, b2);
    sf->ng = sf->ns = r->normal;
    sf->centroid = v3_scale(v3_add(v3_add(p0, p1), p2), 1.f / 3.f);
    sf->emission = pm_emitter_emitted_at(ps->scene, e, b1, b2);
    sf->double_sided = r->double_sided;
}

/* A start for light travelling along dir, uniform over the shadow the core's box casts on the
 * plane across the scene behind it, from two numbers in [0, 1) (drawn, or the emission guide's):
 * a line along dir enters a box through exactly one face that faces the light, so a face picked
 * by its area across dir (|dir . normal| x area, by the first number, which is then rescaled to
 * [0, 1)) and a uniform point on it give a uniform point of that shadow, which is then carried
 * back along dir to the plane. A start outside that shadow would miss the whole core, and most of
 * the disc around it is such: the disc across a room's ground of 120 m lit at 40 degrees is 2.4
 * times its shadow, and such photons cost their emission and a ray each for nothing.
 * box_shadow_across sets the faces up once per light; box_start draws a start, and returns the
 * shadow's area (0 for a box with no area across dir: the caller then takes the disc). */
static box_shadow box_shadow_across(const pm_scene *s, vec3 dir) {
    vec3 lo = s->core_min, hi = s->core_max, ext = v3_sub(hi, lo);
    float wx = fabsf(dir.x) * ext.y * ext.z, wy = fabsf(dir.y) * ext.x * ext.z, wz = fabsf(dir.z) * ext.x * ext.y;
    /* the face at the low side of an axis faces the light when dir runs up that axis */
    vec3 face = v3(dir.x > 0.f ? lo.x : hi.x, dir.y > 0.f ? lo.y : hi.y, dir.z > 0.f ? lo.z : hi.z);
    box_shadow b = {
        .total = wx + wy + wz,
        .weight = {wx, wy, wz},
        .skip = {0.f, wx, wx},
        .skip_more = {0.f, 0.f, wy},
        .corner = {v3(face.x, lo.y, lo.z), v3(lo.x, face.y, lo.z), v3(lo.x, lo.y, face.z)},
        .edge_a = {v3(0.f, ext.y, 0.f), v3(ext.x, 0.f, 0.f), v3(ext.x, 0.f, 0.f)},
        .edge_b = {v3(0.f, 0.f, ext.z), v3(0.f, 0.f, ext.z), v3(0.f, ext.y, 0.f)},
    };
    b.usable = b.total > 0.f && isfinite(b.total);
    /* a face with no weight is never picked: a pick past the last weighted face stays on it */
    b.below_second = wy + wz > 0.f ? wx : INFINITY;
    b.below_third = wz > 0.f ? pm_maxf(wx + wy, b.below_second) : INFINITY;
    return b;
}

static float box_start(const pm_scene *s, const box_shadow *b, vec3 dir, float u1, float u2, float back, vec3 *o) {
    if (!b->usable) return 0.f;
    float pick = u1 * b->total;
    /* the face by compares, not branches: the pick is random */
    int k = (pick >= b->below_second) + (pick >= b->below_third);
    float a = pm_minf(pm_maxf(pick - b->skip[k] - b->skip_more[k], 0.f) / b->weight[k], 0.99999994f);
    vec3 p = v3_add(v3_madd(b->corner[k], b->edge_a[k], a), v3_scale(b->edge_b[k], u2));
    /* onto the plane `back` behind the centre, across dir */
    *o = v3_madd(p, dir, -(v3_dot(v3_sub(p, s->center), dir) + back));
    return b->total;
}

/* Where light travelling along dir starts: a point on a plane across the scene, behind it.
 * Without targets, for a directional light (box) uniform over the core box's shadow on that plane
 * (box_start; a degenerate box falls back to the disc), for the sky uniform on a disc of the
 * scene's bounding radius: the shadow's area varies with the direction (a flat landscape's from
 * its whole top down to a thin strip seen edge on), so sky photons starting in it would carry
 * powers that vary as much, and the many edge-on ones, weak but each a full path of rays, cost
 * more than they bring (photons alone on window-room under a white sky: relMSE 0.0031 against the
 * disc's 0.0025 at equal rays); a sun's shadow is one area, its photons keep one power. With
 * targets (the caustic pass), uniform on
 * the union of the targets' projected discs: pick a disc by area, a point in it, and divide by
 * how many discs cover that point, so overlaps are not counted twice.
 * Returns the area that the sampling stands for: flux = irradiance x that area. */
static float parallel_start(const pass *ps, vec3 dir, const box_shadow *box, pm_rng *rng, const float *guided, vec3 *o) {
    const pm_scene *s = ps->scene;
    float R = s->radius > 0.f ? s->radius : 1.f, x, y, area, back = 1.01f * R;
    bool targets = ps->caustic_pass && ps->targets && ps->target_count;
    if (!targets) {
        float u1 = guided ? guided[0] : pm_rng_float(rng), u2 = guided ? guided[1] : pm_rng_float(rng);
        area = box ? box_start(s, box, dir, u1, u2, back, o) : 0.f;
        if (area > 0.f) return area;
        vec3 t, b;
        v3_basis(dir, &t, &b);
        pm_sample_disc(u1, u2, &x, &y);
        *o = v3_add(v3_madd(s->center, dir, -back), v3_add(v3_scale(t, x * R), v3_scale(b, y * R)));
        return PM_PI * R * R;
    }
    vec3 t, b;
    v3_basis(dir, &t, &b);
    float u = pm_rng_float(rng);
    pm_sample_disc(pm_rng_float(rng), pm_rng_float(rng), &x, &y);
    const sphere *c = &ps->targets[pm_cdf_interval(ps->target_cdf, ps->target_count, u)];
    vec3 rel = v3_sub(c->center, s->center);
    x = v3_dot(rel, t) + x * c->radius;
    y = v3_dot(rel, b) + y * c->radius;
    int cover = 0;
    for (uint32_t j = 0; j < ps->target_count; j++) {
        vec3 rj = v3_sub(ps->targets[j].center, s->center);
        float dx = x - v3_dot(rj, t), dy = y - v3_dot(rj, b), r = ps->targets[j].radius;
        cover += dx * dx + dy * dy <= r * r;
    }
    area = ps->target_area / (float)(cover > 0 ? cover : 1); /* cover >= 1 but for rounding */
    back = ps->target_reach;
    *o = v3_add(v3_madd(s->center, dir, -back), v3_add(v3_scale(t, x), v3_scale(b, y)));
    return area;
}

/* Starts one photon from source l: origin, direction and flux (before dividing by the photon
 * count and the pick probability). Returns false when it carries nothing. guided: the emission
 * guide's two numbers for the start on the disc across the scene (directional light, sky) or the
 * direction (point, spot), NULL to draw them. Out of line: inlined into the chunk's loop, it takes
 * the inliner's budget from the bounce's pm_scene_surface_lean (3% of a Cornell box's pass). */
static __attribute__((noinline)) bool emit(const pass *ps, const light_source *l, pm_rng *rng, const float *guided,
                                           const float *guided_direction, vec3 *o, vec3 *d, vec3 *flux) {
    const pm_scene *s = ps->scene;
    bool aimed = ps->caustic_pass && l->marked; /* projection maps aim caustic photons only */
    if (l->kind == SOURCE_EMITTERS) {
        float pick_pdf;
        uint32_t e = pm_scene_pick_emitter_index(s, pm_rng_float(rng), &pick_pdf);
        float r1 = sqrtf(pm_rng_float(rng)), r2 = pm_rng_float(rng);
        const pm_emitter *r = &s->emitter_records[e];
        if (pick_pdf <= 0.f || r->area <= 0.f) return false;
        vec3 n = r->normal;
        /* an aimed direction is tested before the point is made: one that leaves through the
         * emitter's back carries nothing (a lamp modelled as a sphere turns half of its aimed
         * starts away), and the numbers are drawn in the same order either way */
        float omega = 0.f, cos_t = 0.f;
        if (aimed) {
            omega = sample_direction(l, aimed, rng, d);
            cos_t = v3_dot(n, *d);
            if (r->double_sided) cos_t = fabsf(cos_t);
            if (cos_t <= 0.f) return false;
        }
        pm_surface sf;
        emitter_point(ps, e, r, r1 * (1.f - r2), r1 * r2, &sf);
        if (v3_is_black(sf.emission)) return false; /* a black texel, a cut-out */
        float area = r->area;
        if (aimed) {
            *flux = v3_scale(sf.emission, cos_t * area / pick_pdf * omega);
            n = pm_facing(n, *d);
        } else {
            if (sf.double_sided && pm_rng_float(rng) < 0.5f) n = v3_neg(n);
            *d = pm_sample_cosine(n, pm_rng_float(rng), pm_rng_float(rng));
            *flux = v3_scale(sf.emission, PM_PI * area / pick_pdf * (sf.double_sided ? 2.f : 1.f));
        }
        *o = pm_offset_surface_origin(sf.p, sf.centroid, n, s->ray_scale);
        return true;
    }
    if (l->kind == SOURCE_PUNCTUAL) {
        const pm_light *pl = &s->lights[l->light];
        if (pl->type == PM_LIGHT_DIRECTIONAL) {
            *d = pl->direction;
            *flux = v3_scale(pl->intensity, parallel_start(ps, *d, &l->shadow, rng, guided, o));
            return true;
        }
        *o = pl->position;
        if (pl->type == PM_LIGHT_SPOT && !aimed) {
            /* uniform in the outer cone */
            float uz = guided ? guided[0] : pm_rng_float(rng), uphi = guided ? guided[1] : pm_rng_float(rng);
            float z = 1.f - uz * (1.f - pl->cos_outer), r = sqrtf(pm_maxf(0.f, 1.f - z * z));
            float sin_phi, cos_phi; /* phi = 2 pi uphi */
            pm_sincos_turn(uphi, &sin_phi, &cos_phi);
            vec3 t, b;
            v3_basis(pl->direction, &t, &b);
            *d = v3_add(v3_scale(pl->direction, z), v3_add(v3_scale(t, r * cos_phi), v3_scale(b, r * sin_phi)));
            float omega = 2.f * PM_PI * (1.f - pl->cos_outer);
            *flux = v3_scale(pl->intensity, pm_spot_falloff(pl, *d) * omega);
            return !v3_is_black(*flux);
        }
        float omega;
        if (guided && !aimed) {
            *d = pm_sample_sphere(guided[0], guided[1]);
            omega = 4.f * PM_PI;
        } else {
            omega = sample_direction(l, aimed, rng, d);
        }
        float falloff = pl->type == PM_LIGHT_SPOT ? pm_spot_falloff(pl, *d) : 1.f;
        *flux = v3_scale(pl->intensity, falloff * omega);
        return falloff > 0.f;
    }
    /* sky: a direction (drawn from the map, if any), then a start behind the scene as for a
     * directional light */
    if (s->sky_map) {
        vec3 toward;
        float pdf;
        float u1 = guided_direction ? guided_direction[0] : pm_rng_float(rng);
        float u2 = guided_direction ? guided_direction[1] : pm_rng_float(rng);
        vec3 radiance = pm_sky_map_sample(s->sky_map, u1, u2, &toward, &pdf);
        if (!(pdf > 0.f)) return false;
        *d = v3_neg(toward);
        *flux = v3_scale(v3_mul(s->sky_radiance, radiance), parallel_start(ps, *d, NULL, rng, guided, o) / pdf);
        return true;
    }
    float u1 = guided_direction ? guided_direction[0] : pm_rng_float(rng);
    float u2 = guided_direction ? guided_direction[1] : pm_rng_float(rng);
    *d = v3_neg(pm_sample_sphere(u1, u2));
    *flux = v3_scale(s->sky_radiance, 4.f * PM_PI * parallel_start(ps, *d, NULL, rng, guided, o));
    return true;
}

/* A chunk's view of its thread's record arena: it appends from `start`; `room` is where the
 * slow path must run next (the arena is full, or the chunk's next CHUNK records are to be
 * counted against the pass's storage bound). */
typedef struct { pm_light_vertex *data; uint32_t count, capacity; } vertex_list;
typedef struct { pm_photon *data; size_t count, capacity, start, counted, room; bool failed; pass *ps; uint32_t *guide_counts; vertex_list *vertices; } photon_list;
typedef struct { pm_camera_splat *data; uint32_t count, capacity; } splat_list;


static bool precompute_irradiance(pm_photon_maps *maps, const pm_scene *s, const pm_accel *a,
                                  const pm_photon_settings *settings, int threads);

/* The slow path of push: counts the chunk's next CHUNK records against the pass's storage bound
 * (per chunk, so whether the bound is crossed does not depend on the threads) and doubles the
 * arena when it is full. False (the pass has failed) past the bound or when memory runs out. */
static bool make_room(photon_list *list) {
    if (list->failed) return false;
    if (list->count == list->start + list->counted) {
        uint64_t records = atomic_fetch_add(&list->ps->records, CHUNK) + CHUNK;
        if (records > list->ps->record_limit) {
            pm_memory_refuse(4 * records * sizeof(pm_photon), "photon records of one pass, their arenas and merged copies");
            list->failed = true;
            atomic_store(&list->ps->out_of_memory, true);
            return false;
        }
        list->counted += CHUNK;
    }
    if (list->count == list->capacity) {
        size_t capacity = list->capacity ? 2 * list->capacity : 4 * CHUNK;
        pm_photon *grown = pm_realloc(list->data, sizeof(pm_photon) * capacity, "photon records of a thread");
        if (!grown) { list->failed = true; atomic_store(&list->ps->out_of_memory, true); return false; }
        list->data = grown;
        list->capacity = capacity;
    }
    size_t counted_end = list->start + list->counted;
    list->room = counted_end < list->capacity ? counted_end : list->capacity;
    return true;
}

/* Inline, the slow path out of line: a record at every diffuse hit. */
enum { RECORD_AHEAD = 16 }; /* 5 lines: 8, 16 and 32 measured alike */
static inline __attribute__((always_inline)) void push(photon_list *list, vec3 p, vec3 n, vec3 d, vec3 power, int path) {
    if (list->count == list->room && !make_room(list)) return;
    /* a pass's records outgrow the caches (a few MB), and each write waits for its line: asked
     * for RECORD_AHEAD records ahead (an address past the arena is harmless to a prefetch) */
    __builtin_prefetch((const void *)((uintptr_t)(list->data + list->count) + RECORD_AHEAD * sizeof(pm_photon)), 1, 3);
    pm_photon_set(&list->data[list->count++], p, n, d, power, path);
}

static uint32_t pick_source(const pass *ps, float u, float *pdf) {
    uint32_t lo = pm_cdf_interval(ps->source_cdf, ps->source_count, u);
    *pdf = ps->source_cdf[lo + 1] - ps->source_cdf[lo];
    return lo;
}

/* The rest of a lean hit record (shading normal, centroid) once the path goes on from the hit;
 * returns the shading normal on the side of ng, the side the path leaves. */
static inline vec3 complete_shading(const pm_scene *s, const pm_hit *h, bool shading_left, vec3 ng, pm_surface *sf) {
    if (shading_left) pm_scene_surface_shading(s, h->tri, h->b1, h->b2, sf);
    return v3_dot(sf->ns, ng) < 0.f ? v3_neg(sf->ns) : sf->ns;
}

/* Light tracing at a caustic photon's diffuse or glossy hit: where the camera sees the point
 * directly, the radiance the photon reflects toward it, f x power x cos x importance, goes to
 * its pixel. This is the particle tracer's estimate of the caustic seen directly, exact with no
 * radius, so the progressive mode uses it instead of statistics at directly seen visible points
 * (which sample one point of the pixel per iteration: on a sharp caustic that is most of their
 * error). ng faces the side the photon arrived from; a lean record (*shading_left) is completed
 * only for a photon the camera can see. */
static void splat_to_camera(pass *ps, splat_list *out, const pm_hit *h, bool *shading_left, pm_surface *sf, vec3 ng,
                            vec3 d, vec3 power, uint64_t *rays) {
    pm_camera_connection c;
    if (!pm_camera_connect(&ps->splat_view, sf->p, &c)) return;
    float cos_x = v3_dot(ng, c.to_camera);
    if (!(cos_x > 0.f)) return; /* the camera sees the other side */
    vec3 ns = complete_shading(ps->scene, h, *shading_left, ng, sf);
    *shading_left = false;
    vec3 f = pm_vertex_f(sf, PM_LOBE_NONSPECULAR, ns, c.to_camera, v3_neg(d));
    vec3 l = v3_scale(v3_mul(f, power), cos_x * c.importance);
    if (v3_is_black(l) || !v3_is_finite(l)) return;
    vec3 o = pm_surface_origin(sf, ng, ps->scene->ray_scale);
    float reach = ps->splat_view.camera.orthographic ? c.distance : v3_length(v3_sub(ps->splat_view.camera.position, o));
    (*rays)++;
    if (pm_accel_occluded(ps->accel, o, c.to_camera, reach)) return;
    if (out->count == out->capacity) {
        uint32_t capacity = out->capacity ? 2 * out->capacity : 256;
        pm_camera_splat *grown = pm_realloc(out->data, capacity * sizeof *grown, "camera splats of a chunk");
        if (!grown) { atomic_store(&ps->out_of_memory, true); return; }
        out->data = grown;
        out->capacity = capacity;
    }
    pm_camera_splat *sp = &out->data[out->count++];
    sp->pixel = c.pixel;
    sp->rgb[0] = l.x;
    sp->rgb[1] = l.y;
    sp->rgb[2] = l.z;
}

/* One photon in flight: what its next bounce needs besides its ray. */
typedef struct {
    pm_rng rng;
    vec3 power;
    int bounce, specular_bounces;
    bool diffuse_seen;
    bool scattered;         /* met a surface that turned it (a thin wall crossed straight does not): else its records are direct light */
    bool first_hit_skipped; /* its light is punctual and the reader traces its first hits: no record there */
    bool punctual;          /* its light is a punctual light's */
    bool punctual_specular; /* ... and a mirror or glass scattered it first (PM_PATH_PUNCTUAL_SPECULAR) */
    uint32_t light;         /* the scene light of a punctual light's photon */
    uint32_t guide_cell[2]; /* the emission guide's slots and cells it left from (guided, guided_direction), UINT32_MAX where unguided */
} photon_path;

/* Starts photon number i of the pass (its own random stream): false when it carries nothing. */
/* The pass stores punctual-specular records alone (pm_photon_tracer_tag_punctual_specular): a
 * global pass asked to; the caustic pass is never so restricted. */
static inline bool tagged_only(const pass *ps) { return ps->only_punctual_specular && !ps->caustic_pass; }

static bool start_photon(const pass *ps, pm_rng_family streams, uint64_t i, photon_path *p, vec3 *o, vec3 *d,
                         uint32_t *guide_counts) {
    p->rng = pm_rng_member(streams, i);
    float source_pdf;
    const light_source *l = &ps->sources[pick_source(ps, pm_rng_float(&p->rng), &source_pdf)];
    /* only a punctual light's light can be tagged, and the emitters' (found by area samples) make
     * no light vertices: the others' carry nothing such a pass keeps */
    if (tagged_only(ps) ? l->kind != SOURCE_PUNCTUAL : ps->light_vertex_pass && l->kind == SOURCE_EMITTERS) return false;
    vec3 flux;
    float pair[2][2], weight = 1.f;
    int slot[2] = {l->guided, l->guided_direction};
    p->guide_cell[0] = p->guide_cell[1] = UINT32_MAX;
    if (ps->guide && l->guided >= 0) {
        /* all guided numbers uniform, or all learned: one mixture over the whole photon (guide.h) */
        bool uniform = pm_rng_float(&p->rng) < PM_GUIDE_UNIFORM;
        double learned = 1.0;
        for (int k = 0; k < 2 && slot[k] >= 0; k++) {
            float u_cell = pm_rng_float(&p->rng);
            pair[k][0] = pm_rng_float(&p->rng);
            pair[k][1] = pm_rng_float(&p->rng);
            uint32_t cell = uniform ? pm_guide_cell_of(pair[k][0], pair[k][1])
                                    : pm_guide_pick(ps->guide, (uint32_t)slot[k], u_cell, &pair[k][0], &pair[k][1]);
            learned *= pm_guide_density(ps->guide, (uint32_t)slot[k], cell);
            p->guide_cell[k] = (uint32_t)slot[k] * PM_GUIDE_CELL_COUNT + cell;
            guide_counts[p->guide_cell[k]]++;
        }
        weight = (float)(1.0 / (PM_GUIDE_UNIFORM + (1.0 - PM_GUIDE_UNIFORM) * learned));
    }
    if (source_pdf <= 0.f || !emit(ps, l, &p->rng, p->guide_cell[0] != UINT32_MAX ? pair[0] : NULL,
                                   p->guide_cell[1] != UINT32_MAX ? pair[1] : NULL, o, d, &flux))
        return false;
    p->first_hit_skipped = ps->punctual_first_hits_skipped && l->kind == SOURCE_PUNCTUAL;
    p->punctual = l->kind == SOURCE_PUNCTUAL;
    p->light = l->kind == SOURCE_SKY ? PM_LIGHT_VERTEX_SKY : l->light;
    p->punctual_specular = false;
    p->power = v3_scale(flux, weight / ((float)ps->photons * source_pdf));
    p->bounce = p->specular_bounces = 0;
    p->diffuse_seen = p->scattered = false;
    return true;
}

/* A light vertex where photon p first met a diffuse or glossy surface (ng facing where it came from). */
static void push_light_vertex(photon_list *list, const pm_surface *sf, vec3 ng, vec3 to_light, const pm_hit *h, const photon_path *p,
                              float keep) {
    vertex_list *v = list->vertices;
    if (v->count == v->capacity) {
        uint32_t capacity = v->capacity ? 2 * v->capacity : 256;
        pm_light_vertex *grown = pm_realloc(v->data, capacity * sizeof *grown, "light vertices of a chunk");
        if (!grown) { list->failed = true; return; }
        v->data = grown;
        v->capacity = capacity;
    }
    v->data[v->count++] = (pm_light_vertex){sf->p, ng, to_light, v3_scale(p->power, 1.f / keep), h->tri, p->light, h->b1, h->b2, keep};
}

/* A guided photon's hit at q (arriving on the side ng faces) where a camera point read photons in
 * the last iteration that read any: counted useful for the cells it left from. A light vertex pass
 * asks for the mark on the hit's own side: its vertices must lie where eye vertices join them,
 * not on the roof above a ceiling. A global pass takes either side: the sky's start and direction
 * are learned apart, and counting only the room's own surfaces narrows both to the opening while
 * their product still pairs starts and directions that miss it; the photons drawn uniformly that
 * do reach the room then weigh up to ten times the rest, which a density estimate, with no
 * weighing against another way, shows as noise (photons alone on the solid window room: relMSE
 * 2 to 5 times as high on seeds 5-8, the means off by up to 1.1%). */
static inline void count_useful(const pass *ps, const photon_path *p, photon_list *list, vec3 q, vec3 ng) {
    if (p->guide_cell[0] == UINT32_MAX) return;
    if (!(ps->light_vertex_pass ? pm_marks_test_facing(ps->marks, q, ng) : pm_marks_test(ps->marks, q))) return;
    list->guide_counts[ps->guide_cells + p->guide_cell[0]]++;
    if (p->guide_cell[1] != UINT32_MAX) list->guide_counts[ps->guide_cells + p->guide_cell[1]]++;
}

/* What photon p does where its ray (*o, *d) hit h: a record (and a camera splat) at a diffuse or
 * glossy surface, then Russian roulette; true with its next ray in *o, *d, false when the path ends. */
static bool photon_bounce(pass *ps, photon_path *p, const pm_hit *h, vec3 *o, vec3 *d, photon_list *list,
                          splat_list *splats, uint64_t *rays) {
    const pm_scene *s = ps->scene;
    pm_rng *rng = &p->rng;
    pm_surface sf;
    bool shading_left = pm_scene_surface_lean(s, h->tri, h->b1, h->b2, &sf);
    if (ps->volumes) p->power = v3_mul(p->power, pm_volume_transmittance(s, &sf, *d, h->t));
    vec3 ng = pm_facing(sf.ng, v3_neg(*d));
    if (ps->light_vertex_pass) {
        if (!p->scattered && pm_vertex_has_nonspecular(&sf)) {
            float keep = pm_light_vertex_keep(ps->vertex_worth, sf.p);
            if (keep >= 1.f || (keep > 0.f && pm_rng_float(rng) < keep)) push_light_vertex(list, &sf, ng, v3_neg(*d), h, p, keep);
            count_useful(ps, p, list, sf.p, ng);
        }
        /* only a thin wall crossed straight lets the photon on (below) */
        if (!s->analysis.has_thin_glass) return false;
    } else if (pm_vertex_has_nonspecular(&sf)) {
        if (ps->caustic_pass) {
            /* stored, and the roulette below decides: a non-specular bounce ends the caustic
             * path, while the specular and near-specular parts of a mixed surface carry it on
             * (L S+ D is stored again at the next non-specular surface it reaches) */
            if (p->specular_bounces > 0) {
                push(list, sf.p, ng, *d, p->power, PM_PATH_CAUSTIC);
                if (ps->splat) splat_to_camera(ps, splats, h, &shading_left, &sf, ng, *d, p->power, rays);
            }
        } else {
            /* past thin walls alone a photon is still direct light, as direct light's rays cross them (thin.h) */
            int path = !p->scattered                                        ? PM_PATH_DIRECT
                       : p->punctual_specular && ps->tag_punctual_specular ? PM_PATH_PUNCTUAL_SPECULAR
                       : p->diffuse_seen                                   ? PM_PATH_INDIRECT
                                                                           : PM_PATH_CAUSTIC;
            bool kept = !tagged_only(ps) || path == PM_PATH_PUNCTUAL_SPECULAR;
            if ((p->scattered || !p->first_hit_skipped) && kept) push(list, sf.p, ng, *d, p->power, path);
            /* stored or not (a punctual light's first hit, which the reader traces, shows the way in too) */
            count_useful(ps, p, list, sf.p, ng);
        }
    }
    /* the vertex kernel: the part to go on with, its sample and the survival (vertex.h); the
     * caustic pass ends at a non-specular choice, as L S+ D was stored above (and where nothing
     * specular or near-specular could carry it on, before the shading record is completed) */
    if (ps->caustic_pass && !pm_vertex_has_specular(&sf)) return false;
    /* the choice reads the shading normal on a glossy lobe only; past it, an absorbed photon needs none */
    const pm_vertex_policy *policy = ps->caustic_pass ? &caustic_photon_policy : &photon_policy;
    if (sf.glossy) {
        complete_shading(s, h, shading_left, ng, &sf);
        shading_left = false;
    }
    pm_vertex_ray ray;
    if (!pm_vertex_choose(&sf, *d, p->bounce, policy, rng, &ray)) return false;
    complete_shading(s, h, shading_left, ng, &sf);
    if (!pm_vertex_sample_chosen(&sf, *d, p->bounce, policy, rng, s->ray_scale, &ray)) return false;
    p->power = v3_mul(p->power, ray.weight); /* flux: no radiance_scale across a refraction */
    *d = ray.direction;
    *o = ray.origin;
    if (ray.straight) return true; /* no caustic: direct light crosses thin walls too */
    if (ps->light_vertex_pass) return false;
    if (!p->scattered) p->punctual_specular = p->punctual && ray.lobe == PM_LOBE_SPECULAR;
    p->scattered = true;
    if (ray.lobe == PM_LOBE_NONSPECULAR) p->diffuse_seen = true;
    else p->specular_bounces++;
    /* a path that can no longer be tagged carries nothing a pass of tagged records alone keeps */
    return !(tagged_only(ps) && !p->punctual_specular);
}

/* A chunk's photons in waves of WAVE (settings->wave if smaller): a wave starts with that many
 * photons (fewer at the end of the chunk), then repeats two phases while any path goes on: every
 * ray of the wave to Embree, in packets of PM_ACCEL_PACKET, then every hit's bounce, the paths
 * that go on packed to the front. Each phase is one tight loop (Embree's code and ours each stay
 * hot, their branches predicted among their own), and Embree answers a packet of unrelated rays
 * faster than one call each. Each photon keeps its own random stream, so its path is what it would
 * be traced alone; only the order of the chunk's records depends on the waves, the same at any
 * thread count. */
enum { WAVE = PM_PHOTON_WAVE, PREFETCH_ROWS = 16, PREFETCH_CORNERS = 8, PREFETCH_TEXELS = 4, EMIT_AHEAD = 8 };
typedef struct {
    vec3 origin[WAVE], direction[WAVE];
    photon_path path[WAVE];
    bool hit[WAVE];
    pm_hit hits[WAVE];
} photon_wave;

/* Prefetches hit j of a wave of n, if it is one: its triangle's row, its corners or its texels */
typedef enum { PREFETCH_ROW, PREFETCH_CORNER, PREFETCH_TEXEL } prefetch_stage;
static inline void prefetch_hit(const pm_scene *s, const photon_wave *w, size_t n, size_t j, prefetch_stage stage) {
    if (j >= n || !w->hit[j]) return;
    const pm_hit *h = &w->hits[j];
    if (stage == PREFETCH_CORNER) pm_scene_prefetch_corners(s, h->tri);
    else if (stage == PREFETCH_ROW) pm_scene_prefetch_triangle(s, h->tri);
    else pm_scene_prefetch_texels(s, h->tri, h->b1, h->b2);
}

/* Photon i's emitter, asked for ahead of its start on emitter tables larger than the caches: its
 * pick is drawn from its own stream as start_photon and emit draw it (the source, then the
 * emitter), and its chain of loads (the cut point, the CDF, the emitter's record), each a miss
 * waiting on the last, is split over two calls: far ahead the cut point's line is asked for, near
 * ahead (the cut point then cached) the CDF's and the record's. A photon of another kind of source
 * asks for nothing; a peek that drew differently from the start would only fetch in vain. */
static void prefetch_emitter(const pass *ps, pm_rng_family streams, uint64_t i, bool near) {
    pm_rng rng = pm_rng_member(streams, i);
    float pdf;
    const light_source *l = &ps->sources[pick_source(ps, pm_rng_float(&rng), &pdf)];
    const pm_scene *s = ps->scene;
    uint32_t n = s->emitter_count;
    if (l->kind != SOURCE_EMITTERS || n <= PM_CDF_SEARCH_MAX) return;
    const uint32_t *cut = &s->emitter_cut[pm_cdf_cut_slot(n, pm_rng_float(&rng))];
    if (!near) {
        __builtin_prefetch(cut);
        return;
    }
    uint32_t lo = *cut;
    __builtin_prefetch(&s->emitter_cdf[lo + 1]);
    __builtin_prefetch(&s->emitter_records[lo]);
    __builtin_prefetch((const char *)&s->emitter_records[lo] + sizeof(pm_emitter) - 1);
}

static void trace_chunk(void *ctx, size_t chunk, int thread) {
    pass *ps = ctx;
    struct record_arena *arena = &ps->arenas[thread];
    photon_list list = {arena->data, arena->count, arena->capacity, arena->count, 0, arena->count, false, ps,
                        ps->guide ? ps->guide_counts + (size_t)thread * 2 * ps->guide_cells : NULL, NULL};
    splat_list splats = {NULL, 0, 0};
    vertex_list vertices = {NULL, 0, 0};
    list.vertices = &vertices;
    if (atomic_load(&ps->out_of_memory)) return; /* the pass has failed: no use tracing on */
    /* the first chunk always runs: an iteration with no photon at all would bias its average */
    if (chunk > 0 && ps->deadline > 0.0 && pm_now_seconds() > ps->deadline) {
        ps->chunk_skipped[chunk] = true;
        return;
    }
    photon_wave wave, *w = &wave; /* 20 KB of the worker's stack */
    uint64_t first = (uint64_t)chunk * CHUNK, last = first + CHUNK < ps->photons ? first + CHUNK : ps->photons;
    uint64_t rays = 0, dropped = 0, next = first;
    int max_bounces = ps->settings->max_bounces;
    size_t wave_size = ps->settings->wave > 0 && ps->settings->wave < WAVE ? (size_t)ps->settings->wave : WAVE;
    pm_rng_family streams = pm_rng_family_for(ps->seed, ps->caustic_pass ? 0x51u : 0x61u);
    while (next < last) {
        size_t n = 0;
        while (n < wave_size && next < last) {
            if (atomic_load_explicit(&ps->out_of_memory, memory_order_relaxed)) {
                next = last;
                break;
            }
            /* long paths (a room of albedo 1: 100 bounces a photon) make a chunk long: the
             * deadline is also checked inside it, every 64 photons started */
            if (chunk > 0 && ps->deadline > 0.0 && (next & 63) == 0 && next > first && pm_now_seconds() > ps->deadline) {
                ps->chunk_cut[chunk] = (uint32_t)(last - next);
                next = last;
                break;
            }
            if (ps->cancel && atomic_load_explicit(ps->cancel, memory_order_relaxed)) {
                next = last;
                break;
            }
            if (ps->prefetch_emitters) {
                if (next + 2 * EMIT_AHEAD < last) prefetch_emitter(ps, streams, next + 2 * EMIT_AHEAD, false);
                if (next + EMIT_AHEAD < last) prefetch_emitter(ps, streams, next + EMIT_AHEAD, true);
            }
            if (!start_photon(ps, streams, next++, &w->path[n], &w->origin[n], &w->direction[n], list.guide_counts) ||
                max_bounces < 1)
                continue;
            if (!v3_is_finite(w->path[n].power)) { dropped++; continue; } /* an overflowing light: never stored */
            n++;
        }
        while (n > 0) {
            /* a cancelled pass is thrown away whole: its paths in flight may stop anywhere */
            if (ps->cancel && atomic_load_explicit(ps->cancel, memory_order_relaxed)) {
                next = last;
                break;
            }
            rays += n;
            pm_accel_intersect_packets(ps->accel, n, w->origin, w->direction, false, w->hit, w->hits);
            size_t alive = 0;
            /* on a large mesh the rows of the hits PREFETCH_ROWS ahead and the corners of those
             * PREFETCH_CORNERS ahead are asked for while a hit bounces (pm_scene_prefetch_triangle),
             * the first ones before */
            bool prefetch = ps->prefetch_hits, texels = ps->prefetch_texels;
            for (size_t j = 0; prefetch && j < PREFETCH_ROWS; j++) prefetch_hit(ps->scene, w, n, j, PREFETCH_ROW);
            for (size_t j = 0; prefetch && j < PREFETCH_CORNERS; j++) prefetch_hit(ps->scene, w, n, j, PREFETCH_CORNER);
            for (size_t j = 0; texels && j < PREFETCH_TEXELS; j++) prefetch_hit(ps->scene, w, n, j, PREFETCH_TEXEL);
            for (size_t i = 0; i < n; i++) {
                if (prefetch) {
                    prefetch_hit(ps->scene, w, n, i + PREFETCH_ROWS, PREFETCH_ROW);
                    prefetch_hit(ps->scene, w, n, i + PREFETCH_CORNERS, PREFETCH_CORNER);
                }
                if (texels) prefetch_hit(ps->scene, w, n, i + PREFETCH_TEXELS, PREFETCH_TEXEL);
                photon_path *p = &w->path[i];
                if (!w->hit[i] || !photon_bounce(ps, p, &w->hits[i], &w->origin[i], &w->direction[i], &list, &splats, &rays))
                    continue;
                if (++p->bounce >= max_bounces) continue;
                if (!v3_is_finite(p->power)) { dropped++; continue; } /* an overflowing weight: never stored */
                if (alive != i) {
                    w->path[alive] = *p;
                    w->origin[alive] = w->origin[i];
                    w->direction[alive] = w->direction[i];
                }
                alive++;
            }
            n = alive;
        }
    }
    arena->data = list.data;
    arena->capacity = list.capacity;
    arena->count = list.count;
    ps->chunk_arena[chunk] = (uint32_t)thread;
    ps->chunk_start[chunk] = list.start;
    ps->chunk_counts[chunk] = (uint32_t)(list.count - list.start);
    if (ps->chunk_splats) {
        ps->chunk_splats[chunk] = splats.data;
        ps->chunk_splat_counts[chunk] = splats.count;
    } else {
        free(splats.data);
    }
    if (ps->chunk_vertices) {
        ps->chunk_vertices[chunk] = vertices.data;
        ps->chunk_vertex_counts[chunk] = vertices.count;
    } else {
        free(vertices.data);
    }
    if (list.failed) atomic_store(&ps->out_of_memory, true);
    ps->counters[thread].rays += rays;
    ps->counters[thread].dropped += dropped;
}

/* Concatenates per-chunk lists in chunk order into *data (grown to hold them, *capacity in
 * elements), freeing each chunk's list; *total is their length. With ok false, or when growing
 * fails (false), nothing is copied but the lists are still freed. */
static bool merge_chunks(void **chunk_data, const uint32_t *chunk_counts, size_t chunks, size_t size, void **data,
                         size_t *capacity, size_t *total, bool ok, const char *what) {
    *total = 0;
    for (size_t c = 0; c < chunks; c++) *total += chunk_counts[c];
    if (ok && *total > *capacity) {
        void *grown = pm_realloc(*data, *total * size, what);
        if (grown) {
            *data = grown;
            *capacity = *total;
        } else {
            ok = false;
        }
    }
    size_t at = 0;
    for (size_t c = 0; c < chunks; c++) {
        if (ok && chunk_counts[c]) memcpy((char *)*data + at * size, chunk_data[c], chunk_counts[c] * size);
        at += chunk_counts[c];
        free(chunk_data[c]);
    }
    return ok;
}

/* One kind of a pass's per-chunk output (splats, light vertices) merged by merge_chunks into its
 * buffer, given as its data (returned, perhaps moved), capacity and count: the count is 0 unless
 * the pass is whole and *ok; *ok is false when growing failed (a cancelled pass is no failure). */
static void *merge_output(void **chunk_data, const uint32_t *chunk_counts, size_t chunks, size_t size, void *data,
                          size_t *capacity, size_t *count, bool *ok, bool cancelled, const char *what) {
    size_t total = 0;
    *ok = merge_chunks(chunk_data, chunk_counts, chunks, size, &data, capacity, &total, *ok && !cancelled, what) || cancelled;
    *count = *ok && !cancelled ? total : 0;
    return data;
}

/* Copies the chunks' records out of the thread arenas, in chunk order, into out (grown to
 * hold them); *total is their count. False, with nothing copied, when growing fails. When one
 * arena already holds them all in chunk order from its start (one thread), out and that arena
 * trade buffers instead: the copy, tens of MB a pass, took up to 9% of a one-thread pass
 * (docs/design.md, photonmap). */
static bool merge_records(pass *ps, size_t chunks, pm_photon_buffer *out, size_t *total) {
    *total = 0;
    bool in_place = true;
    uint32_t holder = UINT32_MAX;
    for (size_t c = 0; c < chunks; c++) {
        uint32_t n = ps->chunk_counts[c];
        if (!n) continue;
        if (holder == UINT32_MAX) holder = ps->chunk_arena[c];
        in_place &= ps->chunk_arena[c] == holder && ps->chunk_start[c] == *total;
        *total += n;
    }
    if (in_place && holder != UINT32_MAX && ps->arenas[holder].count == *total) {
        struct record_arena *arena = &ps->arenas[holder];
        pm_photon *data = out->data;
        size_t capacity = out->capacity;
        out->data = arena->data;
        out->capacity = arena->capacity;
        arena->data = data;
        arena->capacity = capacity;
        arena->count = 0;
        return true;
    }
    if (*total > out->capacity) {
        pm_photon *grown = pm_realloc(out->data, *total * sizeof(pm_photon), "merged photon records");
        if (!grown) return false;
        out->data = grown;
        out->capacity = *total;
    }
    size_t at = 0;
    for (size_t c = 0; c < chunks; c++) {
        uint32_t n = ps->chunk_counts[c];
        if (n) memcpy(out->data + at, ps->arenas[ps->chunk_arena[c]].data + ps->chunk_start[c], n * sizeof(pm_photon));
        at += n;
    }
    return true;
}

static void free_chunk_lists(pass *ps) {
    free(ps->chunk_arena);
    free(ps->chunk_start);
    free(ps->chunk_counts);
    free(ps->chunk_skipped);
    free(ps->chunk_cut);
    free(ps->chunk_splats);
    free(ps->chunk_splat_counts);
    free(ps->chunk_vertices);
    free(ps->chunk_vertex_counts);
    ps->chunk_vertices = NULL;
    ps->chunk_vertex_counts = NULL;
    ps->chunk_arena = NULL;
    ps->chunk_start = NULL;
    ps->chunk_counts = NULL;
    ps->chunk_skipped = NULL;
    ps->chunk_cut = NULL;
    ps->chunk_splats = NULL;
    ps->chunk_splat_counts = NULL;
}

/* Traces ps->photons photons in chunks on all threads and merges the chunks' records, in chunk
 * order, into out (grown as needed): the same records at any thread count. */
static bool trace_into(pass *ps, pm_photon_buffer *out, uint64_t *rays) {
    out->count = 0;
    size_t chunks = (size_t)((ps->photons + CHUNK - 1) / CHUNK), lists = chunks ? chunks : 1;
    bool splatting = ps->splat && ps->caustic_pass && ps->splat_out;
    ps->chunk_arena = pm_calloc(lists, sizeof(uint32_t), "photon pass chunk list");
    ps->chunk_start = pm_calloc(lists, sizeof(size_t), "photon pass chunk list");
    ps->chunk_counts = pm_calloc(lists, sizeof(uint32_t), "photon pass chunk list");
    ps->chunk_skipped = pm_calloc(lists, sizeof(bool), "photon pass chunk list");
    ps->chunk_cut = pm_calloc(lists, sizeof(uint32_t), "photon pass chunk list");
    if (splatting) {
        ps->splat_out->count = 0;
        ps->chunk_splats = pm_calloc(lists, sizeof(pm_camera_splat *), "camera splat chunk list");
        ps->chunk_splat_counts = pm_calloc(lists, sizeof(uint32_t), "camera splat chunk list");
    }
    bool vertices = ps->light_vertex_pass && ps->vertex_out;
    if (vertices) {
        ps->vertex_out->count = 0;
        ps->chunk_vertices = pm_calloc(lists, sizeof(pm_light_vertex *), "light vertex chunk list");
        ps->chunk_vertex_counts = pm_calloc(lists, sizeof(uint32_t), "light vertex chunk list");
    }
    if (!ps->chunk_arena || !ps->chunk_start || !ps->chunk_counts || !ps->chunk_skipped || !ps->chunk_cut ||
        (splatting && (!ps->chunk_splats || !ps->chunk_splat_counts)) ||
        (vertices && (!ps->chunk_vertices || !ps->chunk_vertex_counts))) {
        free_chunk_lists(ps);
        return false;
    }
    memset(ps->counters, 0, sizeof ps->counters);
    atomic_store(&ps->out_of_memory, false);
    atomic_store(&ps->records, out->capacity); /* the merged buffer kept from the last pass counts too */
    /* the pass shares the limit with everything admitted before it (film, scene, textures, outputs) */
    ps->record_limit = pm_memory_available() / (4 * sizeof(pm_photon));
    int threads = pm_thread_count(ps->settings->threads);
    for (int t = 0; t < threads; t++) ps->arenas[t].count = 0;
    ps->cancel = pm_parallel_get_cancel();
    pm_parallel_for(threads, chunks, trace_chunk, ps);
    /* A cancelled pass stores nothing and has not failed: whoever cancelled it (a restart, a quit,
     * a signal) discards it, and a record bound it would have crossed later is no error of it. */
    bool cancelled = pm_parallel_cancelled();
    bool ok = cancelled || !atomic_load(&ps->out_of_memory);
    size_t total = 0;
    if (ok && !cancelled) ok = merge_records(ps, chunks, out, &total);
    uint64_t traced = 0;
    for (size_t c = 0; c < chunks; c++)
        if (!ps->chunk_skipped[c])
            traced += ((c + 1) * (uint64_t)CHUNK < ps->photons ? CHUNK : ps->photons - c * (uint64_t)CHUNK) - ps->chunk_cut[c];
    ps->dropped = 0;
    for (int t = 0; t < threads; t++) {
        *rays += ps->counters[t].rays;
        ps->dropped += ps->counters[t].dropped;
    }
    /* the chunks' splats and light vertices in chunk order, as the records: the same at any thread count */
    if (splatting)
        ps->splat_out->data = merge_output((void **)ps->chunk_splats, ps->chunk_splat_counts, chunks, sizeof(pm_camera_splat),
                                           ps->splat_out->data, &ps->splat_out->capacity, &ps->splat_out->count, &ok, cancelled,
                                           "camera splats of a pass");
    if (vertices)
        ps->vertex_out->data = merge_output((void **)ps->chunk_vertices, ps->chunk_vertex_counts, chunks, sizeof(pm_light_vertex),
                                            ps->vertex_out->data, &ps->vertex_out->capacity, &ps->vertex_out->count, &ok, cancelled,
                                            "light vertices of a pass");
    free_chunk_lists(ps);
    if (cancelled) {
        ps->traced = 0;
        return true;
    }
    if (ok && traced < ps->photons) {
        /* cut by the deadline: each stored photon stands for photons / traced of the flux */
        float scale = traced ? (float)((double)ps->photons / (double)traced) : 0.f;
        for (size_t i = 0; i < total; i++) {
            pm_photon *ph = &out->data[i];
            pm_rgbe_encode(v3_scale(pm_photon_power(ph), scale), ph->power);
        }
        if (splatting)
            for (size_t i = 0; i < ps->splat_out->count; i++)
                for (int ch = 0; ch < 3; ch++) ps->splat_out->data[i].rgb[ch] *= scale;
        ps->traced = traced;
    } else {
        ps->traced = ps->photons;
    }
    if (ok) out->count = total;
    return ok;
}

static void free_arenas(pass *ps) {
    for (int i = 0; i < MAX_THREADS; i++) {
        free(ps->arenas[i].data);
        ps->arenas[i].data = NULL;
        ps->arenas[i].count = ps->arenas[i].capacity = 0;
    }
}

/* One pass into a new tree (the classic maps, built once): its arenas are freed before the tree
 * is built, since no pass will reuse them soon. */
static bool run_pass(pass *ps, pm_kdtree *tree, uint64_t *stored, uint64_t *rays, pm_photon_stats *st) {
    double t0 = pm_now_seconds();
    pm_photon_buffer all = {NULL, 0, 0};
    bool traced = trace_into(ps, &all, rays);
    free_arenas(ps);
    if (!traced) { free(all.data); return false; }
    *stored = all.count;
    double t1 = pm_now_seconds();
    int threads = pm_thread_count(ps->settings->threads);
    if (!all.data) all.data = pm_malloc(sizeof(pm_photon), "photon records");
    bool ok = all.data && pm_kdtree_build(tree, all.data, all.count, threads);
    st->kdtree_seconds += pm_now_seconds() - t1;
    st->trace_seconds += t1 - t0;
    return ok;
}

struct pm_photon_tracer {
    const pm_scene *scene;
    pm_photon_settings settings;
    light_source *sources;
    uint32_t source_count;
    float *cdf;
    sphere *spheres;
    uint32_t sphere_count;
    float *target_cdf;
    pass ps;                   /* the pass template: sources, targets; photons and seed set per trace */
    bool global_possible, caustic_possible;
    double projection_fraction;
    double deadline;           /* of the time budget, 0 = none */
    uint32_t guided_sources;   /* sources the emission guide may steer (directional, sky, point, spot) */
    uint32_t *source_of_light; /* per scene light, its source */
    int sky_source;            /* the sky's source, -1 without a sky */
    pm_guide *guide;           /* set by pm_photon_tracer_set_guide: learns from each global pass */
    /* the guide as the last light vertex pass drew from it (the passes after it teach the guide
     * while its vertices are joined), for their density */
    pm_guide vertex_guide;
};

static float source_weight(const light_source *l) {
    return (float)fmax(v3_luminance(l->power), 1e-3 * v3_max_component(l->power));
}

pm_photon_tracer *pm_photon_tracer_create(const pm_scene *s, const pm_accel *a, const pm_photon_settings *settings) {
    pm_photon_tracer *t = pm_calloc(1, sizeof *t, "photon tracer");
    if (!t) return NULL;
    t->scene = s;
    t->settings = *settings;
    /* the emitter set, every punctual light and the sky: at most light_count + 2 sources */
    t->sources = pm_malloc(sizeof(light_source) * ((size_t)s->light_count + 2), "photon light sources");
    t->cdf = pm_malloc(sizeof(float) * ((size_t)s->light_count + 3), "photon light sources");
    if (!t->sources || !t->cdf) { pm_photon_tracer_destroy(t); return NULL; }
    uint32_t source_count = build_sources(s, t->sources);
    t->source_count = source_count;
    t->source_of_light = pm_calloc(s->light_count ? s->light_count : 1, sizeof *t->source_of_light, "photon light sources");
    if (!t->source_of_light) { pm_photon_tracer_destroy(t); return NULL; }
    t->sky_source = -1;
    for (uint32_t i = 0; i < source_count; i++) {
        if (t->sources[i].kind == SOURCE_PUNCTUAL) t->source_of_light[t->sources[i].light] = i;
        if (t->sources[i].kind == SOURCE_SKY) t->sky_source = (int)i;
    }
    /* an emitter set's photons start all over its triangles: not guided; the sky's direction and
     * start are guided apart (the product of two learned marginals) */
    for (uint32_t i = 0; i < source_count; i++) {
        light_source *l = &t->sources[i];
        bool sky = l->kind == SOURCE_SKY, room = t->guided_sources + (sky ? 2 : 1) <= PM_GUIDE_MAX_SOURCES;
        l->guided = l->guided_direction = -1;
        if (l->kind == SOURCE_EMITTERS || !room) continue;
        if (sky) l->guided_direction = (int)t->guided_sources++;
        l->guided = (int)t->guided_sources++;
    }
    float *cdf = t->cdf;
    double total = 0.0, run = 0.0;
    for (uint32_t i = 0; i < source_count; i++) total += source_weight(&t->sources[i]);
    cdf[0] = 0.f;
    for (uint32_t i = 0; i < source_count; i++) {
        run += source_weight(&t->sources[i]);
        cdf[i + 1] = total > 0 ? (float)(run / total) : 1.f;
    }
    if (source_count) cdf[source_count] = 1.f;

    pass *ps = &t->ps;
    ps->scene = s;
    ps->accel = a;
    ps->settings = &t->settings;
    ps->sources = t->sources;
    ps->source_count = source_count;
    ps->source_cdf = cdf;
    for (uint32_t i = 0; i < s->material_count; i++) ps->volumes |= !v3_is_black(s->materials[i].attenuation);
    uint64_t prefetch_from = settings->prefetch_bytes ? settings->prefetch_bytes : PM_PREFETCH_GEOMETRY_BYTES + 1;
    ps->prefetch_hits = pm_scene_hit_data_bytes(s) >= prefetch_from;
    ps->prefetch_texels = pm_scene_texture_bytes(s) >= prefetch_from;
    ps->prefetch_emitters = (uint64_t)s->emitter_count * (sizeof(pm_emitter) + sizeof(float) + sizeof(uint32_t)) >= prefetch_from;
    t->global_possible = source_count && s->analysis.has_diffuse;

    if (source_count && s->analysis.caustics_possible) {
        t->spheres = specular_spheres(s, &t->sphere_count);
        if (!t->spheres) { pm_photon_tracer_destroy(t); return NULL; }
        double covered = 0.0;
        float R = s->radius > 0.f ? s->radius : 1.f;
        uint32_t n = t->sphere_count;
        if (settings->projection_maps && n) {
            t->target_cdf = pm_malloc(sizeof(float) * (n + 1), "projection targets");
            if (!t->target_cdf) { pm_photon_tracer_destroy(t); return NULL; }
            double sum = 0.0, reach = R, acc = 0.0;
            for (uint32_t i = 0; i < n; i++) sum += (double)t->spheres[i].radius * t->spheres[i].radius;
            t->target_cdf[0] = 0.f;
            for (uint32_t i = 0; i < n; i++) {
                acc += (double)t->spheres[i].radius * t->spheres[i].radius;
                t->target_cdf[i + 1] = sum > 0 ? (float)(acc / sum) : (float)(i + 1) / n;
                reach = fmax(reach, v3_length(v3_sub(t->spheres[i].center, s->center)) + t->spheres[i].radius);
            }
            t->target_cdf[n] = 1.f;
            ps->targets = t->spheres;
            ps->target_count = n;
            ps->target_cdf = t->target_cdf;
            ps->target_area = (float)(PM_PI * sum);
            ps->target_reach = (float)(1.01 * reach);
        }
        /* the point-like sources' projection maps, built in parallel: one task per source (each
         * writes only its own source's map) */
        if (settings->projection_maps) {
            uint32_t *mapped = pm_malloc(sizeof *mapped * source_count, "projection map sources");
            projection_cell *cells = projection_cells();
            uint32_t count = 0;
            for (uint32_t i = 0; mapped && cells && i < source_count; i++)
                if (point_like(s, &t->sources[i])) mapped[count++] = i;
            projection_job job = {t->sources, mapped, cells, t->spheres, n, !mapped || !cells};
            if (!atomic_load(&job.failed)) pm_parallel_for(pm_thread_count(settings->threads), count, build_projection_map, &job);
            free(mapped);
            free(cells);
            if (atomic_load(&job.failed)) { pm_photon_tracer_destroy(t); return NULL; }
        }
        for (uint32_t i = 0; i < source_count; i++) {
            light_source *l = &t->sources[i];
            if (settings->projection_maps && point_like(s, l)) {
                covered += (double)l->marked_count / (PROJ_Z * PROJ_PHI) * (cdf[i + 1] - cdf[i]);
            } else if (ps->targets) {
                covered += fmin(1.0, ps->target_area / (PM_PI * R * R)) * (cdf[i + 1] - cdf[i]);
            } else {
                covered += cdf[i + 1] - cdf[i];
            }
        }
        t->projection_fraction = covered;
        /* No light can reach a specular object: no caustic photons at all. */
        t->caustic_possible = covered > 0;
    }
    return t;
}

void pm_photon_tracer_destroy(pm_photon_tracer *t) {
    if (!t) return;
    free_arenas(&t->ps);
    if (t->sources)
        for (uint32_t i = 0; i < t->source_count; i++) {
            free(t->sources[i].marked);
        }
    free(t->spheres);
    free(t->target_cdf);
    free(t->source_of_light);
    free(t->sources);
    free(t->cdf);
    pm_guide_free(&t->vertex_guide);
    free(t->ps.guide_counts);
    free(t);
}

uint32_t pm_photon_tracer_guided_sources(const pm_photon_tracer *t) { return t->guided_sources; }

bool pm_photon_tracer_set_guide(pm_photon_tracer *t, pm_guide *guide, const pm_marks *marks) {
    free(t->ps.guide_counts);
    t->ps.guide_counts = NULL;
    pm_guide_free(&t->vertex_guide);
    t->guide = NULL;
    t->ps.guide = NULL;
    t->ps.marks = NULL;
    if (!guide || !t->guided_sources) return true;
    assert(guide->sources == t->guided_sources);
    int threads = pm_thread_count(t->settings.threads);
    t->ps.guide_cells = (size_t)t->guided_sources * PM_GUIDE_CELL_COUNT;
    t->ps.guide_counts = pm_calloc((size_t)threads * 2 * t->ps.guide_cells, sizeof(uint32_t), "photon guide counts");
    if (!t->ps.guide_counts || !pm_guide_init(&t->vertex_guide, t->guided_sources)) return false;
    t->guide = guide;
    t->ps.marks = marks;
    return true;
}

bool pm_photon_tracer_can_trace(const pm_photon_tracer *t, bool caustic) {
    return caustic ? t->caustic_possible : t->global_possible;
}

double pm_photon_tracer_projection_fraction(const pm_photon_tracer *t) { return t->projection_fraction; }

bool pm_photon_tracer_trace(pm_photon_tracer *t, bool caustic, uint64_t photons, uint64_t seed, pm_kdtree *out,
                            pm_photon_stats *stats) {
    memset(out, 0, sizeof *out);
    if (!photons || !pm_photon_tracer_can_trace(t, caustic)) return true;
    t->ps.caustic_pass = caustic;
    t->ps.photons = photons;
    t->ps.seed = caustic ? seed ^ 0xca05u : seed;
    uint64_t stored = 0, rays = 0;
    bool ok = run_pass(&t->ps, out, &stored, &rays, stats);
    stats->rays += rays;
    stats->dropped += t->ps.dropped;
    stats->emitted += photons;
    if (caustic) stats->stored_caustic += stored;
    else stats->stored_global += stored;
    return ok;
}

void pm_photon_tracer_set_deadline(pm_photon_tracer *t, double deadline) { t->deadline = deadline; }

void pm_photon_tracer_skip_punctual_first_hits(pm_photon_tracer *t, bool skip) { t->ps.punctual_first_hits_skipped = skip; }

void pm_photon_tracer_tag_punctual_specular(pm_photon_tracer *t, bool tag, bool only) {
    t->ps.tag_punctual_specular = tag || only;
    t->ps.only_punctual_specular = only;
}

void pm_photon_tracer_set_splats(pm_photon_tracer *t, const pm_camera *camera, int width, int height, pm_splat_buffer *out) {
    t->ps.splat = camera && out && width > 0 && height > 0;
    if (t->ps.splat) t->ps.splat_view = pm_camera_view_make(camera, width, height);
    t->ps.splat_out = out;
}

/* trace_into for a pass set up in t->ps, whose photons (if guided) teach the guide where they met
 * the marks: the threads' counts summed into the first's, then learned from. */
static bool trace_guided(pm_photon_tracer *t, pm_photon_buffer *out, uint64_t *rays) {
    int threads = pm_thread_count(t->settings.threads);
    if (t->ps.guide) memset(t->ps.guide_counts, 0, sizeof(uint32_t) * (size_t)threads * 2 * t->ps.guide_cells);
    bool ok = trace_into(&t->ps, out, rays);
    if (ok && t->ps.guide && t->ps.marks->any && !pm_parallel_cancelled()) {
        uint32_t *sum = t->ps.guide_counts;
        for (int k = 1; k < threads; k++)
            for (size_t c = 0; c < 2 * t->ps.guide_cells; c++) sum[c] += t->ps.guide_counts[(size_t)k * 2 * t->ps.guide_cells + c];
        pm_guide_learn(t->guide, sum, sum + t->ps.guide_cells);
    }
    return ok;
}

bool pm_photon_tracer_trace_into(pm_photon_tracer *t, bool caustic, uint64_t photons, uint64_t seed,
                                 pm_photon_buffer *out, pm_photon_stats *stats) {
    out->count = 0;
    if (!photons || !pm_photon_tracer_can_trace(t, caustic)) return true;
    double t0 = pm_now_seconds();
    /* sorting what a pass stored costs more than tracing it (about 2x, measured on a closed
     * white room): a pass may use a quarter of the time left */
    t->ps.deadline = t->deadline > 0.0 ? t0 + (t->deadline - t0) * PM_PHOTON_PASS_TIME_SHARE : 0.0;
    t->ps.caustic_pass = caustic;
    t->ps.photons = photons;
    t->ps.seed = caustic ? seed ^ 0xca05u : seed;
    /* the global pass is guided (the caustic pass has its projection maps) */
    t->ps.guide = !caustic && !t->ps.only_punctual_specular ? t->guide : NULL;
    uint64_t rays = 0;
    bool ok = trace_guided(t, out, &rays);
    stats->rays += rays;
    stats->dropped += t->ps.dropped;
    stats->emitted += t->ps.traced;
    if (caustic) stats->stored_caustic += out->count;
    else stats->stored_global += out->count;
    stats->trace_seconds += pm_now_seconds() - t0;
    return ok;
}

bool pm_photon_tracer_trace_light_vertices(pm_photon_tracer *t, uint64_t photons, uint64_t seed, const pm_cell_values *worth,
                                           pm_light_vertex_buffer *out, pm_photon_stats *stats) {
    const pm_scene *s = t->scene;
    out->count = 0;
    out->photons = 0;
    if (!photons || !s->light_count || !t->global_possible) return true;
    double t0 = pm_now_seconds();
    pass *ps = &t->ps;
    bool tag = ps->tag_punctual_specular, only = ps->only_punctual_specular;
    ps->tag_punctual_specular = ps->only_punctual_specular = false;
    ps->caustic_pass = false;
    ps->light_vertex_pass = true;
    ps->vertex_worth = worth;
    ps->vertex_out = out;
    ps->photons = photons;
    ps->seed = seed ^ 0x11e7u;
    ps->deadline = 0.0; /* a few thousand rays: never cut, so no vertex needs rescaling */
    ps->guide = t->guide; /* taught by the first hits, as global passes teach it by every record */
    if (t->guide) pm_guide_copy(&t->vertex_guide, t->guide);
    uint64_t rays = 0;
    bool ok = trace_guided(t, &(pm_photon_buffer){NULL, 0, 0}, &rays);
    ps->light_vertex_pass = false;
    ps->vertex_worth = NULL;
    ps->vertex_out = NULL;
    ps->tag_punctual_specular = tag;
    ps->only_punctual_specular = only;
    out->photons = ps->traced;
    stats->rays += rays;
    stats->dropped += ps->dropped;
    stats->emitted += ps->traced;
    stats->trace_seconds += pm_now_seconds() - t0;
    return ok;
}

/* The guide's two placing numbers of a directional light's start toward p (box_start turned
 * back): the face where the line through p along dir enters the core's box, and the point there.
 * False where that line misses the box. */
static bool box_numbers(const pm_scene *s, const box_shadow *b, vec3 dir, vec3 p, float *u1, float *u2) {
    float lo[3] = {s->core_min.x, s->core_min.y, s->core_min.z}, hi[3] = {s->core_max.x, s->core_max.y, s->core_max.z};
    float o[3] = {p.x, p.y, p.z}, d[3] = {dir.x, dir.y, dir.z}, enter = -INFINITY, leave = INFINITY;
    int face = -1;
    for (int a = 0; a < 3; a++) {
        if (d[a] == 0.f) {
            if (o[a] < lo[a] || o[a] > hi[a]) return false;
            continue;
        }
        float t_lo = (lo[a] - o[a]) / d[a], t_hi = (hi[a] - o[a]) / d[a];
        float near = pm_minf(t_lo, t_hi), far = pm_maxf(t_lo, t_hi);
        if (near > enter) { enter = near; face = a; }
        leave = pm_minf(leave, far);
    }
    if (face < 0 || !(enter <= leave)) return false;
    vec3 q = v3_sub(v3_madd(p, dir, enter), b->corner[face]);
    float a = v3_dot(q, b->edge_a[face]) / pm_maxf(v3_dot(b->edge_a[face], b->edge_a[face]), FLT_MIN);
    float v = v3_dot(q, b->edge_b[face]) / pm_maxf(v3_dot(b->edge_b[face], b->edge_b[face]), FLT_MIN);
    *u1 = pm_minf(pm_maxf((b->skip[face] + b->skip_more[face] + a * b->weight[face]) / b->total, 0.f), 0.99999994f);
    *u2 = pm_minf(pm_maxf(v, 0.f), 0.99999994f);
    return true;
}

/* The two numbers pm_sample_disc turns into (x, y) of the unit disc (its concentric mapping
 * turned back: the side of the square is the larger of |x| and |y|'s, the angle within its
 * octant the other's share). */
static void disc_numbers(float x, float y, float *u1, float *u2) {
    float r = sqrtf(x * x + y * y), a, b;
    if (fabsf(x) > fabsf(y)) {
        a = x < 0.f ? -r : r;
        b = a * pm_atan_unit(y / x) * (float)(4.0 / PM_PI);
    } else {
        b = y < 0.f ? -r : r;
        a = y != 0.f ? b * pm_atan_unit(x / y) * (float)(4.0 / PM_PI) : 0.f;
    }
    *u1 = pm_minf(pm_maxf(0.5f * (a + 1.f), 0.f), 0x1.fffffep-1f);
    *u2 = pm_minf(pm_maxf(0.5f * (b + 1.f), 0.f), 0x1.fffffep-1f);
}

/* pm_photon_tracer_first_hit_density for the sky's photons arriving at p from to_light: the
 * disc's start behind p and the direction, each turned back to its guide cell. */
static float sky_first_hit_density(const pm_photon_tracer *t, vec3 p, vec3 ng, vec3 to_light) {
    const pm_scene *s = t->scene;
    if (t->sky_source < 0) return 0.f;
    const light_source *l = &t->sources[t->sky_source];
    float R = s->radius > 0.f ? s->radius : 1.f, x, y;
    vec3 tb, bb, rel = v3_sub(p, s->center);
    v3_basis(v3_neg(to_light), &tb, &bb);
    x = v3_dot(rel, tb) / R;
    y = v3_dot(rel, bb) / R;
    if (x * x + y * y > 1.f) return 0.f; /* no photon starts outside the disc */
    float pick = t->cdf[t->sky_source + 1] - t->cdf[t->sky_source], per_direction, d1, d2, s1, s2;
    if (s->sky_map) {
        per_direction = pm_sky_map_pdf(s->sky_map, to_light);
        pm_sky_map_numbers(s->sky_map, to_light, &d1, &d2);
    } else {
        per_direction = (float)(0.25 / PM_PI);
        pm_sphere_numbers(to_light, &d1, &d2);
    }
    double guided = 1.0;
    if (t->guide && l->guided >= 0 && l->guided_direction >= 0) {
        const pm_guide *g = &t->vertex_guide;
        disc_numbers(x, y, &s1, &s2);
        guided = PM_GUIDE_UNIFORM + (1.0 - PM_GUIDE_UNIFORM) * pm_guide_density(g, (uint32_t)l->guided, pm_guide_cell_of(s1, s2)) *
                                        pm_guide_density(g, (uint32_t)l->guided_direction, pm_guide_cell_of(d1, d2));
    }
    return (float)(pick * guided) * fabsf(v3_dot(ng, to_light)) / (PM_PI * R * R) * per_direction;
}

float pm_photon_tracer_first_hit_density(const pm_photon_tracer *t, uint32_t light, vec3 p, vec3 ng, vec3 to_light) {
    const pm_scene *s = t->scene;
    if (light == PM_LIGHT_VERTEX_SKY) return sky_first_hit_density(t, p, ng, to_light);
    if (light >= s->light_count) return 0.f;
    uint32_t k = t->source_of_light[light];
    const light_source *l = &t->sources[k];
    const pm_light *pl = &s->lights[light];
    float pick = t->cdf[k + 1] - t->cdf[k], u1 = 0.f, u2 = 0.f, per_area;
    bool placed = true;
    if (pl->type == PM_LIGHT_DIRECTIONAL) {
        float R = s->radius > 0.f ? s->radius : 1.f, cos_p = fabsf(v3_dot(ng, pl->direction));
        if (l->shadow.usable) {
            if (!box_numbers(s, &l->shadow, pl->direction, p, &u1, &u2)) return 0.f;
            per_area = cos_p / l->shadow.total;
        } else {
            /* the disc across the scene: no photon starts outside it */
            vec3 tb, bb, rel = v3_sub(p, s->center);
            v3_basis(pl->direction, &tb, &bb);
            float x = v3_dot(rel, tb), y = v3_dot(rel, bb);
            if (x * x + y * y > R * R) return 0.f;
            per_area = cos_p / (PM_PI * R * R);
            placed = false; /* the disc's numbers are not turned back: the guide's mean stands for them */
        }
    } else {
        vec3 to = v3_sub(p, pl->position);
        float d2 = v3_dot(to, to);
        if (!(d2 > 0.f)) return 0.f;
        vec3 w = v3_scale(to, 1.f / sqrtf(d2));
        float cos_p = fabsf(v3_dot(ng, w)) / d2;
        if (pl->type == PM_LIGHT_SPOT) {
            float z = v3_dot(w, pl->direction);
            if (z < pl->cos_outer) return 0.f;
            vec3 tb, bb;
            v3_basis(pl->direction, &tb, &bb);
            u1 = (1.f - z) / pm_maxf(1.f - pl->cos_outer, FLT_MIN);
            u2 = pm_azimuth_turn(v3_dot(w, tb), v3_dot(w, bb));
            per_area = cos_p / (2.f * PM_PI * (1.f - pl->cos_outer));
        } else {
            pm_sphere_numbers(w, &u1, &u2);
            per_area = cos_p / (4.f * PM_PI);
        }
        u1 = pm_minf(pm_maxf(u1, 0.f), 0.99999994f);
    }
    double guided = 1.0;
    if (t->guide && l->guided >= 0 && placed)
        guided = PM_GUIDE_UNIFORM + (1.0 - PM_GUIDE_UNIFORM) * pm_guide_density(&t->vertex_guide, (uint32_t)l->guided, pm_guide_cell_of(u1, u2));
    return (float)(pick * guided) * per_area;
}

bool pm_photon_maps_build(const pm_scene *s, const pm_accel *a, const pm_photon_settings *settings,
                          pm_photon_maps *maps, pm_photon_stats *stats) {
    double start = pm_now_seconds();
    memset(maps, 0, sizeof *maps);
    pm_photon_stats local;
    memset(&local, 0, sizeof local);
    pm_photon_tracer *t = pm_photon_tracer_create(s, a, settings);
    if (!t) return false;
    bool ok = true;
    if (settings->global_photons && pm_photon_tracer_can_trace(t, false)) {
        ok = pm_photon_tracer_trace(t, false, settings->global_photons, settings->seed, &maps->global, &local);
        maps->global_emitted = settings->global_photons;
        if (ok && settings->irradiance_stride > 0 && maps->global.count) {
            double t0 = pm_now_seconds();
            int threads = pm_thread_count(settings->threads);
            ok = precompute_irradiance(maps, s, a, settings, threads);
            local.irradiance_seconds = pm_now_seconds() - t0;
        }
    }
    maps->projection_fraction = t->projection_fraction;
    if (ok && settings->caustic_photons && pm_photon_tracer_can_trace(t, true)) {
        ok = pm_photon_tracer_trace(t, true, settings->caustic_photons, settings->seed, &maps->caustic, &local);
        maps->caustic_emitted = settings->caustic_photons;
    }
    pm_photon_tracer_destroy(t);
    local.seconds = pm_now_seconds() - start;
    if (stats) *stats = local;
    if (!ok) pm_photon_maps_free(maps);
    return ok;
}

typedef struct {
    const pm_photon_maps *maps;
    const pm_photon_settings *settings;
    const pm_scene *scene;
    const pm_accel *accel;
    size_t stride, points;
    pm_photon *out;
} irradiance_job;

static void irradiance_chunk(void *ctx, size_t chunk, int thread) {
    const irradiance_job *job = ctx;
    size_t first = chunk * CHUNK, last = first + CHUNK < job->points ? first + CHUNK : job->points;
    for (size_t i = first; i < last; i++) {
        const pm_photon *ph = &job->maps->global.photons[i * job->stride];
        vec3 p = pm_photon_position(ph), n = pm_photon_normal(ph);
        pm_clip_site site = {job->scene, job->accel, PM_CLIP_NO_TRIANGLE, job->settings->seed ^ pm_hash64(i), NULL, NULL};
        vec3 e = pm_photon_estimate(&job->maps->global, p, n, &job->settings->irradiance_estimate,
                                    job->settings->unclipped ? NULL : &site);
        /* stored as if it arrived head-on, so the estimate's front filter would accept it */
        pm_photon_set(&job->out[i], p, n, v3_neg(n), e, PM_PATH_DIRECT);
    }
}

/* Samples the global map at every stride-th photon of its (deterministic) tree order. */
static bool precompute_irradiance(pm_photon_maps *maps, const pm_scene *s, const pm_accel *a,
                                  const pm_photon_settings *settings, int threads) {
    irradiance_job job = {maps, settings, s, a, (size_t)settings->irradiance_stride, 0, NULL};
    job.points = (maps->global.count + job.stride - 1) / job.stride;
    job.out = pm_malloc(sizeof(pm_photon) * (job.points ? job.points : 1), "precomputed irradiance points");
    if (!job.out) return false;
    pm_parallel_for(threads, (job.points + CHUNK - 1) / CHUNK, irradiance_chunk, &job);
    maps->irradiance_radius = settings->irradiance_estimate.max_radius;
    return pm_kdtree_build(&maps->irradiance, job.out, job.points, threads);
}

bool pm_photon_irradiance_lookup(const pm_photon_maps *maps, vec3 p, vec3 n, const pm_clip *clip, vec3 *irradiance) {
    enum { CANDIDATES = 8 };
    uint32_t idx[CANDIDATES];
    float d2[CANDIDATES], r2;
    if (!maps->irradiance.count) return false;
    float max2 = maps->irradiance_radius * maps->irradiance_radius;
    size_t found = pm_kdtree_nearest(&maps->irradiance, p, CANDIDATES, max2, idx, d2, &r2);
    int best = -1;
    for (size_t i = 0; i < found; i++) {
        const pm_photon *ph = &maps->irradiance.photons[idx[i]];
        if (v3_dot(pm_photon_normal(ph), n) < 0.9f) continue; /* another surface, or its back */
        if (clip && !pm_clip_keeps(clip, pm_photon_position(ph))) continue; /* across a wall */
        if (best < 0 || d2[i] < d2[best]) best = (int)i;
    }
    if (best < 0) return false;
    *irradiance = pm_photon_power(&maps->irradiance.photons[idx[best]]);
    return true;
}

void pm_photon_maps_free(pm_photon_maps *maps) {
    pm_kdtree_free(&maps->irradiance);
    pm_kdtree_free(&maps->caustic);
    pm_kdtree_free(&maps->global);
    memset(maps, 0, sizeof *maps);
}

/* Jensen's Gaussian shape (his beta; his alpha = 0.918 is replaced by the factor that makes the
 * kernel integrate to exactly one over the disc). */
static const float gauss_beta = 1.953f;

/* Jensen's estimate: the photons' power, each weighted by the kernel and (with b) by the BRDF
 * f(wo, wi) for its incoming direction wi, over the kernel's area. */
/* Inlined into both callers so that the Lambert one (b == NULL) carries no per-photon branch. */
static inline __attribute__((always_inline)) vec3 estimate(const pm_kdtree *map, vec3 p, vec3 n,
                                                           const pm_estimate_settings *e, const pm_brdf *b, vec3 ns,
                                                           vec3 wo, const pm_clip_site *site) {
    enum { MAX_K = 2048 };
    uint32_t idx[MAX_K];
    float d2[MAX_K], r2 = 0.f;
    int k = e->k < 1 ? 1 : (e->k > MAX_K ? MAX_K : e->k);
    if (!map->count) return v3s(0.f);
    size_t found = pm_kdtree_nearest(map, p, (size_t)k, e->max_radius * e->max_radius, idx, d2, &r2);
    if (!found || r2 <= 0.f) return v3s(0.f);
    /* With fewer than k photons inside the maximum radius, the disc is the maximum radius. */
    if ((int)found < k) r2 = e->max_radius * e->max_radius;
    float r = sqrtf(r2);
    pm_clip made;
    const pm_clip *clip = site ? site->made : NULL;
    if (site && !clip) {
        pm_clip_make(&made, site->scene, site->accel, p, n, site->tri, r, site->seed, site->rays);
        clip = &made;
    }
    vec3 sum = v3s(0.f);
    const float cone_k = 1.1f;
    float gauss_norm = 0.f;
    if (e->kernel == PM_KERNEL_GAUSSIAN) {
        float eb = expf(-gauss_beta);
        float integral = 1.f - (1.f - (2.f / gauss_beta) * (1.f - expf(-0.5f * gauss_beta))) / (1.f - eb);
        gauss_norm = 1.f / integral;
    }
    for (size_t i = 0; i < found; i++) {
        const pm_photon *ph = &map->photons[idx[i]];
        if (!((e->path_mask >> pm_photon_path(ph)) & 1u)) continue;
        if (v3_dot(pm_photon_direction(ph), n) >= 0.f) continue;       /* arrived from behind */
        if (v3_dot(pm_photon_normal(ph), n) < 0.9f) continue;            /* another surface */
        if (clip && !pm_clip_keeps(clip, pm_photon_position(ph))) continue; /* across a wall, below a floor */
        float w = 1.f;
        if (e->kernel == PM_KERNEL_GAUSSIAN) {
            float t = 1.f - (1.f - expf(-gauss_beta * d2[i] / (2.f * r2))) / (1.f - expf(-gauss_beta));
            w = gauss_norm * t;
        } else if (e->kernel == PM_KERNEL_CONE) {
            w = (1.f - sqrtf(d2[i]) / (cone_k * r)) / (1.f - 2.f / (3.f * cone_k));
        }
        vec3 power = pm_photon_power(ph);
        if (b) power = v3_mul(power, pm_brdf_eval(b, ns, wo, v3_neg(pm_photon_direction(ph))));
        sum = v3_madd(sum, power, w);
    }
    float kept = clip ? pm_clip_area_fraction(clip, r) : 1.f;
    return v3_scale(sum, 1.f / (PM_PI * r2 * kept));
}

vec3 pm_photon_estimate(const pm_kdtree *map, vec3 p, vec3 n, const pm_estimate_settings *e, const pm_clip_site *site) {
    return estimate(map, p, n, e, NULL, n, n, site);
}

vec3 pm_photon_estimate_brdf(const pm_kdtree *map, vec3 p, vec3 n, const pm_estimate_settings *e, const pm_brdf *b,
                             vec3 ns, vec3 wo, const pm_clip_site *site) {
    return estimate(map, p, n, e, b, ns, wo, site);
}

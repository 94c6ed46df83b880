/* shadowmap.c: shadow photons: photons from every punctual light traced straight through every surface, summarised per cell, normal and light into a visibility table.
 *
 * The photons carry no power and are never scattered: they only say, at the surfaces they
 * cross, whether the straight segment back to their light was clear. Each light sends the same
 * number (a dim light's shadows need the same resolution as a bright one's), spread evenly
 * rather than at random, so no part of a surface is left without records by chance. Tracing is
 * parallel in fixed chunks merged in order, and the table is filled in that order: the map is the
 * same at any thread count.
 */
#include "shadowmap.h"
#include "memory.h"

#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "clock.h"
#include "defaults.h"
#include "parallel.h"
#include "light.h"
#include "photonmap.h"
#include "rng.h"
#include "scatter.h"

#define CHUNK 4096
#define MAX_THREADS PM_MAX_THREADS
#define AXIS_BITS 20                         /* cells per axis below 2^20 */
#define LAYERS 4                             /* along the normal, cells are this many times thinner */
#define GOLDEN_ANGLE 2.39996322972865332f    /* pi (3 - sqrt 5): the spherical Fibonacci set's turn */

enum { RECORD_SEEN = 0, RECORD_HIDDEN = 1, RECORD_UNCERTAIN = 2 };

/* One crossing of a photon with a surface that can have direct light. */
typedef struct {
    vec3 p;
    uint16_t light;
    uint8_t side;      /* side_code() of the side the photon arrived on */
    uint8_t state;     /* RECORD_* */
} record;

/* Per light, the records near the cell on surfaces facing one way: seen in the low nibble, hidden
 * in the high one, each saturating at 15; an uncertain record counts as both (so it never lets a
 * lookup decide). */
typedef struct {
    uint64_t key; /* 0 = empty slot */
    uint8_t counts[PM_SHADOW_MAX_LIGHTS];
} entry;

struct pm_shadow_map {
    vec3 origin;
    float cell, inv_cell;
    uint32_t cells_per_axis;
    int min_count;
    entry *slots;
    size_t capacity, used; /* capacity: a power of two, at most half full */
};

typedef struct {
    const pm_scene *scene;
    const pm_accel *accel;
    uint64_t photons;       /* per light */
    size_t chunks_per_light;
    uint32_t lights;
    double deadline;
    record **chunk_records;
    uint32_t *chunk_counts;
    atomic_bool out_of_memory;
    struct { uint64_t rays; char pad[56]; } counters[MAX_THREADS];
} trace_job;


/* Which of the six axis directions n (the side's normal) is nearest, times two, plus one on a
 * triangle's front (its own normal is n): records and lookups on differently facing surfaces (a
 * floor and the wall it meets) never mix, nor the outside of a thin closed object with its inside
 * (its far wall, seen from within, faces the same way as its near wall). */
static inline int side_code(vec3 n, bool front) {
    float ax = fabsf(n.x), ay = fabsf(n.y), az = fabsf(n.z);
    int bucket = ax >= ay && ax >= az ? (n.x >= 0.f ? 0 : 1) : (ay >= az ? (n.y >= 0.f ? 2 : 3) : (n.z >= 0.f ? 4 : 5));
    return 2 * bucket + (front ? 1 : 0);
}

uint64_t pm_shadow_default_photons(int width, int height) {
    double n = (double)width * height * PM_SHADOW_PHOTONS_PER_PIXEL;
    return (uint64_t)(n < PM_SHADOW_MIN_PHOTONS ? PM_SHADOW_MIN_PHOTONS : (n > PM_SHADOW_MAX_PHOTONS ? PM_SHADOW_MAX_PHOTONS : n));
}

static uint64_t photons_per_light(const pm_shadow_settings *set) {
    return set->photons_per_light ? set->photons_per_light : PM_SHADOW_MIN_PHOTONS;
}

const char *pm_shadow_map_unneeded(const pm_scene *s, const pm_shadow_settings *set) {
    if (set->mode == PM_SHADOW_OFF) return "off";
    if (!s->light_count) return "no_punctual_lights";
    if (s->light_count > PM_SHADOW_MAX_LIGHTS) return "too_many_lights";
    for (uint32_t t = 0; t < s->triangle_count; t++) {
        const pm_material *m = &s->materials[s->triangle_material[t]];
        if (m->alpha_mode == PM_ALPHA_BLEND && pm_material_can_be_transparent(s, m)) return "stochastic_transparency";
    }
    if (set->mode == PM_SHADOW_AUTO && set->expected_samples > 0.0) {
        double shaded = s->light_count < PM_DIRECT_LIGHT_SAMPLES ? s->light_count : PM_DIRECT_LIGHT_SAMPLES;
        double traced = (double)photons_per_light(set) * s->light_count;
        if (set->expected_samples * shaded < PM_SHADOW_PAYBACK * traced) return "would_not_pay";
    }
    return NULL;
}

/* The i-th of n photons of a light: where it starts and where it goes. Points and spots use a
 * spherical Fibonacci set (over the sphere, or the spot's cone), turned by a per-light angle;
 * directional lights a sunflower spiral on a disc across the scene, behind it. */
static void photon_ray(const pm_scene *s, const pm_light *l, uint32_t light, uint64_t i, uint64_t n, vec3 *o, vec3 *d) {
    float turn = (float)(pm_hash64(light + 0x5bd1e995u) >> 40) * (2.f * PM_PI / 16777216.f);
    float phi = (float)fmod((double)i * GOLDEN_ANGLE + turn, 2.0 * PM_PI);
    float f = (float)(((double)i + 0.5) / (double)n);
    if (l->type == PM_LIGHT_DIRECTIONAL) {
        float R = 1.01f * (s->radius > 0.f ? s->radius : 1.f), r = R * sqrtf(f);
        vec3 t, b;
        v3_basis(l->direction, &t, &b);
        *d = l->direction;
        *o = v3_add(v3_madd(s->center, l->direction, -R), v3_add(v3_scale(t, r * cosf(phi)), v3_scale(b, r * sinf(phi))));
        return;
    }
    *o = l->position;
    float z = l->type == PM_LIGHT_SPOT ? 1.f - f * (1.f - l->cos_outer) : 1.f - 2.f * f;
    float r = sqrtf(pm_maxf(0.f, 1.f - z * z));
    vec3 axis = l->type == PM_LIGHT_SPOT ? l->direction : v3(0.f, 0.f, 1.f), t, b;
    v3_basis(axis, &t, &b);
    *d = v3_add(v3_scale(axis, z), v3_add(v3_scale(t, r * cosf(phi)), v3_scale(b, r * sinf(phi))));
}

static bool push(record **list, uint32_t *count, uint32_t *capacity, record r) {
    if (*count == *capacity) {
        uint32_t grown_capacity = *capacity ? 2 * *capacity : 2 * CHUNK;
        record *grown = pm_realloc(*list, sizeof(record) * grown_capacity, "shadow photon records");
        if (!grown) return false;
        *list = grown;
        *capacity = grown_capacity;
    }
    (*list)[(*count)++] = r;
    return true;
}

static void trace_chunk(void *ctx, size_t task, int thread) {
    trace_job *job = ctx;
    const pm_scene *s = job->scene;
    /* lights interleaved, so a deadline takes the same directions from each */
    uint32_t light = (uint32_t)(task % job->lights);
    uint64_t first = (uint64_t)(task / job->lights) * CHUNK;
    if (job->deadline > 0.0 && pm_now_seconds() > job->deadline) return;
    uint64_t last = first + CHUNK < job->photons ? first + CHUNK : job->photons;
    const pm_light *l = &s->lights[light];
    record *list = NULL;
    uint32_t count = 0, capacity = 0;
    uint64_t rays = 0;
    bool failed = false;
    for (uint64_t i = first; i < last && !failed; i++) {
        vec3 o, d;
        photon_ray(s, l, light, i, job->photons, &o, &d);
        int state = RECORD_SEEN;
        for (int crossing = 0; crossing < PM_SHADOW_MAX_CROSSINGS; crossing++) {
            pm_hit h;
            rays++;
            if (!pm_accel_intersect(job->accel, o, d, INFINITY, &h)) break;
            pm_triangle_geometry g = pm_triangle_geometry_of(s, h.tri);
            vec3 p = pm_triangle_point(&g, h.b1, h.b2), face = g.normal, toward_light = pm_facing(face, v3_neg(d));
            const pm_material *m = &s->materials[pm_scene_triangle_material(s, h.tri)];
            if (m->may_diffuse || m->may_glossy) {
                record r = {p, (uint16_t)light, (uint8_t)side_code(toward_light, v3_dot(face, d) < 0.f), (uint8_t)state};
                if (!push(&list, &count, &capacity, r)) { failed = true; break; }
            }
            /* a shadow ray stops at every surface, glass included; but light does pass glass (as a
             * caustic), so what lies behind it is not called hidden */
            if (m->may_glass) { if (state == RECORD_SEEN) state = RECORD_UNCERTAIN; }
            else state = RECORD_HIDDEN;
            o = pm_offset_ray_origin(p, v3_neg(toward_light), s->ray_scale);
        }
    }
    if (failed) atomic_store(&job->out_of_memory, true);
    job->chunk_records[task] = list;
    job->chunk_counts[task] = count;
    job->counters[thread].rays += rays;
}

static inline uint64_t slot_hash(uint64_t key) { return pm_hash64(key); }

static entry *slot_of(entry *slots, size_t capacity, uint64_t key) {
    size_t i = (size_t)slot_hash(key) & (capacity - 1);
    while (slots[i].key && slots[i].key != key) i = (i + 1) & (capacity - 1);
    return &slots[i];
}

static bool grow_table(pm_shadow_map *m) {
    size_t capacity = m->capacity ? 2 * m->capacity : 1024;
    entry *slots = pm_calloc(capacity, sizeof *slots, "shadow photon cells");
    if (!slots) return false;
    for (size_t i = 0; i < m->capacity; i++)
        if (m->slots[i].key) *slot_of(slots, capacity, m->slots[i].key) = m->slots[i];
    free(m->slots);
    m->slots = slots;
    m->capacity = capacity;
    return true;
}

static inline uint64_t cell_key(uint32_t x, uint32_t y, uint32_t z, int side) {
    return (((uint64_t)x << (2 * AXIS_BITS + 4)) | ((uint64_t)y << (AXIS_BITS + 4)) | ((uint64_t)z << 4) | (uint64_t)side) + 1u;
}

/* A point's position in cells: along the axis its surfaces face (the bucket's), cells are
 * LAYERS times thinner, so a surface and a parallel one a little above it (a shelf over a floor)
 * do not share records. */
static inline void grid_position(const pm_shadow_map *m, vec3 p, int side, float g[3]) {
    g[0] = (p.x - m->origin.x) * m->inv_cell;
    g[1] = (p.y - m->origin.y) * m->inv_cell;
    g[2] = (p.z - m->origin.z) * m->inv_cell;
    g[side / 4] *= LAYERS;
}

/* Counts a record in every cell that half a cell around it touches. */
static bool add_record(pm_shadow_map *m, const record *r) {
    float g[3];
    grid_position(m, r->p, r->side, g);
    for (int a = 0; a < 3; a++) /* past the grid (outside the scene's core): clamped onto its edge it would count there */
        if (!(g[a] >= -1.f && g[a] <= (float)m->cells_per_axis + 1.f)) return true;
    uint32_t lo[3], hi[3];
    for (int a = 0; a < 3; a++) {
        float l = floorf(g[a] - 0.5f), h = floorf(g[a] + 0.5f), top = (float)(m->cells_per_axis - 1);
        lo[a] = (uint32_t)pm_minf(pm_maxf(l, 0.f), top);
        hi[a] = (uint32_t)pm_minf(pm_maxf(h, 0.f), top);
    }
    for (uint32_t x = lo[0]; x <= hi[0]; x++)
        for (uint32_t y = lo[1]; y <= hi[1]; y++)
            for (uint32_t z = lo[2]; z <= hi[2]; z++) {
                if (2 * (m->used + 1) > m->capacity && !grow_table(m)) return false;
                uint64_t key = cell_key(x, y, z, r->side);
                entry *e = slot_of(m->slots, m->capacity, key);
                if (!e->key) { e->key = key; m->used++; }
                uint8_t *c = &e->counts[r->light];
                unsigned seen = *c & 15u, hidden = *c >> 4;
                if (r->state != RECORD_HIDDEN && seen < 15) seen++;
                if (r->state != RECORD_SEEN && hidden < 15) hidden++;
                *c = (uint8_t)(seen | hidden << 4);
            }
    return true;
}

/* What lookups cost against the shadow rays they replace, timed on this machine at random points
 * of the surfaces that can have direct light (both sides, every light in front): the time of a
 * lookup and of a shadow ray, and the share of light samples the map decides. The image does not
 * depend on it (a decided sample gives what its ray would), only the speed. */
/* The instanced mesh stored triangle t belongs to, -1 for a flat one (meshes are stored in order). */
static int32_t instanced_mesh_of(const pm_scene *s, uint32_t t) {
    if (t < pm_scene_flat_triangles(s)) return -1;
    uint32_t lo = 0, hi = s->instanced_mesh_count - 1;
    while (lo < hi) {
        uint32_t mid = lo + (hi - lo + 1) / 2;
        if (s->instanced_meshes[mid].first_triangle <= t) lo = mid;
        else hi = mid - 1;
    }
    return (int32_t)lo;
}

static bool probe(const pm_scene *s, const pm_accel *a, const pm_shadow_map *m, pm_shadow_stats *stats) {
    enum { POINTS = 4096 };
    typedef struct { vec3 p, n, origin; bool front; } probe_point;
    probe_point *points = pm_malloc(POINTS * sizeof *points, "shadow photon probe");
    float *cdf = pm_malloc(((size_t)s->triangle_count + 1) * sizeof *cdf, "shadow photon probe");
    if (!points || !cdf) { free(points); free(cdf); return false; }
    cdf[0] = 0.0;
    /* over stored triangles; an instanced one stands for all its placements (mesh-space area times
     * their number: a probe's estimate, not a measure), one of which is picked at random below */
    for (uint32_t t = 0; t < s->triangle_count; t++) {
        const pm_material *mat = &s->materials[s->triangle_material[t]];
        int32_t mesh = instanced_mesh_of(s, t);
        float copies = mesh < 0 ? 1.f : (float)s->instanced_meshes[mesh].placement_count;
        const uint32_t *ix = s->indices + 3 * (size_t)t;
        float area = 0.5f * v3_length(v3_cross(v3_sub(s->positions[ix[1]], s->positions[ix[0]]), v3_sub(s->positions[ix[2]], s->positions[ix[0]])));
        cdf[t + 1] = cdf[t] + (mat->may_diffuse || mat->may_glossy ? copies * area : 0.0);
    }
    pm_rng rng = pm_rng_for(0x5ad0, 1, 2);
    size_t n = 0;
    for (int k = 0; k < POINTS && cdf[s->triangle_count] > 0.0; k++) {
        uint32_t lo = pm_cdf_interval(cdf, s->triangle_count, pm_rng_float(&rng) * cdf[s->triangle_count]);
        float r1 = sqrtf(pm_rng_float(&rng)), r2 = pm_rng_float(&rng);
        uint32_t id = lo;
        int32_t mesh = instanced_mesh_of(s, lo);
        if (mesh >= 0 && s->instanced_meshes[mesh].placement_count) {
            const pm_instanced_mesh *im = &s->instanced_meshes[mesh];
            uint32_t p = im->first_placement + (uint32_t)(pm_rng_float(&rng) * im->placement_count) % im->placement_count;
            id = pm_scene_placed_id(s, p, lo);
        }
        pm_surface sf;
        pm_scene_surface(s, id, r1 * (1.f - r2), r1 * r2, &sf);
        bool front = pm_rng_float(&rng) < 0.5f;
        vec3 side = front ? sf.ng : v3_neg(sf.ng);
        points[n++] = (probe_point){sf.p, side, pm_surface_origin(&sf, side, s->ray_scale), front};
    }
    free(cdf);
    /* the light samples direct light would take there: each light in front of the side */
    typedef struct { uint32_t point, light; vec3 wi; float tmax; } probe_sample;
    probe_sample *samples = pm_malloc(n * s->light_count * sizeof *samples + 1, "shadow photon probe");
    if (!samples) { free(points); return false; }
    size_t count = 0;
    for (size_t i = 0; i < n; i++)
        for (uint32_t l = 0; l < s->light_count; l++) {
            const pm_light *light = &s->lights[l];
            vec3 wi = v3_neg(light->direction);
            float tmax = INFINITY;
            if (light->type != PM_LIGHT_DIRECTIONAL) {
                vec3 to = v3_sub(light->position, points[i].origin);
                tmax = v3_length(to);
                wi = v3_scale(to, 1.f / pm_maxf(tmax, 1e-30f));
            }
            if (v3_dot(wi, points[i].n) > 0.f) samples[count++] = (probe_sample){(uint32_t)i, l, wi, tmax};
        }
    uint64_t decided = 0, hidden = 0;
    double t0 = pm_now_seconds();
    for (size_t k = 0; k < count; k++) {
        const probe_point *q = &points[samples[k].point];
        decided += pm_shadow_map_verdict(m, pm_shadow_map_find(m, q->p, q->n, q->front), samples[k].light) != PM_VISIBILITY_UNKNOWN;
    }
    double t1 = pm_now_seconds();
    for (size_t k = 0; k < count; k++)
        hidden += pm_accel_occluded(a, points[samples[k].point].origin, samples[k].wi, samples[k].tmax);
    double t2 = pm_now_seconds();
    free(points);
    free(samples);
    (void)hidden; /* kept so the compiler cannot drop the rays */
    double samples_done = (double)count;
    if (samples_done > 0.0) {
        stats->probe_decided = (double)decided / samples_done;
        stats->probe_lookup_ns = (t1 - t0) / samples_done * 1e9;
        stats->probe_ray_ns = (t2 - t1) / samples_done * 1e9;
    }
    return true;
}

uint64_t pm_shadow_map_forecast_bytes(const pm_scene *s, const pm_shadow_settings *set) {
    if (pm_shadow_map_unneeded(s, set)) return 0;
    /* the records (a photon can leave several: one per surface it crosses) and the table of cells over them */
    return photons_per_light(set) * s->light_count * PM_SHADOW_RECORDS_PER_PHOTON * sizeof(record);
}

bool pm_shadow_map_pays(double decided) { return decided >= PM_SHADOW_MIN_GAIN * PM_SHADOW_LOOKUP_OVER_RAY; }

pm_shadow_map *pm_shadow_map_build(const pm_scene *s, const pm_accel *a, const pm_shadow_settings *set,
                                   pm_shadow_stats *stats) {
    double start = pm_now_seconds();
    memset(stats, 0, sizeof *stats);
    stats->reason = pm_shadow_map_unneeded(s, set);
    if (stats->reason) return NULL;
    stats->lights = s->light_count;
    trace_job *job = pm_calloc(1, sizeof *job, "shadow photon pass");
    pm_shadow_map *m = job ? pm_calloc(1, sizeof *m, "shadow photons") : NULL;
    if (!job || !m) {
        free(job);
        free(m);
        stats->out_of_memory = true;
        return NULL;
    }
    job->scene = s;
    job->accel = a;
    job->photons = photons_per_light(set);
    job->chunks_per_light = (size_t)((job->photons + CHUNK - 1) / CHUNK);
    job->lights = s->light_count;
    job->deadline = set->deadline;
    size_t tasks = job->chunks_per_light * s->light_count;
    job->chunk_records = pm_calloc(tasks, sizeof *job->chunk_records, "shadow photon pass");
    job->chunk_counts = job->chunk_records ? pm_calloc(tasks, sizeof *job->chunk_counts, "shadow photon pass") : NULL;
    atomic_init(&job->out_of_memory, false);
    bool ok = job->chunk_records && job->chunk_counts;
    int threads = pm_thread_count(set->threads);
    if (ok) pm_parallel_for(threads, tasks, trace_chunk, job);
    ok = ok && !atomic_load(&job->out_of_memory);

    /* the cell: a lookup's region (two cells wide) holds PM_SHADOW_LOOKUP_PHOTONS records of
     * one light on a surface where its records lie at their mean density */
    uint64_t records = 0;
    for (size_t t = 0; ok && t < tasks; t++) records += job->chunk_counts[t];
    double area = s->analysis.receiving_area, density = area > 0.0 ? (double)records / s->light_count / area : 0.0;
    double extent = s->ray_scale, cell = density > 0.0 ? sqrt(PM_SHADOW_LOOKUP_PHOTONS / (4.0 * density)) : extent;
    cell = fmin(fmax(cell, LAYERS * extent / ((1u << AXIS_BITS) - 4 * LAYERS)), extent);
    m->cell = (float)cell;
    m->inv_cell = (float)(1.0 / cell);
    m->origin = v3_sub(s->core_min, v3s(m->cell)); /* the core's grid: records past it are left out, lookups there trace */
    m->cells_per_axis = (uint32_t)fmin(LAYERS * (ceil(extent / cell) + 3.0), (double)((1u << AXIS_BITS) - 1));
    m->min_count = set->min_count > 0 ? (set->min_count < 15 ? set->min_count : 15) : PM_SHADOW_MIN_COUNT;
    for (size_t t = 0; ok && t < tasks; t++)
        for (uint32_t i = 0; ok && i < job->chunk_counts[t]; i++) ok = add_record(m, &job->chunk_records[t][i]);

    for (int t = 0; t < threads; t++) stats->rays += job->counters[t].rays;
    if (job->chunk_records)
        for (size_t t = 0; t < tasks; t++) free(job->chunk_records[t]);
    free(job->chunk_records);
    free(job->chunk_counts);
    free(job);
    if (!ok) {
        pm_shadow_map_free(m);
        stats->out_of_memory = true;
        return NULL;
    }
    stats->photons = photons_per_light(set) * s->light_count;
    stats->records = records;
    stats->cells = m->used;
    stats->bytes = m->capacity * sizeof(entry) + sizeof *m;
    stats->cell_size = m->cell;
    stats->spacing = density > 0.0 ? (float)(1.0 / sqrt(density)) : 0.f;
    ok = probe(s, a, m, stats);
    stats->seconds = pm_now_seconds() - start;
    if (!ok) {
        pm_shadow_map_free(m);
        stats->out_of_memory = true;
        return NULL;
    }
    /* priced by counts, not by the probe's clock: the same scene and settings get the same map
     * (and the same eye pass) on any machine under any load */
    if (set->mode == PM_SHADOW_AUTO && !pm_shadow_map_pays(stats->probe_decided)) {
        /* the map would decide too few light samples to pay for its lookups: no map */
        pm_shadow_map_free(m);
        stats->reason = "would_not_pay";
        return NULL;
    }
    stats->built = true;
    return m;
}

void pm_shadow_map_free(pm_shadow_map *m) {
    if (!m) return;
    free(m->slots);
    free(m);
}

const uint8_t *pm_shadow_map_find(const pm_shadow_map *m, vec3 p, vec3 n, bool front) {
    if (!m->used) return NULL;
    int side = side_code(n, front);
    float g[3];
    grid_position(m, p, side, g);
    uint32_t c[3];
    for (int a = 0; a < 3; a++) {
        if (!(g[a] >= 0.f && g[a] < (float)m->cells_per_axis)) return NULL;
        c[a] = (uint32_t)g[a];
    }
    uint64_t key = cell_key(c[0], c[1], c[2], side);
    const entry *e = slot_of(m->slots, m->capacity, key);
    return e->key ? e->counts : NULL;
}

pm_visibility pm_shadow_map_verdict(const pm_shadow_map *m, const uint8_t *found, uint32_t light) {
    if (!found || light >= PM_SHADOW_MAX_LIGHTS) return PM_VISIBILITY_UNKNOWN;
    int seen = found[light] & 15, hidden = found[light] >> 4;
    if (hidden == 0 && seen >= m->min_count) return PM_VISIBILITY_SEEN;
    if (seen == 0 && hidden >= m->min_count) return PM_VISIBILITY_HIDDEN;
    return PM_VISIBILITY_UNKNOWN;
}

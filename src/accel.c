/* accel.c: the Embree 3 scene over all triangles, with closest-hit and occlusion queries and the glTF alpha test.
 *
 * Instancing: each instanced mesh (scene.h) is a child Embree scene built once, with the same
 * opaque / alpha-tested split, and each placement an RTC_GEOMETRY_TYPE_INSTANCE of it with the
 * placement's transform, attached as geometry PLACEMENT_GEOMETRY + its index, so a hit's instID
 * names the placement and the child's geomID and primID the stored triangle; both map to the
 * scene's triangle id (pm_scene_placed_id) before anything outside reads them.
 *
 * Embree appears nowhere else. The geometry is copied into Embree's own buffers. Triangles whose
 * material can let rays through (MASK, BLEND) go into a second Embree geometry whose intersection
 * and occlusion filters reject a candidate hit the alpha test lets through, so every query (eye,
 * shadow, gather, photon) sees the same cut-outs; opaque triangles stay in a geometry without
 * filters, and a scene without such materials has one geometry and no filter, so it pays nothing
 * for the alpha test. Only the alpha test reads the scene after creation, so the scene must outlive the
 * accel (it does: the session holds it too).
 */
#include "accel.h"
#include "clock.h"
#include "defaults.h"
#include "memory.h"

#include <embree3/rtcore.h>
#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

struct pm_accel {
    RTCDevice device;
    RTCScene scene;
    _Atomic long long bytes; /* Embree reports from its build threads */
    _Atomic uint64_t admitted; /* of those, what is committed against --max-memory now */
    double build_seconds;
    /* Rejects hits at t == 0: an offset origin can still lie exactly in the plane of a
     * neighbouring wall (corner hits, float grids far from the origin), and such a hit would
     * flip the side the path continues on. Far below any visible gap. */
    float tnear;
    const pm_scene *source;         /* read by the alpha filter */
    uint32_t *tri_of_prim[2];       /* per geometry: Embree primID -> scene triangle (NULL: the same) */
    uint32_t alpha_tested;          /* triangles in the filtered geometry */
    /* instanced meshes: their child scenes, and per mesh and geometry primID -> stored triangle
     * (NULL: the mesh's first_triangle + primID) */
    RTCScene *mesh_scenes;
    uint32_t *(*mesh_tri_of_prim)[2];
    struct filter_user *filter_users; /* instanced_mesh_count + 1: the flat geometry's, then each mesh's */
};

enum { OPAQUE_GEOMETRY = 0, ALPHA_GEOMETRY = 1, PLACEMENT_GEOMETRY = 2 };

/* What the alpha filter of one geometry needs: the accel and which mesh (-1: the flat triangles). */
struct filter_user {
    const pm_accel *accel;
    int32_t mesh;
};

/* The scene's triangle id of Embree's (instID, geomID, primID). */
static inline uint32_t triangle_id(const pm_accel *a, unsigned inst, unsigned geom, unsigned prim) {
    if (inst == RTC_INVALID_GEOMETRY_ID) {
        const uint32_t *tri_of_prim = a->tri_of_prim[geom];
        return tri_of_prim ? tri_of_prim[prim] : prim;
    }
    const pm_scene *s = a->source;
    uint32_t placement = inst - PLACEMENT_GEOMETRY, mesh = s->placements[placement].mesh;
    const uint32_t *tri_of_prim = a->mesh_tri_of_prim[mesh][geom];
    return pm_scene_placed_id(s, placement, tri_of_prim ? tri_of_prim[prim] : s->instanced_meshes[mesh].first_triangle + prim);
}

/* Debian's Embree keeps its assertions: a ray whose origin or direction has a coordinate beyond
 * +-1.844e18 (Embree's FLT_LARGE) or NaN, or whose tfar is NaN, aborts the whole process (found
 * by fuzzing, tests/fuzz/regressions/). Scenes reaching that far are refused at creation; a ray
 * from farther (a camera or a light out there) is answered as a miss, or as blocked for a
 * shadow ray, without reaching Embree. */
#define EMBREE_MAX_COORDINATE 1.8e18f
static bool ray_in_range(vec3 o, vec3 d, float tmax) {
    /* & rather than &&: seven compares and no branch, on every ray cast */
    return (fabsf(o.x) <= EMBREE_MAX_COORDINATE) & (fabsf(o.y) <= EMBREE_MAX_COORDINATE) &
           (fabsf(o.z) <= EMBREE_MAX_COORDINATE) & (fabsf(d.x) <= EMBREE_MAX_COORDINATE) &
           (fabsf(d.y) <= EMBREE_MAX_COORDINATE) & (fabsf(d.z) <= EMBREE_MAX_COORDINATE) & !isnan(tmax);
}

/* A uniform number in [0, 1) from the ray (origin and direction bits) and the triangle.
 *
 * Why a hash and not a random stream: the decision must be a function of (ray, surface) alone.
 * Embree may offer the same triangle to a ray more than once (spatial splits put it in several
 * leaves), and consuming a fresh number each time would let a ray through a pane of alpha a
 * with probability below 1 - a. Distinct rays (every ray of every path starts from a new random
 * point or direction) get independent decisions, and the decision needs no thread-dependent
 * state, so images still depend only on the seed. */
static float crossing_uniform(const float org[3], const float dir[3], uint32_t tri) {
    uint64_t h = 0x9E3779B97F4A7C15ull * (tri + 1ull);
    for (int k = 0; k < 6; k++) {
        uint32_t bits;
        memcpy(&bits, k < 3 ? &org[k] : &dir[k - 3], 4);
        h ^= bits;
        h ^= h >> 31; h *= 0x7FB5D329728EA185ull;
        h ^= h >> 27; h *= 0x81DADEF4BC2DD44Dull;
        h ^= h >> 33;
    }
    return (float)(h >> 40) * 0x1p-24f;
}

/* glTF: MASK is opaque where alpha >= alphaCutoff; BLEND is here stochastic transparency, a
 * hit with probability alpha, so every kind of ray passes a pane with probability 1 - alpha. */
static bool alpha_accepts(const pm_scene *s, uint32_t tri, float b1, float b2, const float org[3], const float dir[3]) {
    const pm_material *m = &s->materials[pm_scene_triangle_material(s, tri)];
    float alpha = pm_scene_alpha_at(s, tri, b1, b2);
    if (m->alpha_mode == PM_ALPHA_MASK) return alpha >= m->alpha_cutoff;
    if (alpha >= 1.f) return true;
    return crossing_uniform(org, dir, tri) < alpha;
}

/* Embree's intersection and occlusion filter for the alpha geometry: clearing valid[i] makes
 * Embree go on looking past this candidate. */
static void alpha_filter(const struct RTCFilterFunctionNArguments *args) {
    const struct filter_user *user = args->geometryUserPtr;
    const pm_accel *a = user->accel;
    unsigned n = args->N;
    /* Embree's packets are structures of arrays; its accessors for them are C++ only. Ray:
     * org_x, org_y, org_z, tnear, dir_x, dir_y, dir_z, ...; hit: Ng_x, Ng_y, Ng_z, u, v, primID, geomID,
     * instID[0]. Inside an instance the ray is in the mesh's space: the hash only needs to be a
     * function of the ray, which it still is. */
    const float *ray = (const float *)args->ray, *hit_f = (const float *)args->hit;
    const unsigned *hit_u = (const unsigned *)args->hit;
    for (unsigned i = 0; i < n; i++) {
        if (args->valid[i] != -1) continue;
        float org[3] = {ray[0 * n + i], ray[1 * n + i], ray[2 * n + i]};
        float dir[3] = {ray[4 * n + i], ray[5 * n + i], ray[6 * n + i]};
        uint32_t tri = user->mesh < 0 ? a->tri_of_prim[ALPHA_GEOMETRY][hit_u[5 * n + i]]
                                      : triangle_id(a, hit_u[7 * n + i], ALPHA_GEOMETRY, hit_u[5 * n + i]);
        if (!alpha_accepts(a->source, tri, hit_f[3 * n + i], hit_f[4 * n + i], org, dir))
            args->valid[i] = 0;
    }
}

static bool track_memory(void *user, ssize_t bytes, bool post) {
    pm_accel *a = user;
    atomic_fetch_add(&a->bytes, (long long)bytes); /* negative on release */
    if (bytes < 0) {
        /* give back no more than this device committed: Embree's own bookkeeping need not pair up */
        uint64_t had = atomic_load(&a->admitted), back;
        do back = had < (uint64_t)-bytes ? had : (uint64_t)-bytes;
        while (!atomic_compare_exchange_weak(&a->admitted, &had, had - back));
        pm_memory_release(back);
        return true;
    }
    /* Embree asks before it allocates: what does not fit beside everything else admitted is
     * refused (Embree then fails the build with RTC_ERROR_OUT_OF_MEMORY, reported below),
     * instead of exhausting the machine. A report after the fact can no longer be refused. */
    if (post) return true;
    if (!pm_memory_admit((uint64_t)bytes, "acceleration structure")) return false;
    atomic_fetch_add(&a->admitted, (uint64_t)bytes);
    return true;
}

/* Adds the triangles `tris` (count of them; NULL: all from `first`, in order) as geometry `id` of
 * `target` over the vertex buffer holding the stored vertices from first_vertex on; with
 * `filtered`, the alpha filter decides each candidate hit (user: its filter_user). The map is
 * stored in *map. */
static bool add_geometry_to(pm_accel *a, RTCScene target, RTCBuffer vertices, uint32_t first_vertex, uint32_t vertex_count,
                            const pm_scene *s, uint32_t *tris, uint32_t first, uint32_t count, unsigned id,
                            struct filter_user *user, uint32_t **map) {
    RTCGeometry g = rtcNewGeometry(a->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, vertices, 0, 3 * sizeof(float), vertex_count);
    uint32_t *triangles = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                  3 * sizeof(uint32_t), count);
    if (!triangles) {
        rtcReleaseGeometry(g);
        return false;
    }
    if (!tris && !first_vertex) memcpy(triangles, s->indices + 3 * (size_t)first, 3 * sizeof(uint32_t) * (size_t)count);
    else
        for (uint32_t i = 0; i < count; i++)
            for (int k = 0; k < 3; k++)
                triangles[3 * (size_t)i + k] = s->indices[3 * (size_t)(tris ? tris[i] : first + i) + k] - first_vertex;
    if (user) {
        rtcSetGeometryUserData(g, user);
        rtcSetGeometryIntersectFilterFunction(g, alpha_filter);
        rtcSetGeometryOccludedFilterFunction(g, alpha_filter);
    }
    rtcCommitGeometry(g);
    rtcAttachGeometryByID(target, g, id);
    rtcReleaseGeometry(g);
    *map = tris;
    return true;
}

static bool add_geometry(pm_accel *a, RTCBuffer vertices, const pm_scene *s, uint32_t *tris, uint32_t count,
                         unsigned id, bool filtered) {
    uint32_t flat_vertices = s->instanced_mesh_count ? s->instanced_meshes[0].first_vertex : s->vertex_count;
    return add_geometry_to(a, a->scene, vertices, 0, flat_vertices, s, tris, 0, count, id,
                           filtered ? &a->filter_users[0] : NULL, &a->tri_of_prim[id]);
}

/* Splits the stored triangles [first, first + total) by whether their material can let a ray
 * through; false when out of memory. */
static bool split_triangles(const pm_scene *s, uint32_t first, uint32_t total, uint32_t **opaque, uint32_t *opaque_count,
                            uint32_t **alpha, uint32_t *alpha_count) {
    *opaque = *alpha = NULL;
    *opaque_count = *alpha_count = 0;
    if (!s->analysis.has_non_opaque) return true;
    bool *see_through = pm_calloc(s->material_count ? s->material_count : 1, sizeof(bool), "acceleration structure");
    if (!see_through) return false;
    for (uint32_t i = 0; i < s->material_count; i++) see_through[i] = pm_material_can_be_transparent(s, &s->materials[i]);
    for (uint32_t t = first; t < first + total; t++) *alpha_count += see_through[s->triangle_material[t]];
    *opaque_count = total - *alpha_count;
    *opaque = pm_malloc(((size_t)*opaque_count + 1) * sizeof(uint32_t), "acceleration structure");
    *alpha = pm_malloc(((size_t)*alpha_count + 1) * sizeof(uint32_t), "acceleration structure");
    if (!*opaque || !*alpha) {
        free(see_through);
        free(*opaque);
        free(*alpha);
        *opaque = *alpha = NULL;
        return false;
    }
    uint32_t no = 0, na = 0;
    for (uint32_t t = first; t < first + total; t++) {
        if (see_through[s->triangle_material[t]]) (*alpha)[na++] = t;
        else (*opaque)[no++] = t;
    }
    free(see_through);
    return true;
}

/* Instanced mesh i as a child scene of its own, over its own vertices, committed; false when out of memory. */
static bool add_instanced_mesh(pm_accel *a, const pm_scene *s, uint32_t i) {
    const pm_instanced_mesh *m = &s->instanced_meshes[i];
    a->filter_users[i + 1] = (struct filter_user){a, (int32_t)i};
    RTCScene child = a->mesh_scenes[i] = rtcNewScene(a->device);
    rtcSetSceneBuildQuality(child, RTC_BUILD_QUALITY_HIGH);
    rtcSetSceneFlags(child, RTC_SCENE_FLAG_ROBUST);
    uint32_t *opaque, *alpha, opaque_count, alpha_count;
    if (!split_triangles(s, m->first_triangle, m->triangle_count, &opaque, &opaque_count, &alpha, &alpha_count)) return false;
    RTCBuffer mesh_vertices = rtcNewBuffer(a->device, 3 * sizeof(float) * (size_t)m->vertex_count + 16);
    float *data = mesh_vertices ? rtcGetBufferData(mesh_vertices) : NULL;
    bool ok = data != NULL;
    if (ok) memcpy(data, s->positions + m->first_vertex, 3 * sizeof(float) * (size_t)m->vertex_count);
    if (ok && !s->analysis.has_non_opaque)
        ok = add_geometry_to(a, child, mesh_vertices, m->first_vertex, m->vertex_count, s, NULL, m->first_triangle,
                             m->triangle_count, OPAQUE_GEOMETRY, NULL, &a->mesh_tri_of_prim[i][OPAQUE_GEOMETRY]);
    if (ok && opaque_count) {
        ok = add_geometry_to(a, child, mesh_vertices, m->first_vertex, m->vertex_count, s, opaque, 0, opaque_count,
                             OPAQUE_GEOMETRY, NULL, &a->mesh_tri_of_prim[i][OPAQUE_GEOMETRY]);
        if (ok) opaque = NULL;
    }
    if (ok && alpha_count) {
        ok = add_geometry_to(a, child, mesh_vertices, m->first_vertex, m->vertex_count, s, alpha, 0, alpha_count,
                             ALPHA_GEOMETRY, &a->filter_users[i + 1], &a->mesh_tri_of_prim[i][ALPHA_GEOMETRY]);
        if (ok) alpha = NULL;
        if (ok) a->alpha_tested += alpha_count;
    }
    free(opaque);
    free(alpha);
    if (mesh_vertices) rtcReleaseBuffer(mesh_vertices);
    if (ok) rtcCommitScene(child);
    return ok;
}

pm_accel *pm_accel_create(const pm_scene *s, char *err, size_t err_size) {
    /* a failure reported below is one of this build's, never one handled before it */
    uint64_t failures = pm_memory_failure_mark();
    float reach = fmaxf(fmaxf(fmaxf(fabsf(s->bounds_min.x), fabsf(s->bounds_max.x)), fmaxf(fabsf(s->bounds_min.y), fabsf(s->bounds_max.y))),
                        fmaxf(fabsf(s->bounds_min.z), fabsf(s->bounds_max.z)));
    if (s->triangle_count && !(reach <= EMBREE_MAX_COORDINATE)) {
        snprintf(err, err_size, "the scene reaches %.3g from the origin, beyond the %.2g Embree can trace (accel)",
                 (double)reach, (double)EMBREE_MAX_COORDINATE);
        return NULL;
    }
    pm_accel *a = pm_calloc(1, sizeof *a, "acceleration structure");
    if (!a) {
        snprintf(err, err_size, "out of memory (acceleration structure, %zu bytes)", sizeof *a);
        return NULL;
    }
    double start = pm_now_seconds();
    a->source = s;
    a->device = rtcNewDevice("verbose=0");
    if (!a->device) {
        snprintf(err, err_size, "Embree: cannot create a device (error %d)", (int)rtcGetDeviceError(NULL));
        free(a);
        return NULL;
    }
    rtcSetDeviceMemoryMonitorFunction(a->device, track_memory, a);
    a->scene = rtcNewScene(a->device);
    rtcSetSceneBuildQuality(a->scene, RTC_BUILD_QUALITY_HIGH);
    rtcSetSceneFlags(a->scene, RTC_SCENE_FLAG_ROBUST);
    uint32_t flat_count = pm_scene_flat_triangles(s);
    uint32_t flat_vertices = s->instanced_mesh_count ? s->instanced_meshes[0].first_vertex : s->vertex_count;
    a->filter_users = pm_calloc((size_t)s->instanced_mesh_count + 1, sizeof *a->filter_users, "acceleration structure");
    if (s->instanced_mesh_count) {
        a->mesh_scenes = pm_calloc(s->instanced_mesh_count, sizeof *a->mesh_scenes, "acceleration structure");
        a->mesh_tri_of_prim = pm_calloc(s->instanced_mesh_count, sizeof *a->mesh_tri_of_prim, "acceleration structure");
    }
    if (!a->filter_users || (s->instanced_mesh_count && (!a->mesh_scenes || !a->mesh_tri_of_prim))) {
        /* the failed allocation's own record names it and its bytes */
        snprintf(err, err_size, "out of memory (%s)", pm_memory_failure_since(failures) ? pm_memory_failure_since(failures) : "acceleration structure");
        pm_accel_destroy(a);
        return NULL;
    }
    a->filter_users[0] = (struct filter_user){a, -1};
    uint32_t *opaque, *alpha, opaque_count, alpha_count;
    if (!split_triangles(s, 0, flat_count, &opaque, &opaque_count, &alpha, &alpha_count)) {
        snprintf(err, err_size, "out of memory (%s) for %u triangles", pm_memory_failure_since(failures) ? pm_memory_failure_since(failures) : "triangle lists", s->triangle_count);
        pm_accel_destroy(a);
        return NULL;
    }
    /* Copied into Embree's own buffer, 16 bytes longer: Embree may read 16 bytes at the last
     * element (SSE loads), which a tightly packed vec3 array does not guarantee. */
    size_t vertex_bytes = 3 * sizeof(float) * (size_t)flat_vertices;
    RTCBuffer vertices = flat_count ? rtcNewBuffer(a->device, vertex_bytes + 16) : NULL;
    float *vertex_data = vertices ? rtcGetBufferData(vertices) : NULL;
    bool ok = vertex_data != NULL || !flat_count;
    if (vertex_data) memcpy(vertex_data, s->positions, vertex_bytes);
    if (ok && flat_count && !s->analysis.has_non_opaque) ok = add_geometry(a, vertices, s, NULL, flat_count, OPAQUE_GEOMETRY, false);
    if (ok && opaque_count) {
        ok = add_geometry(a, vertices, s, opaque, opaque_count, OPAQUE_GEOMETRY, false);
        if (ok) opaque = NULL; /* owned by the accel now */
    }
    if (ok && alpha_count) {
        ok = add_geometry(a, vertices, s, alpha, alpha_count, ALPHA_GEOMETRY, true);
        if (ok) alpha = NULL;
        if (ok) a->alpha_tested = alpha_count;
    }
    free(opaque);
    free(alpha);
    if (vertices) rtcReleaseBuffer(vertices);
    /* each instanced mesh once, as a child scene over its own vertices */
    for (uint32_t i = 0; ok && i < s->instanced_mesh_count; i++) {
        ok = add_instanced_mesh(a, s, i);
    }
    /* each placement an instance of its mesh's child scene */
    for (uint32_t p = 0; ok && p < s->placement_count; p++) {
        RTCGeometry g = rtcNewGeometry(a->device, RTC_GEOMETRY_TYPE_INSTANCE);
        rtcSetGeometryInstancedScene(g, a->mesh_scenes[s->placements[p].mesh]);
        rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_ROW_MAJOR, s->placements[p].object_to_world);
        rtcCommitGeometry(g);
        rtcAttachGeometryByID(a->scene, g, PLACEMENT_GEOMETRY + p);
        rtcReleaseGeometry(g);
    }
    if (!ok) {
        snprintf(err, err_size, "out of memory (%s)",
                 pm_memory_failure_since(failures) ? pm_memory_failure_since(failures) : "Embree geometry");
        pm_accel_destroy(a);
        return NULL;
    }
    rtcCommitScene(a->scene);
    enum RTCError e = rtcGetDeviceError(a->device);
    if (e == RTC_ERROR_OUT_OF_MEMORY) {
        if (!pm_memory_failure_since(failures)) pm_memory_fail((uint64_t)atomic_load(&a->bytes), "acceleration structure");
        snprintf(err, err_size, "out of memory (%s)", pm_memory_failure_since(failures));
        pm_accel_destroy(a);
        return NULL;
    }
    if (e != RTC_ERROR_NONE) {
        snprintf(err, err_size, "Embree: scene build failed (error %d)", (int)e);
        pm_accel_destroy(a);
        return NULL;
    }
    a->tnear = s->ray_scale * 1e-9f;
    a->build_seconds = pm_now_seconds() - start;
    return a;
}

void pm_accel_destroy(pm_accel *a) {
    if (!a) return;
    if (a->scene) rtcReleaseScene(a->scene);
    uint32_t meshes = a->source ? a->source->instanced_mesh_count : 0;
    for (uint32_t i = 0; a->mesh_scenes && i < meshes; i++)
        if (a->mesh_scenes[i]) rtcReleaseScene(a->mesh_scenes[i]);
    for (uint32_t i = 0; a->mesh_tri_of_prim && i < meshes; i++) {
        free(a->mesh_tri_of_prim[i][OPAQUE_GEOMETRY]);
        free(a->mesh_tri_of_prim[i][ALPHA_GEOMETRY]);
    }
    free(a->mesh_scenes);
    free(a->mesh_tri_of_prim);
    free(a->filter_users);
    if (a->device) rtcReleaseDevice(a->device);
    pm_memory_release(atomic_load(&a->admitted)); /* whatever Embree did not report freeing */
    free(a->tri_of_prim[OPAQUE_GEOMETRY]);
    free(a->tri_of_prim[ALPHA_GEOMETRY]);
    free(a);
}

static void fill_ray(struct RTCRay *r, vec3 o, vec3 d, float tnear, float tmax) {
    r->org_x = o.x; r->org_y = o.y; r->org_z = o.z;
    r->dir_x = d.x; r->dir_y = d.y; r->dir_z = d.z;
    r->tnear = tnear;
    r->tfar = tmax;
    r->time = 0.f;
    r->mask = 0xFFFFFFFFu;
    r->id = 0;
    r->flags = 0;
}

static bool intersect_one(const pm_accel *a, vec3 o, vec3 d, float tmax, pm_hit *hit) {
    if (!ray_in_range(o, d, tmax)) return false;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRayHit rh;
    fill_ray(&rh.ray, o, d, a->tnear, tmax);
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(a->scene, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
    hit->t = rh.ray.tfar;
    hit->tri = triangle_id(a, rh.hit.instID[0], rh.hit.geomID, rh.hit.primID);
    hit->b1 = rh.hit.u;
    hit->b2 = rh.hit.v;
    return true;
}

/* The packets' one-by-one loop calls intersect_one, not this: bench/photon_ceiling.c wraps this
 * symbol and the packets' to log each ray once. */
bool pm_accel_intersect(const pm_accel *a, vec3 o, vec3 d, float tmax, pm_hit *hit) { return intersect_one(a, o, d, tmax, hit); }

/* Four consecutive vec3 (xyz xyz xyz xyz, three vector loads) as one vector per axis. */
static inline void axes_of_four(const vec3 *v, pm_f4_ *x, pm_f4_ *y, pm_f4_ *z) {
    pm_f4_ a, b, c;
    memcpy(&a, (const char *)v, sizeof a);      /* x0 y0 z0 x1 */
    memcpy(&b, (const char *)v + 16, sizeof b); /* y1 z1 x2 y2 */
    memcpy(&c, (const char *)v + 32, sizeof c); /* z2 x3 y3 z3 */
    *x = PM_SHUFFLE(PM_SHUFFLE(a, b, 0, 3, 6, 7), c, 0, 1, 2, 5);
    *y = PM_SHUFFLE(PM_SHUFFLE(a, b, 1, 4, 7, 0), c, 0, 1, 2, 6);
    *z = PM_SHUFFLE(PM_SHUFFLE(a, b, 2, 5, 0, 0), c, 0, 1, 4, 7);
}

/* -1 in the lanes where |v| <= EMBREE_MAX_COORDINATE (not where v is NaN), else 0. */
static inline pm_i4_ within_embree_range(pm_f4_ v) {
    pm_f4_ magnitude = (pm_f4_)((pm_u4_)v & 0x7fffffffu);
    return magnitude <= EMBREE_MAX_COORDINATE;
}

/* A packet of the m <= PM_ACCEL_PACKET rays o[j], d[j]; lanes past m repeat the first ray (Embree
 * reads every lane). valid: -1 for the lanes Embree is to trace (the first m, those in range when
 * check_range, as ray_in_range decides), 0 for the rest, which it answers as misses. Four lanes
 * at a time: 32 instructions a ray, where a lane by lane copy took 70, beside Embree's 770. */
_Static_assert(sizeof(vec3) == 12 && PM_ACCEL_PACKET == 8, "a packet is two sets of four packed vec3");
static void fill_packet(struct RTCRayHit8 *rh, int *valid, const vec3 *o, const vec3 *d, size_t m, float tnear, bool check_range) {
    vec3 padded_o[PM_ACCEL_PACKET], padded_d[PM_ACCEL_PACKET];
    if (m < PM_ACCEL_PACKET) {
        for (size_t j = 0; j < PM_ACCEL_PACKET; j++) {
            padded_o[j] = o[j < m ? j : 0];
            padded_d[j] = d[j < m ? j : 0];
        }
        o = padded_o;
        d = padded_d;
    }
    /* what Embree reads of every lane besides the coordinates: the same in all eight */
    uint32_t near_bits, far_bits;
    float far = INFINITY;
    memcpy(&near_bits, &tnear, sizeof near_bits);
    memcpy(&far_bits, &far, sizeof far_bits);
    const struct { void *lanes; uint32_t bits; } same[] = {
        {rh->ray.tnear, near_bits}, {rh->ray.tfar, far_bits}, {rh->ray.time, 0u},         {rh->ray.mask, ~0u},
        {rh->ray.id, 0u},           {rh->ray.flags, 0u},      {rh->hit.geomID, RTC_INVALID_GEOMETRY_ID},
        {rh->hit.instID[0], RTC_INVALID_GEOMETRY_ID},
    };
#pragma GCC unroll 8
    for (size_t k = 0; k < sizeof same / sizeof same[0]; k++) {
        pm_u4_ four = {same[k].bits, same[k].bits, same[k].bits, same[k].bits};
        memcpy(same[k].lanes, &four, sizeof four);
        memcpy((uint32_t *)same[k].lanes + 4, &four, sizeof four);
    }
    float *const axes[6] = {rh->ray.org_x, rh->ray.org_y, rh->ray.org_z, rh->ray.dir_x, rh->ray.dir_y, rh->ray.dir_z};
#pragma GCC unroll 2
    for (int at = 0; at < PM_ACCEL_PACKET; at += 4) {
        pm_f4_ v[6];
        axes_of_four(o + at, &v[0], &v[1], &v[2]);
        axes_of_four(d + at, &v[3], &v[4], &v[5]);
        pm_i4_ in_range = {-1, -1, -1, -1};
#pragma GCC unroll 6
        for (int k = 0; k < 6; k++) {
            memcpy(axes[k] + at, &v[k], sizeof v[k]);
            in_range &= within_embree_range(v[k]);
        }
        pm_i4_ lane = {at, at + 1, at + 2, at + 3}, count = {(int)m, (int)m, (int)m, (int)m};
        pm_i4_ use = lane < count;
        if (check_range) use &= in_range;
        memcpy(valid + at, &use, sizeof use);
    }
}

void pm_accel_intersect_packets(const pm_accel *a, size_t n, const vec3 *o, const vec3 *d, bool coherent, bool *hit, pm_hit *hits) {
    /* Through instances Embree answers unrelated rays faster one by one: on 10,000 placements of a
     * small mesh its packets of 8 ran at 0.8 of rtcIntersect1's rate on the same photon rays (on
     * flat scenes they run 1.06-1.56 times faster, docs/design.md, the photon pass's waves) */
    if (!coherent && a->mesh_scenes) {
        for (size_t i = 0; i < n; i++) hit[i] = intersect_one(a, o[i], d[i], INFINITY, &hits[i]);
        return;
    }
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = coherent ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    for (size_t base = 0; base < n; base += PM_ACCEL_PACKET) {
        size_t m = n - base < PM_ACCEL_PACKET ? n - base : PM_ACCEL_PACKET;
        _Alignas(32) int valid[PM_ACCEL_PACKET]; /* Embree asks for the mask aligned like the packet */
        struct RTCRayHit8 rh;
        /* rays Embree must not see stay invalid: a miss */
        fill_packet(&rh, valid, o + base, d + base, m, a->tnear, true);
        rtcIntersect8(valid, a->scene, &ctx, &rh);
        for (size_t j = 0; j < m; j++) {
            size_t i = base + j;
            hit[i] = (valid[j] != 0) & (rh.hit.geomID[j] != RTC_INVALID_GEOMETRY_ID);
            if (!hit[i]) continue;
            hits[i].t = rh.ray.tfar[j];
            hits[i].tri = triangle_id(a, rh.hit.instID[0][j], rh.hit.geomID[j], rh.hit.primID[j]);
            hits[i].b1 = rh.hit.u[j];
            hits[i].b2 = rh.hit.v[j];
        }
    }
}

bool pm_accel_occluded(const pm_accel *a, vec3 o, vec3 d, float tmax) {
    if (!ray_in_range(o, d, tmax)) return true;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRay r;
    fill_ray(&r, o, d, a->tnear, tmax);
    rtcOccluded1(a->scene, &ctx, &r);
    return r.tfar < 0.f; /* Embree sets tfar to -inf on a hit */
}

/* What a point query carries through Embree to its visitor. */
struct near_query {
    const pm_accel *accel;
    bool (*visit)(void *user, uint32_t tri, float *radius);
    void *user;
    bool ended;
};

/* Embree's point query callback: one candidate primitive whose bounds reach the query's ball.
 * Shrinking the radius to 0 stops the traversal once the visitor has seen enough; a visitor that
 * shrinks it prunes what lies beyond (outside instances only, where the ball is the world's). */
static bool near_candidate(struct RTCPointQueryFunctionArguments *args) {
    struct near_query *q = args->userPtr;
    if (q->ended) return false;
    bool instanced = args->context->instStackSize != 0;
    unsigned inst = instanced ? args->context->instID[0] : RTC_INVALID_GEOMETRY_ID;
    float radius = args->query->radius;
    if (q->visit(q->user, triangle_id(q->accel, inst, args->geomID, args->primID), &radius)) {
        if (instanced || !(radius < args->query->radius)) return false;
        args->query->radius = radius;
        return true;
    }
    q->ended = true;
    args->query->radius = 0.f;
    return true;
}

bool pm_accel_triangles_near(const pm_accel *a, vec3 p, float radius, bool (*visit)(void *user, uint32_t tri, float *radius),
                             void *user) {
    if (!ray_in_range(p, v3s(0.f), radius) || !(radius >= 0.f) || !isfinite(radius)) return false;
    struct RTCPointQuery query = {p.x, p.y, p.z, 0.f, radius};
    struct RTCPointQueryContext ctx;
    rtcInitPointQueryContext(&ctx);
    struct near_query q = {a, visit, user, false};
    rtcPointQuery(a->scene, &query, &ctx, near_candidate, &q);
    return !q.ended;
}

uint64_t pm_accel_forecast_bytes(const pm_scene *s, bool building) {
    /* stored triangles only: a placement adds an instance, not its mesh's triangles again; the
     * vertex buffers are Embree's too */
    return (uint64_t)s->triangle_count * (building ? PM_ACCEL_BUILD_BYTES_PER_TRIANGLE : PM_ACCEL_BUILT_BYTES_PER_TRIANGLE) +
           (uint64_t)s->vertex_count * PM_ACCEL_BYTES_PER_VERTEX + (uint64_t)s->placement_count * PM_ACCEL_BYTES_PER_PLACEMENT;
}

size_t pm_accel_bytes(const pm_accel *a) {
    long long b = atomic_load(&((pm_accel *)a)->bytes);
    return b > 0 ? (size_t)b : 0;
}
double pm_accel_build_seconds(const pm_accel *a) { return a->build_seconds; }
uint32_t pm_accel_alpha_tested_triangles(const pm_accel *a) { return a->alpha_tested; }

double pm_accel_bench_raw(const pm_accel *a, const vec3 *origins, const vec3 *dirs, size_t n, bool packet, size_t *hits) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    size_t count = 0;
    double start = pm_now_seconds();
    if (packet) {
        for (size_t base = 0; base < n; base += PM_ACCEL_PACKET) {
            size_t m = n - base < PM_ACCEL_PACKET ? n - base : PM_ACCEL_PACKET;
            _Alignas(32) int valid[PM_ACCEL_PACKET];
            struct RTCRayHit8 rh;
            fill_packet(&rh, valid, origins + base, dirs + base, m, a->tnear, false);
            rtcIntersect8(valid, a->scene, &ctx, &rh);
            for (size_t j = 0; j < m; j++) count += rh.hit.geomID[j] != RTC_INVALID_GEOMETRY_ID;
        }
    } else {
        for (size_t i = 0; i < n; i++) {
            struct RTCRayHit rh;
            fill_ray(&rh.ray, origins[i], dirs[i], a->tnear, INFINITY);
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(a->scene, &ctx, &rh);
            count += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
        }
    }
    double seconds = pm_now_seconds() - start;
    if (hits) *hits = count;
    return seconds;
}

/* accel.c: the Embree 3 scene over all triangles, with closest-hit and occlusion queries.
 *
 * Embree appears nowhere else. The geometry is copied into Embree's own buffers, so the
 * accel does not depend on the scene's arrays after creation.
 */
#include "accel.h"

#include <embree3/rtcore.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

struct pm_accel {
    RTCDevice device;
    RTCScene scene;
    _Atomic long long bytes; /* Embree reports from its build threads */
    double build_seconds;
    /* Rejects hits at t == 0: an offset origin can still lie exactly in the plane of a
     * neighbouring wall (corner hits, float grids far from the origin), and such a hit would
     * flip the side the path continues on. Far below any visible gap. */
    float tnear;
};

static double now_seconds(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + ts.tv_nsec * 1e-9;
}

static bool track_memory(void *user, ssize_t bytes, bool post) {
    pm_accel *a = user;
    atomic_fetch_add(&a->bytes, (long long)bytes); /* negative on release */
    return true;
}

pm_accel *pm_accel_create(const pm_scene *s, char *err, size_t err_size) {
    pm_accel *a = calloc(1, sizeof *a);
    double start = now_seconds();
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
    RTCGeometry g = rtcNewGeometry(a->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    /* Copied into Embree's own buffers: Embree may read 16 bytes at the last element (SSE
     * loads), which a tightly packed vec3 array does not guarantee. */
    float *vertices = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                              s->vertex_count);
    uint32_t *triangles = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                  3 * sizeof(uint32_t), s->triangle_count);
    if (!vertices || !triangles) {
        snprintf(err, err_size, "Embree: out of memory for %u vertices", s->vertex_count);
        rtcReleaseGeometry(g);
        pm_accel_destroy(a);
        return NULL;
    }
    memcpy(vertices, s->positions, 3 * sizeof(float) * (size_t)s->vertex_count);
    memcpy(triangles, s->indices, 3 * sizeof(uint32_t) * (size_t)s->triangle_count);
    rtcCommitGeometry(g);
    rtcAttachGeometry(a->scene, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(a->scene);
    enum RTCError e = rtcGetDeviceError(a->device);
    if (e != RTC_ERROR_NONE) {
        snprintf(err, err_size, "Embree: scene build failed (error %d)", (int)e);
        pm_accel_destroy(a);
        return NULL;
    }
    a->tnear = s->ray_scale * 1e-9f;
    a->build_seconds = now_seconds() - start;
    return a;
}

void pm_accel_destroy(pm_accel *a) {
    if (!a) return;
    if (a->scene) rtcReleaseScene(a->scene);
    if (a->device) rtcReleaseDevice(a->device);
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

bool pm_accel_intersect(const pm_accel *a, vec3 o, vec3 d, float tmax, pm_hit *hit) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRayHit rh;
    fill_ray(&rh.ray, o, d, a->tnear, tmax);
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(a->scene, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
    hit->t = rh.ray.tfar;
    hit->tri = rh.hit.primID;
    hit->b1 = rh.hit.u;
    hit->b2 = rh.hit.v;
    return true;
}

bool pm_accel_occluded(const pm_accel *a, vec3 o, vec3 d, float tmax) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRay r;
    fill_ray(&r, o, d, a->tnear, tmax);
    rtcOccluded1(a->scene, &ctx, &r);
    return r.tfar < 0.f; /* Embree sets tfar to -inf on a hit */
}

size_t pm_accel_bytes(const pm_accel *a) {
    long long b = atomic_load(&((pm_accel *)a)->bytes);
    return b > 0 ? (size_t)b : 0;
}
double pm_accel_build_seconds(const pm_accel *a) { return a->build_seconds; }

double pm_accel_bench_raw(const pm_accel *a, const vec3 *origins, const vec3 *dirs, size_t n, size_t *hits) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    size_t count = 0;
    double start = now_seconds();
    for (size_t i = 0; i < n; i++) {
        struct RTCRayHit rh;
        fill_ray(&rh.ray, origins[i], dirs[i], a->tnear, INFINITY);
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(a->scene, &ctx, &rh);
        count += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
    }
    double seconds = now_seconds() - start;
    if (hits) *hits = count;
    return seconds;
}

/* camera.c: camera rays through film positions, pixel sizes, and scene points connected back to their pixels. */
#include "camera.h"

void pm_camera_ray(const pm_camera *c, int width, int height, float x, float y, vec3 *origin, vec3 *dir) {
    pm_camera_view v = pm_camera_view_make(c, width, height);
    pm_camera_view_ray(&v, x, y, origin, dir);
}

void pm_camera_view_ray(const pm_camera_view *v, float x, float y, vec3 *origin, vec3 *dir) {
    const pm_camera *c = &v->camera;
    float sx = (2.f * x / v->width - 1.f) * v->half * v->aspect;
    float sy = (1.f - 2.f * y / v->height) * v->half;
    vec3 across = v3_add(v3_scale(c->right, sx), v3_scale(c->up, sy));
    if (c->orthographic) {
        *origin = v3_add(c->position, across);
        *dir = c->forward;
    } else {
        *origin = c->position;
        *dir = v3_normalize(v3_add(c->forward, across));
    }
}

float pm_camera_pixel_size(const pm_camera *c, int height, float distance) {
    float h = (float)(height > 0 ? height : 1);
    return c->orthographic ? 2.f * c->ymag / h : 2.f * tanf(0.5f * c->yfov) * distance / h;
}

pm_camera_view pm_camera_view_make(const pm_camera *c, int width, int height) {
    pm_camera_view v;
    v.camera = *c;
    v.width = width;
    v.height = height;
    v.half = c->orthographic ? c->ymag : tanf(0.5f * c->yfov);
    v.aspect = (float)width / (float)height;
    v.pixel_area = (2.f * v.half * v.aspect / (float)width) * (2.f * v.half / (float)height);
    return v;
}

bool pm_camera_connect(const pm_camera_view *view, vec3 p, pm_camera_connection *out) {
    const pm_camera *c = &view->camera;
    float half = view->half, aspect = view->aspect;
    int width = view->width, height = view->height;
    vec3 v = v3_sub(p, c->position);
    float z = v3_dot(v, c->forward);
    if (!(z > 0.f) || !(half > 0.f)) return false;
    float sx = v3_dot(v, c->right), sy = v3_dot(v, c->up);
    if (!c->orthographic) {
        sx /= z;
        sy /= z;
    }
    /* the inverse of pm_camera_ray's film mapping */
    float fx = (sx / (half * aspect) + 1.f) * 0.5f * (float)width;
    float fy = (1.f - sy / half) * 0.5f * (float)height;
    if (!(fx >= 0.f && fx < (float)width && fy >= 0.f && fy < (float)height)) return false;
    int x = (int)fx, y = (int)fy;
    if (x >= width) x = width - 1;
    if (y >= height) y = height - 1;
    out->pixel = (uint32_t)y * (uint32_t)width + (uint32_t)x;
    if (c->orthographic) {
        out->to_camera = v3_neg(c->forward);
        out->distance = z;
        out->importance = 1.f / view->pixel_area;
    } else {
        float d = v3_length(v);
        float cos_axis = z / d;
        out->to_camera = v3_scale(v, -1.f / d);
        out->distance = d;
        out->importance = 1.f / (view->pixel_area * cos_axis * cos_axis * cos_axis * d * d);
    }
    return true;
}

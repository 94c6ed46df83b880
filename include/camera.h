/* camera.h: the pinhole and orthographic camera's rays, pixel sizes, and the connection of a scene point back to its pixel (light tracing).
 *
 * Film positions are in pixels, (0, 0) the top-left corner of an image width x height. A ray
 * through a film position and pm_camera_connect are inverse to each other: a point a camera ray
 * hits connects back to the pixel the ray went through.
 */
#ifndef PM_CAMERA_H
#define PM_CAMERA_H

#include <stdbool.h>
#include <stdint.h>
#include "scene.h"

/* Builds the camera ray through film position (x, y) in pixels (0,0 = top-left corner). */
void pm_camera_ray(const pm_camera *c, int width, int height, float x, float y, vec3 *origin, vec3 *dir);
/* The width of a pixel of an image `height` tall at `distance` along the ray (any distance for an
 * orthographic camera). */
float pm_camera_pixel_size(const pm_camera *c, int height, float distance);

/* A scene point seen from the camera: the pixel a camera ray to it goes through, the unit
 * direction and distance from the point to where that ray starts, and the importance: the
 * factor that turns radiance leaving the point toward the camera, per unit of the surface's
 * projected area (cos at the point x area), into the pixel's mean radiance. For a pinhole it is
 * 1 / (A cos^3 theta d^2), A the pixel's area on an image plane at distance 1, theta the angle to
 * the optical axis, d the distance; orthographic, 1 / A with A the pixel's area in scene units.
 * False when the point projects outside the image or lies behind the camera. */
typedef struct {
    uint32_t pixel;     /* y x width + x */
    vec3 to_camera;
    float distance;
    float importance;
} pm_camera_connection;
/* A camera and image size with what every ray and connection needs computed once (a tangent,
 * the pixel's area): an eye pass makes a ray per pixel, the light tracer many connections. */
typedef struct {
    pm_camera camera;
    int width, height;
    float half, aspect, pixel_area;
} pm_camera_view;
pm_camera_view pm_camera_view_make(const pm_camera *c, int width, int height);
/* pm_camera_ray with the view's tangent, computed once: the same ray, bit for bit. */
void pm_camera_view_ray(const pm_camera_view *v, float x, float y, vec3 *origin, vec3 *dir);
bool pm_camera_connect(const pm_camera_view *v, vec3 p, pm_camera_connection *out);

#endif

/* camera_control.c: orbit, pan, dolly, fly and framing as rotations and translations of a pm_camera. */
#include "camera_control.h"

#include "eye.h"

/* Rodrigues' rotation of v about the unit axis by angle. */
static vec3 rotate(vec3 v, vec3 axis, float angle) {
    float c = cosf(angle), s = sinf(angle);
    return v3_add(v3_add(v3_scale(v, c), v3_scale(v3_cross(axis, v), s)), v3_scale(axis, v3_dot(axis, v) * (1.f - c)));
}

static pm_camera rotate_camera(pm_camera c, vec3 pivot, vec3 axis, float angle) {
    c.position = v3_add(pivot, rotate(v3_sub(c.position, pivot), axis, angle));
    c.forward = v3_normalize(rotate(c.forward, axis, angle));
    c.up = v3_normalize(rotate(c.up, axis, angle));
    c.right = v3_normalize(v3_cross(c.forward, c.up));
    return c;
}

pm_camera pm_camera_orbit(pm_camera c, vec3 pivot, float yaw, float pitch) {
    c = rotate_camera(c, pivot, v3(0.f, 1.f, 0.f), yaw);
    /* no pitch past the poles: the view would flip over */
    float elevation = v3_dot(c.forward, v3(0.f, 1.f, 0.f));
    if ((pitch > 0.f && elevation < -0.98f) || (pitch < 0.f && elevation > 0.98f)) pitch = 0.f;
    return rotate_camera(c, pivot, c.right, pitch);
}

pm_camera pm_camera_pan(pm_camera c, vec3 *pivot, float dx, float dy, int height) {
    float distance = v3_length(v3_sub(*pivot, c.position));
    float per_pixel = pm_camera_pixel_size(&c, height, distance);
    vec3 move = v3_add(v3_scale(c.right, -dx * per_pixel), v3_scale(c.up, dy * per_pixel));
    c.position = v3_add(c.position, move);
    *pivot = v3_add(*pivot, move);
    return c;
}

pm_camera pm_camera_dolly(pm_camera c, vec3 pivot, float steps) {
    if (c.orthographic) { /* moving an orthographic camera changes nothing on screen: zoom */
        c.ymag *= powf(0.85f, steps);
        return c;
    }
    vec3 to = v3_sub(pivot, c.position);
    float distance = v3_length(to);
    if (!(distance > 0.f)) return c;
    float move = distance * (1.f - powf(0.85f, steps));
    if (move > 0.95f * distance) move = 0.95f * distance;
    c.position = v3_add(c.position, v3_scale(to, move / distance));
    return c;
}

pm_camera pm_camera_fly(pm_camera c, vec3 *pivot, const float move[3], float step) {
    vec3 d = v3_add(v3_add(v3_scale(c.forward, move[0]), v3_scale(c.right, move[1])), v3_scale(c.up, move[2]));
    d = v3_scale(d, step);
    c.position = v3_add(c.position, d);
    *pivot = v3_add(*pivot, d);
    return c;
}

pm_camera pm_camera_frame(const pm_scene *s, pm_camera c, float aspect) { return pm_scene_fit_camera(s, c, aspect); }

/* camera_control.h: moving a camera as a person steers it: orbit about a pivot, pan, dolly, fly, frame the scene.
 *
 * Pure functions of a camera (no GL, no window), so the window and the tests share them. World
 * up is +Y (glTF's convention); every step is relative to the scene's size or to the distance
 * to the pivot, so a scene scaled by 1e-3 or 1e3 steers the same.
 */
#ifndef PM_CAMERA_CONTROL_H
#define PM_CAMERA_CONTROL_H

#include "scene.h"

/* Turns the camera about the pivot: yaw about world up, pitch about the camera's right (radians). */
pm_camera pm_camera_orbit(pm_camera c, vec3 pivot, float yaw, float pitch);
/* Slides camera and pivot in the image plane by (dx, dy) pixels of an image `height` tall, so
 * that a point at the pivot's depth follows the cursor. */
pm_camera pm_camera_pan(pm_camera c, vec3 *pivot, float dx, float dy, int height);
/* Moves toward the pivot by 15% of the distance per step (negative: away); never past it. */
pm_camera pm_camera_dolly(pm_camera c, vec3 pivot, float steps);
/* Moves along the camera's forward, right and up by `step` scene units per unit of move; the pivot follows. */
pm_camera pm_camera_fly(pm_camera c, vec3 *pivot, const float move[3], float step);
/* Keeps the orientation and backs off until the scene fills the view (pm_scene_fit_camera). */
pm_camera pm_camera_frame(const pm_scene *s, pm_camera c, float aspect);

#endif

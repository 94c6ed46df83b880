/* sky_choice.h: which environment a run gets (--sky, or the default policy) and the warnings about how the scene is lit.
 *
 * Runs between accel and the passes: it looks at the scene through the accel (how much of the
 * view and of the camera's surroundings geometry encloses) and sets the scene's sky.
 */
#ifndef PM_SKY_CHOICE_H
#define PM_SKY_CHOICE_H

#include <stdbool.h>
#include "accel.h"
#include "scene.h"

typedef struct {
    const char *sky;        /* --sky: none, white, gradient or an .exr/.hdr file; NULL = the default policy */
    bool no_default_light;  /* --no-default-light */
    const char *scene_path; /* for messages */
    bool quiet, stats;      /* no warnings; print the `stat sky` line */
} pm_sky_request;

/* The environment: --sky when given; else the gradient for a file without punctual lights,
 * unless its emitters enclose the view (a closed room lit from inside); else none. Warns when
 * the default is added and when the camera is shut in by geometry that no light is inside.
 * False after printing the error when an environment map cannot be read. */
bool pm_choose_sky(const pm_sky_request *request, pm_scene *scene, const pm_accel *accel, const pm_camera *camera,
                   float aspect);

#endif

/* sky_choice.h: which environment a run gets (--sky, or the default policy) and the warnings about how the scene is lit.
 *
 * A --sky file is read first, before the scene is loaded (pm_sky_prepare), so that a file pmview
 * cannot use costs no load and no BVH build; the choice runs between accel and the passes: it
 * looks at the scene through the accel (how much of the view and of the camera's surroundings
 * geometry encloses) and sets the scene's sky.
 */
#ifndef PM_SKY_CHOICE_H
#define PM_SKY_CHOICE_H

#include <stdbool.h>
#include "accel.h"
#include "scene.h"
#include "sky.h"

typedef struct {
    const char *sky;        /* --sky: none, white, gradient or an .exr/.hdr file; NULL = the default policy */
    bool no_default_light;  /* --no-default-light */
    const char *scene_path; /* for messages */
    bool quiet, stats;      /* no warnings; print the `stat sky` line */
    double rotate_degrees;  /* --sky-rotate: the map turned about +Y */
    pm_sky_map *map;        /* the --sky file's map once read, until pm_choose_sky hands it to the scene */
} pm_sky_request;

/* Reads --sky's file, when it names one: refuses what is not a regular file (a FIFO would be
 * waited on forever), not the format its name says, cut short, larger than PM_SKY_MAX_TEXELS, or
 * over the memory limit by an estimate from its header alone (pm_sky_map_bytes, before any pixel
 * is decoded). Warns in one line how many texels were clamped (sky.h). False after printing one
 * error line "pmview: error: FILE: what (where)". Frees nothing: pm_sky_release does. */
bool pm_sky_prepare(pm_sky_request *request);
/* Frees a map read but not handed to a scene (a run that stops before the choice). */
void pm_sky_release(pm_sky_request *request);

/* The environment: --sky when given; else the gradient for a file without punctual lights,
 * unless its emitters enclose the view (a closed room lit from inside); else none. Warns when
 * the default is added and when the camera is shut in by geometry that no light is inside.
 * A --sky file is read here unless pm_sky_prepare read it already; its map goes to the scene.
 * False after printing the error when an environment map cannot be read. */
bool pm_choose_sky(pm_sky_request *request, pm_scene *scene, const pm_accel *accel, const pm_camera *camera,
                   float aspect);

#endif

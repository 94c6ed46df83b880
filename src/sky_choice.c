/* sky_choice.c: which environment a run gets (--sky, or the default policy) and the warnings about how the scene is lit. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "defaults.h"
#include "eye.h"
#include "image_io.h"
#include "sky.h"
#include "sky_choice.h"

bool pm_choose_sky(const pm_sky_request *request, pm_scene *scene, const pm_accel *accel, const pm_camera *camera, float aspect) {
    float view_fraction, around_fraction;
    pm_eye_enclosure(scene, accel, camera, aspect, &view_fraction, &around_fraction);
    const char *sky = request->sky;
    if (!sky) {
        bool emitters_enclose = scene->emitter_count > 0 && view_fraction >= PM_VIEW_ENCLOSED_FRACTION;
        sky = request->no_default_light || scene->light_count > 0 || emitters_enclose ? "none" : "gradient";
        if (!strcmp(sky, "gradient") && !request->quiet)
            fprintf(stderr, "pmview: warning: %s: %s; lighting it with the default gradient sky (--sky none|white|gradient|FILE chooses)\n",
                    request->scene_path, scene->emitter_count ? "no punctual light, and its emitters do not enclose the view" : "the scene has no light");
    }
    char err[1024];
    if (!strcmp(sky, "none")) {
        pm_scene_set_sky(scene, false, v3s(0.f), NULL);
    } else if (!strcmp(sky, "white")) {
        pm_scene_set_sky(scene, true, v3s(1.f), NULL);
    } else {
        pm_sky_map *map = NULL;
        if (!strcmp(sky, "gradient")) {
            map = pm_sky_map_gradient(err, sizeof err);
        } else {
            int w = 0, h = 0;
            float *rgb = pm_read_environment(sky, &w, &h, err, sizeof err);
            if (rgb) {
                char inner[512];
                map = pm_sky_map_create(w, h, rgb, inner, sizeof inner);
                if (!map) snprintf(err, sizeof err, "%s: %s", sky, inner);
                free(rgb);
            }
        }
        if (!map) { fprintf(stderr, "pmview: error: %s\n", err); return false; }
        pm_scene_set_sky(scene, true, v3s(1.f), map);
    }
    if (!request->quiet && scene->emitter_count == 0 && scene->light_count == 0 && around_fraction >= PM_CAMERA_ENCLOSED_FRACTION)
        fprintf(stderr, "pmview: warning: %s: the camera is shut in by geometry (%.0f%% of the directions around it) and no light is inside: %s\n",
                request->scene_path, 100.0 * around_fraction,
                scene->sky ? "the environment lies outside and the image will be dark" : "the image will be black");
    double reflective = pm_scene_reflective_area_fraction(scene, PM_ENERGY_CONSERVING_ALBEDO);
    if (!request->quiet && around_fraction >= PM_CAMERA_ENCLOSED_FRACTION && (scene->emitter_count || scene->light_count) &&
        reflective >= 0.5)
        fprintf(stderr, "pmview: warning: %s: a closed room that conserves energy (%.0f%% of the surface reflects %.0f%% or more; "
                "glTF's default material is white): light does not die out by itself, so photon paths end by Russian roulette "
                "capped at %.0f%% survival or after %d bounces, and renders are slower and noisier than usual\n",
                request->scene_path, 100.0 * reflective, 100.0 * PM_ENERGY_CONSERVING_ALBEDO, 100.0 * PM_PHOTON_MAX_SURVIVAL,
                PM_DEFAULT_MAX_PHOTON_BOUNCES);
    if (request->stats)
        printf("stat sky kind=%s view_enclosed=%.3f camera_enclosed=%.3f\n",
               !scene->sky ? "none" : (!scene->sky_map ? "white" : (!strcmp(sky, "gradient") ? "gradient" : "map")),
               view_fraction, around_fraction);
    return true;
}

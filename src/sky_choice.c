/* sky_choice.c: which environment a run gets (--sky, or the default policy) and the warnings about how the scene is lit. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "defaults.h"
#include "eye.h"
#include "image_io.h"
#include "memory.h"
#include "sky.h"
#include "sky_choice.h"

static bool names_file(const char *sky) {
    return sky && strcmp(sky, "none") && strcmp(sky, "white") && strcmp(sky, "gradient");
}

bool pm_sky_prepare(pm_sky_request *request) {
    uint64_t mark = pm_memory_failure_mark(); /* what fails in this call, never an older failure */
    const char *path = request->sky;
    if (!names_file(path) || request->map) return true;
    char err[1024];
    int w = 0, h = 0;
    if (!pm_environment_size(path, &w, &h, err, sizeof err)) {
        fprintf(stderr, "pmview: error: %s\n", err);
        return false;
    }
    /* from the header, before a pixel is decoded: a small file can claim billions of texels */
    char what[128];
    snprintf(what, sizeof what, "sky map of %dx%d texels", w, h);
    uint64_t bytes = pm_sky_map_bytes(w, h);
    if (!pm_memory_admit(bytes, what)) {
        fprintf(stderr, "pmview: error: %s: out of memory (%s)\n", path, pm_memory_failure_since(mark));
        return false;
    }
    if ((uint64_t)w * (uint64_t)h > PM_SKY_MAX_TEXELS) {
        pm_memory_release(bytes);
        fprintf(stderr, "pmview: error: %s: an environment map of %dx%d texels is too large (at most %llu texels)\n", path,
                w, h, (unsigned long long)PM_SKY_MAX_TEXELS);
        return false;
    }
    int rw = 0, rh = 0;
    float *rgb = pm_read_environment(path, &rw, &rh, err, sizeof err);
    if (!rgb) {
        pm_memory_release(bytes);
        fprintf(stderr, "pmview: error: %s\n", err);
        return false;
    }
    if (rw != w || rh != h) { /* the memory was admitted for the header's size */
        free(rgb);
        pm_memory_release(bytes);
        fprintf(stderr, "pmview: error: %s: the file changed while it was read (%dx%d, then %dx%d texels)\n", path, w, h, rw, rh);
        return false;
    }
    char inner[512];
    request->map = pm_sky_map_adopt(w, h, rgb, inner, sizeof inner);
    if (!request->map) {
        pm_memory_release(bytes);
        fprintf(stderr, "pmview: error: %s: %s\n", path, inner);
        return false;
    }
    request->map->admitted = bytes;
    if (request->map->clamped && !request->quiet)
        fprintf(stderr, "pmview: warning: %s: %zu of %llu texels above %g or not finite clamped (NaN to 0, the rest to %g): "
                "a float film could not sum them\n",
                path, request->map->clamped, (unsigned long long)w * (unsigned long long)h, (double)PM_MAX_EMISSION,
                (double)PM_MAX_EMISSION);
    return true;
}

void pm_sky_release(pm_sky_request *request) {
    pm_sky_map_free(request->map);
    request->map = NULL;
}

bool pm_choose_sky(pm_sky_request *request, pm_scene *scene, const pm_accel *accel, const pm_camera *camera, float aspect) {
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
            if (!pm_sky_prepare(request)) return false;
            map = request->map;
            request->map = NULL;
        }
        if (!map) { fprintf(stderr, "pmview: error: %s\n", err); return false; }
        pm_sky_map_rotate(map, request->rotate_degrees);
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
                request->scene_path, 100.0 * reflective, 100.0 * PM_ENERGY_CONSERVING_ALBEDO, 100.0 * PM_MAX_SURVIVAL,
                PM_DEFAULT_MAX_PHOTON_BOUNCES);
    if (request->stats)
        printf("stat sky kind=%s view_enclosed=%.3f camera_enclosed=%.3f clamped_texels=%zu\n",
               !scene->sky ? "none" : (!scene->sky_map ? "white" : (!strcmp(sky, "gradient") ? "gradient" : "map")),
               view_fraction, around_fraction, scene->sky_map ? scene->sky_map->clamped : (size_t)0);
    return true;
}

/* options.h: pmview's command line: one table of options gives the parser, the range checks, the mode rules and the usage text.
 *
 * Every default the usage text shows is read from defaults.h. A bad value is a usage error
 * naming the option and what it accepts (exit 2).
 */
#ifndef PM_OPTIONS_H
#define PM_OPTIONS_H

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include "film.h"
#include "scene.h"
#include "session.h"

typedef struct {
    const char *scene_path;
    const char *snapshot;    /* --snapshot: offscreen; NULL: the window */
    const char *screenshot;  /* the window's P key */
    const char *reference;   /* EXR to measure the error against */
    const char *log;         /* --log: CSV of the run, one row per logged iteration */
    const char *sky;         /* --sky: none, white, gradient or an .exr/.hdr file; NULL = the default policy */
    const char *variant;     /* --variant: a KHR_materials_variants name; NULL = the file's default materials */
    long width, height;      /* 0: the default width, the height from the camera */
    long iterations;         /* 0 = the mode's default */
    long threads, seed;
    long camera;             /* -1 = first */
    long photons, caustic_photons; /* -1: chosen from the scene and the image */
    long k, gather_rays, irradiance_stride;
    long eye_passes;         /* progressive: per photon pass (0 = automatic) */
    double time_limit;       /* 0 = none */
    double checkpoint;       /* --checkpoint: seconds between writes of the image so far (0 = none) */
    double exposure_ev;
    double sky_rotate;       /* --sky-rotate: degrees about +Y */
    double max_radius;
    double alpha, radius;    /* progressive: radius reduction, initial radius (0 = from the scene) */
    uint64_t max_memory;     /* --max-memory: bytes the admitted structures may take together (0 = the default) */
    int mode;                /* pm_mode */
    int kernel;              /* pm_kernel */
    int indirect;            /* pm_indirect_mode */
    int gather;              /* pm_gather_choice */
    int shadow_photons;      /* pm_shadow_mode: default where they pay */
    int caustic_statistics;  /* --caustic-splats off */
    int unclipped;           /* --clip off */
    int unguided;            /* --guide off */
    int connect;             /* pm_connect_choice */
    int view_photons;        /* --view photons */
    bool stats, no_default_light, quiet, no_photons;
    bool flatten_instances;  /* --flatten-instances: pm_load_options.flatten_instances */
    bool watch;              /* --watch: the window reloads the scene when its files change */
    bool components_given, components[PM_COMPONENT_COUNT]; /* --components: what a PNG (and the window) shows */
} pm_options;

/* -1 when the run goes on; else the exit code (0 after --help, 2 after a usage error, whose one
 * line and the usage text are printed). */
int pm_options_parse(int argc, char **argv, pm_options *o);
void pm_options_usage(FILE *f);
/* A usage error found after parsing (the scene's units): "pmview: " and the line, then 2. */
int pm_options_usage_error(const char *format, const char *argument);
/* The session's configuration for the options at width x height on the scene (its size sets the
 * classic mode's estimate radii); with --stats prints the progressive mode's set-up line. */
void pm_options_session_config(const pm_options *o, const pm_scene *scene, int width, int height, pm_session_config *config);

#endif

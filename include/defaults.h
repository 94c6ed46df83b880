/* defaults.h: every default of pmview in one place (SmallVCM style), so the CLI, README and tests agree. */
#ifndef PM_DEFAULTS_H
#define PM_DEFAULTS_H

#define PM_DEFAULT_SCENE "scenes/cornell-box.gltf"
#define PM_DEFAULT_WIDTH 512            /* height follows the camera's aspect ratio, else square */
#define PM_DEFAULT_SNAPSHOT_ITERATIONS 64
#define PM_DEFAULT_WINDOW_ITERATIONS 100000 /* the window keeps converging until closed */
#define PM_DEFAULT_SEED 1
#define PM_DEFAULT_EXPOSURE_EV 0.0f
#define PM_DEFAULT_MAX_SPECULAR_DEPTH 12
#define PM_MAX_IMAGE_SIDE 16384

#endif

/* defaults.h: every default of pmview in one place (SmallVCM style), so the CLI, README and tests agree. */
#ifndef PM_DEFAULTS_H
#define PM_DEFAULTS_H

#define PM_DEFAULT_SCENE "scenes/cornell-box.gltf"
#define PM_DEFAULT_WIDTH 512            /* height follows the camera's aspect ratio, else square */
#define PM_DEFAULT_SNAPSHOT_ITERATIONS 64
#define PM_DEFAULT_WINDOW_ITERATIONS 100000 /* the window keeps converging until closed */
#define PM_DEFAULT_SEED 1
#define PM_DEFAULT_EXPOSURE_EV 0.0f
#define PM_DEFAULT_MAX_SPECULAR_DEPTH 64 /* a safety stop: past depth 4, roulette on throughput ends eye paths */
#define PM_MAX_IMAGE_SIDE 16384
#define PM_DEFAULT_MEMORY_SHARE 0.5     /* --max-memory default: one estimated structure (triangles, photon records of a pass,
                                           a film, a texture) may take at most this share of physical memory */
#define PM_MAX_EMISSION 1e20f          /* emission radiance and light intensity are clamped to this (with a warning): a float film sums
                                           up to 1e9 iterations of samples, and 1e20 x 1e9 leaves 1e9 of FLT_MAX's headroom for path weights */
#define PM_ACCEL_BYTES_PER_TRIANGLE 160 /* Embree's BVH, estimated before the build (measured: 90 bytes a triangle built, twice that at the build's peak) */

/* the default environment (radiance), for files without KHR_lights_punctual whose emitters do
 * not enclose the view: a lit white top (about 1.1) stands out against the horizon (0.35) */
#define PM_SKY_ZENITH 1.5
#define PM_SKY_HORIZON 0.35
#define PM_SKY_GROUND 0.3
#define PM_VIEW_ENCLOSED_FRACTION 0.5   /* cosine rays from the surfaces in view that hit geometry: above this the view is a room
                                           (the open Cornell box 0.67), its emitters light it alone; a model in open space is near 0 */
#define PM_CAMERA_ENCLOSED_FRACTION 0.99 /* rays from the camera in all directions that hit geometry: the camera is shut in */

/* materials */
#define PM_GLOSSY_MIN_ALPHA 1e-3f         /* GGX alpha = roughness^2 below this is the perfect mirror (roughness < 0.032) */

/* progressive photon mapping (the default mode) */
#define PM_DEFAULT_ALPHA (2.0 / 3.0)       /* Hachisuka and Jensen's radius reduction */
#define PM_PPM_PHOTONS_PER_PIXEL 0.25      /* photons per iteration = pixels x this, clamped below */
#define PM_PPM_MIN_PHOTONS 10000
#define PM_PPM_MAX_PHOTONS 1000000
#define PM_PPM_FOOTPRINT_PIXELS 1.0        /* initial radius at least this many pixel footprints ... */
#define PM_PPM_INITIAL_PHOTONS 16.0        /* ... and wide enough to hold this many first-iteration photons at the scene's mean density */
#define PM_PPM_GATHER_PHOTONS 8.0          /* final gathering: the shared radius starts holding this many (each estimate is averaged over pixels and iterations) */

/* photon mapping (classic two-pass mode) */
#define PM_DEFAULT_PHOTONS_PER_PIXEL 1.0   /* global photons = pixels x this, clamped below */
#define PM_MIN_DEFAULT_PHOTONS 100000
#define PM_MAX_DEFAULT_PHOTONS 4000000
#define PM_DEFAULT_K_GLOBAL 64
#define PM_DEFAULT_K_CAUSTIC 64
#define PM_DEFAULT_GLOBAL_RADIUS 0.1f     /* x the scene's largest extent */
#define PM_DEFAULT_CAUSTIC_RADIUS 0.025f  /* x the scene's largest extent */
#define PM_DEFAULT_GATHER_RAYS 1          /* per eye sample; iterations add more */
#define PM_DEFAULT_IRRADIANCE_STRIDE 4    /* precomputed irradiance at every 4th global photon (Christensen) */
#define PM_DEFAULT_MAX_PHOTON_BOUNCES 1024 /* the path-length cap, a safety stop: Russian roulette ends paths; a closed room of albedo 0.99
                                             loses 0.99^1024 = 3e-5 of its light to it, one of albedo 1 reaches it with probability 3e-5 */
#define PM_TIME_SHARE_PHOTONS 0.25        /* with --time: the photon pass's share of the budget */
#define PM_PHOTON_PASS_TIME_SHARE 0.25     /* with --time: a photon pass stops starting chunks after this share of the time left (sorting what it stored takes as long again) */
#define PM_ENERGY_CONSERVING_ALBEDO 0.98f /* a shut-in camera whose surroundings mostly reflect this much or more gets a warning */
#define PM_PHOTON_MAX_SURVIVAL 0.99f      /* Russian roulette keeps a photon with at most this probability (the weight compensates):
                                              a closed room of albedo 1 ends its paths after 100 bounces on average (so a pass stores
                                              at most about 100 records a photon), not at the cap. Below albedo rho the weights grow by
                                              rho/q a bounce and their variance stays finite only while q > rho^2: 0.99 keeps a room of
                                              albedo 0.99 exact (tests/test_hardcases.c), 0.95 left it 10% dark */

#endif

/* defaults.h: every default of pmview in one place (SmallVCM style), so the CLI, README and tests agree. */
#ifndef PM_DEFAULTS_H
#define PM_DEFAULTS_H

#define PM_DEFAULT_SCENE "scenes/cornell-box.gltf"
#define PM_DEFAULT_WIDTH 512            /* height follows the camera's aspect ratio, else square */
#define PM_DEFAULT_SNAPSHOT_ITERATIONS 64
#define PM_CLUSTER_MERGE_SECONDS 0.25     /* the window's merges of every rank's image, at most this often */
#define PM_CLUSTER_SILENCE_SECONDS 0.5    /* after a signal, a rank that has not finished by then is taken for gone (mpirun's SIGKILL follows its SIGTERM by 1 s) */
#define PM_CLUSTER_AGREE_SECONDS 10.0    /* the set-up's agreement: rank 0 waits this long plus PM_CLUSTER_AGREE_FACTOR times its */
#define PM_CLUSTER_AGREE_FACTOR 4.0      /* own set-up for every rank's word, then ends the job naming the silent (stopped) ones */
#define PM_CLUSTER_QUIT_SECONDS 5.0      /* the window's quit or resize: a rank that has not answered it by then is taken for stopped */
#define PM_CLUSTER_END_SECONDS 5.0       /* --time under MPI: a rank silent this long plus PM_CLUSTER_END_SHARE of --time past the */
#define PM_CLUSTER_END_SHARE 0.1         /* deadline (or past the wait's start, if later) is taken for stopped and the job ends */
#define PM_DEFAULT_WINDOW_ITERATIONS 100000 /* the window keeps converging until closed */
#define PM_WATCH_SETTLE_SECONDS 0.15      /* --watch: a reload starts once the scene's folder has been quiet this long (a burst of saves is one reload) */
#define PM_PREPARE_AFTER_SECONDS 0.03   /* the window: a set-up longer than this makes the GL context and compiles the display
                                           shader meanwhile; a shorter one shows its first image composed on the CPU first */
#define PM_QUICK_IMAGE_WAIT_SECONDS 0.1 /* the window: how long the first image (the session's preview) is waited for before
                                           the shader is built anyway */
#define PM_WINDOW_MOTION_GAP 0.2          /* the window: camera changes less than this many seconds apart are one motion (a drag, a held key) */
#define PM_PREVIEW_DIVISOR 4              /* the coarse preview after a restart: a quarter of the width and height */
#define PM_PREVIEW_MAX_DIVISOR 16         /* a camera moving over a big scene: previews down to 1/16 of the width and height */
#define PM_PREVIEW_BUDGET_SECONDS 0.03    /* a preview slower than this makes the next one coarser (24 new images a second
                                             and more while the camera moves, the window's drawing included) */
#define PM_PREVIEW_SETTLE_SECONDS 0.1     /* a moving camera: its next position is waited for at most this long after the
                                             last one (twice the time between its last two) before a full iteration starts */
#define PM_DEFAULT_SEED 1
#define PM_DEFAULT_SKY_ROTATE_DEGREES 0.0 /* --sky-rotate: the environment map as the file has it */
#define PM_MAX_SKY_ROTATE_DEGREES 1e9    /* --sky-rotate takes any angle this size or smaller (modulo 360) */
#define PM_DEFAULT_SCREENSHOT "pmview-screenshot.png" /* the window's P key; the layers go beside it as .exr */
#define PM_MAX_THREADS 256              /* worker threads at most (--threads; per-thread counters are sized by it) */
#define PM_DEFAULT_EXPOSURE_EV 0.0f
#define PM_DEFAULT_MAX_SPECULAR_DEPTH 1024 /* a safety stop only, as PM_DEFAULT_MAX_PHOTON_BOUNCES: roulette (PM_MAX_SURVIVAL)
                                            ends specular chains; between 0.99 mirrors the chains past it carry 0.99^1024 = 3e-5
                                            of the light (64 lost half of it) */
#define PM_MAX_IMAGE_SIDE 16384
#define PM_LOG_EVERY_ITERATION_UNTIL 64 /* --log: a row per iteration up to here, then at every doubling (and the last) */
#define PM_DEFAULT_MEMORY_SHARE 0.5     /* --max-memory default: one estimated structure (triangles, photon records of a pass,
                                           a film, a texture) may take at most this share of physical memory */
#define PM_MAX_EMISSION 1e20f          /* emission radiance and light intensity are clamped to this (with a warning): a float film sums
                                           up to 1e9 iterations of samples, and 1e20 x 1e9 leaves 1e9 of FLT_MAX's headroom for path weights */
/* The memory forecast (memory.h): bytes per unit of what each stage holds, measured on scenes of 10^4 to 10^7 triangles */
#define PM_JSON_DOCUMENT_BYTES_PER_BYTE 10   /* nlohmann's document per byte of JSON text */
#define PM_ACCEL_BUILD_BYTES_PER_TRIANGLE 102 /* Embree's peak during the build, what it keeps included (plus the vertices) */
#define PM_ACCEL_BUILT_BYTES_PER_TRIANGLE 72  /* what the built BVH keeps (plus the vertices) */
#define PM_ACCEL_BYTES_PER_VERTEX 16          /* the vertex buffers Embree reads (padded to 16 bytes) */
#define PM_ACCEL_BYTES_PER_PLACEMENT 384 /* one Embree instance of a shared mesh, its geometry object and its share of the top BVH
                                            (measured: 83 bytes in Embree's count, 356-386 of resident memory for 250,000 to 10^6
                                            placements, docs/design.md, Instancing) */
#define PM_PHOTON_PASS_RECORDS 3             /* photon records alive per photon of an iteration: the threads' lists, the merged list, the grid */
#define PM_PHOTON_MAP_RECORDS 3              /* the global map's records per emitted photon: stored bounces, irradiance points, the tree
                                                (a caustic photon is stored once, if at all) */
#define PM_SHADOW_RECORDS_PER_PHOTON 2       /* shadow photon records per photon traced: about one crossing each, lists grown by doubling */
#define PM_RENDER_RESIDENT_BYTES (8u << 20)  /* the render's threads, stacks and small tables */
#define PM_GL_RESIDENT_BYTES (16u << 20)     /* an offscreen (OSMesa) context and its buffers, for PNG output */
#define PM_OSMESA_LIBRARY_BYTES (50u << 20)  /* libOSMesa and the LLVM it links, resident once opened for the first PNG (measured:
                                               49 MB, the resident size at start with the library linked and without) */

/* the default environment (radiance), for files without KHR_lights_punctual whose emitters do
 * not enclose the view: a lit white top (about 1.1) stands out against the horizon (0.35) */
#define PM_SKY_ZENITH 1.5
#define PM_SKY_HORIZON 0.35
#define PM_SKY_GROUND 0.3
#define PM_VIEW_ENCLOSED_FRACTION 0.5   /* cosine rays from the surfaces in view that hit geometry: above this the view is a room
                                           (the open Cornell box 0.67), its emitters light it alone; a model in open space is near 0 */
#define PM_CAMERA_ENCLOSED_FRACTION 0.99 /* rays from the camera in all directions that hit geometry: the camera is shut in */

/* direct light */
#define PM_DIRECT_LIGHT_SAMPLES 4         /* punctual lights shaded per shading point: every one in a scene with at most this many,
                                             else this many drawn by power (stratified), so the cost does not grow with the count */

#define PM_THIN_MAX_CROSSINGS 16          /* thin walls a direct-light ray crosses before it is taken as blocked (thin.h) */

/* shadow photons (Jensen and Christensen 1995): which punctual lights a point surely sees or surely does not */
#define PM_SHADOW_PHOTONS_PER_PIXEL 1.0   /* photons per light = image pixels x this, clamped below */
#define PM_SHADOW_MIN_PHOTONS 65536
#define PM_SHADOW_MAX_PHOTONS 1048576
#define PM_SHADOW_MAX_LIGHTS 8            /* a scene with more punctual lights gets none (they are sampled; a map per light would not pay) */
#define PM_SHADOW_LOOKUP_PHOTONS 256      /* a lookup's region holds this many of one light's photons at their mean density (sets the
                                             cell): larger is safer near thin shadows, smaller saves more rays (tests/test_shadow.c) */
#define PM_SHADOW_MIN_COUNT 8             /* the threshold: a light is decided without a ray only when at least this many of its
                                             photons are near and all agree (at most 15) */
#define PM_SHADOW_MAX_CROSSINGS 16        /* surfaces a shadow photon passes through before it stops */
#define PM_SHADOW_MIN_GAIN 2.0            /* ... and keeps it only when, on random surface points, the shadow rays it decides would
                                             cost at least this many times as much as its lookups, priced by PM_SHADOW_LOOKUP_OVER_RAY */
#define PM_SHADOW_LOOKUP_OVER_RAY 0.45    /* a lookup's cost over a shadow ray's, fixed so that whether a scene gets shadow photons
                                             (and so its eye pass) never depends on the machine's load: the probe's own timing
                                             (`stat shadow_photons probe_lookup_ns probe_ray_ns`, fastest of 15 builds, one thread)
                                             read 22.5/35.1 ns caustic, 35.4/116.3 point-room, 23.2/54.8 window-hollow, 21.3/27.9
                                             window-room, 25.9/75.1 a two-light test scene: 0.31-0.76, geometric mean 0.47. With
                                             PM_SHADOW_MIN_GAIN, a map is kept where it decides at least 90% of the light samples */
#define PM_SHADOW_TIME_SHARE 0.1         /* with --time: the shadow photons stop starting chunks after this share of the budget */
#define PM_SHADOW_PAYBACK 4.0             /* by default a render gets shadow photons only when its shadow rays (samples x lights
                                             shaded) are at least this many times the photons the map would trace */

/* materials */
#define PM_GLOSSY_MIN_ALPHA 1e-3f         /* GGX alpha = roughness^2 below this is the perfect mirror (roughness < 0.032) */
#define PM_NEAR_SPECULAR_ALPHA 0.1f       /* a GGX reflection sharper than this alpha (roughness 0.32) is near-specular (vertex.h):
                                             paths go on through it, as through mirrors, rather than read photons there. A photon
                                             estimate weights each photon by the lobe, which peaks at 1 / (pi alpha^2): the noise
                                             of reading photons and of going on cross between roughness 0.2 and 0.3
                                             (docs/design.md, "Sharp glossy lobes"), and below it reading explodes (relMSE
                                             2.0 at roughness 0.1, 90 at 0.05, against 0.018 going on) */

/* progressive photon mapping (the default mode) */
#define PM_DEFAULT_ALPHA (2.0 / 3.0)       /* Hachisuka and Jensen's radius reduction */
#define PM_PPM_PHOTONS_PER_PIXEL 0.125     /* photons per iteration = pixels x this, clamped below */
#define PM_PPM_MIN_PHOTONS 10000
#define PM_PPM_FIRST_PHOTON_FRACTION 0.5   /* the first iteration (after a start or a camera move) emits this share of them: the user waits for it */
#define PM_PPM_MAX_PHOTONS 1000000
#define PM_PPM_FOOTPRINT_PIXELS 1.0        /* initial radius at least this many pixel footprints ... */
#define PM_PPM_CURVED_RADIUS 0.43         /* ... and at most this many radii of the surface's curvature (the chord of the photons' 25-degree normal test) */
#define PM_PPM_INITIAL_PHOTONS 16.0        /* ... and wide enough to hold this many first-iteration photons at the scene's mean density */
#define PM_PPM_MAX_EYE_PASSES 8            /* automatic eye passes per photon pass: at most this many (--eye-passes sets any) */
#define PM_PPM_EYE_RAY_COST 2.0            /* an eye ray with its gathering costs this many photon rays (each with its storing) */
#define PM_PPM_PROBE_PIXELS 1024           /* the noise probe that chooses them watches about this many pixels ... */
#define PM_PPM_PROBE_ITERATIONS 8          /* ... over at least this many iterations of two eye passes first */
#define PM_PPM_GATHER_PHOTONS 8.0          /* final gathering: the shared radius starts holding this many (each estimate is averaged over pixels and iterations) */
#define PM_PPM_CHOICE_ITERATIONS 8        /* the final gather's source (photons or the path tracer) is chosen after at most this many iterations of each, alternating ... */
#define PM_PPM_CHOICE_MARGIN 2.0           /* ... and after n of each (from 2 on) where one's predicted relMSE is below the other's by a factor 1 + this / n ... */
#define PM_PPM_CHOICE_HORIZON 256.0        /* ... for the lower predicted relMSE after this many iterations' worth of the photon gather's cost */
#define PM_PPM_CHOICE_CAUSTIC_SHARE 0.01     /* ... and the photons are kept at once where mirrors or glass send this share of the light the photons bring to gather points */
#define PM_PPM_TRIAL_ITERATIONS 16        /* the caustic trial: measured iterations of each arm, the caustic photons' and the path tracer's loop ... */
#define PM_PPM_TRIAL_PIXELS 16384        /* ... over a grid of about this many pixels ... */
#define PM_PPM_TRIAL_TAIL 4.0              /* ... each arm's caustic variance weighed this many times (rare bright samples, which a few iterations see less often than they come) */
#define PM_DIFFUSE_LIGHT_PEAK 8.0f         /* light no brighter anywhere than this times the mean it arrives with is broad: the path tracer's alone (scene.h, light_diffuse) */
#define PM_PPM_EXAMINED_COST 0.2           /* a photon within a disc's radius costs this many rays in that prediction (its tests and sum; measured on the window room, where the ground under the floor fills the discs) */
#define PM_PPM_QUERY_COST 4.0              /* ... and a disc query (its clip's search or lookup, the grid's cells) this many (one thread's CPU time over counts: 3.2 on the point-lit room, 4.6 on the window room, 6.7 on the glossy spheres' lobes) */
#define PM_MAX_RADIUS 1e18                 /* --radius and --max-radius (scene units) at most: a disc query squares the radius in float */
#define PM_MIN_RADIUS 1e-18                /* ... and at least: (FLT_MAX 3.4e38, FLT_MIN 1.2e-38), with room for the sums of squares */

/* estimates stay on their side of the geometry (clip.h), in both photon modes */
#define PM_CLIP_PROBES 4                   /* rays along a gather point's tangent plane that look for walls across its disc (each reaches r / cos(pi / this)) */
#define PM_CLIP_LIFT 0.002f                /* ... lifted this share of the disc's radius off the surface, so that they do not graze it */

/* photons sent where the camera looks (guide.h), progressive mode */
#define PM_GUIDE_CELLS 32                  /* a guided source's two placing numbers split into this many x this many cells */
#define PM_GUIDE_UNIFORM 0.1               /* share of the photons drawn uniformly whatever was learned (every emission stays possible) */
#define PM_GUIDE_PRIOR 16.0                /* a cell's learned rate counts this many photons at the source's mean rate besides its own */
#define PM_GUIDE_MAX_SOURCES 16            /* lights past this many are not guided */
#define PM_GUIDE_MARK_BITS (1u << 22)      /* the marks' hashed bit sets (either side, one side): 512 KB each */
#define PM_CONNECT_CELL 0.0625             /* the connections' worth cells, of the median distance the camera sees */
#define PM_CELL_VALUES_CELLS (1u << 15)    /* a cell value table's hashed cells: 384 KB, in a core's cache */
#define PM_CONNECT_WORTH_UNIT 1e-7         /* a worth's unit, of the first pass's mean flux over the cell squared */
#define PM_CONNECT_TRIAL_ITERATIONS 32     /* the connections' trial: iterations of each arm ... */
#define PM_CONNECT_TRIAL_PIXELS 1024       /* ... the pixels it measures at most (the arm with connections joins there alone) ... */
#define PM_CONNECT_TRIAL_WARMUP 16         /* ... after at least this many iterations with connections, unmeasured ... */
#define PM_CONNECT_TRIAL_WARMUP_PHOTONS 1e6 /* ... and this many light vertex photons */
#define PM_CONNECT_COST 0.05               /* a connection's work beyond its shadow ray, in eye rays */
#define PM_CONNECT_PHOTON_COST 1.0         /* a light vertex pass's photon ray (emission, one hit), in eye rays */
#define PM_CONNECT_WORTH_SHARE 4           /* one connection in this many adds its worth (the others would mostly repeat it) */
#define PM_CONNECT_KEEP_LEAST 0.02f        /* a light vertex in a cell of little worth is kept at least this often */
#define PM_CONNECT_HISTORY_FADE 0.875      /* photons per kept light vertex: each earlier pass's weight, per pass since */
#define PM_ARRIVAL_CELL 4.0                /* the sky's arrival guide (arrival.h): its cells, in the connections' cells ... */
#define PM_ARRIVAL_BINS_SIDE 12            /* ... direction bins a side (144 of 0.087 sr) ... */
#define PM_ARRIVAL_SLOTS (1u << 12)        /* ... hashed slots (4.8 MB of counts and distributions) ... */
#define PM_ARRIVAL_MIN_HITS 32             /* ... rays that reached the sky before a cell is used ... */
#define PM_ARRIVAL_MAX_HITS 4096           /* ... and after which it counts no more ... */
#define PM_ARRIVAL_CONCENTRATION 8.0       /* ... and its bins' squared probabilities x the bins, at least */

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
/* the photon pass prefetches its hits' triangles and corners (pm_scene_prefetch_triangle) when what a
 * surface record reads of the mesh (pm_scene_hit_data_bytes) is larger than this, about half of a core's
 * L2 cache: photon_ceiling on height fields (bench/big_scene.py) read 0.97 of the unprefetched speed
 * at 4,428 triangles (0.18 MB), 1.02-1.03 at 20,000 (0.8 MB), 1.07-1.14 at 50,000 and 1.21-1.41 at
 * 250,000 and a million. Its hits' texels likewise when the textures' level 0 (pm_scene_texture_bytes)
 * is: 1.42-1.5 times the rays per second on LightsPunctualLamp (four 2048 x 2048 textures),
 * MultiUVTest (two of 1024 x 1024) and AlphaBlendModeTest, 1.01 on Duck (one of 512 x 512, 1 MB) */
#define PM_PREFETCH_GEOMETRY_BYTES (512u * 1024u)
#define PM_PHOTON_WAVE 256                 /* photons a chunk traces side by side: their rays go to Embree together, then their hits bounce (as fast as 1,024, faster than 64) */
#define PM_DEFAULT_MAX_PHOTON_BOUNCES 1024 /* the path-length cap, a safety stop: Russian roulette ends paths; a closed room of albedo 0.99
                                             loses 0.99^1024 = 3e-5 of its light to it, one of albedo 1 reaches it with probability 3e-5 */
#define PM_TIME_SHARE_PHOTONS 0.25        /* with --time: the photon pass's share of the budget */
#define PM_PILOT_PHOTONS 20000            /* with --time and no --photons: the classic mode's pilot pass measures photon speed with these */
#define PM_PHOTON_PASS_TIME_SHARE 0.25     /* with --time: a photon pass stops starting chunks after this share of the time left (sorting what it stored takes as long again) */
#define PM_ENERGY_CONSERVING_ALBEDO 0.98f /* a shut-in camera whose surroundings mostly reflect this much or more gets a warning */

/* Russian roulette, one rule for every path (vertex.h): from the vertex given below on, a path
 * goes on with probability q = min(PM_MAX_SURVIVAL, mean weight of the bounce), its weight divided by q */
#define PM_MAX_SURVIVAL 0.99f             /* the cap: a closed room of albedo 1 ends its paths after 100 bounces on average (so a
                                              photon pass stores at most about 100 records a photon), not at a length cap. Below
                                              albedo rho the weights grow by rho/q a bounce and their variance stays finite only
                                              while q > rho^2: 0.99 keeps a room of albedo 0.99 exact (tests/test_hard_energy.c), 0.95
                                              left it 10% dark, and a box of 0.99 mirrors reads its 100 x emission (tests/test_mirror_box.c) */
#define PM_EYE_ROULETTE_VERTEX 3          /* eye paths (camera chains, gather walks, the path tracer) meet the roulette from the
                                              fourth surface (index 3) on: their first bounces carry most of a pixel; photons from
                                              the first, so a photon keeps its power (Jensen) */

/* path tracing (--mode pathtrace) */
#define PM_PATHTRACE_MAX_VERTICES 1024     /* a safety stop only, as PM_DEFAULT_MAX_PHOTON_BOUNCES: roulette ends paths first */

/* textures */
#define PM_TEXTURE_MAX_LEVELS 32           /* mip levels a texture can have: 1 + log2 of the largest int side */
#define PM_FOOTPRINT_PIXELS 0.5f           /* a camera ray's texture footprint, in pixels: samples are jittered over the
                                              pixel and averaged, which filters what is finer than a pixel over the
                                              iterations; half a pixel takes out what would shimmer in the first ones
                                              without blurring the converged image by another pixel's width */
#define PM_FOOTPRINT_MIN_COS 1e-3f         /* a footprint on a surface grows as 1 / sqrt(cos) of the ray's incidence
                                              (the geometric mean of the ellipse's axes); the cosine is floored here */

#endif

/* shadowmap.h: shadow photons (Jensen and Christensen 1995): which punctual lights a surface point surely sees or surely does not, so direct light casts a shadow ray only where that is uncertain.
 *
 * Built once per scene (visibility depends on neither the camera nor the iteration): every
 * punctual light sends the same number of photons, spread evenly over its directions (a
 * spherical Fibonacci set, a spot's cone, a directional light's disc across the scene). A photon
 * stores an illumination record at the first surface it meets and then goes on in a straight
 * line through every further surface, storing a shadow record at each. Behind glass (or any
 * material with a glass share) a record is "uncertain" instead: the light may come through.
 * Only surfaces that can have direct light (a diffuse or glossy share) keep records.
 *
 * The records are then summarised into a hash table keyed by grid cell and side (the nearest of
 * the six axis directions to the side's normal, and whether it is the triangle's front; along that
 * axis cells are four times thinner, so a shelf and the floor under it stay apart), holding per light saturating counts of the
 * illumination and shadow records within half a cell of any point of the cell (each record is
 * counted in the up to eight cells that half a cell around it touches). A lookup is one probe. A light counts as seen when at least `min_count`
 * of its records are near and none is a shadow record, as hidden when at least that many are
 * near and all are shadow records; anything else (too few, mixed: a shadow's edge, a penumbra,
 * an uncertain record) is left to the shadow ray. Only whole photons decide, so a shadow
 * narrower than the photon spacing can be missed: `stat shadow_photons` reports the spacing.
 */
#ifndef PM_SHADOWMAP_H
#define PM_SHADOWMAP_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "accel.h"
#include "scene.h"

typedef enum { PM_SHADOW_AUTO = 0, PM_SHADOW_ON = 1, PM_SHADOW_OFF = 2 } pm_shadow_mode;

typedef struct {
    pm_shadow_mode mode;
    uint64_t photons_per_light;  /* 0: PM_SHADOW_MIN_PHOTONS */
    double expected_samples;     /* shading points the render will shade (pixels x iterations); 0 = unknown (a window, a time budget) */
    int min_count;               /* the threshold (0: PM_SHADOW_MIN_COUNT), at most 15 */
    int threads;
    double deadline;             /* CLOCK_MONOTONIC seconds past which no chunk of photons starts (0 = none): every light
                                    loses the same bands of directions, where lookups then find nothing and rays decide */
} pm_shadow_settings;

typedef struct {
    bool built;
    const char *reason;          /* why there is no map: a word for `stat shadow_photons reason=` */
    uint32_t lights;
    uint64_t photons, records, rays;
    size_t cells, bytes;         /* table entries in use, bytes of the table */
    double seconds;
    float cell_size, spacing;    /* scene units; spacing: between one light's records at their mean density */
    /* the probe (random surface points, every light): the share of light samples the map decides
     * (which alone decides whether the map is kept), and the nanoseconds per light sample of the
     * lookups and of the shadow rays (reported, never decisive) */
    double probe_decided, probe_lookup_ns, probe_ray_ns;
    bool out_of_memory;
} pm_shadow_stats;

typedef struct pm_shadow_map pm_shadow_map;

/* Photons per light for an image of that many pixels: PM_SHADOW_PHOTONS_PER_PIXEL each, clamped. */
uint64_t pm_shadow_default_photons(int width, int height);

/* Why a scene gets no map under these settings before one is built (NULL: it may get one): "off",
 * "no_punctual_lights", "too_many_lights", "stochastic_transparency" (BLEND lets rays through at
 * random: no photon can vouch for a ray), "would_not_pay" (auto: fewer shadow rays than
 * PM_SHADOW_PAYBACK x the photons). After building, auto also drops a map whose probe finds
 * the rays it saves cheaper than PM_SHADOW_MIN_GAIN x its lookups ("would_not_pay"). */
const char *pm_shadow_map_unneeded(const pm_scene *s, const pm_shadow_settings *set);

/* Whether a map that decides this share of the probe's light samples is kept by default: the
 * rays it saves, priced at a fixed cost ratio (PM_SHADOW_LOOKUP_OVER_RAY), at least
 * PM_SHADOW_MIN_GAIN times its lookups. From counts alone, so the choice never depends on load. */
bool pm_shadow_map_pays(double decided);

/* The most memory a build would hold at once (records and cells), for the memory forecast; 0 when the scene gets no map. */
uint64_t pm_shadow_map_forecast_bytes(const pm_scene *s, const pm_shadow_settings *set);
/* Traces and summarises the shadow photons. NULL when the scene gets none (stats->reason says
 * why) or when out of memory (stats->out_of_memory). stats may not be NULL. */
pm_shadow_map *pm_shadow_map_build(const pm_scene *s, const pm_accel *a, const pm_shadow_settings *set,
                                   pm_shadow_stats *stats);
void pm_shadow_map_free(pm_shadow_map *m);

typedef enum { PM_VISIBILITY_UNKNOWN = 0, PM_VISIBILITY_SEEN = 1, PM_VISIBILITY_HIDDEN = 2 } pm_visibility;

/* The counts of every light at point p of a surface whose side toward those lights faces n
 * (the geometric normal of that side; front: it is the triangle's own normal, not its reverse),
 * for pm_shadow_map_verdict; NULL when no record came near. */
const uint8_t *pm_shadow_map_find(const pm_shadow_map *m, vec3 p, vec3 n, bool front);
/* What the records found say about light `light` (an index into the scene's lights). */
pm_visibility pm_shadow_map_verdict(const pm_shadow_map *m, const uint8_t *found, uint32_t light);

#endif

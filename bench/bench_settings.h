/* bench_settings.h: the photon settings every photon benchmark program uses, so their figures measure the same pass. */
#ifndef PM_BENCH_SETTINGS_H
#define PM_BENCH_SETTINGS_H

#include <string.h>
#include "photonmap.h"

/* Seed 1, 32 bounces, projection maps; the photon counts are the caller's. */
static inline pm_photon_settings bench_photon_settings(int threads) {
    pm_photon_settings ps;
    memset(&ps, 0, sizeof ps);
    ps.seed = 1;
    ps.threads = threads;
    ps.max_bounces = 32;
    ps.projection_maps = true;
    return ps;
}

#endif

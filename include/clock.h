/* clock.h: the monotonic clock every stage times itself with (seconds, CLOCK_MONOTONIC). */
#ifndef PM_CLOCK_H
#define PM_CLOCK_H

#include <time.h>

static inline double pm_now_seconds(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

#endif

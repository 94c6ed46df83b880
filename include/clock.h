/* clock.h: the monotonic clock every stage times itself with (seconds, CLOCK_MONOTONIC), the wall clock and the process's processor time. */
#ifndef PM_CLOCK_H
#define PM_CLOCK_H

#include <time.h>

static inline double pm_now_seconds(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

/* The wall clock (CLOCK_REALTIME), for a time measured against another process's clock: the
 * window's first image against the moment a script started pmview. */
static inline double pm_realtime_seconds(void) {
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

/* The processor time of every thread of the process so far: what a start-up costs, which a loaded
 * machine stretches less than the wall time. */
static inline double pm_process_cpu_seconds(void) {
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

#endif

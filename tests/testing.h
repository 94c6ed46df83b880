/* testing.h: the tiny check framework every tests/test_*.c uses: named checks, numeric tolerances, one exit code.
 *
 * Each CHECK prints a line on failure (file:line, what, the values); pm_test_done() prints
 * "NAME: N checks, M failed" and returns the process exit code (0 only when nothing failed).
 * Skips print "SKIP: reason" and count as neither.
 */
#ifndef PM_TESTING_H
#define PM_TESTING_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

static int pm_checks_run, pm_checks_failed;

#define CHECK(cond, ...) do { \
    pm_checks_run++; \
    if (!(cond)) { pm_checks_failed++; \
        fprintf(stderr, "FAIL %s:%d: %s: ", __FILE__, __LINE__, #cond); \
        fprintf(stderr, __VA_ARGS__); fputc('\n', stderr); } \
} while (0)

/* |got - want| <= rel * |want| (+ abs) */
#define CHECK_NEAR(got, want, rel, abs_tol, what) do { \
    double g_ = (got), w_ = (want); \
    pm_checks_run++; \
    if (!(fabs(g_ - w_) <= (rel) * fabs(w_) + (abs_tol))) { pm_checks_failed++; \
        fprintf(stderr, "FAIL %s:%d: %s: got %.6g want %.6g (rel tol %g, abs tol %g)\n", \
                __FILE__, __LINE__, what, g_, w_, (double)(rel), (double)(abs_tol)); } \
} while (0)

static inline int pm_test_done(const char *name) {
    printf("%s: %d checks, %d failed\n", name, pm_checks_run, pm_checks_failed);
    return pm_checks_failed ? 1 : (pm_checks_run ? 0 : 1);
}

#endif

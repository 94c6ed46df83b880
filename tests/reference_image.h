/* reference_image.h: a committed reference EXR for the tests that compare with it, read by runlog.h's reader (the one --reference uses). */
#ifndef PM_REFERENCE_IMAGE_H
#define PM_REFERENCE_IMAGE_H

#include <stdbool.h>
#include "runlog.h"
#include "testing.h"

/* The references are committed with the tests: one that cannot be read is a failed check, never a
 * skip (a test that skipped its comparison would pass without comparing). ref is freed then. */
static inline bool load_ref(const char *path, pm_reference_image *ref) {
    char err[512];
    bool loaded = pm_reference_load(path, false, ref, err, sizeof err);
    CHECK(loaded, "reference %s: %s", path, err);
    if (!loaded) pm_reference_free(ref);
    return loaded;
}

#endif

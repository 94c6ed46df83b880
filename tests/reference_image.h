/* reference_image.h: reads a committed reference EXR's R, G, B for the tests that compare with it; a missing file is a skip. */
#ifndef PM_REFERENCE_IMAGE_H
#define PM_REFERENCE_IMAGE_H

#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "image_io.h"

typedef struct { float *rgb[3]; int w, h; } image;

/* False, after printing "SKIP: why", when the file or a channel cannot be read. */
static inline bool load_ref(const char *path, image *img) {
    char err[512];
    const char *names[3] = {"R", "G", "B"};
    memset(img, 0, sizeof *img);
    for (int c = 0; c < 3; c++) {
        img->rgb[c] = pm_read_exr_channel(path, names[c], &img->w, &img->h, err, sizeof err);
        if (!img->rgb[c]) {
            printf("SKIP: %s\n", err);
            for (int k = 0; k < c; k++) free(img->rgb[k]);
            return false;
        }
    }
    return true;
}

static inline void free_image(image *img) {
    for (int c = 0; c < 3; c++) free(img->rgb[c]);
}

#endif

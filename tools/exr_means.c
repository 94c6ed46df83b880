/* exr_means.c: prints the mean of every layer of pmview EXR files side by side (a quick look at where two renders differ). */
#include <stdio.h>
#include <stdlib.h>

#include "image_io.h"

int main(int argc, char **argv) {
    static const char *const layers[] = {"", "direct.", "specular.", "caustic.", "indirect."};
    static const char *const rgb[] = {"R", "G", "B"};
    if (argc < 2) { fprintf(stderr, "usage: exr_means FILE.exr...\n"); return 2; }
    printf("%-10s", "layer");
    for (int f = 1; f < argc; f++) printf(" %30s", argv[f]);
    printf("\n");
    for (int l = 0; l < 5; l++) {
        printf("%-10s", l ? layers[l] : "total");
        for (int f = 1; f < argc; f++) {
            double m[3] = {0, 0, 0};
            for (int c = 0; c < 3; c++) {
                char name[32], err[256];
                snprintf(name, sizeof name, "%s%s", layers[l], rgb[c]);
                int w, h;
                float *px = pm_read_exr_channel(argv[f], name, &w, &h, err, sizeof err);
                if (!px) { m[c] = -1; continue; }
                for (int i = 0; i < w * h; i++) m[c] += px[i];
                m[c] /= (double)w * h;
                free(px);
            }
            printf("   %8.5f %8.5f %8.5f", m[0], m[1], m[2]);
        }
        printf("\n");
    }
    return 0;
}

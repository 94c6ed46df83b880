/* view.h: the display, OpenGL 3.3 core: a GLFW window or an OSMesa offscreen context, one shader path for both.
 *
 * The film's component means are uploaded as float textures; shaders/compose.frag adds the
 * enabled components, applies exposure and a tonemap and encodes sRGB. Toggling a component
 * only redraws: nothing is re-rendered. GL entry points are fetched through the current
 * context's get-proc-address (libGL and libOSMesa both export gl* symbols).
 */
#ifndef PM_VIEW_H
#define PM_VIEW_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "film.h"

typedef struct {
    bool enabled[PM_COMPONENT_COUNT];
    float exposure_ev;   /* display scale 2^ev */
    int tonemap;         /* 0 = clamp, 1 = Reinhard on luminance; see shaders/compose.frag */
} pm_display;

typedef struct pm_view pm_view;

/* Things the user asked for through the window since the last poll. */
typedef struct {
    bool quit;
    bool save_png;        /* P: save what is shown */
    bool display_changed; /* a toggle, exposure or tonemap key: redraw */
} pm_view_events;

/* The shaders in shaders/ are compiled into the binary (build/shaders.inc, made by the Makefile). */
pm_view *pm_view_create_window(int width, int height, const char *title,
                               char *err, size_t err_size);
pm_view *pm_view_create_offscreen(int width, int height, char *err, size_t err_size);
void pm_view_destroy(pm_view *v);

/* Uploads the film's current means (absent components stay black). */
void pm_view_upload(pm_view *v, const pm_film *film);
void pm_view_draw(pm_view *v, const pm_display *d);
/* Reads back what was last drawn: width*height*4 bytes, row 0 = top. */
void pm_view_read_rgba8(pm_view *v, uint8_t *rgba);
/* Window only: processes input (keys edit *d); blocks up to timeout seconds when wait is true. */
pm_view_events pm_view_poll(pm_view *v, pm_display *d, bool wait, double timeout);
bool pm_view_is_window(const pm_view *v);

#endif

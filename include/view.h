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
    bool error_view;     /* each pixel's error against the reference (pm_view_set_reference), false colour */
} pm_display;

typedef struct pm_view pm_view;

/* Things the user asked for through the window since the last poll. Mouse motion is in pixels of
 * the window; the caller turns it into camera moves. */
typedef struct {
    bool quit;
    bool save_png;        /* P or F12: save what is shown (and the linear layers) */
    bool display_changed; /* a toggle, exposure or tonemap key: redraw */
    double orbit_dx, orbit_dy;  /* left drag */
    double pan_dx, pan_dy;      /* right or middle drag */
    double dolly;               /* scroll wheel steps, positive = closer */
    bool pick;                  /* double click: orbit around the point under the cursor */
    double pick_x, pick_y;      /* where, in film pixels */
    float fly[3];               /* W/S, D/A, E/Q key presses: forward, right, up */
    bool fast;                  /* Shift held */
    bool frame, next_camera, home, toggle_gather, cycle_view, pause, restart, help;
    bool next_variant;          /* M: the file's next material variant (KHR_materials_variants) */
    int resized_width, resized_height; /* the film size for the window's new size, 0 when unchanged: its pixels, at
                                          most the primary monitor's (the shape kept; the picture is scaled up) */
    char dropped[4096];         /* a file dropped on the window (the first of several), "" when none */
} pm_view_events;

/* The shaders in shaders/ are compiled into the binary (build/shaders.inc, made by the Makefile).
 * A window is on screen, grey, when create returns; its GL context, shaders and textures come with
 * pm_view_prepare (until then uploads and draws do nothing), so the window can show while the
 * scene loads and the context is made and the shader compiled meanwhile, or after the first image
 * (pm_view_show_quick). An offscreen view is prepared at once. */
pm_view *pm_view_create_window(int width, int height, const char *title,
                               char *err, size_t err_size);
bool pm_view_prepare(pm_view *v, char *err, size_t err_size);
/* A film of another size: the display textures and the FBO, and the window's size to show it
 * (the window's own resize event for it is not reported as the user's). */
bool pm_view_set_size(pm_view *v, int width, int height, char *err, size_t err_size);
/* A window's GL calls may come from one thread at a time: the view's functions take its context
 * to the calling thread, and this lets it go (for another thread to prepare or draw). */
void pm_view_release_context(pm_view *v);
/* Takes the window off the screen at once, the view kept (for a process about to end). */
void pm_view_hide(pm_view *v);
/* From any thread: ends the window's wait in pm_view_poll at once. */
void pm_view_wake(pm_view *v);
pm_view *pm_view_create_offscreen(int width, int height, char *err, size_t err_size);
void pm_view_destroy(pm_view *v);

/* Uploads the film's components as pm_film_resolve gives them (absent components stay black).
 * False, the shown image unchanged and the failure recorded (memory.h), when the resolved copy
 * cannot be allocated. */
bool pm_view_upload(pm_view *v, const pm_film *film);
/* Uploads already resolved components: width*height*3 floats each, NULL = black. A size other than
 * the last upload's reallocates the textures. */
void pm_view_upload_layers(pm_view *v, int width, int height, const float *const layers[PM_COMPONENT_COUNT]);
/* The reference's total (width*height*3 floats, row 0 = top; NULL removes it) for the display's
 * error_view: each pixel's relative error sqrt(mean over channels of (x - r)^2 / (r^2 + 0.01)),
 * from 10^-3 (blue) to 1 and above (red) on a log scale. Drawn only while the film has its size. */
void pm_view_set_reference(pm_view *v, int width, int height, const float *rgb);
/* Window only: what a file dropped on the window does (GLFW's drop callback calls it with the
 * first file dropped): the next poll reports it in `dropped`. */
void pm_view_drop(pm_view *v, const char *path);
/* Window only, before pm_view_prepare: shows resolved layers at once, composed on the CPU as the
 * shader composes them (no shader needed), so a first image need not wait for the shader's
 * compilation. Nothing is kept: the prepared view's first draw replaces it. */
void pm_view_show_quick(pm_view *v, int width, int height, const float *const layers[PM_COMPONENT_COUNT], const pm_display *d);
/* Window only: the title's status part (iterations, photons, time...), before the component flags. */
void pm_view_set_status(pm_view *v, const char *status);
void pm_view_draw(pm_view *v, const pm_display *d);
/* Reads back what was last drawn: width*height*4 bytes, row 0 = top. */
void pm_view_read_rgba8(pm_view *v, uint8_t *rgba);
/* Window only: processes input (keys edit *d); blocks up to timeout seconds when wait is true. */
pm_view_events pm_view_poll(pm_view *v, pm_display *d, bool wait, double timeout);
bool pm_view_is_window(const pm_view *v);

#endif

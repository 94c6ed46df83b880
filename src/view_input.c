/* view_input.c: the window's input: GLFW's key, mouse, scroll, resize, drop and close callbacks turned into pm_view_events, polled by the window driver, and the title they keep. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "view_state.h"

static const char *const key_names[PM_COMPONENT_COUNT] = {"direct", "specular", "caustic", "indirect"};

static void update_title(pm_view *v, const pm_display *d) {
    char t[sizeof v->title + sizeof v->status + 192];
    int n = snprintf(t, sizeof t, "%s %s", v->title, v->status);
    for (int c = 0; c < PM_COMPONENT_COUNT && n < (int)sizeof t; c++)
        n += snprintf(t + n, sizeof t - n, " [%d %s]", c + 1, d->enabled[c] ? key_names[c] : "off");
    if (n < (int)sizeof t)
        snprintf(t + n, sizeof t - n, "  ev %+.1f%s", d->exposure_ev, d->tonemap ? "  reinhard" : "");
    glfwSetWindowTitle(v->window, t);
}

static void change_exposure(pm_display *d, float delta) {
    /* the same range the command line accepts, so 2^ev stays a finite float */
    float ev = d->exposure_ev + delta;
    d->exposure_ev = ev > 64.f ? 64.f : ev < -64.f ? -64.f : ev;
}

static void on_key(GLFWwindow *window, int key, int scancode, int action, int mods) {
    pm_view *v = glfwGetWindowUserPointer(window);
    if (!v || action == GLFW_RELEASE) return;
    bool repeatable = key == GLFW_KEY_EQUAL || key == GLFW_KEY_KP_ADD || key == GLFW_KEY_MINUS ||
                      key == GLFW_KEY_KP_SUBTRACT;
    pm_display *d = v->display;
    bool changed = true;
    bool fly_key = key == GLFW_KEY_W || key == GLFW_KEY_A || key == GLFW_KEY_S || key == GLFW_KEY_D ||
                   key == GLFW_KEY_Q || key == GLFW_KEY_E;
    if (action == GLFW_REPEAT && !repeatable && !fly_key) return;
    v->pending.fast = v->pending.fast || (mods & GLFW_MOD_SHIFT);
    switch (key) {
    case GLFW_KEY_ESCAPE: v->pending.quit = true; return;
    case GLFW_KEY_P: case GLFW_KEY_F12: v->pending.save_png = true; return;
    case GLFW_KEY_W: v->pending.fly[0] += 1.f; return;
    case GLFW_KEY_S: v->pending.fly[0] -= 1.f; return;
    case GLFW_KEY_D: v->pending.fly[1] += 1.f; return;
    case GLFW_KEY_A: v->pending.fly[1] -= 1.f; return;
    case GLFW_KEY_E: v->pending.fly[2] += 1.f; return;
    case GLFW_KEY_Q: v->pending.fly[2] -= 1.f; return;
    case GLFW_KEY_F: v->pending.frame = true; return;
    case GLFW_KEY_C: v->pending.next_camera = true; return;
    case GLFW_KEY_M: v->pending.next_variant = true; return;
    case GLFW_KEY_HOME: v->pending.home = true; return;
    case GLFW_KEY_G: v->pending.toggle_gather = true; return;
    case GLFW_KEY_V: v->pending.cycle_view = true; return;
    case GLFW_KEY_SPACE: v->pending.pause = true; return;
    case GLFW_KEY_R: v->pending.restart = true; return;
    case GLFW_KEY_H: v->pending.help = true; return;
    default: break;
    }
    if (!d) return;
    switch (key) {
    case GLFW_KEY_1: case GLFW_KEY_2: case GLFW_KEY_3: case GLFW_KEY_4:
        d->enabled[key - GLFW_KEY_1] = !d->enabled[key - GLFW_KEY_1];
        break;
    case GLFW_KEY_KP_1: case GLFW_KEY_KP_2: case GLFW_KEY_KP_3: case GLFW_KEY_KP_4:
        d->enabled[key - GLFW_KEY_KP_1] = !d->enabled[key - GLFW_KEY_KP_1];
        break;
    case GLFW_KEY_EQUAL: case GLFW_KEY_KP_ADD: change_exposure(d, 0.5f); break;
    case GLFW_KEY_MINUS: case GLFW_KEY_KP_SUBTRACT: change_exposure(d, -0.5f); break;
    case GLFW_KEY_0: case GLFW_KEY_KP_0:
        d->exposure_ev = 0.f;
        for (int c = 0; c < PM_COMPONENT_COUNT; c++) d->enabled[c] = true;
        break;
    case GLFW_KEY_T: d->tonemap = !d->tonemap; break;
    default: changed = false; break;
    }
    if (changed) v->pending.display_changed = true;
}

/* Window pixels to film pixels (the film is letterboxed into the window). */
static void window_to_film(const pm_view *v, double wx, double wy, double *fx, double *fy) {
    int ww = 1, wh = 1;
    glfwGetWindowSize(v->window, &ww, &wh);
    double s = fmin((double)ww / v->width, (double)wh / v->height);
    *fx = (wx - 0.5 * (ww - v->width * s)) / s;
    *fy = (wy - 0.5 * (wh - v->height * s)) / s;
}

static void on_mouse_button(GLFWwindow *window, int button, int action, int mods) {
    pm_view *v = glfwGetWindowUserPointer(window);
    if (!v) return;
    int bit = button == GLFW_MOUSE_BUTTON_LEFT ? 1 : (button == GLFW_MOUSE_BUTTON_RIGHT ? 2 : (button == GLFW_MOUSE_BUTTON_MIDDLE ? 4 : 0));
    if (action == GLFW_PRESS) {
        v->buttons |= bit;
        glfwGetCursorPos(window, &v->last_x, &v->last_y);
        if (bit == 1) {
            double now = glfwGetTime();
            if (now - v->last_click < 0.35) {
                v->pending.pick = true;
                window_to_film(v, v->last_x, v->last_y, &v->pending.pick_x, &v->pending.pick_y);
            }
            v->last_click = now;
        }
    } else {
        v->buttons &= ~bit;
    }
    v->pending.fast = v->pending.fast || (mods & GLFW_MOD_SHIFT);
}

static void on_cursor(GLFWwindow *window, double x, double y) {
    pm_view *v = glfwGetWindowUserPointer(window);
    if (!v || !v->buttons) return;
    double dx = x - v->last_x, dy = y - v->last_y;
    v->last_x = x;
    v->last_y = y;
    if (v->buttons & 1) { v->pending.orbit_dx += dx; v->pending.orbit_dy += dy; }
    else { v->pending.pan_dx += dx; v->pending.pan_dy += dy; }
}

/* A window's pixels that no monitor shows are not worth rendering: a film for a window larger
 * than the primary monitor keeps the window's shape at the monitor's size (as a window made for a
 * film larger than the screen is smaller than it), and the picture is scaled up into the window.
 * An 8192 x 8192 window on a small screen thus renders, uploads and composes a screenful, not 67
 * million pixels of float textures that took a software OpenGL half a minute to take in. */
static void on_framebuffer_size(GLFWwindow *window, int width, int height) {
    pm_view *v = glfwGetWindowUserPointer(window);
    if (!v || width < 1 || height < 1) return; /* minimised: keep rendering at the old size */
    GLFWmonitor *monitor = glfwGetPrimaryMonitor();
    const GLFWvidmode *mode = monitor ? glfwGetVideoMode(monitor) : NULL;
    int ww = 0, wh = 0;
    glfwGetWindowSize(window, &ww, &wh);
    if (v->asked_width && ww == v->asked_width && wh == v->asked_height) {
        /* the size pm_view_set_size gave the film's window, not a resize by the user */
        v->asked_width = v->asked_height = 0;
        return;
    }
    if (mode && ww > 0 && wh > 0) {
        /* the monitor's size in framebuffer pixels (screen coordinates times the window's pixel ratio) */
        double mw = (double)mode->width * width / ww, mh = (double)mode->height * height / wh;
        double s = fmin(1.0, fmin(mw / width, mh / height));
        if (s < 1.0) {
            width = (int)(width * s) > 0 ? (int)(width * s) : 1;
            height = (int)(height * s) > 0 ? (int)(height * s) : 1;
        }
    }
    v->pending.resized_width = width;
    v->pending.resized_height = height;
}

static void on_scroll(GLFWwindow *window, double xoffset, double yoffset) {
    pm_view *v = glfwGetWindowUserPointer(window);
    if (v) v->pending.dolly += yoffset;
}

void pm_view_set_status(pm_view *v, const char *status) {
    if (!v || v->backend != PM_BACKEND_WINDOW) return;
    snprintf(v->status, sizeof v->status, "%s", status ? status : "");
    v->title_set = false; /* the next poll rewrites the title */
}

void pm_view_drop(pm_view *v, const char *path) {
    if (v && path) snprintf(v->pending.dropped, sizeof v->pending.dropped, "%s", path);
}

/* GLFW's drop: the first file of what was dropped (one scene or one sky at a time). */
static void on_drop(GLFWwindow *window, int count, const char **paths) {
    pm_view *v = glfwGetWindowUserPointer(window);
    if (v && count > 0) pm_view_drop(v, paths[0]);
}

/* Tests drive the drop handler through a file, since a virtual X server has no drag source:
 * PMVIEW_TEST_DROP names a file whose first line, once it appears, is dropped (the file removed). */
static void test_drop(pm_view *v) {
    static const char *hook;
    static bool looked;
    if (!looked) { hook = getenv("PMVIEW_TEST_DROP"); looked = true; }
    if (!hook) return;
    FILE *f = fopen(hook, "r");
    if (!f) return;
    char line[sizeof v->pending.dropped] = "";
    bool read = fgets(line, sizeof line, f) != NULL;
    fclose(f);
    if (!read || !strchr(line, '\n')) return; /* still being written */
    *strchr(line, '\n') = '\0';
    unlink(hook);
    pm_view_drop(v, line);
}

static void on_close(GLFWwindow *window) {
    pm_view *v = glfwGetWindowUserPointer(window);
    if (v) v->pending.quit = true;
}

pm_view_events pm_view_poll(pm_view *v, pm_display *d, bool wait, double timeout) {
    pm_view_events none;
    memset(&none, 0, sizeof none);
    if (!v || v->backend != PM_BACKEND_WINDOW) return none;
    v->display = d;
    if (d && !v->title_set) { update_title(v, d); v->title_set = true; }
    /* GLFW rejects a zero or infinite timeout */
    if (wait && timeout > 0 && isfinite(timeout)) glfwWaitEventsTimeout(timeout);
    else glfwPollEvents();
    v->display = NULL;
    if (glfwWindowShouldClose(v->window)) v->pending.quit = true;
    test_drop(v);
    pm_view_events ev = v->pending;
    v->pending = none;
    if (ev.display_changed && d) update_title(v, d);
    return ev;
}

/* The window's events routed to the callbacks above. */
void pm_view_listen(pm_view *v) {
    glfwSetKeyCallback(v->window, on_key);
    glfwSetMouseButtonCallback(v->window, on_mouse_button);
    glfwSetCursorPosCallback(v->window, on_cursor);
    glfwSetScrollCallback(v->window, on_scroll);
    glfwSetFramebufferSizeCallback(v->window, on_framebuffer_size);
    glfwSetWindowCloseCallback(v->window, on_close);
    glfwSetDropCallback(v->window, on_drop);
}

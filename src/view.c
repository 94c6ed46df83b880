/* view.c: the display: a GLFW window or an OSMesa offscreen context running shaders/compose.* on the film.
 *
 * Both backends draw the composite into the same kind of target, an FBO with an RGBA8 colour
 * texture of the film's size, and pm_view_read_rgba8 reads that FBO; the window only copies it
 * to its own framebuffer afterwards. So a PNG saved from the window equals the offscreen one
 * pixel for pixel, whatever the window's size.
 *
 * The process uses both libGL (through GLFW) and libOSMesa, and both export gl* symbols whose
 * dispatch belongs to different libraries. Calling them directly would pick one at link time,
 * so every entry point is fetched through the current context's get-proc-address into a table
 * (pm_gl) and all GL code goes through v->gl. libOSMesa is opened (dlopen) at the first
 * offscreen view, not linked: it brings LLVM, whose loading took 65 ms of every start.
 *
 * The window is made the same way: GLFW opens it without a context (its X11 window, its events),
 * and the GL context is made on it later through GLX, libGL opened with dlopen by
 * pm_view_prepare. Loading the GL driver (Mesa's brings LLVM too) took longer than the rest of a
 * small scene's start together; without it the window and the first image (pm_view_show_quick,
 * through X11) come first.
 */
#include <dlfcn.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "view_state.h"
#include "memory.h"

#include "shaders.inc"

static void draw_composite(pm_view *v, const pm_display *d);
static void copy_to_window(pm_view *v);
static bool load_gl(pm_gl *gl, pm_gl_loader load, char *err, size_t err_size);

/* GLFW reports errors through a callback; the last message becomes part of create's error. */
static char glfw_error[256];
static int glfw_users;

static void on_glfw_error(int code, const char *description) {
    snprintf(glfw_error, sizeof glfw_error, "%s (GLFW error 0x%x)", description ? description : "?", code);
}

/* libOSMesa's entry points, from the library opened at the first offscreen view. */
static struct {
    OSMesaContext (*CreateContextAttribs)(const int *attribs, OSMesaContext share);
    GLboolean (*MakeCurrent)(OSMesaContext context, void *buffer, GLenum type, GLsizei width, GLsizei height);
    void (*DestroyContext)(OSMesaContext context);
    OSMesaContext (*GetCurrentContext)(void);
    OSMESAproc (*GetProcAddress)(const char *name);
    bool loaded;
    char error[256];
} osmesa;
static pthread_once_t osmesa_once = PTHREAD_ONCE_INIT;

static void open_osmesa(void) {
    void *lib = dlopen("libOSMesa.so.8", RTLD_NOW | RTLD_LOCAL);
    if (!lib) lib = dlopen("libOSMesa.so", RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        const char *why = dlerror();
        snprintf(osmesa.error, sizeof osmesa.error, "cannot open libOSMesa (%s)", why ? why : "dlopen failed");
        return;
    }
    /* (a data pointer to a function pointer through memcpy: dlsym's documented use) */
    struct { const char *name; void *slot; size_t size; } entries[] = {
        {"OSMesaCreateContextAttribs", &osmesa.CreateContextAttribs, sizeof osmesa.CreateContextAttribs},
        {"OSMesaMakeCurrent", &osmesa.MakeCurrent, sizeof osmesa.MakeCurrent},
        {"OSMesaDestroyContext", &osmesa.DestroyContext, sizeof osmesa.DestroyContext},
        {"OSMesaGetCurrentContext", &osmesa.GetCurrentContext, sizeof osmesa.GetCurrentContext},
        {"OSMesaGetProcAddress", &osmesa.GetProcAddress, sizeof osmesa.GetProcAddress}};
    for (size_t i = 0; i < sizeof entries / sizeof *entries; i++) {
        void *f = dlsym(lib, entries[i].name);
        if (!f) {
            snprintf(osmesa.error, sizeof osmesa.error, "libOSMesa has no %s", entries[i].name);
            return;
        }
        memcpy(entries[i].slot, &f, entries[i].size);
    }
    osmesa.loaded = true;
}

static pm_gl_proc osmesa_loader(const char *name) {
    return (pm_gl_proc)osmesa.GetProcAddress(name);
}

/* libGL's GLX entry points, from the library opened when the first window's context is made. */
static struct {
    GLXFBConfig *(*ChooseFBConfig)(Display *display, int screen, const int *attributes, int *count);
    XVisualInfo *(*GetVisualFromFBConfig)(Display *display, GLXFBConfig config);
    int (*GetFBConfigAttrib)(Display *display, GLXFBConfig config, int attribute, int *value);
    const char *(*QueryExtensionsString)(Display *display, int screen);
    Bool (*MakeCurrent)(Display *display, GLXDrawable drawable, GLXContext context);
    GLXContext (*GetCurrentContext)(void);
    void (*SwapBuffers)(Display *display, GLXDrawable drawable);
    void (*DestroyContext)(Display *display, GLXContext context);
    pm_gl_proc (*GetProcAddress)(const GLubyte *name);
    bool loaded;
    char error[256];
} glx;
static pthread_once_t glx_once = PTHREAD_ONCE_INIT;

static void open_glx(void) {
    void *lib = dlopen("libGL.so.1", RTLD_NOW | RTLD_LOCAL);
    if (!lib) lib = dlopen("libGL.so", RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        const char *why = dlerror();
        snprintf(glx.error, sizeof glx.error, "cannot open libGL (%s)", why ? why : "dlopen failed");
        return;
    }
    struct { const char *name; void *slot; size_t size; } entries[] = {
        {"glXChooseFBConfig", &glx.ChooseFBConfig, sizeof glx.ChooseFBConfig},
        {"glXGetVisualFromFBConfig", &glx.GetVisualFromFBConfig, sizeof glx.GetVisualFromFBConfig},
        {"glXGetFBConfigAttrib", &glx.GetFBConfigAttrib, sizeof glx.GetFBConfigAttrib},
        {"glXQueryExtensionsString", &glx.QueryExtensionsString, sizeof glx.QueryExtensionsString},
        {"glXMakeCurrent", &glx.MakeCurrent, sizeof glx.MakeCurrent},
        {"glXGetCurrentContext", &glx.GetCurrentContext, sizeof glx.GetCurrentContext},
        {"glXSwapBuffers", &glx.SwapBuffers, sizeof glx.SwapBuffers},
        {"glXDestroyContext", &glx.DestroyContext, sizeof glx.DestroyContext},
        {"glXGetProcAddressARB", &glx.GetProcAddress, sizeof glx.GetProcAddress}};
    for (size_t i = 0; i < sizeof entries / sizeof *entries; i++) {
        void *f = dlsym(lib, entries[i].name);
        if (!f) {
            snprintf(glx.error, sizeof glx.error, "libGL has no %s", entries[i].name);
            return;
        }
        memcpy(entries[i].slot, &f, entries[i].size);
    }
    glx.loaded = true;
}

static pm_gl_proc glx_loader(const char *name) {
    return glx.GetProcAddress((const GLubyte *)name);
}

/* An X error while the context is made (a server without 3.3 core contexts answers BadMatch or
 * GLXBadFBConfig) is noted here rather than ending the process, Xlib's default. */
static volatile int glx_x_error;
static int note_x_error(Display *display, XErrorEvent *event) {
    (void)display;
    glx_x_error = event->error_code ? event->error_code : 1;
    return 0;
}

static bool has_extension(const char *list, const char *name) {
    size_t n = strlen(name);
    for (const char *at = list; at && (at = strstr(at, name)); at += n)
        if ((at == list || at[-1] == ' ') && (at[n] == ' ' || at[n] == 0)) return true;
    return false;
}

/* The window's OpenGL 3.3 core context, made through GLX on the X11 window GLFW opened (its
 * visual: a framebuffer configuration of that visual), current on the calling thread. */
static bool make_window_context(pm_view *v, char *err, size_t err_size) {
    pthread_once(&glx_once, open_glx);
    if (!glx.loaded) {
        snprintf(err, err_size, "cannot create an OpenGL 3.3 core context: %s", glx.error);
        return false;
    }
    Display *display = glfwGetX11Display();
    Window window = glfwGetX11Window(v->window);
    XWindowAttributes attributes;
    if (!display || !window || !XGetWindowAttributes(display, window, &attributes)) {
        snprintf(err, err_size, "cannot create an OpenGL 3.3 core context: the window's X11 attributes are unknown");
        return false;
    }
    int screen = XScreenNumberOfScreen(attributes.screen);
    const char *extensions = glx.QueryExtensionsString(display, screen);
    if (!has_extension(extensions, "GLX_ARB_create_context") || !has_extension(extensions, "GLX_ARB_create_context_profile")) {
        snprintf(err, err_size, "cannot create an OpenGL 3.3 core context: GLX has no GLX_ARB_create_context_profile");
        return false;
    }
    static const int wanted[] = {GLX_X_RENDERABLE, True, GLX_DRAWABLE_TYPE, GLX_WINDOW_BIT, GLX_RENDER_TYPE, GLX_RGBA_BIT,
                                 GLX_DOUBLEBUFFER, True, GLX_RED_SIZE, 8, GLX_GREEN_SIZE, 8, GLX_BLUE_SIZE, 8, None};
    int count = 0;
    GLXFBConfig *configs = glx.ChooseFBConfig(display, screen, wanted, &count), chosen = NULL;
    /* The configuration with the fewest extra buffers: nothing here uses depth, stencil or
     * multisampling, and each is allocated at the window's size (a depth and stencil buffer made
     * the first frame of an 8192 x 8192 window take seconds). A server may offer none such for the
     * window's own visual (Xvfb's default visual has one configuration, with both), so the GL
     * draws into a child window of the configuration's visual; its pixels must mean what the
     * parent's do (the same depth and masks, TrueColor), so that X shows, and xwd reads, them alike. */
    int least = 0;
    XVisualInfo chosen_visual = {0};
    for (int i = 0; i < count; i++) {
        XVisualInfo *info = glx.GetVisualFromFBConfig(display, configs[i]);
        bool alike = info && info->class == TrueColor && info->depth == attributes.depth &&
                     info->red_mask == attributes.visual->red_mask && info->green_mask == attributes.visual->green_mask &&
                     info->blue_mask == attributes.visual->blue_mask;
        if (alike) {
            int depth = 0, stencil = 0, samples = 0;
            glx.GetFBConfigAttrib(display, configs[i], GLX_DEPTH_SIZE, &depth);
            glx.GetFBConfigAttrib(display, configs[i], GLX_STENCIL_SIZE, &stencil);
            glx.GetFBConfigAttrib(display, configs[i], GLX_SAMPLES, &samples);
            int extra = 1000 * samples + depth + stencil;
            if (!chosen || extra < least) {
                chosen = configs[i];
                least = extra;
                chosen_visual = *info;
            }
        }
        if (info) XFree(info);
    }
    if (configs) XFree(configs);
    if (!chosen) {
        snprintf(err, err_size, "cannot create an OpenGL 3.3 core context: no double-buffered RGB8 configuration for a %d-bit TrueColor window",
                 attributes.depth);
        return false;
    }
    GLXContext (*create)(Display *, GLXFBConfig, GLXContext, Bool, const int *);
    pm_gl_proc found = glx.GetProcAddress((const GLubyte *)"glXCreateContextAttribsARB");
    memcpy(&create, &found, sizeof create);
    static const int context_attributes[] = {GLX_CONTEXT_MAJOR_VERSION_ARB, 3, GLX_CONTEXT_MINOR_VERSION_ARB, 3,
                                             GLX_CONTEXT_PROFILE_MASK_ARB, GLX_CONTEXT_CORE_PROFILE_BIT_ARB,
                                             GLX_CONTEXT_FLAGS_ARB, GLX_CONTEXT_FORWARD_COMPATIBLE_BIT_ARB, None};
    /* (the handler is the process's: GLFW sets its own only around its own calls on the window's
     * thread, none of which runs while a context is made, the window's thread waiting meanwhile) */
    XSync(display, False);
    glx_x_error = 0;
    XErrorHandler previous = XSetErrorHandler(note_x_error);
    GLXContext context = create ? create(display, chosen, NULL, True, context_attributes) : NULL;
    XSync(display, False);
    XSetErrorHandler(previous);
    if (!context || glx_x_error) {
        if (context) glx.DestroyContext(display, context);
        snprintf(err, err_size, "cannot create an OpenGL 3.3 core context: GLX refused it (X error %d)", glx_x_error);
        return false;
    }
    /* the child: no events selected, so keys and the mouse go on to GLFW's window; no background,
     * so what the parent shows (the first image) stays until GL draws */
    XSetWindowAttributes child = {.background_pixmap = None, .border_pixel = 0};
    child.colormap = XCreateColormap(display, window, chosen_visual.visual, AllocNone);
    int width = attributes.width > 0 ? attributes.width : 1, height = attributes.height > 0 ? attributes.height : 1;
    Window gl_window = XCreateWindow(display, window, 0, 0, (unsigned)width, (unsigned)height, 0, chosen_visual.depth, InputOutput,
                                     chosen_visual.visual, CWBackPixmap | CWBorderPixel | CWColormap, &child);
    if (!gl_window || !glx.MakeCurrent(display, gl_window, context)) {
        glx.DestroyContext(display, context);
        if (gl_window) XDestroyWindow(display, gl_window);
        XFreeColormap(display, child.colormap);
        snprintf(err, err_size, "cannot create an OpenGL 3.3 core context: glXMakeCurrent failed");
        return false;
    }
    XMapWindow(display, gl_window);
    v->glx_context = context;
    v->gl_window = gl_window;
    v->gl_colormap = child.colormap;
    v->gl_window_width = width;
    v->gl_window_height = height;
    /* rendering iterations are not to be throttled by the monitor's refresh */
    if (has_extension(extensions, "GLX_EXT_swap_control")) {
        void (*interval)(Display *, GLXDrawable, int);
        found = glx.GetProcAddress((const GLubyte *)"glXSwapIntervalEXT");
        memcpy(&interval, &found, sizeof interval);
        if (interval) interval(display, gl_window, 0);
    } else if (has_extension(extensions, "GLX_MESA_swap_control")) {
        int (*interval)(unsigned);
        found = glx.GetProcAddress((const GLubyte *)"glXSwapIntervalMESA");
        memcpy(&interval, &found, sizeof interval);
        if (interval) interval(0);
    }
    if (!load_gl(&v->gl, glx_loader, err, err_size)) return false;
    v->gl_loaded = true;
    XFlush(display);
    return true;
}

static bool load_gl(pm_gl *gl, pm_gl_loader load, char *err, size_t err_size) {
    pm_gl_proc p;
#define PM_GL_LOAD(ret, name, params) \
    if (!(p = load("gl" #name))) { \
        snprintf(err, err_size, "cannot create an OpenGL 3.3 core context: no entry point gl%s", #name); \
        return false; \
    } \
    gl->name = (ret (GLAPIENTRY *) params)p;
    PM_GL_FUNCTIONS(PM_GL_LOAD)
#undef PM_GL_LOAD
    return true;
}

static void make_current(pm_view *v) {
    if (v->backend == PM_BACKEND_OFFSCREEN) {
        if (osmesa.GetCurrentContext() != v->osmesa)
            osmesa.MakeCurrent(v->osmesa, v->osmesa_buffer, GL_UNSIGNED_BYTE, v->width, v->height);
    } else if (v->glx_context && glx.GetCurrentContext() != v->glx_context) {
        glx.MakeCurrent(glfwGetX11Display(), v->gl_window, v->glx_context);
    }
}

/* Info logs span lines; the caller's error is one line. */
static void one_line(char *s) {
    size_t n = strlen(s);
    while (n && (s[n - 1] == '\n' || s[n - 1] == '\r' || s[n - 1] == ' ')) s[--n] = 0;
    for (char *c = s; *c; c++)
        if (*c == '\n' || *c == '\r') *c = ' ';
}

static GLuint compile_shader(pm_view *v, GLenum type, const char *source, const char *name, char *err, size_t err_size) {
    GLuint s = v->gl.CreateShader(type);
    v->gl.ShaderSource(s, 1, &source, NULL);
    v->gl.CompileShader(s);
    GLint ok = 0;
    v->gl.GetShaderiv(s, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        char log[768] = "";
        v->gl.GetShaderInfoLog(s, sizeof log, NULL, log);
        one_line(log);
        snprintf(err, err_size, "cannot compile shaders/%s: %s", name, log);
        v->gl.DeleteShader(s);
        return 0;
    }
    return s;
}

static bool build_program(pm_view *v, char *err, size_t err_size) {
    GLuint vs = compile_shader(v, GL_VERTEX_SHADER, pm_shader_compose_vert, "compose.vert", err, err_size);
    if (!vs) return false;
    GLuint fs = compile_shader(v, GL_FRAGMENT_SHADER, pm_shader_compose_frag, "compose.frag", err, err_size);
    if (!fs) { v->gl.DeleteShader(vs); return false; }
    v->program = v->gl.CreateProgram();
    v->gl.AttachShader(v->program, vs);
    v->gl.AttachShader(v->program, fs);
    v->gl.LinkProgram(v->program);
    /* the program keeps the compiled code; the shader objects go away with it */
    v->gl.DeleteShader(vs);
    v->gl.DeleteShader(fs);
    GLint ok = 0;
    v->gl.GetProgramiv(v->program, GL_LINK_STATUS, &ok);
    if (!ok) {
        char log[768] = "";
        v->gl.GetProgramInfoLog(v->program, sizeof log, NULL, log);
        one_line(log);
        snprintf(err, err_size, "cannot link shaders/compose.vert + compose.frag: %s", log);
        return false;
    }
    static const char *const sampler_names[PM_COMPONENT_COUNT] = {"u_component[0]", "u_component[1]",
                                                                  "u_component[2]", "u_component[3]"};
    static const char *const enabled_names[PM_COMPONENT_COUNT] = {"u_enabled[0]", "u_enabled[1]", "u_enabled[2]",
                                                                  "u_enabled[3]"};
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        v->u_component[c] = v->gl.GetUniformLocation(v->program, sampler_names[c]);
        v->u_enabled[c] = v->gl.GetUniformLocation(v->program, enabled_names[c]);
    }
    v->u_scale = v->gl.GetUniformLocation(v->program, "u_scale");
    v->u_exposure = v->gl.GetUniformLocation(v->program, "u_exposure");
    v->u_tonemap = v->gl.GetUniformLocation(v->program, "u_tonemap");
    v->u_height = v->gl.GetUniformLocation(v->program, "u_height");
    v->u_reference = v->gl.GetUniformLocation(v->program, "u_reference");
    v->u_error_view = v->gl.GetUniformLocation(v->program, "u_error_view");
    v->gl.UseProgram(v->program);
    v->gl.Uniform1i(v->u_reference, PM_COMPONENT_COUNT); /* the unit after the components' */
    /* texture unit c always holds component c */
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) v->gl.Uniform1i(v->u_component[c], c);
    return true;
}

static void nearest_clamped(pm_view *v) {
    v->gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    v->gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    v->gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    v->gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    /* a single level: without this the texture would be incomplete under a mipmap min filter */
    v->gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
}

/* (Re)allocates the film-sized objects: the FBO's colour texture and the component textures. */
static bool allocate_film_targets(pm_view *v, int width, int height, char *err, size_t err_size) {
    GLint max_size = 0;
    v->gl.GetIntegerv(GL_MAX_TEXTURE_SIZE, &max_size);
    if (width > max_size || height > max_size) {
        snprintf(err, err_size, "a %dx%d image is larger than this OpenGL's texture limit (%d)", width, height,
                 (int)max_size);
        return false;
    }
    v->width = width;
    v->height = height;
    v->gl.ActiveTexture(GL_TEXTURE0);
    v->gl.BindTexture(GL_TEXTURE_2D, v->target);
    v->gl.TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, width, height, 0, GL_RGBA, GL_UNSIGNED_BYTE, NULL);
    nearest_clamped(v);
    v->gl.BindFramebuffer(GL_FRAMEBUFFER, v->fbo);
    v->gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, v->target, 0);
    GLenum status = v->gl.CheckFramebufferStatus(GL_FRAMEBUFFER);
    if (status != GL_FRAMEBUFFER_COMPLETE) {
        snprintf(err, err_size, "cannot render to a %dx%d RGBA8 texture (framebuffer status 0x%x)", width, height,
                 (unsigned)status);
        return false;
    }
    /* black until the first draw, so reading back before drawing is still defined */
    v->gl.Viewport(0, 0, width, height);
    v->gl.ClearColor(0.f, 0.f, 0.f, 1.f);
    v->gl.Clear(GL_COLOR_BUFFER_BIT);
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        v->gl.BindTexture(GL_TEXTURE_2D, v->component_tex[c]);
        v->gl.TexImage2D(GL_TEXTURE_2D, 0, GL_RGB32F, width, height, 0, GL_RGB, GL_FLOAT, NULL);
        nearest_clamped(v);
        v->present[c] = false;
    }
    if (v->gl.GetError() != GL_NO_ERROR) {
        snprintf(err, err_size, "cannot allocate the %dx%d display textures (out of memory?)", width, height);
        return false;
    }
    return true;
}

/* Everything after the context and its entry points: shaders, textures, the FBO. */
static bool prepare_gl(pm_view *v, int width, int height, char *err, size_t err_size) {
    while (v->gl.GetError() != GL_NO_ERROR) {}
    if (!build_program(v, err, err_size)) return false;
    v->gl.GenVertexArrays(1, &v->vao);
    v->gl.GenFramebuffers(1, &v->fbo);
    v->gl.GenTextures(1, &v->target);
    v->gl.GenTextures(1, &v->black);
    v->gl.GenTextures(PM_COMPONENT_COUNT, v->component_tex);
    /* rows of RGB floats and RGBA bytes are always 4-byte multiples, but say so anyway */
    v->gl.PixelStorei(GL_UNPACK_ALIGNMENT, 1);
    v->gl.PixelStorei(GL_PACK_ALIGNMENT, 1);
    static const float zero[3] = {0.f, 0.f, 0.f};
    v->gl.ActiveTexture(GL_TEXTURE0);
    v->gl.BindTexture(GL_TEXTURE_2D, v->black);
    v->gl.TexImage2D(GL_TEXTURE_2D, 0, GL_RGB32F, 1, 1, 0, GL_RGB, GL_FLOAT, zero);
    nearest_clamped(v);
    v->gl.Disable(GL_DEPTH_TEST);
    v->gl.Disable(GL_BLEND);
    if (!allocate_film_targets(v, width, height, err, err_size)) return false;
    v->prepared = true;
    return true;
}

static bool setup_gl(pm_view *v, pm_gl_loader load, int width, int height, char *err, size_t err_size) {
    if (!load_gl(&v->gl, load, err, err_size)) return false;
    v->gl_loaded = true;
    return prepare_gl(v, width, height, err, err_size);
}

static void release_gl(pm_view *v) {
    if (!v->gl_loaded) return;
    v->gl.BindFramebuffer(GL_FRAMEBUFFER, 0);
    v->gl.BindVertexArray(0);
    v->gl.UseProgram(0);
    if (v->program) v->gl.DeleteProgram(v->program);
    if (v->vao) v->gl.DeleteVertexArrays(1, &v->vao);
    if (v->fbo) v->gl.DeleteFramebuffers(1, &v->fbo);
    if (v->target) v->gl.DeleteTextures(1, &v->target);
    if (v->black) v->gl.DeleteTextures(1, &v->black);
    v->gl.DeleteTextures(PM_COMPONENT_COUNT, v->component_tex);
    if (v->reference_tex) v->gl.DeleteTextures(1, &v->reference_tex);
}

void pm_view_destroy(pm_view *v) {
    if (!v) return;
    if (v->backend == PM_BACKEND_OFFSCREEN) {
        if (v->osmesa) {
            make_current(v);
            release_gl(v);
            osmesa.MakeCurrent(NULL, NULL, GL_UNSIGNED_BYTE, 0, 0);
            osmesa.DestroyContext(v->osmesa);
        }
        free(v->osmesa_buffer);
    } else {
        if (v->window) {
            if (v->glx_context) {
                make_current(v);
                release_gl(v);
                glx.MakeCurrent(glfwGetX11Display(), None, NULL);
                glx.DestroyContext(glfwGetX11Display(), v->glx_context);
                XDestroyWindow(glfwGetX11Display(), v->gl_window);
                XFreeColormap(glfwGetX11Display(), v->gl_colormap);
            }
            glfwDestroyWindow(v->window);
        }
        if (--glfw_users == 0) glfwTerminate();
    }
    free(v);
}

/* A view of the given size and backend with nothing created yet; NULL with err set. */
static pm_view *view_alloc(int backend, int width, int height, char *err, size_t err_size) {
    uint64_t mark = pm_memory_failure_mark();
    if (width < 1 || height < 1) {
        snprintf(err, err_size, "bad display size %dx%d", width, height);
        return NULL;
    }
    pm_view *v = pm_calloc(1, sizeof *v, "the display");
    if (!v) { snprintf(err, err_size, "out of memory (%s)", pm_memory_failure_since(mark)); return NULL; }
    v->backend = backend;
    v->width = width;
    v->height = height;
    return v;
}

pm_view *pm_view_create_offscreen(int width, int height, char *err, size_t err_size) {
    pm_view *v = view_alloc(PM_BACKEND_OFFSCREEN, width, height, err, err_size);
    if (!v) return NULL;
    static const int attribs[] = {OSMESA_FORMAT, OSMESA_RGBA, OSMESA_DEPTH_BITS, 0,
                                  OSMESA_PROFILE, OSMESA_CORE_PROFILE,
                                  OSMESA_CONTEXT_MAJOR_VERSION, 3, OSMESA_CONTEXT_MINOR_VERSION, 3, 0};
    pthread_once(&osmesa_once, open_osmesa);
    if (!osmesa.loaded) {
        snprintf(err, err_size, "cannot create an offscreen OpenGL context: %s", osmesa.error);
        pm_view_destroy(v);
        return NULL;
    }
    v->osmesa = osmesa.CreateContextAttribs(attribs, NULL);
    if (!v->osmesa) {
        snprintf(err, err_size, "cannot create an OpenGL 3.3 core context: OSMesaCreateContextAttribs failed");
        pm_view_destroy(v);
        return NULL;
    }
    v->osmesa_buffer = pm_malloc(4 * (size_t)width * height, "offscreen buffer");
    if (!v->osmesa_buffer) {
        snprintf(err, err_size, "out of memory for a %dx%d offscreen buffer", width, height);
        pm_view_destroy(v);
        return NULL;
    }
    if (!osmesa.MakeCurrent(v->osmesa, v->osmesa_buffer, GL_UNSIGNED_BYTE, width, height)) {
        snprintf(err, err_size, "cannot create an OpenGL 3.3 core context: OSMesaMakeCurrent failed for %dx%d",
                 width, height);
        pm_view_destroy(v);
        return NULL;
    }
    if (!setup_gl(v, osmesa_loader, width, height, err, err_size)) {
        pm_view_destroy(v);
        return NULL;
    }
    return v;
}

/* A film larger than the screen gets a smaller window of the same shape; the picture is scaled
 * into it and the saved PNG keeps the film's full size. */
static void window_size_for(int width, int height, int *win_w, int *win_h) {
    *win_w = width;
    *win_h = height;
    GLFWmonitor *monitor = glfwGetPrimaryMonitor();
    const GLFWvidmode *mode = monitor ? glfwGetVideoMode(monitor) : NULL;
    if (mode && (width > mode->width || height > mode->height)) {
        double s = fmin((double)mode->width / width, (double)mode->height / height) * 0.9;
        *win_w = (int)(width * s) > 0 ? (int)(width * s) : 1;
        *win_h = (int)(height * s) > 0 ? (int)(height * s) : 1;
    }
}

pm_view *pm_view_create_window(int width, int height, const char *title, char *err, size_t err_size) {
    pm_view *v = view_alloc(PM_BACKEND_WINDOW, width, height, err, err_size);
    if (!v) return NULL;
    snprintf(v->title, sizeof v->title, "%s", title ? title : "pmview");
    glfw_error[0] = 0;
    glfwSetErrorCallback(on_glfw_error);
    glfw_users++; /* destroy balances this, even when init fails: glfwTerminate is safe then */
    if (!glfwInit()) {
        snprintf(err, err_size, "cannot open a window: %s", glfw_error[0] ? glfw_error : "glfwInit failed");
        pm_view_destroy(v);
        return NULL;
    }
    /* the context comes later (pm_view_prepare), through GLX */
    glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
    glfwWindowHint(GLFW_RESIZABLE, GLFW_TRUE);
    glfwWindowHint(GLFW_DEPTH_BITS, 0);
    glfwWindowHint(GLFW_STENCIL_BITS, 0);
    int win_w, win_h;
    window_size_for(width, height, &win_w, &win_h);
    v->window = glfwCreateWindow(win_w, win_h, v->title, NULL, NULL);
    if (!v->window) {
        snprintf(err, err_size, "cannot open a window: %s", glfw_error[0] ? glfw_error : "glfwCreateWindow failed");
        pm_view_destroy(v);
        return NULL;
    }
    glfwSetWindowUserPointer(v->window, v);
    pm_view_listen(v);
    /* The first frame: the bars' grey, the X server's own background for the window until GL
     * draws. The GL context, the compose shader and Mesa's software rasteriser turning it into
     * code at its first draw take longer than opening the window; pm_view_prepare does them while
     * the scene loads, or after the first image. */
    Display *display = glfwGetX11Display();
    Window window = glfwGetX11Window(v->window);
    XWindowAttributes attributes;
    if (display && window && XGetWindowAttributes(display, window, &attributes) && attributes.visual->class == TrueColor) {
        unsigned long grey = 0, masks[3] = {attributes.visual->red_mask, attributes.visual->green_mask, attributes.visual->blue_mask};
        for (int c = 0; c < 3; c++) {
            int shift = 0;
            while (masks[c] && !((masks[c] >> shift) & 1)) shift++;
            grey |= ((unsigned long)PM_VIEW_BAR_GREY << shift) & masks[c];
        }
        XSetWindowBackground(display, window, grey);
        XClearWindow(display, window);
        XFlush(display);
    }
    return v;
}

bool pm_view_prepare(pm_view *v, char *err, size_t err_size) {
    if (!v) return false;
    if (v->prepared) return true;
    if (v->backend == PM_BACKEND_WINDOW && !v->glx_context && !make_window_context(v, err, err_size)) return false;
    make_current(v);
    if (!prepare_gl(v, v->width, v->height, err, err_size)) return false;
    /* one draw into the FBO, finished: the software rasteriser compiles the shader for the state
     * every later draw uses (the same texture formats, filters and target), so the first image
     * is drawn without that pause */
    pm_display black = {.enabled = {true, true, true, true}, .exposure_ev = 0.f, .tonemap = 0};
    draw_composite(v, &black);
    /* the copy into the window is a shader of the rasteriser's own (scaled: linear filtering) */
    if (v->backend == PM_BACKEND_WINDOW) copy_to_window(v);
    v->gl.Finish();
    return true;
}

bool pm_view_set_size(pm_view *v, int width, int height, char *err, size_t err_size) {
    if (!v) return false;
    if (width == v->width && height == v->height) return true;
    if (width < 1 || height < 1) {
        snprintf(err, err_size, "bad display size %dx%d", width, height);
        return false;
    }
    make_current(v);
    if (v->prepared && !allocate_film_targets(v, width, height, err, err_size)) return false;
    v->width = width;
    v->height = height;
    if (v->backend == PM_BACKEND_WINDOW) {
        window_size_for(width, height, &v->asked_width, &v->asked_height);
        glfwSetWindowSize(v->window, v->asked_width, v->asked_height);
    }
    return true;
}

void pm_view_release_context(pm_view *v) {
    if (v && v->backend == PM_BACKEND_WINDOW && v->glx_context && glx.GetCurrentContext() == v->glx_context)
        glx.MakeCurrent(glfwGetX11Display(), None, NULL);
}

void pm_view_hide(pm_view *v) {
    if (!v || v->backend != PM_BACKEND_WINDOW || !v->window) return;
    glfwHideWindow(v->window);
    glfwPollEvents(); /* sends the request to the display server at once */
}

void pm_view_wake(pm_view *v) {
    if (v && v->backend == PM_BACKEND_WINDOW) glfwPostEmptyEvent();
}

/* ---- drawing ---- */

void pm_view_upload_layers(pm_view *v, int width, int height, const float *const layers[PM_COMPONENT_COUNT]) {
    if (!v || !v->prepared) return;
    make_current(v);
    if (width != v->width || height != v->height) {
        char ignored[256];
        if (width < 1 || height < 1 || !allocate_film_targets(v, width, height, ignored, sizeof ignored)) return;
    }
    v->gl.ActiveTexture(GL_TEXTURE0);
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        v->present[c] = layers[c] != NULL;
        if (!layers[c]) continue;
        /* film row 0 (top) goes to texel row 0; compose.frag flips when it fetches */
        v->gl.BindTexture(GL_TEXTURE_2D, v->component_tex[c]);
        v->gl.TexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, width, height, GL_RGB, GL_FLOAT, layers[c]);
    }
    v->scale = 1.f;
}

void pm_view_set_reference(pm_view *v, int width, int height, const float *rgb) {
    if (!v || !v->prepared) return;
    make_current(v);
    if (!rgb) {
        if (v->reference_tex) v->gl.DeleteTextures(1, &v->reference_tex);
        v->reference_tex = 0;
        return;
    }
    if (!v->reference_tex) v->gl.GenTextures(1, &v->reference_tex);
    v->gl.ActiveTexture(GL_TEXTURE0);
    v->gl.BindTexture(GL_TEXTURE_2D, v->reference_tex);
    v->gl.TexImage2D(GL_TEXTURE_2D, 0, GL_RGB32F, width, height, 0, GL_RGB, GL_FLOAT, rgb);
    nearest_clamped(v);
    v->reference_width = width;
    v->reference_height = height;
}

/* compose.frag's arithmetic on the CPU, for the one image shown before the shader exists. */
static float quick_sanitize(float x) { return x > 0.f ? (x < 1e15f ? x : 1e15f) : 0.f; } /* NaN fails x > 0 */
static uint8_t quick_srgb(float x) {
    x = x < 0.f ? 0.f : (x > 1.f ? 1.f : x);
    float e = x < 0.0031308f ? 12.92f * x : 1.055f * powf(x, 1.f / 2.4f) - 0.055f;
    return (uint8_t)lroundf(e * 255.f);
}

/* Shows the image through X11 itself (XPutImage into the GLFW window): any GL drawing, a blit
 * included, makes Mesa's software rasteriser compile code first, longer than everything else
 * before the first image. */
void pm_view_show_quick(pm_view *v, int width, int height, const float *const layers[PM_COMPONENT_COUNT], const pm_display *d) {
    if (!v || v->backend != PM_BACKEND_WINDOW || v->prepared || width < 1 || height < 1) return;
    Display *display = glfwGetX11Display();
    Window window = glfwGetX11Window(v->window);
    XWindowAttributes attributes;
    if (!display || !window || !XGetWindowAttributes(display, window, &attributes) || attributes.visual->class != TrueColor)
        return;
    int fw = attributes.width, fh = attributes.height;
    if (fw < 1 || fh < 1) return;
    XImage *image = XCreateImage(display, attributes.visual, (unsigned)attributes.depth, ZPixmap, 0, NULL, (unsigned)fw,
                                 (unsigned)fh, 32, 0);
    if (!image) return;
    const uint16_t one = 1;
    bool little_endian = *(const uint8_t *)&one == 1;
    if (image->bits_per_pixel != 32 || image->byte_order != (little_endian ? LSBFirst : MSBFirst)) {
        XDestroyImage(image);
        return;
    }
    /* out of memory, the first image waits for GL to draw it: said, not silent */
    uint64_t mark = pm_memory_failure_mark();
    if (!(image->data = pm_malloc((size_t)image->bytes_per_line * fh, "the first image's X11 copy"))) {
        fprintf(stderr, "pmview: warning: out of memory (%s): the first image waits for GL\n",
                pm_memory_failure_since_or(mark, "the first image's X11 copy"));
        XDestroyImage(image);
        return;
    }
    /* a channel's place in a pixel from the visual's masks (8 bits each on any TrueColor X server) */
    unsigned long masks[3] = {attributes.visual->red_mask, attributes.visual->green_mask, attributes.visual->blue_mask};
    int shifts[3];
    for (int c = 0; c < 3; c++) {
        shifts[c] = 0;
        while (masks[c] && !((masks[c] >> shifts[c]) & 1)) shifts[c]++;
    }
    /* the film's pixels composed once (a preview's blocks repeat a value: composed once a run),
     * then scaled into the window row by row */
    uint32_t *composed = pm_malloc(sizeof(uint32_t) * (size_t)width * height, "the first image's composed pixels");
    if (!composed) {
        fprintf(stderr, "pmview: warning: out of memory (%s): the first image waits for GL\n",
                pm_memory_failure_since_or(mark, "the first image's composed pixels"));
        XDestroyImage(image);
        return;
    }
    float exposure = exp2f(isfinite(d->exposure_ev) ? fmaxf(-64.f, fminf(64.f, d->exposure_ev)) : 0.f);
    float last[PM_COMPONENT_COUNT][3];
    bool have_last = false;
    uint32_t last_pixel = 0;
    for (size_t i = 0; i < (size_t)width * height; i++) {
        bool same = have_last;
        for (int k = 0; k < PM_COMPONENT_COUNT && same; k++)
            if (layers[k] && d->enabled[k]) same = !memcmp(last[k], layers[k] + 3 * i, sizeof last[k]);
        if (!same) {
            float c[3] = {0.f, 0.f, 0.f};
            for (int k = 0; k < PM_COMPONENT_COUNT; k++)
                if (layers[k] && d->enabled[k]) {
                    memcpy(last[k], layers[k] + 3 * i, sizeof last[k]);
                    for (int ch = 0; ch < 3; ch++) c[ch] += quick_sanitize(layers[k][3 * i + ch]);
                }
            for (int ch = 0; ch < 3; ch++) c[ch] = quick_sanitize(c[ch] * exposure);
            if (d->tonemap == 1) {
                float l = 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2];
                if (l > 0.f)
                    for (int ch = 0; ch < 3; ch++) c[ch] *= 1.f / (1.f + l);
            }
            last_pixel = 0;
            for (int ch = 0; ch < 3; ch++) last_pixel |= (uint32_t)(((unsigned long)quick_srgb(c[ch]) << shifts[ch]) & masks[ch]);
            have_last = true;
        }
        composed[i] = last_pixel;
    }
    double scale = fmin((double)fw / width, (double)fh / height);
    int dw = (int)lround(width * scale), dh = (int)lround(height * scale), dx = (fw - dw) / 2, dy = (fh - dh) / 2;
    const unsigned long bar = PM_VIEW_BAR_GREY;
    uint32_t grey = 0;
    for (int ch = 0; ch < 3; ch++) grey |= (uint32_t)((bar << shifts[ch]) & masks[ch]);
    for (int y = 0; y < fh; y++) {
        uint32_t *row = (uint32_t *)(image->data + (size_t)y * image->bytes_per_line);
        if (y > 0 && y >= dy && y < dy + dh && y - 1 >= dy && (int)((y - dy) / scale) == (int)((y - 1 - dy) / scale)) {
            memcpy(row, row - image->bytes_per_line / 4, sizeof(uint32_t) * (size_t)fw);
            continue;
        }
        for (int x = 0; x < fw; x++) {
            if (y < dy || y >= dy + dh || x < dx || x >= dx + dw) { row[x] = grey; continue; }
            int sx = (int)((x - dx) / scale), sy = (int)((y - dy) / scale);
            row[x] = composed[(size_t)(sy < height ? sy : height - 1) * width + (size_t)(sx < width ? sx : width - 1)];
        }
    }
    free(composed);
    GC gc = XCreateGC(display, window, 0, NULL);
    XPutImage(display, window, gc, image, 0, 0, 0, 0, (unsigned)fw, (unsigned)fh);
    XFreeGC(display, gc);
    XFlush(display);
    XDestroyImage(image);
}

bool pm_view_upload(pm_view *v, const pm_film *film) {
    if (!v || !film) return false;
    size_t floats = 3 * (size_t)film->width * film->height;
    float *buffers[PM_COMPONENT_COUNT] = {NULL, NULL, NULL, NULL};
    bool ok = true;
    for (int c = 0; c < PM_COMPONENT_COUNT && ok; c++) {
        if (!film->sum[c]) continue;
        buffers[c] = pm_malloc(floats * sizeof(float), "the display's copy of the film");
        if (!buffers[c]) { ok = false; break; }
        pm_film_resolve(film, (pm_component)c, buffers[c]);
    }
    if (ok) pm_view_upload_layers(v, film->width, film->height, (const float *const *)buffers);
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) free(buffers[c]);
    return ok;
}

/* The composite into the FBO, the film's size. */
static void draw_composite(pm_view *v, const pm_display *d) {
    v->gl.BindFramebuffer(GL_FRAMEBUFFER, v->fbo);
    v->gl.Viewport(0, 0, v->width, v->height);
    v->gl.UseProgram(v->program);
    for (int c = 0; c < PM_COMPONENT_COUNT; c++) {
        v->gl.ActiveTexture(GL_TEXTURE0 + c);
        v->gl.BindTexture(GL_TEXTURE_2D, v->present[c] ? v->component_tex[c] : v->black);
        v->gl.Uniform1i(v->u_enabled[c], d->enabled[c] ? 1 : 0);
    }
    float ev = isfinite(d->exposure_ev) ? fmaxf(-64.f, fminf(64.f, d->exposure_ev)) : 0.f;
    v->gl.Uniform1f(v->u_scale, v->scale);
    v->gl.Uniform1f(v->u_exposure, exp2f(ev));
    v->gl.Uniform1i(v->u_tonemap, d->tonemap == 1 ? 1 : 0);
    v->gl.Uniform1i(v->u_height, v->height);
    bool error_view = d->error_view && v->reference_tex && v->reference_width == v->width && v->reference_height == v->height;
    v->gl.ActiveTexture(GL_TEXTURE0 + PM_COMPONENT_COUNT);
    v->gl.BindTexture(GL_TEXTURE_2D, error_view ? v->reference_tex : v->black);
    v->gl.Uniform1i(v->u_error_view, error_view ? 1 : 0);
    v->gl.ActiveTexture(GL_TEXTURE0);
    v->gl.BindVertexArray(v->vao);
    v->gl.DrawArrays(GL_TRIANGLES, 0, 3);
    v->gl.BindVertexArray(0);
}

/* The FBO copied into the window's back buffer. */
/* The part of the window's framebuffer that some monitor shows, in GL's framebuffer coordinates
 * (origin at the bottom): clearing and scaling the picture into the rest (most of an 8192 x 8192
 * window on a small screen) took a software OpenGL seconds a frame. The whole framebuffer when
 * GLFW knows no monitor or the window seems to be on none. */
static void shown_part(const pm_view *v, int fw, int fh, int rect[4]) {
    rect[0] = rect[1] = 0;
    rect[2] = fw;
    rect[3] = fh;
    int ww = 0, wh = 0, wx = 0, wy = 0, count = 0;
    glfwGetWindowSize(v->window, &ww, &wh);
    glfwGetWindowPos(v->window, &wx, &wy);
    GLFWmonitor **monitors = glfwGetMonitors(&count);
    if (ww < 1 || wh < 1 || !monitors) return;
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (int m = 0; m < count; m++) {
        const GLFWvidmode *mode = glfwGetVideoMode(monitors[m]);
        int mx = 0, my = 0;
        glfwGetMonitorPos(monitors[m], &mx, &my);
        if (!mode) continue;
        /* the monitor's rectangle in window coordinates, clipped to the window */
        double x0 = fmax(0.0, mx - wx), y0 = fmax(0.0, my - wy);
        double x1 = fmin(ww, mx + mode->width - wx), y1 = fmin(wh, my + mode->height - wy);
        if (x1 <= x0 || y1 <= y0) continue;
        lo[0] = fmin(lo[0], x0), lo[1] = fmin(lo[1], y0), hi[0] = fmax(hi[0], x1), hi[1] = fmax(hi[1], y1);
    }
    if (!(hi[0] > lo[0] && hi[1] > lo[1])) return;
    double sx = (double)fw / ww, sy = (double)fh / wh;
    int x0 = (int)floor(lo[0] * sx), x1 = (int)ceil(hi[0] * sx), y0 = (int)floor(lo[1] * sy), y1 = (int)ceil(hi[1] * sy);
    rect[0] = x0;
    rect[1] = fh - (y1 < fh ? y1 : fh);
    rect[2] = (x1 < fw ? x1 : fw) - x0;
    rect[3] = (y1 < fh ? y1 : fh) - y0;
}

static void copy_to_window(pm_view *v) {
    /* Copy to the window, as large as fits with the film's aspect ratio, bars in dark grey. */
    int fw = 0, fh = 0;
    glfwGetFramebufferSize(v->window, &fw, &fh);
    if (fw < 1 || fh < 1) return; /* minimised */
    if (fw != v->gl_window_width || fh != v->gl_window_height) {
        /* the GL's child window follows GLFW's; GL reads its new size at the next draw */
        XResizeWindow(glfwGetX11Display(), v->gl_window, (unsigned)fw, (unsigned)fh);
        v->gl_window_width = fw;
        v->gl_window_height = fh;
    }
    double s = fmin((double)fw / v->width, (double)fh / v->height);
    int dw = (int)lround(v->width * s), dh = (int)lround(v->height * s);
    int dx = (fw - dw) / 2, dy = (fh - dh) / 2;
    v->gl.BindFramebuffer(GL_READ_FRAMEBUFFER, v->fbo);
    v->gl.BindFramebuffer(GL_DRAW_FRAMEBUFFER, 0);
    v->gl.Viewport(0, 0, fw, fh);
    int shown[4];
    shown_part(v, fw, fh, shown);
    v->gl.Scissor(shown[0], shown[1], shown[2], shown[3]);
    v->gl.Enable(GL_SCISSOR_TEST);
    v->gl.ClearColor(0.1f, 0.1f, 0.1f, 1.f);
    v->gl.Clear(GL_COLOR_BUFFER_BIT);
    v->gl.BlitFramebuffer(0, 0, v->width, v->height, dx, dy, dx + dw, dy + dh, GL_COLOR_BUFFER_BIT,
                          dw == v->width && dh == v->height ? GL_NEAREST : GL_LINEAR);
    v->gl.Disable(GL_SCISSOR_TEST);
    v->gl.BindFramebuffer(GL_FRAMEBUFFER, 0);
}

void pm_view_draw(pm_view *v, const pm_display *d) {
    if (!v || !d || !v->prepared) return;
    make_current(v);
    draw_composite(v, d);
    if (v->backend != PM_BACKEND_WINDOW) return;
    copy_to_window(v);
    glx.SwapBuffers(glfwGetX11Display(), v->gl_window);
}

void pm_view_read_rgba8(pm_view *v, uint8_t *rgba) {
    if (!v || !rgba || !v->prepared) return;
    make_current(v);
    v->gl.BindFramebuffer(GL_FRAMEBUFFER, v->fbo);
    v->gl.PixelStorei(GL_PACK_ALIGNMENT, 1);
    v->gl.ReadPixels(0, 0, v->width, v->height, GL_RGBA, GL_UNSIGNED_BYTE, rgba);
    v->gl.BindFramebuffer(GL_FRAMEBUFFER, 0);
    /* GL's row 0 is the bottom one: the rows swap in place, a stack-sized piece at a time, so the
     * flip needs no allocation and cannot fail */
    size_t row = 4 * (size_t)v->width;
    uint8_t tmp[4096];
    for (int y = 0; y < v->height / 2; y++) {
        uint8_t *a = rgba + row * y, *b = rgba + row * (v->height - 1 - y);
        for (size_t at = 0; at < row; at += sizeof tmp) {
            size_t n = row - at < sizeof tmp ? row - at : sizeof tmp;
            memcpy(tmp, a + at, n);
            memcpy(a + at, b + at, n);
            memcpy(b + at, tmp, n);
        }
    }
}

bool pm_view_is_window(const pm_view *v) {
    return v && v->backend == PM_BACKEND_WINDOW;
}

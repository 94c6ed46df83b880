/* view_state.h: the view's state (struct pm_view, its GL entry points), shared by view.c (GL drawing, the window's making) and view_input.c (the window's input) only. */
#ifndef PM_VIEW_STATE_H
#define PM_VIEW_STATE_H

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <X11/Xlib.h>
#include <X11/Xutil.h>
/* GLFW's X11 access (glfw3native.h, whose X11 part needs the Xrandr headers): the first image is
 * put into the window by X11 itself (pm_view_show_quick) */
Display *glfwGetX11Display(void);
Window glfwGetX11Window(GLFWwindow *window);
#include <GL/osmesa.h> /* also brings GL/gl.h and GL/glext.h: types and enums only */
#include <GL/glx.h>    /* types and enums only: libGL's entry points are fetched with dlsym */

#include "view.h"

/* the bars' grey in 8 bits, drawn by X11 before GL exists: copy_to_window's clear to 0.1 */
#define PM_VIEW_BAR_GREY 26u

/* Every GL function used here: return type, name without the gl prefix, parameters. */
#define PM_GL_FUNCTIONS(X) \
    X(GLenum, GetError, (void)) \
    X(const GLubyte *, GetString, (GLenum name)) \
    X(void, GetIntegerv, (GLenum pname, GLint *data)) \
    X(void, Viewport, (GLint x, GLint y, GLsizei w, GLsizei h)) \
    X(void, ClearColor, (GLfloat r, GLfloat g, GLfloat b, GLfloat a)) \
    X(void, Clear, (GLbitfield mask)) \
    X(void, Disable, (GLenum cap)) \
    X(void, Enable, (GLenum cap)) \
    X(void, Scissor, (GLint x, GLint y, GLsizei w, GLsizei h)) \
    X(void, PixelStorei, (GLenum pname, GLint param)) \
    X(void, ReadPixels, (GLint x, GLint y, GLsizei w, GLsizei h, GLenum format, GLenum type, void *pixels)) \
    X(void, GenTextures, (GLsizei n, GLuint *textures)) \
    X(void, DeleteTextures, (GLsizei n, const GLuint *textures)) \
    X(void, BindTexture, (GLenum target, GLuint texture)) \
    X(void, ActiveTexture, (GLenum texture)) \
    X(void, TexParameteri, (GLenum target, GLenum pname, GLint param)) \
    X(void, TexImage2D, (GLenum target, GLint level, GLint internalformat, GLsizei w, GLsizei h, GLint border, \
                         GLenum format, GLenum type, const void *pixels)) \
    X(void, TexSubImage2D, (GLenum target, GLint level, GLint x, GLint y, GLsizei w, GLsizei h, GLenum format, \
                            GLenum type, const void *pixels)) \
    X(void, GenFramebuffers, (GLsizei n, GLuint *framebuffers)) \
    X(void, DeleteFramebuffers, (GLsizei n, const GLuint *framebuffers)) \
    X(void, BindFramebuffer, (GLenum target, GLuint framebuffer)) \
    X(void, FramebufferTexture2D, (GLenum target, GLenum attachment, GLenum textarget, GLuint texture, GLint level)) \
    X(GLenum, CheckFramebufferStatus, (GLenum target)) \
    X(void, BlitFramebuffer, (GLint sx0, GLint sy0, GLint sx1, GLint sy1, GLint dx0, GLint dy0, GLint dx1, GLint dy1, \
                              GLbitfield mask, GLenum filter)) \
    X(void, GenVertexArrays, (GLsizei n, GLuint *arrays)) \
    X(void, DeleteVertexArrays, (GLsizei n, const GLuint *arrays)) \
    X(void, BindVertexArray, (GLuint array)) \
    X(void, DrawArrays, (GLenum mode, GLint first, GLsizei count)) \
    X(GLuint, CreateShader, (GLenum type)) \
    X(void, ShaderSource, (GLuint shader, GLsizei count, const GLchar *const *strings, const GLint *lengths)) \
    X(void, CompileShader, (GLuint shader)) \
    X(void, GetShaderiv, (GLuint shader, GLenum pname, GLint *params)) \
    X(void, GetShaderInfoLog, (GLuint shader, GLsizei size, GLsizei *length, GLchar *log)) \
    X(void, DeleteShader, (GLuint shader)) \
    X(GLuint, CreateProgram, (void)) \
    X(void, AttachShader, (GLuint program, GLuint shader)) \
    X(void, LinkProgram, (GLuint program)) \
    X(void, GetProgramiv, (GLuint program, GLenum pname, GLint *params)) \
    X(void, GetProgramInfoLog, (GLuint program, GLsizei size, GLsizei *length, GLchar *log)) \
    X(void, DeleteProgram, (GLuint program)) \
    X(void, UseProgram, (GLuint program)) \
    X(GLint, GetUniformLocation, (GLuint program, const GLchar *name)) \
    X(void, Uniform1i, (GLint location, GLint v0)) \
    X(void, Uniform1f, (GLint location, GLfloat v0)) \
    X(void, Finish, (void))

typedef struct {
#define PM_GL_MEMBER(ret, name, params) ret (GLAPIENTRY *name) params;
    PM_GL_FUNCTIONS(PM_GL_MEMBER)
#undef PM_GL_MEMBER
} pm_gl;

typedef void (*pm_gl_proc)(void);
typedef pm_gl_proc (*pm_gl_loader)(const char *name);

enum { PM_BACKEND_WINDOW, PM_BACKEND_OFFSCREEN };

struct pm_view {
    int backend;
    pm_gl gl;
    bool gl_loaded;             /* every entry point in gl is set */
    bool prepared;              /* the shaders, the FBO and the textures exist (a window's come after its first frame) */
    int width, height;          /* the film, the FBO and the component textures */

    GLFWwindow *window;
    GLXContext glx_context;     /* the window's, made by pm_view_prepare */
    Window gl_window;           /* the X11 window it draws into: a child filling GLFW's (see make_window_context) */
    Colormap gl_colormap;
    int gl_window_width, gl_window_height;
    OSMesaContext osmesa;
    void *osmesa_buffer;        /* OSMesa's default framebuffer; never drawn to, but it must exist */

    GLuint program, vao, fbo, target, black;
    GLuint component_tex[PM_COMPONENT_COUNT];
    bool present[PM_COMPONENT_COUNT];
    float scale;
    GLint u_component[PM_COMPONENT_COUNT], u_enabled[PM_COMPONENT_COUNT], u_scale, u_exposure, u_tonemap, u_height;
    GLuint reference_tex;       /* --reference's total, for the relative-error view; 0 = none */
    int reference_width, reference_height;
    GLint u_reference, u_error_view;

    /* window input between callbacks; display is the caller's state, only set while polling */
    pm_view_events pending;
    pm_display *display;
    bool title_set;
    char title[128];
    char status[512];
    double last_x, last_y;      /* cursor, window pixels */
    int buttons;                /* bit 0 left, 1 right, 2 middle held */
    double last_click;          /* time of the last left press, for double clicks */
    int asked_width, asked_height; /* the window size pm_view_set_size asked for: its size event is no user's resize */
};

/* The window's GLFW callbacks set (view_input.c). */
void pm_view_listen(pm_view *v);

#endif

/* SPDX-License-Identifier: MIT */
/* render_gl: how to stream your own GPU renderer to an hmdwarp board: EGL surfaceless + OpenGL ES 3 render a
 * textured, depth-tested scene at each pose the board predicts, read colour and depth back, submit both. */

/* The example links only libhmdwarp-host, EGL, GLESv2 and libm. Build it outside this tree with
 *   cc -std=gnu11 render_gl.c $(pkg-config --cflags --libs hmdwarp-host egl glesv2) -lm
 *
 * Depth: GLES 3 cannot glReadPixels a depth buffer, so the fragment shader writes the view-space distance along
 * -Z (metres, what the board calls linear depth) to a second, R32F colour attachment in the same pass: no second
 * pass, no window-depth round trip, exact float depth; the depth renderbuffer is only for the depth test. Rendering
 * into R32F needs EXT_color_buffer_float (every GLES 3 desktop driver and Mesa's llvmpipe have it). */
#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GLES3/gl3.h>
#include <math.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <hmdwarp-host.h>

/* ---- EGL: a GLES 3 context with no window ---- */

typedef struct {
    EGLDisplay dpy;
    EGLContext ctx;
} gl_context;

static bool has_word(const char *list, const char *word)
{
    size_t n = strlen(word);
    for (const char *p = list; p && (p = strstr(p, word)) != NULL; p += n)
        if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == 0)) return true;
    return false;
}

/* Mesa's surfaceless platform renders without any display server (a GPU or llvmpipe); other drivers offer
 * EGL_EXT_platform_device (the first device). No config, no surface: everything goes into our own FBOs. */
static bool gl_open(gl_context *g)
{
    const char *client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    PFNEGLGETPLATFORMDISPLAYEXTPROC get_display =
        (PFNEGLGETPLATFORMDISPLAYEXTPROC)eglGetProcAddress("eglGetPlatformDisplayEXT");
    g->dpy = EGL_NO_DISPLAY;
    if (get_display && has_word(client, "EGL_MESA_platform_surfaceless"))
        g->dpy = get_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, NULL);
    if (g->dpy == EGL_NO_DISPLAY && get_display && has_word(client, "EGL_EXT_platform_device")) {
        PFNEGLQUERYDEVICESEXTPROC query = (PFNEGLQUERYDEVICESEXTPROC)eglGetProcAddress("eglQueryDevicesEXT");
        EGLDeviceEXT dev;
        EGLint n = 0;
        if (query && query(1, &dev, &n) && n > 0) g->dpy = get_display(EGL_PLATFORM_DEVICE_EXT, dev, NULL);
    }
    if (g->dpy == EGL_NO_DISPLAY || !eglInitialize(g->dpy, NULL, NULL)) {
        fprintf(stderr, "render_gl: no EGL display (neither EGL_MESA_platform_surfaceless nor a device)\n");
        return false;
    }
    if (!has_word(eglQueryString(g->dpy, EGL_EXTENSIONS), "EGL_KHR_surfaceless_context") ||
        !eglBindAPI(EGL_OPENGL_ES_API)) {
        fprintf(stderr, "render_gl: EGL has no surfaceless OpenGL ES contexts\n");
        return false;
    }
    const EGLint want[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_ES3_BIT, EGL_NONE};
    EGLConfig cfg = EGL_NO_CONFIG_KHR;
    EGLint n = 0;
    if (!eglChooseConfig(g->dpy, want, &cfg, 1, &n) || n < 1) cfg = EGL_NO_CONFIG_KHR;
    const EGLint attrs[] = {EGL_CONTEXT_CLIENT_VERSION, 3, EGL_NONE};
    g->ctx = eglCreateContext(g->dpy, cfg, EGL_NO_CONTEXT, attrs);
    if (g->ctx == EGL_NO_CONTEXT || !eglMakeCurrent(g->dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, g->ctx)) {
        fprintf(stderr, "render_gl: no OpenGL ES 3 context (EGL error 0x%x)\n", (unsigned)eglGetError());
        return false;
    }
    const char *ext = (const char *)glGetString(GL_EXTENSIONS);
    if (!has_word(ext, "GL_EXT_color_buffer_float")) {
        fprintf(stderr, "render_gl: %s cannot render to float textures (no GL_EXT_color_buffer_float)\n",
                (const char *)glGetString(GL_RENDERER));
        return false;
    }
    return true;
}

static void gl_close(gl_context *g)
{
    if (g->dpy == EGL_NO_DISPLAY) return;
    eglMakeCurrent(g->dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    if (g->ctx != EGL_NO_CONTEXT) eglDestroyContext(g->dpy, g->ctx);
    eglTerminate(g->dpy);
}

/* ---- the scene: a floor and boxes, one procedural texture, one draw call ---- */

typedef struct {
    float pos[3], uv[2], tint[3];
} vertex;

/* Boxes at 1.5 to 6 m (centre x, y, z, half sizes, tint): near and far ones so a depth-aware warp has parallax to
 * correct, and a tall one crossing the eye height so a head turn sweeps an edge across the view. */
static const float BOXES[][9] = {
    {-0.6f, 0.25f, -1.5f, 0.25f, 0.25f, 0.25f, 1.0f, 0.55f, 0.45f},
    {0.7f, 0.4f, -2.5f, 0.4f, 0.4f, 0.4f, 0.5f, 0.8f, 1.0f},
    {-1.5f, 1.0f, -4.0f, 0.5f, 1.0f, 0.5f, 0.6f, 1.0f, 0.55f},
    {1.8f, 0.6f, -6.0f, 0.6f, 0.6f, 0.6f, 1.0f, 0.9f, 0.4f},
    {0.0f, 1.6f, -5.0f, 0.3f, 0.3f, 0.3f, 0.9f, 0.5f, 1.0f},
};
#define N_BOXES (sizeof BOXES / sizeof BOXES[0])
#define FLOOR_HALF 20.0f /* metres: reaches the horizon at the FOVs of HMDs */
#define N_VERTS (4 + 24 * N_BOXES)
#define N_INDEX (6 + 36 * N_BOXES)

static void quad(vertex *v, uint16_t *ix, int base, const float c[4][3], float us, float vs, const float tint[3])
{
    static const float uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (int i = 0; i < 4; i++) {
        memcpy(v[base + i].pos, c[i], sizeof c[i]);
        v[base + i].uv[0] = uv[i][0] * us;
        v[base + i].uv[1] = uv[i][1] * vs;
        memcpy(v[base + i].tint, tint, 3 * sizeof(float));
    }
    const uint16_t t[6] = {0, 1, 2, 0, 2, 3};
    for (int i = 0; i < 6; i++) ix[i] = (uint16_t)(base + t[i]);
}

static void build_scene(vertex *v, uint16_t *ix)
{
    const float F = FLOOR_HALF, white[3] = {1, 1, 1};
    const float floor[4][3] = {{-F, 0, F}, {F, 0, F}, {F, 0, -F}, {-F, 0, -F}};
    quad(v, ix, 0, floor, 2 * F, 2 * F, white); /* one texture repeat per metre */
    for (size_t b = 0; b < N_BOXES; b++) {
        const float *B = BOXES[b];
        /* The 6 faces as (axis, sign): corners from the centre and half sizes. */
        for (int f = 0; f < 6; f++) {
            int ax = f / 2, u = (ax + 1) % 3, w = (ax + 2) % 3;
            float s = f % 2 ? 1.0f : -1.0f, c[4][3];
            static const float corner[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
            for (int k = 0; k < 4; k++) {
                c[k][ax] = B[ax] + s * B[3 + ax];
                c[k][u] = B[u] + corner[k][0] * B[3 + u];
                c[k][w] = B[w] + corner[k][1] * B[3 + w];
            }
            quad(v, ix + 6 + 36 * b + 6 * f, (int)(4 + 24 * b + 4 * f), c, 2 * B[3 + u], 2 * B[3 + w], B + 6);
        }
    }
}

/* 256x256 texels: 4x4 checker cells (25 cm on the floor), a thin grid and a colour ramp: a warp error shows as a
 * bent or doubled line. */
#define TEX_SIZE 256
static void make_texture(uint8_t *t)
{
    for (int y = 0; y < TEX_SIZE; y++)
        for (int x = 0; x < TEX_SIZE; x++) {
            bool dark = ((x / 64) ^ (y / 64)) & 1, line = x % 64 < 3 || y % 64 < 3;
            uint8_t *p = t + 4 * (y * TEX_SIZE + x);
            int base = line ? 30 : dark ? 110 : 220;
            p[0] = (uint8_t)(base * (192 + x / 4) / 255);
            p[1] = (uint8_t)base;
            p[2] = (uint8_t)(base * (192 + y / 4) / 255);
            p[3] = 255;
        }
}

static const char *VS = "#version 300 es\n"
                        "uniform mat4 view, proj;\n"
                        "layout(location = 0) in vec3 pos;\n"
                        "layout(location = 1) in vec2 uv;\n"
                        "layout(location = 2) in vec3 tint;\n"
                        "out vec2 v_uv; out vec3 v_tint; out float v_z;\n"
                        "void main() {\n"
                        "    vec4 e = view * vec4(pos, 1.0);\n"
                        "    v_uv = uv; v_tint = tint; v_z = -e.z;\n"
                        "    gl_Position = proj * e;\n"
                        "}\n";
/* v_z is interpolated perspective-correctly, so it is the exact planar distance of the fragment. */
static const char *FS = "#version 300 es\n"
                        "precision highp float;\n"
                        "uniform sampler2D tex;\n"
                        "in vec2 v_uv; in vec3 v_tint; in float v_z;\n"
                        "layout(location = 0) out vec4 color;\n"
                        "layout(location = 1) out float depth;\n"
                        "void main() {\n"
                        "    color = vec4(texture(tex, v_uv).rgb * v_tint, 1.0);\n"
                        "    depth = v_z;\n"
                        "}\n";

typedef struct {
    int w, h;
    GLuint fbo, color, depth_lin, depth_test;
} eye_target;

typedef struct {
    GLuint prog, vao, vbo, ibo, tex;
    GLint u_view, u_proj;
    eye_target eye[2];
} renderer;

static GLuint compile(GLenum type, const char *src)
{
    GLuint s = glCreateShader(type);
    glShaderSource(s, 1, &src, NULL);
    glCompileShader(s);
    GLint ok = 0;
    glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        char log[512] = "";
        glGetShaderInfoLog(s, sizeof log, NULL, log);
        fprintf(stderr, "render_gl: shader: %s\n", log);
        glDeleteShader(s);
        return 0;
    }
    return s;
}

static bool renderer_init(renderer *r)
{
    memset(r, 0, sizeof *r);
    GLuint vs = compile(GL_VERTEX_SHADER, VS), fs = compile(GL_FRAGMENT_SHADER, FS);
    if (!vs || !fs) return false;
    r->prog = glCreateProgram();
    glAttachShader(r->prog, vs);
    glAttachShader(r->prog, fs);
    glLinkProgram(r->prog);
    glDeleteShader(vs);
    glDeleteShader(fs);
    GLint ok = 0;
    glGetProgramiv(r->prog, GL_LINK_STATUS, &ok);
    if (!ok) {
        fprintf(stderr, "render_gl: the shaders do not link\n");
        return false;
    }
    r->u_view = glGetUniformLocation(r->prog, "view");
    r->u_proj = glGetUniformLocation(r->prog, "proj");

    static vertex v[N_VERTS];
    static uint16_t ix[N_INDEX];
    build_scene(v, ix);
    glGenVertexArrays(1, &r->vao);
    glBindVertexArray(r->vao);
    glGenBuffers(1, &r->vbo);
    glBindBuffer(GL_ARRAY_BUFFER, r->vbo);
    glBufferData(GL_ARRAY_BUFFER, sizeof v, v, GL_STATIC_DRAW);
    glGenBuffers(1, &r->ibo);
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, r->ibo);
    glBufferData(GL_ELEMENT_ARRAY_BUFFER, sizeof ix, ix, GL_STATIC_DRAW);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(vertex), (void *)offsetof(vertex, pos));
    glVertexAttribPointer(1, 2, GL_FLOAT, GL_FALSE, sizeof(vertex), (void *)offsetof(vertex, uv));
    glVertexAttribPointer(2, 3, GL_FLOAT, GL_FALSE, sizeof(vertex), (void *)offsetof(vertex, tint));
    for (GLuint a = 0; a < 3; a++) glEnableVertexAttribArray(a);

    static uint8_t texels[TEX_SIZE * TEX_SIZE * 4];
    make_texture(texels);
    glGenTextures(1, &r->tex);
    glBindTexture(GL_TEXTURE_2D, r->tex);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, TEX_SIZE, TEX_SIZE, 0, GL_RGBA, GL_UNSIGNED_BYTE, texels);
    glGenerateMipmap(GL_TEXTURE_2D); /* trilinear: the floor recedes to the horizon without shimmering */
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_REPEAT);
    return glGetError() == GL_NO_ERROR;
}

static void eye_target_free(eye_target *t)
{
    glDeleteFramebuffers(1, &t->fbo);
    glDeleteTextures(1, &t->color);
    glDeleteTextures(1, &t->depth_lin);
    glDeleteRenderbuffers(1, &t->depth_test);
    memset(t, 0, sizeof *t);
}

/* (Re)creates the eye's FBO when the board asks for another size. */
static bool eye_target_size(eye_target *t, int w, int h)
{
    if (t->fbo && t->w == w && t->h == h) return true;
    eye_target_free(t);
    t->w = w;
    t->h = h;
    glGenTextures(1, &t->color);
    glBindTexture(GL_TEXTURE_2D, t->color);
    glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA8, w, h);
    glGenTextures(1, &t->depth_lin);
    glBindTexture(GL_TEXTURE_2D, t->depth_lin);
    glTexStorage2D(GL_TEXTURE_2D, 1, GL_R32F, w, h);
    glGenRenderbuffers(1, &t->depth_test);
    glBindRenderbuffer(GL_RENDERBUFFER, t->depth_test);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, w, h);
    glGenFramebuffers(1, &t->fbo);
    glBindFramebuffer(GL_FRAMEBUFFER, t->fbo);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, t->color, 0);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT1, GL_TEXTURE_2D, t->depth_lin, 0);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, t->depth_test);
    const GLenum bufs[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    glDrawBuffers(2, bufs);
    if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
        fprintf(stderr, "render_gl: a %dx%d RGBA8 + R32F framebuffer is not complete\n", w, h);
        return false;
    }
    return true;
}

static void renderer_free(renderer *r)
{
    for (int e = 0; e < 2; e++) eye_target_free(&r->eye[e]);
    glDeleteTextures(1, &r->tex);
    glDeleteBuffers(1, &r->vbo);
    glDeleteBuffers(1, &r->ibo);
    glDeleteVertexArrays(1, &r->vao);
    glDeleteProgram(r->prog);
}

/* Column-major view matrix: the inverse of world_from_eye (R^T, -R^T p). */
static void view_matrix(const hmdwarp_host_pose *pose, float m[16])
{
    double w = pose->orientation[0], x = pose->orientation[1], y = pose->orientation[2], z = pose->orientation[3];
    const double *p = pose->position;
    double R[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
                      {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
                      {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}};
    memset(m, 0, 16 * sizeof *m);
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) m[j * 4 + i] = (float)R[j][i];
        m[12 + i] = (float)-(R[0][i] * p[0] + R[1][i] * p[1] + R[2][i] * p[2]);
    }
    m[15] = 1;
}

/* Column-major projection of the asymmetric frustum given by the FOV tangents, with y negated: GL's row 0 is the
 * bottom, the board's images start at the top, so the readback comes out in the board's row order with no copy. */
static void proj_matrix(const hmdwarp_host_camera *e, float m[16])
{
    double sx = e->tan_left + e->tan_right, sy = e->tan_up + e->tan_down, n = e->near_z, f = e->far_z;
    memset(m, 0, 16 * sizeof *m);
    m[0] = (float)(2 / sx);
    m[8] = (float)((e->tan_right - e->tan_left) / sx);
    m[5] = (float)-(2 / sy);
    m[9] = (float)-((e->tan_up - e->tan_down) / sy);
    bool inf = !isfinite(f);
    m[10] = inf ? -1.0f : (float)(-(f + n) / (f - n));
    m[14] = inf ? (float)(-2 * n) : (float)(-2 * f * n / (f - n));
    m[11] = -1;
}

/* Renders one eye and reads back colour (RGBA8, w*h*4 bytes) and linear depth (float metres, +inf = sky). */
static bool render_eye(renderer *r, int eye, const hmdwarp_host_pose *pose, const hmdwarp_host_camera *cam,
                       uint8_t *rgba, float *depth)
{
    eye_target *t = &r->eye[eye];
    if (!eye_target_size(t, (int)cam->width, (int)cam->height)) return false;
    float view[16], proj[16];
    view_matrix(pose, view);
    proj_matrix(cam, proj);
    glBindFramebuffer(GL_FRAMEBUFFER, t->fbo);
    glViewport(0, 0, t->w, t->h);
    const float sky[4] = {0.45f, 0.62f, 0.85f, 1.0f}, far[4] = {INFINITY, 0, 0, 0};
    glClearBufferfv(GL_COLOR, 0, sky);
    glClearBufferfv(GL_COLOR, 1, far); /* sky: no surface, linear depth +inf */
    glClearBufferfi(GL_DEPTH_STENCIL, 0, 1.0f, 0);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glUseProgram(r->prog);
    glUniformMatrix4fv(r->u_view, 1, GL_FALSE, view);
    glUniformMatrix4fv(r->u_proj, 1, GL_FALSE, proj);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, r->tex);
    glBindVertexArray(r->vao);
    glDrawElements(GL_TRIANGLES, (GLsizei)N_INDEX, GL_UNSIGNED_SHORT, NULL);

    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    glReadBuffer(GL_COLOR_ATTACHMENT0);
    glReadPixels(0, 0, t->w, t->h, GL_RGBA, GL_UNSIGNED_BYTE, rgba);
    glReadBuffer(GL_COLOR_ATTACHMENT1);
    /* GL_RED/GL_FLOAT is the implementation's read format for R32F on Mesa and most drivers; GLES 3 guarantees
     * only GL_RGBA/GL_FLOAT, so fall back to that (four times the bytes) where it is not. */
    GLint fmt = 0, type = 0;
    glGetIntegerv(GL_IMPLEMENTATION_COLOR_READ_FORMAT, &fmt);
    glGetIntegerv(GL_IMPLEMENTATION_COLOR_READ_TYPE, &type);
    if (fmt == GL_RED && type == GL_FLOAT) {
        glReadPixels(0, 0, t->w, t->h, GL_RED, GL_FLOAT, depth);
    } else {
        float *tmp = malloc((size_t)t->w * (size_t)t->h * 4 * sizeof *tmp);
        if (!tmp) return false;
        glReadPixels(0, 0, t->w, t->h, GL_RGBA, GL_FLOAT, tmp);
        for (size_t i = 0; i < (size_t)t->w * (size_t)t->h; i++) depth[i] = tmp[4 * i];
        free(tmp);
    }
    GLenum e = glGetError();
    if (e != GL_NO_ERROR) fprintf(stderr, "render_gl: GL error 0x%x rendering eye %d\n", e, eye);
    return e == GL_NO_ERROR;
}


/* ---- the loop: pose in, render, frame out ---- */

/* A board that sends no pose this long is not coming back (the library reconnects to one that does). */
#define NO_POSE_GIVE_UP_NS (30 * (int64_t)1000000000)

typedef struct {
    const char *uri;
    long frames;      /* 0: until interrupted */
    bool synth;       /* poses made up here (a slow head turn) instead of the board's */
    int width, height;
    double hfov_deg;
    const char *save; /* PREFIX: the last frame's colour as PREFIX-0.ppm and PREFIX-1.ppm */
} options;

static void usage(FILE *f)
{
    fprintf(f, "Usage: render_gl [OPTION]... [CONNECTION]\n"
               "Renders a textured, depth-tested scene with EGL + OpenGL ES 3 at each eye pose the board predicts,\n"
               "reads back colour and linear depth and submits them through libhmdwarp-host.\n\n"
               "CONNECTION: socket:PATH (hmdwarpd's [frames] backend = socket; default\n"
               "socket:/run/hmdwarp/frames.sock), usb (the board's USB gadget), file:PATH (the frame stream into a\n"
               "file; implies --synth).\n\n"
               "  -n, --frames N    stop after N frames (default: until interrupted)\n"
               "      --synth       synthesise the poses (a slow head turn at 90 Hz) instead of the board's\n"
               "      --eye WxH     eye size when the board sends no cameras (--synth, file:; default 640x480)\n"
               "      --fov DEG     horizontal field of view then (default 90; vertical from the aspect)\n"
               "      --save PREFIX write the last frame's colour to PREFIX-0.ppm and PREFIX-1.ppm\n"
               "  -h, --help        this text\n");
}

static bool parse(int argc, char **argv, options *o)
{
    *o = (options){.uri = "socket:/run/hmdwarp/frames.sock", .width = 640, .height = 480, .hfov_deg = 90};
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            usage(stdout);
            exit(0);
        } else if (!strcmp(a, "--synth")) {
            o->synth = true;
        } else if ((!strcmp(a, "-n") || !strcmp(a, "--frames")) && v) {
            o->frames = atol(v), i++;
            if (o->frames < 0) return fprintf(stderr, "render_gl: --frames %s: not a count\n", v), false;
        } else if (!strcmp(a, "--eye") && v) {
            if (sscanf(v, "%dx%d", &o->width, &o->height) != 2 || o->width < 1 || o->height < 1 ||
                o->width > 16384 || o->height > 16384)
                return fprintf(stderr, "render_gl: --eye %s: want WxH, 1 to 16384 each\n", v), false;
            i++;
        } else if (!strcmp(a, "--fov") && v) {
            o->hfov_deg = atof(v), i++;
            if (!(o->hfov_deg > 1 && o->hfov_deg < 179))
                return fprintf(stderr, "render_gl: --fov %s: want degrees in (1, 179)\n", v), false;
        } else if (!strcmp(a, "--save") && v) {
            o->save = v, i++;
        } else if (a[0] != '-' || !strcmp(a, "-")) {
            o->uri = a;
        } else {
            return fprintf(stderr, "render_gl: unknown option or missing value: %s (--help lists them)\n", a), false;
        }
    }
    if (!strncmp(o->uri, "file:", 5)) o->synth = true; /* a file sends no poses back */
    return true;
}

/* A slow head turn (yaw +-30 deg, a little pitch) at the default eye height, eyes 64 mm apart: what --synth
 * renders for when there is no board to predict poses. */
static void synth_pose(long i, hmdwarp_host_pose eye[2])
{
    double t = (double)i / 90.0, yaw = 0.5 * sin(0.5 * t), pitch = 0.1 * sin(0.3 * t);
    double cy = cos(yaw / 2), sy = sin(yaw / 2), cp = cos(pitch / 2), sp = sin(pitch / 2);
    double q[4] = {cy * cp, cy * sp, sy * cp, -sy * sp}; /* yaw about +Y, then pitch about the turned +X */
    for (int e = 0; e < 2; e++) {
        double off = e ? 0.032 : -0.032; /* along the head's +X: q rotates (off, 0, 0) */
        double w = q[0], x = q[1], y = q[2], z = q[3];
        memcpy(eye[e].orientation, q, sizeof q);
        eye[e].position[0] = off * (1 - 2 * (y * y + z * z));
        eye[e].position[1] = 1.6 + off * 2 * (x * y + w * z);
        eye[e].position[2] = off * 2 * (x * z - w * y);
    }
}

static void default_cameras(const options *o, hmdwarp_host_cameras *c)
{
    memset(c, 0, sizeof *c);
    c->planes = HMDWARP_HOST_PLANE_COLOR | HMDWARP_HOST_PLANE_DEPTH; /* what this example sends */
    c->depth_encoding = HMDWARP_HOST_ENCODING_LINEAR;
    c->refresh_hz = c->pose_rate_hz = 90;
    double th = tan(o->hfov_deg * M_PI / 360), tv = th * o->height / o->width;
    for (int e = 0; e < 2; e++)
        c->cam[e] = (hmdwarp_host_camera){(uint32_t)o->width, (uint32_t)o->height, th, th, tv, tv, 0.05, INFINITY};
}

/* Whether the board's eye sizes now differ from those rendered with (a frame refused for its size is then the
 * only one lost; otherwise the refusal would repeat for ever). */
static bool cameras_changed(hmdwarp_host *h, const hmdwarp_host_cameras *rendered)
{
    hmdwarp_host_cameras now;
    if (hmdwarp_host_get_cameras(h, &now) != 1) return false;
    for (int e = 0; e < 2; e++)
        if (now.cam[e].width != rendered->cam[e].width || now.cam[e].height != rendered->cam[e].height) return true;
    return false;
}

static bool save_ppm(const char *prefix, int eye, const uint8_t *rgba, int w, int h)
{
    char path[4096];
    snprintf(path, sizeof path, "%s-%d.ppm", prefix, eye);
    FILE *f = fopen(path, "wb");
    if (!f) return fprintf(stderr, "render_gl: %s: cannot write\n", path), false;
    fprintf(f, "P6\n%d %d\n255\n", w, h);
    for (size_t i = 0; i < (size_t)w * (size_t)h; i++) fwrite(rgba + 4 * i, 1, 3, f);
    return fclose(f) == 0;
}

int main(int argc, char **argv)
{
    options o;
    if (!parse(argc, argv, &o)) return 2;
    gl_context g = {EGL_NO_DISPLAY, EGL_NO_CONTEXT};
    renderer r;
    memset(&r, 0, sizeof r);
    int rc = 1;
    uint8_t *rgba[2] = {NULL, NULL};
    float *depth[2] = {NULL, NULL};
    size_t alloc_px[2] = {0, 0};
    hmdwarp_host *h = NULL;
    if (!gl_open(&g) || !renderer_init(&r)) goto out;
    fprintf(stderr, "render_gl: rendering with %s\n", (const char *)glGetString(GL_RENDERER));

    h = hmdwarp_host_open(o.uri);
    if (!h) {
        fprintf(stderr, "render_gl: %s\n", hmdwarp_host_last_error());
        goto out;
    }
    hmdwarp_host_cameras cams;
    if (o.synth) {
        default_cameras(&o, &cams);
        if (hmdwarp_host_set_cameras(h, &cams) < 0) {
            fprintf(stderr, "render_gl: %s\n", hmdwarp_host_last_error());
            goto out;
        }
    } else if (hmdwarp_host_wait_cameras(h, 5000, &cams) != 1) {
        fprintf(stderr, "render_gl: no camera message from %s in 5 s%s%s\n", o.uri,
                *hmdwarp_host_last_error() ? ": " : "", hmdwarp_host_last_error());
        goto out;
    }

    long done = 0;
    int64_t last_pose_ns = hmdwarp_host_now_ns();
    while (o.frames == 0 || done < o.frames) {
        hmdwarp_host_frame fr = {.color_format = HMDWARP_HOST_COLOR_RGBA8,
                                 .depth_format = HMDWARP_HOST_DEPTH_LINEAR_F32};
        hmdwarp_host_pose eye_pose[2];
        if (o.synth) {
            synth_pose(done, eye_pose);
            usleep(11111); /* 90 Hz, as a board would ask */
        } else {
            /* The newest prediction: rendered at its eye poses, its times echoed in the frame. */
            hmdwarp_host_pose_msg pm;
            int w = hmdwarp_host_wait_pose(h, 1000, &pm);
            if (w < 0 && w != HMDWARP_HOST_ERR_NOT_CONNECTED) {
                fprintf(stderr, "render_gl: %s\n", hmdwarp_host_last_error());
                goto out;
            }
            if (w != 1) { /* the board is slow to start, or gone for a while: its reconnect is the library's */
                if (w < 0) usleep(100000);
                int64_t quiet = hmdwarp_host_now_ns() - last_pose_ns;
                if (quiet > NO_POSE_GIVE_UP_NS) {
                    fprintf(stderr, "render_gl: no pose from the board for %.0f s: giving up\n", quiet / 1e9);
                    goto out;
                }
                continue;
            }
            last_pose_ns = hmdwarp_host_now_ns();
            /* The pose rendered for, given whole: pose_seq = pm.seq would do as long as the message is among the
             * library's last 1024 (2 s at a board's 500 Hz), which a slow renderer outlasts. */
            fr.pose_target_ns = pm.target_time_ns;
            fr.pose_board_ns = pm.board_time_ns;
            fr.pose_received_ns = pm.received_ns;
            memcpy(eye_pose, pm.eye, sizeof eye_pose);
            hmdwarp_host_get_cameras(h, &cams); /* a camera message may have changed the size */
        }
        fr.render_start_ns = hmdwarp_host_now_ns();
        for (int e = 0; e < 2; e++) {
            size_t px = (size_t)cams.cam[e].width * cams.cam[e].height;
            if (px > alloc_px[e]) {
                free(rgba[e]);
                free(depth[e]);
                rgba[e] = malloc(px * 4);
                depth[e] = malloc(px * sizeof(float));
                alloc_px[e] = px;
                if (!rgba[e] || !depth[e]) {
                    fprintf(stderr, "render_gl: out of memory for a %ux%u eye\n", cams.cam[e].width,
                            cams.cam[e].height);
                    goto out;
                }
            }
            if (!render_eye(&r, e, &eye_pose[e], &cams.cam[e], rgba[e], depth[e])) goto out;
            fr.eye[e].color = rgba[e];
            fr.eye[e].depth = depth[e];
            fr.eye[e].camera = cams.cam[e]; /* the camera rendered with: the library checks it is the board's */
            fr.eye[e].pose = eye_pose[e];
        }
        fr.render_end_ns = hmdwarp_host_now_ns();
        int s = hmdwarp_host_submit(h, &fr);
        if (s == HMDWARP_HOST_ERR_DISCONNECTED || s == HMDWARP_HOST_ERR_NOT_CONNECTED ||
            (s == HMDWARP_HOST_ERR_SIZE && cameras_changed(h, &cams))) {
            /* Gone (the library reconnects), or the board changed its cameras since the render: the next pose. */
            fprintf(stderr, "render_gl: frame dropped: %s\n", hmdwarp_host_last_error());
            continue;
        }
        if (s < 0) {
            fprintf(stderr, "render_gl: %s\n", hmdwarp_host_last_error());
            goto out;
        }
        done++;
        if (o.save && (o.frames == 0 || done == o.frames))
            for (int e = 0; e < 2; e++)
                if (!save_ppm(o.save, e, rgba[e], (int)cams.cam[e].width, (int)cams.cam[e].height)) goto out;
    }
    hmdwarp_host_stats st;
    if (hmdwarp_host_get_stats(h, &st) == 0)
        printf("render_gl: %llu frames sent, %.1f MB, %llu poses received, %llu refused, %llu send errors\n",
               (unsigned long long)st.frames_sent, (double)st.bytes_sent / 1e6, (unsigned long long)st.poses_received,
               (unsigned long long)st.frames_refused, (unsigned long long)st.send_errors);
    rc = 0;
out:
    hmdwarp_host_close(h);
    if (r.prog) renderer_free(&r);
    gl_close(&g);
    for (int e = 0; e < 2; e++) {
        free(rgba[e]);
        free(depth[e]);
    }
    return rc;
}

/* SPDX-License-Identifier: MIT */
/* plat_egl: EGL display and OpenGL ES 3 context for the GPU renderer: surfaceless (rendering into FBOs, tests
 * and the simulated board) or a real panel through DRM/KMS + GBM with page flips on its connector. */
#include "platform/plat_egl.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GLES3/gl3.h>
#include <errno.h>
#include <dlfcn.h>
#include <fcntl.h>
#include <gbm.h>
#include <link.h>
#include <poll.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <xf86drm.h>
#include <xf86drmMode.h>

#include "platform/plat_clock.h"
#include "warp/warp_err.h"

/* How long a present waits for the previous flip's event, and after how long a flip that never completed is taken
 * as lost (see plat_egl_present). */
#define PRESENT_WAIT_MS 100
#define FLIP_LOST_MS 1000

struct plat_egl {
    EGLDisplay dpy;
    EGLContext ctx;
    EGLSurface surf; /* pbuffer (offscreen without surfaceless contexts), window (KMS), or EGL_NO_SURFACE */
    char renderer[160], version[96];
    char *extensions;
    /* KMS */
    bool kms;
    plat_kms *k; /* device, CRTC, flips and their events */
    int fd;
    struct gbm_device *gbm;
    struct gbm_surface *gs;
    struct gbm_bo *shown_bo, *pending_bo;
    int64_t pending_since_ns; /* when pending_bo's flip was committed */
};

#if defined(__GNUC__)
__attribute__((format(printf, 3, 4)))
#endif
static void *fail(char *err, int errlen, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    warp_verr(err, errlen, fmt, ap);
    va_end(ap);
    return NULL;
}

static bool has_word(const char *list, const char *word)
{
    if (!list || !word || !*word) return false;
    size_t n = strlen(word);
    for (const char *p = list; (p = strstr(p, word)) != NULL; p += n)
        if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == 0)) return true;
    return false;
}

static const char *egl_err_str(EGLint e)
{
    switch (e) {
    case EGL_SUCCESS: return "EGL_SUCCESS";
    case EGL_NOT_INITIALIZED: return "EGL_NOT_INITIALIZED";
    case EGL_BAD_ACCESS: return "EGL_BAD_ACCESS";
    case EGL_BAD_ALLOC: return "EGL_BAD_ALLOC";
    case EGL_BAD_ATTRIBUTE: return "EGL_BAD_ATTRIBUTE";
    case EGL_BAD_CONFIG: return "EGL_BAD_CONFIG";
    case EGL_BAD_CONTEXT: return "EGL_BAD_CONTEXT";
    case EGL_BAD_DISPLAY: return "EGL_BAD_DISPLAY";
    case EGL_BAD_MATCH: return "EGL_BAD_MATCH";
    case EGL_BAD_NATIVE_WINDOW: return "EGL_BAD_NATIVE_WINDOW";
    case EGL_BAD_PARAMETER: return "EGL_BAD_PARAMETER";
    case EGL_BAD_SURFACE: return "EGL_BAD_SURFACE";
    default: return "EGL error";
    }
}

bool plat_egl_renderer_is_software(const char *r)
{
    if (!r) return true;
    static const char *const sw[] = {"llvmpipe", "softpipe", "swrast", "lavapipe", "SwiftShader", "Software Rasterizer"};
    for (size_t i = 0; i < sizeof sw / sizeof sw[0]; i++)
        if (strcasestr(r, sw[i])) return true;
    return false;
}

/* Mesa's DRI drivers keep state in globals they never free, and LLVM (llvmpipe) does not survive being unloaded
 * and loaded again cleanly; eglTerminate unloads them, and LeakSanitizer then reports that state as leaked from
 * an unknown module. Once loaded, a driver stays: every later context reuses it. */
static int pin_one(struct dl_phdr_info *info, size_t size, void *data)
{
    (void)size;
    (void)data;
    if (info->dlpi_name && strstr(info->dlpi_name, "/dri/") && strstr(info->dlpi_name, "_dri.so"))
        dlopen(info->dlpi_name, RTLD_NOW | RTLD_NOLOAD | RTLD_NODELETE);
    return 0;
}

/* Creates a GLES 3 context on e->dpy (initialised) with config cfg (may be EGL_NO_CONFIG_KHR), makes it current
 * on e->surf and reads the renderer strings. */
static bool make_context(plat_egl *e, EGLConfig cfg, const char *what, char *err, int errlen)
{
    if (!eglBindAPI(EGL_OPENGL_ES_API)) {
        fail(err, errlen, "%s: EGL cannot bind OpenGL ES (%s)", what, egl_err_str(eglGetError()));
        return false;
    }
    const EGLint attrs[] = {EGL_CONTEXT_CLIENT_VERSION, 3, EGL_NONE};
    e->ctx = eglCreateContext(e->dpy, cfg, EGL_NO_CONTEXT, attrs);
    if (e->ctx == EGL_NO_CONTEXT) {
        fail(err, errlen, "%s: no OpenGL ES 3 context (%s): the driver offers only GLES 2 or none", what,
             egl_err_str(eglGetError()));
        return false;
    }
    if (!eglMakeCurrent(e->dpy, e->surf, e->surf, e->ctx)) {
        fail(err, errlen, "%s: eglMakeCurrent failed (%s)", what, egl_err_str(eglGetError()));
        return false;
    }
    dl_iterate_phdr(pin_one, NULL);
    const char *r = (const char *)glGetString(GL_RENDERER), *v = (const char *)glGetString(GL_VERSION);
    const char *x = (const char *)glGetString(GL_EXTENSIONS);
    snprintf(e->renderer, sizeof e->renderer, "%s", r ? r : "unknown");
    snprintf(e->version, sizeof e->version, "%s", v ? v : "unknown");
    e->extensions = strdup(x ? x : "");
    if (!e->extensions) {
        fail(err, errlen, "%s: out of memory", what);
        return false;
    }
    int major = 0;
    if (!v || sscanf(v, "OpenGL ES %d", &major) != 1 || major < 3) {
        fail(err, errlen, "%s: context is '%s', OpenGL ES 3.0 or later needed", what, v ? v : "?");
        return false;
    }
    return true;
}

static EGLDisplay platform_display(EGLenum platform, void *native)
{
    PFNEGLGETPLATFORMDISPLAYEXTPROC get = (PFNEGLGETPLATFORMDISPLAYEXTPROC)eglGetProcAddress("eglGetPlatformDisplayEXT");
    return get ? get(platform, native, NULL) : EGL_NO_DISPLAY;
}

plat_egl *plat_egl_open_offscreen(char *err, int errlen)
{
    plat_egl *e = calloc(1, sizeof *e);
    if (!e) return fail(err, errlen, "EGL: out of memory");
    e->fd = -1;
    e->surf = EGL_NO_SURFACE;
    const char *client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    bool surfaceless = has_word(client, "EGL_MESA_platform_surfaceless") && has_word(client, "EGL_EXT_platform_base");
    e->dpy = surfaceless ? platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY)
                         : eglGetDisplay(EGL_DEFAULT_DISPLAY);
    const char *what = surfaceless ? "EGL (surfaceless)" : "EGL (default display, pbuffer)";
    EGLint major, minor;
    if (e->dpy == EGL_NO_DISPLAY || !eglInitialize(e->dpy, &major, &minor)) {
        EGLint code = eglGetError();
        plat_egl_close(e);
        return fail(err, errlen, "%s: no display (%s)%s", what, egl_err_str(code),
                    surfaceless ? "" : "; the EGL library has no EGL_MESA_platform_surfaceless either");
    }
    const char *dext = eglQueryString(e->dpy, EGL_EXTENSIONS);
    bool no_surface = has_word(dext, "EGL_KHR_surfaceless_context");
    const EGLint want[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_ES3_BIT, EGL_SURFACE_TYPE, EGL_PBUFFER_BIT,
                           EGL_RED_SIZE, 8, EGL_GREEN_SIZE, 8, EGL_BLUE_SIZE, 8, EGL_NONE};
    EGLConfig cfg = NULL;
    EGLint n = 0;
    if (!eglChooseConfig(e->dpy, want, &cfg, 1, &n) || n < 1) {
        if (no_surface && has_word(dext, "EGL_KHR_no_config_context")) {
            cfg = EGL_NO_CONFIG_KHR;
        } else {
            plat_egl_close(e);
            return fail(err, errlen, "%s: no config with OpenGL ES 3 and pbuffers", what);
        }
    }
    if (!no_surface) {
        const EGLint pb[] = {EGL_WIDTH, 1, EGL_HEIGHT, 1, EGL_NONE};
        e->surf = eglCreatePbufferSurface(e->dpy, cfg, pb);
        if (e->surf == EGL_NO_SURFACE) {
            EGLint code = eglGetError();
            plat_egl_close(e);
            return fail(err, errlen, "%s: neither EGL_KHR_surfaceless_context nor a pbuffer (%s)", what,
                        egl_err_str(code));
        }
    }
    if (!make_context(e, cfg, what, err, errlen)) {
        plat_egl_close(e);
        return NULL;
    }
    return e;
}

/* ---- KMS ---- */

plat_egl *plat_egl_open_kms(const plat_egl_kms_params *p, char *err, int errlen)
{
    if (errlen > 0) err[0] = 0;
    const char *dev = p && p->device && *p->device ? p->device : "/dev/dri/card0";
    plat_egl_kms_params pp = p ? *p : (plat_egl_kms_params){0};
    pp.device = dev;
    plat_egl *e = calloc(1, sizeof *e);
    if (!e) return fail(err, errlen, "KMS: out of memory");
    e->kms = true;
    e->surf = EGL_NO_SURFACE;
    e->fd = -1;
    e->k = plat_kms_open(&pp, err, errlen);
    if (!e->k) {
        plat_egl_close(e);
        return NULL;
    }
    e->fd = plat_kms_fd(e->k);
    dev = plat_kms_device(e->k); /* the card kms_device = auto found */
    plat_kms_set_format(e->k, GBM_FORMAT_XRGB8888);
    const drmModeModeInfo *mode = &plat_kms_chosen(e->k)->mode;
    e->gbm = gbm_create_device(e->fd);
    if (!e->gbm) {
        plat_egl_close(e);
        return fail(err, errlen, "DRM device %s: GBM cannot use it (%s)", dev, strerror(errno));
    }
    e->gs = gbm_surface_create(e->gbm, mode->hdisplay, mode->vdisplay, GBM_FORMAT_XRGB8888,
                               GBM_BO_USE_SCANOUT | GBM_BO_USE_RENDERING);
    if (!e->gs) {
        plat_egl_close(e);
        return fail(err, errlen, "DRM device %s: no GBM scanout surface %dx%d XRGB8888", dev, mode->hdisplay,
                    mode->vdisplay);
    }
    const char *client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    if (!has_word(client, "EGL_KHR_platform_gbm") && !has_word(client, "EGL_MESA_platform_gbm")) {
        plat_egl_close(e);
        return fail(err, errlen, "EGL (GBM): the EGL library has no EGL_KHR_platform_gbm / EGL_MESA_platform_gbm");
    }
    e->dpy = platform_display(EGL_PLATFORM_GBM_KHR, e->gbm);
    EGLint major, minor;
    if (e->dpy == EGL_NO_DISPLAY || !eglInitialize(e->dpy, &major, &minor)) {
        EGLint code = eglGetError();
        plat_egl_close(e);
        return fail(err, errlen, "EGL (GBM on %s): no display (%s)", dev, egl_err_str(code));
    }
    /* The config whose native visual is the GBM surface's format. */
    const EGLint want[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_ES3_BIT, EGL_SURFACE_TYPE, EGL_WINDOW_BIT, EGL_RED_SIZE, 8,
                           EGL_GREEN_SIZE, 8, EGL_BLUE_SIZE, 8, EGL_NONE};
    EGLConfig cfgs[64], cfg = NULL;
    EGLint n = 0;
    eglChooseConfig(e->dpy, want, cfgs, 64, &n);
    for (int i = 0; i < n && !cfg; i++) {
        EGLint vid = 0;
        if (eglGetConfigAttrib(e->dpy, cfgs[i], EGL_NATIVE_VISUAL_ID, &vid) && (uint32_t)vid == GBM_FORMAT_XRGB8888)
            cfg = cfgs[i];
    }
    if (!cfg) {
        plat_egl_close(e);
        return fail(err, errlen, "EGL (GBM on %s): no OpenGL ES 3 window config for XRGB8888", dev);
    }
    e->surf = eglCreateWindowSurface(e->dpy, cfg, (EGLNativeWindowType)e->gs, NULL);
    if (e->surf == EGL_NO_SURFACE) {
        EGLint code = eglGetError();
        plat_egl_close(e);
        return fail(err, errlen, "EGL (GBM on %s): no window surface (%s)", dev, egl_err_str(code));
    }
    if (!make_context(e, cfg, "EGL (GBM)", err, errlen)) {
        plat_egl_close(e);
        return NULL;
    }
    return e;
}

static void destroy_fb(struct gbm_bo *bo, void *data)
{
    int fd = gbm_device_get_fd(gbm_bo_get_device(bo));
    uint32_t fb = (uint32_t)(uintptr_t)data;
    if (fb) drmModeRmFB(fd, fb);
}

/* The DRM framebuffer of a GBM buffer, created once and kept with it. */
static uint32_t bo_fb(plat_egl *e, struct gbm_bo *bo)
{
    uint32_t fb = (uint32_t)(uintptr_t)gbm_bo_get_user_data(bo);
    if (fb) return fb;
    uint32_t handles[4] = {gbm_bo_get_handle(bo).u32}, pitches[4] = {gbm_bo_get_stride(bo)}, offsets[4] = {0};
    if (drmModeAddFB2(e->fd, gbm_bo_get_width(bo), gbm_bo_get_height(bo), GBM_FORMAT_XRGB8888, handles, pitches,
                      offsets, &fb, 0) != 0)
        return 0;
    gbm_bo_set_user_data(bo, (void *)(uintptr_t)fb, destroy_fb);
    return fb;
}

bool plat_egl_present(plat_egl *e, char *err, int errlen)
{
    if (!e->kms) return true;
    /* The flip queued last vsync has normally completed long ago; its buffer is on screen from then on, and the
     * one it replaced can be drawn into again. */
    if (e->pending_bo) {
        /* A flip still pending after PRESENT_WAIT_MS stays the kernel's (a new commit would be refused EBUSY while it
         * is: a busy host's event thread can take that long): this present is skipped and the next one waits again.
         * Only after FLIP_LOST_MS is the flip taken as lost (driver hang, CRTC switched off) and forgotten. */
        int64_t now = plat_now_ns(), until = now + PRESENT_WAIT_MS * PLAT_NS_PER_MS;
        bool lost_by_now = now - e->pending_since_ns >= FLIP_LOST_MS * PLAT_NS_PER_MS;
        if (!lost_by_now) {
            while (plat_kms_flip_pending(e->k) && plat_now_ns() < until)
                plat_kms_wait(e->k, (int)((until - plat_now_ns()) / PLAT_NS_PER_MS) + 1);
            if (plat_kms_flip_pending(e->k)) {
                warp_err(err, errlen, "KMS %s: the previous page flip is still pending after %d ms: this frame is "
                         "not shown", plat_kms_chosen(e->k)->conn_name, PRESENT_WAIT_MS);
                return false;
            }
        } else if (!plat_kms_wait_flip(e->k, 0)) {
            warp_err(err, errlen, "KMS %s: previous page flip never completed (pending %d ms)",
                     plat_kms_chosen(e->k)->conn_name, (int)((now - e->pending_since_ns) / PLAT_NS_PER_MS));
            gbm_surface_release_buffer(e->gs, e->pending_bo);
            e->pending_bo = NULL;
            return false;
        }
        if (e->shown_bo) gbm_surface_release_buffer(e->gs, e->shown_bo);
        e->shown_bo = e->pending_bo;
        e->pending_bo = NULL;
    }
    const char *conn = plat_kms_chosen(e->k)->conn_name;
    if (!eglSwapBuffers(e->dpy, e->surf)) {
        warp_err(err, errlen, "KMS %s: eglSwapBuffers failed (%s)", conn, egl_err_str(eglGetError()));
        return false;
    }
    struct gbm_bo *bo = gbm_surface_lock_front_buffer(e->gs);
    uint32_t fb = bo ? bo_fb(e, bo) : 0;
    if (!fb) {
        if (bo) gbm_surface_release_buffer(e->gs, bo);
        warp_err(err, errlen, "KMS %s: cannot make a framebuffer of the rendered buffer", conn);
        return false;
    }
    uint64_t before = plat_kms_flips_completed(e->k);
    if (!plat_kms_commit(e->k, fb, err, errlen)) {
        gbm_surface_release_buffer(e->gs, bo);
        return false;
    }
    if (plat_kms_flips_completed(e->k) > before && !plat_kms_flip_pending(e->k)) {
        /* the modeset: shown at once */
        if (e->shown_bo) gbm_surface_release_buffer(e->gs, e->shown_bo);
        e->shown_bo = bo;
    } else {
        e->pending_bo = bo;
        e->pending_since_ns = plat_now_ns();
    }
    return true;
}

void plat_egl_flip_stats(const plat_egl *e, uint64_t *flips, uint64_t *failed)
{
    plat_kms_stats st = {0};
    if (e->k) plat_kms_stats_get(e->k, &st);
    *flips = st.flips;
    *failed = st.failed;
}

plat_kms *plat_egl_kms(const plat_egl *e) { return e->k; }

bool plat_egl_make_current(plat_egl *e) { return eglMakeCurrent(e->dpy, e->surf, e->surf, e->ctx) == EGL_TRUE; }

void plat_egl_release(plat_egl *e) { eglMakeCurrent(e->dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT); }

const char *plat_egl_renderer(const plat_egl *e) { return e->renderer; }
const char *plat_egl_version(const plat_egl *e) { return e->version; }
bool plat_egl_has_extension(const plat_egl *e, const char *name) { return has_word(e->extensions, name); }
bool plat_egl_is_kms(const plat_egl *e) { return e->kms; }

void plat_egl_kms_mode(const plat_egl *e, int *w, int *h, double *hz, const char **connector)
{
    const plat_kms_choice *ch = e->k ? plat_kms_chosen(e->k) : NULL;
    if (w) *w = ch ? ch->mode.hdisplay : 0;
    if (h) *h = ch ? ch->mode.vdisplay : 0;
    if (hz) *hz = ch ? ch->mode.vrefresh : 0;
    if (connector) *connector = ch ? ch->conn_name : "";
}

void plat_egl_close(plat_egl *e)
{
    if (!e) return;
    if (e->k && e->pending_bo) plat_kms_wait_flip(e->k, 100);
    if (e->dpy != EGL_NO_DISPLAY && e->dpy) {
        eglMakeCurrent(e->dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        if (e->ctx) eglDestroyContext(e->dpy, e->ctx);
        if (e->surf != EGL_NO_SURFACE) eglDestroySurface(e->dpy, e->surf);
        eglTerminate(e->dpy);
        /* frees the calling thread's EGL state (otherwise left to thread exit, or never for the main thread) */
        eglReleaseThread();
    }
    /* gives the CRTC back and closes the device (after GBM is done with it, below) */
    plat_kms *k = e->k;
    if (e->gs) {
        if (e->shown_bo) gbm_surface_release_buffer(e->gs, e->shown_bo);
        if (e->pending_bo) gbm_surface_release_buffer(e->gs, e->pending_bo);
        gbm_surface_destroy(e->gs);
    }
    if (e->gbm) gbm_device_destroy(e->gbm);
    plat_kms_close(k);
    free(e->extensions);
    free(e);
}

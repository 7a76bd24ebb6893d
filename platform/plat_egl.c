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

struct plat_egl {
    EGLDisplay dpy;
    EGLContext ctx;
    EGLSurface surf; /* pbuffer (offscreen without surfaceless contexts), window (KMS), or EGL_NO_SURFACE */
    char renderer[160], version[96];
    char *extensions;
    /* KMS */
    bool kms;
    int fd;
    struct gbm_device *gbm;
    struct gbm_surface *gs;
    uint32_t conn_id, crtc_id;
    drmModeModeInfo mode;
    char conn_name[32];
    drmModeCrtc *saved_crtc; /* restored at close */
    struct gbm_bo *shown_bo, *pending_bo;
    bool crtc_set, flip_pending;
    uint64_t flips, flip_failed;
};

#if defined(__GNUC__)
__attribute__((format(printf, 3, 4)))
#endif
static void *fail(char *err, int errlen, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err, (size_t)errlen, fmt, ap);
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

static void connector_name(const drmModeConnector *c, char *buf, size_t len)
{
    const char *t = drmModeGetConnectorTypeName(c->connector_type);
    snprintf(buf, len, "%s-%u", t ? t : "Unknown", c->connector_type_id);
}

static bool pick_mode(const drmModeConnector *c, const plat_egl_kms_params *p, drmModeModeInfo *out)
{
    const drmModeModeInfo *best = NULL;
    for (int i = 0; i < c->count_modes; i++) {
        const drmModeModeInfo *m = &c->modes[i];
        if (p->mode_w > 0) {
            if (m->hdisplay != p->mode_w || m->vdisplay != p->mode_h) continue;
            if (p->mode_hz > 0 && (m->vrefresh < p->mode_hz - 0.5 || m->vrefresh > p->mode_hz + 0.5)) continue;
            best = m;
            break;
        }
        if (m->type & DRM_MODE_TYPE_PREFERRED) {
            best = m;
            break;
        }
        if (!best) best = m;
    }
    if (!best) return false;
    *out = *best;
    return true;
}

static uint32_t pick_crtc(int fd, const drmModeRes *res, const drmModeConnector *c)
{
    if (c->encoder_id) {
        drmModeEncoder *enc = drmModeGetEncoder(fd, c->encoder_id);
        if (enc) {
            uint32_t id = enc->crtc_id;
            drmModeFreeEncoder(enc);
            if (id) return id;
        }
    }
    for (int i = 0; i < c->count_encoders; i++) {
        drmModeEncoder *enc = drmModeGetEncoder(fd, c->encoders[i]);
        if (!enc) continue;
        for (int k = 0; k < res->count_crtcs; k++)
            if (enc->possible_crtcs & (1u << k)) {
                drmModeFreeEncoder(enc);
                return res->crtcs[k];
            }
        drmModeFreeEncoder(enc);
    }
    return 0;
}

/* Finds the connector, mode and CRTC; fills e; false with err. */
static bool kms_setup(plat_egl *e, const plat_egl_kms_params *p, char *err, int errlen)
{
    drmModeRes *res = drmModeGetResources(e->fd);
    if (!res) {
        fail(err, errlen, "DRM device %s: no KMS resources (%s): not a display controller (a render node?)",
             p->device, strerror(errno));
        return false;
    }
    const bool any = !p->connector || !*p->connector || strcmp(p->connector, "auto") == 0;
    char seen[256] = "";
    bool ok = false;
    for (int i = 0; i < res->count_connectors && !ok; i++) {
        drmModeConnector *c = drmModeGetConnector(e->fd, res->connectors[i]);
        if (!c) continue;
        char name[32];
        connector_name(c, name, sizeof name);
        strncat(seen, *seen ? ", " : "", sizeof seen - strlen(seen) - 1);
        strncat(seen, name, sizeof seen - strlen(seen) - 1);
        strncat(seen, c->connection == DRM_MODE_CONNECTED ? " (connected)" : " (not connected)",
                sizeof seen - strlen(seen) - 1);
        bool wanted = any ? c->connection == DRM_MODE_CONNECTED : strcmp(name, p->connector) == 0;
        if (wanted) {
            if (c->connection != DRM_MODE_CONNECTED) {
                fail(err, errlen, "DRM device %s: connector %s is not connected", p->device, name);
            } else if (!pick_mode(c, p, &e->mode)) {
                if (p->mode_w > 0)
                    fail(err, errlen, "DRM device %s: connector %s has no mode %dx%d%s", p->device, name, p->mode_w,
                         p->mode_h, p->mode_hz > 0 ? " at that refresh" : "");
                else
                    fail(err, errlen, "DRM device %s: connector %s reports no modes", p->device, name);
            } else if (!(e->crtc_id = pick_crtc(e->fd, res, c))) {
                fail(err, errlen, "DRM device %s: no CRTC can drive connector %s", p->device, name);
            } else {
                e->conn_id = c->connector_id;
                snprintf(e->conn_name, sizeof e->conn_name, "%s", name);
                ok = true;
            }
            drmModeFreeConnector(c);
            if (!ok) break;
            continue;
        }
        drmModeFreeConnector(c);
    }
    drmModeFreeResources(res);
    if (!ok && !*err) {
        if (any)
            fail(err, errlen, "DRM device %s: no connected connector (connectors: %s)", p->device,
                 *seen ? seen : "none");
        else
            fail(err, errlen, "DRM device %s: no connector named %s (connectors: %s)", p->device, p->connector,
                 *seen ? seen : "none");
    }
    return ok;
}

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
    e->fd = open(dev, O_RDWR | O_CLOEXEC);
    if (e->fd < 0) {
        int code = errno;
        plat_egl_close(e);
        return fail(err, errlen, "no DRM device: %s: %s", dev, strerror(code));
    }
    if (!kms_setup(e, &pp, err, errlen)) {
        plat_egl_close(e);
        return NULL;
    }
    e->saved_crtc = drmModeGetCrtc(e->fd, e->crtc_id);
    e->gbm = gbm_create_device(e->fd);
    if (!e->gbm) {
        plat_egl_close(e);
        return fail(err, errlen, "DRM device %s: GBM cannot use it (%s)", dev, strerror(errno));
    }
    e->gs = gbm_surface_create(e->gbm, e->mode.hdisplay, e->mode.vdisplay, GBM_FORMAT_XRGB8888,
                               GBM_BO_USE_SCANOUT | GBM_BO_USE_RENDERING);
    if (!e->gs) {
        plat_egl_close(e);
        return fail(err, errlen, "DRM device %s: no GBM scanout surface %dx%d XRGB8888", dev, e->mode.hdisplay,
                    e->mode.vdisplay);
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

static void flip_done(int fd, unsigned seq, unsigned sec, unsigned usec, void *data)
{
    (void)fd;
    (void)seq;
    (void)sec;
    (void)usec;
    plat_egl *e = data;
    if (e->shown_bo) gbm_surface_release_buffer(e->gs, e->shown_bo);
    e->shown_bo = e->pending_bo;
    e->pending_bo = NULL;
    e->flip_pending = false;
}

/* Waits up to timeout_ms for the pending flip's event. */
static bool wait_flip(plat_egl *e, int timeout_ms)
{
    drmEventContext ev = {.version = 2, .page_flip_handler = flip_done};
    while (e->flip_pending) {
        struct pollfd pfd = {e->fd, POLLIN, 0};
        int r = poll(&pfd, 1, timeout_ms);
        if (r <= 0) return false;
        if (drmHandleEvent(e->fd, &ev) != 0) return false;
    }
    return true;
}

bool plat_egl_present(plat_egl *e, char *err, int errlen)
{
    if (!e->kms) return true;
    if (e->flip_pending && !wait_flip(e, 100)) {
        e->flip_failed++;
        snprintf(err, (size_t)errlen, "KMS %s: previous page flip never completed", e->conn_name);
        return false;
    }
    if (!eglSwapBuffers(e->dpy, e->surf)) {
        e->flip_failed++;
        snprintf(err, (size_t)errlen, "KMS %s: eglSwapBuffers failed (%s)", e->conn_name, egl_err_str(eglGetError()));
        return false;
    }
    struct gbm_bo *bo = gbm_surface_lock_front_buffer(e->gs);
    uint32_t fb = bo ? bo_fb(e, bo) : 0;
    if (!fb) {
        if (bo) gbm_surface_release_buffer(e->gs, bo);
        e->flip_failed++;
        snprintf(err, (size_t)errlen, "KMS %s: cannot make a framebuffer of the rendered buffer", e->conn_name);
        return false;
    }
    if (!e->crtc_set) {
        if (drmModeSetCrtc(e->fd, e->crtc_id, fb, 0, 0, &e->conn_id, 1, &e->mode) != 0) {
            gbm_surface_release_buffer(e->gs, bo);
            e->flip_failed++;
            snprintf(err, (size_t)errlen, "KMS %s: drmModeSetCrtc %dx%d failed: %s", e->conn_name, e->mode.hdisplay,
                     e->mode.vdisplay, strerror(errno));
            return false;
        }
        e->crtc_set = true;
        e->shown_bo = bo;
        e->flips++;
        return true;
    }
    if (drmModePageFlip(e->fd, e->crtc_id, fb, DRM_MODE_PAGE_FLIP_EVENT, e) != 0) {
        gbm_surface_release_buffer(e->gs, bo);
        e->flip_failed++;
        snprintf(err, (size_t)errlen, "KMS %s: drmModePageFlip failed: %s", e->conn_name, strerror(errno));
        return false;
    }
    e->pending_bo = bo;
    e->flip_pending = true;
    e->flips++;
    return true;
}

void plat_egl_flip_stats(const plat_egl *e, uint64_t *flips, uint64_t *failed)
{
    *flips = e->flips;
    *failed = e->flip_failed;
}

bool plat_egl_make_current(plat_egl *e) { return eglMakeCurrent(e->dpy, e->surf, e->surf, e->ctx) == EGL_TRUE; }

void plat_egl_release(plat_egl *e) { eglMakeCurrent(e->dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT); }

const char *plat_egl_renderer(const plat_egl *e) { return e->renderer; }
const char *plat_egl_version(const plat_egl *e) { return e->version; }
bool plat_egl_has_extension(const plat_egl *e, const char *name) { return has_word(e->extensions, name); }
bool plat_egl_is_kms(const plat_egl *e) { return e->kms; }

void plat_egl_kms_mode(const plat_egl *e, int *w, int *h, double *hz, const char **connector)
{
    if (w) *w = e->kms ? e->mode.hdisplay : 0;
    if (h) *h = e->kms ? e->mode.vdisplay : 0;
    if (hz) *hz = e->kms ? e->mode.vrefresh : 0;
    if (connector) *connector = e->conn_name;
}

void plat_egl_close(plat_egl *e)
{
    if (!e) return;
    if (e->kms && e->flip_pending) wait_flip(e, 100);
    if (e->dpy != EGL_NO_DISPLAY && e->dpy) {
        eglMakeCurrent(e->dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        if (e->ctx) eglDestroyContext(e->dpy, e->ctx);
        if (e->surf != EGL_NO_SURFACE) eglDestroySurface(e->dpy, e->surf);
        eglTerminate(e->dpy);
        /* frees the calling thread's EGL state (otherwise left to thread exit, or never for the main thread) */
        eglReleaseThread();
    }
    if (e->saved_crtc) {
        /* Give the console (or whoever had the CRTC) its framebuffer back. */
        drmModeSetCrtc(e->fd, e->saved_crtc->crtc_id, e->saved_crtc->buffer_id, e->saved_crtc->x, e->saved_crtc->y,
                       &e->conn_id, 1, &e->saved_crtc->mode);
        drmModeFreeCrtc(e->saved_crtc);
    }
    if (e->gs) {
        if (e->shown_bo) gbm_surface_release_buffer(e->gs, e->shown_bo);
        if (e->pending_bo) gbm_surface_release_buffer(e->gs, e->pending_bo);
        gbm_surface_destroy(e->gs);
    }
    if (e->gbm) gbm_device_destroy(e->gbm);
    if (e->kms && e->fd >= 0) close(e->fd);
    free(e->extensions);
    free(e);
}

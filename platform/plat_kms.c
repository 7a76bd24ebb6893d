/* SPDX-License-Identifier: MIT */
/* plat_kms: DRM/KMS output for both renderers: the connector/mode/CRTC choice, atomic (or legacy) page flips, one
 * event thread that reads the DRM fd, and the CPU path's display on dumb buffers.
 *
 * Threads. The event thread is the only reader of the fd's events: page-flip completions (it counts late ones and
 * wakes the committing thread) and, once a vsync source asked, one vblank event per vblank whose times it queues
 * for that source. Commits come from one other thread (the CPU display's thread, or the GLES compositor) and never
 * wait for the event thread: they only look at an atomic "flip pending" flag. */
#include "platform/plat_kms.h"

#include <drm_fourcc.h>
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <pthread.h>
#include <semaphore.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>
#include <unistd.h>
#include <xf86drm.h>

#include "platform/plat_clock.h"
#include "warp/warp_err.h"

#define EVENT_POLL_MS 20        /* the event thread checks for close() and re-arms vblank requests this often */
#define VBLANK_QUEUE 64         /* vblank times waiting for the vsync source (a second at 60 Hz) */
#define VBLANK_REARM_NS (200 * PLAT_NS_PER_MS) /* no vblank event for this long: the request was lost, ask again */
#define CLOSE_FLIP_WAIT_MS 100
#define AUTO_CARDS 16           /* kms_device = auto looks at /dev/dri/card0 to card15 */  /* at close, how long a queued flip may take to complete */

/* ---- connector, mode, CRTC ---- */

static void connector_name(const drmModeConnector *c, char *buf, size_t len)
{
    const char *t = drmModeGetConnectorTypeName(c->connector_type);
    snprintf(buf, len, "%s-%u", t ? t : "Unknown", c->connector_type_id);
}

static bool pick_mode(const drmModeConnector *c, const plat_kms_params *p, drmModeModeInfo *out)
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

/* The CRTC the connector's encoder drives now, else the first one an encoder of it can use. */
static uint32_t pick_crtc(int fd, const drmModeRes *res, const drmModeConnector *c, int *index)
{
    if (c->encoder_id) {
        drmModeEncoder *enc = drmModeGetEncoder(fd, c->encoder_id);
        if (enc) {
            uint32_t id = enc->crtc_id;
            drmModeFreeEncoder(enc);
            for (int k = 0; id && k < res->count_crtcs; k++)
                if (res->crtcs[k] == id) {
                    *index = k;
                    return id;
                }
        }
    }
    for (int i = 0; i < c->count_encoders; i++) {
        drmModeEncoder *enc = drmModeGetEncoder(fd, c->encoders[i]);
        if (!enc) continue;
        for (int k = 0; k < res->count_crtcs; k++)
            if (enc->possible_crtcs & (1u << k)) {
                drmModeFreeEncoder(enc);
                *index = k;
                return res->crtcs[k];
            }
        drmModeFreeEncoder(enc);
    }
    return 0;
}

bool plat_kms_pick(int fd, const plat_kms_params *p, plat_kms_choice *out, char *err, int errlen)
{
    memset(out, 0, sizeof *out);
    if (err && errlen > 0) err[0] = 0;
    const char *dev = p->device ? p->device : "?";
    drmModeRes *res = drmModeGetResources(fd);
    if (!res) {
        warp_err(err, errlen, "DRM device %s: no KMS resources (%s): not a display controller (a render node?)", dev,
                 strerror(errno));
        return false;
    }
    const bool any = !p->connector || !*p->connector || strcmp(p->connector, "auto") == 0;
    char seen[256] = "";
    bool ok = false, failed = false;
    for (int i = 0; i < res->count_connectors && !ok && !failed; i++) {
        drmModeConnector *c = drmModeGetConnector(fd, res->connectors[i]);
        if (!c) continue;
        char name[32];
        connector_name(c, name, sizeof name);
        strncat(seen, *seen ? ", " : "", sizeof seen - strlen(seen) - 1);
        strncat(seen, name, sizeof seen - strlen(seen) - 1);
        strncat(seen, c->connection == DRM_MODE_CONNECTED ? " (connected)" : " (not connected)",
                sizeof seen - strlen(seen) - 1);
        bool wanted = any ? c->connection == DRM_MODE_CONNECTED : strcmp(name, p->connector) == 0;
        if (wanted) {
            failed = true;
            if (c->connection != DRM_MODE_CONNECTED) {
                warp_err(err, errlen, "DRM device %s: connector %s is not connected", dev, name);
            } else if (!pick_mode(c, p, &out->mode)) {
                if (p->mode_w > 0)
                    warp_err(err, errlen, "DRM device %s: connector %s has no mode %dx%d%s", dev, name, p->mode_w,
                             p->mode_h, p->mode_hz > 0 ? " at that refresh" : "");
                else
                    warp_err(err, errlen, "DRM device %s: connector %s reports no modes", dev, name);
            } else if (!(out->crtc_id = pick_crtc(fd, res, c, &out->crtc_index))) {
                warp_err(err, errlen, "DRM device %s: no CRTC can drive connector %s", dev, name);
            } else {
                out->conn_id = c->connector_id;
                snprintf(out->conn_name, sizeof out->conn_name, "%s", name);
                ok = true;
                failed = false;
            }
        }
        drmModeFreeConnector(c);
    }
    drmModeFreeResources(res);
    if (!ok && !failed) {
        if (any)
            warp_err(err, errlen, "DRM device %s: no connected connector (connectors: %s)", dev, *seen ? seen : "none");
        else
            warp_err(err, errlen, "DRM device %s: no connector named %s (connectors: %s)", dev, p->connector,
                     *seen ? seen : "none");
    }
    return ok;
}

/* ---- the output ---- */

enum { P_FB_ID, P_CRTC_ID, P_SRC_X, P_SRC_Y, P_SRC_W, P_SRC_H, P_CRTC_X, P_CRTC_Y, P_CRTC_W, P_CRTC_H, P_PLANE_N };
static const char *const plane_prop_names[P_PLANE_N] = {"FB_ID",  "CRTC_ID", "SRC_X",  "SRC_Y",  "SRC_W",
                                                        "SRC_H",  "CRTC_X",  "CRTC_Y", "CRTC_W", "CRTC_H"};

struct plat_kms {
    int fd;
    int rt_priority;
    char device[128];
    plat_kms_choice ch;
    bool atomic;
    uint32_t plane_id;             /* primary plane (0 when the driver lists none: legacy) */
    uint32_t plane_prop[P_PLANE_N];
    uint32_t crtc_mode_id, crtc_active, conn_crtc_id; /* property ids */
    uint32_t mode_blob;
    uint32_t *formats;             /* the primary plane's */
    int nformats;
    uint32_t format;
    drmModeAtomicReq *req;         /* reused by every commit (cursor reset), so a flip allocates no request */
    drmModeCrtc *saved_crtc;       /* given back at close */
    bool lit;                      /* the first commit (the modeset) succeeded */

    /* committing thread <-> event thread */
    atomic_bool pending;
    _Atomic uint64_t completed;
    sem_t wake;

    /* event thread */
    pthread_t th;
    bool th_up;
    atomic_bool quit;
    bool have_seq;
    uint32_t last_seq;
    bool vbl_armed;
    int64_t vbl_last_ns;

    /* vblank queue for the vsync source */
    atomic_bool want_vbl;
    pthread_mutex_t mu;
    pthread_cond_t cv;
    int64_t vq[VBLANK_QUEUE];
    int vq_head, vq_count;
    char vbl_error[160];

    _Atomic uint64_t flips, failed, late, vblanks;
    /* Written by the committing thread (the vsync path: it only try-locks, so a message is dropped rather than the
     * commit waiting while stats are being copied; the failure is counted either way), read by plat_kms_stats_get
     * from any thread. */
    pthread_mutex_t err_mu;
    char last_error[160];
};

static void note_error(plat_kms *k, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void note_error(plat_kms *k, const char *fmt, ...)
{
    if (pthread_mutex_trylock(&k->err_mu) != 0) return;
    va_list ap;
    va_start(ap, fmt);
    warp_verr(k->last_error, sizeof k->last_error, fmt, ap);
    va_end(ap);
    pthread_mutex_unlock(&k->err_mu);
}

int plat_kms_fd(const plat_kms *k) { return k->fd; }
const char *plat_kms_device(const plat_kms *k) { return k->device; }
const plat_kms_choice *plat_kms_chosen(const plat_kms *k) { return &k->ch; }
bool plat_kms_atomic(const plat_kms *k) { return k->atomic; }
void plat_kms_set_format(plat_kms *k, uint32_t fourcc) { k->format = fourcc; }
bool plat_kms_flip_pending(const plat_kms *k) { return atomic_load_explicit(&k->pending, memory_order_acquire); }
uint64_t plat_kms_flips_completed(const plat_kms *k) { return atomic_load_explicit(&k->completed, memory_order_acquire); }
void plat_kms_kick(plat_kms *k) { sem_post(&k->wake); }

bool plat_kms_plane_has_format(const plat_kms *k, uint32_t fourcc)
{
    if (!k->nformats) return fourcc == DRM_FORMAT_XRGB8888;
    for (int i = 0; i < k->nformats; i++)
        if (k->formats[i] == fourcc) return true;
    return false;
}

const char *plat_kms_format_name(uint32_t fourcc)
{
    switch (fourcc) {
    case DRM_FORMAT_XRGB8888: return "XRGB8888";
    case DRM_FORMAT_XBGR8888: return "XBGR8888";
    case DRM_FORMAT_ARGB8888: return "ARGB8888";
    case DRM_FORMAT_ABGR8888: return "ABGR8888";
    default: return "unknown";
    }
}

bool plat_kms_flip_is_late(bool prev_valid, uint32_t prev_seq, uint32_t seq)
{
    /* unsigned difference: right across the counter's wrap */
    return prev_valid && (uint32_t)(seq - prev_seq) > 1;
}

void plat_kms_copy_to_xrgb(uint8_t *dst, int pitch, const warp_image_rgba8 *src)
{
    for (int y = 0; y < src->h; y++) {
        const warp_rgba8 *s = &WARP_AT(src, 0, y);
        uint8_t *d = dst + (size_t)y * (size_t)pitch;
        for (int x = 0; x < src->w; x++) {
            d[4 * x + 0] = s[x].b;
            d[4 * x + 1] = s[x].g;
            d[4 * x + 2] = s[x].r;
            d[4 * x + 3] = 0xff;
        }
    }
}

void plat_kms_copy_to_xbgr(uint8_t *dst, int pitch, const warp_image_rgba8 *src)
{
    for (int y = 0; y < src->h; y++)
        memcpy(dst + (size_t)y * (size_t)pitch, &WARP_AT(src, 0, y), (size_t)src->w * sizeof(warp_rgba8));
}

static uint32_t prop_id(int fd, uint32_t obj, uint32_t type, const char *name, uint64_t *value)
{
    drmModeObjectProperties *props = drmModeObjectGetProperties(fd, obj, type);
    uint32_t id = 0;
    for (uint32_t i = 0; props && i < props->count_props && !id; i++) {
        drmModePropertyRes *pr = drmModeGetProperty(fd, props->props[i]);
        if (pr && strcmp(pr->name, name) == 0) {
            id = pr->prop_id;
            if (value) *value = props->prop_values[i];
        }
        drmModeFreeProperty(pr);
    }
    drmModeFreeObjectProperties(props);
    return id;
}

/* The CRTC's primary plane and its formats (needs DRM_CLIENT_CAP_UNIVERSAL_PLANES). */
static void find_primary(plat_kms *k)
{
    drmModePlaneRes *pr = drmModeGetPlaneResources(k->fd);
    for (uint32_t i = 0; pr && i < pr->count_planes && !k->plane_id; i++) {
        drmModePlane *pl = drmModeGetPlane(k->fd, pr->planes[i]);
        if (!pl) continue;
        uint64_t type = 0;
        if ((pl->possible_crtcs & (1u << k->ch.crtc_index)) &&
            prop_id(k->fd, pl->plane_id, DRM_MODE_OBJECT_PLANE, "type", &type) && type == DRM_PLANE_TYPE_PRIMARY) {
            k->formats = calloc(pl->count_formats ? pl->count_formats : 1, sizeof *k->formats);
            if (k->formats) {
                memcpy(k->formats, pl->formats, pl->count_formats * sizeof *k->formats);
                k->nformats = (int)pl->count_formats;
            }
            k->plane_id = pl->plane_id;
        }
        drmModeFreePlane(pl);
    }
    drmModeFreePlaneResources(pr);
}

/* Looks up every property id an atomic commit sets; false when one is missing (then legacy calls are used). */
static bool atomic_props(plat_kms *k)
{
    for (int i = 0; i < P_PLANE_N; i++)
        if (!(k->plane_prop[i] = prop_id(k->fd, k->plane_id, DRM_MODE_OBJECT_PLANE, plane_prop_names[i], NULL)))
            return false;
    k->crtc_mode_id = prop_id(k->fd, k->ch.crtc_id, DRM_MODE_OBJECT_CRTC, "MODE_ID", NULL);
    k->crtc_active = prop_id(k->fd, k->ch.crtc_id, DRM_MODE_OBJECT_CRTC, "ACTIVE", NULL);
    k->conn_crtc_id = prop_id(k->fd, k->ch.conn_id, DRM_MODE_OBJECT_CONNECTOR, "CRTC_ID", NULL);
    return k->crtc_mode_id && k->crtc_active && k->conn_crtc_id;
}

static int64_t event_ns(unsigned sec, unsigned usec) { return (int64_t)sec * PLAT_NS_PER_S + (int64_t)usec * 1000; }

static void arm_vblank(plat_kms *k, bool absolute, uint32_t seq)
{
    drmVBlank vbl;
    memset(&vbl, 0, sizeof vbl);
    /* ABSOLUTE | NEXTONMISS: the vblank after the one just reported even if this thread ran late; the kernel
     * encodes CRTCs past the first in the high bits */
    vbl.request.type = (drmVBlankSeqType)(DRM_VBLANK_EVENT |
                                          (absolute ? DRM_VBLANK_ABSOLUTE | DRM_VBLANK_NEXTONMISS : DRM_VBLANK_RELATIVE) |
                                          (((unsigned)k->ch.crtc_index << DRM_VBLANK_HIGH_CRTC_SHIFT) &
                                           DRM_VBLANK_HIGH_CRTC_MASK));
    vbl.request.sequence = absolute ? seq : 1;
    vbl.request.signal = (unsigned long)(uintptr_t)k;
    if (drmWaitVBlank(k->fd, &vbl) == 0) {
        k->vbl_armed = true;
        k->vbl_last_ns = plat_now_ns();
    } else {
        pthread_mutex_lock(&k->mu);
        snprintf(k->vbl_error, sizeof k->vbl_error, "%.60s: vblank event request on CRTC %u failed: %s", k->device,
                 k->ch.crtc_id, strerror(errno));
        pthread_mutex_unlock(&k->mu);
    }
}

static void on_vblank(int fd, unsigned seq, unsigned sec, unsigned usec, void *data)
{
    (void)fd;
    plat_kms *k = data;
    k->vbl_armed = false;
    if (!atomic_load(&k->want_vbl)) return;
    pthread_mutex_lock(&k->mu);
    if (k->vq_count == VBLANK_QUEUE) { /* the source fell behind: drop the oldest */
        k->vq_head = (k->vq_head + 1) % VBLANK_QUEUE;
        k->vq_count--;
    }
    k->vq[(k->vq_head + k->vq_count++) % VBLANK_QUEUE] = event_ns(sec, usec);
    pthread_cond_signal(&k->cv);
    pthread_mutex_unlock(&k->mu);
    atomic_fetch_add(&k->vblanks, 1);
    arm_vblank(k, true, seq + 1);
}

static void on_flip(int fd, unsigned seq, unsigned sec, unsigned usec, void *data)
{
    (void)fd;
    (void)sec;
    (void)usec;
    plat_kms *k = data;
    if (plat_kms_flip_is_late(k->have_seq, k->last_seq, seq)) atomic_fetch_add(&k->late, 1);
    k->have_seq = true;
    k->last_seq = seq;
    atomic_store_explicit(&k->pending, false, memory_order_release);
    atomic_fetch_add_explicit(&k->completed, 1, memory_order_release);
    sem_post(&k->wake);
}

static void *event_thread(void *arg)
{
    plat_kms *k = arg;
    plat_thread_set_name("hmdwarp-kms-ev");
    if (k->rt_priority > 0) plat_thread_set_realtime(k->rt_priority < 99 ? k->rt_priority + 1 : 99);
    drmEventContext ev = {.version = 2, .vblank_handler = on_vblank, .page_flip_handler = on_flip};
    while (!atomic_load(&k->quit)) {
        if (atomic_load(&k->want_vbl) && atomic_load(&k->completed)) {
            if (k->vbl_armed && plat_now_ns() - k->vbl_last_ns > VBLANK_REARM_NS) k->vbl_armed = false;
            if (!k->vbl_armed) arm_vblank(k, false, 0);
        }
        struct pollfd pfd = {k->fd, POLLIN, 0};
        if (poll(&pfd, 1, EVENT_POLL_MS) > 0 && (pfd.revents & POLLIN)) drmHandleEvent(k->fd, &ev);
    }
    return NULL;
}

/* kms_device = auto: the first card whose connectors include the wanted one, connected (on a Raspberry Pi 5 the
 * display controller is card1 or card0 depending on the kernel; card numbers follow probe order). */
static bool find_card(const plat_kms_params *p, char *dev, size_t len, char *err, int errlen)
{
    char tried[200] = "";
    for (int n = 0; n < AUTO_CARDS; n++) {
        char path[32], e[200];
        snprintf(path, sizeof path, "/dev/dri/card%d", n);
        int fd = open(path, O_RDWR | O_CLOEXEC);
        if (fd < 0) continue;
        plat_kms_params pp = *p;
        pp.device = path;
        plat_kms_choice ch;
        bool ok = plat_kms_pick(fd, &pp, &ch, e, sizeof e);
        close(fd);
        if (ok) {
            snprintf(dev, len, "%s", path);
            return true;
        }
        size_t used = strlen(tried);
        /* cut where it does not fit: the first cards tried are named */
        if (snprintf(tried + used, sizeof tried - used, "%s%s", used ? "; " : "", e) < 0) break;
    }
    warp_err(err, errlen, "kms_device = auto: no /dev/dri/cardN with a connected connector%s%s%s",
             *tried ? " (" : " (no card at all)", tried, *tried ? ")" : "");
    return false;
}

plat_kms *plat_kms_open(const plat_kms_params *p, char *err, int errlen)
{
    if (err && errlen > 0) err[0] = 0;
    const char *dev = p && p->device && *p->device ? p->device : "/dev/dri/card0";
    char found[32];
    if (strcmp(dev, "auto") == 0) {
        if (!find_card(p, found, sizeof found, err, errlen)) return NULL;
        dev = found;
    }
    plat_kms_params pp = p ? *p : (plat_kms_params){0};
    pp.device = dev;
    plat_kms *k = calloc(1, sizeof *k);
    if (!k) {
        warp_err(err, errlen, "KMS: out of memory");
        return NULL;
    }
    k->fd = -1;
    k->rt_priority = pp.rt_priority;
    snprintf(k->device, sizeof k->device, "%s", dev);
    k->format = DRM_FORMAT_XRGB8888;
    sem_init(&k->wake, 0, 0);
    pthread_mutex_init(&k->mu, NULL);
    pthread_mutex_init(&k->err_mu, NULL);
    plat_cond_init_monotonic(&k->cv);
    k->fd = open(dev, O_RDWR | O_CLOEXEC);
    if (k->fd < 0) {
        warp_err(err, errlen, "no DRM device: %s: %s", dev, strerror(errno));
        plat_kms_close(k);
        return NULL;
    }
    if (!plat_kms_pick(k->fd, &pp, &k->ch, err, errlen)) {
        plat_kms_close(k);
        return NULL;
    }
    /* Universal planes first (the primary plane and its formats are listed only then); atomic where the driver
     * has it and every property a commit sets exists, else the legacy SetCrtc / PageFlip calls. */
    if (drmSetClientCap(k->fd, DRM_CLIENT_CAP_UNIVERSAL_PLANES, 1) == 0) find_primary(k);
    k->atomic = k->plane_id && drmSetClientCap(k->fd, DRM_CLIENT_CAP_ATOMIC, 1) == 0 && atomic_props(k);
    if (k->atomic) {
        k->req = drmModeAtomicAlloc();
        if (!k->req || drmModeCreatePropertyBlob(k->fd, &k->ch.mode, sizeof k->ch.mode, &k->mode_blob) != 0) {
            warp_err(err, errlen, "DRM device %s: cannot create the mode's property blob: %s", dev, strerror(errno));
            plat_kms_close(k);
            return NULL;
        }
    }
    k->saved_crtc = drmModeGetCrtc(k->fd, k->ch.crtc_id);
    if (!drmIsMaster(k->fd))
        note_error(k, "%.60s: not DRM master (another process holds the display): commits will fail", dev);
    if (pthread_create(&k->th, NULL, event_thread, k) != 0) {
        warp_err(err, errlen, "DRM device %s: cannot start the KMS event thread", dev);
        plat_kms_close(k);
        return NULL;
    }
    k->th_up = true;
    return k;
}

static void commit_failed(plat_kms *k, const char *what, int code, char *err, int errlen)
{
    const char *why = code == EBUSY                   ? "EBUSY, a flip is still pending"
                      : code == EACCES || code == EPERM ? "not DRM master: another process holds the display"
                      : code == EINVAL                  ? "EINVAL, the driver refused the configuration"
                                                        : strerror(code);
    atomic_fetch_add(&k->failed, 1);
    note_error(k, "KMS %s: %s failed: %s", k->ch.conn_name, what, why);
    warp_err(err, errlen, "KMS %s: %s failed: %s", k->ch.conn_name, what, why);
}

static void add_plane(plat_kms *k, uint32_t fb)
{
    const uint32_t w = k->ch.mode.hdisplay, h = k->ch.mode.vdisplay;
    const uint64_t v[P_PLANE_N] = {fb, k->ch.crtc_id, 0, 0, (uint64_t)w << 16, (uint64_t)h << 16, 0, 0, w, h};
    for (int i = 0; i < P_PLANE_N; i++) drmModeAtomicAddProperty(k->req, k->plane_id, k->plane_prop[i], v[i]);
}

bool plat_kms_commit(plat_kms *k, uint32_t fb, char *err, int errlen)
{
    if (!k->lit) {
        int rc;
        if (k->atomic) {
            drmModeAtomicSetCursor(k->req, 0);
            drmModeAtomicAddProperty(k->req, k->ch.conn_id, k->conn_crtc_id, k->ch.crtc_id);
            drmModeAtomicAddProperty(k->req, k->ch.crtc_id, k->crtc_mode_id, k->mode_blob);
            drmModeAtomicAddProperty(k->req, k->ch.crtc_id, k->crtc_active, 1);
            add_plane(k, fb);
            rc = drmModeAtomicCommit(k->fd, k->req, DRM_MODE_ATOMIC_ALLOW_MODESET, k);
        } else {
            rc = drmModeSetCrtc(k->fd, k->ch.crtc_id, fb, 0, 0, &k->ch.conn_id, 1, &k->ch.mode);
        }
        if (rc != 0) {
            commit_failed(k, k->atomic ? "atomic modeset" : "drmModeSetCrtc", errno, err, errlen);
            return false;
        }
        k->lit = true;
        atomic_fetch_add(&k->flips, 1);
        atomic_fetch_add_explicit(&k->completed, 1, memory_order_release); /* a modeset completes at once */
        return true;
    }
    if (atomic_load_explicit(&k->pending, memory_order_acquire)) {
        commit_failed(k, "page flip", EBUSY, err, errlen);
        return false;
    }
    /* pending before the commit: the completion may arrive before the ioctl returns */
    atomic_store_explicit(&k->pending, true, memory_order_release);
    int rc;
    if (k->atomic) {
        drmModeAtomicSetCursor(k->req, 0);
        add_plane(k, fb);
        rc = drmModeAtomicCommit(k->fd, k->req, DRM_MODE_ATOMIC_NONBLOCK | DRM_MODE_PAGE_FLIP_EVENT, k);
    } else {
        rc = drmModePageFlip(k->fd, k->ch.crtc_id, fb, DRM_MODE_PAGE_FLIP_EVENT, k);
    }
    if (rc != 0) {
        int code = errno;
        atomic_store_explicit(&k->pending, false, memory_order_release);
        commit_failed(k, k->atomic ? "atomic page flip" : "drmModePageFlip", code, err, errlen);
        return false;
    }
    atomic_fetch_add(&k->flips, 1);
    return true;
}

bool plat_kms_wait(plat_kms *k, int timeout_ms)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts); /* sem_clockwait: a wall-clock step cannot stretch the wait */
    ts.tv_nsec += (long)(timeout_ms % 1000) * 1000000L;
    ts.tv_sec += timeout_ms / 1000 + ts.tv_nsec / 1000000000L;
    ts.tv_nsec %= 1000000000L;
    while (sem_clockwait(&k->wake, CLOCK_MONOTONIC, &ts) != 0)
        if (errno != EINTR) return false;
    return true;
}

/* The event never came (driver hang, CRTC switched off): count it and go on without it. */
static void forget_flip(plat_kms *k, int waited_ms)
{
    atomic_store(&k->pending, false);
    atomic_fetch_add(&k->failed, 1);
    note_error(k, "KMS %s: page flip never completed (no event in %d ms)", k->ch.conn_name, waited_ms);
}

bool plat_kms_wait_flip(plat_kms *k, int timeout_ms)
{
    int64_t until = plat_now_ns() + (int64_t)timeout_ms * PLAT_NS_PER_MS;
    while (plat_kms_flip_pending(k)) {
        int64_t left = until - plat_now_ns();
        if (left <= 0 || !k->th_up) {
            forget_flip(k, timeout_ms);
            return false;
        }
        plat_kms_wait(k, (int)(left / PLAT_NS_PER_MS) + 1);
    }
    return true;
}

int plat_kms_wait_vblanks(plat_kms *k, int64_t *t_ns, int max, int timeout_ms, char *err, int errlen)
{
    atomic_store(&k->want_vbl, true);
    struct timespec ts = plat_deadline_after_ms(timeout_ms);
    pthread_mutex_lock(&k->mu);
    while (k->vq_count == 0 && !atomic_load(&k->quit))
        if (pthread_cond_timedwait(&k->cv, &k->mu, &ts) == ETIMEDOUT) break;
    int n = 0;
    for (; n < max && k->vq_count; n++, k->vq_count--) {
        t_ns[n] = k->vq[k->vq_head];
        k->vq_head = (k->vq_head + 1) % VBLANK_QUEUE;
    }
    if (!n && k->vbl_error[0]) {
        warp_err(err, errlen, "%s", k->vbl_error);
        k->vbl_error[0] = 0;
        pthread_mutex_unlock(&k->mu);
        return -EIO;
    }
    pthread_mutex_unlock(&k->mu);
    return n;
}

void plat_kms_stop_vblanks(plat_kms *k) { atomic_store(&k->want_vbl, false); }

void plat_kms_stats_get(plat_kms *k, plat_kms_stats *st)
{
    memset(st, 0, sizeof *st);
    st->flips = atomic_load(&k->flips);
    st->failed = atomic_load(&k->failed);
    st->late = atomic_load(&k->late);
    st->vblanks = atomic_load(&k->vblanks);
    st->api = k->atomic ? "atomic" : "legacy";
    st->format = plat_kms_format_name(k->format);
    snprintf(st->connector, sizeof st->connector, "%s", k->ch.conn_name);
    st->w = k->ch.mode.hdisplay;
    st->h = k->ch.mode.vdisplay;
    st->hz = k->ch.mode.vrefresh;
    pthread_mutex_lock(&k->err_mu);
    snprintf(st->last_error, sizeof st->last_error, "%s", k->last_error);
    pthread_mutex_unlock(&k->err_mu);
}

void plat_kms_close(plat_kms *k)
{
    if (!k) return;
    if (k->th_up) {
        if (plat_kms_flip_pending(k)) plat_kms_wait_flip(k, CLOSE_FLIP_WAIT_MS);
        atomic_store(&k->quit, true);
        pthread_join(k->th, NULL);
    }
    if (k->saved_crtc && k->lit) {
        /* Give the console (or whoever had the CRTC) its framebuffer back; a CRTC that was off goes off again. */
        drmModeCrtc *s = k->saved_crtc;
        if (s->mode_valid && s->buffer_id)
            drmModeSetCrtc(k->fd, s->crtc_id, s->buffer_id, s->x, s->y, &k->ch.conn_id, 1, &s->mode);
        else
            drmModeSetCrtc(k->fd, s->crtc_id, 0, 0, 0, NULL, 0, NULL);
    }
    drmModeFreeCrtc(k->saved_crtc);
    if (k->mode_blob) drmModeDestroyPropertyBlob(k->fd, k->mode_blob);
    drmModeAtomicFree(k->req);
    free(k->formats);
    if (k->fd >= 0) close(k->fd);
    pthread_cond_destroy(&k->cv);
    pthread_mutex_destroy(&k->mu);
    pthread_mutex_destroy(&k->err_mu);
    sem_destroy(&k->wake);
    free(k);
}

/* ---- the CPU path's display: dumb buffers ---- */

#define KMS_OWN_BUFFERS 2 /* copy mode: one shown, one filled and flipped to (one flip at a time) */

typedef struct {
    uint32_t handle, fb, pitch;
    uint8_t *map;
    size_t size;
} dumb_buf;

typedef struct {
    plat_display base;
    plat_kms *k;
    plat_swapchain *sc;
    bool zero_copy;             /* XBGR8888: the swapchain's images are the dumb buffers */
    dumb_buf buf[PLAT_SWAPCHAIN_MAX > KMS_OWN_BUFFERS ? PLAT_SWAPCHAIN_MAX : KMS_OWN_BUFFERS];
    int nbuf;
    warp_image_rgba8 own_img[PLAT_SWAPCHAIN_MAX]; /* zero copy: the swapchain's own pixels, put back at destroy */

    pthread_t th;
    atomic_bool quit;
    _Atomic int job;            /* swapchain index handed over by present(), -1 none */
    _Atomic uint64_t dropped;   /* images replaced by a newer one before the thread took them */
} kms_display;

static bool dumb_create(int fd, int w, int h, dumb_buf *b, char *err, int errlen)
{
    struct drm_mode_create_dumb cd = {.height = (uint32_t)h, .width = (uint32_t)w, .bpp = 32};
    if (drmIoctl(fd, DRM_IOCTL_MODE_CREATE_DUMB, &cd) != 0) {
        warp_err(err, errlen, "cannot create a %dx%d dumb buffer: %s", w, h, strerror(errno));
        return false;
    }
    b->handle = cd.handle;
    b->pitch = cd.pitch;
    b->size = cd.size;
    struct drm_mode_map_dumb md = {.handle = cd.handle};
    if (drmIoctl(fd, DRM_IOCTL_MODE_MAP_DUMB, &md) != 0) {
        warp_err(err, errlen, "cannot map a dumb buffer: %s", strerror(errno));
        return false;
    }
    void *m = mmap(NULL, b->size, PROT_READ | PROT_WRITE, MAP_SHARED, fd, (off_t)md.offset);
    if (m == MAP_FAILED) {
        warp_err(err, errlen, "cannot mmap a dumb buffer: %s", strerror(errno));
        return false;
    }
    b->map = m;
    return true;
}

static bool dumb_fb(int fd, int w, int h, uint32_t fourcc, dumb_buf *b, char *err, int errlen)
{
    uint32_t handles[4] = {b->handle}, pitches[4] = {b->pitch}, offsets[4] = {0};
    if (drmModeAddFB2(fd, (uint32_t)w, (uint32_t)h, fourcc, handles, pitches, offsets, &b->fb, 0) != 0) {
        warp_err(err, errlen, "drmModeAddFB2 %dx%d %s: %s", w, h, plat_kms_format_name(fourcc), strerror(errno));
        return false;
    }
    return true;
}

static void dumb_free(int fd, dumb_buf *b)
{
    if (b->fb) drmModeRmFB(fd, b->fb);
    if (b->map) munmap(b->map, b->size);
    if (b->handle) {
        struct drm_mode_destroy_dumb dd = {.handle = b->handle};
        drmIoctl(fd, DRM_IOCTL_MODE_DESTROY_DUMB, &dd);
    }
    memset(b, 0, sizeof *b);
}

static void release(kms_display *d, int index)
{
    if (index >= 0) atomic_store_explicit(&d->sc->held[index], 0, memory_order_release);
}

static void *kms_thread(void *arg)
{
    kms_display *d = arg;
    plat_thread_set_name("hmdwarp-kms");
    if (d->k->rt_priority > 0) plat_thread_set_realtime(d->k->rt_priority);
    int shown = -1, flipping = -1; /* buffers (zero copy: swapchain indices) on screen and queued */
    uint64_t flip_done_at = 0;     /* plat_kms_flips_completed() value once the queued flip is done */
    int64_t flip_since = 0;
    /* the kernel sends an event for every flip it accepted unless the CRTC went off: wait long before calling one
     * lost (a late event after that would be taken for the next flip's) */
    const int flip_timeout_ms = 2000;
    char err[160];
    while (!atomic_load(&d->quit)) {
        plat_kms_wait(d->k, 50);
        if (flipping >= 0) {
            if (plat_kms_flips_completed(d->k) >= flip_done_at) {
                /* the flip replaced `shown`: the panel no longer reads it */
                if (d->zero_copy) release(d, shown);
                shown = flipping;
                flipping = -1;
            } else if (plat_now_ns() - flip_since > (int64_t)flip_timeout_ms * PLAT_NS_PER_MS) {
                forget_flip(d->k, flip_timeout_ms);
                if (d->zero_copy) release(d, flipping);
                flipping = -1;
            } else {
                continue; /* one flip at a time: the newest image waits for it */
            }
        }
        int idx = atomic_exchange(&d->job, -1);
        if (idx < 0) continue;
        int b = idx;
        if (!d->zero_copy) {
            b = 0;
            while (b == shown) b++;
            const warp_image_rgba8 *img = &d->sc->img[idx];
            if (img->w == d->k->ch.mode.hdisplay && img->h == d->k->ch.mode.vdisplay)
                plat_kms_copy_to_xrgb(d->buf[b].map, (int)d->buf[b].pitch, img);
            release(d, idx); /* copied: the compositor may draw into it again */
        }
        uint64_t before = plat_kms_flips_completed(d->k);
        if (!plat_kms_commit(d->k, d->buf[b].fb, err, sizeof err)) {
            if (d->zero_copy) release(d, idx);
            continue;
        }
        if (plat_kms_flips_completed(d->k) > before) { /* the modeset: shown at once */
            if (d->zero_copy) release(d, shown);
            shown = b;
        } else {
            flipping = b;
            flip_done_at = before + 1;
            flip_since = plat_now_ns();
        }
    }
    if (flipping >= 0) plat_kms_wait_flip(d->k, 100);
    return NULL;
}

static void kms_present(plat_display *base, plat_swapchain *sc, int index, int64_t vsync_ns, uint64_t vsync_no)
{
    kms_display *d = (kms_display *)base;
    (void)vsync_ns;
    (void)vsync_no;
    if (sc != d->sc) return;
    atomic_store_explicit(&sc->held[index], 1, memory_order_release);
    /* the newest image wins: one the thread has not taken yet is given back unseen */
    int old = atomic_exchange(&d->job, index);
    if (old >= 0) {
        release(d, old);
        atomic_fetch_add(&d->dropped, 1);
    }
    plat_kms_kick(d->k); /* a semaphore post: never blocks */
}

static void kms_flush(plat_display *base)
{
    kms_display *d = (kms_display *)base;
    for (int i = 0; i < 200 && atomic_load(&d->job) >= 0; i++) plat_sleep_ns(PLAT_NS_PER_MS);
}

static void kms_describe(plat_display *base, char *buf, int len)
{
    kms_display *d = (kms_display *)base;
    plat_kms_stats st;
    plat_kms_stats_get(d->k, &st);
    snprintf(buf, (size_t)len, "KMS dumb buffers on %s %dx%d@%.0f (%s, %s%s), %llu images replaced before shown",
             st.connector, st.w, st.h, st.hz, st.api, st.format,
             d->zero_copy ? ", zero copy" : ", R/B swapped while copying", (unsigned long long)atomic_load(&d->dropped));
}

static void kms_destroy(plat_display *base)
{
    kms_display *d = (kms_display *)base;
    if (d->th) {
        atomic_store(&d->quit, true);
        plat_kms_kick(d->k);
        pthread_join(d->th, NULL);
    }
    /* the CRTC back to its owner first, so no buffer is scanned out while it goes */
    plat_kms_close(d->k);
    for (int i = 0; d->zero_copy && i < d->sc->count; i++) {
        if (d->own_img[i].px) d->sc->img[i] = d->own_img[i];
        atomic_store(&d->sc->held[i], 0);
    }
    /* closing the device freed the framebuffers and buffers; the mappings kept their memory until now */
    for (int i = 0; i < d->nbuf; i++)
        if (d->buf[i].map) munmap(d->buf[i].map, d->buf[i].size);
    free(d);
}

plat_display *plat_display_kms_create(plat_kms *k, plat_swapchain *sc, char *err, int errlen)
{
    kms_display *d = calloc(1, sizeof *d);
    if (!d) {
        plat_kms_close(k);
        warp_err(err, errlen, "KMS: out of memory");
        return NULL;
    }
    d->k = k;
    d->sc = sc;
    atomic_store(&d->job, -1);
    const int fd = plat_kms_fd(k), w = k->ch.mode.hdisplay, h = k->ch.mode.vdisplay;
    char e[200] = "";
    bool ok = sc->count > 0 && sc->img[0].w == w && sc->img[0].h == h;
    if (!ok) snprintf(e, sizeof e, "the mode is %dx%d, the swapchain %dx%d", w, h, sc->img[0].w, sc->img[0].h);
    /* XBGR8888 is RGBA8 in memory: the compositor draws straight into the scanout buffers */
    d->zero_copy = ok && plat_kms_plane_has_format(k, DRM_FORMAT_XBGR8888);
    uint32_t fourcc = d->zero_copy ? DRM_FORMAT_XBGR8888 : DRM_FORMAT_XRGB8888;
    if (ok && !d->zero_copy && !plat_kms_plane_has_format(k, DRM_FORMAT_XRGB8888)) {
        snprintf(e, sizeof e, "the primary plane offers neither XBGR8888 nor XRGB8888");
        ok = false;
    }
    d->nbuf = d->zero_copy ? sc->count : KMS_OWN_BUFFERS;
    for (int i = 0; ok && i < d->nbuf; i++)
        ok = dumb_create(fd, w, h, &d->buf[i], e, sizeof e) && dumb_fb(fd, w, h, fourcc, &d->buf[i], e, sizeof e);
    for (int i = 0; ok && d->zero_copy && i < d->nbuf; i++)
        if (d->buf[i].pitch % sizeof(warp_rgba8)) d->zero_copy = false; /* never seen; stay safe */
    if (ok && d->zero_copy) {
        for (int i = 0; i < sc->count; i++) {
            d->own_img[i] = sc->img[i];
            warp_image_rgba8 m = {w, h, (int)(d->buf[i].pitch / sizeof(warp_rgba8)), (warp_rgba8 *)(void *)d->buf[i].map};
            plat_kms_copy_to_xbgr(d->buf[i].map, (int)d->buf[i].pitch, &sc->img[i]);
            sc->img[i] = m;
        }
    } else if (ok) {
        for (int i = 0; i < d->nbuf; i++) memset(d->buf[i].map, 0, d->buf[i].size); /* black until the first frame */
    }
    if (ok && pthread_create(&d->th, NULL, kms_thread, d) != 0) {
        snprintf(e, sizeof e, "cannot start the KMS thread");
        ok = false;
    }
    if (!ok) {
        for (int i = 0; d->zero_copy && i < sc->count; i++)
            if (d->own_img[i].px) sc->img[i] = d->own_img[i];
        for (int i = 0; i < d->nbuf; i++) dumb_free(fd, &d->buf[i]);
        plat_kms_close(k);
        free(d);
        warp_err(err, errlen, "KMS dumb buffers: %s", e);
        return NULL;
    }
    plat_kms_set_format(k, fourcc);
    d->base.name = "kms";
    d->base.present = kms_present;
    d->base.flush = kms_flush;
    d->base.describe = kms_describe;
    d->base.destroy = kms_destroy;
    return &d->base;
}

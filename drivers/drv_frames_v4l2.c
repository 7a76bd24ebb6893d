/* SPDX-License-Identifier: MIT */
/* drv_frames_v4l2: host frames captured over V4L2 (HDMI/CSI capture of the host's video output) in the in-band
 * layout of drv_v4l2_inband over a device-operations seam (its mock: drv_frames_v4l2_mock.c), and the host tool's
 * output writer. */
#include "drivers/drv_frames_v4l2.h"

#include <errno.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include "drivers/drv_v4l2_convert.h"
#include "drivers/drv_v4l2_inband.h"
#include "platform/plat_clock.h"

#define NBUF DRV_V4L2_NBUF
#define REOPEN_NS (500 * PLAT_NS_PER_MS)

/* ---- device operations: the only layer the mock (drv_frames_v4l2_mock.c) replaces ---- */

typedef drv_v4l2_dev_ops dev_ops;

static int real_open(void *ctx, const char *path, int flags)
{
    (void)ctx;
    return open(path, flags);
}
static int real_close(void *ctx, int fd)
{
    (void)ctx;
    return close(fd);
}
static int real_ioctl(void *ctx, int fd, unsigned long req, void *arg)
{
    (void)ctx;
    int r;
    do r = ioctl(fd, req, arg);
    while (r < 0 && errno == EINTR);
    return r;
}
static void *real_mmap(void *ctx, size_t len, int fd, off_t off)
{
    (void)ctx;
    return mmap(NULL, len, PROT_READ | PROT_WRITE, MAP_SHARED, fd, off);
}
static int real_munmap(void *ctx, void *p, size_t len)
{
    (void)ctx;
    return munmap(p, len);
}
static int real_poll(void *ctx, int fd, short events, int timeout_ms, short *revents)
{
    (void)ctx;
    struct pollfd pfd = {fd, events, 0};
    int r = poll(&pfd, 1, timeout_ms);
    *revents = pfd.revents;
    return r;
}
static const dev_ops real_ops = {real_open, real_close, real_ioctl, real_mmap, real_munmap, real_poll, NULL};

/* ---- shared pieces of capture and output ---- */

static void msg(char *err, int errlen, const char *fmt, ...)
{
    if (!err || errlen <= 0) return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err, (size_t)errlen, fmt, ap);
    va_end(ap);
}

/* Our formats in order of preference: YUV first (what HDMI bridges such as the TC358743 deliver natively, and half
 * the bytes of BGR32), then the RGB ones. */
static const uint32_t preference[] = {V4L2_PIX_FMT_YUYV, V4L2_PIX_FMT_NV12, V4L2_PIX_FMT_XBGR32, V4L2_PIX_FMT_BGR32,
                                      V4L2_PIX_FMT_RGB24};

/* Picks the pixel format: want (0 = auto) among what ENUM_FMT lists for buffer type `type`. BGR32 and XBGR32 have
 * the same bytes, so either satisfies a request for the other. Returns 0 when nothing fits. */
static uint32_t choose_format(const dev_ops *ops, void *ctx, int fd, uint32_t type, uint32_t want, char *offered,
                              int offeredlen)
{
    uint32_t have[32];
    int n = 0;
    offered[0] = 0;
    for (uint32_t i = 0; n < 32; i++) {
        struct v4l2_fmtdesc d;
        memset(&d, 0, sizeof d);
        d.index = i;
        d.type = type;
        if (ops->ioctl(ctx, fd, VIDIOC_ENUM_FMT, &d) < 0) break;
        have[n++] = d.pixelformat;
        char fc[8];
        size_t len = strlen(offered);
        snprintf(offered + len, (size_t)offeredlen - len, "%s%s", len ? " " : "", drv_v4l2_fourcc_str(d.pixelformat, fc));
    }
    for (size_t k = 0; k < sizeof preference / sizeof preference[0]; k++) {
        uint32_t f = preference[k];
        bool wanted = !want || f == want ||
                      ((want == V4L2_PIX_FMT_BGR32 || want == V4L2_PIX_FMT_XBGR32) &&
                       (f == V4L2_PIX_FMT_BGR32 || f == V4L2_PIX_FMT_XBGR32));
        if (!wanted) continue;
        for (int i = 0; i < n; i++)
            if (have[i] == f) return f;
    }
    return 0;
}

/* Y'CbCr encoding the driver reports (defaults resolved as the kernel does). */
static drv_v4l2_colorspace colorspace_of(const struct v4l2_pix_format *pf)
{
    drv_v4l2_colorspace cs = DRV_V4L2_CS_DEFAULT;
    unsigned enc = pf->ycbcr_enc ? pf->ycbcr_enc : V4L2_MAP_YCBCR_ENC_DEFAULT(pf->colorspace);
    if (enc == V4L2_YCBCR_ENC_709) cs.matrix = DRV_V4L2_BT709;
    unsigned q = pf->quantization ? pf->quantization : V4L2_MAP_QUANTIZATION_DEFAULT(false, pf->colorspace, enc);
    cs.full_range = q == V4L2_QUANTIZATION_FULL_RANGE;
    return cs;
}

/* Format parameter -> fourcc (0 = auto); false for an unknown name. */
static bool parse_format(const char *s, uint32_t *f)
{
    *f = 0;
    if (!s || !s[0] || strcasecmp(s, "auto") == 0) return true;
    *f = drv_v4l2_fourcc_parse(s);
    return *f != 0;
}

/* S_FMT for the layout's size; checks what the driver made of it. A capture bridge keeps the incoming video mode,
 * so a larger frame is fine (the layout sits in its top-left corner), a smaller or different format is not. */
static bool set_format(const dev_ops *ops, void *ctx, int fd, const char *dev, uint32_t type, uint32_t fourcc, int w,
                       int h, drv_v4l2_geom *g, drv_v4l2_colorspace *cs, char *err, int errlen)
{
    struct v4l2_format fmt;
    memset(&fmt, 0, sizeof fmt);
    fmt.type = type;
    fmt.fmt.pix.width = (uint32_t)w;
    fmt.fmt.pix.height = (uint32_t)h;
    fmt.fmt.pix.pixelformat = fourcc;
    fmt.fmt.pix.field = V4L2_FIELD_NONE;
    /* What the band, colour and depth are written with (an output device honours it; capture reports its own). */
    fmt.fmt.pix.colorspace = V4L2_COLORSPACE_SMPTE170M;
    fmt.fmt.pix.ycbcr_enc = V4L2_YCBCR_ENC_601;
    fmt.fmt.pix.quantization = V4L2_QUANTIZATION_LIM_RANGE;
    char fc[8], fc2[8];
    if (ops->ioctl(ctx, fd, VIDIOC_S_FMT, &fmt) < 0) {
        msg(err, errlen, "%s: VIDIOC_S_FMT %s %dx%d: %s", dev, drv_v4l2_fourcc_str(fourcc, fc), w, h, strerror(errno));
        return false;
    }
    const struct v4l2_pix_format *pf = &fmt.fmt.pix;
    if (pf->pixelformat != fourcc) {
        msg(err, errlen, "%s: asked for %s, driver set %s", dev, drv_v4l2_fourcc_str(fourcc, fc),
            drv_v4l2_fourcc_str(pf->pixelformat, fc2));
        return false;
    }
    if ((int)pf->width < w || (int)pf->height < h) {
        msg(err, errlen, "%s: frames are %ux%u, the layout (eyes and band) needs at least %dx%d", dev, pf->width,
            pf->height, w, h);
        return false;
    }
    if (pf->field != V4L2_FIELD_NONE && pf->field != V4L2_FIELD_ANY) {
        msg(err, errlen, "%s: interlaced video (field %u) is not supported", dev, pf->field);
        return false;
    }
    if (!drv_v4l2_geom_init(g, fourcc, (int)pf->width, (int)pf->height, (int)pf->bytesperline)) {
        msg(err, errlen, "%s: unusable geometry %ux%u, bytesperline %u", dev, pf->width, pf->height, pf->bytesperline);
        return false;
    }
    if (pf->sizeimage > g->size) g->size = pf->sizeimage;
    *cs = colorspace_of(pf);
    return true;
}

typedef struct {
    void *p;
    size_t len;
} mapped;

/* REQBUFS + QUERYBUF + mmap of NBUF buffers. Returns how many were mapped (0 on failure, err set). */
static int map_buffers(const dev_ops *ops, void *ctx, int fd, const char *dev, uint32_t type, size_t need, mapped *b,
                       char *err, int errlen)
{
    struct v4l2_requestbuffers rb;
    memset(&rb, 0, sizeof rb);
    rb.count = NBUF;
    rb.type = type;
    rb.memory = V4L2_MEMORY_MMAP;
    if (ops->ioctl(ctx, fd, VIDIOC_REQBUFS, &rb) < 0) {
        msg(err, errlen, "%s: VIDIOC_REQBUFS (mmap): %s", dev, strerror(errno));
        return 0;
    }
    if (rb.count < 2) {
        msg(err, errlen, "%s: driver granted %u buffers, need at least 2", dev, rb.count);
        return 0;
    }
    int n = rb.count < NBUF ? (int)rb.count : NBUF;
    for (int i = 0; i < n; i++) {
        struct v4l2_buffer vb;
        memset(&vb, 0, sizeof vb);
        vb.index = (uint32_t)i;
        vb.type = type;
        vb.memory = V4L2_MEMORY_MMAP;
        if (ops->ioctl(ctx, fd, VIDIOC_QUERYBUF, &vb) < 0) {
            msg(err, errlen, "%s: VIDIOC_QUERYBUF %d: %s", dev, i, strerror(errno));
            return 0;
        }
        if (vb.length < need) {
            msg(err, errlen, "%s: buffer %d holds %u bytes, the format needs %zu", dev, i, vb.length, need);
            return 0;
        }
        b[i].p = ops->mmap(ctx, vb.length, fd, (off_t)vb.m.offset);
        if (b[i].p == MAP_FAILED) {
            b[i].p = NULL;
            msg(err, errlen, "%s: mmap of buffer %d: %s", dev, i, strerror(errno));
            return 0;
        }
        b[i].len = vb.length;
    }
    return n;
}

static void unmap_buffers(const dev_ops *ops, void *ctx, mapped *b, int n)
{
    for (int i = 0; i < n; i++)
        if (b[i].p) ops->munmap(ctx, b[i].p, b[i].len), b[i].p = NULL;
}

static int queue_buffer(const dev_ops *ops, void *ctx, int fd, uint32_t type, int index, uint32_t bytesused)
{
    struct v4l2_buffer vb;
    memset(&vb, 0, sizeof vb);
    vb.index = (uint32_t)index;
    vb.type = type;
    vb.memory = V4L2_MEMORY_MMAP;
    vb.bytesused = bytesused;
    vb.field = V4L2_FIELD_NONE;
    return ops->ioctl(ctx, fd, VIDIOC_QBUF, &vb);
}

/* ---- capture backend ---- */

typedef struct {
    drv_frames base;
    drv_frames_v4l2_params p;
    const dev_ops *ops;
    void *ctx;
    void *owned;          /* ctx, destroyed with the source (ops->destroy) */
    uint32_t want;        /* 0 = auto */
    drv_v4l2_layout_info layout;
    int fd;
    drv_v4l2_geom g;
    drv_v4l2_colorspace cs;
    mapped buf[NBUF];
    int nbuf;
    int64_t next_open_ns;
    pthread_mutex_t lock; /* guards st */
    drv_frames_v4l2_stats st;
} v4l2_cap;

static void cap_error(v4l2_cap *c, const char *fmt, ...)
{
    pthread_mutex_lock(&c->lock);
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(c->st.last_error, sizeof c->st.last_error, fmt, ap);
    va_end(ap);
    pthread_mutex_unlock(&c->lock);
}

static void cap_stop(v4l2_cap *c)
{
    if (c->fd < 0) return;
    int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    c->ops->ioctl(c->ctx, c->fd, VIDIOC_STREAMOFF, &type);
    unmap_buffers(c->ops, c->ctx, c->buf, c->nbuf);
    c->nbuf = 0;
    c->ops->close(c->ctx, c->fd);
    c->fd = -1;
    pthread_mutex_lock(&c->lock);
    c->st.connected = false;
    pthread_mutex_unlock(&c->lock);
}

static bool cap_start(v4l2_cap *c, char *err, int errlen)
{
    const char *dev = c->p.device;
    c->fd = c->ops->open(c->ctx, dev, O_RDWR | O_NONBLOCK | O_CLOEXEC);
    if (c->fd < 0) {
        msg(err, errlen, "%s: cannot open the capture device: %s", dev, strerror(errno));
        return false;
    }
    struct v4l2_capability cap;
    memset(&cap, 0, sizeof cap);
    if (c->ops->ioctl(c->ctx, c->fd, VIDIOC_QUERYCAP, &cap) < 0) {
        msg(err, errlen, "%s: VIDIOC_QUERYCAP: %s (not a V4L2 device?)", dev, strerror(errno));
        goto fail;
    }
    uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
    if (!(caps & V4L2_CAP_VIDEO_CAPTURE) || !(caps & V4L2_CAP_STREAMING)) {
        msg(err, errlen, "%s (%.32s): not a single-planar streaming video capture device (caps 0x%08x)%s", dev,
            (const char *)cap.card, caps,
            (caps & V4L2_CAP_VIDEO_CAPTURE_MPLANE) ? "; multi-planar capture is not supported" : "");
        goto fail;
    }
    char offered[160], fc[8];
    uint32_t f = choose_format(c->ops, c->ctx, c->fd, V4L2_BUF_TYPE_VIDEO_CAPTURE, c->want, offered, sizeof offered);
    if (!f) {
        msg(err, errlen, "%s: offers [%s], none of which is %s", dev, offered,
            c->want ? drv_v4l2_fourcc_str(c->want, fc) : "YUYV, NV12, XBGR32/BGR32 or RGB24");
        goto fail;
    }
    if (!set_format(c->ops, c->ctx, c->fd, dev, V4L2_BUF_TYPE_VIDEO_CAPTURE, f, c->layout.width, c->layout.height,
                    &c->g, &c->cs, err, errlen))
        goto fail;
    c->nbuf = map_buffers(c->ops, c->ctx, c->fd, dev, V4L2_BUF_TYPE_VIDEO_CAPTURE,
                          drv_v4l2_image_size(c->g.fourcc, c->g.height, c->g.bytesperline), c->buf, err, errlen);
    if (!c->nbuf) goto fail;
    for (int i = 0; i < c->nbuf; i++)
        if (queue_buffer(c->ops, c->ctx, c->fd, V4L2_BUF_TYPE_VIDEO_CAPTURE, i, 0) < 0) {
            msg(err, errlen, "%s: VIDIOC_QBUF: %s", dev, strerror(errno));
            goto fail;
        }
    int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (c->ops->ioctl(c->ctx, c->fd, VIDIOC_STREAMON, &type) < 0) {
        msg(err, errlen, "%s: VIDIOC_STREAMON: %s (no signal?)", dev, strerror(errno));
        goto fail;
    }
    pthread_mutex_lock(&c->lock);
    c->st.connected = true;
    snprintf(c->st.format, sizeof c->st.format, "%s %dx%d (bpl %d), %s %s range, %d buffers",
             drv_v4l2_fourcc_str(c->g.fourcc, fc), c->g.width, c->g.height, c->g.bytesperline,
             c->cs.matrix == DRV_V4L2_BT709 ? "BT.709" : "BT.601", c->cs.full_range ? "full" : "limited", c->nbuf);
    pthread_mutex_unlock(&c->lock);
    return true;
fail:
    cap_stop(c);
    return false;
}

/* The device went away or failed: close it; receive() reopens it at most every REOPEN_NS. */
static int cap_lost(v4l2_cap *c, const char *what, int e)
{
    cap_error(c, "%s: %s: %s; reopening every %d ms", c->p.device, what, strerror(e), (int)(REOPEN_NS / PLAT_NS_PER_MS));
    cap_stop(c);
    c->next_open_ns = plat_now_ns() + REOPEN_NS;
    pthread_mutex_lock(&c->lock);
    c->st.io_errors++;
    c->st.rejected[DRV_FRAME_ERR_IO]++;
    pthread_mutex_unlock(&c->lock);
    return -DRV_FRAME_ERR_IO;
}

static int cap_reject(v4l2_cap *c, int index, drv_frame_err e, const char *why)
{
    cap_error(c, "%s: frame rejected: %s: %s", c->p.device, drv_frame_err_str(e), why);
    pthread_mutex_lock(&c->lock);
    c->st.rejected[e]++;
    pthread_mutex_unlock(&c->lock);
    if (queue_buffer(c->ops, c->ctx, c->fd, V4L2_BUF_TYPE_VIDEO_CAPTURE, index, 0) < 0) cap_lost(c, "VIDIOC_QBUF", errno);
    return -(int)e;
}

static int cap_receive(drv_frames *fr, drv_frame *f, int timeout_ms)
{
    v4l2_cap *c = (v4l2_cap *)fr;
    if (c->fd < 0) {
        int64_t now = plat_now_ns();
        if (now < c->next_open_ns) {
            int64_t until = now + (int64_t)timeout_ms * PLAT_NS_PER_MS;
            plat_sleep_until_ns(c->next_open_ns < until ? c->next_open_ns : until);
            if (plat_now_ns() < c->next_open_ns) return 0;
        }
        c->next_open_ns = plat_now_ns() + REOPEN_NS;
        char err[200];
        if (!cap_start(c, err, sizeof err)) {
            cap_error(c, "%s", err);
            pthread_mutex_lock(&c->lock);
            c->st.io_errors++;
            c->st.rejected[DRV_FRAME_ERR_IO]++;
            pthread_mutex_unlock(&c->lock);
            return -DRV_FRAME_ERR_IO;
        }
        pthread_mutex_lock(&c->lock);
        c->st.reconnects++;
        pthread_mutex_unlock(&c->lock);
    }
    short rev = 0;
    int r = c->ops->poll(c->ctx, c->fd, POLLIN, timeout_ms, &rev);
    if (r < 0) return errno == EINTR ? 0 : cap_lost(c, "poll", errno);
    if (r == 0) return 0;
    if (rev & POLLNVAL) return cap_lost(c, "poll", EBADF);

    /* Take the newest completed buffer; older ones go straight back (the warps want the latest frame). */
    struct v4l2_buffer vb;
    memset(&vb, 0, sizeof vb);
    int have = -1;
    for (;;) {
        struct v4l2_buffer b;
        memset(&b, 0, sizeof b);
        b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        b.memory = V4L2_MEMORY_MMAP;
        if (c->ops->ioctl(c->ctx, c->fd, VIDIOC_DQBUF, &b) < 0) {
            if (errno == EAGAIN) break;
            return cap_lost(c, "VIDIOC_DQBUF", errno);
        }
        if (b.index >= (uint32_t)c->nbuf) return cap_lost(c, "VIDIOC_DQBUF (bad buffer index)", EINVAL);
        if (have >= 0) {
            if (queue_buffer(c->ops, c->ctx, c->fd, V4L2_BUF_TYPE_VIDEO_CAPTURE, have, 0) < 0)
                return cap_lost(c, "VIDIOC_QBUF", errno);
            pthread_mutex_lock(&c->lock);
            c->st.skipped++;
            pthread_mutex_unlock(&c->lock);
        }
        vb = b;
        have = (int)b.index;
    }
    if (have < 0) return (rev & POLLERR) ? cap_lost(c, "poll", EIO) : 0;

    int64_t now = plat_now_ns();
    if (vb.flags & V4L2_BUF_FLAG_ERROR)
        return cap_reject(c, have, DRV_FRAME_ERR_TRUNCATED, "driver flagged the buffer as corrupted");
    size_t need = drv_v4l2_image_size(c->g.fourcc, c->g.height, c->g.bytesperline);
    if (vb.bytesused && vb.bytesused < need) {
        char why[80];
        snprintf(why, sizeof why, "%u bytes, the format needs %zu", vb.bytesused, need);
        return cap_reject(c, have, DRV_FRAME_ERR_TRUNCATED, why);
    }
    char why[160];
    drv_frame_err e = drv_v4l2_unpack(c->buf[have].p, &c->g, &c->cs, f, why, sizeof why);
    if (e == DRV_FRAME_OK) {
        e = drv_frame_validate(f);
        if (e) snprintf(why, sizeof why, "drv_frame_validate");
    }
    if (e != DRV_FRAME_OK) return cap_reject(c, have, e, why);
    /* The buffer's timestamp is when the frame was complete (V4L2 default: end of frame), if on our clock. A driver's
     * timestamp is checked before it is multiplied (a huge tv_sec would overflow) and must not lie in the future. */
    f->received_ns = now;
    if ((vb.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC &&
        (vb.timestamp.tv_sec || vb.timestamp.tv_usec) && vb.timestamp.tv_sec >= 0 &&
        vb.timestamp.tv_sec <= now / PLAT_NS_PER_S && vb.timestamp.tv_usec >= 0 && vb.timestamp.tv_usec < 1000000) {
        int64_t t = (int64_t)vb.timestamp.tv_sec * PLAT_NS_PER_S + (int64_t)vb.timestamp.tv_usec * 1000;
        if (t <= now) f->received_ns = t;
    }
    pthread_mutex_lock(&c->lock);
    c->st.frames++;
    pthread_mutex_unlock(&c->lock);
    if (queue_buffer(c->ops, c->ctx, c->fd, V4L2_BUF_TYPE_VIDEO_CAPTURE, have, 0) < 0)
        cap_lost(c, "VIDIOC_QBUF", errno); /* the frame itself is good */
    return 1;
}

static unsigned cap_planes(drv_frames *fr)
{
    v4l2_cap *c = (v4l2_cap *)fr;
    return DRV_PLANE_COLOR | (c->p.depth ? DRV_PLANE_DEPTH : 0u);
}

static void cap_destroy(drv_frames *fr)
{
    v4l2_cap *c = (v4l2_cap *)fr;
    cap_stop(c);
    if (c->owned) c->ops->destroy(c->owned);
    pthread_mutex_destroy(&c->lock);
    free(c);
}

void drv_frames_v4l2_stats_get(drv_frames *fr, drv_frames_v4l2_stats *st)
{
    v4l2_cap *c = (v4l2_cap *)fr;
    pthread_mutex_lock(&c->lock);
    *st = c->st;
    pthread_mutex_unlock(&c->lock);
}

static void cap_last_error(drv_frames *fr, char *buf, int len)
{
    drv_frames_v4l2_stats st;
    drv_frames_v4l2_stats_get(fr, &st);
    snprintf(buf, (size_t)len, "%s", st.last_error);
}

static drv_frames *cap_create(const drv_frames_v4l2_params *p, const dev_ops *ops, void *ctx, const char *name,
                              char *err, int errlen)
{
    const char *dev = p->device[0] ? p->device : "(no device)";
    uint32_t want;
    if (!parse_format(p->format, &want)) {
        msg(err, errlen, "%s: unknown format '%s' (auto, yuyv, nv12, bgr32, rgb24)", dev, p->format);
        return NULL;
    }
    drv_v4l2_layout_info l;
    if (!drv_v4l2_layout_get(p->eye_w, p->eye_h, p->depth, &l)) {
        msg(err, errlen, "%s: eye size %dx%d has no in-band layout (even sizes, width >= %d)", dev, p->eye_w, p->eye_h,
            DRV_V4L2_MIN_EYE_W);
        return NULL;
    }
    v4l2_cap *c = calloc(1, sizeof *c);
    if (!c) {
        msg(err, errlen, "%s: out of memory", dev);
        return NULL;
    }
    c->p = *p;
    c->p.device[sizeof c->p.device - 1] = 0;
    c->ops = ops, c->ctx = ctx, c->owned = ops->destroy ? ctx : NULL;
    c->want = want;
    c->layout = l;
    c->fd = -1;
    pthread_mutex_init(&c->lock, NULL);
    c->base.name = name;
    c->base.receive = cap_receive;
    c->base.planes = cap_planes;
    c->base.destroy = cap_destroy;
    c->base.last_error = cap_last_error;
    if (!cap_start(c, err, errlen)) {
        c->owned = NULL; /* the caller destroys it */
        cap_destroy(&c->base);
        return NULL;
    }
    return &c->base;
}

drv_frames *drv_frames_v4l2_create(const drv_frames_v4l2_params *p, char *err, int errlen)
{
    return cap_create(p, &real_ops, NULL, "v4l2", err, errlen);
}

drv_frames *drv_frames_v4l2_create_on_ops(const drv_frames_v4l2_params *p, const drv_v4l2_dev_ops *ops, void *ctx,
                                          const char *name, char *err, int errlen)
{
    drv_frames *fr = cap_create(p, ops, ctx, name, err, errlen);
    if (!fr && ops->destroy) ops->destroy(ctx);
    return fr;
}

void *drv_frames_v4l2_ops_ctx(drv_frames *fr, const drv_v4l2_dev_ops *ops)
{
    v4l2_cap *c = (v4l2_cap *)fr;
    return fr && fr->receive == cap_receive && c->ops == ops ? c->ctx : NULL;
}

/* ---- output writer (host tool) ---- */

struct drv_v4l2_output {
    const dev_ops *ops;
    char device[64];
    int fd;
    bool depth;
    bool streaming;   /* mmap streaming I/O; else write() */
    bool stream_on;
    drv_v4l2_geom g;
    drv_v4l2_colorspace cs;
    mapped buf[NBUF];
    int nbuf;
    int fresh;        /* buffers never queued yet (used before dequeuing any) */
    int spare;        /* a dequeued buffer a failed pack left unqueued, or -1 */
    uint8_t *wbuf;    /* write() path */
};

drv_v4l2_output *drv_v4l2_output_open(const char *device, const char *format, int eye_w, int eye_h, bool depth,
                                      char *err, int errlen)
{
    uint32_t want;
    if (!parse_format(format, &want)) {
        msg(err, errlen, "%s: unknown format '%s' (auto, yuyv, nv12, bgr32, rgb24)", device, format);
        return NULL;
    }
    drv_v4l2_layout_info l;
    if (!drv_v4l2_layout_get(eye_w, eye_h, depth, &l)) {
        msg(err, errlen, "%s: eye size %dx%d has no in-band layout", device, eye_w, eye_h);
        return NULL;
    }
    drv_v4l2_output *o = calloc(1, sizeof *o);
    if (!o) {
        msg(err, errlen, "%s: out of memory", device);
        return NULL;
    }
    o->ops = &real_ops;
    snprintf(o->device, sizeof o->device, "%s", device);
    o->depth = depth;
    o->spare = -1;
    o->fd = o->ops->open(NULL, device, O_RDWR | O_CLOEXEC);
    if (o->fd < 0) {
        msg(err, errlen, "%s: cannot open the output device: %s", device, strerror(errno));
        free(o);
        return NULL;
    }
    struct v4l2_capability cap;
    memset(&cap, 0, sizeof cap);
    char offered[160], fc[8];
    uint32_t caps, f;
    if (o->ops->ioctl(NULL, o->fd, VIDIOC_QUERYCAP, &cap) < 0) {
        msg(err, errlen, "%s: VIDIOC_QUERYCAP: %s (not a V4L2 device?)", device, strerror(errno));
        goto fail;
    }
    caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
    if (!(caps & V4L2_CAP_VIDEO_OUTPUT) || !(caps & (V4L2_CAP_STREAMING | V4L2_CAP_READWRITE))) {
        msg(err, errlen, "%s (%.32s): not a single-planar video output device (caps 0x%08x)", device,
            (const char *)cap.card, caps);
        goto fail;
    }
    o->streaming = caps & V4L2_CAP_STREAMING;
    f = choose_format(o->ops, NULL, o->fd, V4L2_BUF_TYPE_VIDEO_OUTPUT, want, offered, sizeof offered);
    if (!f) {
        msg(err, errlen, "%s: offers [%s], none of which is %s", device, offered,
            want ? drv_v4l2_fourcc_str(want, fc) : "YUYV, NV12, XBGR32/BGR32 or RGB24");
        goto fail;
    }
    if (!set_format(o->ops, NULL, o->fd, device, V4L2_BUF_TYPE_VIDEO_OUTPUT, f, l.width, l.height, &o->g, &o->cs, err,
                    errlen))
        goto fail;
    if (o->streaming) {
        o->nbuf = map_buffers(o->ops, NULL, o->fd, device, V4L2_BUF_TYPE_VIDEO_OUTPUT, o->g.size, o->buf, err, errlen);
        if (!o->nbuf) goto fail;
        o->fresh = o->nbuf;
    } else {
        o->wbuf = malloc(o->g.size);
        if (!o->wbuf) {
            msg(err, errlen, "%s: out of memory", device);
            goto fail;
        }
    }
    return o;
fail:
    drv_v4l2_output_close(o);
    return NULL;
}

int drv_v4l2_output_write(drv_v4l2_output *o, const drv_frame *f)
{
    if (!o->streaming) {
        if (drv_v4l2_pack(f, o->depth, &o->g, &o->cs, o->wbuf) != DRV_FRAME_OK) return -EINVAL;
        size_t off = 0;
        while (off < o->g.size) {
            ssize_t n = write(o->fd, o->wbuf + off, o->g.size - off);
            if (n < 0 && errno == EINTR) continue;
            if (n <= 0) return n < 0 ? -errno : -EIO;
            off += (size_t)n;
        }
        return 0;
    }
    int index;
    if (o->spare >= 0) {
        index = o->spare;
        o->spare = -1;
    } else if (o->fresh > 0) {
        index = o->nbuf - o->fresh--;
    } else {
        /* Wait for the device to hand back a shown buffer. */
        short rev = 0;
        int r = o->ops->poll(NULL, o->fd, POLLOUT, 1000, &rev);
        if (r < 0) return -errno;
        if (r == 0) return -ETIMEDOUT;
        struct v4l2_buffer b;
        memset(&b, 0, sizeof b);
        b.type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
        b.memory = V4L2_MEMORY_MMAP;
        if (o->ops->ioctl(NULL, o->fd, VIDIOC_DQBUF, &b) < 0) return -errno;
        if (b.index >= (uint32_t)o->nbuf) return -EIO;
        index = (int)b.index;
    }
    if (drv_v4l2_pack(f, o->depth, &o->g, &o->cs, o->buf[index].p) != DRV_FRAME_OK) {
        o->spare = index; /* not queued: still ours for the next frame */
        return -EINVAL;
    }
    if (queue_buffer(o->ops, NULL, o->fd, V4L2_BUF_TYPE_VIDEO_OUTPUT, index, (uint32_t)o->g.size) < 0) return -errno;
    if (!o->stream_on) {
        int type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
        if (o->ops->ioctl(NULL, o->fd, VIDIOC_STREAMON, &type) < 0) return -errno;
        o->stream_on = true;
    }
    return 0;
}

void drv_v4l2_output_close(drv_v4l2_output *o)
{
    if (!o) return;
    if (o->fd >= 0) {
        if (o->stream_on) {
            int type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
            o->ops->ioctl(NULL, o->fd, VIDIOC_STREAMOFF, &type);
        }
        unmap_buffers(o->ops, NULL, o->buf, o->nbuf);
        o->ops->close(NULL, o->fd);
    }
    free(o->wbuf);
    free(o);
}

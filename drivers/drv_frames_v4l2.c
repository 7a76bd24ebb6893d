/* SPDX-License-Identifier: MIT */
/* drv_frames_v4l2: host frames captured over V4L2 (HDMI/CSI capture of the host's video output) in the in-band
 * layout of drv_v4l2_inband, through drv_v4l2_dev's device operations (its mock: drv_frames_v4l2_mock.c). */
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
#include "warp/warp_err.h"

#define NBUF DRV_V4L2_NBUF
#define REOPEN_NS (500 * PLAT_NS_PER_MS)

/* ---- capture backend ---- */

typedef struct {
    drv_frames base;
    drv_frames_v4l2_params p;
    const drv_v4l2_dev_ops *ops;
    void *ctx;
    void *owned;          /* ctx, destroyed with the source (ops->destroy) */
    uint32_t want;        /* 0 = auto */
    drv_v4l2_layout_info layout;
    int fd;
    drv_v4l2_geom g;
    drv_v4l2_colorspace cs;
    drv_v4l2_mapped buf[NBUF];
    int nbuf;
    int64_t next_open_ns;
    pthread_mutex_t lock; /* guards st */
    drv_frames_v4l2_stats st;
} v4l2_cap;

static void cap_error(v4l2_cap *c, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    drv_frames_vnote(&c->lock, c->st.last_error, (int)sizeof c->st.last_error, fmt, ap);
    va_end(ap);
}

static void cap_stop(v4l2_cap *c)
{
    if (c->fd < 0) return;
    int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    c->ops->ioctl(c->ctx, c->fd, VIDIOC_STREAMOFF, &type);
    drv_v4l2_unmap_buffers(c->ops, c->ctx, c->buf, c->nbuf);
    c->nbuf = 0;
    c->ops->close(c->ctx, c->fd);
    c->fd = -1;
    pthread_mutex_lock(&c->lock);
    c->st.connected = false;
    pthread_mutex_unlock(&c->lock);
}

static unsigned cap_planes(drv_frames *fr);

static bool cap_start(v4l2_cap *c, char *err, int errlen)
{
    const char *dev = c->p.device;
    c->fd = c->ops->open(c->ctx, dev, O_RDWR | O_NONBLOCK | O_CLOEXEC);
    if (c->fd < 0) {
        warp_err(err, errlen, "%s: cannot open the capture device: %s", dev, strerror(errno));
        return false;
    }
    struct v4l2_capability cap;
    memset(&cap, 0, sizeof cap);
    if (c->ops->ioctl(c->ctx, c->fd, VIDIOC_QUERYCAP, &cap) < 0) {
        warp_err(err, errlen, "%s: VIDIOC_QUERYCAP: %s (not a V4L2 device?)", dev, strerror(errno));
        goto fail;
    }
    uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
    if (!(caps & V4L2_CAP_VIDEO_CAPTURE) || !(caps & V4L2_CAP_STREAMING)) {
        warp_err(err, errlen, "%s (%.32s): not a single-planar streaming video capture device (caps 0x%08x)%s", dev,
                 (const char *)cap.card, caps,
                 (caps & V4L2_CAP_VIDEO_CAPTURE_MPLANE) ? "; multi-planar capture is not supported" : "");
        goto fail;
    }
    char offered[160], fc[8];
    uint32_t f =
        drv_v4l2_choose_format(c->ops, c->ctx, c->fd, V4L2_BUF_TYPE_VIDEO_CAPTURE, c->want, offered, sizeof offered);
    if (!f) {
        warp_err(err, errlen, "%s: offers [%s], none of which is %s", dev, offered,
                 c->want ? drv_v4l2_fourcc_str(c->want, fc) : "YUYV, NV12, XBGR32/BGR32 or RGB24");
        goto fail;
    }
    memset(&c->g, 0, sizeof c->g);
    if (!drv_v4l2_set_format(c->ops, c->ctx, c->fd, dev, V4L2_BUF_TYPE_VIDEO_CAPTURE, f, c->layout.width,
                             c->layout.height, &c->g, &c->cs, err, errlen)) {
        /* A mode too small for the layout (an HDMI bridge delivers the incoming mode): name what it would hold. */
        char why[320];
        drv_v4l2_fit fit;
        if (c->g.width > 0 && !drv_v4l2_fit_check(c->g.width, c->g.height, c->g.fourcc, c->p.eye_w, c->p.eye_h,
                                                  cap_planes(&c->base), &fit, why, sizeof why))
            warp_err(err, errlen, "%s: %s", dev, why);
        goto fail;
    }
    c->nbuf = drv_v4l2_map_buffers(c->ops, c->ctx, c->fd, dev, V4L2_BUF_TYPE_VIDEO_CAPTURE,
                                   drv_v4l2_image_size(c->g.fourcc, c->g.height, c->g.bytesperline), c->buf, err,
                                   errlen);
    if (!c->nbuf) goto fail;
    for (int i = 0; i < c->nbuf; i++)
        if (drv_v4l2_queue_buffer(c->ops, c->ctx, c->fd, V4L2_BUF_TYPE_VIDEO_CAPTURE, i, 0) < 0) {
            warp_err(err, errlen, "%s: VIDIOC_QBUF: %s", dev, strerror(errno));
            goto fail;
        }
    int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (c->ops->ioctl(c->ctx, c->fd, VIDIOC_STREAMON, &type) < 0) {
        warp_err(err, errlen, "%s: VIDIOC_STREAMON: %s (no signal?)", dev, strerror(errno));
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
    if (drv_v4l2_queue_buffer(c->ops, c->ctx, c->fd, V4L2_BUF_TYPE_VIDEO_CAPTURE, index, 0) < 0)
        cap_lost(c, "VIDIOC_QBUF", errno);
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
            if (drv_v4l2_queue_buffer(c->ops, c->ctx, c->fd, V4L2_BUF_TYPE_VIDEO_CAPTURE, have, 0) < 0)
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
    if (drv_v4l2_queue_buffer(c->ops, c->ctx, c->fd, V4L2_BUF_TYPE_VIDEO_CAPTURE, have, 0) < 0)
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

static drv_frames *cap_create(const drv_frames_v4l2_params *p, const drv_v4l2_dev_ops *ops, void *ctx, const char *name,
                              char *err, int errlen)
{
    const char *dev = p->device[0] ? p->device : "(no device)";
    uint32_t want;
    if (!drv_v4l2_parse_format(p->format, &want)) {
        warp_err(err, errlen, "%s: unknown format '%s' (auto, yuyv, nv12, bgr32, rgb24)", dev, p->format);
        return NULL;
    }
    drv_v4l2_layout_info l;
    if (!drv_v4l2_layout_get(p->eye_w, p->eye_h, p->depth, &l)) {
        warp_err(err, errlen, "%s: eye size %dx%d has no in-band layout (even sizes, width >= %d)", dev, p->eye_w,
                 p->eye_h, DRV_V4L2_MIN_EYE_W);
        return NULL;
    }
    v4l2_cap *c = calloc(1, sizeof *c);
    if (!c) {
        warp_err(err, errlen, "%s: out of memory", dev);
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
    return cap_create(p, &drv_v4l2_real_ops, NULL, "v4l2", err, errlen);
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

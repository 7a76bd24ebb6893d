/* SPDX-License-Identifier: MIT */
/* drv_v4l2_output: the host tool's side of the V4L2 link (hmdwarp-feed): a V4L2 output device (e.g. vivid's loop)
 * fed frames packed in drv_v4l2_inband's layout, by MMAP streaming or write(). Not linked into hmdwarpd. */
#include "drivers/drv_v4l2_output.h"

#include <errno.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "drivers/drv_v4l2_dev.h"
#include "drivers/drv_v4l2_inband.h"
#include "warp/warp_err.h"

struct drv_v4l2_output {
    const drv_v4l2_dev_ops *ops;
    char device[64];
    int fd;
    bool depth;
    bool streaming;   /* mmap streaming I/O; else write() */
    bool stream_on;
    drv_v4l2_geom g;
    drv_v4l2_colorspace cs;
    drv_v4l2_mapped buf[DRV_V4L2_NBUF];
    int nbuf;
    int fresh;        /* buffers never queued yet (used before dequeuing any) */
    int spare;        /* a dequeued buffer a failed pack left unqueued, or -1 */
    uint8_t *wbuf;    /* write() path */
};

drv_v4l2_output *drv_v4l2_output_open(const char *device, const char *format, int eye_w, int eye_h, bool depth,
                                      char *err, int errlen)
{
    uint32_t want;
    if (!drv_v4l2_parse_format(format, &want)) {
        warp_err(err, errlen, "%s: unknown format '%s' (auto, yuyv, nv12, bgr32, rgb24)", device, format);
        return NULL;
    }
    drv_v4l2_layout_info l;
    if (!drv_v4l2_layout_get(eye_w, eye_h, depth, &l)) {
        warp_err(err, errlen, "%s: eye size %dx%d has no in-band layout", device, eye_w, eye_h);
        return NULL;
    }
    drv_v4l2_output *o = calloc(1, sizeof *o);
    if (!o) {
        warp_err(err, errlen, "%s: out of memory", device);
        return NULL;
    }
    o->ops = &drv_v4l2_real_ops;
    snprintf(o->device, sizeof o->device, "%s", device);
    o->depth = depth;
    o->spare = -1;
    o->fd = o->ops->open(NULL, device, O_RDWR | O_CLOEXEC);
    if (o->fd < 0) {
        warp_err(err, errlen, "%s: cannot open the output device: %s", device, strerror(errno));
        free(o);
        return NULL;
    }
    struct v4l2_capability cap;
    memset(&cap, 0, sizeof cap);
    char offered[160], fc[8];
    uint32_t caps, f;
    if (o->ops->ioctl(NULL, o->fd, VIDIOC_QUERYCAP, &cap) < 0) {
        warp_err(err, errlen, "%s: VIDIOC_QUERYCAP: %s (not a V4L2 device?)", device, strerror(errno));
        goto fail;
    }
    caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
    if (!(caps & V4L2_CAP_VIDEO_OUTPUT) || !(caps & (V4L2_CAP_STREAMING | V4L2_CAP_READWRITE))) {
        warp_err(err, errlen, "%s (%.32s): not a single-planar video output device (caps 0x%08x)", device,
                 (const char *)cap.card, caps);
        goto fail;
    }
    o->streaming = caps & V4L2_CAP_STREAMING;
    f = drv_v4l2_choose_format(o->ops, NULL, o->fd, V4L2_BUF_TYPE_VIDEO_OUTPUT, want, offered, sizeof offered);
    if (!f) {
        warp_err(err, errlen, "%s: offers [%s], none of which is %s", device, offered,
                 want ? drv_v4l2_fourcc_str(want, fc) : "YUYV, NV12, XBGR32/BGR32 or RGB24");
        goto fail;
    }
    if (!drv_v4l2_set_format(o->ops, NULL, o->fd, device, V4L2_BUF_TYPE_VIDEO_OUTPUT, f, l.width, l.height, &o->g,
                             &o->cs, err, errlen))
        goto fail;
    if (o->streaming) {
        o->nbuf = drv_v4l2_map_buffers(o->ops, NULL, o->fd, device, V4L2_BUF_TYPE_VIDEO_OUTPUT, o->g.size, o->buf, err,
                                       errlen);
        if (!o->nbuf) goto fail;
        o->fresh = o->nbuf;
    } else {
        o->wbuf = malloc(o->g.size);
        if (!o->wbuf) {
            warp_err(err, errlen, "%s: out of memory", device);
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
    if (drv_v4l2_queue_buffer(o->ops, NULL, o->fd, V4L2_BUF_TYPE_VIDEO_OUTPUT, index, (uint32_t)o->g.size) < 0)
        return -errno;
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
        drv_v4l2_unmap_buffers(o->ops, NULL, o->buf, o->nbuf);
        o->ops->close(NULL, o->fd);
    }
    free(o->wbuf);
    free(o);
}

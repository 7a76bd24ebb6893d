/* SPDX-License-Identifier: MIT */
/* drv_v4l2_dev: what the board's capture and the host tool's output writer both do to a V4L2 node: the device
 * operations (the seam the capture's mock replaces), format choice and setting, MMAP buffers and queueing. */
#include "drivers/drv_v4l2_dev.h"

#include <errno.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include "warp/warp_err.h"

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
const drv_v4l2_dev_ops drv_v4l2_real_ops = {real_open, real_close, real_ioctl, real_mmap, real_munmap, real_poll, NULL};

/* Our formats in order of preference: YUV first (what HDMI bridges such as the TC358743 deliver natively, and half
 * the bytes of BGR32), then the RGB ones. */
static const uint32_t preference[] = {V4L2_PIX_FMT_YUYV, V4L2_PIX_FMT_NV12, V4L2_PIX_FMT_XBGR32, V4L2_PIX_FMT_BGR32,
                                      V4L2_PIX_FMT_RGB24};

/* Picks the pixel format: want (0 = auto) among what ENUM_FMT lists for buffer type `type`. BGR32 and XBGR32 have
 * the same bytes, so either satisfies a request for the other. Returns 0 when nothing fits. */
uint32_t drv_v4l2_choose_format(const drv_v4l2_dev_ops *ops, void *ctx, int fd, uint32_t type, uint32_t want,
                                char *offered, int offeredlen)
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
bool drv_v4l2_parse_format(const char *s, uint32_t *f)
{
    *f = 0;
    if (!s || !s[0] || strcasecmp(s, "auto") == 0) return true;
    *f = drv_v4l2_fourcc_parse(s);
    return *f != 0;
}

/* S_FMT for the layout's size; checks what the driver made of it. A capture bridge keeps the incoming video mode,
 * so a larger frame is fine (the layout sits in its top-left corner), a smaller or different format is not. */
bool drv_v4l2_set_format(const drv_v4l2_dev_ops *ops, void *ctx, int fd, const char *dev, uint32_t type,
                         uint32_t fourcc, int w, int h, drv_v4l2_geom *g, drv_v4l2_colorspace *cs, char *err,
                         int errlen)
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
        warp_err(err, errlen, "%s: VIDIOC_S_FMT %s %dx%d: %s", dev, drv_v4l2_fourcc_str(fourcc, fc), w, h,
                 strerror(errno));
        return false;
    }
    const struct v4l2_pix_format *pf = &fmt.fmt.pix;
    if (pf->pixelformat != fourcc) {
        warp_err(err, errlen, "%s: asked for %s, driver set %s", dev, drv_v4l2_fourcc_str(fourcc, fc),
                 drv_v4l2_fourcc_str(pf->pixelformat, fc2));
        return false;
    }
    if (pf->field != V4L2_FIELD_NONE && pf->field != V4L2_FIELD_ANY) {
        warp_err(err, errlen, "%s: interlaced video (field %u) is not supported", dev, pf->field);
        return false;
    }
    if (!drv_v4l2_geom_init(g, fourcc, (int)pf->width, (int)pf->height, (int)pf->bytesperline)) {
        warp_err(err, errlen, "%s: unusable geometry %ux%u, bytesperline %u", dev, pf->width, pf->height,
                 pf->bytesperline);
        return false;
    }
    if (pf->sizeimage > g->size) g->size = pf->sizeimage;
    *cs = colorspace_of(pf);
    /* Last, with g filled: the caller can then say what the mode would hold (drv_v4l2_fit_check). */
    if ((int)pf->width < w || (int)pf->height < h) {
        warp_err(err, errlen, "%s: frames are %ux%u, the layout (eyes and band) needs at least %dx%d", dev, pf->width,
                 pf->height, w, h);
        return false;
    }
    return true;
}

/* REQBUFS + QUERYBUF + mmap of DRV_V4L2_NBUF buffers. Returns how many were mapped (0 on failure, err
 * set). */
int drv_v4l2_map_buffers(const drv_v4l2_dev_ops *ops, void *ctx, int fd, const char *dev, uint32_t type, size_t need,
                         drv_v4l2_mapped *b, char *err, int errlen)
{
    struct v4l2_requestbuffers rb;
    memset(&rb, 0, sizeof rb);
    rb.count = DRV_V4L2_NBUF;
    rb.type = type;
    rb.memory = V4L2_MEMORY_MMAP;
    if (ops->ioctl(ctx, fd, VIDIOC_REQBUFS, &rb) < 0) {
        warp_err(err, errlen, "%s: VIDIOC_REQBUFS (mmap): %s", dev, strerror(errno));
        return 0;
    }
    if (rb.count < 2) {
        warp_err(err, errlen, "%s: driver granted %u buffers, need at least 2", dev, rb.count);
        return 0;
    }
    int n = rb.count < DRV_V4L2_NBUF ? (int)rb.count : DRV_V4L2_NBUF;
    for (int i = 0; i < n; i++) {
        struct v4l2_buffer vb;
        memset(&vb, 0, sizeof vb);
        vb.index = (uint32_t)i;
        vb.type = type;
        vb.memory = V4L2_MEMORY_MMAP;
        if (ops->ioctl(ctx, fd, VIDIOC_QUERYBUF, &vb) < 0) {
            warp_err(err, errlen, "%s: VIDIOC_QUERYBUF %d: %s", dev, i, strerror(errno));
            return 0;
        }
        if (vb.length < need) {
            warp_err(err, errlen, "%s: buffer %d holds %u bytes, the format needs %zu", dev, i, vb.length, need);
            return 0;
        }
        b[i].p = ops->mmap(ctx, vb.length, fd, (off_t)vb.m.offset);
        if (b[i].p == MAP_FAILED) {
            b[i].p = NULL;
            warp_err(err, errlen, "%s: mmap of buffer %d: %s", dev, i, strerror(errno));
            return 0;
        }
        b[i].len = vb.length;
    }
    return n;
}

void drv_v4l2_unmap_buffers(const drv_v4l2_dev_ops *ops, void *ctx, drv_v4l2_mapped *b, int n)
{
    for (int i = 0; i < n; i++)
        if (b[i].p) ops->munmap(ctx, b[i].p, b[i].len), b[i].p = NULL;
}

int drv_v4l2_queue_buffer(const drv_v4l2_dev_ops *ops, void *ctx, int fd, uint32_t type, int index,
                          uint32_t bytesused)
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

/* SPDX-License-Identifier: MIT */
/* drv_frames_v4l2_mock: a capture device in memory behind drv_v4l2_dev_ops (the seam the kernel's V4L2 node fills on
 * a board): formats, MMAP buffers and a queue like a driver's, filled with a simulated host's frames packed in band. */
#include "drivers/drv_frames_v4l2_mock.h"

#include <errno.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

#include "drivers/drv_v4l2_convert.h"
#include "drivers/drv_v4l2_inband.h"
#include "platform/plat_clock.h"
#include "warp/warp_err.h"

typedef enum { MB_USER = 0, MB_QUEUED, MB_DONE } mock_state;

typedef struct {
    drv_frames *host;
    drv_frame hf;        /* the host's latest frame */
    bool depth;
    int eye_w, eye_h;
    int opens;           /* open file descriptions (1 at most) */
    int fail_opens;      /* opens left to fail with ENOENT (unplugged) */
    bool unplugged;      /* the current fd is dead: POLLERR, DQBUF ENODEV */
    bool garble, blank;
    int corrupt_every;   /* [mock] corrupt_every: every Nth frame damaged, a flipped block and a blank in turn */
    uint64_t packed;     /* frames the host delivered into a buffer */
    drv_v4l2_geom g;
    drv_v4l2_colorspace cs;
    bool fmt_set, streaming;
    int nbuf;
    struct {
        uint8_t *mem;
        size_t len;
        mock_state st;
        uint64_t order;  /* FIFO order of QBUF / completion */
        struct v4l2_buffer info;
    } b[DRV_V4L2_NBUF];
    uint64_t ticket;
    uint32_t sequence;
} mock_dev;

static const uint32_t mock_formats[] = {V4L2_PIX_FMT_RGB24, V4L2_PIX_FMT_XBGR32, V4L2_PIX_FMT_NV12, V4L2_PIX_FMT_YUYV};
#define MOCK_FD 42
#define MOCK_OFFSET_STEP (1u << 24)

static void mock_release_buffers(mock_dev *m)
{
    for (int i = 0; i < m->nbuf; i++) free(m->b[i].mem);
    memset(m->b, 0, sizeof m->b);
    m->nbuf = 0;
    m->streaming = false;
}

static int mock_open(void *ctx, const char *path, int flags)
{
    (void)path, (void)flags;
    mock_dev *m = ctx;
    if (m->fail_opens > 0) {
        m->fail_opens--;
        errno = ENOENT;
        return -1;
    }
    if (m->opens) {
        errno = EBUSY;
        return -1;
    }
    m->opens = 1;
    m->unplugged = false;
    return MOCK_FD;
}

static int mock_close(void *ctx, int fd)
{
    mock_dev *m = ctx;
    if (fd != MOCK_FD || !m->opens) {
        errno = EBADF;
        return -1;
    }
    m->opens = 0;
    mock_release_buffers(m);
    m->fmt_set = false;
    return 0;
}

static int mock_fail(int e)
{
    errno = e;
    return -1;
}

static int mock_ioctl(void *ctx, int fd, unsigned long req, void *arg)
{
    mock_dev *m = ctx;
    if (fd != MOCK_FD || !m->opens) return mock_fail(EBADF);
    if (m->unplugged && req != VIDIOC_STREAMOFF && req != VIDIOC_REQBUFS) return mock_fail(ENODEV);
    switch (req) {
    case VIDIOC_QUERYCAP: {
        struct v4l2_capability *c = arg;
        memset(c, 0, sizeof *c);
        snprintf((char *)c->driver, sizeof c->driver, "hmdwarp-mock");
        snprintf((char *)c->card, sizeof c->card, "simulated HDMI capture");
        c->device_caps = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING;
        c->capabilities = c->device_caps | V4L2_CAP_DEVICE_CAPS;
        return 0;
    }
    case VIDIOC_ENUM_FMT: {
        struct v4l2_fmtdesc *d = arg;
        if (d->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return mock_fail(EINVAL);
        if (d->index >= sizeof mock_formats / sizeof mock_formats[0]) return mock_fail(EINVAL);
        d->pixelformat = mock_formats[d->index];
        return 0;
    }
    case VIDIOC_S_FMT:
    case VIDIOC_G_FMT: {
        struct v4l2_format *f = arg;
        if (f->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return mock_fail(EINVAL);
        if (req == VIDIOC_S_FMT) {
            if (m->nbuf) return mock_fail(EBUSY);
            uint32_t pf = f->fmt.pix.pixelformat;
            bool ok = false;
            for (size_t i = 0; i < sizeof mock_formats / sizeof mock_formats[0]; i++) ok = ok || mock_formats[i] == pf;
            if (!ok) pf = V4L2_PIX_FMT_YUYV; /* drivers substitute a format they have */
            /* Like an HDMI bridge, the size is the incoming video mode (the host's layout), not what was asked. */
            int w, h;
            drv_v4l2_layout(m->eye_w, m->eye_h, m->depth, &w, &h);
            /* A padded stride, as DMA engines like, so stride handling is exercised. */
            int bpl = (drv_v4l2_min_bytesperline(pf, w) + 63) / 64 * 64 + 64;
            drv_v4l2_geom_init(&m->g, pf, w, h, bpl);
            m->cs = DRV_V4L2_CS_DEFAULT;
            m->fmt_set = true;
        } else if (!m->fmt_set) {
            return mock_fail(EINVAL);
        }
        memset(&f->fmt.pix, 0, sizeof f->fmt.pix);
        f->fmt.pix.width = (uint32_t)m->g.width;
        f->fmt.pix.height = (uint32_t)m->g.height;
        f->fmt.pix.pixelformat = m->g.fourcc;
        f->fmt.pix.field = V4L2_FIELD_NONE;
        f->fmt.pix.bytesperline = (uint32_t)m->g.bytesperline;
        f->fmt.pix.sizeimage = (uint32_t)m->g.size;
        bool rgb = m->g.fourcc == V4L2_PIX_FMT_RGB24 || m->g.fourcc == V4L2_PIX_FMT_XBGR32;
        f->fmt.pix.colorspace = rgb ? V4L2_COLORSPACE_SRGB : V4L2_COLORSPACE_SMPTE170M;
        f->fmt.pix.ycbcr_enc = rgb ? V4L2_YCBCR_ENC_DEFAULT : V4L2_YCBCR_ENC_601;
        f->fmt.pix.quantization = rgb ? V4L2_QUANTIZATION_FULL_RANGE : V4L2_QUANTIZATION_LIM_RANGE;
        return 0;
    }
    case VIDIOC_REQBUFS: {
        struct v4l2_requestbuffers *rb = arg;
        if (rb->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || rb->memory != V4L2_MEMORY_MMAP) return mock_fail(EINVAL);
        mock_release_buffers(m);
        if (rb->count == 0) return 0;
        if (!m->fmt_set) return mock_fail(EINVAL);
        int n = rb->count > DRV_V4L2_NBUF ? DRV_V4L2_NBUF : (int)rb->count;
        for (int i = 0; i < n; i++) {
            m->b[i].len = m->g.size;
            m->b[i].mem = calloc(1, m->g.size);
            if (!m->b[i].mem) {
                mock_release_buffers(m);
                return mock_fail(ENOMEM);
            }
        }
        m->nbuf = n;
        rb->count = (uint32_t)n;
        return 0;
    }
    case VIDIOC_QUERYBUF:
    case VIDIOC_QBUF: {
        struct v4l2_buffer *vb = arg;
        if (vb->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || vb->index >= (uint32_t)m->nbuf) return mock_fail(EINVAL);
        if (req == VIDIOC_QBUF) {
            if (m->b[vb->index].st != MB_USER) return mock_fail(EINVAL);
            m->b[vb->index].st = MB_QUEUED;
            m->b[vb->index].order = ++m->ticket;
        }
        vb->length = (uint32_t)m->b[vb->index].len;
        vb->m.offset = vb->index * MOCK_OFFSET_STEP;
        vb->memory = V4L2_MEMORY_MMAP;
        return 0;
    }
    case VIDIOC_DQBUF: {
        struct v4l2_buffer *vb = arg;
        if (vb->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return mock_fail(EINVAL);
        int best = -1;
        for (int i = 0; i < m->nbuf; i++)
            if (m->b[i].st == MB_DONE && (best < 0 || m->b[i].order < m->b[best].order)) best = i;
        if (best < 0) return mock_fail(EAGAIN); /* opened O_NONBLOCK */
        m->b[best].st = MB_USER;
        *vb = m->b[best].info;
        return 0;
    }
    case VIDIOC_STREAMON:
    case VIDIOC_STREAMOFF: {
        const int *type = arg;
        if (*type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return mock_fail(EINVAL);
        m->streaming = req == VIDIOC_STREAMON;
        if (!m->streaming)
            for (int i = 0; i < m->nbuf; i++) m->b[i].st = MB_USER;
        return 0;
    }
    default: return mock_fail(ENOTTY);
    }
}

static void *mock_mmap(void *ctx, size_t len, int fd, off_t off)
{
    mock_dev *m = ctx;
    uint32_t i = (uint32_t)(off / MOCK_OFFSET_STEP);
    if (fd != MOCK_FD || off % MOCK_OFFSET_STEP || i >= (uint32_t)m->nbuf || len > m->b[i].len) {
        errno = EINVAL;
        return MAP_FAILED;
    }
    return m->b[i].mem;
}

static int mock_munmap(void *ctx, void *p, size_t len)
{
    (void)ctx, (void)p, (void)len;
    return 0; /* the memory belongs to the mock's buffers */
}

/* A "frame interrupt": the host renders, its frame is packed into the oldest queued buffer as the HDMI link and
 * the bridge would deliver it. */
static int mock_poll(void *ctx, int fd, short events, int timeout_ms, short *revents)
{
    mock_dev *m = ctx;
    (void)events;
    *revents = 0;
    if (fd != MOCK_FD || !m->opens) {
        *revents = POLLNVAL;
        return 1;
    }
    if (m->unplugged) {
        *revents = POLLERR;
        return 1;
    }
    for (int i = 0; i < m->nbuf; i++)
        if (m->b[i].st == MB_DONE) {
            *revents = POLLIN;
            return 1;
        }
    int q = -1;
    for (int i = 0; i < m->nbuf; i++)
        if (m->b[i].st == MB_QUEUED && (q < 0 || m->b[i].order < m->b[q].order)) q = i;
    if (!m->streaming || q < 0) {
        plat_sleep_ns((int64_t)timeout_ms * PLAT_NS_PER_MS);
        return 0;
    }
    int r = drv_frames_receive(m->host, &m->hf, timeout_ms);
    if (r <= 0) return 0;
    m->packed++;
    if (m->corrupt_every > 0 && m->packed % (uint64_t)m->corrupt_every == 0) {
        /* both ways a capture goes wrong in the band: a dropped symbol (CRC) and a picture without it (magic) */
        if ((m->packed / (uint64_t)m->corrupt_every) % 2)
            m->garble = true;
        else
            m->blank = true;
    }
    uint8_t *mem = m->b[q].mem;
    if (m->blank) {
        memset(mem, 0x80, m->g.size); /* a mid-grey picture: the host is not running our renderer */
        m->blank = false;
    } else if (drv_v4l2_pack(&m->hf, m->depth, &m->g, &m->cs, mem) != DRV_FRAME_OK) {
        return 0; /* the host's frame does not fit: nothing arrives */
    }
    if (m->garble) {
        /* Invert the block of bit 1000 (past the preamble), as a dropped HDMI symbol would. */
        int bit = 1000, bx = bit % m->eye_w, by = bit / m->eye_w;
        uint8_t lv[2];
        drv_v4l2_read_luma(mem, &m->g, 2 * bx, 2 * by, 1, lv);
        lv[0] = lv[1] = lv[0] > 128 ? DRV_V4L2_LEVEL_BLACK : DRV_V4L2_LEVEL_WHITE;
        for (int k = 0; k < 2; k++) drv_v4l2_write_grey(mem, &m->g, 2 * bx, 2 * by + k, 2, lv);
        m->garble = false;
    }
    struct v4l2_buffer *vb = &m->b[q].info;
    memset(vb, 0, sizeof *vb);
    vb->index = (uint32_t)q;
    vb->type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    vb->memory = V4L2_MEMORY_MMAP;
    vb->bytesused = (uint32_t)m->g.size;
    vb->length = (uint32_t)m->b[q].len;
    vb->field = V4L2_FIELD_NONE;
    vb->sequence = m->sequence++;
    vb->flags = V4L2_BUF_FLAG_MAPPED | V4L2_BUF_FLAG_DONE | V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC |
                V4L2_BUF_FLAG_TSTAMP_SRC_EOF;
    vb->timestamp.tv_sec = (time_t)(m->hf.received_ns / PLAT_NS_PER_S);
    vb->timestamp.tv_usec = (suseconds_t)(m->hf.received_ns % PLAT_NS_PER_S / 1000);
    m->b[q].st = MB_DONE;
    m->b[q].order = ++m->ticket;
    *revents = POLLIN;
    return 1;
}

static void mock_destroy(void *ctx)
{
    mock_dev *m = ctx;
    if (!m) return;
    mock_release_buffers(m);
    drv_frames_destroy(m->host);
    drv_frame_free(&m->hf);
    free(m);
}

static const drv_v4l2_dev_ops mock_ops = {mock_open, mock_close, mock_ioctl, mock_mmap, mock_munmap, mock_poll,
                                         mock_destroy};

drv_frames *drv_frames_v4l2_create_mock(const drv_frames_sim_params *host, const drv_frames_v4l2_params *p,
                                        char *err, int errlen)
{
    if (host->cam[0].width != p->eye_w || host->cam[0].height != p->eye_h || host->cam[1].width != p->eye_w ||
        host->cam[1].height != p->eye_h) {
        warp_err(err, errlen, "v4l2 mock: host renders %dx%d, capture expects eyes of %dx%d", host->cam[0].width,
                 host->cam[0].height, p->eye_w, p->eye_h);
        return NULL;
    }
    mock_dev *m = calloc(1, sizeof *m);
    if (!m) {
        warp_err(err, errlen, "v4l2 mock: out of memory");
        return NULL;
    }
    m->eye_w = p->eye_w, m->eye_h = p->eye_h, m->depth = p->depth;
    m->host = drv_frames_sim_create(host);
    if (!m->host || !drv_frame_alloc(&m->hf, p->eye_w, p->eye_h, drv_frames_planes(m->host), 1)) {
        warp_err(err, errlen, "v4l2 mock: cannot create the simulated host");
        mock_destroy(m);
        return NULL;
    }
    drv_frames_v4l2_params mp = *p;
    if (!mp.device[0]) snprintf(mp.device, sizeof mp.device, "mock:v4l2");
    return drv_frames_v4l2_create_on_ops(&mp, &mock_ops, m, "v4l2-mock", err, errlen);
}

void drv_frames_v4l2_mock_fault(drv_frames *fr, drv_v4l2_fault fault)
{
    mock_dev *m = drv_frames_v4l2_ops_ctx(fr, &mock_ops);
    if (!m) return;
    switch (fault) {
    case DRV_V4L2_FAULT_UNPLUG:
        m->unplugged = true;
        m->fail_opens = 1;
        break;
    case DRV_V4L2_FAULT_GARBLE: m->garble = true; break;
    case DRV_V4L2_FAULT_BLANK: m->blank = true; break;
    }
}

void drv_frames_v4l2_mock_corrupt_every(drv_frames *fr, int n)
{
    mock_dev *m = drv_frames_v4l2_ops_ctx(fr, &mock_ops);
    if (m) m->corrupt_every = n > 0 ? n : 0;
}

/* SPDX-License-Identifier: MIT */
/* drv_frames_v4l2: host frames captured over V4L2 (HDMI/CSI capture of the host's video output) in the in-band
 * layout of drv_v4l2_inband, the device-operations seam below it (its mock: drv_frames_v4l2_mock.h), and the host
 * tool's output writer. */
#ifndef DRV_FRAMES_V4L2_H
#define DRV_FRAMES_V4L2_H

#include <stdbool.h>
#include <stdint.h>

#include "drivers/drv_frames.h"
#include <sys/types.h>

typedef struct {
    char device[128]; /* e.g. /dev/video0 (as long as [frames] device) */
    char format[16];  /* auto|yuyv|nv12|bgr32|rgb24 (auto: the first of these the device offers) */
    int eye_w, eye_h;
    bool depth;       /* a depth plane is packed with the colour (below it: docs/v4l2-inband.md) */
} drv_frames_v4l2_params;

/* Opens and starts the capture device. NULL with a message naming the device in err when it is missing, is no
 * streaming video capture device, offers none of the formats, or delivers frames smaller than the layout. */
drv_frames *drv_frames_v4l2_create(const drv_frames_v4l2_params *p, char *err, int errlen);
/* The lowest layer, what the backend does to a V4L2 node: every function gets the ctx given below. */
typedef struct {
    int (*open)(void *ctx, const char *path, int flags);
    int (*close)(void *ctx, int fd);
    int (*ioctl)(void *ctx, int fd, unsigned long req, void *arg); /* 0, or -1 with errno */
    void *(*mmap)(void *ctx, size_t len, int fd, off_t off);         /* MAP_FAILED with errno on failure */
    int (*munmap)(void *ctx, void *p, size_t len);
    int (*poll)(void *ctx, int fd, short events, int timeout_ms, short *revents); /* as poll(2) for one fd */
    void (*destroy)(void *ctx); /* optional: frees ctx with the source */
} drv_v4l2_dev_ops;

#define DRV_V4L2_NBUF 4 /* buffers the capture requests */

/* The capture backend on any device operations; ctx is owned from here on when ops->destroy is set (destroyed on
 * failure too). `name` (static) names the source. */
drv_frames *drv_frames_v4l2_create_on_ops(const drv_frames_v4l2_params *p, const drv_v4l2_dev_ops *ops, void *ctx,
                                          const char *name, char *err, int errlen);
/* The ctx of a source created on `ops`; NULL for any other source. */
void *drv_frames_v4l2_ops_ctx(drv_frames *fr, const drv_v4l2_dev_ops *ops);

typedef struct {
    uint64_t frames;                         /* delivered */
    uint64_t rejected[DRV_FRAME_ERR_COUNT];  /* per reason */
    uint64_t skipped;                        /* older buffers dropped in favour of a newer one */
    uint64_t io_errors;                      /* device errors and failed reopen attempts */
    uint64_t reconnects;                     /* successful reopens */
    bool connected;
    char format[128];                        /* what was negotiated, e.g. "YUYV 1280x1090 (bpl 2560), BT.601 limited" */
    char last_error[200];                    /* the latest problem, naming the device; "" if none */
} drv_frames_v4l2_stats;
/* Safe to call from another thread than receive(). */
void drv_frames_v4l2_stats_get(drv_frames *fr, drv_frames_v4l2_stats *st);

/* The host tool's side: a V4L2 output device (e.g. vivid's loop) fed packed frames. */
typedef struct drv_v4l2_output drv_v4l2_output;
drv_v4l2_output *drv_v4l2_output_open(const char *device, const char *format, int eye_w, int eye_h, bool depth,
                                      char *err, int errlen);
int drv_v4l2_output_write(drv_v4l2_output *o, const drv_frame *f); /* 0 or -errno */
void drv_v4l2_output_close(drv_v4l2_output *o);

#endif

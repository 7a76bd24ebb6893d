/* SPDX-License-Identifier: MIT */
/* drv_frames_v4l2: host frames captured over V4L2 (HDMI/CSI capture of the host's video output) in the in-band
 * layout of drv_v4l2_inband, on drv_v4l2_dev's device operations (its mock: drv_frames_v4l2_mock.h). The host
 * tool's output writer is drv_v4l2_output. */
#ifndef DRV_FRAMES_V4L2_H
#define DRV_FRAMES_V4L2_H

#include <stdbool.h>
#include <stdint.h>

#include "drivers/drv_frames.h"
#include "drivers/drv_v4l2_dev.h"

typedef struct {
    char device[128]; /* e.g. /dev/video0 (as long as [frames] device) */
    char format[16];  /* auto|yuyv|nv12|bgr32|rgb24 (auto: the first of these the device offers) */
    int eye_w, eye_h;
    bool depth;       /* a depth plane is packed with the colour (below it: docs/v4l2-inband.md) */
} drv_frames_v4l2_params;

/* Opens and starts the capture device. NULL with a message naming the device in err when it is missing, is no
 * streaming video capture device, offers none of the formats, or delivers frames smaller than the layout. */
drv_frames *drv_frames_v4l2_create(const drv_frames_v4l2_params *p, char *err, int errlen);
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

#endif

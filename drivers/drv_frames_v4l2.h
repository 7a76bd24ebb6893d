/* SPDX-License-Identifier: MIT */
/* drv_frames_v4l2: host frames captured over V4L2 (HDMI/CSI capture of the host's video output) in the in-band
 * layout of drv_v4l2_inband, a mock capture device fed by the simulated host, and the host tool's output writer. */
#ifndef DRV_FRAMES_V4L2_H
#define DRV_FRAMES_V4L2_H

#include <stdbool.h>
#include <stdint.h>

#include "drivers/drv_frames.h"
#include "drivers/drv_sim.h"

typedef struct {
    char device[128]; /* e.g. /dev/video0 (as long as [frames] device) */
    char format[16];  /* auto|yuyv|nv12|bgr32|rgb24 (auto: the first of these the device offers) */
    int eye_w, eye_h;
    bool depth;       /* a depth plane is packed with the colour (below it: docs/v4l2-inband.md) */
} drv_frames_v4l2_params;

/* Opens and starts the capture device. NULL with a message naming the device in err when it is missing, is no
 * streaming video capture device, offers none of the formats, or delivers frames smaller than the layout. */
drv_frames *drv_frames_v4l2_create(const drv_frames_v4l2_params *p, char *err, int errlen);
/* The same backend over a mock device (replacing only open/ioctl/mmap/poll) whose frames come from a simulated
 * host packed in the chosen format (auto picks YUYV: the mock offers RGB24, XBGR32, NV12 and YUYV). */
drv_frames *drv_frames_v4l2_create_mock(const drv_frames_sim_params *host, const drv_frames_v4l2_params *p,
                                        char *err, int errlen);

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

/* Mock faults for tests (no effect on a real device). */
typedef enum {
    DRV_V4L2_FAULT_UNPLUG = 1, /* the next poll reports POLLERR, DQBUF fails with ENODEV, the next open fails */
    DRV_V4L2_FAULT_GARBLE = 2, /* the next frame's band has one bit flipped (CRC error) */
    DRV_V4L2_FAULT_BLANK = 3,  /* the next frame is a plain picture without band (BAD_MAGIC) */
} drv_v4l2_fault;
void drv_frames_v4l2_mock_fault(drv_frames *fr, drv_v4l2_fault fault);
/* [mock] corrupt_every: from now on every nth frame arrives damaged, in turn GARBLE and BLANK (0 = never). */
void drv_frames_v4l2_mock_corrupt_every(drv_frames *fr, int n);

/* The host tool's side: a V4L2 output device (e.g. vivid's loop) fed packed frames. */
typedef struct drv_v4l2_output drv_v4l2_output;
drv_v4l2_output *drv_v4l2_output_open(const char *device, const char *format, int eye_w, int eye_h, bool depth,
                                      char *err, int errlen);
int drv_v4l2_output_write(drv_v4l2_output *o, const drv_frame *f); /* 0 or -errno */
void drv_v4l2_output_close(drv_v4l2_output *o);

#endif

/* SPDX-License-Identifier: MIT */
/* drv_v4l2_output: the host tool's side of the V4L2 link: frames packed in the in-band layout (drv_v4l2_inband) and
 * written to a V4L2 output device (e.g. vivid's loop into a capture node). hmdwarp-feed uses it; the board does not. */
#ifndef DRV_V4L2_OUTPUT_H
#define DRV_V4L2_OUTPUT_H

#include <stdbool.h>

#include "drivers/drv_frames.h"

typedef struct drv_v4l2_output drv_v4l2_output;
/* Opens `device`, picks the format (auto|yuyv|nv12|bgr32|rgb24) and maps its buffers. NULL with a message naming
 * the device in err when it is missing, is no single-planar output device, or offers none of the formats. */
drv_v4l2_output *drv_v4l2_output_open(const char *device, const char *format, int eye_w, int eye_h, bool depth,
                                      char *err, int errlen);
int drv_v4l2_output_write(drv_v4l2_output *o, const drv_frame *f); /* 0 or -errno */
void drv_v4l2_output_close(drv_v4l2_output *o);

#endif

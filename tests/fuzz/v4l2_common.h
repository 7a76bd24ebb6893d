/* SPDX-License-Identifier: MIT */
/* The V4L2 in-band harnesses' shared setup: eyes of 64 x 2 (the narrowest the band allows), with depth rows, in any
 * of the supported pixel formats. */
#ifndef HMDWARP_FUZZ_V4L2_COMMON_H
#define HMDWARP_FUZZ_V4L2_COMMON_H

#include <stdlib.h>
#include <string.h>

#include "drivers/drv_v4l2_inband.h"
#include "tests/fuzz/fuzz.h"

#define V4_EYE_W DRV_V4L2_MIN_EYE_W
#define V4_EYE_H 2

static const uint32_t v4_fourccs[] = {DRV_V4L2_YUYV, DRV_V4L2_NV12, DRV_V4L2_BGR32, DRV_V4L2_XBGR32, DRV_V4L2_RGB24};

/* Geometry of the video frame for format index sel (any byte), and the frame the harnesses unpack into. */
static inline void v4_setup(uint8_t sel, drv_v4l2_geom *g, drv_frame **out)
{
    static drv_frame f;
    static bool ready;
    if (!ready) {
        if (!drv_frame_alloc(&f, V4_EYE_W, V4_EYE_H, DRV_PLANE_COLOR | DRV_PLANE_DEPTH, 1)) abort();
        ready = true;
    }
    int w, h;
    if (!drv_v4l2_layout(V4_EYE_W, V4_EYE_H, true, &w, &h) ||
        !drv_v4l2_geom_init(g, v4_fourccs[sel % (sizeof v4_fourccs / sizeof v4_fourccs[0])], w, h, 0))
        abort();
    *out = &f;
}

/* Unpacks img; an accepted frame has the eye size, usable cameras and in-range times. */
static inline void v4_unpack(const uint8_t *img, const drv_v4l2_geom *g, bool bt709, drv_frame *f)
{
    drv_v4l2_colorspace cs = {bt709 ? DRV_V4L2_BT709 : DRV_V4L2_BT601, bt709};
    char why[160];
    drv_v4l2_meta m;
    drv_v4l2_read_meta(img, g, V4_EYE_W, &m, why, sizeof why);
    if (drv_v4l2_unpack(img, g, &cs, f, why, sizeof why) != DRV_FRAME_OK) return;
    /* times in [0, 2^62], as the runtime assumes (drv_framelink.h) */
    const int64_t tmax = (int64_t)1 << 62;
    if (drv_frame_validate(f) != DRV_FRAME_OK || f->pose_t_ns < 0 || f->pose_t_ns > tmax || f->render_start_ns < 0 ||
        f->render_start_ns > tmax)
        abort();
}

#endif

/* SPDX-License-Identifier: MIT */
/* drv_v4l2_inband: the in-band layout of a host frame in one video frame (HDMI/CSI capture): a metadata band of
 * luma-only bit blocks, both eyes' colour side by side, optional 16-bit depth as luma byte pairs (docs/v4l2-inband.md). */
#ifndef DRV_V4L2_INBAND_H
#define DRV_V4L2_INBAND_H

#include <stdbool.h>
#include <stdint.h>

#include "drivers/drv_frames.h"
#include "drivers/drv_v4l2_convert.h"

#define DRV_V4L2_MAGIC 0x56444D48u /* bytes "HMDV" */
#define DRV_V4L2_VERSION 1
#define DRV_V4L2_META_BYTES 260    /* serialised metadata incl. the trailing CRC32 */
#define DRV_V4L2_BLOCK 2           /* a bit is a BLOCK x BLOCK square of pixels (survives 4:2:2 and 4:2:0) */
#define DRV_V4L2_LEVEL_BLACK 16    /* bit 0 / padding luma */
#define DRV_V4L2_LEVEL_WHITE 235   /* bit 1 luma */
#define DRV_V4L2_MIN_EYE_W 64      /* the preamble (magic, eye size) must fit the first block row */
#define DRV_V4L2_DEPTH_WIRE_INV16 1 /* depth as q = round(65535 * near_z / z), 0 = infinitely far */

/* Where everything lies in the video frame (all rows even, so NV12 chroma never straddles two regions). */
typedef struct {
    int eye_w, eye_h;
    bool depth;
    int band_rows;  /* rows 0 .. band_rows-1: metadata */
    int color_y;    /* eye e's colour: x in [e*eye_w, (e+1)*eye_w), rows color_y .. color_y+eye_h-1 */
    int depth_y;    /* eye e's depth row y: high bytes in row depth_y+2y, low bytes in row depth_y+2y+1; -1: none */
    int width, height; /* the smallest video frame that holds the layout */
} drv_v4l2_layout_info;

/* The video frame size for two eyes of eye_w x eye_h (even, eye_w >= DRV_V4L2_MIN_EYE_W). False if impossible. */
bool drv_v4l2_layout(int eye_w, int eye_h, bool depth, int *img_w, int *img_h);
bool drv_v4l2_layout_get(int eye_w, int eye_h, bool depth, drv_v4l2_layout_info *l);

/* Whether a host frame fits a capture mode: the layout of two eye_w x eye_h eyes with `planes` (DRV_PLANE_COLOR,
 * optionally DRV_PLANE_DEPTH: the layout carries nothing else) in a mode_w x mode_h video mode of `fourcc`. The
 * layout sits unscaled in the mode's top-left corner, so it fits when both its sides do (bytes alone would not
 * tell: 3840x1080 holds as many as 1920x2160). Pure: the start-up check, --check-config and the docs' table. */
typedef struct {
    bool fits;
    int need_w, need_h; /* the layout's frame; 0 x 0 when the eye size or planes have no layout */
    size_t need_bytes;  /* a need_w x need_h frame of fourcc at the minimum stride */
    size_t have_bytes;  /* a mode_w x mode_h frame of fourcc at the minimum stride */
    int max_eye_w;      /* the widest eye whose layout the mode holds (even), 0 if none */
    int max_eye_h;      /* the tallest eye the mode holds at min(eye_w, max_eye_w) wide, same planes; 0 if none */
} drv_v4l2_fit;
/* Fills *fit and returns fit->fits; when it does not fit, why (may be NULL) gets one line naming the mode, eye size,
 * planes, the frame and bytes needed and those available, and the largest eyes that would fit. */
bool drv_v4l2_fit_check(int mode_w, int mode_h, uint32_t fourcc, int eye_w, int eye_h, unsigned planes,
                        drv_v4l2_fit *fit, char *why, int whylen);

/* Common HDMI capture modes (720p, 1080p, 1200p, 1440p, 4K UHD, DCI 4K), smallest first, for --check-config and
 * docs/v4l2-inband.md's table. */
typedef struct {
    const char *name;
    int w, h;
} drv_v4l2_mode;
extern const drv_v4l2_mode drv_v4l2_common_modes[];
extern const int drv_v4l2_common_mode_count;

/* Metadata as carried in the band. */
typedef struct {
    int version;
    int eye_w, eye_h;
    bool depth;                /* the depth rows hold valid depth */
    warp_depth_encoding depth_encoding; /* the encoding the unpacked depth plane gets (the host frame's) */
    uint64_t seq;
    int64_t pose_t_ns;         /* board clock: the time of the pose the board sent (the host echoes it) */
    int64_t render_start_ns;   /* board clock as far as the host knows it; 0 if unknown */
    double scene_time;         /* simulated hosts only, else 0 */
    warp_pose eye_pose[2];
    warp_camera cam[2];
} drv_v4l2_meta;

/* Packs f (colour, and depth when `depth` and f carries it) into the buffer img of geometry g, which must be at
 * least the layout's size (the rest is filled black). Colour uses cs; band and depth do not depend on it.
 * Returns DRV_FRAME_OK, BAD_FORMAT (fourcc), BAD_SIZE (buffer or planes), BAD_DEPTH (NaN / negative depth). */
drv_frame_err drv_v4l2_pack(const drv_frame *f, bool depth, const drv_v4l2_geom *g, const drv_v4l2_colorspace *cs,
                            uint8_t *img);

/* Reads the band of a buffer laid out for eyes eye_w wide. Checks magic, eye size, version, CRC, then the values
 * (finite unit poses, usable cameras). why (may be NULL) gets a one-line reason on failure. */
drv_frame_err drv_v4l2_read_meta(const uint8_t *img, const drv_v4l2_geom *g, int eye_w, drv_v4l2_meta *m,
                                 char *why, int whylen);

/* Unpacks a buffer into out, allocated by the caller with drv_frame_alloc for the eye size (colour; depth if
 * wanted). Never allocates. The eye size is out's; depth is unpacked when the band says it is there and out has a
 * depth plane. Sets seq, pose_t_ns, render_start_ns, planes, cam, eye_pose, depth_encoding, scene_time; leaves
 * received_ns to the caller. Errors: BAD_FORMAT, BAD_SIZE, BAD_MAGIC, BAD_VERSION, CRC, BAD_POSE, BAD_CAMERA. */
drv_frame_err drv_v4l2_unpack(const uint8_t *img, const drv_v4l2_geom *g, const drv_v4l2_colorspace *cs,
                              drv_frame *out, char *why, int whylen);

#endif

/* SPDX-License-Identifier: MIT */
/* drv_v4l2_convert: pixel formats of V4L2 capture/output buffers (YUYV, NV12, BGR32/XBGR32, RGB24) to and from
 * RGBA8 with integer BT.601/BT.709 limited/full-range math, plus the luma-level access the in-band layout uses. */
#ifndef DRV_V4L2_CONVERT_H
#define DRV_V4L2_CONVERT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "warp/warp_image.h"

/* Fourccs as in linux/videodev2.h (v4l2_fourcc), repeated so pure code and tests need no kernel headers. */
#define DRV_V4L2_FOURCC(a, b, c, d) \
    ((uint32_t)(a) | ((uint32_t)(b) << 8) | ((uint32_t)(c) << 16) | ((uint32_t)(d) << 24))
#define DRV_V4L2_YUYV DRV_V4L2_FOURCC('Y', 'U', 'Y', 'V')   /* Y0 Cb Y1 Cr, 4:2:2 */
#define DRV_V4L2_NV12 DRV_V4L2_FOURCC('N', 'V', '1', '2')   /* Y plane, then interleaved CbCr plane, 4:2:0 */
#define DRV_V4L2_BGR32 DRV_V4L2_FOURCC('B', 'G', 'R', '4')  /* bytes B G R X (deprecated name of XBGR32) */
#define DRV_V4L2_XBGR32 DRV_V4L2_FOURCC('X', 'R', '2', '4') /* bytes B G R X */
#define DRV_V4L2_RGB24 DRV_V4L2_FOURCC('R', 'G', 'B', '3')  /* bytes R G B */

typedef enum { DRV_V4L2_BT601 = 0, DRV_V4L2_BT709 = 1 } drv_v4l2_matrix;
/* Y'CbCr encoding of the YUV formats (ignored by the RGB ones). Limited range: Y 16..235, C 16..240. */
typedef struct {
    drv_v4l2_matrix matrix;
    bool full_range;
} drv_v4l2_colorspace;
#define DRV_V4L2_CS_DEFAULT ((drv_v4l2_colorspace){DRV_V4L2_BT601, false})

/* A buffer's geometry. NV12 here is V4L2's single-planar NV12: the CbCr plane follows the Y plane (height rows)
 * directly, with the same bytesperline. */
typedef struct {
    uint32_t fourcc;
    int width, height;
    int bytesperline;
    size_t size; /* bytes the buffer holds */
} drv_v4l2_geom;

bool drv_v4l2_fourcc_supported(uint32_t fourcc);
/* "yuyv", "nv12", "bgr32", "xbgr32", "rgb24" (any case) -> fourcc; 0 for "auto", "" or anything else. */
uint32_t drv_v4l2_fourcc_parse(const char *name);
/* Four printable characters ("YUYV"); buf holds at least 5 bytes. Returns buf. */
const char *drv_v4l2_fourcc_str(uint32_t fourcc, char *buf);
/* Smallest bytesperline for width pixels (0 for an unsupported fourcc). */
int drv_v4l2_min_bytesperline(uint32_t fourcc, int width);
/* Bytes of a buffer of `height` rows with the given stride (NV12 included its CbCr plane). */
size_t drv_v4l2_image_size(uint32_t fourcc, int height, int bytesperline);
/* Fills *g (bytesperline 0: the minimum). False for an unsupported fourcc or an impossible size. */
bool drv_v4l2_geom_init(drv_v4l2_geom *g, uint32_t fourcc, int width, int height, int bytesperline);
/* NULL when g is usable, else a static string naming what is wrong (subsampled formats need even sizes). */
const char *drv_v4l2_geom_check(const drv_v4l2_geom *g);

/* The rectangle (x0, y0, w, h) of the buffer to RGBA8 (alpha 255) at dst (dst_stride pixels per row). YUYV needs
 * even x0 and w, NV12 also even y0 and h (the caller's layout guarantees it). */
void drv_v4l2_to_rgba(const uint8_t *img, const drv_v4l2_geom *g, const drv_v4l2_colorspace *cs, int x0, int y0,
                      int w, int h, warp_rgba8 *dst, int dst_stride);
/* The reverse: w x h RGBA8 pixels (alpha ignored) into the rectangle at (x0, y0); chroma is the mean of the pixels
 * sharing a sample (2 in YUYV, 2x2 in NV12). Same alignment rules. */
void drv_v4l2_from_rgba(const warp_rgba8 *src, int src_stride, int w, int h, const drv_v4l2_colorspace *cs,
                        uint8_t *img, const drv_v4l2_geom *g, int x0, int y0);

/* Luma levels of w pixels of row y from x0: the Y byte for YUV formats, (R + 2G + B) / 4 for RGB formats (exactly
 * the level for grey pixels). */
void drv_v4l2_read_luma(const uint8_t *img, const drv_v4l2_geom *g, int x0, int y, int w, uint8_t *out);
/* Writes w grey pixels of row y from x0 with the given luma levels: Y = level with neutral chroma (128) for YUV
 * formats, R = G = B = level for RGB formats. NV12's chroma row y/2 is set neutral for the span (x0, w even). */
void drv_v4l2_write_grey(uint8_t *img, const drv_v4l2_geom *g, int x0, int y, int w, const uint8_t *level);

#endif

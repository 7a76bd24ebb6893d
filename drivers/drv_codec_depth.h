/* SPDX-License-Identifier: MIT */
/* drv_codec_depth: framelink v2's compact depth: 16-bit quantisation (INV16 inverse depth, UNORM16 window depth),
 * downsampling that keeps each block's nearest depth, and the board's colour-guided, edge-preserving upsample. */
#ifndef DRV_CODEC_DEPTH_H
#define DRV_CODEC_DEPTH_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "warp/warp_camera.h"
#include "warp/warp_image.h"

/* INV16: round(65535 * near_z / z) of linear metres. Precision follows parallax (a step is z^2 / (65535 near_z)
 * metres, a relative error of at most z / (2 * 65535 near_z)); 0 is sky (+inf, NaN). Nearer than near_z clamps
 * to 65535, a finite depth too far for a step to 1. Inline: the encoder and decoder convert every pixel of a
 * full-resolution plane with these; the rounding is lround's (half away from zero) without its libm call, as for
 * 1 <= x < 65534.5, x - trunc(x) is exact. */
static inline uint16_t drv_depth_to_inv16(float z, double near_z)
{
    if (!(z < INFINITY)) return 0; /* +inf and NaN: sky */
    if (z <= near_z) return 65535;
    const double x = 65535.0 * near_z / z;
    if (!(x >= 1.0)) return 1; /* lround gives 0 or less (or, for NaN, anything), clamped to 1 */
    if (x >= 65534.5) return 65535;
    const long v = (long)x;
    return (uint16_t)(v + (x - (double)v >= 0.5));
}
static inline float drv_depth_from_inv16(uint16_t v, double near_z) /* 0 -> +inf */
{
    return v ? (float)(65535.0 * near_z / v) : INFINITY;
}
/* UNORM16: round(d * 65535) of window depth d clamped to [0, 1], NaN as far (1); v1's format. */
uint16_t drv_depth_to_unorm16(float d);
float drv_depth_from_unorm16(uint16_t v);

/* Low-resolution size of an eye side at 1/2^scale (ceil). */
static inline int drv_depth_scaled(int side, int scale) { return (side + (1 << scale) - 1) >> scale; }

/* Downsamples src (w x h, stride in elements) to dst (drv_depth_scaled(w) x drv_depth_scaled(h), tightly packed).
 * A 2^scale block that spans a depth edge (or holds sky or NaN) keeps its nearest depth in encoding enc (linear and
 * standard: the smallest; reversed: the largest; NaN counts as far), so a thin foreground object never disappears
 * behind its background; a block of one surface (within DRV_DEPTH_EDGE_REL) keeps its mean in inverse depth, as
 * the nearest would shift a slope by up to a block. */
void drv_depth_downsample(const float *src, int w, int h, size_t stride, int scale, warp_depth_encoding enc,
                          float *dst);

/* Upsamples lo (lw x lh, tightly packed, as drv_depth_downsample wrote it) to dst (w x h, stride in elements).
 * Each full-resolution pixel looks at its 4 nearest low-resolution samples: where they agree (one surface, within
 * DRV_DEPTH_EDGE_REL in inverse depth) it interpolates bilinearly in inverse (or window) depth, which is exact for
 * planes; where they do not (a depth edge) it takes, as it is, the sample of its own block or a neighbouring one
 * whose block-centre colour is closest to its own (color NULL: the spatially nearest of the 4), so no pixel gets
 * an in-between depth floating in the gap and each edge pixel keeps its own surface's. */
#define DRV_DEPTH_EDGE_REL 0.1
/* scratch: drv_depth_upsample_scratch(lw, lh) bytes of the caller's (float-aligned), so upsampling allocates
 * nothing. */
size_t drv_depth_upsample_scratch(int lw, int lh);
void drv_depth_upsample(const float *lo, int lw, int lh, int scale, warp_depth_encoding enc,
                        const warp_image_rgba8 *color, float *dst, int w, int h, size_t stride, void *scratch);
/* The same in two steps, so bands of rows upsample on several threads: prepare (once, fills scratch), then rows
 * [row0, row1) of dst, any number of bands at once. */
void drv_depth_upsample_prepare(const float *lo, int lw, int lh, warp_depth_encoding enc, void *scratch);
void drv_depth_upsample_rows(const float *lo, int lw, int lh, int scale, warp_depth_encoding enc,
                             const warp_image_rgba8 *color, float *dst, int w, int h, size_t stride, int row0,
                             int row1, const void *scratch);

#endif

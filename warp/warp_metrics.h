/* SPDX-License-Identifier: MIT */
/* warp_metrics: image quality against ground truth: PSNR, SSIM (Wang et al. 2004, Gaussian window) and the
 * error-pixel percentage of 002 §4 (CIE Lab distance > 20), each optionally restricted by a mask. */
#ifndef WARP_METRICS_H
#define WARP_METRICS_H

#include <stdint.h>

#include "warp/warp_image.h"

/* Region selection shared by all metrics: a pixel counts unless mask != NULL and (mask value & exclude) != 0.
 * Pass a warp's own mask with exclude = WARP_MASK_FRINGE to score away from fringes. Images must be equal size. */

/* PSNR in dB over R, G, B (alpha ignored), peak 255. INFINITY when identical; NAN when no pixel counts. */
double warp_psnr(const warp_image_rgba8 *a, const warp_image_rgba8 *b, const warp_image_u8 *mask, uint8_t exclude);

/* Mean SSIM on luma (BT.601 weights) with an 11x11 Gaussian window (sigma 1.5), K1 = 0.01, K2 = 0.03, L = 255,
 * averaged over counted pixels (window centres; windows clipped at the image border). NAN when none counts. */
double warp_ssim(const warp_image_rgba8 *a, const warp_image_rgba8 *b, const warp_image_u8 *mask, uint8_t exclude);

/* Percentage (0..100) of counted pixels whose CIE76 Lab distance exceeds `threshold` (002 §4 uses 20).
 * Colours are sRGB with a D65 white point. NAN when no pixel counts. */
double warp_error_pixel_percent(const warp_image_rgba8 *a, const warp_image_rgba8 *b, const warp_image_u8 *mask,
                                uint8_t exclude, double threshold);

/* The band along the depth edges of a true depth image (linear or inverse: a relative jump is the same in both),
 * where a depth warp's silhouettes and disocclusion fills show (#21's depth-edge band): band is set to 0 at every
 * pixel within `radius` pixels (a square) of a pair of neighbours whose depths differ by more than rel_jump times the
 * nearer one, 1 elsewhere, so that a metric with exclude = 1 scores the band alone. Depths that are not positive and
 * finite (sky: INFINITY) count as beyond every finite one. Returns the band's pixel count, -1 when the sizes differ. */
long warp_depth_edge_band(const warp_image_f32 *depth, float rel_jump, int radius, warp_image_u8 *band);

/* sRGB (8-bit) -> CIE L*a*b* (D65). */
void warp_srgb_to_lab(warp_rgba8 c, double lab[3]);

#endif

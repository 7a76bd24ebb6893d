/* SPDX-License-Identifier: MIT */
/* warp_reproject: rotation reprojection of a rendered eye image to a new head orientation (003 §3.4), with the
 * clamped-texcoord fringe fill of 003 §4.3. Needs colour only; head translation is ignored (depth at infinity). */
#ifndef WARP_REPROJECT_H
#define WARP_REPROJECT_H

#include "warp/warp_camera.h"
#include "warp/warp_image.h"
#include "warp/warp_view.h"

/* Homography for warping `src` to a target eye with orientation dst_orient seen through dst_cam: maps target
 * pixels (homogeneous, centres at +0.5) to source pixels. Uses only the orientations of the two poses. */
warp_mat3 warp_reproject_homography(const warp_view *src, const warp_camera *dst_cam, warp_quat dst_orient);
/* The same after checking what it uses: the source's pose (a view whose position is not finite is a broken frame,
 * though rotation ignores positions), the target orientation and both cameras. NULL and *h set when usable, else a
 * static string naming what is wrong (a NaN orientation would otherwise give an all-fringe image without a word). */
const char *warp_reproject_prepare(warp_mat3 *h, const warp_view *src, const warp_camera *dst_cam,
                                   warp_quat dst_orient);

/* Writes rows [y0, y1) of dst (dst->w x dst->h must equal dst_cam's size) through homography h. Pixels whose
 * source position falls outside the source image, or behind it, are filled by clamping to the border (003 §4.3)
 * and flagged WARP_MASK_FRINGE in mask (mask may be NULL). Returns the number of fringe pixels written. */
long warp_reproject_rows(const warp_view *src, const warp_mat3 *h, warp_image_rgba8 *dst, warp_image_u8 *mask,
                         int y0, int y1);

#endif

/* SPDX-License-Identifier: MIT */
/* warp_reproject: rotation reprojection of a rendered eye image to a new head orientation (003 §3.4), with the
 * clamped-texcoord fringe fill of 003 §4.3. Needs colour only; head translation is ignored (depth at infinity). */
#include "warp/warp_reproject.h"

#include <math.h>

warp_mat3 warp_reproject_homography(const warp_view *src, const warp_camera *dst_cam, warp_quat dst_orient)
{
    /* 003 eq. 9, R = P H(t+1) H(t)^-1 P^-1, read backwards (target pixel -> source pixel) so that every output
     * pixel is produced exactly once: src_from_dst = q_src^-1 q_dst. */
    warp_quat src_from_dst = warp_quat_mul(warp_quat_conj(src->pose.q), dst_orient);
    return warp_rotation_homography(&src->cam, dst_cam, src_from_dst);
}

const char *warp_reproject_prepare(warp_mat3 *h, const warp_view *src, const warp_camera *dst_cam,
                                   warp_quat dst_orient)
{
    const char *bad = warp_pose_check(src->pose, WARP_POSE_SOURCE);
    if (!bad) bad = warp_orientation_check(dst_orient, WARP_POSE_TARGET);
    if (bad) return bad;
    if (!src->color) return "rotation warp needs a colour plane";
    if (warp_camera_check(&src->cam)) return "source camera is not valid";
    if (warp_camera_check(dst_cam)) return "target camera is not valid";
    *h = warp_reproject_homography(src, dst_cam, dst_orient);
    return NULL;
}

long warp_reproject_rows(const warp_view *src, const warp_mat3 *h, warp_image_rgba8 *dst, warp_image_u8 *mask,
                         int y0, int y1)
{
    const double w = src->color->w, hh = src->color->h;
    long fringe = 0;
    for (int y = y0; y < y1; y++) {
        double py = y + 0.5;
        /* The homogeneous source position is affine in x along a row: step it instead of a 3x3 product. */
        double hx = h->m[0][0] * 0.5 + h->m[0][1] * py + h->m[0][2];
        double hy = h->m[1][0] * 0.5 + h->m[1][1] * py + h->m[1][2];
        double hw = h->m[2][0] * 0.5 + h->m[2][1] * py + h->m[2][2];
        warp_rgba8 *out = &WARP_AT(dst, 0, y);
        uint8_t *m = mask ? &WARP_AT(mask, 0, y) : NULL;
        for (int x = 0; x < dst->w; x++) {
            double sx, sy;
            bool outside;
            if (hw > 1e-12) {
                double iw = 1.0 / hw;
                sx = hx * iw;
                sy = hy * iw;
                outside = !(sx >= 0 && sx <= w && sy >= 0 && sy <= hh);
            } else {
                /* Behind the source camera: no data in that direction at all; the clamp below still gives the
                 * nearest border colour, as for any other fringe pixel. */
                sx = hx > 0 ? w : 0;
                sy = hy > 0 ? hh : 0;
                outside = true;
            }
            out[x] = warp_sample_bilinear(src->color, (float)sx, (float)sy);
            if (m) m[x] = outside ? WARP_MASK_FRINGE : 0;
            fringe += outside;
            hx += h->m[0][0];
            hy += h->m[1][0];
            hw += h->m[2][0];
        }
    }
    return fringe;
}

/* SPDX-License-Identifier: MIT */
/* warp_view: a rendered eye image together with the pose and camera it was rendered with: the input of every
 * warp. Depth is held as inverse depth (1/z, 0 = infinity), which is affine in screen space along any ray. */
#include "warp/warp_view.h"

#include <math.h>

long warp_inverse_depth_from(const warp_camera *cam, warp_depth_encoding enc, const warp_image_f32 *depth,
                             warp_image_f32 *inv, float *inv_min, float *inv_max)
{
    /* Depth nearer than the near plane (a renderer's rounding, or one whose near plane is nearer than the camera's)
     * is a surface at least that near: clamped to near it stays the nearest thing in view and occludes as it should;
     * written as sky (0) it would vanish behind everything and show what is behind it through it (issue #21). */
    const double in = 1.0 / cam->near_z, inf = 1.0 / cam->far_z;
    /* Affine map d -> 1/z for the window-depth encodings (see warp_depth_to_inverse). */
    double a = 0, b = 0;
    if (enc == WARP_DEPTH_STANDARD) { a = in; b = inf - in; }
    if (enc == WARP_DEPTH_REVERSED) { a = inf; b = in - inf; }
    long bad = 0;
    float mn = INFINITY, mx = 0;
    for (int y = 0; y < depth->h; y++) {
        const float *src = &WARP_AT(depth, 0, y);
        float *dst = &WARP_AT(inv, 0, y);
        for (int x = 0; x < depth->w; x++) {
            double d = src[x], v;
            if (enc == WARP_DEPTH_LINEAR)
                v = d > 0 ? 1.0 / d : NAN; /* +INF -> 0: sky */
            else
                v = (d >= 0 && d <= 1) ? a + b * d : NAN;
            if (v > in) v = in;
            if (!(v >= 0)) {
                bad++;
                v = 0;
            }
            float f = (float)v;
            dst[x] = f;
            if (f < mn) mn = f;
            if (f > mx) mx = f;
        }
    }
    if (!(mn <= mx)) mn = mx = 0;
    *inv_min = mn;
    *inv_max = mx;
    return bad;
}

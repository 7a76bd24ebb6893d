/* SPDX-License-Identifier: MIT */
/* warp_view: a rendered eye image together with the pose and camera it was rendered with: the input of every
 * warp. Depth is held as inverse depth (1/z, 0 = infinity), which is affine in screen space along any ray. */
#include "warp/warp_view.h"

#include <math.h>
#include <string.h>

#include "warp/warp_v4.h"

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
    /* Linear depth 4 at a time (a frame's whole plane, on the frames thread): in float, which gives the same
     * values as the double path below: the quotient 1/d rounded to double and then to float is the float quotient
     * (double rounding of a division is innocuous with 53 >= 2 * 24 + 2 bits), and rounding is monotonic, so the
     * clamp to near commutes with it. Lanes that are not depths (d <= 0, NaN) become 0 and count as bad. */
    const warp_v4f vin = (warp_v4f){0} + (float)in, zero = {0};
    warp_v4f vmn = (warp_v4f){0} + INFINITY, vmx = zero;
    warp_v4i vbad = (warp_v4i){0};
    for (int y = 0; y < depth->h; y++) {
        const float *src = &WARP_AT(depth, 0, y);
        float *dst = &WARP_AT(inv, 0, y);
        int x = 0;
        for (; enc == WARP_DEPTH_LINEAR && x + 4 <= depth->w; x += 4) {
            warp_v4f d;
            memcpy(&d, src + x, sizeof d);
            const warp_v4i pos = d > 0.0f;
            warp_v4f r = 1.0f / d;
            r = warp_v4f_select(pos, warp_v4f_select(r > vin, vin, r), zero);
            vbad += pos + 1; /* pos is -1 where d is a depth */
            memcpy(dst + x, &r, sizeof r);
            vmn = warp_v4f_select(r < vmn, r, vmn);
            vmx = warp_v4f_select(r > vmx, r, vmx);
        }
        for (; x < depth->w; x++) {
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
    for (int k = 0; k < 4; k++) {
        bad += vbad[k];
        mn = vmn[k] < mn ? vmn[k] : mn;
        mx = vmx[k] > mx ? vmx[k] : mx;
    }
    if (!(mn <= mx)) mn = mx = 0;
    *inv_min = mn;
    *inv_max = mx;
    return bad;
}

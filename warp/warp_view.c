/* SPDX-License-Identifier: MIT */
/* warp_view: a rendered eye image together with the pose and camera it was rendered with: the input of every
 * warp. Depth is held as inverse depth (1/z, 0 = infinity), which is affine in screen space along any ray. */
#include "warp/warp_view.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

/* Four floats and their masks: GCC/clang vector extensions, which are SSE2 on x86-64 and NEON on aarch64 at 16
 * bytes (wider ones are split into scalars where the target lacks them). */
typedef float v4f __attribute__((vector_size(16)));
typedef int32_t v4i __attribute__((vector_size(16)));

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
    const v4f vin = (v4f){0} + (float)in;
    v4f vmn = (v4f){0} + INFINITY, vmx = (v4f){0};
    v4i vbad = (v4i){0};
    for (int y = 0; y < depth->h; y++) {
        const float *src = &WARP_AT(depth, 0, y);
        float *dst = &WARP_AT(inv, 0, y);
        int x = 0;
        for (; enc == WARP_DEPTH_LINEAR && x + 4 <= depth->w; x += 4) {
            v4f d, r;
            memcpy(&d, src + x, sizeof d);
            const v4i pos = d > 0.0f;
            r = 1.0f / d;
            const v4i big = r > vin;
            r = (v4f)((((v4i)r & ~big) | ((v4i)vin & big)) & pos);
            vbad += pos + 1; /* pos is -1 where d is a depth */
            memcpy(dst + x, &r, sizeof r);
            const v4i lo = r < vmn, hi = r > vmx;
            vmn = (v4f)(((v4i)r & lo) | ((v4i)vmn & ~lo));
            vmx = (v4f)(((v4i)r & hi) | ((v4i)vmx & ~hi));
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

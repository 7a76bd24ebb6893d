/* SPDX-License-Identifier: MIT */
/* warp_camera: per-eye asymmetric frusta from FOV tangents, pixel <-> ray mapping, depth encodings.
 * Everything that converts between pixels, tangent-space directions and depth goes through here. */
#include "warp/warp_camera.h"

#include <math.h>
#include <string.h>

#include "warp/warp_image.h"

warp_camera warp_camera_symmetric(int width, int height, double hfov_deg, double vfov_deg, double near_z, double far_z)
{
    warp_camera c;
    c.width = width;
    c.height = height;
    c.tan_left = c.tan_right = tan(hfov_deg * WARP_PI / 360.0);
    c.tan_up = c.tan_down = tan(vfov_deg * WARP_PI / 360.0);
    c.near_z = near_z;
    c.far_z = far_z;
    return c;
}

const char *warp_camera_check(const warp_camera *c)
{
    if (c->width <= 0 || c->height <= 0 || c->width > WARP_MAX_SIDE || c->height > WARP_MAX_SIDE)
        return "image size out of range";
    if (!isfinite(c->tan_left) || !isfinite(c->tan_right) || !isfinite(c->tan_up) || !isfinite(c->tan_down))
        return "FOV tangent not finite";
    if (!(c->tan_left + c->tan_right > 1e-6) || !(c->tan_up + c->tan_down > 1e-6)) return "FOV is empty";
    if (!(c->near_z > 0) || !isfinite(c->near_z)) return "near plane must be positive and finite";
    if (!(c->far_z > c->near_z)) return "far plane must lie beyond the near plane";
    return NULL;
}

warp_mat3 warp_camera_K(const warp_camera *c)
{
    double sx = warp_camera_pixels_per_tan_x(c), sy = warp_camera_pixels_per_tan_y(c);
    /* x = (X/-Z + tl) sx  ->  x w = sx X + sx tl (-Z);  y = (tu - Y/-Z) sy  ->  y w = -sy Y + sy tu (-Z). */
    warp_mat3 k = {{{sx, 0, -sx * c->tan_left}, {0, -sy, -sy * c->tan_up}, {0, 0, -1}}};
    return k;
}

warp_mat3 warp_camera_K_inverse(const warp_camera *c)
{
    double sx = warp_camera_pixels_per_tan_x(c), sy = warp_camera_pixels_per_tan_y(c);
    /* Inverse of K above: (x, y, 1) -> direction (u, v, -1) with u = x/sx - tl, v = tu - y/sy. */
    warp_mat3 k = {{{1 / sx, 0, -c->tan_left}, {0, -1 / sy, c->tan_up}, {0, 0, -1}}};
    return k;
}

bool warp_camera_project(const warp_camera *c, warp_vec3 p, double *x, double *y, double *inv_z)
{
    double w = -p.z;
    if (!(w > 0)) return false;
    double iz = 1.0 / w;
    warp_camera_tan_to_pixel(c, p.x * iz, p.y * iz, x, y);
    if (inv_z) *inv_z = iz;
    return true;
}

double warp_depth_to_inverse(const warp_camera *c, warp_depth_encoding enc, double d)
{
    /* For a perspective projection 1/z is affine in window depth: exact, and free of the cancellation that
     * converting to z first would suffer near the far plane. 1/far is 0 for an infinite far plane. */
    double in = 1.0 / c->near_z, inf = 1.0 / c->far_z;
    switch (enc) {
    case WARP_DEPTH_LINEAR: return d > 0 ? 1.0 / d : NAN; /* 1/INF = 0: sky */
    case WARP_DEPTH_STANDARD: return (1.0 - d) * in + d * inf;
    case WARP_DEPTH_REVERSED: return d * in + (1.0 - d) * inf;
    }
    return NAN;
}

double warp_depth_from_inverse(const warp_camera *c, warp_depth_encoding enc, double iz)
{
    double in = 1.0 / c->near_z, inf = 1.0 / c->far_z;
    switch (enc) {
    case WARP_DEPTH_LINEAR: return iz > 0 ? 1.0 / iz : INFINITY;
    case WARP_DEPTH_STANDARD: return (in - iz) / (in - inf);
    case WARP_DEPTH_REVERSED: return (iz - inf) / (in - inf);
    }
    return NAN;
}

warp_mat4 warp_camera_gl_projection(const warp_camera *c)
{
    double sw = c->tan_left + c->tan_right, sh = c->tan_up + c->tan_down;
    double n = c->near_z, f = c->far_z;
    warp_mat4 m;
    memset(&m, 0, sizeof m);
    m.m[0][0] = 2.0 / sw;
    m.m[0][2] = (c->tan_right - c->tan_left) / sw;
    m.m[1][1] = 2.0 / sh;
    m.m[1][2] = (c->tan_up - c->tan_down) / sh;
    if (isinf(f)) {
        m.m[2][2] = -1.0;
        m.m[2][3] = -2.0 * n;
    } else {
        m.m[2][2] = -(f + n) / (f - n);
        m.m[2][3] = -2.0 * f * n / (f - n);
    }
    m.m[3][2] = -1.0;
    return m;
}

warp_mat3 warp_rotation_homography(const warp_camera *src, const warp_camera *dst, warp_quat src_from_dst)
{
    warp_mat3 ks = warp_camera_K(src), kdi = warp_camera_K_inverse(dst), r = warp_quat_to_mat3(src_from_dst);
    warp_mat3 t = warp_mat3_mul(&r, &kdi);
    return warp_mat3_mul(&ks, &t);
}

/* SPDX-License-Identifier: MIT */
/* warp_camera: per-eye asymmetric frusta from FOV tangents, pixel <-> ray mapping, depth encodings.
 * Everything that converts between pixels, tangent-space directions and depth goes through here. */
#ifndef WARP_CAMERA_H
#define WARP_CAMERA_H

#include <stdbool.h>

#include "warp/warp_math.h"

/* How a depth plane stores depth. Window depth d in [0,1] is what a GPU depth buffer holds.
 *  LINEAR:   view-space distance along -Z in metres (planar z, not distance along the ray); +INF = sky.
 *  STANDARD: d = 0 at near, 1 at far (far may be infinite).
 *  REVERSED: d = 1 at near, 0 at far (reversed-Z; far may be infinite, then d = near / z).
 * All three convert exactly to inverse depth 1/z, which is affine in window depth and in screen space;
 * the warps work on 1/z (0 = infinity). */
typedef enum {
    WARP_DEPTH_LINEAR = 0,
    WARP_DEPTH_STANDARD = 1,
    WARP_DEPTH_REVERSED = 2,
} warp_depth_encoding;

/* A pinhole eye camera. The image covers tangent-space u in [-tan_left, tan_right] and v in [-tan_down, tan_up]
 * (u = X/-Z, v = Y/-Z). Pixel (i, j) has its centre at continuous coordinates (i + 0.5, j + 0.5); y grows downwards. */
typedef struct {
    int width, height;
    double tan_left, tan_right, tan_up, tan_down;
    double near_z, far_z; /* positive; far_z may be INFINITY */
} warp_camera;

/* Symmetric camera from full horizontal and vertical FOV in degrees. */
warp_camera warp_camera_symmetric(int width, int height, double hfov_deg, double vfov_deg, double near_z, double far_z);
/* Returns NULL when usable, else a static string naming what is wrong. */
const char *warp_camera_check(const warp_camera *cam);

/* Intrinsics K: camera-space direction (X, Y, Z) -> homogeneous pixel (x w, y w, w) with w = -Z. */
warp_mat3 warp_camera_K(const warp_camera *cam);
warp_mat3 warp_camera_K_inverse(const warp_camera *cam);

static inline double warp_camera_pixels_per_tan_x(const warp_camera *c) { return c->width / (c->tan_left + c->tan_right); }
static inline double warp_camera_pixels_per_tan_y(const warp_camera *c) { return c->height / (c->tan_up + c->tan_down); }
static inline void warp_camera_tan_to_pixel(const warp_camera *c, double u, double v, double *x, double *y)
{
    *x = (u + c->tan_left) * warp_camera_pixels_per_tan_x(c);
    *y = (c->tan_up - v) * warp_camera_pixels_per_tan_y(c);
}
static inline void warp_camera_pixel_to_tan(const warp_camera *c, double x, double y, double *u, double *v)
{
    *u = x / warp_camera_pixels_per_tan_x(c) - c->tan_left;
    *v = c->tan_up - y / warp_camera_pixels_per_tan_y(c);
}
/* Projects a camera-space point; false when it is not in front of the camera (-Z <= 0). */
bool warp_camera_project(const warp_camera *cam, warp_vec3 p, double *x, double *y, double *inv_z);

/* Depth conversions (see warp_depth_encoding). Inverse depth is 0 for points at infinity. */
double warp_depth_to_inverse(const warp_camera *cam, warp_depth_encoding enc, double d);
double warp_depth_from_inverse(const warp_camera *cam, warp_depth_encoding enc, double inv_z);

/* OpenGL projection matrix (NDC z in [-1,1], standard depth); far_z may be infinite. */
warp_mat4 warp_camera_gl_projection(const warp_camera *cam);

/* Pixel homography of a rotation-only reprojection (003 §3.4, eq. 9: R = P H(t+1) H(t)^-1 P^-1 with depth at
 * infinity): maps homogeneous pixel coordinates of the target view to those of the source view.
 * src_from_dst is the rotation taking target-eye directions to source-eye directions. */
warp_mat3 warp_rotation_homography(const warp_camera *src, const warp_camera *dst, warp_quat src_from_dst);

#endif

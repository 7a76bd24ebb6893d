/* SPDX-License-Identifier: MIT */
/* warp_lens: radial lens distortion with one polynomial per colour channel (chromatic aberration), and its
 * numeric inverse. Maps panel pixels to the tangent-space directions the eye sees through the lens. */
#ifndef WARP_LENS_H
#define WARP_LENS_H

#include <stdbool.h>

#include "warp/warp_camera.h"

#define WARP_LENS_TERMS 4

/* Radial scale as a polynomial in r^2: s(r^2) = k[0] + k[1] r^2 + k[2] r^4 + k[3] r^6. */
typedef struct { double k[WARP_LENS_TERMS]; } warp_lens_poly;

/* A panel pixel (x, y) of one eye's viewport (pixels from its top-left, centres at +0.5) is seen in direction
 *   q = ((x - center_x) / scale, (center_y - y) / scale),   tangent t_c = q * s_c(|q|^2)   for channel c,
 * i.e. u = t.x, v = t.y in the eye camera's tangent space (u = X/-Z, v = Y/-Z). Separate polynomials per
 * channel correct lateral chromatic aberration (like OpenHMD's per-channel radial scale). */
typedef struct {
    warp_lens_poly ch[3]; /* 0 = red, 1 = green, 2 = blue */
    double center_x, center_y;
    double scale; /* viewport pixels per unit of normalised radius */
} warp_lens;

/* A lens that does not distort: panel pixels map to tangents exactly as the pixels of `cam` do (square pixels
 * assumed; the horizontal pixel density is used for both axes). */
warp_lens warp_lens_identity(const warp_camera *cam);

/* Panel pixel -> tangent direction for channel c (distortion applied as the display needs it). */
void warp_lens_distort(const warp_lens *lens, int c, double x, double y, double *u, double *v);

/* Tangent direction -> panel pixel for channel c: the numeric inverse (Newton on the radius). Returns false,
 * leaving *x, *y untouched, when no panel radius maps to that direction within the lens's monotonic range. */
bool warp_lens_undistort(const warp_lens *lens, int c, double u, double v, double *x, double *y);

/* Largest normalised radius up to which r * s_c(r^2) keeps increasing (where the inverse is unique); INFINITY
 * when it increases everywhere. */
double warp_lens_monotonic_radius(const warp_lens *lens, int c);

/* Checks that every pixel of a w x h viewport lies inside the monotonic range of all three channels and that the
 * coefficients are finite. Returns NULL when usable, else a message naming the problem (written to buf). */
const char *warp_lens_check(const warp_lens *lens, int w, int h, char *buf, int buflen);

#endif

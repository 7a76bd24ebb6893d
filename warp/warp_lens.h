/* SPDX-License-Identifier: MIT */
/* warp_lens: lens distortion per colour channel (chromatic aberration), panel pixel <-> view tangent, and its
 * numeric inverse: the even polynomial here, the other published models (warp_lens_models.h) through the same calls. */
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
typedef enum {
    WARP_LENS_POLY = 0,  /* the even polynomial above: ch[], center_x/y, scale (the zero-initialised default) */
    WARP_LENS_PANOTOOLS, /* OpenHMD's universal_distortion (a b c d, odd and even terms) x universal_aberration */
    WARP_LENS_VIVE,      /* Monado's u_vive: per-channel centre and 1 / (1 + k1 r^2 + k2 r^4 + k3 r^6) + k4 */
    WARP_LENS_CARDBOARD, /* Cardboard SDK's PolynomialRadialDistortion: 1 + k1 r^2 + k2 r^4 in screen tan-angles */
    WARP_LENS_OPENCV,    /* OpenCV's pinhole camera with k1 k2 p1 p2 k3, mapping view tangents to panel pixels */
    WARP_LENS_MODELS
} warp_lens_model;

/* One channel of the models other than poly (warp/warp_lens_models.h builds them from each format's own
 * parameters). Forward models (all but opencv) map a panel pixel to
 *   q = ((x - cx) / scale, (cy - y) / scale_y),  p = q F(|q|),  tangent = (tsx p.x + tbx, tsy p.y + tby),
 * F the model's radial factor of k[]; opencv maps a tangent to a pixel instead (see warp_lens_models.h). */
typedef struct {
    double k[4];
    double cx, cy;     /* the channel's centre, viewport pixels */
    double tsx, tsy;   /* tangent per unit of p */
    double tbx, tby;   /* tangent offset */
} warp_lens_channel;

typedef struct {
    warp_lens_poly ch[3]; /* 0 = red, 1 = green, 2 = blue */
    double center_x, center_y;
    double scale; /* viewport pixels per unit of normalised radius */
    /* Other models; code that builds a poly lens by hand leaves these zero. center_x/y and scale keep the green
     * channel's centre and horizontal scale for every model. */
    warp_lens_model model;
    warp_lens_channel m[3];
    double scale_y;     /* vertical pixels per unit (models other than poly) */
    double p1, p2;      /* opencv's tangential coefficients */
    double rcut;        /* vive: radius (normalised) beyond which f continues linearly (undistort_r2_cutoff); 0 none */
    double rmono[3];    /* each channel's monotonic radius, cached by warp_lens_prepare (not for poly) */
    bool prepared;
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
 * when it increases everywhere. Other models: the panel-side normalised radius (|q| above, or for opencv
 * |((x - cx) / fx, (y - cy) / fy)|) within which panel pixels and directions map one to one. */
double warp_lens_monotonic_radius(const warp_lens *lens, int c);

/* Checks that every pixel of a w x h viewport lies inside the monotonic range of all three channels and that the
 * coefficients are finite. Returns NULL when usable, else a message naming the problem (written to buf). */
const char *warp_lens_check(const warp_lens *lens, int w, int h, char *buf, int buflen);

/* Caches what the models other than poly need per call (their monotonic radii); their constructors call it, and
 * code that changes a built lens's coefficients calls it again. */
void warp_lens_prepare(warp_lens *lens);

/* Whether the lens shows panel pixel (x, y) of channel c at all: false only where a model marks the end of its view
 * (vive: beyond undistort_r2_cutoff, where its directions are a continuation, not the lens's). For a hidden-area
 * mask; every model maps every viewport pixel one to one either way. */
bool warp_lens_in_view(const warp_lens *lens, int c, double x, double y);

/* The model's name (poly, panotools, vive, cardboard, opencv), or "?". */
const char *warp_lens_model_name(warp_lens_model m);

#endif

/* SPDX-License-Identifier: MIT */
/* warp_lensfit: fits a lens model's radial coefficients, per colour channel, to measured correspondences (panel
 * pixel -> view tangent) by linear least squares, and measures the fit's residual in panel pixels. */
#ifndef WARP_LENSFIT_H
#define WARP_LENSFIT_H

#include <stdbool.h>

#include "warp/warp_lens.h"

/* One measurement of one colour channel: the panel pixel (viewport pixels, the lens's own frame) and the view
 * tangent it is seen at (u right, v up). */
typedef struct {
    double x, y;
    double u, v;
} warp_lensfit_point;

typedef struct {
    double k[4];   /* poly: k0 k1 k2 k3 of s(r^2); panotools: a b c d of F(r) = d + c r + b r^2 + a r^3 */
    double rms_px; /* panel pixels between each measured pixel and where the fitted lens puts its tangent */
    double max_px;
    int n;         /* points fitted */
    int unmapped;  /* points whose tangent the fitted lens cannot map back (beyond its fold) */
} warp_lensfit_result;

/* Fits `model` (WARP_LENS_POLY or WARP_LENS_PANOTOOLS, tangent per unit 1) for one channel, with the lens centre
 * (cx, cy) and scale (pixels per normalised unit) held fixed. Both models are linear in their coefficients: each
 * point gives two equations t = q F(|q|), solved through the normal equations in long double with the columns
 * scaled to unit norm. Needs at least 4 points off the centre; false with a message otherwise. */
bool warp_lensfit_radial(warp_lens_model model, const warp_lensfit_point *pts, int n, double cx, double cy,
                         double scale, warp_lensfit_result *out, char *err, int errlen);

/* Also fits the lens centre, shared by the three channels (poly and panotools have one): the centre minimising the
 * channels' summed tangent residual, by Nelder-Mead from (*cx, *cy) with the coefficients solved exactly at every
 * trial centre. The scale needs no fit: both bases are closed under scaling (scaling it by s multiplies the
 * coefficient of q r^j by s^(j+1)), so it only normalises. out[c] as warp_lensfit_radial at the fitted centre. */
bool warp_lensfit_center(warp_lens_model model, const warp_lensfit_point *const pts[3], const int n[3], double *cx,
                         double *cy, double scale, warp_lensfit_result out[3], char *err, int errlen);

/* The one-channel lens the fit describes (all three channels alike), for residuals and the caller's checks. */
warp_lens warp_lensfit_lens(warp_lens_model model, const double k[4], double cx, double cy, double scale);

#endif

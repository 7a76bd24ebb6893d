/* SPDX-License-Identifier: MIT */
/* warp_lensfit: fits a lens model's radial coefficients, per colour channel, to measured correspondences (panel
 * pixel -> view tangent) by linear least squares, and measures the fit's residual in panel pixels. */
#include "warp/warp_lensfit.h"

#include <math.h>
#include <string.h>

#include "warp/warp_err.h"
#include "warp/warp_lens_models.h"

warp_lens warp_lensfit_lens(warp_lens_model model, const double k[4], double cx, double cy, double scale)
{
    if (model == WARP_LENS_PANOTOOLS) {
        warp_lens_panotools_params p = {.aberration = {1, 1, 1}, .center_x = cx, .center_y = cy, .scale = scale,
                                        .tan_scale = 1};
        for (int c = 0; c < 3; c++) memcpy(p.abcd[c], k, sizeof p.abcd[c]);
        return warp_lens_panotools(&p);
    }
    warp_lens l = {.model = WARP_LENS_POLY, .center_x = cx, .center_y = cy, .scale = scale};
    for (int c = 0; c < 3; c++) memcpy(l.ch[c].k, k, sizeof l.ch[c].k);
    return l;
}

/* The basis: t = sum_i k_i q phi_i(r). poly: phi = 1, r^2, r^4, r^6; panotools (k = a b c d): r^3, r^2, r, 1. */
static void basis(warp_lens_model model, double r, double phi[4])
{
    if (model == WARP_LENS_PANOTOOLS) {
        phi[3] = 1;
        phi[2] = r;
        phi[1] = r * r;
        phi[0] = r * r * r;
    } else {
        double r2 = r * r;
        phi[0] = 1;
        phi[1] = r2;
        phi[2] = r2 * r2;
        phi[3] = r2 * r2 * r2;
    }
}

bool warp_lensfit_radial(warp_lens_model model, const warp_lensfit_point *pts, int n, double cx, double cy,
                         double scale, warp_lensfit_result *out, char *err, int errlen)
{
    memset(out, 0, sizeof *out);
    if (model != WARP_LENS_POLY && model != WARP_LENS_PANOTOOLS)
        return warp_err(err, errlen, "fit: model %s is not linear in its coefficients (poly or panotools)",
                        warp_lens_model_name(model));
    if (!isfinite(cx) || !isfinite(cy) || !isfinite(scale) || !(scale > 0))
        return warp_err(err, errlen, "fit: centre (%g, %g) and scale %g must be finite, the scale positive", cx, cy,
                        scale);
    /* normal equations A^T A k = A^T b over 2 n rows, accumulated in long double */
    long double ata[4][4] = {{0}}, atb[4] = {0};
    int used = 0;
    for (int i = 0; i < n; i++) {
        double qx = (pts[i].x - cx) / scale, qy = (cy - pts[i].y) / scale, r = hypot(qx, qy), phi[4];
        if (!isfinite(qx) || !isfinite(qy) || !isfinite(pts[i].u) || !isfinite(pts[i].v))
            return warp_err(err, errlen, "fit: point %d is not finite", i + 1);
        if (r == 0) continue; /* the centre constrains nothing: q = 0 there whatever the coefficients */
        basis(model, r, phi);
        double row[2][4];
        for (int j = 0; j < 4; j++) {
            row[0][j] = qx * phi[j];
            row[1][j] = qy * phi[j];
        }
        const double b[2] = {pts[i].u, pts[i].v};
        for (int e = 0; e < 2; e++)
            for (int j = 0; j < 4; j++) {
                atb[j] += (long double)row[e][j] * b[e];
                for (int m = 0; m < 4; m++) ata[j][m] += (long double)row[e][j] * row[e][m];
            }
        used++;
    }
    if (used < 4) return warp_err(err, errlen, "fit: %d points off the lens centre, at least 4 needed", used);
    /* column scaling (Jacobi): the r^6 column is orders of magnitude from the constant one */
    long double sc[4];
    for (int j = 0; j < 4; j++) {
        sc[j] = ata[j][j] > 0 ? 1 / sqrtl(ata[j][j]) : 1;
    }
    long double m[4][5];
    for (int j = 0; j < 4; j++) {
        for (int k = 0; k < 4; k++) m[j][k] = ata[j][k] * sc[j] * sc[k];
        m[j][4] = atb[j] * sc[j];
    }
    /* Gaussian elimination with partial pivoting on the symmetric positive (semi)definite 4 x 4 system */
    for (int col = 0; col < 4; col++) {
        int piv = col;
        for (int r = col + 1; r < 4; r++)
            if (fabsl(m[r][col]) > fabsl(m[piv][col])) piv = r;
        if (!(fabsl(m[piv][col]) > 1e-14L))
            return warp_err(err, errlen,
                            "fit: the points do not determine the coefficients (all at one radius? spread them "
                            "from the centre to the edge)");
        if (piv != col)
            for (int k = 0; k < 5; k++) {
                long double t = m[col][k];
                m[col][k] = m[piv][k];
                m[piv][k] = t;
            }
        for (int r = 0; r < 4; r++) {
            if (r == col) continue;
            long double f = m[r][col] / m[col][col];
            for (int k = col; k < 5; k++) m[r][k] -= f * m[col][k];
        }
    }
    for (int j = 0; j < 4; j++) out->k[j] = (double)(m[j][4] / m[j][j] * sc[j]);
    out->n = used;
    /* residual in panel pixels: where the fitted lens puts each measured tangent */
    warp_lens l = warp_lensfit_lens(model, out->k, cx, cy, scale);
    double sum2 = 0;
    int mapped = 0;
    for (int i = 0; i < n; i++) {
        double x, y;
        if (!warp_lens_undistort(&l, 1, pts[i].u, pts[i].v, &x, &y)) {
            out->unmapped++;
            continue;
        }
        double d = hypot(x - pts[i].x, y - pts[i].y);
        sum2 += d * d;
        out->max_px = fmax(out->max_px, d);
        mapped++;
    }
    out->rms_px = mapped ? sqrt(sum2 / mapped) : NAN;
    return true;
}

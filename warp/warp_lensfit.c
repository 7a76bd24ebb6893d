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

/* The linear least-squares coefficients for a fixed centre and scale; *ssr, when given, the sum of squared tangent
 * residuals they leave; *used the points off the centre. */
static bool solve(warp_lens_model model, const warp_lensfit_point *pts, int n, double cx, double cy, double scale,
                  double k_out[4], double *ssr, int *used_out, char *err, int errlen)
{
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
    for (int j = 0; j < 4; j++) k_out[j] = (double)(m[j][4] / m[j][j] * sc[j]);
    *used_out = used;
    if (ssr) {
        double sum = 0;
        for (int i = 0; i < n; i++) {
            double qx = (pts[i].x - cx) / scale, qy = (cy - pts[i].y) / scale, r = hypot(qx, qy), phi[4], f = 0;
            basis(model, r, phi);
            for (int j = 0; j < 4; j++) f += k_out[j] * phi[j];
            double eu = qx * f - pts[i].u, ev = qy * f - pts[i].v;
            sum += eu * eu + ev * ev;
        }
        *ssr = sum;
    }
    return true;
}

static bool check_args(warp_lens_model model, double cx, double cy, double scale, char *err, int errlen)
{
    if (model != WARP_LENS_POLY && model != WARP_LENS_PANOTOOLS)
        return warp_err(err, errlen, "fit: model %s is not linear in its coefficients (poly or panotools)",
                        warp_lens_model_name(model));
    if (!isfinite(cx) || !isfinite(cy) || !isfinite(scale) || !(scale > 0))
        return warp_err(err, errlen, "fit: centre (%g, %g) and scale %g must be finite, the scale positive", cx, cy,
                        scale);
    return true;
}

/* Residual in panel pixels: where the fitted lens puts each measured tangent. */
static void residual(warp_lens_model model, const warp_lensfit_point *pts, int n, double cx, double cy, double scale,
                     warp_lensfit_result *out)
{
    warp_lens l = warp_lensfit_lens(model, out->k, cx, cy, scale);
    double sum2 = 0;
    int mapped = 0;
    out->max_px = 0;
    out->unmapped = 0;
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
}

bool warp_lensfit_radial(warp_lens_model model, const warp_lensfit_point *pts, int n, double cx, double cy,
                         double scale, warp_lensfit_result *out, char *err, int errlen)
{
    memset(out, 0, sizeof *out);
    if (!check_args(model, cx, cy, scale, err, errlen)) return false;
    if (!solve(model, pts, n, cx, cy, scale, out->k, NULL, &out->n, err, errlen)) return false;
    residual(model, pts, n, cx, cy, scale, out);
    return true;
}

/* The three channels' summed tangent residual at centre (cx, cy); INFINITY where a channel cannot be solved. */
static double centre_cost(warp_lens_model model, const warp_lensfit_point *const pts[3], const int n[3], double cx,
                          double cy, double scale)
{
    double total = 0;
    for (int c = 0; c < 3; c++) {
        double k[4], ssr;
        int used;
        if (!solve(model, pts[c], n[c], cx, cy, scale, k, &ssr, &used, NULL, 0)) return INFINITY;
        total += ssr;
    }
    return total;
}

bool warp_lensfit_center(warp_lens_model model, const warp_lensfit_point *const pts[3], const int n[3], double *cx,
                         double *cy, double scale, warp_lensfit_result out[3], char *err, int errlen)
{
    if (!check_args(model, *cx, *cy, scale, err, errlen)) return false;
    /* Nelder-Mead on the centre: two parameters, each cost one linear solve per channel; the coefficients are
     * re-solved exactly at every trial centre (variable projection), so only the centre is searched. */
    double v[3][2] = {{*cx, *cy}, {*cx + 0.05 * scale, *cy}, {*cx, *cy + 0.05 * scale}}, f[3];
    for (int i = 0; i < 3; i++) f[i] = centre_cost(model, pts, n, v[i][0], v[i][1], scale);
    if (!isfinite(f[0])) {
        for (int c = 0; c < 3; c++)
            if (!warp_lensfit_radial(model, pts[c], n[c], *cx, *cy, scale, &out[c], err, errlen)) return false;
        return warp_err(err, errlen, "fit: no solution at the starting centre");
    }
    for (int it = 0; it < 400; it++) {
        /* order best .. worst */
        for (int a = 0; a < 2; a++)
            for (int b = a + 1; b < 3; b++)
                if (f[b] < f[a]) {
                    double t = f[a];
                    f[a] = f[b];
                    f[b] = t;
                    for (int d = 0; d < 2; d++) {
                        t = v[a][d];
                        v[a][d] = v[b][d];
                        v[b][d] = t;
                    }
                }
        double size = fmax(fabs(v[1][0] - v[0][0]) + fabs(v[1][1] - v[0][1]),
                           fabs(v[2][0] - v[0][0]) + fabs(v[2][1] - v[0][1]));
        if (size < 1e-7) break; /* pixels */
        double m[2] = {(v[0][0] + v[1][0]) / 2, (v[0][1] + v[1][1]) / 2}, r[2], e[2];
        for (int d = 0; d < 2; d++) r[d] = m[d] + (m[d] - v[2][d]);
        double fr = centre_cost(model, pts, n, r[0], r[1], scale);
        if (fr < f[0]) {
            for (int d = 0; d < 2; d++) e[d] = m[d] + 2 * (m[d] - v[2][d]);
            double fe = centre_cost(model, pts, n, e[0], e[1], scale);
            if (fe < fr) {
                v[2][0] = e[0], v[2][1] = e[1], f[2] = fe;
            } else {
                v[2][0] = r[0], v[2][1] = r[1], f[2] = fr;
            }
        } else if (fr < f[1]) {
            v[2][0] = r[0], v[2][1] = r[1], f[2] = fr;
        } else {
            double k[2];
            for (int d = 0; d < 2; d++) k[d] = m[d] + 0.5 * (v[2][d] - m[d]);
            double fk = centre_cost(model, pts, n, k[0], k[1], scale);
            if (fk < f[2]) {
                v[2][0] = k[0], v[2][1] = k[1], f[2] = fk;
            } else { /* shrink towards the best */
                for (int i = 1; i < 3; i++) {
                    for (int d = 0; d < 2; d++) v[i][d] = v[0][d] + 0.5 * (v[i][d] - v[0][d]);
                    f[i] = centre_cost(model, pts, n, v[i][0], v[i][1], scale);
                }
            }
        }
    }
    int best = 0;
    for (int i = 1; i < 3; i++)
        if (f[i] < f[best]) best = i;
    *cx = v[best][0];
    *cy = v[best][1];
    for (int c = 0; c < 3; c++)
        if (!warp_lensfit_radial(model, pts[c], n[c], *cx, *cy, scale, &out[c], err, errlen)) return false;
    return true;
}

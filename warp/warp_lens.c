/* SPDX-License-Identifier: MIT */
/* warp_lens: radial lens distortion with one polynomial per colour channel (chromatic aberration), and its
 * numeric inverse. Maps panel pixels to the tangent-space directions the eye sees through the lens. */
#include "warp/warp_lens.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>

#include "warp/warp_err.h"

static const char *const channel_name[3] = {"red", "green", "blue"};

/* s(r^2) by Horner's rule. */
static double poly_s(const warp_lens_poly *p, double r2)
{
    return p->k[0] + r2 * (p->k[1] + r2 * (p->k[2] + r2 * p->k[3]));
}

/* g(x) = f'(r) at x = r^2, for f(r) = r s(r^2): k0 + 3 k1 x + 5 k2 x^2 + 7 k3 x^3. */
static double poly_g(const warp_lens_poly *p, double x)
{
    return p->k[0] + x * (3 * p->k[1] + x * (5 * p->k[2] + x * (7 * p->k[3])));
}

static bool poly_finite(const warp_lens_poly *p)
{
    for (int i = 0; i < WARP_LENS_TERMS; i++)
        if (!isfinite(p->k[i])) return false;
    return true;
}

warp_lens warp_lens_identity(const warp_camera *cam)
{
    warp_lens l;
    for (int c = 0; c < 3; c++) {
        l.ch[c].k[0] = 1;
        l.ch[c].k[1] = l.ch[c].k[2] = l.ch[c].k[3] = 0;
    }
    /* q = 0 must be the optical axis (u = v = 0), which the camera puts at (tan_left, tan_up) tangents in. */
    l.center_x = cam->tan_left * warp_camera_pixels_per_tan_x(cam);
    l.center_y = cam->tan_up * warp_camera_pixels_per_tan_y(cam);
    l.scale = warp_camera_pixels_per_tan_x(cam);
    return l;
}

void warp_lens_distort(const warp_lens *lens, int c, double x, double y, double *u, double *v)
{
    const warp_lens_poly *p = &lens->ch[c];
    double qx = (x - lens->center_x) / lens->scale, qy = (lens->center_y - y) / lens->scale;
    double s = poly_s(p, qx * qx + qy * qy);
    *u = qx * s;
    *v = qy * s;
}

/* Bisection of g on [lo, hi] where g(lo) > 0 >= g(hi), down to adjacent doubles: robust whatever the
 * coefficients' magnitudes, and cheap enough since this runs once per lens, not per pixel. */
static double bisect_g(const warp_lens_poly *p, double lo, double hi)
{
    for (int i = 0; i < 2200; i++) {
        double mid = 0.5 * (lo + hi);
        if (mid <= lo || mid >= hi) break;
        if (poly_g(p, mid) > 0)
            lo = mid;
        else
            hi = mid;
    }
    return hi;
}

/* Non-finite coefficients or k0 <= 0 give 0: no radius where the inverse is known to be unique. */
static double monotonic_radius_poly(const warp_lens_poly *p)
{
    if (!poly_finite(p) || !(p->k[0] > 0)) return 0;
    double c1 = 3 * p->k[1], c2 = 5 * p->k[2], c3 = 7 * p->k[3];
    /* g is monotonic between the positive roots of g'(x) = c1 + 2 c2 x + 3 c3 x^2; walking those intervals in
     * order and bisecting the first one whose right end is <= 0 finds the smallest positive root exactly,
     * including near-tangent ones that a fixed-step scan could step over. */
    double crit[2];
    int n = 0;
    double a = 3 * c3, b = 2 * c2, cc = c1;
    if (a != 0) {
        double disc = b * b - 4 * a * cc;
        if (disc >= 0) {
            /* Numerically stable quadratic roots (no cancellation between -b and sqrt(disc)). */
            double qq = -0.5 * (b + copysign(sqrt(disc), b));
            double r0 = qq / a, r1 = qq != 0 ? cc / qq : r0;
            if (r0 > r1) {
                double t = r0;
                r0 = r1;
                r1 = t;
            }
            if (r0 > 0) crit[n++] = r0;
            if (r1 > 0 && r1 != r0) crit[n++] = r1;
        }
    } else if (b != 0) {
        double r0 = -cc / b;
        if (r0 > 0) crit[n++] = r0;
    }
    double lo = 0;
    for (int i = 0; i < n; i++) {
        if (!isfinite(crit[i])) break;
        if (poly_g(p, crit[i]) <= 0) return sqrt(bisect_g(p, lo, crit[i]));
        lo = crit[i];
    }
    /* Last interval [lo, inf): g ends at the sign of its leading coefficient. */
    double lead = c3 != 0 ? c3 : c2 != 0 ? c2 : c1;
    if (!(lead < 0)) return INFINITY;
    double hi = lo > 0 ? 2 * lo : 1;
    while (poly_g(p, hi) > 0) {
        hi *= 2;
        if (!isfinite(hi)) return INFINITY; /* the root lies beyond anything representable */
    }
    return sqrt(bisect_g(p, lo, hi));
}

double warp_lens_monotonic_radius(const warp_lens *lens, int c)
{
    return monotonic_radius_poly(&lens->ch[c]);
}

bool warp_lens_undistort(const warp_lens *lens, int c, double u, double v, double *x, double *y)
{
    const warp_lens_poly *p = &lens->ch[c];
    if (!isfinite(u) || !isfinite(v) || !isfinite(lens->center_x) || !isfinite(lens->center_y) ||
        !isfinite(lens->scale) || !(lens->scale > 0))
        return false;
    double rmax = monotonic_radius_poly(p);
    if (!(rmax > 0)) return false;
    double rho = hypot(u, v);
    if (rho == 0) {
        *x = lens->center_x;
        *y = lens->center_y;
        return true;
    }
    /* Bracket [lo, hi] with f(lo) <= rho <= f(hi); f(r) = r s(r^2) rises strictly on [0, rmax). */
    double lo = 0, hi;
    if (isfinite(rmax)) {
        double f_at_max = rmax * poly_s(p, rmax * rmax);
        if (!(rho <= f_at_max)) return false; /* beyond the fold: no panel radius sees this direction */
        hi = rmax;
    } else {
        /* g >= some positive minimum on [0, inf), so f is unbounded and doubling terminates. */
        hi = fmax(rho / p->k[0], 1.0);
        for (;;) {
            double fh = hi * poly_s(p, hi * hi);
            if (isnan(fh)) return false; /* inf - inf at absurd radii: no trustworthy bracket */
            if (fh >= rho) break;
            lo = hi;
            hi *= 2;
            if (!isfinite(hi)) return false;
        }
    }
    /* Safeguarded Newton: fast quadratic convergence from r = rho / k0 (exact for a linear lens), falling back
     * to bisection whenever a step leaves the bracket, so it can neither diverge nor stall at the fold where
     * f' -> 0. */
    double r = fmin(fmax(rho / p->k[0], lo), hi);
    for (int it = 0; it < 200; it++) {
        double r2 = r * r;
        double fr = r * poly_s(p, r2) - rho;
        if (fr == 0) break;
        if (fr < 0)
            lo = r;
        else
            hi = r;
        double d = poly_g(p, r2);
        double rn = d > 0 ? r - fr / d : NAN;
        if (!(rn > lo && rn < hi)) rn = 0.5 * (lo + hi);
        if (rn == r || !(hi > lo)) break;
        /* Converged to rounding: another step would only oscillate between neighbouring doubles. */
        bool done = fabs(rn - r) <= 1e-16 * r;
        r = rn;
        if (done) break;
    }
    double k = r / rho;
    double xo = lens->center_x + u * k * lens->scale, yo = lens->center_y - v * k * lens->scale;
    if (!isfinite(xo) || !isfinite(yo)) return false;
    *x = xo;
    *y = yo;
    return true;
}

#if defined(__GNUC__)
__attribute__((format(printf, 3, 4)))
#endif
static const char *fail(char *buf, int buflen, const char *fmt, ...)
{
    if (!buf || buflen <= 0) return "lens unusable"; /* no room for details, but still report failure */
    va_list ap;
    va_start(ap, fmt);
    warp_verr(buf, buflen, fmt, ap);
    va_end(ap);
    return buf;
}

const char *warp_lens_check(const warp_lens *lens, int w, int h, char *buf, int buflen)
{
    if (!lens) return fail(buf, buflen, "lens missing");
    if (w <= 0 || h <= 0) return fail(buf, buflen, "lens viewport %dx%d is empty", w, h);
    if (!isfinite(lens->center_x) || !isfinite(lens->center_y))
        return fail(buf, buflen, "lens centre (%g, %g) not finite", lens->center_x, lens->center_y);
    if (!isfinite(lens->scale) || !(lens->scale > 0))
        return fail(buf, buflen, "lens scale %g must be positive and finite", lens->scale);
    /* The farthest viewport point from the centre is a corner of the pixel area (0,0)-(w,h), whatever side of
     * the viewport the centre lies on; checking pixel edges rather than centres keeps a margin for samplers. */
    double dx = fmax(fabs(lens->center_x), fabs(w - lens->center_x));
    double dy = fmax(fabs(lens->center_y), fabs(h - lens->center_y));
    double corner = hypot(dx, dy) / lens->scale;
    for (int c = 0; c < 3; c++) {
        const warp_lens_poly *p = &lens->ch[c];
        if (!poly_finite(p))
            return fail(buf, buflen, "lens %s channel coefficients (%g, %g, %g, %g) not finite", channel_name[c],
                        p->k[0], p->k[1], p->k[2], p->k[3]);
        if (!(p->k[0] > 0))
            return fail(buf, buflen, "lens %s channel k0 = %g must be positive (the centre would fold over)",
                        channel_name[c], p->k[0]);
        double rm = monotonic_radius_poly(p);
        if (!(corner < rm))
            return fail(buf, buflen,
                        "lens %s channel folds over at radius %.3g (viewport corner at %.3g): inverse distortion "
                        "has no unique solution",
                        channel_name[c], rm, corner);
    }
    return NULL;
}

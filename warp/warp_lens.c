/* SPDX-License-Identifier: MIT */
/* warp_lens: lens distortion per colour channel (chromatic aberration), panel pixel <-> view tangent, and its
 * numeric inverse: the even polynomial, and the other published models (warp_lens_models.h) through the same calls. */
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
    warp_lens l = {.model = WARP_LENS_POLY};
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

static void model_distort(const warp_lens *lens, int c, double x, double y, double *u, double *v);
static bool model_undistort(const warp_lens *lens, int c, double u, double v, double *x, double *y);
static double model_monotonic_radius(const warp_lens *lens, int c);

void warp_lens_distort(const warp_lens *lens, int c, double x, double y, double *u, double *v)
{
    if (lens->model != WARP_LENS_POLY) {
        model_distort(lens, c, x, y, u, v);
        return;
    }
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
    if (lens->model != WARP_LENS_POLY) return model_monotonic_radius(lens, c);
    return monotonic_radius_poly(&lens->ch[c]);
}

bool warp_lens_undistort(const warp_lens *lens, int c, double u, double v, double *x, double *y)
{
    if (lens->model != WARP_LENS_POLY) return model_undistort(lens, c, u, v, x, y);
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

bool warp_lens_in_view(const warp_lens *l, int c, double x, double y)
{
    if (l->model != WARP_LENS_VIVE || !(l->rcut > 0)) return true;
    const warp_lens_channel *m = &l->m[c];
    return hypot((x - m->cx) / l->scale, (m->cy - y) / l->scale_y) <= l->rcut;
}

static const char *model_check(const warp_lens *lens, int w, int h, char *buf, int buflen);

const char *warp_lens_check(const warp_lens *lens, int w, int h, char *buf, int buflen)
{
    if (!lens) return fail(buf, buflen, "lens missing");
    if (w <= 0 || h <= 0) return fail(buf, buflen, "lens viewport %dx%d is empty", w, h);
    if (lens->model != WARP_LENS_POLY) return model_check(lens, w, h, buf, buflen);
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

/* ---- The models other than poly (their parameters: warp/warp_lens_models.h) ----
 * Each is radial about a centre: f(r) = r F(r) maps a normalised radius on one side to the other, with an affine
 * map on each side. Forward models (panotools, vive, cardboard) go panel -> tangent like poly; opencv goes tangent
 * -> panel, and adds tangential terms (p1, p2) that only its own functions know. The inverse of f is unique up to
 * the first radius where f' <= 0 (the fold); that radius is found once per lens and cached by warp_lens_prepare. */

static const char *const model_names[WARP_LENS_MODELS] = {"poly", "panotools", "vive", "cardboard", "opencv"};

const char *warp_lens_model_name(warp_lens_model m)
{
    return (int)m >= 0 && m < WARP_LENS_MODELS ? model_names[m] : "?";
}

/* f(r) = r F(r) and f'(r); false where F is undefined (vive's denominator at or below zero). */
static bool radial(const warp_lens *l, int c, double r, double *f, double *df)
{
    const double *k = l->m[c].k;
    double r2 = r * r;
    switch (l->model) {
    case WARP_LENS_PANOTOOLS: { /* F = d + c r + b r^2 + a r^3, k = {a, b, c, d} as OpenHMD orders them */
        double F = k[3] + r * (k[2] + r * (k[1] + r * k[0]));
        *f = r * F;
        *df = k[3] + r * (2 * k[2] + r * (3 * k[1] + r * 4 * k[0]));
        return true;
    }
    case WARP_LENS_VIVE: { /* F = 1 / (1 + k1 r^2 + k2 r^4 + k3 r^6) + k4 */
        if (l->rcut > 0 && r > l->rcut) {
            /* Past Valve's undistort_r2_cutoff the rational F runs to its pole: those pixels lie outside what the
             * lens shows, and a tangent line keeps them one to one (far outside any eye buffer) instead. */
            double fc, dfc;
            if (!radial(l, c, l->rcut, &fc, &dfc)) return false;
            *f = fc + dfc * (r - l->rcut);
            *df = dfc;
            return true;
        }
        double D = 1 + r2 * (k[0] + r2 * (k[1] + r2 * k[2]));
        if (!(D > 0)) return false;
        double dD = r * (2 * k[0] + r2 * (4 * k[1] + r2 * 6 * k[2]));
        double F = 1 / D + k[3];
        *f = r * F;
        *df = F - r * dD / (D * D);
        return true;
    }
    case WARP_LENS_CARDBOARD: /* F = 1 + k1 r^2 + k2 r^4 (+ k3 r^6 + k4 r^8) */
    case WARP_LENS_OPENCV: {  /* F = 1 + k1 r^2 + k2 r^4 + k3 r^6 */
        double F = 1 + r2 * (k[0] + r2 * (k[1] + r2 * (k[2] + r2 * k[3])));
        *f = r * F;
        *df = 1 + r2 * (3 * k[0] + r2 * (5 * k[1] + r2 * (7 * k[2] + r2 * 9 * k[3])));
        return true;
    }
    default: return false;
    }
}

static bool channel_finite(const warp_lens *l, int c)
{
    const warp_lens_channel *m = &l->m[c];
    for (int i = 0; i < 4; i++)
        if (!isfinite(m->k[i])) return false;
    return isfinite(m->cx) && isfinite(m->cy) && isfinite(m->tsx) && isfinite(m->tsy) && isfinite(m->tbx) &&
           isfinite(m->tby) && m->tsx != 0 && m->tsy != 0 && isfinite(l->scale) && l->scale > 0 &&
           isfinite(l->scale_y) && l->scale_y > 0 && isfinite(l->p1) && isfinite(l->p2);
}

/* The model's own radius (panel side for forward models, tangent side for opencv) where f' first reaches 0:
 * a fine scan near the axis, where lenses fold, then a geometric one, then bisection. A scan can step over a
 * pair of roots closer than its step; the lens check's corner test also verifies the viewport's corners. */
static double native_limit(const warp_lens *l, int c)
{
    if (!channel_finite(l, c)) return 0;
    double f, df;
    if (!radial(l, c, 0, &f, &df) || !(df > 0)) return 0;
    double lo = 0, r = 0;
    for (;;) {
        r = r < 4 ? r + 1.0 / 512 : r * 1.01;
        if (r > 1e4) return INFINITY; /* beyond any panel's reach in normalised units */
        if (!radial(l, c, r, &f, &df) || !(df > 0)) break;
        lo = r;
    }
    double hi = r;
    for (int i = 0; i < 200; i++) {
        double mid = 0.5 * (lo + hi);
        if (mid <= lo || mid >= hi) break;
        if (radial(l, c, mid, &f, &df) && df > 0)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

static double limit_of(const warp_lens *l, int c) { return l->prepared ? l->rmono[c] : native_limit(l, c); }

static double model_monotonic_radius(const warp_lens *l, int c)
{
    double r = limit_of(l, c), f, df;
    if (l->model != WARP_LENS_OPENCV || !(r > 0) || !isfinite(r)) return r;
    return radial(l, c, r, &f, &df) ? f : 0; /* opencv: the panel-side radius the fold is seen at */
}

void warp_lens_prepare(warp_lens *lens)
{
    lens->prepared = false;
    if (lens->model == WARP_LENS_POLY) return;
    for (int c = 0; c < 3; c++) lens->rmono[c] = native_limit(lens, c);
    lens->prepared = true;
}

/* r in [0, rmax] with f(r) = rho: safeguarded Newton as for poly (bisection whenever a step leaves the bracket). */
static bool radial_inverse(const warp_lens *l, int c, double rho, double rmax, double *out)
{
    double f, df, lo = 0, hi;
    if (!(rmax > 0)) return false;
    if (rho == 0) {
        *out = 0;
        return true;
    }
    if (isfinite(rmax)) {
        if (!radial(l, c, rmax, &f, &df) || !(rho <= f)) return false; /* beyond the fold */
        hi = rmax;
    } else {
        hi = fmax(rho, 1.0);
        for (;;) {
            if (!radial(l, c, hi, &f, &df) || isnan(f)) return false;
            if (f >= rho) break;
            lo = hi;
            hi *= 2;
            if (!isfinite(hi)) return false;
        }
    }
    if (!radial(l, c, 0, &f, &df)) return false;
    double r = fmin(fmax(rho / df, lo), hi);
    for (int it = 0; it < 200; it++) {
        if (!radial(l, c, r, &f, &df)) return false;
        double fr = f - rho;
        if (fr == 0) break;
        if (fr < 0)
            lo = r;
        else
            hi = r;
        double rn = df > 0 ? r - fr / df : NAN;
        if (!(rn > lo && rn < hi)) rn = 0.5 * (lo + hi);
        if (rn == r || !(hi > lo)) break;
        bool done = fabs(rn - r) <= 1e-16 * r;
        r = rn;
        if (done) break;
    }
    *out = r;
    return true;
}

/* OpenCV's projection of a view tangent to a panel pixel (cv::projectPoints' distortion, y pointing down). */
static void opencv_project(const warp_lens *l, int c, double u, double v, double *x, double *y)
{
    const warp_lens_channel *m = &l->m[c];
    double xp = u, yp = -v, r2 = xp * xp + yp * yp;
    double F = 1 + r2 * (m->k[0] + r2 * (m->k[1] + r2 * (m->k[2] + r2 * m->k[3])));
    double xpp = xp * F + 2 * l->p1 * xp * yp + l->p2 * (r2 + 2 * xp * xp);
    double ypp = yp * F + l->p1 * (r2 + 2 * yp * yp) + 2 * l->p2 * xp * yp;
    *x = m->cx + l->scale * xpp;
    *y = m->cy + l->scale_y * ypp;
}

/* Panel pixel -> tangent for opencv: the radial inverse, then Newton on the full model when p1 or p2 are set
 * (the tangential terms are small: the radial answer starts Newton well inside its basin). */
static void opencv_unproject(const warp_lens *l, int c, double x, double y, double *u, double *v)
{
    const warp_lens_channel *m = &l->m[c];
    double xpp = (x - m->cx) / l->scale, ypp = (y - m->cy) / l->scale_y, rho = hypot(xpp, ypp), r;
    if (!radial_inverse(l, c, rho, limit_of(l, c), &r)) {
        *u = *v = NAN;
        return;
    }
    double xp = rho > 0 ? xpp * r / rho : 0, yp = rho > 0 ? ypp * r / rho : 0;
    if (l->p1 != 0 || l->p2 != 0) {
        const double *k = m->k, p1 = l->p1, p2 = l->p2;
        for (int it = 0; it < 50; it++) {
            double r2 = xp * xp + yp * yp;
            double F = 1 + r2 * (k[0] + r2 * (k[1] + r2 * (k[2] + r2 * k[3])));
            double dF = k[0] + r2 * (2 * k[1] + r2 * (3 * k[2] + r2 * 4 * k[3]));
            double X = xp * F + 2 * p1 * xp * yp + p2 * (r2 + 2 * xp * xp) - xpp;
            double Y = yp * F + p1 * (r2 + 2 * yp * yp) + 2 * p2 * xp * yp - ypp;
            double a = F + 2 * xp * xp * dF + 2 * p1 * yp + 6 * p2 * xp, b = 2 * xp * yp * dF + 2 * p1 * xp + 2 * p2 * yp;
            double cc = 2 * xp * yp * dF + 2 * p1 * xp + 2 * p2 * yp, d = F + 2 * yp * yp * dF + 6 * p1 * yp + 2 * p2 * xp;
            double det = a * d - b * cc;
            if (!(fabs(det) > 0)) break;
            double dx = (d * X - b * Y) / det, dy = (a * Y - cc * X) / det;
            xp -= dx;
            yp -= dy;
            if (fabs(dx) + fabs(dy) <= 1e-15 * (1 + fabs(xp) + fabs(yp))) break;
        }
    }
    *u = xp;
    *v = -yp;
}

static void model_distort(const warp_lens *l, int c, double x, double y, double *u, double *v)
{
    if (l->model == WARP_LENS_OPENCV) {
        opencv_unproject(l, c, x, y, u, v);
        return;
    }
    const warp_lens_channel *m = &l->m[c];
    double qx = (x - m->cx) / l->scale, qy = (m->cy - y) / l->scale_y, r = hypot(qx, qy), f, df, s;
    if (!radial(l, c, r, &f, &df))
        s = NAN;
    else
        s = r > 0 ? f / r : df;
    *u = m->tsx * qx * s + m->tbx;
    *v = m->tsy * qy * s + m->tby;
}

static bool model_undistort(const warp_lens *l, int c, double u, double v, double *x, double *y)
{
    const warp_lens_channel *m = &l->m[c];
    if (!isfinite(u) || !isfinite(v) || !channel_finite(l, c)) return false;
    double rmax = limit_of(l, c);
    if (!(rmax > 0)) return false;
    double xo, yo;
    if (l->model == WARP_LENS_OPENCV) {
        if (isfinite(rmax) && !(hypot(u, v) <= rmax)) return false; /* beyond the fold */
        opencv_project(l, c, u, v, &xo, &yo);
    } else {
        double px = (u - m->tbx) / m->tsx, py = (v - m->tby) / m->tsy, rho = hypot(px, py), r;
        if (!radial_inverse(l, c, rho, rmax, &r)) return false;
        double k = rho > 0 ? r / rho : 0;
        xo = m->cx + px * k * l->scale;
        yo = m->cy - py * k * l->scale_y;
    }
    if (!isfinite(xo) || !isfinite(yo)) return false;
    *x = xo;
    *y = yo;
    return true;
}

static const char *model_check(const warp_lens *l, int w, int h, char *buf, int buflen)
{
    const char *model = warp_lens_model_name(l->model);
    if ((int)l->model < 0 || l->model >= WARP_LENS_MODELS) return fail(buf, buflen, "lens model %d unknown", (int)l->model);
    for (int c = 0; c < 3; c++) {
        const warp_lens_channel *m = &l->m[c];
        if (!channel_finite(l, c))
            return fail(buf, buflen,
                        "%s lens %s channel: coefficients (%g, %g, %g, %g), centre (%g, %g), scales (%g, %g) and "
                        "tangent scales (%g, %g) must be finite, the scales positive",
                        model, channel_name[c], m->k[0], m->k[1], m->k[2], m->k[3], m->cx, m->cy, l->scale, l->scale_y,
                        m->tsx, m->tsy);
        double rm = warp_lens_monotonic_radius(l, c);
        if (!(rm > 0))
            return fail(buf, buflen, "%s lens %s channel folds over at its centre (f'(0) <= 0)", model,
                        channel_name[c]);
        /* the farthest pixel edge from this channel's centre, in the model's normalised units */
        double dx = fmax(fabs(m->cx), fabs(w - m->cx)) / l->scale;
        double dy = fmax(fabs(m->cy), fabs(h - m->cy)) / l->scale_y;
        double corner = hypot(dx, dy);
        if (!(corner < rm))
            return fail(buf, buflen,
                        "%s lens %s channel folds over at radius %.3g (viewport corner at %.3g): inverse distortion "
                        "has no unique solution",
                        model, channel_name[c], rm, corner);
        /* every corner must come back to itself (opencv's tangential terms are not covered by the radius) */
        const double cx[4] = {0, w, 0, w}, cy[4] = {0, 0, h, h};
        for (int i = 0; i < 4; i++) {
            double u, v, x, y;
            warp_lens_distort(l, c, cx[i], cy[i], &u, &v);
            if (!isfinite(u) || !isfinite(v) || !warp_lens_undistort(l, c, u, v, &x, &y) ||
                hypot(x - cx[i], y - cy[i]) > 1e-3)
                return fail(buf, buflen,
                            "%s lens %s channel: viewport corner (%g, %g) does not map back to itself (the lens "
                            "folds over inside the viewport)",
                            model, channel_name[c], cx[i], cy[i]);
        }
    }
    return NULL;
}

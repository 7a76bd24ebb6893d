/* SPDX-License-Identifier: MIT */
/* warp_forward: McMillan's forward 3D warp (004 eq. 1): every source pixel is moved to where the target eye sees
 * it; epipoles, occlusion-compatible traversal in 4 or 8 sheets (004 §2, §4.3), a z-buffered version, the two-pass
 * binned warp (004 §5) and the worst-case pixel movement bound p (004 eqs. 5-7). Unreached pixels are holes. */
#include "warp/warp_forward.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- the warp equation ---- */

warp_fwd_xform warp_fwd_xform_make(const warp_camera *src, const warp_camera *dst, warp_pose dst_from_src)
{
    /* X1 = z1 K1^-1 xbar1 (K^-1 gives the direction at -Z = 1), X2 = R X1 + t; multiplying K2 X2 by delta = 1/z1
     * leaves H xbar1 + delta K2 t with w = z2 / z1. */
    warp_mat3 k2 = warp_camera_K(dst), k1i = warp_camera_K_inverse(src), r = warp_quat_to_mat3(dst_from_src.q);
    warp_mat3 rk = warp_mat3_mul(&r, &k1i);
    warp_fwd_xform xf;
    xf.h = warp_mat3_mul(&k2, &rk);
    xf.e = warp_mat3_apply(&k2, dst_from_src.p);
    return xf;
}

bool warp_fwd_xform_apply(const warp_fwd_xform *xf, double x, double y, double d, double *x2, double *y2, double *d2)
{
    const double(*h)[3] = xf->h.m;
    double X = h[0][0] * x + h[0][1] * y + h[0][2] + d * xf->e.x;
    double Y = h[1][0] * x + h[1][1] * y + h[1][2] + d * xf->e.y;
    double W = h[2][0] * x + h[2][1] * y + h[2][2] + d * xf->e.z;
    if (!(W > 1e-9 * (fabs(X) + fabs(Y))) || !isfinite(X) || !isfinite(Y)) return false;
    *x2 = X / W;
    *y2 = Y / W;
    *d2 = d / W;
    return true;
}

/* ---- epipoles ---- */

warp_fwd_epipole warp_fwd_epipole_make(const warp_camera *src, warp_vec3 c2)
{
    warp_fwd_epipole ep;
    memset(&ep, 0, sizeof ep);
    warp_mat3 k = warp_camera_K(src);
    warp_vec3 h = warp_mat3_apply(&k, c2);
    ep.hx = h.x;
    ep.hy = h.y;
    ep.hw = h.z;
    ep.defined = warp_v3_norm(c2) > 1e-12;
    if (!ep.defined) return ep;
    /* A baseline parallel to the image plane puts the epipole at infinity: keep it far outside the image on the
     * correct side, so the sheets degenerate to one or two as 004 §2 describes. */
    double w = h.z, tiny = 1e-9 * (fabs(h.x) + fabs(h.y));
    if (fabs(w) < tiny) w = w < 0 ? -tiny : tiny;
    ep.positive = w > 0;
    ep.x = h.x / w;
    ep.y = h.y / w;
    return ep;
}

/* ---- worst-case pixel movement ---- */

static double bound_from_amax(double a_max, double t_max, double d_min)
{
    if (!(t_max >= 0) || !(d_min > 0) || !isfinite(t_max) || !(a_max > 0)) return NAN;
    if (t_max >= d_min) return INFINITY;
    return a_max * asin(t_max / d_min); /* eqs. 5, 6 */
}

double warp_fwd_pixel_bound(int v_pixels, double aspect, double vfov_rad, double t_max, double d_min)
{
    if (v_pixels <= 0 || !(aspect > 0) || !(vfov_rad > 0 && vfov_rad < WARP_PI)) return NAN;
    double c = cos(vfov_rad);
    /* eq. 7: the largest pixels-per-radian, reached at the display corners */
    double a_max = v_pixels / 2.0 / tan(vfov_rad / 2) * ((aspect * aspect + 1) * ((1 - c) / (1 + c)) + 1);
    return bound_from_amax(a_max, t_max, d_min);
}

double warp_fwd_pixel_bound_camera(const warp_camera *dst, double t_max, double d_min)
{
    if (warp_camera_check(dst)) return NAN;
    /* Radial density at tangent radius r is f (1 + r^2) (d(f tan)/d angle); it grows outwards, so the corner
     * farthest from the axis bounds it for an off-centre frustum too. */
    double u = fmax(dst->tan_left, dst->tan_right), v = fmax(dst->tan_up, dst->tan_down);
    double f = fmax(warp_camera_pixels_per_tan_x(dst), warp_camera_pixels_per_tan_y(dst));
    return bound_from_amax(f * (1 + u * u + v * v), t_max, d_min);
}

/* ---- scratch ---- */

void warp_fwd_scratch_free(warp_fwd_scratch *s)
{
    free(s->x2);
    free(s->y2);
    free(s->d2);
    free(s->jac);
    free(s->order);
    free(s->zbuf);
    free(s->rank);
    free(s->near2);
    free(s->bin_of);
    free(s->binned);
    free(s->bin_start);
    free(s->bin_fill);
    free(s->bin_key);
    memset(s, 0, sizeof *s);
}

bool warp_fwd_scratch_alloc(warp_fwd_scratch *s, int src_w, int src_h, int dst_w, int dst_h)
{
    memset(s, 0, sizeof *s);
    if (src_w <= 0 || src_h <= 0 || dst_w <= 0 || dst_h <= 0 || src_w > WARP_MAX_SIDE || src_h > WARP_MAX_SIDE ||
        dst_w > WARP_MAX_SIDE || dst_h > WARP_MAX_SIDE)
        return false;
    size_t ns = (size_t)src_w * (size_t)src_h, nd = (size_t)dst_w * (size_t)dst_h;
    s->src_w = src_w;
    s->src_h = src_h;
    s->dst_w = dst_w;
    s->dst_h = dst_h;
    s->n_bins_max = src_w; /* bin width >= 1 */
    s->x2 = malloc(ns * sizeof *s->x2);
    s->y2 = malloc(ns * sizeof *s->y2);
    s->d2 = malloc(ns * sizeof *s->d2);
    s->jac = malloc(ns * 4 * sizeof *s->jac);
    s->order = malloc(ns * sizeof *s->order);
    s->binned = malloc(ns * sizeof *s->binned);
    s->bin_start = malloc(((size_t)s->n_bins_max + 1) * sizeof *s->bin_start);
    s->bin_fill = malloc(((size_t)s->n_bins_max + 1) * sizeof *s->bin_fill);
    s->bin_key = malloc(ns * sizeof *s->bin_key);
    s->zbuf = malloc(nd * sizeof *s->zbuf);
    s->rank = malloc(nd * sizeof *s->rank);
    s->near2 = malloc(nd * sizeof *s->near2);
    s->bin_of = malloc(nd * sizeof *s->bin_of);
    if (!s->x2 || !s->y2 || !s->d2 || !s->jac || !s->order || !s->binned || !s->bin_start || !s->bin_fill ||
        !s->bin_key || !s->zbuf || !s->rank || !s->near2 || !s->bin_of) {
        warp_fwd_scratch_free(s);
        return false;
    }
    return true;
}

/* ---- setup ---- */

warp_forward_params warp_forward_default_params(void)
{
    warp_forward_params p = {WARP_FWD_SHEETS8, false, 16, 0.1f, true};
    return p;
}

const char *warp_forward_prepare(warp_fwd_setup *s, const warp_view *src, const warp_camera *dst_cam,
                                 warp_pose dst_pose, const warp_forward_params *p)
{
    if (!src->color) return "forward warp needs a colour plane";
    if (!src->inv_depth) return "forward warp needs a depth plane";
    if (src->inv_depth->w != src->color->w || src->inv_depth->h != src->color->h)
        return "depth and colour planes differ in size";
    if (src->color->w != src->cam.width || src->color->h != src->cam.height) return "source planes differ from camera";
    if (warp_camera_check(&src->cam)) return "source camera is not valid";
    if (warp_camera_check(dst_cam)) return "target camera is not valid";
    const char *bad = warp_poses_check(src->pose, dst_pose);
    if (bad) return bad;
    if (p->vis != WARP_FWD_ZBUFFER && p->vis != WARP_FWD_SHEETS4 && p->vis != WARP_FWD_SHEETS8)
        return "unknown visibility mode";
    if (p->two_pass && p->bin_width < 1) return "two-pass bin width must be at least 1";
    if (src->ids && (src->ids->w != src->color->w || src->ids->h != src->color->h))
        return "id plane differs from colour in size";
    memset(s, 0, sizeof *s);
    s->src = src;
    s->dst_cam = *dst_cam;
    s->p = *p;
    /* Relative pose first (subtracting positions before rotating keeps precision far from the world origin). */
    warp_pose src_from_dst = warp_pose_relative(src->pose, dst_pose);
    s->cam_xf = warp_fwd_xform_make(&src->cam, dst_cam, warp_pose_inverse(src_from_dst));
    s->c2_src = src_from_dst.p;
    s->ep = warp_fwd_epipole_make(&src->cam, s->c2_src);
    s->dst_to_src_inf = warp_rotation_homography(&src->cam, dst_cam, src_from_dst.q);
    return NULL;
}

/* ---- pass 1: mapping ---- */

/* d(delta)/dx from the neighbours a (left) and b (right) of c: the central difference of 002 §3.3 on smooth
 * surfaces; across a depth edge the smaller one-sided difference, so an edge does not inflate splats. */
static inline float depth_slope(float a, float c, float b, bool has_a, bool has_b, float jump)
{
    bool ok_a = has_a && fabsf(a - c) <= jump * fmaxf(a, c);
    bool ok_b = has_b && fabsf(b - c) <= jump * fmaxf(b, c);
    if (ok_a && ok_b) return (b - a) * 0.5f;
    if (ok_b) return b - c;
    if (ok_a) return c - a;
    return 0.0f; /* a one-pixel sliver: no trustworthy slope */
}

void warp_forward_map_rows(const warp_fwd_setup *s, warp_fwd_scratch *sc, bool jacobian, int y0, int y1,
                           warp_forward_stats *st)
{
    const warp_view *v = s->src;
    const warp_image_f32 *dimg = v->inv_depth;
    const int w = v->color->w, h = v->color->h;
    const double dw = s->dst_cam.width, dh = s->dst_cam.height;
    const float jump = s->p.edge_jump;
    long samples = 0, dropped = 0, bad = 0;
    for (int y = y0; y < y1; y++) {
        const float *dr = &WARP_AT(dimg, 0, y);
        const float *du = y > 0 ? &WARP_AT(dimg, 0, y - 1) : NULL;
        const float *dd = y + 1 < h ? &WARP_AT(dimg, 0, y + 1) : NULL;
        const uint16_t *ir = v->ids ? &WARP_AT(v->ids, 0, y) : NULL;
        for (int x = 0; x < w; x++) {
            size_t k = (size_t)y * (size_t)w + (size_t)x;
            const warp_fwd_xform *xf = &s->cam_xf;
            if (ir && s->obj_xf) {
                if (ir[x] < s->n_obj_xf)
                    xf = &s->obj_xf[ir[x]];
                else
                    bad++;
            }
            double px = x + 0.5, py = y + 0.5, d = dr[x], x2, y2, d2;
            samples++;
            if (!warp_fwd_xform_apply(xf, px, py, d, &x2, &y2, &d2)) {
                sc->x2[k] = sc->y2[k] = NAN;
                sc->d2[k] = 0;
                dropped++;
                continue;
            }
            sc->x2[k] = (float)x2;
            sc->y2[k] = (float)y2;
            sc->d2[k] = (float)d2;
            if (!(x2 >= 0 && x2 < dw && y2 >= 0 && y2 < dh)) dropped++;
            if (!jacobian) continue;
            float gx = depth_slope(x > 0 ? dr[x - 1] : 0, dr[x], x + 1 < w ? dr[x + 1] : 0, x > 0, x + 1 < w, jump);
            float gy = depth_slope(du ? du[x] : 0, dr[x], dd ? dd[x] : 0, du != NULL, dd != NULL, jump);
            /* 002 §3.3: J = d(P'/P'w)/d(x, y) with P' = M4 + M1 x + M2 y + M3 f(x, y). */
            const double(*m)[3] = xf->h.m;
            double W = m[2][0] * px + m[2][1] * py + m[2][2] + d * xf->e.z;
            double dXx = m[0][0] + xf->e.x * gx, dXy = m[0][1] + xf->e.x * gy;
            double dYx = m[1][0] + xf->e.y * gx, dYy = m[1][1] + xf->e.y * gy;
            double dWx = m[2][0] + xf->e.z * gx, dWy = m[2][1] + xf->e.z * gy;
            float *j = &sc->jac[4 * k];
            j[0] = (float)((dXx - x2 * dWx) / W);
            j[1] = (float)((dXy - x2 * dWy) / W);
            j[2] = (float)((dYx - y2 * dWx) / W);
            j[3] = (float)((dYy - y2 * dWy) / W);
        }
    }
    if (st) {
        st->samples += samples;
        st->dropped += dropped;
        st->bad_ids += bad;
    }
}

/* ---- traversal order ----
 * Each sheet is walked outwards from the epipole in a raster-like way: 4 sheets (quadrants) row by row, rows
 * nearest the epipole first, each row from the epipole out (004 Fig. 2); 8 sheets (004 Fig. 11) split every
 * quadrant at the diagonal, the half nearer the horizontal walked column by column, so the minor direction is never
 * closer than 45 degrees to an epipolar line. Sheets are independent in the continuous image, but in a discrete one
 * a sample next to a sheet border can land in the same target pixel as one from the neighbouring sheet; walking the
 * sheets one after another would decide those by sheet order. So the sheets advance together: they are merged on
 * their major coordinate (distance of the row or column from the epipole), which keeps each sheet's own order. The
 * back-to-front order of a negative epipole is this outward walk; a positive one reverses it (004 Fig. 1). */

typedef struct {
    int32_t *out;
    int n, w;
    double ex, ey;
} order_ctx;

/* Appends the outward walk of one sheet of quadrant [x0, x1) x [y0, y1). octant: 0 = the whole quadrant, rows
 * major (4 sheets); 1 = |dx| >= |dy|, columns major; 2 = |dy| > |dx|, rows major (8 sheets). */
static bool emit_sheet(order_ctx *c, int x0, int x1, int y0, int y1, bool left, bool top, int octant)
{
    if (x0 >= x1 || y0 >= y1) return false;
    int n0 = c->n;
    /* near the epipole first: a left quadrant ends at the epipole, so it is walked right to left */
    int xs = left ? x1 - 1 : x0, xstep = left ? -1 : 1, nx = x1 - x0;
    int ys = top ? y1 - 1 : y0, ystep = top ? -1 : 1, ny = y1 - y0;
    if (octant == 1) {
        for (int a = 0; a < nx; a++) {
            int x = xs + a * xstep;
            double adx = fabs(x + 0.5 - c->ex);
            for (int b = 0; b < ny; b++) {
                int y = ys + b * ystep;
                if (fabs(y + 0.5 - c->ey) <= adx) c->out[c->n++] = y * c->w + x;
            }
        }
    } else {
        for (int b = 0; b < ny; b++) {
            int y = ys + b * ystep;
            double ady = fabs(y + 0.5 - c->ey);
            for (int a = 0; a < nx; a++) {
                int x = xs + a * xstep;
                if (octant == 0 || fabs(x + 0.5 - c->ex) < ady) c->out[c->n++] = y * c->w + x;
            }
        }
    }
    return c->n > n0;
}

static int split_at(double e, int size)
{
    /* pixels i with centre i + 0.5 < e lie before the split */
    double s = ceil(e - 0.5);
    return s < 0 ? 0 : (s > size ? size : (int)s);
}

/* Major and minor distance of pixel idx from the epipole, as its sheet walks them. */
static inline void sheet_key(const order_ctx *c, int32_t idx, bool eight, double *major, double *minor)
{
    double dx = fabs(idx % c->w + 0.5 - c->ex), dy = fabs(idx / c->w + 0.5 - c->ey);
    if (!eight) {
        *major = dy;
        *minor = dx;
    } else {
        *major = dx >= dy ? dx : dy;
        *minor = dx >= dy ? dy : dx;
    }
}

int warp_forward_order_into(const warp_fwd_setup *s, warp_fwd_visibility vis, int32_t *order, int32_t *tmp)
{
    const int w = s->src->color->w, h = s->src->color->h;
    const int n = w * h;
    if (vis == WARP_FWD_ZBUFFER || !s->ep.defined) {
        for (int i = 0; i < n; i++) order[i] = i;
        return 1;
    }
    const bool eight = vis == WARP_FWD_SHEETS8;
    order_ctx c = {tmp, 0, w, s->ep.x, s->ep.y};
    int sx = split_at(s->ep.x, w), sy = split_at(s->ep.y, h), sheets = 0;
    const int qx0[2] = {0, sx}, qx1[2] = {sx, w}, qy0[2] = {0, sy}, qy1[2] = {sy, h};
    int start[9], end[9];
    for (int qy = 0; qy < 2; qy++)
        for (int qx = 0; qx < 2; qx++)
            for (int oct = eight ? 1 : 0; oct <= (eight ? 2 : 0); oct++) {
                start[sheets] = c.n;
                if (emit_sheet(&c, qx0[qx], qx1[qx], qy0[qy], qy1[qy], qx == 0, qy == 0, oct)) {
                    end[sheets] = c.n;
                    sheets++;
                }
            }
    /* Merge the sheets on (major, minor): at most 8 heads, so a linear scan per pixel. */
    double kmaj[8], kmin[8];
    for (int i = 0; i < sheets; i++) sheet_key(&c, tmp[start[i]], eight, &kmaj[i], &kmin[i]);
    for (int k = 0; k < n; k++) {
        int best = -1;
        for (int i = 0; i < sheets; i++) {
            if (start[i] >= end[i]) continue;
            if (best < 0 || kmaj[i] < kmaj[best] || (kmaj[i] == kmaj[best] && kmin[i] < kmin[best])) best = i;
        }
        order[k] = tmp[start[best]++];
        if (start[best] < end[best]) sheet_key(&c, tmp[start[best]], eight, &kmaj[best], &kmin[best]);
    }
    if (s->ep.positive)
        for (int i = 0, j = n - 1; i < j; i++, j--) {
            int32_t t = order[i];
            order[i] = order[j];
            order[j] = t;
        }
    return sheets;
}

int warp_forward_order(const warp_fwd_setup *s, warp_fwd_visibility vis, warp_fwd_scratch *sc)
{
    return warp_forward_order_into(s, vis, sc->order, sc->binned);
}

/* ---- pass 2: drawing points ---- */

void warp_forward_clear(warp_fwd_scratch *sc)
{
    size_t nd = (size_t)sc->dst_w * (size_t)sc->dst_h;
    for (size_t i = 0; i < nd; i++) {
        sc->zbuf[i] = -1.0f;
        sc->rank[i] = -1;
        sc->bin_of[i] = -1;
    }
}

static inline bool target_of(const warp_fwd_scratch *sc, int32_t k, int32_t *t)
{
    float x = sc->x2[k], y = sc->y2[k];
    if (!(x >= 0 && y >= 0 && x < (float)sc->dst_w && y < (float)sc->dst_h)) return false;
    int i = (int)x, j = (int)y;
    if (i >= sc->dst_w || j >= sc->dst_h) return false;
    *t = j * sc->dst_w + i;
    return true;
}

/* Footprints are grown by this factor: each is the linearisation at its own sample, so neighbours' parallelograms
 * on a curving warp (a rotation's homography) leave slivers between them, and a pixel centre in one is a crack. */
#define FOOTPRINT_GROW 1.1
/* Largest footprint side (pixels): a larger Jacobian belongs to a surface seen almost edge-on, or to a depth slope
 * across an edge the one-sided differences missed; drawing it would smear one colour over a wide area. */
#define FOOTPRINT_MAX 4.0
/* Pixels one footprint can cover: at most (FOOTPRINT_MAX + 1)^2 centres in its box, plus the pixel it lands in. */
#define FOOTPRINT_PIXELS 26

/* Pixels whose centres lie in [lo, hi) (the half-open rule keeps abutting footprints from sharing pixels). */
static inline void span(double lo, double hi, int n, int *a, int *b)
{
    double fa = ceil(lo - 0.5), fb = ceil(hi - 0.5);
    *a = fa < 0 ? 0 : (fa > n ? n : (int)fa);
    *b = fb < 0 ? 0 : (fb > n ? n : (int)fb);
}

/* The target pixels sample k covers: the one it lands in first (a minified sample still shows, as a point would),
 * then, with footprints, the other pixel centres inside its grown parallelogram. Returns their count. */
static int footprint(const warp_fwd_setup *s, const warp_fwd_scratch *sc, int32_t k, int32_t *t)
{
    int n = 0;
    int32_t home = -1;
    if (target_of(sc, k, &home)) t[n++] = home;
    if (!s->p.footprint) return n;
    const float *j = &sc->jac[4 * k];
    double g = 0.5 * FOOTPRINT_GROW, lim = 0.5 * FOOTPRINT_MAX;
    double ax = g * j[0], ay = g * j[2], bx = g * j[1], by = g * j[3];
    double ex = fabs(ax) + fabs(bx), ey = fabs(ay) + fabs(by);
    if (!(ex <= lim && ey <= lim)) {
        double f = lim / fmax(ex, ey);
        if (!isfinite(f)) return n;
        ax *= f, ay *= f, bx *= f, by *= f, ex *= f, ey *= f;
    }
    double det = ax * by - bx * ay, cx = sc->x2[k], cy = sc->y2[k];
    if (!(fabs(det) > 1e-6) || !(cx > -lim && cy > -lim && cx < sc->dst_w + lim && cy < sc->dst_h + lim)) return n;
    int x0, x1, y0, y1;
    span(cx - ex, cx + ex, sc->dst_w, &x0, &x1);
    span(cy - ey, cy + ey, sc->dst_h, &y0, &y1);
    for (int y = y0; y < y1; y++) {
        double dy = y + 0.5 - cy;
        for (int x = x0; x < x1; x++) {
            double dx = x + 0.5 - cx;
            /* coordinates in the (a, b) frame of the parallelogram: inside when both are in [-1, 1) */
            double al = (by * dx - bx * dy) / det, be = (ax * dy - ay * dx) / det;
            int32_t i = y * sc->dst_w + x;
            if (al >= -1 && al < 1 && be >= -1 && be < 1 && i != home) t[n++] = i;
        }
    }
    return n;
}

/* The colour of target pixel t drawn by sample k: with footprints, the source resampled bilinearly at the point
 * J^-1 maps t's centre back to (at most a pixel from the sample, the linearisation's reach). Bilinear across depth
 * edges too, as the backward warps resample: a pure rotation then gives exactly their image. */
static warp_rgba8 sample_colour(const warp_fwd_setup *s, const warp_fwd_scratch *sc, int32_t k, int32_t t)
{
    const warp_view *v = s->src;
    const int w = v->color->w, h = v->color->h, kx = k % w, ky = k / w;
    if (!s->p.footprint) return WARP_AT(v->color, kx, ky);
    const float *j = &sc->jac[4 * k];
    double det = (double)j[0] * j[3] - (double)j[1] * j[2];
    double px = t % sc->dst_w + 0.5 - sc->x2[k], py = t / sc->dst_w + 0.5 - sc->y2[k];
    double u = (j[3] * px - j[1] * py) / det, vv = (j[0] * py - j[2] * px) / det;
    if (!(fabs(det) > 1e-6) || !isfinite(u) || !isfinite(vv)) return WARP_AT(v->color, kx, ky);
    /* taps around source position (kx + 0.5 + u, ky + 0.5 + vv), clamped to the image */
    double sx = kx + fmin(1, fmax(-1, u)), sy = ky + fmin(1, fmax(-1, vv));
    int x0 = (int)floor(sx), y0 = (int)floor(sy);
    double fx = sx - x0, fy = sy - y0;
    int xa = x0 < 0 ? 0 : x0, ya = y0 < 0 ? 0 : y0;
    int xb = x0 + 1 >= w ? w - 1 : x0 + 1, yb = y0 + 1 >= h ? h - 1 : y0 + 1;
    warp_rgba8 c00 = WARP_AT(v->color, xa, ya), c10 = WARP_AT(v->color, xb, ya);
    warp_rgba8 c01 = WARP_AT(v->color, xa, yb), c11 = WARP_AT(v->color, xb, yb);
    double w00 = (1 - fx) * (1 - fy), w10 = fx * (1 - fy), w01 = (1 - fx) * fy, w11 = fx * fy;
    warp_rgba8 c;
    c.r = (uint8_t)(w00 * c00.r + w10 * c10.r + w01 * c01.r + w11 * c11.r + 0.5);
    c.g = (uint8_t)(w00 * c00.g + w10 * c10.g + w01 * c01.g + w11 * c11.g + 0.5);
    c.b = (uint8_t)(w00 * c00.b + w10 * c10.b + w01 * c01.b + w11 * c11.b + 0.5);
    c.a = (uint8_t)(w00 * c00.a + w10 * c10.a + w01 * c01.a + w11 * c11.a + 0.5);
    return c;
}

static inline void put(const warp_fwd_setup *s, warp_image_rgba8 *dst, warp_fwd_scratch *sc, int32_t k, int32_t t)
{
    WARP_AT(dst, t % sc->dst_w, t / sc->dst_w) = sample_colour(s, sc, k, t);
    sc->zbuf[t] = sc->d2[k];
}

static void draw_two_pass(const warp_fwd_setup *s, warp_fwd_scratch *sc, warp_image_rgba8 *dst,
                          warp_forward_stats *st)
{
    const warp_view *v = s->src;
    const int w = v->color->w, n = w * v->color->h, b = s->p.bin_width;
    int nb = (w + b - 1) / b;
    if (nb > sc->n_bins_max) nb = sc->n_bins_max;
    const double ex = s->ep.hx, ew = s->ep.hw;
    int32_t *start = sc->bin_start;
    for (int i = 0; i <= nb; i++) start[i] = 0;
    /* 004 eq. 8: bin by the post-translation, pre-rotation x: xbar1 + delta K1 (C1 - C2), C1 = 0. The bins are
     * counting-sorted stably, so each keeps the traversal order of pass 1. */
    for (int k = 0; k < n; k++) {
        int32_t idx = sc->order[k];
        int x = idx % w, y = idx / w;
        double d = WARP_AT(v->inv_depth, x, y);
        double den = 1 - d * ew, xp = (x + 0.5 - d * ex) / den;
        int bin = den > 0 && isfinite(xp) ? (int)floor(xp / b) : 0;
        bin = bin < 0 ? 0 : (bin >= nb ? nb - 1 : bin);
        sc->bin_key[k] = bin;
        start[bin + 1]++;
    }
    for (int i = 0; i < nb; i++) start[i + 1] += start[i];
    int32_t *fill = sc->bin_fill;
    for (int i = 0; i < nb; i++) fill[i] = start[i];
    for (int k = 0; k < n; k++) sc->binned[fill[sc->bin_key[k]]++] = k;

    long writes = 0, seams = 0;
    for (int bi = 0; bi < nb; bi++)
        for (int q = start[bi]; q < start[bi + 1]; q++) {
            int32_t k = sc->binned[q], idx = sc->order[k], ts[FOOTPRINT_PIXELS];
            int nt = footprint(s, sc, idx, ts);
            for (int f = 0; f < nt; f++) {
                int32_t t = ts[f];
                /* Within a bin later means later in the occlusion-compatible order. Where two bins meet (samples
                 * of one output pixel straddling a bin border) the order positions decide, so the result is
                 * exactly the single-pass one. */
                if (sc->bin_of[t] >= 0 && sc->bin_of[t] != bi) {
                    seams++;
                    if (k < sc->rank[t]) continue;
                }
                put(s, dst, sc, idx, t);
                sc->rank[t] = k;
                sc->bin_of[t] = bi;
                writes++;
            }
        }
    if (st) {
        st->writes += writes;
        st->seam_resolves += seams;
        st->bins = nb;
    }
}

void warp_forward_draw_points(const warp_fwd_setup *s, warp_fwd_scratch *sc, warp_image_rgba8 *dst,
                              warp_forward_stats *st)
{
    if (s->p.two_pass && s->p.vis != WARP_FWD_ZBUFFER) {
        draw_two_pass(s, sc, dst, st);
        return;
    }
    const warp_view *v = s->src;
    const int n = v->color->w * v->color->h;
    const bool zt = s->p.vis == WARP_FWD_ZBUFFER;
    long writes = 0, rejects = 0;
    for (int k = 0; k < n; k++) {
        int32_t idx = sc->order[k], ts[FOOTPRINT_PIXELS];
        int nt = footprint(s, sc, idx, ts);
        for (int f = 0; f < nt; f++) {
            int32_t t = ts[f];
            /* Ties go to the later sample, as in the painter's order. */
            if (zt && sc->d2[idx] < sc->zbuf[t]) {
                rejects++;
                continue;
            }
            put(s, dst, sc, idx, t);
            writes++;
        }
    }
    if (st) {
        st->writes += writes;
        st->depth_rejects += rejects;
    }
}

void warp_forward_finish_rows(const warp_fwd_setup *s, const warp_fwd_scratch *sc, warp_image_rgba8 *dst,
                              warp_image_u8 *mask, int y0, int y1, warp_forward_stats *st)
{
    const double sw = s->src->color->w, sh = s->src->color->h;
    const double(*h)[3] = s->dst_to_src_inf.m;
    long holes = 0, fringe = 0;
    for (int y = y0; y < y1; y++) {
        const float *z = &sc->zbuf[(size_t)y * (size_t)sc->dst_w];
        warp_rgba8 *out = &WARP_AT(dst, 0, y);
        uint8_t *m = mask ? &WARP_AT(mask, 0, y) : NULL;
        for (int x = 0; x < sc->dst_w; x++) {
            if (z[x] >= 0) {
                if (m) m[x] = 0;
                continue;
            }
            out[x] = (warp_rgba8){0, 0, 0, 0};
            holes++;
            double px = x + 0.5, py = y + 0.5;
            double hx = h[0][0] * px + h[0][1] * py + h[0][2], hy = h[1][0] * px + h[1][1] * py + h[1][2];
            double hw = h[2][0] * px + h[2][1] * py + h[2][2];
            bool outside = !(hw > 0) || !(hx >= 0 && hx <= sw * hw && hy >= 0 && hy <= sh * hw);
            fringe += outside;
            if (m) m[x] = (uint8_t)(WARP_MASK_HOLE | (outside ? WARP_MASK_FRINGE : 0));
        }
    }
    if (st) {
        st->holes += holes;
        st->fringe += fringe;
    }
}

const char *warp_fwd_check_sizes(const warp_view *src, const warp_camera *dst_cam, const warp_fwd_scratch *sc,
                                 const warp_image_rgba8 *dst, const warp_image_u8 *mask)
{
    if (sc->src_w != src->color->w || sc->src_h != src->color->h || sc->dst_w != dst_cam->width ||
        sc->dst_h != dst_cam->height)
        return "scratch was allocated for other image sizes";
    if (dst->w != dst_cam->width || dst->h != dst_cam->height) return "target image differs from target camera";
    if (mask && (mask->w != dst->w || mask->h != dst->h)) return "mask differs from target image";
    return NULL;
}

const char *warp_forward_run(const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose,
                             const warp_forward_params *p, warp_fwd_scratch *sc, warp_image_rgba8 *dst,
                             warp_image_u8 *mask, warp_forward_stats *st)
{
    warp_fwd_setup s;
    const char *err = warp_forward_prepare(&s, src, dst_cam, dst_pose, p);
    if (err) return err;
    err = warp_fwd_check_sizes(src, dst_cam, sc, dst, mask);
    if (err) return err;
    warp_forward_stats local;
    memset(&local, 0, sizeof local);
    warp_forward_map_rows(&s, sc, p->footprint, 0, src->color->h, &local);
    local.sheets = warp_forward_order(&s, p->vis, sc);
    warp_forward_clear(sc);
    warp_forward_draw_points(&s, sc, dst, &local);
    warp_forward_finish_rows(&s, sc, dst, mask, 0, dst->h, &local);
    if (st) *st = local;
    return NULL;
}

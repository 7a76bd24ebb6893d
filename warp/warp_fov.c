/* SPDX-License-Identifier: MIT */
/* warp_fov: the field each eye sees through its lens: the panel's visible region (the hidden-area mask), the eye
 * camera's tangents that cover it in every colour channel plus a guard band, and the share sampling outside the source. */
#include "warp/warp_fov.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "warp/warp_err.h"

#define DEG (3.14159265358979323846 / 180.0)
/* A widened half-angle must stay below this: tan(89 deg) = 57, beyond which a pinhole eye buffer is all periphery. */
#define MAX_HALF_DEG 89.0
/* warp_err's message, returned as the message */
#define FAIL(...) (warp_err(buf, buflen, __VA_ARGS__), (const char *)buf)

/* Whether the whole circle of normalised radius r around the lens centre lies where every channel's lens still
 * shows the panel (warp_lens_in_view: a Vive-class lens's undistort_r2_cutoff; every other model, everywhere). */
static bool circle_in_view(const warp_lens *lens, double r)
{
    enum { POINTS = 64 };
    for (int i = 0; i < POINTS; i++) {
        const double a = 2 * 3.14159265358979323846 * i / POINTS;
        const double x = lens->center_x + r * lens->scale * cos(a), y = lens->center_y + r * lens->scale * sin(a);
        for (int c = 0; c < 3; c++)
            if (!warp_lens_in_view(lens, c, x, y)) return false;
    }
    return true;
}

double warp_fov_visible_radius(const warp_lens *lens, double radius_cfg, int vp_w, int vp_h)
{
    const double cx = lens->center_x, cy = lens->center_y, s = lens->scale;
    if (!(s > 0) || !isfinite(s) || !isfinite(cx) || !isfinite(cy) || vp_w <= 0 || vp_h <= 0) return 0;
    if (!(cx > 0 && cx < vp_w && cy > 0 && cy < vp_h)) return 0;
    double r = isfinite(radius_cfg) && radius_cfg > 0 ? radius_cfg : fmin(fmin(cx, vp_w - cx), fmin(cy, vp_h - cy)) / s;
    for (int c = 0; c < 3; c++) {
        double mr = warp_lens_monotonic_radius(lens, c);
        if (!(mr > 0)) return 0;
        r = fmin(r, 0.999 * mr);
    }
    /* auto stops where the lens's own view ends (the model's cutoff), found by bisection; a configured radius is
     * the user's to choose */
    if (!(isfinite(radius_cfg) && radius_cfg > 0) && !circle_in_view(lens, r)) {
        double lo = 0, hi = r;
        for (int i = 0; i < 40; i++) {
            const double mid = 0.5 * (lo + hi);
            if (circle_in_view(lens, mid)) lo = mid;
            else hi = mid;
        }
        r = lo;
    }
    return r;
}

bool warp_fov_pixel_visible(const warp_lens *lens, double radius, int vp_w, int vp_h, int x, int y)
{
    if (x < 0 || y < 0 || x >= vp_w || y >= vp_h) return false;
    const double dx = x + 0.5 - lens->center_x, dy = y + 0.5 - lens->center_y, rp = radius * lens->scale;
    return dx * dx + dy * dy <= rp * rp;
}

int64_t warp_fov_spans(const warp_lens *lens, double radius, int vp_w, int vp_h, int32_t *span)
{
    int64_t n = 0;
    const double rp = radius * lens->scale, cx = lens->center_x;
    for (int y = 0; y < vp_h; y++) {
        int x0 = 0, x1 = 0;
        const double dy = y + 0.5 - lens->center_y;
        if (rp > 0 && dy * dy <= rp * rp) {
            /* the disc's chord, then settled on the exact predicate (rounding at the ends) */
            const double half = sqrt(rp * rp - dy * dy);
            double a = ceil(cx - half - 0.5), b = floor(cx + half - 0.5) + 1;
            x0 = a < 0 ? 0 : a > vp_w ? vp_w : (int)a;
            x1 = b < 0 ? 0 : b > vp_w ? vp_w : (int)b;
            while (x0 < x1 && !warp_fov_pixel_visible(lens, radius, vp_w, vp_h, x0, y)) x0++;
            while (x0 > 0 && warp_fov_pixel_visible(lens, radius, vp_w, vp_h, x0 - 1, y)) x0--;
            while (x1 > x0 && !warp_fov_pixel_visible(lens, radius, vp_w, vp_h, x1 - 1, y)) x1--;
            while (x1 < vp_w && x1 >= x0 && warp_fov_pixel_visible(lens, radius, vp_w, vp_h, x1, y)) x1++;
            if (x1 <= x0) x0 = x1 = 0;
        }
        span[2 * y] = x0;
        span[2 * y + 1] = x1;
        n += x1 - x0;
    }
    return n;
}

typedef struct {
    double umin, umax, vmin, vmax;
    bool any;
} extent;

static void see(const warp_lens *lens, int x, int y, extent *e)
{
    for (int c = 0; c < 3; c++) {
        double u, v;
        warp_lens_distort(lens, c, x + 0.5, y + 0.5, &u, &v);
        e->umin = fmin(e->umin, u);
        e->umax = fmax(e->umax, u);
        e->vmin = fmin(e->vmin, v);
        e->vmax = fmax(e->vmax, v);
    }
    e->any = true;
}

/* The span of row y, or an empty one outside the viewport. */
static void row_span(const int32_t *span, int vp_h, int y, int *x0, int *x1)
{
    if (y < 0 || y >= vp_h) {
        *x0 = *x1 = 0;
        return;
    }
    *x0 = span[2 * y];
    *x1 = span[2 * y + 1];
}

const char *warp_fov_tangents(const warp_lens *lens, double radius, int vp_w, int vp_h, double guard_deg,
                              double tangent[4], char *buf, int buflen)
{
    if (vp_w <= 0 || vp_h <= 0 || vp_h > WARP_MAX_SIDE) return FAIL("no viewport (%dx%d)", vp_w, vp_h);
    if (!isfinite(guard_deg) || guard_deg < 0 || guard_deg >= MAX_HALF_DEG)
        return FAIL("guard band %g deg: expected 0 to %g", guard_deg, MAX_HALF_DEG);
    int32_t *span = malloc(sizeof *span * 2 * (size_t)vp_h);
    if (!span) return FAIL("out of memory");
    extent e = {INFINITY, -INFINITY, INFINITY, -INFINITY, false};
    if (radius > 0 && warp_fov_spans(lens, radius, vp_w, vp_h, span) > 0) {
        for (int y = 0; y < vp_h; y++) {
            int x0, x1, a0, a1, b0, b1;
            row_span(span, vp_h, y, &x0, &x1);
            if (x0 >= x1) continue;
            row_span(span, vp_h, y - 1, &a0, &a1);
            row_span(span, vp_h, y + 1, &b0, &b1);
            /* border pixels: the row's ends and whatever a neighbour row does not cover */
            int i0 = x0 + 1, i1 = x1 - 1;
            if (a0 > i0) i0 = a0;
            if (b0 > i0) i0 = b0;
            if (a1 < i1) i1 = a1;
            if (b1 < i1) i1 = b1;
            if (i1 < i0) i1 = i0;
            for (int x = x0; x < i0 && x < x1; x++) see(lens, x, y, &e);
            for (int x = i1 > i0 ? i1 : i0; x < x1; x++) see(lens, x, y, &e);
        }
    }
    free(span);
    if (!e.any) return FAIL("no panel pixel lies in the lens's visible region (radius %g)", radius);
    const double t[4] = {-e.umin, e.umax, e.vmax, -e.vmin};
    static const char *const side[4] = {"left", "right", "up", "down"};
    for (int i = 0; i < 4; i++) {
        const double a = atan(t[i]) / DEG + guard_deg;
        if (!isfinite(a) || a >= MAX_HALF_DEG)
            return FAIL("the visible region reaches %.1f deg %s, %.1f with the guard band: more than %g",
                            atan(t[i]) / DEG, side[i], a, MAX_HALF_DEG);
        tangent[i] = tan(a * DEG);
    }
    return NULL;
}

int warp_fov_mask_loop(const warp_lens *lens, double radius, int vp_w, int vp_h, double guard_deg, int n, float *uv)
{
    const double cx = lens->center_x, cy = lens->center_y, rp = radius * lens->scale;
    if (n < 3 || n > WARP_FOV_MASK_MAX || !(rp > 0) || !isfinite(guard_deg) || guard_deg < 0) return 0;
    /* the region of pixel centres: the disc within [0.5, w - 0.5] x [0.5, h - 0.5], star-shaped around the centre */
    const double lo_x = 0.5, hi_x = vp_w - 0.5, lo_y = 0.5, hi_y = vp_h - 0.5;
    if (!(cx > lo_x && cx < hi_x && cy > lo_y && cy < hi_y)) return 0;
    const double widen = 1.0 / cos(3.14159265358979323846 / n), amax = MAX_HALF_DEG * DEG;
    for (int k = 0; k < n; k++) {
        /* counter-clockwise in tangent space (u right, v up): panel rows grow downwards */
        const double phi = 2 * 3.14159265358979323846 * k / n, dx = cos(phi), dy = -sin(phi);
        double d = rp;
        if (dx > 1e-12) d = fmin(d, (hi_x - cx) / dx);
        if (dx < -1e-12) d = fmin(d, (lo_x - cx) / dx);
        if (dy > 1e-12) d = fmin(d, (hi_y - cy) / dy);
        if (dy < -1e-12) d = fmin(d, (lo_y - cy) / dy);
        double bu = 0, bv = 0, brho = -1;
        for (int c = 0; c < 3; c++) {
            double u, v;
            warp_lens_distort(lens, c, cx + d * dx, cy + d * dy, &u, &v);
            double rho = hypot(u, v);
            if (rho > brho) bu = u, bv = v, brho = rho;
        }
        if (!(brho > 0) || !isfinite(brho)) return 0;
        const double a = fmin(atan(brho) + guard_deg * DEG, amax), rho = tan(a) * widen;
        uv[2 * k] = (float)(bu / brho * rho);
        uv[2 * k + 1] = (float)(bv / brho * rho);
    }
    return n;
}

double warp_fov_default_guard_deg(double deg_per_s, double frame_age_s) { return deg_per_s * frame_age_s; }

bool warp_fov_weights_alloc(warp_fov_weights *w, const warp_mesh *m, const int32_t *span)
{
    memset(w, 0, sizeof *w);
    const int n = m->rows * m->cols;
    w->weight = calloc((size_t)n, sizeof *w->weight);
    if (!w->weight) return false;
    w->n = n;
    for (int y = 0; y < m->vp_h; y++) {
        const int x0 = span ? span[2 * y] : 0, x1 = span ? span[2 * y + 1] : m->vp_w;
        /* the nearest vertex row and column of a pixel centre (vertex positions: warp_mesh.h) */
        int j = (int)floor((y + 0.5) * (m->rows - 1) / m->vp_h + 0.5);
        j = j < m->rows - 1 ? j : m->rows - 1;
        for (int x = x0; x < x1; x++) {
            int i = (int)floor((x + 0.5) / m->cell_w + 0.5);
            i = i < m->cols - 1 ? i : m->cols - 1;
            w->weight[j * m->cols + i]++;
        }
        w->visible += x1 - x0;
    }
    return true;
}

void warp_fov_weights_free(warp_fov_weights *w)
{
    free(w->weight);
    memset(w, 0, sizeof *w);
}

int64_t warp_fov_outside(const warp_fov_weights *w, const warp_mesh *m, int src_w, int src_h)
{
    if (!w->weight || w->n != m->rows * m->cols) return 0;
    const float fw = (float)src_w, fh = (float)src_h;
    int64_t out = 0;
    for (int k = 0; k < w->n; k++) {
        if (!w->weight[k]) continue;
        const warp_vec2f *s = &m->src[(size_t)k * 3];
        for (int c = 0; c < 3; c++)
            if (!(s[c].x >= 0 && s[c].x <= fw && s[c].y >= 0 && s[c].y <= fh)) {
                out += w->weight[k];
                break;
            }
    }
    return out;
}

int64_t warp_fov_outside_exact(const warp_mesh *m, int src_w, int src_h)
{
    int64_t out = 0;
    for (int y = 0; y < m->vp_h; y++) {
        const int x0 = m->visible ? m->visible[2 * y] : 0, x1 = m->visible ? m->visible[2 * y + 1] : m->vp_w;
        const double gy = (y + 0.5) * (m->rows - 1) / m->vp_h;
        const int j = (int)gy < m->rows - 2 ? (int)gy : m->rows - 2;
        const double ty = gy - j;
        for (int x = x0; x < x1; x++) {
            const int i = x / m->cell_w;
            const double fx = (x + 0.5 - (double)i * m->cell_w) / m->cell_w;
            for (int c = 0; c < 3; c++) {
                const warp_vec2f *p00 = &m->src[((size_t)j * m->cols + i) * 3 + c], *p10 = p00 + 3;
                const warp_vec2f *p01 = p00 + (size_t)m->cols * 3, *p11 = p01 + 3;
                const double lx = p00->x + (p01->x - p00->x) * ty, rx = p10->x + (p11->x - p10->x) * ty;
                const double ly = p00->y + (p01->y - p00->y) * ty, ry = p10->y + (p11->y - p10->y) * ty;
                const double sx = lx + (rx - lx) * fx, sy = ly + (ry - ly) * fx;
                if (!(sx >= 0 && sx <= src_w && sy >= 0 && sy <= src_h)) {
                    out++;
                    break;
                }
            }
        }
    }
    return out;
}

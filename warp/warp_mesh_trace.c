/* SPDX-License-Identifier: MIT */
/* warp_mesh_trace: the per-pixel part of the display path's depth warp: the lens mesh cells whose rays meet a depth
 * discontinuity (000 §3: the grid is refined only there) are raytraced per pixel (003 §3.5), the rest interpolated. */
#include "warp/warp_mesh_trace.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

warp_mesh_trace_params warp_mesh_trace_default_params(void)
{
    warp_mesh_trace_params p = {1.0f};
    return p;
}

bool warp_mesh_trace_alloc(warp_mesh_trace *t, const warp_mesh *m)
{
    memset(t, 0, sizeof *t);
    if (m->rows < 2 || m->cols < 2) return false;
    t->cells_x = m->cols - 1;
    t->cells_y = m->rows - 1;
    t->cell = calloc((size_t)t->cells_x * (size_t)t->cells_y, 1);
    return t->cell != NULL;
}

void warp_mesh_trace_free(warp_mesh_trace *t)
{
    free(t->cell);
    memset(t, 0, sizeof *t);
}

static int clampi(int v, int lo, int hi) { return v < lo ? lo : (v > hi ? hi : v); }

/* Whether cell (i, j) needs per-pixel rays (the criteria in warp_mesh_trace.h). */
static bool cell_discontinuous(const warp_mesh *m, int i, int j, const warp_camera *dst_cam,
                               const warp_raytrace_setup *s, const warp_raytrace_setup *last, const warp_scan *scan,
                               const warp_mesh_trace_params *p)
{
    const size_t v[4] = {(size_t)j * m->cols + i, (size_t)j * m->cols + i + 1, (size_t)(j + 1) * m->cols + i,
                         (size_t)(j + 1) * m->cols + i + 1};
    uint8_t any = 0, all = 0xff;
    for (int k = 0; k < 4; k++) {
        any |= m->flags[v[k]];
        all &= m->flags[v[k]];
    }
    /* wholly outside the source: the clamped fringe fill, per pixel or interpolated alike */
    if (all & WARP_MASK_FRINGE) return false;
    /* some rays left the source or crossed an edge and others did not: the boundary runs through the cell */
    if (any != all || (any & WARP_MASK_EDGE)) return true;
    /* the ray through the cell's centre (green) */
    const warp_vec2f *tn = m->tan;
    double tx, ty;
    warp_camera_tan_to_pixel(dst_cam,
                             0.25 * (tn[v[0] * 3 + 1].x + tn[v[1] * 3 + 1].x + tn[v[2] * 3 + 1].x + tn[v[3] * 3 + 1].x),
                             0.25 * (tn[v[0] * 3 + 1].y + tn[v[1] * 3 + 1].y + tn[v[2] * 3 + 1].y + tn[v[3] * 3 + 1].y),
                             &tx, &ty);
    /* The centre ray (000 §4.1's error test of a grid cell): corners on both sides of an edge, an object between
     * them or one surface too curved for the interpolation land it away from where the corners put it, while on a
     * slanted surface it lands there however much the depth changes. One ray per cell, a third of a vertex's. */
    double cx, cy;
    if (warp_raytrace_point(s, tx, ty, &cx, &cy, NULL) != all) return true;
    if (last && scan) {
        /* rolling: the vertices hold their own scan line's interpolation; the centre takes its own */
        const double f = warp_scan_fraction(scan, m->vp_x + (i + 0.5) * m->cell_w,
                                            m->vp_y + (j + 0.5) * (double)m->vp_h / (m->rows - 1));
        double lx, ly;
        if (warp_raytrace_point(last, tx, ty, &lx, &ly, NULL) != all) return true;
        cx += (lx - cx) * f;
        cy += (ly - cy) * f;
    }
    double ix = 0, iy = 0;
    for (int k = 0; k < 4; k++) {
        ix += 0.25 * m->src[v[k] * 3 + 1].x;
        iy += 0.25 * m->src[v[k] * 3 + 1].y;
    }
    return (cx - ix) * (cx - ix) + (cy - iy) * (cy - iy) > (double)p->parallax_px * p->parallax_px;
}

int warp_mesh_trace_mark(warp_mesh_trace *t, const warp_mesh *m, const warp_camera *dst_cam,
                         const warp_raytrace_setup *s, const warp_raytrace_setup *last, const warp_scan *scan,
                         const warp_mesh_trace_params *p)
{
    int n = 0;
    for (int j = 0; j < t->cells_y; j++)
        for (int i = 0; i < t->cells_x; i++) {
            const bool d = cell_discontinuous(m, i, j, dst_cam, s, last, scan, p);
            t->cell[(size_t)j * t->cells_x + i] = d;
            n += d;
        }
    t->marked = n;
    return n;
}

/* Channel c of src at source position (x, y) exactly as the resampler samples it (warp_resample.c): the position
 * in 1/64 pixel with the half pixel from centre to corner and the rounding bias (warp_mesh.h's lines), truncated
 * and clamped to the border, then 6-bit bilinear weights over the four taps of one 32-bit element. */
static uint8_t sample64(const warp_planar3 *src, int c, double x, double y)
{
    /* as set_vertex keeps it: far positions (and NaN) at the border */
    x = x > -65536 ? (x < 65536 ? x : 65536) : -65536;
    y = y > -65536 ? (y < 65536 ? y : 65536) : -65536;
    const int ax = clampi((int)(64.0f * (float)x - 31.5f), 0, 64 * (src->w - 1));
    const int ay = clampi((int)(64.0f * (float)y - 31.5f), 0, 64 * (src->h - 1));
    uint32_t v;
    memcpy(&v, src->plane[c] + (size_t)(ay >> 6) * (size_t)src->stride + (size_t)(ax >> 6), 4);
    const uint32_t wx = (uint32_t)ax & 63, wy = (uint32_t)ay & 63;
    const uint32_t p00 = v & 255, p10 = v >> 8 & 255, p01 = v >> 16 & 255, p11 = v >> 24;
    const uint32_t l = p00 * (64 - wy) + p10 * wy, r = p01 * (64 - wy) + p11 * wy;
    return (uint8_t)((l * (64 - wx) + r * wx + 2048) >> 12);
}

/* The line the ray through target position (tx, ty) draws in the source under s (warp_raytrace.c): its point at
 * infinity into pinf and its parallax direction into e. False when it points 90 degrees or more off the source's
 * view axis (no point at infinity there). */
static bool ray_line(const warp_raytrace_setup *s, double tx, double ty, double pinf[2], double e[2])
{
    const double bx = s->h.m[0][0] * tx + s->h.m[0][1] * ty + s->h.m[0][2];
    const double by = s->h.m[1][0] * tx + s->h.m[1][1] * ty + s->h.m[1][2];
    const double bw = s->h.m[2][0] * tx + s->h.m[2][1] * ty + s->h.m[2][2];
    if (!(bw > 1e-9 * (fabs(bx) + fabs(by) + fabs(bw)))) return false;
    pinf[0] = bx / bw;
    pinf[1] = by / bw;
    e[0] = s->ax - s->aw * pinf[0];
    e[1] = s->ay - s->aw * pinf[1];
    return true;
}

void warp_mesh_trace_rect(const warp_mesh_trace *t, const warp_mesh *m, const warp_camera *dst_cam,
                          const warp_raytrace_setup *s, const warp_raytrace_setup *last, const warp_scan *scan,
                          const warp_planar3 *src, warp_image_rgba8 *dst, int x0, int y0, int x1, int y1)
{
    if (!t->marked) return;
    x0 = x0 > 0 ? x0 : 0;
    y0 = y0 > 0 ? y0 : 0;
    x1 = x1 < m->vp_w ? x1 : m->vp_w;
    y1 = y1 < m->vp_h ? y1 : m->vp_h;
    const int cw = m->cell_w;
    const bool rolling = last && scan;
    for (int y = y0; y < y1; y++) {
        /* the cell band and the fraction across it, as the resampler's row table takes them */
        const double by = ((double)y + 0.5) * (m->rows - 1) / m->vp_h;
        int j = (int)by;
        if (j > m->rows - 2) j = m->rows - 2;
        const double fy = by - j;
        int lo = x0, hi = x1;
        if (m->visible) {
            lo = m->visible[2 * y] > lo ? m->visible[2 * y] : lo;
            hi = m->visible[2 * y + 1] < hi ? m->visible[2 * y + 1] : hi;
        }
        warp_rgba8 *row = &WARP_AT(dst, m->vp_x, m->vp_y + y);
        for (int i = lo / cw; lo < hi && i <= (hi - 1) / cw; i++) {
            if (!t->cell[(size_t)j * t->cells_x + i]) continue;
            const int xa = i * cw > lo ? i * cw : lo, xb = (i + 1) * cw < hi ? (i + 1) * cw : hi;
            const warp_vec2f *v00 = &m->tan[((size_t)j * m->cols + i) * 3], *v10 = v00 + 3,
                             *v01 = v00 + (size_t)m->cols * 3, *v11 = v01 + 3;
            for (int x = xa; x < xb; x++) {
                const double fx = (x + 0.5 - (double)i * cw) / cw;
                /* the eye-buffer positions of the pixel's three lens directions, bilinear between the corners'
                 * (tan_to_pixel is affine: where the two-pass path's lens mesh reads its eye buffer) */
                double px[3], py[3];
                for (int c = 0; c < 3; c++) {
                    const double u = (1 - fy) * ((1 - fx) * v00[c].x + fx * v10[c].x) +
                                     fy * ((1 - fx) * v01[c].x + fx * v11[c].x);
                    const double w = (1 - fy) * ((1 - fx) * v00[c].y + fx * v10[c].y) +
                                     fy * ((1 - fx) * v01[c].y + fx * v11[c].y);
                    warp_camera_tan_to_pixel(dst_cam, u, w, &px[c], &py[c]);
                }
                /* One ray, green's; red and blue lie a chromatic aberration away (a pixel or two) and take the
                 * surface green hit, as the two-pass path's lens pass samples one traced eye buffer per pixel. */
                double gx, gy;
                if (!rolling) {
                    warp_raytrace_point(s, px[1], py[1], &gx, &gy, NULL);
                } else {
                    const double frac = warp_scan_fraction(scan, m->vp_x + x + 0.5, m->vp_y + y + 0.5);
                    double lx = 0, ly = 0;
                    gx = gy = 0;
                    if (frac < 1) warp_raytrace_point(s, px[1], py[1], &gx, &gy, NULL);
                    if (frac > 0) warp_raytrace_point(last, px[1], py[1], &lx, &ly, NULL);
                    gx = frac <= 0 ? gx : (frac >= 1 ? lx : gx + (lx - gx) * frac);
                    gy = frac <= 0 ? gy : (frac >= 1 ? ly : gy + (ly - gy) * frac);
                }
                uint8_t out[3];
                out[1] = sample64(src, 1, gx, gy);
                double ig[2], eg[2];
                const bool front = ray_line(s, px[1], py[1], ig, eg);
                /* the hit's inverse depth along green's ray (S(D) = p_inf + D e), for the other two */
                const double e2 = eg[0] * eg[0] + eg[1] * eg[1];
                const double d = front && e2 > 1e-12 ? ((gx - ig[0]) * eg[0] + (gy - ig[1]) * eg[1]) / e2 : 0;
                for (int c = 0; c < 3; c += 2) {
                    double ic[2], ec[2], sx, sy;
                    if (front && ray_line(s, px[c], py[c], ic, ec)) {
                        sx = gx + (ic[0] - ig[0]) + d * (ec[0] - eg[0]);
                        sy = gy + (ic[1] - ig[1]) + d * (ec[1] - eg[1]);
                    } else {
                        warp_raytrace_point(s, px[c], py[c], &sx, &sy, NULL); /* beyond 90 degrees: its own */
                    }
                    out[c] = sample64(src, c, sx, sy);
                }
                row[x] = (warp_rgba8){out[0], out[1], out[2], 255};
            }
        }
    }
}

/* SPDX-License-Identifier: MIT */
/* warp_mesh_trace: the per-pixel part of the display path's depth warp: lens mesh cells whose rays meet a depth
 * discontinuity (000 §3: refine the grid only there) are raytraced per pixel (003 §3.5), the rest interpolated. */
#include "warp/warp_mesh_trace.h"

#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

warp_mesh_trace_params warp_mesh_trace_default_params(void)
{
    warp_mesh_trace_params p = {0.5f};
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
    /* some rays crossed an edge: the boundary runs through the cell */
    if (any & WARP_MASK_EDGE) return true;
    /* Rays that left the source beside rays that did not: the border of what the source saw. Where the lens sees
     * beyond the eye buffer (the panel's periphery) that is a ring of cells whose fringe fill (003 §4.3) the
     * interpolation already gives; where a translation uncovers what the source never saw, the fill's positions
     * do not continue the hits beside them. The centre ray tells which (its flag may be either). */
    const bool border = any != all;
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
    if (warp_raytrace_point(s, tx, ty, &cx, &cy, NULL) != all && !border) return true;
    if (last && scan) {
        /* rolling: the vertices hold their own scan line's interpolation; the centre takes its own */
        const double f = warp_scan_fraction(scan, m->vp_x + (i + 0.5) * m->cell_w,
                                            m->vp_y + (j + 0.5) * (double)m->vp_h / (m->rows - 1));
        double lx, ly;
        if (warp_raytrace_point(last, tx, ty, &lx, &ly, NULL) != all && !border) return true;
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

/* Whether any pixel of cell (i, j) is shown (the hidden-area mask): the rest are written black, never sampled. */
static bool cell_shown(const warp_mesh *m, int i, int j)
{
    if (!m->visible) return true;
    const int x0 = i * m->cell_w, x1 = x0 + m->cell_w;
    const int y0 = (int)ceil((double)j * m->vp_h / (m->rows - 1) - 0.5) - 1;
    const int y1 = (int)ceil((double)(j + 1) * m->vp_h / (m->rows - 1) - 0.5) + 1;
    for (int y = y0 > 0 ? y0 : 0; y < y1 && y < m->vp_h; y++)
        if (m->visible[2 * y] < x1 && m->visible[2 * y + 1] > x0) return true;
    return false;
}

int warp_mesh_trace_mark(warp_mesh_trace *t, const warp_mesh *m, const warp_camera *dst_cam,
                         const warp_raytrace_setup *s, const warp_raytrace_setup *last, const warp_scan *scan,
                         const warp_mesh_trace_params *p)
{
    int n = 0;
    for (int j = 0; j < t->cells_y; j++)
        for (int i = 0; i < t->cells_x; i++) {
            const bool d = cell_shown(m, i, j) && cell_discontinuous(m, i, j, dst_cam, s, last, scan, p);
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

/* One rectangle's counts (warp_mesh_trace_stats), added to the shared ones once at its end. */
typedef struct {
    long pixels, lattice_rays, pixel_rays, channel_rays, samples;
} rect_counts;

/* What tracing one rectangle needs, hoisted. */
typedef struct {
    const warp_mesh *m;
    const warp_camera *cam;
    const warp_raytrace_setup *s, *last;
    const warp_scan *scan;
    const warp_planar3 *src;
    rect_counts *n;
} rect_ctx;

/* One traced pixel: per channel its source position; its flag and the inverse depth of green's hit: along green's
 * ray where its source position lies (d) and where its search stopped (dhit: at an edge, on the wall). */
typedef struct {
    double x[3], y[3];
    double d, dhit, elen;
    int flag;
} ray_px;

/* The vertex band j of viewport row y and the fraction across it, as the resampler's row table takes them. */
static int band_of(const warp_mesh *m, int y, double *fy)
{
    const double b = ((double)y + 0.5) * (m->rows - 1) / m->vp_h;
    int j = (int)b;
    if (j > m->rows - 2) j = m->rows - 2;
    *fy = b - j;
    return j;
}

/* The source position of the ray through eye-buffer position (tx, ty) under the pass's setup(s) (rolling: at
 * viewport pixel (x, y)'s scan fraction); its flag; its hit's inverse depth into *d (rolling: under the first setup
 * that traced it). */
static int trace_at(const rect_ctx *c, int x, int y, double tx, double ty, double *sx, double *sy, double *d,
                    warp_raytrace_stats *st)
{
    if (!(c->last && c->scan)) return warp_raytrace_point_depth(c->s, tx, ty, sx, sy, d, st);
    const double f = warp_scan_fraction(c->scan, c->m->vp_x + x + 0.5, c->m->vp_y + y + 0.5);
    double fx = 0, fy = 0, lx = 0, ly = 0, dl = 0;
    int flag = 0;
    if (f < 1) flag |= warp_raytrace_point_depth(c->s, tx, ty, &fx, &fy, d, st);
    if (f > 0) flag |= warp_raytrace_point_depth(c->last, tx, ty, &lx, &ly, f < 1 ? &dl : d, st);
    *sx = f <= 0 ? fx : (f >= 1 ? lx : fx + (lx - fx) * f);
    *sy = f <= 0 ? fy : (f >= 1 ? ly : fy + (ly - fy) * f);
    return flag;
}

/* The surfaces the corners of a block hit, nearest first: their hits' inverse depths (dhit: at an edge where the
 * ray met its wall), grouped where they lie within GUESS_GAP_PX of parallax of each other (a slanted surface), apart
 * where more (the near and the far side of an edge, and a wall between). Corners whose rays left the source are left
 * out (their depths are the fill's): n = 0 when none is left. */
typedef struct {
    int n;             /* surfaces */
    uint8_t corner[4]; /* per surface: bit k = corner k (q[k]) hit it */
    double dhit[4];    /* per corner */
} block_surfaces;

/* A ray's guesses: the inverse depth at which it would meet each of its block's surfaces, nearest first. */
typedef struct {
    int n;
    double d[4];
} hit_guess;

/* Parallax (source pixels) between two corners' hits that still counts as one surface: a slanted one spreads its
 * corners' hits over a few pixels, where an edge's sides lie tens apart at a few centimetres of head motion. */
#define GUESS_GAP_PX 2.0

static void block_surfaces_of(const ray_px *const q[4], double elen, block_surfaces *b)
{
    int order[4], k = 0;
    for (int i = 0; i < 4; i++) {
        b->dhit[i] = q[i]->dhit;
        if (q[i]->flag & WARP_MASK_FRINGE) continue;
        int at = k++;
        while (at > 0 && b->dhit[order[at - 1]] < b->dhit[i]) {
            order[at] = order[at - 1];
            at--;
        }
        order[at] = i;
    }
    b->n = 0;
    for (int i = 0; i < k; i++) {
        if (i == 0 || (b->dhit[order[i - 1]] - b->dhit[order[i]]) * elen > GUESS_GAP_PX) b->corner[b->n++] = 0;
        b->corner[b->n - 1] |= (uint8_t)(1u << order[i]);
    }
}

/* The guesses of the ray of the pixel at (u, v) across its block (0..1 from corner q[0] to q[3]): per surface its
 * corners' hits weighted bilinearly (000 §3's interpolation between vertices; a surface that one corner alone hit is
 * taken as flat there). */
static void guess_at(const block_surfaces *b, double u, double v, hit_guess *g)
{
    const double w[4] = {(1 - u) * (1 - v) + 1e-3, u * (1 - v) + 1e-3, (1 - u) * v + 1e-3, u * v + 1e-3};
    g->n = b->n;
    for (int i = 0; i < b->n; i++) {
        double sw = 0, sd = 0;
        for (int k = 0; k < 4; k++)
            if (b->corner[i] >> k & 1) {
                sw += w[k];
                sd += w[k] * b->dhit[k];
            }
        g->d[i] = sd / sw;
    }
}

/* How far around a guess (source pixels of parallax) a ray's hit is sought: the interpolation between corners 4
 * pixels apart misses a curved surface's hit by far less. Red's and blue's rays, a chromatic aberration away from
 * the pixel the guesses are for, look as much farther (on a slanted surface their hits' parallax differs by about
 * as much: at the full panel's aberration a pixel's margin alone sent four times as many of them to full rays). */
#define GUESS_MARGIN_PX 1.0

/* trace_at, but the hit sought only at the guesses g (NULL: the full search) of where the ray meets its block's
 * surfaces, margin_px around each (warp_raytrace_point_guess: a few depth samples, where the full search takes one
 * per source pixel of the whole depth range, 003 §3.5). A hit there is the ray's first unless something nearer than
 * every corner's hit stands in its way, or a thin object between two of the surfaces, which no corner saw (at 4
 * pixels apart); where the ray is behind the height map already at the nearest guess or meets nothing at any (a
 * disocclusion's wall beyond them, or it leaves the source) it is traced in full (*full). Rolling: under both setups,
 * at the same guesses (a scan's pose change moves a surface's depth by far less than the margin). */
static int resolve_at(const rect_ctx *c, const hit_guess *g, double margin_px, int x, int y, double tx, double ty,
                      double *sx, double *sy, double *d, bool *full)
{
    *full = false;
    int taken = 0;
    if (g && g->n) {
        if (!(c->last && c->scan)) {
            const int r = warp_raytrace_point_guess(c->s, tx, ty, g->d, g->n, margin_px, sx, sy, d, &taken);
            c->n->samples += taken;
            if (r >= 0) return r;
        } else {
            const double f = warp_scan_fraction(c->scan, c->m->vp_x + x + 0.5, c->m->vp_y + y + 0.5);
            double fx = 0, fy = 0, lx = 0, ly = 0, dl = 0;
            int rf = 0, rl = 0;
            if (f < 1) rf = warp_raytrace_point_guess(c->s, tx, ty, g->d, g->n, margin_px, &fx, &fy, d, &taken);
            if (rf >= 0 && f > 0)
                rl = warp_raytrace_point_guess(c->last, tx, ty, g->d, g->n, margin_px, &lx, &ly,
                                               f < 1 ? &dl : d, &taken);
            c->n->samples += taken;
            if (rf >= 0 && rl >= 0) {
                *sx = f <= 0 ? fx : (f >= 1 ? lx : fx + (lx - fx) * f);
                *sy = f <= 0 ? fy : (f >= 1 ? ly : fy + (ly - fy) * f);
                return rf | rl;
            }
        }
    }
    *full = true;
    warp_raytrace_stats st = {0};
    const int r = trace_at(c, x, y, tx, ty, sx, sy, d, &st);
    c->n->samples += st.samples;
    return r;
}

/* Traces viewport pixel (x, y) of cell (i, j) (fy: its fraction across the band). all3: each channel its own ray
 * (beside a depth edge, where red's or blue's ray may meet the other side), else green's alone. h: where its rays
 * meet its block's surfaces, where their hits are sought (NULL: full rays). */
static void trace_pixel(const rect_ctx *c, int i, int j, int x, int y, double fy, bool all3, double dnear,
                        const hit_guess *h, ray_px *r)
{
    const warp_mesh *m = c->m;
    const int cw = m->cell_w;
    const warp_vec2f *v00 = &m->tan[((size_t)j * m->cols + i) * 3], *v10 = v00 + 3, *v01 = v00 + (size_t)m->cols * 3,
                     *v11 = v01 + 3;
    const double fx = (x + 0.5 - (double)i * cw) / cw;
    /* the eye-buffer positions of the pixel's three lens directions, bilinear between the corners' (tan_to_pixel is
     * affine: where the two-pass path's lens mesh reads its eye buffer) */
    double px[3], py[3];
    for (int k = 0; k < 3; k++) {
        const double u = (1 - fy) * ((1 - fx) * v00[k].x + fx * v10[k].x) + fy * ((1 - fx) * v01[k].x + fx * v11[k].x);
        const double w = (1 - fy) * ((1 - fx) * v00[k].y + fx * v10[k].y) + fy * ((1 - fx) * v01[k].y + fx * v11[k].y);
        warp_camera_tan_to_pixel(c->cam, u, w, &px[k], &py[k]);
    }
    /* Green's ray; red and blue lie a chromatic aberration away (a pixel or two) and, away from depth edges,
     * take the surface green hit at their own lens directions. */
    double gx = 0, gy = 0;
    bool full;
    const int flag = resolve_at(c, h, GUESS_MARGIN_PX, x, y, px[1], py[1], &gx, &gy, &r->dhit, &full);
    if (all3) c->n->pixel_rays += full;
    r->flag = flag;
    r->x[1] = gx;
    r->y[1] = gy;
    double ig[2], eg[2];
    const bool front = ray_line(c->s, px[1], py[1], ig, eg);
    /* the hit's inverse depth along green's ray (S(D) = p_inf + D e), for the other two */
    const double e2 = eg[0] * eg[0] + eg[1] * eg[1];
    r->d = front && e2 > 1e-12 ? ((gx - ig[0]) * eg[0] + (gy - ig[1]) * eg[1]) / e2 : 0;
    r->elen = front ? sqrt(e2) : 0;
    for (int k = 0; k < 3; k += 2) {
        double ic[2], ec[2];
        /* beside an edge a channel that lies half a pixel or more from green's may meet the edge's other side:
         * its own ray then (near the lens's centre, where the aberration is small, green's hit serves) */
        const double ca = (px[k] - px[1]) * (px[k] - px[1]) + (py[k] - py[1]) * (py[k] - py[1]);
        if (front && ray_line(c->s, px[k], py[k], ic, ec)) {
            r->x[k] = gx + (ic[0] - ig[0]) + r->d * (ec[0] - eg[0]);
            r->y[k] = gy + (ic[1] - ig[1]) + r->d * (ec[1] - eg[1]);
            if (all3 && ca > 0.25 && !(flag & WARP_MASK_FRINGE)) {
                /* its own ray unless the surface is there at green's depth and nothing as near as the block's
                 * nearest hit (dnear) stands where its ray would cross that depth */
                const warp_image_f32 *inv = c->s->src->inv_depth;
                const double dk = warp_sample_f32(inv, (float)r->x[k], (float)r->y[k]);
                bool own = (flag & WARP_MASK_EDGE) || fabs(dk - r->d) > 0.1 * r->d;
                if (!own && dnear > r->d * 1.1) {
                    const float nx = (float)(ic[0] + dnear * ec[0]), ny = (float)(ic[1] + dnear * ec[1]);
                    own = warp_sample_f32(inv, nx, ny) > 0.9 * dnear;
                }
                if (own) {
                    double dh;
                    resolve_at(c, h, GUESS_MARGIN_PX + sqrt(ca), x, y, px[k], py[k], &r->x[k], &r->y[k], &dh, &full);
                    c->n->channel_rays += full;
                }
            }
        } else {
            warp_raytrace_point(c->s, px[k], py[k], &r->x[k], &r->y[k], NULL); /* beyond 90 degrees: its own */
        }
    }
}

static void put(const rect_ctx *c, warp_rgba8 *row, int x, const double sx[3], const double sy[3])
{
    row[x] = (warp_rgba8){sample64(c->src, 0, sx[0], sy[0]), sample64(c->src, 1, sx[1], sy[1]),
                          sample64(c->src, 2, sx[2], sy[2]), 255};
}

/* Whether viewport pixel (x, y) is shown (the hidden-area mask). */
static bool shown(const warp_mesh *m, int x, int y)
{
    return !m->visible || (x >= m->visible[2 * y] && x < m->visible[2 * y + 1]);
}

/* Sub-cells of a traced cell: rays on a lattice SUB pixels apart, and per pixel only in the sub-cells whose
 * corners still disagree (000 §4.1's subdivision, one level): a cell's depth edge crosses a few of them. */
#define SUB 4
#define SUB_MAX 48 /* lattice points per side on the stack; wider cells are traced pixel by pixel */

/* Parallax (source pixels) over which the hits of a block's corners, with one flag and no edge, stop being
 * interpolated. Not a slant test: over it, the ray through the block's centre lands more than 0.25 px from the
 * interpolation (or with another flag) in 5 of 6 such blocks (near at 5 cm; more than 2 px in half): they hold
 * what the lattice's rays straddle (a thin object, an edge's corner), and a centre test would spare 6 % of the
 * blocks traced per pixel. */
#define BLOCK_SPREAD_PX 1.0

/* Pixels [xa, xb) x [ya, yb) of cell (i, j), all in its band. */
static void trace_block(const rect_ctx *c, int i, int j, int xa, int xb, int ya, int yb, warp_image_rgba8 *dst)
{
    const warp_mesh *m = c->m;
    const int nx = (xb - 1 - xa + SUB - 1) / SUB + 1, ny = (yb - 1 - ya + SUB - 1) / SUB + 1;
    if (nx < 2 || ny < 2 || nx > SUB_MAX || ny > SUB_MAX) {
        for (int y = ya; y < yb; y++) {
            double fy;
            band_of(m, y, &fy);
            warp_rgba8 *row = &WARP_AT(dst, m->vp_x, m->vp_y + y);
            for (int x = xa; x < xb; x++) {
                if (!shown(m, x, y)) continue;
                ray_px r;
                trace_pixel(c, i, j, x, y, fy, true, INFINITY, NULL, &r);
                put(c, row, x, r.x, r.y);
                c->n->pixels++;
            }
        }
        return;
    }
    /* the lattice: every SUB-th pixel from the block's first, and its last */
    ray_px lat[2][SUB_MAX];
    int lx[SUB_MAX];
    for (int k = 0; k < nx; k++) lx[k] = xa + k * SUB < xb - 1 ? xa + k * SUB : xb - 1;
    for (int l = 0; l < ny; l++) {
        const int ly = ya + l * SUB < yb - 1 ? ya + l * SUB : yb - 1;
        double lfy;
        band_of(m, ly, &lfy);
        ray_px *cur = lat[l & 1];
        for (int k = 0; k < nx; k++) trace_pixel(c, i, j, lx[k], ly, lfy, false, 0, NULL, &cur[k]);
        c->n->lattice_rays += nx;
        if (l == 0) continue;
        const ray_px *up = lat[(l - 1) & 1];
        const int y0 = ya + (l - 1) * SUB, y1 = ly; /* rows [y0, y1), and y1 itself in the last row of sub-cells */
        const int yend = l == ny - 1 ? y1 + 1 : y1;
        for (int k = 0; k + 1 < nx; k++) {
            const ray_px *q[4] = {&up[k], &up[k + 1], &cur[k], &cur[k + 1]};
            const int x0 = lx[k], x1 = lx[k + 1], xend = k + 1 == nx - 1 ? x1 + 1 : x1;
            /* smooth: one flag, no edge, and the hits' parallax alike to within BLOCK_SPREAD_PX */
            double dlo = q[0]->d, dhi = q[0]->d, el = q[0]->elen;
            bool same = !(q[0]->flag & WARP_MASK_EDGE);
            for (int n = 1; n < 4; n++) {
                same = same && q[n]->flag == q[0]->flag;
                dlo = q[n]->d < dlo ? q[n]->d : dlo;
                dhi = q[n]->d > dhi ? q[n]->d : dhi;
                el = q[n]->elen > el ? q[n]->elen : el;
            }
            const bool smooth = same && (q[0]->flag & WARP_MASK_FRINGE || (dhi - dlo) * el <= BLOCK_SPREAD_PX);
            block_surfaces bs;
            block_surfaces_of(q, el, &bs);
            for (int y = y0; y < yend; y++) {
                double fy;
                band_of(m, y, &fy);
                warp_rgba8 *row = &WARP_AT(dst, m->vp_x, m->vp_y + y);
                const double ty = y1 > y0 ? (double)(y - y0) / (y1 - y0) : 0;
                for (int x = x0; x < xend; x++) {
                    if (!shown(m, x, y)) continue;
                    c->n->pixels++;
                    if (smooth) {
                        const double tx = x1 > x0 ? (double)(x - x0) / (x1 - x0) : 0;
                        double sx[3], sy[3];
                        for (int ch = 0; ch < 3; ch++) {
                            sx[ch] = (1 - ty) * ((1 - tx) * q[0]->x[ch] + tx * q[1]->x[ch]) +
                                     ty * ((1 - tx) * q[2]->x[ch] + tx * q[3]->x[ch]);
                            sy[ch] = (1 - ty) * ((1 - tx) * q[0]->y[ch] + tx * q[1]->y[ch]) +
                                     ty * ((1 - tx) * q[2]->y[ch] + tx * q[3]->y[ch]);
                        }
                        put(c, row, x, sx, sy);
                    } else {
                        hit_guess h;
                        guess_at(&bs, x1 > x0 ? (double)(x - x0) / (x1 - x0) : 0, ty, &h);
                        ray_px r;
                        trace_pixel(c, i, j, x, y, fy, true, dhi, &h, &r);
                        put(c, row, x, r.x, r.y);
                    }
                }
            }
        }
    }
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
    if (x0 >= x1 || y0 >= y1) return;
    rect_counts n = {0, 0, 0, 0, 0};
    const rect_ctx c = {m, dst_cam, s, last, scan, src, &n};
    const int cw = m->cell_w;
    /* runs of rows in one band, then the marked cells across them */
    for (int ya = y0; ya < y1;) {
        double fy;
        const int j = band_of(m, ya, &fy);
        int yb = ya + 1;
        while (yb < y1 && band_of(m, yb, &fy) == j) yb++;
        for (int i = x0 / cw; i <= (x1 - 1) / cw; i++) {
            if (!t->cell[(size_t)j * t->cells_x + i]) continue;
            const int xa = i * cw > x0 ? i * cw : x0, xb = (i + 1) * cw < x1 ? (i + 1) * cw : x1;
            trace_block(&c, i, j, xa, xb, ya, yb, dst);
        }
        ya = yb;
    }
    if (t->stats) {
        atomic_fetch_add_explicit(&t->stats->pixels, n.pixels, memory_order_relaxed);
        atomic_fetch_add_explicit(&t->stats->lattice_rays, n.lattice_rays, memory_order_relaxed);
        atomic_fetch_add_explicit(&t->stats->pixel_rays, n.pixel_rays, memory_order_relaxed);
        atomic_fetch_add_explicit(&t->stats->channel_rays, n.channel_rays, memory_order_relaxed);
        atomic_fetch_add_explicit(&t->stats->samples, n.samples, memory_order_relaxed);
    }
}

/* The steps the display path's depth warp runs (warp_mesh_trace.h): written once here, not in each caller. */
int warp_mesh_raytrace_vertices(warp_mesh *m, warp_mesh_trace *t, const warp_camera *dst_cam,
                                const warp_raytrace_setup *s, const warp_raytrace_setup *last, const warp_scan *scan,
                                const warp_mesh_trace_params *p)
{
    const bool rolling = last && scan;
    if (rolling)
        warp_mesh_update_raytrace_rolling(m, dst_cam, s, last, scan);
    else
        warp_mesh_update_raytrace(m, dst_cam, s);
    return t ? warp_mesh_trace_mark(t, m, dst_cam, s, rolling ? last : NULL, rolling ? scan : NULL, p) : 0;
}

void warp_mesh_raytrace_rect(const warp_mesh *m, const warp_mesh_trace *t, const warp_camera *dst_cam,
                             const warp_raytrace_setup *s, const warp_raytrace_setup *last, const warp_scan *scan,
                             const warp_planar3 *src, warp_image_rgba8 *dst, int x0, int y0, int x1, int y1)
{
    warp_mesh_resample(m, src, dst, x0, y0, x1, y1);
    /* per-pixel rays after the resampling: they overwrite its pixels in the marked cells */
    if (t) warp_mesh_trace_rect(t, m, dst_cam, s, last, scan, src, dst, x0, y0, x1, y1);
}

int warp_mesh_raytrace_draw(warp_mesh *m, warp_mesh_trace *t, const warp_camera *dst_cam,
                            const warp_raytrace_setup *s, const warp_raytrace_setup *last, const warp_scan *scan,
                            const warp_mesh_trace_params *p, const warp_planar3 *src, warp_image_rgba8 *dst)
{
    const int marked = warp_mesh_raytrace_vertices(m, t, dst_cam, s, last, scan, p);
    warp_mesh_raytrace_rect(m, t, dst_cam, s, last, scan, src, dst, 0, 0, m->vp_w, m->vp_h);
    return marked;
}

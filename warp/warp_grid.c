/* SPDX-License-Identifier: MIT */
/* warp_grid: adaptive grid generation (000 §4.1) and grid warping (000 §5.1) on the CPU. */
#include "warp/warp_grid.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Quadtree node bits. Side bits: the node's border pixels pass the collinearity test that reaches into the
 * neighbour on that side (000 §4.1.2: "each node separately encodes its connectedness to its left, right, top and
 * bottom neighbour", plus the four diagonals). */
enum {
    N_SURF = 1,
    N_L = 2,
    N_R = 4,
    N_T = 8,
    N_B = 16,
    N_TL = 32,
    N_TR = 64,
    N_BL = 128,
    N_BR = 256,
    N_ALL = 511,
    N_MERGE_SHIFT = 9, /* 3 bits: the irregular grid's merge type (000 Fig. 6) */
};
/* Merge types of the irregular grid: which children pairs form 2:1 rectangles. */
enum { M_NONE = 0, M_FULL = 1, M_T = 2, M_B = 3, M_L = 4, M_R = 5, M_TB = 6, M_LR = 7 };

/* Extra per-pixel bits (beyond the public WARP_GRID_PX_*): precomputed pair connectivity for speed. */
enum {
    PX_CONN_R = 16, /* (x, y) - (x+1, y) connected */
    PX_CONN_D = 32, /* (x, y) - (x, y+1) connected */
    PX_QUAD = 64,   /* the 2x2 block (x..x+1, y..y+1) is connected: bilinear filtering is safe there */
};

warp_grid_params warp_grid_default_params(void)
{
    warp_grid_params p = {WARP_GRID_IRREGULAR, 32, 0.02f, 0.02f, 0.5f, 0.064f, WARP_GRID_FILTER_ADAPTIVE, true};
    return p;
}

const char *warp_grid_strategy_name(warp_grid_strategy s)
{
    switch (s) {
    case WARP_GRID_DIDYK: return "didyk";
    case WARP_GRID_CROSS: return "cross-kernel";
    case WARP_GRID_PARTIAL: return "partial-cross-kernel";
    case WARP_GRID_IRREGULAR: return "irregular";
    }
    return "?";
}

static int levels_for_tile(int tile)
{
    int l = 0;
    while ((2 << l) < tile) l++;
    return l + 1; /* level k nodes are 2^(k+1) pixels wide */
}

bool warp_grid_alloc(warp_grid *g, int w, int h, int tile)
{
    memset(g, 0, sizeof *g);
    if (w < 1 || h < 1 || w > 65535 || h > 65535 || tile < 2 || tile > 64 || (tile & (tile - 1))) return false;
    g->w = w;
    g->h = h;
    g->tile = tile;
    g->levels = levels_for_tile(tile);
    long total = 0;
    for (int k = 0; k < g->levels; k++) {
        int n = 2 << k;
        g->lw[k] = (w + n - 1) / n;
        g->lh[k] = (h + n - 1) / n;
        g->loff[k] = total;
        total += (long)g->lw[k] * g->lh[k];
    }
    size_t np = (size_t)w * (size_t)h;
    g->max_cells = (long)np; /* every cell holds at least one pixel */
    g->node = calloc((size_t)total, sizeof *g->node);
    g->curv = calloc((size_t)total, sizeof *g->curv);
    g->dmin = calloc((size_t)total, sizeof *g->dmin);
    g->dmax = calloc((size_t)total, sizeof *g->dmax);
    g->px = calloc(np, sizeof *g->px);
    g->pxcurv = calloc(np, sizeof *g->pxcurv);
    g->cell = calloc(np, sizeof *g->cell);
    if (!g->node || !g->curv || !g->dmin || !g->dmax || !g->px || !g->pxcurv || !g->cell) {
        warp_grid_free(g);
        return false;
    }
    return true;
}

void warp_grid_free(warp_grid *g)
{
    free(g->node);
    free(g->curv);
    free(g->dmin);
    free(g->dmax);
    free(g->px);
    free(g->pxcurv);
    free(g->cell);
    memset(g, 0, sizeof *g);
}

/* ---- per-pixel collinearity (000 eq. 1, 2) ---- */

static inline float dat(const warp_image_f32 *d, int x, int y) { return WARP_AT(d, x, y); }

/* Eq. 2 on inverse depth, which is affine in screen space on any plane: a slanted plane passes exactly. The
 * tolerance is relative to the largest of the three so that it means the same near and far. */
static inline bool collinear(float a, float b, float c, float eps, float *rel)
{
    float f = fabsf((a - b) - (b - c));
    float m = fmaxf(fmaxf(a, b), c);
    if (f <= eps * m || f == 0.0f) {
        *rel = m > 0 ? f / m : 0.0f;
        return true;
    }
    return false;
}

static long pixel_tests(warp_grid *g, const warp_image_f32 *d, float eps)
{
    const int w = g->w, h = g->h;
    long bad = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            uint8_t b = 0;
            float k = 0, r;
            float c = dat(d, x, y);
            bad += !(isfinite(c) && c >= 0); /* fails every test below: a discontinuity on all sides */
            bool hx = x > 0 && x + 1 < w, hy = y > 0 && y + 1 < h;
            /* A test with a neighbour outside the image passes: there is no evidence of an edge there. */
            if (!hx || collinear(dat(d, x - 1, y), c, dat(d, x + 1, y), eps, &r)) b |= WARP_GRID_PX_H, k = hx ? fmaxf(k, r) : k;
            if (!hy || collinear(dat(d, x, y - 1), c, dat(d, x, y + 1), eps, &r)) b |= WARP_GRID_PX_V, k = hy ? fmaxf(k, r) : k;
            if (!(hx && hy) || collinear(dat(d, x - 1, y - 1), c, dat(d, x + 1, y + 1), eps, &r)) b |= WARP_GRID_PX_D1;
            if (!(hx && hy) || collinear(dat(d, x + 1, y - 1), c, dat(d, x - 1, y + 1), eps, &r)) b |= WARP_GRID_PX_D2;
            g->px[(size_t)y * w + x] = b;
            g->pxcurv[(size_t)y * w + x] = k;
        }
    return bad;
}

static inline uint8_t pxb(const warp_grid *g, int x, int y) { return g->px[(size_t)y * g->w + x]; }

bool warp_grid_connected(const warp_grid *g, int x, int y, int dx, int dy)
{
    int qx = x + dx, qy = y + dy;
    if ((dx == 0 && dy == 0) || dx < -1 || dx > 1 || dy < -1 || dy > 1) return dx == 0 && dy == 0;
    if (x < 0 || y < 0 || x >= g->w || y >= g->h || qx < 0 || qy < 0 || qx >= g->w || qy >= g->h) return false;
    uint8_t bit = dy == 0 ? WARP_GRID_PX_H : dx == 0 ? WARP_GRID_PX_V : dx == dy ? WARP_GRID_PX_D1 : WARP_GRID_PX_D2;
    /* the test centred on p reaches q through p - (dx, dy); the one centred on q reaches p through q + (dx, dy) */
    int px_ = x - dx, py_ = y - dy, rx = qx + dx, ry = qy + dy;
    bool ep = px_ >= 0 && py_ >= 0 && px_ < g->w && py_ < g->h;
    bool eq = rx >= 0 && ry >= 0 && rx < g->w && ry < g->h;
    if (!ep && !eq) return true;
    return (ep && (pxb(g, x, y) & bit)) || (eq && (pxb(g, qx, qy) & bit));
}

static void pair_bits(warp_grid *g)
{
    const int w = g->w, h = g->h;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            uint8_t *b = &g->px[(size_t)y * w + x];
            if (warp_grid_connected(g, x, y, 1, 0)) *b |= PX_CONN_R;
            if (warp_grid_connected(g, x, y, 0, 1)) *b |= PX_CONN_D;
        }
    for (int y = 0; y + 1 < h; y++)
        for (int x = 0; x + 1 < w; x++) {
            uint8_t a = pxb(g, x, y), r = pxb(g, x + 1, y), dn = pxb(g, x, y + 1);
            if ((a & PX_CONN_R) && (a & PX_CONN_D) && (r & PX_CONN_D) && (dn & PX_CONN_R))
                g->px[(size_t)y * w + x] |= PX_QUAD;
        }
}

/* ---- quadtree (000 §4.1.1 - §4.1.3) ---- */

static inline long nidx(const warp_grid *g, int k, int ix, int iy) { return g->loff[k] + (long)iy * g->lw[k] + ix; }

/* Pixel test with pixels outside the image counting as passing (the cell is clipped to the image anyway). */
static inline bool ptest(const warp_grid *g, int x, int y, uint8_t bit)
{
    if (x < 0 || y < 0 || x >= g->w || y >= g->h) return true;
    return (pxb(g, x, y) & bit) != 0;
}

static inline bool hconn(uint16_t a, uint16_t b) { return (a & N_R) || (b & N_L); } /* a left of b */
static inline bool vconn(uint16_t a, uint16_t b) { return (a & N_B) || (b & N_T); } /* a above b */

static uint16_t merge_type(bool sTL, bool sTR, bool sBL, bool sBR, bool cT, bool cB, bool cL, bool cR)
{
    /* Fig. 6: pairs of whole (square) children that are connected form 2:1 rectangles. Two rectangles beat one. */
    bool t = sTL && sTR && cT, b = sBL && sBR && cB, l = sTL && sBL && cL, r = sTR && sBR && cR;
    if (t && b) return M_TB;
    if (l && r) return M_LR;
    if (t) return M_T;
    if (b) return M_B;
    if (l) return M_L;
    if (r) return M_R;
    return M_NONE;
}

static void build_tree(warp_grid *g, const warp_image_f32 *d, warp_grid_strategy s)
{
    const bool partial = s == WARP_GRID_PARTIAL || s == WARP_GRID_IRREGULAR;
    /* level 0: 2x2 pixel groups, Fig. 5 */
    for (int iy = 0; iy < g->lh[0]; iy++)
        for (int ix = 0; ix < g->lw[0]; ix++) {
            int x0 = 2 * ix, y0 = 2 * iy;
            bool left = ptest(g, x0, y0, WARP_GRID_PX_H) && ptest(g, x0, y0 + 1, WARP_GRID_PX_H);
            bool right = ptest(g, x0 + 1, y0, WARP_GRID_PX_H) && ptest(g, x0 + 1, y0 + 1, WARP_GRID_PX_H);
            bool up = ptest(g, x0, y0, WARP_GRID_PX_V) && ptest(g, x0 + 1, y0, WARP_GRID_PX_V);
            bool down = ptest(g, x0, y0 + 1, WARP_GRID_PX_V) && ptest(g, x0 + 1, y0 + 1, WARP_GRID_PX_V);
            bool surf = partial ? (left || right) && (up || down) : left && right && up && down;
            uint16_t n = (uint16_t)((surf ? N_SURF : 0) | (left ? N_L : 0) | (right ? N_R : 0) | (up ? N_T : 0) |
                                    (down ? N_B : 0));
            n |= ptest(g, x0, y0, WARP_GRID_PX_D1) ? N_TL : 0;
            n |= ptest(g, x0 + 1, y0 + 1, WARP_GRID_PX_D1) ? N_BR : 0;
            n |= ptest(g, x0 + 1, y0, WARP_GRID_PX_D2) ? N_TR : 0;
            n |= ptest(g, x0, y0 + 1, WARP_GRID_PX_D2) ? N_BL : 0;
            float k = 0, mn = INFINITY, mx = -INFINITY;
            bool in[4];
            for (int j = 0; j < 4; j++) {
                int x = x0 + (j & 1), y = y0 + (j >> 1);
                in[j] = x < g->w && y < g->h;
                if (!in[j]) continue;
                k = fmaxf(k, g->pxcurv[(size_t)y * g->w + x]);
                float v = dat(d, x, y);
                mn = fminf(mn, v);
                mx = fmaxf(mx, v);
            }
            if (s == WARP_GRID_IRREGULAR && !surf) {
                /* leaf children are pixels: pairs merge into 2x1 / 1x2 cells when connected */
                bool cT = !in[1] || (pxb(g, x0, y0) & PX_CONN_R);
                bool cB = !in[2] || !in[3] || (pxb(g, x0, y0 + 1) & PX_CONN_R);
                bool cL = !in[2] || (pxb(g, x0, y0) & PX_CONN_D);
                bool cR = !in[1] || !in[3] || (pxb(g, x0 + 1, y0) & PX_CONN_D);
                n |= (uint16_t)(merge_type(true, true, true, true, cT, cB, cL, cR) << N_MERGE_SHIFT);
            } else if (surf) {
                n |= M_FULL << N_MERGE_SHIFT;
            }
            long i = nidx(g, 0, ix, iy);
            g->node[i] = n;
            g->curv[i] = k;
            g->dmin[i] = mn;
            g->dmax[i] = mx;
        }
    /* inner levels, bottom-up */
    for (int k = 1; k < g->levels; k++)
        for (int iy = 0; iy < g->lh[k]; iy++)
            for (int ix = 0; ix < g->lw[k]; ix++) {
                uint16_t c[4];
                float kk = 0, mn = INFINITY, mx = -INFINITY;
                for (int j = 0; j < 4; j++) {
                    int cx = 2 * ix + (j & 1), cy = 2 * iy + (j >> 1);
                    if (cx >= g->lw[k - 1] || cy >= g->lh[k - 1]) {
                        c[j] = N_ALL; /* outside the image: no pixels, no edges */
                        continue;
                    }
                    long ci = nidx(g, k - 1, cx, cy);
                    c[j] = g->node[ci];
                    kk = fmaxf(kk, g->curv[ci]);
                    mn = fminf(mn, g->dmin[ci]);
                    mx = fmaxf(mx, g->dmax[ci]);
                }
                bool s0 = c[0] & N_SURF, s1 = c[1] & N_SURF, s2 = c[2] & N_SURF, s3 = c[3] & N_SURF;
                bool cT = hconn(c[0], c[1]), cB = hconn(c[2], c[3]), cL = vconn(c[0], c[2]), cR = vconn(c[1], c[3]);
                bool surf;
                if (partial) /* children surfaces and connected in the corresponding directions (§4.1.2) */
                    surf = s0 && s1 && s2 && s3 && cT && cB && cL && cR;
                else /* cross-kernel: neighbouring groups used overlapping pixel pairs, so surfaces join (§4.1.1) */
                    surf = s0 && s1 && s2 && s3;
                uint16_t n = surf ? N_SURF : 0;
                /* sides: logical and of the children on that side; diagonals from the corner child */
                if ((c[0] & N_L) && (c[2] & N_L)) n |= N_L;
                if ((c[1] & N_R) && (c[3] & N_R)) n |= N_R;
                if ((c[0] & N_T) && (c[1] & N_T)) n |= N_T;
                if ((c[2] & N_B) && (c[3] & N_B)) n |= N_B;
                n |= (uint16_t)((c[0] & N_TL) | (c[1] & N_TR) | (c[2] & N_BL) | (c[3] & N_BR));
                uint16_t m = surf ? M_FULL : s == WARP_GRID_IRREGULAR ? merge_type(s0, s1, s2, s3, cT, cB, cL, cR) : M_NONE;
                n |= (uint16_t)(m << N_MERGE_SHIFT);
                long i = nidx(g, k, ix, iy);
                g->node[i] = n;
                g->curv[i] = kk;
                g->dmin[i] = mn;
                g->dmax[i] = mx;
            }
}

/* ---- grid building (000 §4.1.4) ---- */

typedef struct {
    warp_grid *g;
    const warp_grid_params *p;
    double didyk_range; /* inverse-depth range matching didyk_disparity_px */
} emitter;

static void emit(emitter *e, int x0, int y0, int x1, int y1)
{
    warp_grid *g = e->g;
    if (x1 > g->w) x1 = g->w;
    if (y1 > g->h) y1 = g->h;
    if (x0 >= x1 || y0 >= y1 || g->n_cells >= g->max_cells) return;
    warp_grid_cell *c = &g->cell[g->n_cells++];
    c->x0 = (uint16_t)x0, c->y0 = (uint16_t)y0, c->x1 = (uint16_t)x1, c->y1 = (uint16_t)y1;
}

static inline bool fits(const emitter *e, float curv, int n)
{
    /* Linear interpolation over length n of a function with second difference k (per pixel^2) is off by at most
     * k n^2 / 8: the accumulated estimation error of §4.1.4 expressed as relative inverse depth. */
    return curv * (float)n * (float)n * 0.125f <= e->p->max_error;
}

static void emit_pixels(emitter *e, int x0, int y0, int n)
{
    for (int y = y0; y < y0 + n; y++)
        for (int x = x0; x < x0 + n; x++) emit(e, x, y, x + 1, y + 1);
}

static void refine(emitter *e, int k, int ix, int iy);

/* One child (square) of a level-k node, or a pixel when k == 0. */
static void refine_child(emitter *e, int k, int ix, int iy, int j)
{
    int cx = 2 * ix + (j & 1), cy = 2 * iy + (j >> 1);
    if (k == 0) {
        emit(e, cx, cy, cx + 1, cy + 1);
        return;
    }
    if (cx < e->g->lw[k - 1] && cy < e->g->lh[k - 1]) refine(e, k - 1, cx, cy);
}

static void refine(emitter *e, int k, int ix, int iy)
{
    warp_grid *g = e->g;
    const int n = 2 << k, x0 = ix * n, y0 = iy * n;
    long i = nidx(g, k, ix, iy);
    if (e->p->strategy == WARP_GRID_DIDYK) {
        if (g->dmax[i] - g->dmin[i] <= e->didyk_range) {
            emit(e, x0, y0, x0 + n, y0 + n);
        } else if (k == 0) {
            emit_pixels(e, x0, y0, 2);
        } else {
            for (int j = 0; j < 4; j++) refine_child(e, k, ix, iy, j);
        }
        return;
    }
    uint16_t nd = g->node[i];
    if ((nd & N_SURF) && fits(e, g->curv[i], n)) {
        emit(e, x0, y0, x0 + n, y0 + n);
        return;
    }
    int m = (nd >> N_MERGE_SHIFT) & 7;
    if (e->p->strategy != WARP_GRID_IRREGULAR || m == M_NONE || m == M_FULL) {
        for (int j = 0; j < 4; j++) refine_child(e, k, ix, iy, j);
        return;
    }
    /* irregular: the merged pairs become rectangles (when flat enough), the rest recurses */
    bool used[4] = {false, false, false, false};
    static const int pairs[8][2][2] = {
        [M_T] = {{0, 1}, {-1, -1}}, [M_B] = {{2, 3}, {-1, -1}}, [M_L] = {{0, 2}, {-1, -1}},
        [M_R] = {{1, 3}, {-1, -1}}, [M_TB] = {{0, 1}, {2, 3}},  [M_LR] = {{0, 2}, {1, 3}},
    };
    const int h = n / 2;
    for (int q = 0; q < 2; q++) {
        int a = pairs[m][q][0], b = pairs[m][q][1];
        if (a < 0) continue;
        float curv;
        if (k == 0) {
            int ax = x0 + (a & 1), ay = y0 + (a >> 1), bx = x0 + (b & 1), by = y0 + (b >> 1);
            curv = fmaxf(ax < g->w && ay < g->h ? g->pxcurv[(size_t)ay * g->w + ax] : 0,
                         bx < g->w && by < g->h ? g->pxcurv[(size_t)by * g->w + bx] : 0);
        } else {
            int ax = 2 * ix + (a & 1), ay = 2 * iy + (a >> 1), bx = 2 * ix + (b & 1), by = 2 * iy + (b >> 1);
            float ca = ax < g->lw[k - 1] && ay < g->lh[k - 1] ? g->curv[nidx(g, k - 1, ax, ay)] : 0;
            float cb = bx < g->lw[k - 1] && by < g->lh[k - 1] ? g->curv[nidx(g, k - 1, bx, by)] : 0;
            curv = fmaxf(ca, cb);
        }
        if (!fits(e, curv, n)) continue;
        int rx0 = x0 + (a & 1) * h, ry0 = y0 + (a >> 1) * h;
        int rx1 = x0 + ((b & 1) + 1) * h, ry1 = y0 + ((b >> 1) + 1) * h;
        emit(e, rx0, ry0, rx1, ry1);
        used[a] = used[b] = true;
    }
    for (int j = 0; j < 4; j++)
        if (!used[j]) refine_child(e, k, ix, iy, j);
}

/* Depth of the grid vertex at pixel corner (vx, vy) for a cell whose pixel at that corner is (px, py): the mean of
 * the (up to four) pixels around the vertex that are connected to (px, py) (000 §5.1: between pixels on a connected
 * surface, from the pixel itself across a discontinuity). Cells of one surface see the same set, so they stay
 * stitched; across an edge they part instead of forming a rubber sheet. */
static float vertex_depth(const warp_grid *g, const warp_image_f32 *d, int vx, int vy, int px, int py, bool all,
                          bool *discontinuous)
{
    /* the four pixels around the vertex: 0 = (vx-1, vy-1), 1 = (vx, vy-1), 2 = (vx-1, vy), 3 = (vx, vy) */
    int xs[4] = {vx - 1, vx, vx - 1, vx}, ys[4] = {vy - 1, vy - 1, vy, vy};
    bool in[4], mem[4] = {false, false, false, false};
    int nin = 0;
    for (int j = 0; j < 4; j++) {
        in[j] = xs[j] >= 0 && ys[j] >= 0 && xs[j] < g->w && ys[j] < g->h;
        nin += in[j];
    }
    int self = (px == vx) + 2 * (py == vy);
    if (all) {
        for (int j = 0; j < 4; j++) mem[j] = in[j];
    } else {
        /* connected component of `self` over the 4-pixel neighbourhood (6 possible pairs) */
        mem[self] = true;
        for (int it = 0; it < 3; it++)
            for (int a = 0; a < 4; a++) {
                if (!mem[a]) continue;
                for (int b = 0; b < 4; b++)
                    if (!mem[b] && in[b] && warp_grid_connected(g, xs[a], ys[a], xs[b] - xs[a], ys[b] - ys[a]))
                        mem[b] = true;
            }
    }
    float s = 0;
    int n = 0;
    for (int j = 0; j < 4; j++)
        if (mem[j]) s += dat(d, xs[j], ys[j]), n++;
    *discontinuous = n < nin;
    return s / (float)n;
}

const char *warp_grid_build(warp_grid *g, const warp_view *src, const warp_grid_params *p, warp_grid_stats *st)
{
    if (!src->inv_depth) return "grid warp needs a depth plane";
    if (!src->color) return "grid warp needs a colour plane";
    if (src->inv_depth->w != g->w || src->inv_depth->h != g->h || src->color->w != g->w || src->color->h != g->h)
        return "grid and source planes differ in size";
    if (p->tile != g->tile) return "grid was allocated for another tile size";
    if (!(p->collinear_eps >= 0) || !(p->max_error >= 0) || !(p->didyk_disparity_px >= 0) ||
        !(p->didyk_baseline_m > 0))
        return "grid parameters are not valid";
    const warp_image_f32 *d = src->inv_depth;
    long bad = pixel_tests(g, d, p->collinear_eps);
    pair_bits(g);
    build_tree(g, d, p->strategy);
    g->strategy = p->strategy;
    g->filter = p->strategy == WARP_GRID_DIDYK ? WARP_GRID_FILTER_LINEAR : p->filter;
    g->n_cells = 0;
    emitter e = {g, p, 0};
    /* disparity (px) = focal (px) * baseline * delta(1/z) */
    e.didyk_range = p->didyk_disparity_px / (warp_camera_pixels_per_tan_x(&src->cam) * p->didyk_baseline_m);
    const int top = g->levels - 1;
    for (int iy = 0; iy < g->lh[top]; iy++)
        for (int ix = 0; ix < g->lw[top]; ix++) refine(&e, top, ix, iy);
    /* corner depths */
    const bool all = p->strategy == WARP_GRID_DIDYK; /* Didyk et al.: vertices between pixels everywhere */
    long disc = 0, one = 0;
    for (long i = 0; i < g->n_cells; i++) {
        warp_grid_cell *c = &g->cell[i];
        int vx[4] = {c->x0, c->x1, c->x0, c->x1}, vy[4] = {c->y0, c->y0, c->y1, c->y1};
        int px[4] = {c->x0, c->x1 - 1, c->x0, c->x1 - 1}, py[4] = {c->y0, c->y0, c->y1 - 1, c->y1 - 1};
        for (int j = 0; j < 4; j++) {
            bool dj;
            c->d[j] = vertex_depth(g, d, vx[j], vy[j], px[j], py[j], all, &dj);
            disc += dj;
        }
        one += c->x1 - c->x0 == 1 && c->y1 - c->y0 == 1;
    }
    if (st) {
        st->cells += g->n_cells;
        st->cells_1px += one;
        st->triangles += 2 * g->n_cells;
        st->discontinuous_vertices += disc;
        st->bad_depth += bad;
    }
    return NULL;
}

/* ---- grid warping (000 §5.1) ---- */

typedef struct {
    double x, y;    /* target pixel position */
    double iw;      /* 1 / w: perspective-correct weight */
    double sx, sy;  /* source pixel position, times iw */
    double dt;      /* target inverse depth (affine in target screen space) */
} wvert;

typedef struct {
    const warp_grid *g;
    const warp_view *src;
    warp_image_rgba8 *dst;
    warp_image_f32 *zb;
    int y0, y1;
    warp_grid_filter filter;
    long frags, lin, nea;
} raster;

static inline warp_rgba8 sample(raster *r, double sx, double sy)
{
    const warp_grid *g = r->g;
    const warp_image_rgba8 *img = r->src->color;
    if (r->filter != WARP_GRID_FILTER_NEAREST) {
        double fx = sx - 0.5, fy = sy - 0.5;
        int x0 = (int)floor(fx), y0 = (int)floor(fy);
        bool lin = r->filter == WARP_GRID_FILTER_LINEAR || x0 < 0 || y0 < 0 || x0 + 1 >= g->w || y0 + 1 >= g->h ||
                   (pxb(g, x0, y0) & PX_QUAD);
        if (lin) {
            r->lin++;
            return warp_sample_bilinear(img, (float)sx, (float)sy);
        }
    }
    r->nea++;
    int x = (int)floor(sx), y = (int)floor(sy);
    x = x < 0 ? 0 : x >= g->w ? g->w - 1 : x;
    y = y < 0 ? 0 : y >= g->h ? g->h - 1 : y;
    return WARP_AT(img, x, y);
}

/* Edge function, evaluated with the endpoints in a canonical order so that the two triangles sharing an edge get
 * exactly opposite values: a pixel centre on the edge (e.g. on every square cell's diagonal) is then neither
 * dropped by both nor drawn by both. */
static inline double edgef(const wvert *a, const wvert *b, double px, double py)
{
    if (a->x > b->x || (a->x == b->x && a->y > b->y)) {
        const wvert *t = a;
        a = b;
        b = t;
        return -((b->x - a->x) * (py - a->y) - (b->y - a->y) * (px - a->x));
    }
    return (b->x - a->x) * (py - a->y) - (b->y - a->y) * (px - a->x);
}

/* Shared edges are owned by exactly one of their two triangles: the test is antisymmetric in the edge direction. */
static inline bool owns(const wvert *a, const wvert *b)
{
    double dx = b->x - a->x, dy = b->y - a->y;
    return dy > 0 || (dy == 0 && dx < 0);
}

static void tri(raster *r, const wvert *v0, const wvert *v1, const wvert *v2)
{
    double area = edgef(v0, v1, v2->x, v2->y);
    if (area == 0 || !isfinite(area)) return;
    if (area < 0) { /* folded or seen from behind: rasterise anyway, the z-buffer decides */
        const wvert *t = v1;
        v1 = v2;
        v2 = t;
        area = -area;
    }
    const int W = r->dst->w;
    double xmin = fmin(v0->x, fmin(v1->x, v2->x)), xmax = fmax(v0->x, fmax(v1->x, v2->x));
    double ymin = fmin(v0->y, fmin(v1->y, v2->y)), ymax = fmax(v0->y, fmax(v1->y, v2->y));
    int ix0 = (int)fmax(ceil(xmin - 0.5), 0), ix1 = (int)fmin(floor(xmax - 0.5), W - 1);
    int iy0 = (int)fmax(ceil(ymin - 0.5), r->y0), iy1 = (int)fmin(floor(ymax - 0.5), r->y1 - 1);
    if (ix0 > ix1 || iy0 > iy1) return;
    const bool o0 = owns(v1, v2), o1 = owns(v2, v0), o2 = owns(v0, v1);
    const double inv_area = 1.0 / area;
    for (int y = iy0; y <= iy1; y++) {
        double py = y + 0.5;
        for (int x = ix0; x <= ix1; x++) {
            double px = x + 0.5;
            double w0 = edgef(v1, v2, px, py), w1 = edgef(v2, v0, px, py), w2 = edgef(v0, v1, px, py);
            if (w0 < 0 || w1 < 0 || w2 < 0) continue;
            if ((w0 == 0 && !o0) || (w1 == 0 && !o1) || (w2 == 0 && !o2)) continue;
            w0 *= inv_area, w1 *= inv_area, w2 *= inv_area;
            double dt = w0 * v0->dt + w1 * v1->dt + w2 * v2->dt;
            float *z = &WARP_AT(r->zb, x, y);
            if (!(dt > *z)) continue; /* larger inverse depth is nearer */
            double iw = w0 * v0->iw + w1 * v1->iw + w2 * v2->iw;
            double sx = (w0 * v0->sx + w1 * v1->sx + w2 * v2->sx) / iw;
            double sy = (w0 * v0->sy + w1 * v1->sy + w2 * v2->sy) / iw;
            *z = (float)dt;
            WARP_AT(r->dst, x, y) = sample(r, sx, sy);
            r->frags++;
        }
    }
}

/* Row-wise fill of uncovered pixels from the farther of the nearest covered pixels left and right: the stretched
 * background of 000 Fig. 8, here only so that the grid warp is complete on its own. */
static long fill_rows(warp_image_rgba8 *dst, const warp_image_f32 *zb, warp_image_u8 *mask, int y0, int y1, bool fill)
{
    long holes = 0;
    const int W = dst->w;
    for (int y = y0; y < y1; y++) {
        int last = -1; /* last covered pixel to the left */
        for (int x = 0; x < W; x++) {
            if (WARP_AT(zb, x, y) >= 0) {
                last = x;
                continue;
            }
            int e = x;
            while (e < W && WARP_AT(zb, e, y) < 0) e++;
            holes += e - x;
            for (int q = x; q < e; q++) {
                if (mask) WARP_AT(mask, q, y) |= WARP_MASK_HOLE | (fill ? WARP_MASK_FILLED : 0);
                if (!fill) continue;
                int pick = last < 0 ? e : e >= W ? last : (WARP_AT(zb, last, y) <= WARP_AT(zb, e, y) ? last : e);
                if (pick >= 0 && pick < W) WARP_AT(dst, q, y) = WARP_AT(dst, pick, y);
                else WARP_AT(dst, q, y) = (warp_rgba8){0, 0, 0, 255};
            }
            x = e - 1;
        }
    }
    return holes;
}

const char *warp_grid_warp_rows(const warp_grid *g, const warp_view *src, const warp_camera *dst_cam,
                                warp_pose dst_pose, const warp_grid_params *p, warp_image_rgba8 *dst,
                                warp_image_f32 *dst_inv, warp_image_u8 *mask, int y0, int y1, warp_grid_stats *st)
{
    const char *bad = warp_poses_check(src->pose, dst_pose);
    if (bad) return bad;
    if (!src->color || src->color->w != g->w || src->color->h != g->h) return "grid and source differ in size";
    if (dst->w != dst_cam->width || dst->h != dst_cam->height || dst_inv->w != dst->w || dst_inv->h != dst->h ||
        (mask && (mask->w != dst->w || mask->h != dst->h)))
        return "target planes differ from the target camera";
    if (y0 < 0) y0 = 0;
    if (y1 > dst->h) y1 = dst->h;
    for (int y = y0; y < y1; y++)
        for (int x = 0; x < dst->w; x++) {
            WARP_AT(dst_inv, x, y) = -1.0f;
            if (mask) WARP_AT(mask, x, y) = 0;
        }
    /* Combined warp (§5.1: "one combined warp matrix"): source eye homogeneous (u, v, -1, d) -> target eye
     * R (u, v, -1) + t d, then target pixels. */
    warp_pose rel = warp_pose_relative(dst_pose, src->pose); /* target_from_source */
    warp_mat3 R = warp_quat_to_mat3(rel.q);
    raster r = {g, src, dst, dst_inv, y0, y1, g->filter, 0, 0, 0};
    long drawn = 0;
    const double px_x = warp_camera_pixels_per_tan_x(dst_cam), px_y = warp_camera_pixels_per_tan_y(dst_cam);
    for (long i = 0; i < g->n_cells; i++) {
        const warp_grid_cell *c = &g->cell[i];
        wvert v[4];
        bool ok = true;
        for (int j = 0; j < 4 && ok; j++) {
            double sx = (j & 1) ? c->x1 : c->x0, sy = (j & 2) ? c->y1 : c->y0, d = c->d[j];
            double u, vv;
            warp_camera_pixel_to_tan(&src->cam, sx, sy, &u, &vv);
            warp_vec3 q = warp_mat3_apply(&R, warp_v3(u, vv, -1.0));
            q = warp_v3_add(q, warp_v3_scale(rel.p, d));
            double w = -q.z;
            if (!(w > 1e-9)) {
                ok = false; /* behind the target eye: dropped (near-plane clipping is not worth it here) */
                break;
            }
            double iw = 1.0 / w;
            v[j].x = (q.x * iw + dst_cam->tan_left) * px_x;
            v[j].y = (dst_cam->tan_up - q.y * iw) * px_y;
            v[j].iw = iw;
            v[j].sx = sx * iw;
            v[j].sy = sy * iw;
            v[j].dt = d * iw;
        }
        if (!ok) continue;
        tri(&r, &v[0], &v[1], &v[3]);
        tri(&r, &v[0], &v[3], &v[2]);
        drawn += 2;
    }
    long holes = fill_rows(dst, dst_inv, mask, y0, y1, p->fill_holes);
    if (st) {
        st->triangles_drawn += drawn;
        st->fragments += r.frags;
        st->linear_samples += r.lin;
        st->nearest_samples += r.nea;
        st->holes += holes;
    }
    return NULL;
}

const char *warp_grid_run(warp_grid *g, const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose,
                          const warp_grid_params *p, warp_image_rgba8 *dst, warp_image_f32 *dst_inv,
                          warp_image_u8 *mask, warp_grid_stats *st)
{
    const char *err = warp_grid_build(g, src, p, st);
    if (err) return err;
    return warp_grid_warp_rows(g, src, dst_cam, dst_pose, p, dst, dst_inv, mask, 0, dst->h, st);
}

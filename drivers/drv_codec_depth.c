/* SPDX-License-Identifier: MIT */
/* drv_codec_depth: framelink v2's compact depth: quantisation to 16 bits, nearest-keeping downsampling and the
 * colour-guided upsample on the board (pure functions; docs/framelink.md, Depth). */
#include "drivers/drv_codec_depth.h"

#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "warp/warp_v4.h"

uint16_t drv_depth_to_unorm16(float d)
{
    double c = d >= 0.0f ? (d <= 1.0f ? d : 1.0) : (d < 0.0f ? 0.0 : 1.0);
    return (uint16_t)lround(c * 65535.0);
}

float drv_depth_from_unorm16(uint16_t v) { return (float)(v / 65535.0); }

/* The encoding's far end, and whether a is nearer than b (NaN never is). */
static float far_value(warp_depth_encoding enc)
{
    return enc == WARP_DEPTH_LINEAR ? INFINITY : enc == WARP_DEPTH_REVERSED ? 0.0f : 1.0f;
}
static bool nearer(float a, float b, warp_depth_encoding enc)
{
    return enc == WARP_DEPTH_REVERSED ? a > b : a < b;
}

/* A value proportional to inverse depth (0 at infinity): window depth is affine in 1/z, linear depth is z. */
static double inverse(float d, warp_depth_encoding enc)
{
    switch (enc) {
    case WARP_DEPTH_LINEAR: return d > 0.0f ? 1.0 / d : 0.0;
    case WARP_DEPTH_STANDARD: return 1.0 - d;
    default: return d;
    }
}
static float from_inverse(double q, warp_depth_encoding enc)
{
    switch (enc) {
    case WARP_DEPTH_LINEAR: return q > 0.0 ? (float)(1.0 / q) : INFINITY;
    case WARP_DEPTH_STANDARD: return (float)(1.0 - q);
    default: return (float)q;
    }
}

void drv_depth_downsample(const float *src, int w, int h, size_t stride, int scale, warp_depth_encoding enc,
                          float *dst)
{
    int lw = drv_depth_scaled(w, scale), lh = drv_depth_scaled(h, scale), b = 1 << scale;
    for (int by = 0; by < lh; by++)
        for (int bx = 0; bx < lw; bx++) {
            float best = far_value(enc);
            double qmin = INFINITY, qmax = -INFINITY, qsum = 0;
            int n = 0;
            bool finite = true;
            for (int y = by * b; y < by * b + b && y < h; y++)
                for (int x = bx * b; x < bx * b + b && x < w; x++) {
                    float d = src[(size_t)y * stride + (size_t)x];
                    if (nearer(d, best, enc)) best = d;
                    double q = inverse(d, enc);
                    finite = finite && isfinite(d);
                    qmin = q < qmin ? q : qmin, qmax = q > qmax ? q : qmax, qsum += q, n++;
                }
            /* One surface: its mean in inverse depth (the nearest would shift a slope by up to a block). */
            if (finite && qmax - qmin <= DRV_DEPTH_EDGE_REL * qmax && qmax > 0) best = from_inverse(qsum / n, enc);
            dst[(size_t)by * (size_t)lw + (size_t)bx] = best;
        }
}

static int colour_dist(warp_rgba8 a, warp_rgba8 b)
{
    return abs(a.r - b.r) + abs(a.g - b.g) + abs(a.b - b.b);
}

size_t drv_depth_upsample_scratch(int lw, int lh) { return (size_t)lw * (size_t)lh * (sizeof(float) + 1); }

/* Whether the samples of block bx and its 8 neighbours lie on one surface (or are all sky): within
 * DRV_DEPTH_EDGE_REL of each other in inverse depth. A pixel of a block next to an edge is treated as on the edge
 * even when its 4 nearest samples agree: its own block's sample may be a foreground depth its pixel lacks. Each
 * column's min, max and NaN over the 3 sample rows is found once and slid along x; a row or column past the border
 * repeats the border's, which changes no min, max or NaN. These are those of the 9 samples, so the test is the one
 * on the 9 (a -0 for a 0 changes nothing). */
typedef struct { float mn, mx; bool nan; } ups_col;
static inline ups_col ups_column(const float *r0, const float *r1, const float *r2, int x)
{
    float a = r0[x], b = r1[x], c = r2[x];
    float mn = a < b ? a : b, mx = a > b ? a : b;
    return (ups_col){c < mn ? c : mn, c > mx ? c : mx, isnan(a) || isnan(b) || isnan(c)};
}
static void ups_flat_row(const float *q, int lw, int lh, int by, uint8_t *flat)
{
    const float *r1 = q + (size_t)by * (size_t)lw, *r0 = by > 0 ? r1 - lw : r1, *r2 = by + 1 < lh ? r1 + lw : r1;
    ups_col a, b = ups_column(r0, r1, r2, 0), c;
    a = b;
    for (int bx = 0; bx < lw; bx++, a = b, b = c) {
        c = bx + 1 < lw ? ups_column(r0, r1, r2, bx + 1) : b;
        float mn = a.mn < b.mn ? a.mn : b.mn, mx = a.mx > b.mx ? a.mx : b.mx;
        mn = c.mn < mn ? c.mn : mn, mx = c.mx > mx ? c.mx : mx;
        flat[bx] = !(a.nan || b.nan || c.nan) && mx - mn <= (float)DRV_DEPTH_EDGE_REL * mx;
    }
}

void drv_depth_upsample_prepare(const float *lo, int lw, int lh, warp_depth_encoding enc, void *scratch)
{
    /* Inverse depth of every sample (sky 0) and whether its block's neighbourhood is one surface, once. */
    float *q = scratch;
    uint8_t *flat = (uint8_t *)(q + (size_t)lw * (size_t)lh);
    size_t i = 0, n = (size_t)lw * (size_t)lh;
    for (; i + 4 <= n; i += 4) {
        /* (float)inverse(d, enc), 4 lanes at a time (warp_v4.h: -O2's very cheap vectoriser takes no loop of
         * unknown count), in double as inverse() computes it */
        warp_v4f d, o;
        memcpy(&d, lo + i, sizeof d);
        if (enc == WARP_DEPTH_LINEAR) {
            warp_v4f r = __builtin_convertvector(1.0 / __builtin_convertvector(d, warp_v4d), warp_v4f);
            o = (warp_v4f)((warp_v4i)r & (d > 0.0f)); /* else +0 */
        } else if (enc == WARP_DEPTH_STANDARD) {
            o = __builtin_convertvector(1.0 - __builtin_convertvector(d, warp_v4d), warp_v4f);
        } else {
            o = __builtin_convertvector(__builtin_convertvector(d, warp_v4d), warp_v4f);
        }
        memcpy(q + i, &o, sizeof o);
    }
    for (; i < n; i++) q[i] = (float)inverse(lo[i], enc);
    for (int by = 0; by < lh; by++) ups_flat_row(q, lw, lh, by, flat + (size_t)by * (size_t)lw);
}

void drv_depth_upsample(const float *lo, int lw, int lh, int scale, warp_depth_encoding enc,
                        const warp_image_rgba8 *color, float *dst, int w, int h, size_t stride, void *scratch)
{
    drv_depth_upsample_prepare(lo, lw, lh, enc, scratch);
    drv_depth_upsample_rows(lo, lw, lh, scale, enc, color, dst, w, h, stride, 0, h, scratch);
}

/* Columns per tile of drv_depth_upsample_rows: a tile's per-x tables and two horizontally interpolated sample rows
 * live on the stack (5 KiB; no VLA, nothing allocated), and every row of the band reuses them. */
#define UPS_TILE 256

/* Where pixel x (or row y) falls between samples: the clamped sample pair and the weight of the second, exactly as
 * the per-pixel code computed them (the equivalence test holds the two bit for bit). */
static void ups_coord(int x, int scale, int lw, int *xa, int *xb, float *tx)
{
    const float inv_b = 1.0f / (float)(1 << scale);
    /* Low-resolution coordinates of the pixel centre; samples sit at their block centres. */
    float fx = ((float)x + 0.5f) * inv_b - 0.5f;
    int x0 = (int)floorf(fx);
    *tx = fx - (float)x0;
    *xa = x0 < 0 ? 0 : x0 >= lw ? lw - 1 : x0;
    *xb = x0 + 1 >= lw ? lw - 1 : x0 + 1 < 0 ? 0 : x0 + 1;
}

/* A run of one-surface pixels: bilinear in inverse depth, exact for planes, from the two horizontally interpolated
 * rows (the same float operations, in the same order, as a + (b - a) tx, c + (d - c) tx, then along y), then
 * from_inverse, 4 pixels at a time. */
static void ups_flat_run(float *restrict out, const float *restrict top, const float *restrict bot, float ty, int n,
                         warp_depth_encoding enc)
{
    const warp_v4f vty = (warp_v4f){0} + ty, inf = (warp_v4f){0} + INFINITY;
    int i = 0;
    for (; i + 4 <= n; i += 4) {
        warp_v4f t, u;
        memcpy(&t, top + i, sizeof t), memcpy(&u, bot + i, sizeof u);
        warp_v4f s = t + (u - t) * vty, o;
        if (enc == WARP_DEPTH_LINEAR) {
            /* q > 0 ? (float)(1.0 / q) : INFINITY, q = (double)s; s > 0 is the same test */
            warp_v4f r = __builtin_convertvector(1.0 / __builtin_convertvector(s, warp_v4d), warp_v4f);
            warp_v4i m = s > 0.0f;
            o = warp_v4f_select(m, r, inf);
        } else if (enc == WARP_DEPTH_STANDARD) {
            o = __builtin_convertvector(1.0 - __builtin_convertvector(s, warp_v4d), warp_v4f);
        } else {
            o = s;
        }
        memcpy(out + i, &o, sizeof o);
    }
    for (; i < n; i++) out[i] = from_inverse(top[i] + (bot[i] - top[i]) * ty, enc);
}

/* One pixel whose block's neighbourhood is not one surface: the per-pixel path (rare: depth edges and sky borders). */
static float ups_edge_pixel(const float *lo, const float *q, int lw, int lh, int scale, warp_depth_encoding enc,
                            const warp_image_rgba8 *color, int w, int h, int x, int y, int xa, int xb, float tx,
                            const int ys[2], float ty)
{
    const int b = 1 << scale, bx = x >> scale, by = y >> scale;
    const float *q0 = q + (size_t)ys[0] * (size_t)lw, *q1 = q + (size_t)ys[1] * (size_t)lw;
    float a = q0[xa], bq = q0[xb], c = q1[xa], d = q1[xb];
    if (!color) {
        /* Without colour the 4 nearest samples judge for themselves. */
        float mn = fminf(fminf(a, bq), fminf(c, d)), mx = fmaxf(fmaxf(a, bq), fmaxf(c, d));
        if (!isnan(a + bq + c + d) && mx - mn <= (float)DRV_DEPTH_EDGE_REL * mx) {
            float s = (a + (bq - a) * tx) + ((c + (d - c) * tx) - (a + (bq - a) * tx)) * ty;
            return from_inverse(s, enc);
        }
        /* the spatially nearest */
        return lo[(size_t)ys[ty >= 0.5f] * (size_t)lw + (size_t)(tx >= 0.5f ? xb : xa)];
    }
    /* A depth edge: the sample of the pixel's own block or one of its 8 neighbours (the 4 nearest may all lie on
     * the far side of the edge) whose block-centre colour is closest to the pixel's, taken as it is. A tie goes to
     * the farther sample: a nearer one sharing the colour took its depth from a few foreground pixels of a block
     * whose centre shows the background. */
    warp_rgba8 px = WARP_AT(color, x, y);
    int bd = 1 << 30;
    float best_q = INFINITY, out = lo[(size_t)by * (size_t)lw + (size_t)bx];
    static const int off[3] = {0, -1, 1}; /* own block first: it wins ties of colour and depth */
    for (int i = 0; i < 9; i++) {
        int sx = bx + off[i % 3], sy = by + off[i / 3];
        if (sx < 0 || sy < 0 || sx >= lw || sy >= lh) continue;
        int cx = sx * b + b / 2, cy = sy * b + b / 2;
        if (cx >= w) cx = w - 1;
        if (cy >= h) cy = h - 1;
        size_t si = (size_t)sy * (size_t)lw + (size_t)sx;
        int dist = colour_dist(px, WARP_AT(color, cx, cy));
        if (dist < bd || (dist == bd && q[si] < best_q)) bd = dist, best_q = q[si], out = lo[si];
    }
    return out;
}

/* The pixels of a flat block depend on x only through (xa, xb, tx) and on y only through the sample rows and ty,
 * so a column tile tabulates x once, interpolates each sample row it needs along x once (kept while successive
 * rows share it: 2^(scale + 1) output rows read each), and a run of flat blocks is then one vectorised loop. */
void drv_depth_upsample_rows(const float *lo, int lw, int lh, int scale, warp_depth_encoding enc,
                             const warp_image_rgba8 *color, float *dst, int w, int h, size_t stride, int row0,
                             int row1, const void *scratch)
{
    const float *q = scratch;
    const uint8_t *flat = (const uint8_t *)(q + (size_t)lw * (size_t)lh);
    int xa[UPS_TILE], xb[UPS_TILE];
    float tx[UPS_TILE], hrow[2][UPS_TILE];
    for (int t0 = 0; t0 < w; t0 += UPS_TILE) {
        const int n = w - t0 < UPS_TILE ? w - t0 : UPS_TILE;
        for (int i = 0; i < n; i++) ups_coord(t0 + i, scale, lw, &xa[i], &xb[i], &tx[i]);
        int tag[2] = {-1, -1}; /* the sample row each hrow holds */
        for (int y = row0; y < row1; y++) {
            int ys[2], by = y >> scale;
            float ty;
            ups_coord(y, scale, lh, &ys[0], &ys[1], &ty);
            /* hrow slots for the two sample rows: reuse what the previous row left, fill the other slot */
            int s[2];
            for (int k = 0; k < 2; k++) {
                int o = k ? s[0] : -1; /* the slot row 0 took: only row 1 may share it, and only if equal */
                s[k] = tag[0] == ys[k] ? 0 : tag[1] == ys[k] ? 1 : -1;
                if (s[k] >= 0) continue;
                s[k] = o == 0 ? 1 : o == 1 ? 0 : tag[0] == ys[1] ? 1 : 0;
                const float *qr = q + (size_t)ys[k] * (size_t)lw;
                float *hr = hrow[s[k]];
                for (int i = 0; i < n; i++) hr[i] = qr[xa[i]] + (qr[xb[i]] - qr[xa[i]]) * tx[i];
                tag[s[k]] = ys[k];
            }
            const float *top = hrow[s[0]], *bot = hrow[s[1]];
            const uint8_t *frow = flat + (size_t)by * (size_t)lw;
            float *drow = dst + (size_t)y * stride + (size_t)t0;
            /* runs of flat blocks, and the blocks between them pixel by pixel */
            for (int i = 0, bx = t0 >> scale, bend = ((t0 + n - 1) >> scale) + 1; i < n;) {
                const bool one = frow[bx];
                /* flags are 0 or 1: 8 at a time while all match, then one by one */
                const uint64_t all = one ? UINT64_C(0x0101010101010101) : 0;
                uint64_t v8;
                for (bx++; bx + 8 <= bend && (memcpy(&v8, frow + bx, 8), v8 == all);) bx += 8;
                for (; bx < bend && (bool)frow[bx] == one;) bx++;
                const int e = (bx << scale) - t0 < n ? (bx << scale) - t0 : n;
                if (one)
                    ups_flat_run(drow + i, top + i, bot + i, ty, e - i, enc);
                else
                    for (; i < e; i++)
                        drow[i] = ups_edge_pixel(lo, q, lw, lh, scale, enc, color, w, h, t0 + i, y, xa[i], xb[i],
                                                 tx[i], ys, ty);
                i = e;
            }
        }
    }
}

/* SPDX-License-Identifier: MIT */
/* Hole filling for forward and iterative warps: 002 §3.3 (bidirectional epipolar far-pixel scan), 000 §5.2
 * (depth-aware low-pass pyramid with an epipolar border search) and the stretch / rubber-sheet baselines of 000 §2.2.
 * All fills read a snapshot of the valid pixels taken in warp_holes_prepare, never pixels filled in this pass, so
 * the result does not depend on the order or the row split. */
#include "warp/warp_holes.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define MAX_LEVELS 16

warp_holes_params warp_holes_default_params(void)
{
    warp_holes_params p = {
        .method = WARP_HOLES_EPIPOLAR_FAR,
        .max_search = 1024,
        .depth_tolerance = 0.05f,
        .max_levels = 9,
        .kernel = 4,
        .level_bias = -1, /* the doubling border search overestimates the distance by up to 2x */
        .depth_aware = true,
        .empty = {0, 0, 0, 255},
    };
    return p;
}

const char *warp_holes_method_name(warp_holes_method m)
{
    switch (m) {
    case WARP_HOLES_EPIPOLAR_FAR: return "epipolar-far";
    case WARP_HOLES_LOWPASS: return "lowpass";
    case WARP_HOLES_STRETCH_NEAREST: return "stretch-nearest";
    case WARP_HOLES_STRETCH_BACKGROUND: return "stretch-background";
    case WARP_HOLES_RUBBER_SHEET: return "rubber-sheet";
    }
    return "unknown";
}

/* ---- epipole ---- */

warp_epipole warp_epipole_from_poses(const warp_camera *dst_cam, warp_pose dst_pose, warp_pose src_pose)
{
    /* Target eye coordinates of a source-eye point X_s: X_t = R X_s + c, c = the source centre in the target frame.
     * With X_s = z ray, K X_t = z (K R ray + K c / z): the target pixel is the point-at-infinity image a = K R ray
     * pushed towards the homogeneous epipole e = K c by the inverse depth (004 §3). */
    warp_vec3 c = warp_pose_apply(warp_pose_inverse(dst_pose), src_pose.p);
    warp_mat3 k = warp_camera_K(dst_cam);
    warp_vec3 e = warp_mat3_apply(&k, c);
    warp_epipole r = {0, 0, true, false};
    double exy = hypot(e.x, e.y);
    if (!(exy > 0 || e.z != 0)) return r; /* no translation */
    if (fabs(e.z) <= 1e-9 * exy) {
        r.x = e.x / exy;
        r.y = e.y / exy;
        return r;
    }
    r.at_infinity = false;
    r.x = e.x / e.z;
    r.y = e.y / e.z;
    r.expansion = e.z < 0; /* the source centre lies behind the target eye: the eye moved forward */
    return r;
}

static void epipole_homogeneous(const warp_epipole *e, double *ex, double *ey, double *ew)
{
    if (e->at_infinity) {
        *ex = e->x, *ey = e->y, *ew = 0;
    } else if (e->expansion) {
        *ex = -e->x, *ey = -e->y, *ew = -1;
    } else {
        *ex = e->x, *ey = e->y, *ew = 1;
    }
}

/* d/ds of (a + s e)_xy / (a + s e)_w at the point q is proportional to e_xy - q e_w (positive factor for points in
 * front of the eye): one formula for finite epipoles of both kinds and for those at infinity. */
static bool direction_h(double ex, double ey, double ew, double x, double y, double *dx, double *dy)
{
    double vx = ex - x * ew, vy = ey - y * ew, n = hypot(vx, vy);
    if (!(n > 1e-9) || !isfinite(n)) {
        *dx = 1, *dy = 0;
        return false;
    }
    *dx = vx / n, *dy = vy / n;
    return true;
}

bool warp_epipole_direction(const warp_epipole *e, double x, double y, double *dx, double *dy)
{
    double ex, ey, ew;
    epipole_homogeneous(e, &ex, &ey, &ew);
    return direction_h(ex, ey, ew, x, y, dx, dy);
}

/* ---- scratch ---- */

void warp_holes_free(warp_holes_ctx *c)
{
    for (int l = 0; l < MAX_LEVELS; l++) free(c->lvl[l]);
    free(c->c0);
    free(c->row_prev), free(c->row_next), free(c->col_prev), free(c->col_next), free(c->near_row);
    memset(c, 0, sizeof *c);
}

bool warp_holes_alloc(warp_holes_ctx *c, int w, int h, int max_levels)
{
    memset(c, 0, sizeof *c);
    if (w <= 0 || h <= 0 || w > 32767 || h > 32767 || max_levels < 1 || max_levels > MAX_LEVELS) return false;
    c->w = w, c->h = h;
    int lw = w, lh = h, n = 0;
    for (; n < max_levels; n++) {
        c->lw[n] = lw, c->lh[n] = lh;
        c->lvl[n] = malloc((size_t)lw * (size_t)lh * sizeof *c->lvl[n]);
        if (!c->lvl[n]) {
            warp_holes_free(c);
            return false;
        }
        if (lw == 1 && lh == 1) {
            n++;
            break;
        }
        lw = (lw + 1) / 2, lh = (lh + 1) / 2;
    }
    c->max_levels = n;
    size_t n16 = (size_t)w * (size_t)h * sizeof(int16_t);
    c->c0 = malloc((size_t)w * (size_t)h * sizeof *c->c0);
    c->row_prev = malloc(n16), c->row_next = malloc(n16), c->col_prev = malloc(n16), c->col_next = malloc(n16);
    c->near_row = malloc((size_t)h * sizeof(int16_t));
    if (!c->c0 || !c->row_prev || !c->row_next || !c->col_prev || !c->col_next || !c->near_row) {
        warp_holes_free(c);
        return false;
    }
    return true;
}

/* ---- pyramid (000 §5.2, pull) ---- */

static void pull_level(warp_holes_ctx *c, int l, const warp_holes_params *p)
{
    const warp_holes_cell *src = c->lvl[l - 1];
    warp_holes_cell *dst = c->lvl[l];
    int sw = c->lw[l - 1], sh = c->lh[l - 1], dw = c->lw[l], dh = c->lh[l];
    static const float k2[2] = {1, 1}, k4[4] = {1, 3, 3, 1};
    const float *k = p->kernel == 2 ? k2 : k4;
    int n = p->kernel == 2 ? 2 : 4, o = p->kernel == 2 ? 0 : -1;
    for (int j = 0; j < dh; j++)
        for (int i = 0; i < dw; i++) {
            const warp_holes_cell *tap[16]; /* the children under the kernel, inside the level, and their weights */
            float tk[16];
            int nt = 0;
            for (int b = 0; b < n; b++) {
                int y = 2 * j + o + b;
                if (y < 0 || y >= sh) continue;
                for (int a = 0; a < n; a++) {
                    int x = 2 * i + o + a;
                    if (x < 0 || x >= sw) continue;
                    tap[nt] = &src[(size_t)y * (size_t)sw + (size_t)x];
                    tk[nt++] = k[a] * k[b];
                }
            }
            /* Mean inverse depth of the valid children first; then average only those not nearer than it, so a
             * foreground object in the kernel dissolves instead of smearing over the background. */
            float sk = 0, sw_ = 0, sz = 0;
            for (int t = 0; t < nt; t++) {
                const warp_holes_cell *s = tap[t];
                float kk = tk[t];
                sk += kk;
                sw_ += kk * s->wt;
                sz += kk * s->wt * s->inv;
            }
            float limit = INFINITY;
            if (p->depth_aware && sw_ > 0) limit = sz / sw_ * (1 + p->depth_tolerance) + 1e-6f;
            float acc[4] = {0, 0, 0, 0}, aw = 0, az = 0;
            for (int t = 0; t < nt; t++) {
                const warp_holes_cell *s = tap[t];
                if (!(s->wt > 0) || s->inv > limit) continue;
                float wk = tk[t] * s->wt;
                for (int ch = 0; ch < 4; ch++) acc[ch] += wk * s->c[ch];
                aw += wk;
                az += wk * s->inv;
            }
            warp_holes_cell *d = &dst[(size_t)j * (size_t)dw + (size_t)i];
            if (aw > 0) {
                for (int ch = 0; ch < 4; ch++) d->c[ch] = acc[ch] / aw;
                d->inv = az / aw;
                d->wt = aw / sk; /* coverage: a cell fed by few valid children counts less in the lookup */
            } else {
                memset(d, 0, sizeof *d);
            }
        }
}

static void build_tables(warp_holes_ctx *c)
{
    int w = c->w, h = c->h;
    const warp_holes_cell *l0 = c->lvl[0];
    for (int y = 0; y < h; y++) {
        size_t r = (size_t)y * (size_t)w;
        int16_t last = -1;
        for (int x = 0; x < w; x++) c->row_prev[r + x] = last = l0[r + x].wt > 0 ? (int16_t)x : last;
        last = -1;
        for (int x = w - 1; x >= 0; x--) c->row_next[r + x] = last = l0[r + x].wt > 0 ? (int16_t)x : last;
    }
    for (int x = 0; x < w; x++) {
        int16_t last = -1;
        for (int y = 0; y < h; y++) {
            size_t i = (size_t)y * (size_t)w + (size_t)x;
            c->col_prev[i] = last = l0[i].wt > 0 ? (int16_t)y : last;
        }
        last = -1;
        for (int y = h - 1; y >= 0; y--) {
            size_t i = (size_t)y * (size_t)w + (size_t)x;
            c->col_next[i] = last = l0[i].wt > 0 ? (int16_t)y : last;
        }
    }
    /* nearest non-empty row: two sweeps over "row has a valid pixel" (its row_prev at the last column) */
    int16_t last = -1;
    for (int y = 0; y < h; y++) {
        if (c->row_prev[(size_t)y * (size_t)w + (size_t)(w - 1)] >= 0) last = (int16_t)y;
        c->near_row[y] = last;
    }
    last = -1;
    for (int y = h - 1; y >= 0; y--) {
        if (c->row_prev[(size_t)y * (size_t)w + (size_t)(w - 1)] >= 0) last = (int16_t)y;
        if (last >= 0 && (c->near_row[y] < 0 || last - y < y - c->near_row[y])) c->near_row[y] = last;
    }
}

const char *warp_holes_prepare(warp_holes_ctx *c, const warp_image_rgba8 *dst, const warp_image_u8 *mask,
                               const warp_image_f32 *inv_depth, const warp_epipole *e, const warp_holes_params *p,
                               warp_holes_stats *st)
{
    if (!c || !c->lvl[0]) return "hole fill: scratch not initialised";
    if (!dst || !mask || !e || !p) return "hole fill: missing image, mask, epipole or params";
    if (dst->w != c->w || dst->h != c->h || mask->w != c->w || mask->h != c->h)
        return "hole fill: image or mask size differs from the scratch";
    bool needs_depth = p->method == WARP_HOLES_EPIPOLAR_FAR || p->method == WARP_HOLES_LOWPASS;
    if (needs_depth && !inv_depth) return "hole fill: this method needs the warped inverse depth";
    if (inv_depth && (inv_depth->w != c->w || inv_depth->h != c->h))
        return "hole fill: inverse depth size differs from the image";
    if (p->max_search < 1) return "hole fill: max_search must be >= 1";
    if (!(p->depth_tolerance >= 0)) return "hole fill: depth_tolerance must be >= 0";
    if (p->level_bias < -MAX_LEVELS || p->level_bias > MAX_LEVELS) return "hole fill: level_bias outside -16..16";
    if (p->method == WARP_HOLES_LOWPASS && (p->kernel != 2 && p->kernel != 4))
        return "hole fill: kernel must be 2 or 4";
    if (p->method == WARP_HOLES_LOWPASS && (p->max_levels < 2 || p->max_levels > c->max_levels))
        return "hole fill: max_levels outside 2..the scratch's levels";
    if ((unsigned)p->method > WARP_HOLES_RUBBER_SHEET) return "hole fill: unknown method";
    if (!isfinite(e->x) || !isfinite(e->y)) return "hole fill: epipole not finite";

    c->p = *p;
    if (c->p.max_search > c->w + c->h) c->p.max_search = c->w + c->h; /* any scan leaves the image by then */
    epipole_homogeneous(e, &c->ex, &c->ey, &c->ew);
    long bad = 0;
    warp_holes_cell *l0 = c->lvl[0];
    for (int y = 0; y < c->h; y++)
        for (int x = 0; x < c->w; x++) {
            size_t i = (size_t)y * (size_t)c->w + (size_t)x;
            warp_holes_cell *cell = &l0[i];
            if (WARP_AT(mask, x, y) & WARP_MASK_HOLE) {
                memset(cell, 0, sizeof *cell);
                c->c0[i] = (warp_rgba8){0, 0, 0, 0};
                continue;
            }
            warp_rgba8 px = WARP_AT(dst, x, y);
            c->c0[i] = px;
            cell->c[0] = px.r, cell->c[1] = px.g, cell->c[2] = px.b, cell->c[3] = px.a;
            cell->wt = 1;
            float z = inv_depth ? WARP_AT(inv_depth, x, y) : 0.0f;
            if (!isfinite(z) || z < 0) {
                bad++;
                z = 0;
            }
            cell->inv = z;
        }
    build_tables(c);
    c->levels = 1;
    if (p->method == WARP_HOLES_LOWPASS) {
        for (int l = 1; l < p->max_levels; l++) {
            pull_level(c, l, p);
            c->levels = l + 1;
        }
    }
    if (st) {
        st->bad_depth += bad;
        if (c->levels > st->levels) st->levels = c->levels;
    }
    return NULL;
}

/* ---- searches ---- */

typedef struct {
    bool found;
    int x, y;   /* the valid pixel */
    int dist;   /* steps (pixels along the major axis) from the hole */
    float inv;
} hit;

static inline bool valid_at(const warp_holes_ctx *c, int x, int y)
{
    return c->lvl[0][(size_t)y * (size_t)c->w + (size_t)x].wt > 0;
}

/* Walks from the centre of (x, y) along (sx, sy) (major-axis component 1: one pixel per step) to the first valid
 * pixel, at most max steps, stopping at the border. Doubling: probe at 1, 2, 4, 8... steps instead (000 §5.2's
 * exponentially increasing step size: a conservative border distance in log2(max) probes). */
static hit scan(const warp_holes_ctx *c, int x, int y, double sx, double sy, int max, bool doubling, long *steps)
{
    hit r = {false, 0, 0, 0, 0};
    double px = x + 0.5, py = y + 0.5;
    for (int k = 1; k <= max; k = doubling ? 2 * k : k + 1) {
        int ix = (int)floor(px + k * sx), iy = (int)floor(py + k * sy);
        if (ix < 0 || iy < 0 || ix >= c->w || iy >= c->h) break;
        (*steps)++;
        if (valid_at(c, ix, iy)) {
            r.found = true, r.x = ix, r.y = iy, r.dist = k;
            r.inv = c->lvl[0][(size_t)iy * (size_t)c->w + (size_t)ix].inv;
            return r;
        }
    }
    return r;
}

/* Both ways along the epipolar line: fwd = the way near pixels move (the occluder's side of a disocclusion),
 * back = the other way (the uncovered background's side). */
static void scan_epipolar(const warp_holes_ctx *c, int x, int y, bool doubling, hit *fwd, hit *back, long *steps)
{
    double dx, dy;
    direction_h(c->ex, c->ey, c->ew, x + 0.5, y + 0.5, &dx, &dy);
    double m = fmax(fabs(dx), fabs(dy));
    dx /= m, dy /= m;
    *fwd = scan(c, x, y, dx, dy, c->p.max_search, doubling, steps);
    *back = scan(c, x, y, -dx, -dy, c->p.max_search, doubling, steps);
}

static bool same_surface(const warp_holes_ctx *c, float a, float b)
{
    return fabsf(a - b) <= c->p.depth_tolerance * fmaxf(a, b) + 1e-6f;
}

/* 002 §3.3: of the two sides, the farther; one surface on both sides -> the nearer in distance; a tie -> back. */
static const hit *pick_far(const warp_holes_ctx *c, const hit *fwd, const hit *back)
{
    if (!fwd->found) return back->found ? back : NULL;
    if (!back->found) return fwd;
    if (same_surface(c, fwd->inv, back->inv)) return fwd->dist < back->dist ? fwd : back;
    return fwd->inv < back->inv ? fwd : back;
}

/* The valid pixels bounding (x, y) on its row and column: [0] left, [1] right, [2] up, [3] down; dist 0 = none. */
static void bounds(const warp_holes_ctx *c, int x, int y, int bx[4], int by[4], int dist[4])
{
    size_t i = (size_t)y * (size_t)c->w + (size_t)x;
    int v[4] = {c->row_prev[i], c->row_next[i], c->col_prev[i], c->col_next[i]};
    for (int k = 0; k < 4; k++) {
        bx[k] = k < 2 ? v[k] : x;
        by[k] = k < 2 ? y : v[k];
        dist[k] = v[k] < 0 ? 0 : abs(k < 2 ? v[k] - x : v[k] - y);
    }
}

/* Fallback when a line search finds nothing: the nearest valid pixel on the row or the column, else on the nearest
 * row that has any. Constant time (tables of prepare). */
static bool nearest_axis(const warp_holes_ctx *c, int x, int y, int *ox, int *oy)
{
    int bx[4], by[4], dist[4], best = -1;
    bounds(c, x, y, bx, by, dist);
    for (int k = 0; k < 4; k++)
        if (dist[k] && (best < 0 || dist[k] < dist[best])) best = k;
    if (best >= 0) {
        *ox = bx[best], *oy = by[best];
        return true;
    }
    int r = c->near_row[y];
    if (r < 0) return false; /* no valid pixel anywhere */
    size_t i = (size_t)r * (size_t)c->w + (size_t)x;
    int a = c->row_prev[i], b = c->row_next[i];
    *ox = a < 0 ? b : (b < 0 ? a : (x - a <= b - x ? a : b));
    *oy = r;
    return true;
}

static inline warp_rgba8 c0_at(const warp_holes_ctx *c, int x, int y)
{
    return c->c0[(size_t)y * (size_t)c->w + (size_t)x];
}

static inline uint8_t to_u8(float v)
{
    v = v < 0 ? 0 : (v > 255 ? 255 : v);
    return (uint8_t)(v + 0.5f);
}

static warp_rgba8 from_acc(const float a[4])
{
    warp_rgba8 r = {to_u8(a[0]), to_u8(a[1]), to_u8(a[2]), to_u8(a[3])};
    return r;
}

/* Rubber sheet: interpolation between the bounding valid pixels of the row and of the column. */
static bool rubber(const warp_holes_ctx *c, int x, int y, warp_rgba8 *out, long *steps)
{
    int bx[4], by[4], dist[4];
    bounds(c, x, y, bx, by, dist);
    for (int k = 0; k < 4; k++)
        if (dist[k] > c->p.max_search) dist[k] = 0;
    *steps += 4; /* table lookups, not scans */
    float acc[4] = {0, 0, 0, 0}, wsum = 0;
    for (int axis = 0; axis < 2; axis++) {
        int a = 2 * axis, b = a + 1;
        float span, col[4];
        if (dist[a] && dist[b]) {
            warp_rgba8 ca = c0_at(c, bx[a], by[a]), cb = c0_at(c, bx[b], by[b]);
            float ta = (float)dist[b] / (float)(dist[a] + dist[b]); /* weight of side a: larger when a is nearer */
            col[0] = ta * ca.r + (1 - ta) * cb.r, col[1] = ta * ca.g + (1 - ta) * cb.g;
            col[2] = ta * ca.b + (1 - ta) * cb.b, col[3] = ta * ca.a + (1 - ta) * cb.a;
            span = (float)(dist[a] + dist[b]);
        } else if (dist[a] || dist[b]) { /* the hole reaches the border: the sheet is held at one end only */
            int s = dist[a] ? a : b;
            warp_rgba8 cs = c0_at(c, bx[s], by[s]);
            col[0] = cs.r, col[1] = cs.g, col[2] = cs.b, col[3] = cs.a;
            span = 2.0f * (float)dist[s];
        } else {
            continue;
        }
        for (int ch = 0; ch < 4; ch++) acc[ch] += col[ch] / span;
        wsum += 1.0f / span;
    }
    if (!(wsum > 0)) return false;
    for (int ch = 0; ch < 4; ch++) acc[ch] /= wsum;
    *out = from_acc(acc);
    return true;
}

/* 000 §5.2, push: the level follows the distance to the background border; within it a bilinear read of the cells
 * that are not nearer than midway between the background and the occluder (the occluder's own colour stays out). */
static bool lowpass(const warp_holes_ctx *c, int x, int y, warp_rgba8 *out, bool *fell_back, long *steps)
{
    hit fwd, back;
    scan_epipolar(c, x, y, true, &fwd, &back, steps);
    const hit *bg = pick_far(c, &fwd, &back);
    const hit *fg = bg == &fwd ? &back : &fwd;
    float limit = INFINITY;
    int dist = c->w > c->h ? c->w : c->h;
    if (bg) {
        dist = bg->dist;
        if (c->p.depth_aware && fg->found && !same_surface(c, fg->inv, bg->inv)) limit = 0.5f * (fg->inv + bg->inv);
    } else {
        *fell_back = true;
    }
    int level = 1;
    while ((1 << level) < dist) level++;
    level += c->p.level_bias;
    if (level < 1) level = 1;
    if (level > c->levels - 1) level = c->levels - 1;
    for (int l = level; l < c->levels; l++) {
        const warp_holes_cell *cells = c->lvl[l];
        int lw = c->lw[l], lh = c->lh[l];
        double s = 1.0 / (double)(1 << l);
        double u = (x + 0.5) * s - 0.5, v = (y + 0.5) * s - 0.5;
        int i0 = (int)floor(u), j0 = (int)floor(v);
        double fu = u - i0, fv = v - j0;
        float acc[4] = {0, 0, 0, 0}, wsum = 0;
        for (int b = 0; b < 2; b++)
            for (int a = 0; a < 2; a++) {
                int i = i0 + a, j = j0 + b;
                if (i < 0 || j < 0 || i >= lw || j >= lh) continue;
                const warp_holes_cell *cell = &cells[(size_t)j * (size_t)lw + (size_t)i];
                if (!(cell->wt > 0) || cell->inv > limit) continue;
                float wk = (float)((a ? fu : 1 - fu) * (b ? fv : 1 - fv)) * cell->wt;
                for (int ch = 0; ch < 4; ch++) acc[ch] += wk * cell->c[ch];
                wsum += wk;
            }
        if (wsum > 1e-6f) {
            for (int ch = 0; ch < 4; ch++) acc[ch] /= wsum;
            *out = from_acc(acc);
            return true;
        }
    }
    if (bg) { /* no level has background here: the border pixel itself (an epipolar stretch) */
        *out = c0_at(c, bg->x, bg->y);
        return true;
    }
    return false;
}

void warp_holes_fill_rows(const warp_holes_ctx *c, warp_image_rgba8 *dst, warp_image_u8 *mask, int y0, int y1,
                          warp_holes_stats *st)
{
    if (c->levels < 1) return; /* not prepared: no snapshot to fill from */
    if (y0 < 0) y0 = 0;
    if (y1 > c->h) y1 = c->h;
    long holes = 0, steps = 0, fallbacks = 0;
    for (int y = y0; y < y1; y++)
        for (int x = 0; x < c->w; x++) {
            if (valid_at(c, x, y)) continue;
            holes++;
            warp_rgba8 col = c->p.empty;
            bool done = false, fell_back = false;
            hit fwd, back;
            const hit *h = NULL;
            switch (c->p.method) {
            case WARP_HOLES_EPIPOLAR_FAR:
                scan_epipolar(c, x, y, false, &fwd, &back, &steps);
                h = pick_far(c, &fwd, &back);
                break;
            case WARP_HOLES_STRETCH_NEAREST:
                scan_epipolar(c, x, y, false, &fwd, &back, &steps);
                h = !fwd.found ? (back.found ? &back : NULL)
                    : !back.found ? &fwd
                    : (fwd.dist < back.dist ? &fwd : &back);
                break;
            case WARP_HOLES_STRETCH_BACKGROUND:
                scan_epipolar(c, x, y, false, &fwd, &back, &steps);
                h = back.found ? &back : (fwd.found ? &fwd : NULL);
                break;
            case WARP_HOLES_RUBBER_SHEET:
                done = rubber(c, x, y, &col, &steps);
                break;
            case WARP_HOLES_LOWPASS:
                done = lowpass(c, x, y, &col, &fell_back, &steps);
                break;
            }
            if (h) {
                col = c0_at(c, h->x, h->y);
                done = true;
            }
            if (!done) {
                int fx = 0, fy = 0;
                fell_back = true;
                if (nearest_axis(c, x, y, &fx, &fy)) col = c0_at(c, fx, fy);
            }
            fallbacks += fell_back;
            WARP_AT(dst, x, y) = col;
            WARP_AT(mask, x, y) |= WARP_MASK_FILLED;
        }
    if (st) {
        st->holes += holes;
        st->filled += holes;
        st->search_steps += steps;
        st->fallbacks += fallbacks;
    }
}

const char *warp_holes_fill(warp_holes_ctx *c, warp_image_rgba8 *dst, warp_image_u8 *mask,
                            const warp_image_f32 *inv_depth, const warp_epipole *e, const warp_holes_params *p,
                            warp_holes_stats *st)
{
    if (st) memset(st, 0, sizeof *st);
    const char *err = warp_holes_prepare(c, dst, mask, inv_depth, e, p, st);
    if (err) return err;
    warp_holes_fill_rows(c, dst, mask, 0, c->h, st);
    return NULL;
}

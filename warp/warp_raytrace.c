/* SPDX-License-Identifier: MIT */
/* warp_raytrace: the height-map raytrace warp of 003 §3.5: every target pixel casts a ray through the source
 * frame's depth treated as a continuous height map; edge fills of 003 §4.4 and a sub-pixel refinement of the hit. */
#include "warp/warp_raytrace.h"

#include <math.h>
#include <string.h>

#include "warp/warp_v4.h"

/* Geometry of one ray, in the source image. A point of the target ray X = o + l*dir has homogeneous source
 * position a + l*b (a = K o, b = K dir), so its inverse depth is D = 1/(aw + l*bw) and its pixel position is
 *     S(D) = p_inf + D * e,   p_inf = b.xy / bw,   e = a.xy - aw * p_inf:
 * affine in D. The search therefore walks a straight screen-space line with the ray's inverse depth changing
 * linearly along it, exactly the linear search of 003 eq. 10 (which is written in post-projective depth). */

warp_raytrace_params warp_raytrace_default_params(void)
{
    warp_raytrace_params p = {512, 4, WARP_EDGE_FILL_FAR, 0.1f};
    return p;
}

const char *warp_raytrace_prepare(warp_raytrace_setup *s, const warp_view *src, const warp_camera *dst_cam,
                                  warp_pose dst_pose, const warp_raytrace_params *p)
{
    const char *bad = warp_poses_check(src->pose, dst_pose);
    if (bad) return bad;
    if (!src->inv_depth) return "raytrace warp needs a depth plane";
    if (!src->color) return "raytrace warp needs a colour plane";
    if (src->inv_depth->w != src->color->w || src->inv_depth->h != src->color->h)
        return "depth and colour planes differ in size";
    if (!(src->inv_depth_max >= src->inv_depth_min) || !(src->inv_depth_min >= 0) || !isfinite(src->inv_depth_max))
        return "inverse depth range is not valid";
    if (p->max_steps < 1) return "raytrace step budget must be at least 1";
    s->src = src;
    s->p = *p;
    /* Relative pose of the target eye in the source eye's frame; subtracting positions first keeps precision for
     * heads far from the world origin. */
    warp_pose rel = warp_pose_relative(src->pose, dst_pose);
    s->h = warp_rotation_homography(&src->cam, dst_cam, rel.q);
    warp_mat3 k = warp_camera_K(&src->cam);
    warp_vec3 a = warp_mat3_apply(&k, rel.p);
    s->ax = a.x;
    s->ay = a.y;
    s->aw = a.z;
    s->dst_w = dst_cam->width;
    s->dst_h = dst_cam->height;
    s->blockmax = NULL;
    s->block = 0;
    return NULL;
}

void warp_raytrace_blockmax(const warp_image_f32 *inv, warp_image_f32 *bmax, int block)
{
    int bw = (inv->w + block - 1) / block, bh = (inv->h + block - 1) / block;
    for (int by = 0; by < bh; by++)
        for (int bx = 0; bx < bw; bx++) {
            float m = 0;
            int x1 = (bx + 1) * block < inv->w ? (bx + 1) * block : inv->w;
            int y1 = (by + 1) * block < inv->h ? (by + 1) * block : inv->h;
            if (block == 8 && x1 - bx * block == 8) {
                /* a whole row of the block is two vectors; v > m ? v : m per lane skips a NaN as the loop below */
                warp_v4f vm = {0, 0, 0, 0};
                for (int y = by * block; y < y1; y++) {
                    warp_v4f a, b;
                    memcpy(&a, &WARP_AT(inv, bx * block, y), sizeof a);
                    memcpy(&b, &WARP_AT(inv, bx * block + 4, y), sizeof b);
                    vm = warp_v4f_select(a > vm, a, vm);
                    vm = warp_v4f_select(b > vm, b, vm);
                }
                for (int k = 0; k < 4; k++) m = vm[k] > m ? vm[k] : m;
            } else {
                for (int y = by * block; y < y1; y++)
                    for (int x = bx * block; x < x1; x++)
                        if (WARP_AT(inv, x, y) > m) m = WARP_AT(inv, x, y);
            }
            WARP_AT(bmax, bx, by) = m;
        }
}

void warp_raytrace_use_blockmax(warp_raytrace_setup *s, const warp_image_f32 *bmax, int block)
{
    s->blockmax = bmax && block > 0 ? bmax : NULL;
    s->block = bmax ? block : 0;
}

/* Largest inverse depth any bilinear sample between source positions p and q can return: the blocks around the
 * segment's bounding box, widened by the bilinear footprint (and the clamping at the borders). */
static float region_max(const warp_raytrace_setup *s, double px, double py, double qx, double qy)
{
    const warp_image_f32 *b = s->blockmax;
    const int B = s->block, w = s->src->inv_depth->w, h = s->src->inv_depth->h;
    double x0 = px < qx ? px : qx, x1 = px < qx ? qx : px, y0 = py < qy ? py : qy, y1 = py < qy ? qy : py;
    /* texels read: floor(x - 0.5) .. floor(x - 0.5) + 1, clamped to the image */
    int tx0 = (int)floor(x0 - 0.5), tx1 = (int)floor(x1 - 0.5) + 1, ty0 = (int)floor(y0 - 0.5), ty1 = (int)floor(y1 - 0.5) + 1;
    tx0 = tx0 < 0 ? 0 : (tx0 >= w ? w - 1 : tx0);
    tx1 = tx1 < 0 ? 0 : (tx1 >= w ? w - 1 : tx1);
    ty0 = ty0 < 0 ? 0 : (ty0 >= h ? h - 1 : ty0);
    ty1 = ty1 < 0 ? 0 : (ty1 >= h ? h - 1 : ty1);
    float m = 0;
    for (int by = ty0 / B; by <= ty1 / B; by++)
        for (int bx = tx0 / B; bx <= tx1 / B; bx++)
            if (WARP_AT(b, bx, by) > m) m = WARP_AT(b, bx, by);
    return m;
}

/* The 2 x 2 texels a bilinear sample of the height map at continuous position (x, y) reads, clamped to the image
 * like the colour fringe fill (a NaN position to 0), and its weights: inv_at's and cell_at's one fetch. */
typedef struct {
    float d00, d10, d01, d11; /* texels (x0, y0), (x1, y0), (x0, y1), (x1, y1) */
    float ax, ay;             /* the weights of x1 and y1 */
    const float *r0, *r1;     /* rows y0 and y1 */
    int x0, x1;
} cell_texels;

static inline cell_texels cell_fetch(const warp_image_f32 *d, float x, float y)
{
    cell_texels t;
    float fx = x - 0.5f, fy = y - 0.5f;
    fx = fx > 0 ? (fx < (float)(d->w - 1) ? fx : (float)(d->w - 1)) : 0;
    fy = fy > 0 ? (fy < (float)(d->h - 1) ? fy : (float)(d->h - 1)) : 0;
    t.x0 = (int)fx;
    const int y0 = (int)fy;
    t.x1 = t.x0 + (t.x0 + 1 < d->w);
    const int y1 = y0 + (y0 + 1 < d->h);
    t.ax = fx - (float)t.x0, t.ay = fy - (float)y0;
    t.r0 = &WARP_AT(d, 0, y0), t.r1 = &WARP_AT(d, 0, y1);
    t.d00 = t.r0[t.x0], t.d10 = t.r0[t.x1], t.d01 = t.r1[t.x0], t.d11 = t.r1[t.x1];
    return t;
}

/* Inverse depth of the height map at continuous position (x, y): bilinear on a surface, but in a cell whose four
 * texels span a depth edge (a relative jump over `jump`) the nearest texel's. The map then has a vertical wall
 * halfway between a near and a far texel instead of a slope one pixel wide, which rays grazing a near object's
 * silhouette passed over: each texel keeps its own half pixel. */
static inline float inv_at(const warp_image_f32 *d, float x, float y, float jump)
{
    const cell_texels t = cell_fetch(d, x, y);
    /* ternaries, not fmaxf: they compile to maxss/minss, where fmaxf's NaN rules cost a call per sample */
    float m0 = t.d00 > t.d10 ? t.d00 : t.d10, m1 = t.d01 > t.d11 ? t.d01 : t.d11;
    float n0 = t.d00 < t.d10 ? t.d00 : t.d10, n1 = t.d01 < t.d11 ? t.d01 : t.d11;
    float mx = m0 > m1 ? m0 : m1, mn = n0 < n1 ? n0 : n1;
    if (mx - mn > jump * mx) return (t.ay < 0.5f ? t.r0 : t.r1)[t.ax < 0.5f ? t.x0 : t.x1];
    float top = t.d00 + (t.d10 - t.d00) * t.ax;
    float bot = t.d01 + (t.d11 - t.d01) * t.ax;
    return top + (bot - top) * t.ay;
}

/* Nearest and farthest of the four texels a bilinear sample at (x, y) reads, into *near_d and *far_d. */
static inline void cell_range(const warp_image_f32 *d, float x, float y, float *near_d, float *far_d)
{
    int x0 = (int)floorf(x - 0.5f), y0 = (int)floorf(y - 0.5f);
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 2; i++) {
            int xi = x0 + i < 0 ? 0 : (x0 + i >= d->w ? d->w - 1 : x0 + i);
            int yj = y0 + j < 0 ? 0 : (y0 + j >= d->h ? d->h - 1 : y0 + j);
            float v = WARP_AT(d, xi, yj);
            *near_d = v > *near_d ? v : *near_d;
            *far_d = v < *far_d ? v : *far_d;
        }
}

/* Inverse depth of the texel whose pixel contains (x, y) (clamped), and its centre into (*cx, *cy). */
static inline float texel_at(const warp_image_f32 *d, double x, double y, float *cx, float *cy)
{
    int tx = (int)floor(x), ty = (int)floor(y);
    tx = tx < 0 ? 0 : (tx >= d->w ? d->w - 1 : tx);
    ty = ty < 0 ? 0 : (ty >= d->h ? d->h - 1 : ty);
    *cx = (float)tx + 0.5f;
    *cy = (float)ty + 0.5f;
    return WARP_AT(d, tx, ty);
}

/* The farthest of the four texels around (x, y), into (*tx, *ty): the far side of an edge without near-side
 * bleed. */
static void far_texel_at(const warp_view *v, float x, float y, int *tx, int *ty)
{
    const warp_image_f32 *d = v->inv_depth;
    int x0 = (int)floorf(x - 0.5f), y0 = (int)floorf(y - 0.5f);
    int bx = 0, by = 0;
    float best = INFINITY;
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 2; i++) {
            int xi = x0 + i, yj = y0 + j;
            xi = xi < 0 ? 0 : (xi >= d->w ? d->w - 1 : xi);
            yj = yj < 0 ? 0 : (yj >= d->h ? d->h - 1 : yj);
            float dv = WARP_AT(d, xi, yj);
            if (dv < best) {
                best = dv;
                bx = xi;
                by = yj;
            }
        }
    *tx = bx;
    *ty = by;
}

/* Clips the D interval [*lo, *hi] to where p + D*e lies inside [0, size]. Returns false when empty. */
static bool clip_axis(double p, double e, double size, double *lo, double *hi)
{
    if (fabs(e) < 1e-12) return p >= 0 && p <= size;
    double d0 = (0 - p) / e, d1 = (size - p) / e;
    if (d0 > d1) {
        double t = d0;
        d0 = d1;
        d1 = t;
    }
    if (d0 > *lo) *lo = d0;
    if (d1 < *hi) *hi = d1;
    return *lo <= *hi;
}

/* What one call traces with, hoisted out of the per-ray code (the output stores may alias the setup). */
typedef struct {
    const warp_raytrace_setup *s;
    const warp_image_f32 *dimg;
    double sw, sh, dmin, dmax;
    int max_steps;
    float jump;
    int chunk;
} ray_ctx;

static ray_ctx ray_ctx_make(const warp_raytrace_setup *s)
{
    const warp_view *v = s->src;
    ray_ctx c = {s, v->inv_depth, v->color->w, v->color->h, v->inv_depth_min, v->inv_depth_max, s->p.max_steps,
                 s->p.edge_jump, s->blockmax ? s->block : 0};
    return c;
}

/* The homogeneous source position (*bx, *by, *bw) of the point at infinity of the ray through continuous target
 * position (tx, ty): what warp_raytrace_rows reaches by stepping along a row (up to rounding). */
static inline void ray_at_infinity(const warp_raytrace_setup *s, double tx, double ty, double *bx, double *by,
                                   double *bw)
{
    *bx = s->h.m[0][0] * tx + s->h.m[0][1] * ty + s->h.m[0][2];
    *by = s->h.m[1][0] * tx + s->h.m[1][1] * ty + s->h.m[1][2];
    *bw = s->h.m[2][0] * tx + s->h.m[2][1] * ty + s->h.m[2][2];
}

/* One ray's line in the source (S(D) = pi + D * e, the derivation at the top) and the search's interval and step
 * grid on it: every search over a ray (trace_ray and the bracketed ones) takes these, so that they sample the same
 * depths. */
typedef struct {
    double pix, piy, ex, ey;
    double lo, hi;     /* the interval in inverse depth, clipped to the image (lo: far end, hi: near end) */
    bool near_clipped; /* hi was cut at the image border (the ray enters it below the near limit) */
    double epx;        /* source pixels of parallax per unit of inverse depth: |e| */
    double len;        /* the interval's length in source pixels */
    int n;             /* steps: one per source pixel (003 §3.5: n_d is the pixel count), within the budget */
    double dd;         /* inverse depth per step */
} ray_span;

enum {
    RAY_SPAN_OK = 0,
    RAY_SPAN_BEYOND_90 = 1, /* no point at infinity in the source image: g unset */
    RAY_SPAN_OUTSIDE = 2,   /* no part of the interval inside the image: lo and hi as far as the clip got (the fringe
                             * fill samples there), len, n and dd unset */
};

/* Fills g for the ray whose point at infinity has homogeneous source position (bx, by, bw). Returns RAY_SPAN_*. */
static inline __attribute__((always_inline)) int ray_span_make(const ray_ctx *c, double bx, double by, double bw,
                                                                ray_span *g)
{
    const warp_raytrace_setup *s = c->s;
    /* A ray at or beyond 90 degrees from the source view axis has no point at infinity in the source
     * image; with centimetre head translations such rays see nothing the source saw: fringe. */
    if (!(bw > 1e-9 * (fabs(bx) + fabs(by) + fabs(bw)))) return RAY_SPAN_BEYOND_90;
    g->pix = bx / bw;
    g->piy = by / bw;
    g->ex = s->ax - s->aw * g->pix;
    g->ey = s->ay - s->aw * g->piy;
    /* Search interval in inverse depth: the scene's depth range, cut to the part of the ray in front of
     * the target eye (D <= 1/aw when the eye is in front of the source eye's plane) ... */
    g->hi = c->dmax;
    g->lo = c->dmin;
    if (s->aw > 0 && 1.0 / s->aw < g->hi) g->hi = 1.0 / s->aw;
    const double hi0 = g->hi;
    /* ... and to the part that projects inside the source image, where the height map is known. */
    if (!(g->lo <= g->hi && clip_axis(g->pix, g->ex, c->sw, &g->lo, &g->hi) &&
          clip_axis(g->piy, g->ey, c->sh, &g->lo, &g->hi)))
        return RAY_SPAN_OUTSIDE;
    g->near_clipped = g->hi < hi0;
    /* One step per source pixel along the segment (003 §3.5: n_d is the pixel count), within budget. */
    g->epx = sqrt(g->ex * g->ex + g->ey * g->ey);
    g->len = fabs(g->hi - g->lo) * g->epx;
    g->n = (int)ceil(g->len);
    if (g->n < 1) g->n = 1;
    if (g->n > c->max_steps) g->n = c->max_steps;
    g->dd = (g->hi - g->lo) / g->n;
    return 0;
}

/* The hit between the last search sample in front of the surface (inverse depth da, height over the ray fa < 0)
 * and the first one behind it (db, fb >= 0): regula falsi (Illinois), so that it lands between samples, not on
 * the step grid. */
static inline __attribute__((always_inline)) double refine_hit(const ray_ctx *c, double pix, double piy, double ex,
                                                               double ey, double da, double fa, double db, double fb)
{
    const warp_raytrace_setup *s = c->s;
    int side = 0;
    /* Refining a bracket that already spans under 1/64 pixel cannot move the hit visibly: most rays of a small
     * head translation stop here after one step. */
    const double epx = sqrt(ex * ex + ey * ey);
    for (int it = 0; it < s->p.refine_iters && fabs(db - da) * epx > 1.0 / 64; it++) {
        double dm = da + (db - da) * (-fa) / (fb - fa);
        float sm = inv_at(c->dimg, (float)(pix + dm * ex), (float)(piy + dm * ey), c->jump);
        double fm = sm - dm;
        if (fm < 0) {
            da = dm;
            fa = fm;
            if (side == -1) fb *= 0.5;
            side = -1;
        } else {
            db = dm;
            fb = fm;
            if (side == 1) fa *= 0.5;
            side = 1;
        }
    }
    /* Without refinement the hit is the first sample behind the surface, as in 003 eq. 10. */
    if (s->p.refine_iters > 0) return fb - fa != 0 ? da + (db - da) * (-fa) / (fb - fa) : db;
    return db;
}

/* The source position (*hx, *hy) of the ray's hit at inverse depth da (dfront: the last search sample in front of
 * the surface; len: the search's length in source pixels), and its flag after the edge rules. */
static inline __attribute__((always_inline)) uint8_t edge_rules(const ray_ctx *c, double pix, double piy, double ex,
                                                                double ey, double len, double da, double dfront,
                                                                uint8_t flag, float *hx, float *hy)
{
    const warp_image_f32 *dimg = c->dimg;
    const float jump = c->jump;
    *hx = (float)(pix + da * ex);
    *hy = (float)(piy + da * ey);
    /* Edge fills (003 §4.4), decided on texels rather than on the two search samples bracketing the hit, which
     * fall anywhere on a wall (so neighbouring rays flipped between the sides: comb-like streaks). Where the hit's
     * cell or that of the last sample in front of it spans a depth edge, the ray belongs to the near surface when,
     * at that surface's depth, it passes through a near texel's own pixel: the near side keeps exactly its half
     * pixel, unblended. Else it sees the far surface: its own texel where the hit's pixel is one, otherwise it is a
     * disocclusion. Without translation (the ray is one source point) there are no disocclusions: bilinear. */
    if (!flag && len * 64 > 1) {
        float near_d = 0, far_d = INFINITY, cx, cy;
        cell_range(dimg, *hx, *hy, &near_d, &far_d);
        cell_range(dimg, (float)(pix + dfront * ex), (float)(piy + dfront * ey), &near_d, &far_d);
        if (near_d - far_d > jump * near_d) {
            const float near_lo = near_d * (1 - jump);
            if (texel_at(dimg, pix + near_d * ex, piy + near_d * ey, &cx, &cy) < near_lo &&
                texel_at(dimg, *hx, *hy, &cx, &cy) >= near_lo)
                flag = WARP_MASK_EDGE;
            else {
                *hx = cx;
                *hy = cy;
            }
        }
    }
    return flag;
}

/* Traces the ray whose point at infinity has homogeneous source position (bx, by, bw): returns its flag (0,
 * WARP_MASK_FRINGE or WARP_MASK_EDGE) and the source position (*hx, *hy) its colour comes from, bilinearly,
 * except for an edge with the far-side fill, which takes far_texel_at(*hx, *hy); adds the steps and samples taken
 * to *steps and *samples. Always inlined: warp_raytrace_rows keeps the speed of the loop this was cut from, and
 * warp_raytrace_point traces exactly the same way. */
static inline __attribute__((always_inline)) uint8_t trace_ray(const ray_ctx *c, double bx, double by, double bw,
                                                               float *hx, float *hy, double *dhit, long *steps,
                                                               long *samples)
{
    const warp_raytrace_setup *s = c->s;
    const warp_image_f32 *dimg = c->dimg;
    const float jump = c->jump;
    const int chunk = c->chunk;
    uint8_t flag = 0;
    ray_span g;
    const int span = ray_span_make(c, bx, by, bw, &g);
    if (span != RAY_SPAN_OK) {
        /* with centimetre head translations a ray beyond 90 degrees sees nothing the source saw: fringe */
        if (span == RAY_SPAN_BEYOND_90) {
            *hx = bx > 0 ? (float)c->sw : 0.f;
            *hy = by > 0 ? (float)c->sh : 0.f;
            *dhit = 0;
            return WARP_MASK_FRINGE;
        }
        /* The clip moved lo to where the ray would enter the image, which may lie nearer than anything in
         * the frame; the fringe fill samples the ray within the frame's depth range (for an all-sky
         * frame exactly the rotation reprojection's clamped sample). */
        double d = g.lo < c->dmin ? c->dmin : (g.lo > c->dmax ? c->dmax : g.lo);
        *dhit = d;
        *hx = (float)(g.pix + d * g.ex);
        *hy = (float)(g.piy + d * g.ey);
        return WARP_MASK_FRINGE;
    }
    const double pix = g.pix, piy = g.piy, ex = g.ex, ey = g.ey, hi = g.hi, lo = g.lo, len = g.len, dd = g.dd;
    const bool near_clipped = g.near_clipped;
    const int n = g.n;

    double da = hi, fa;
    float sa = inv_at(dimg, (float)(pix + da * ex), (float)(piy + da * ey), jump);
    fa = sa - da;
    double db = da, fb = fa;
    double dfront = da; /* the last search sample in front of the surface */
    float sb = sa;
    int k = 0;
    if (fa >= 0) {
        /* Hit at the very first sample. If the segment was cut at the image border, the ray entered
         * below the surface: it is hidden by something the source never saw. */
        if (near_clipped) flag = WARP_MASK_FRINGE;
    } else {
        int plain_until = 0;
        for (k = 1; k <= n; k++) {
            /* A run of `chunk` steps (about a block long) none of which can hit: the nearest surface in
             * their region is farther than the ray at the run's far end. Jump to its last step, whose sample
             * the search would have kept as the bracket's near side. A run that may hit is walked step by step
             * before the next test (testing at every step near a surface cost more than the steps). */
            if (chunk && k >= plain_until && k + chunk - 1 < n) {
                double dlast = hi - dd * (k + chunk - 1);
                double d0 = hi - dd * k;
                if (region_max(s, pix + d0 * ex, piy + d0 * ey, pix + dlast * ex, piy + dlast * ey) < dlast) {
                    k += chunk - 1;
                    da = dlast;
                    sa = inv_at(dimg, (float)(pix + da * ex), (float)(piy + da * ey), jump);
                    fa = sa - da;
                    (*samples)++;
                    continue;
                }
                plain_until = k + chunk;
            }
            db = hi - dd * k;
            if (k == n) db = lo;
            sb = inv_at(dimg, (float)(pix + db * ex), (float)(piy + db * ey), jump);
            (*samples)++;
            fb = sb - db;
            if (fb >= 0) break;
            da = db;
            fa = fb;
            sa = sb;
        }
        *steps += k < n ? k : n;
        if (k > n) {
            /* Not even the farthest depth was reached inside the image: the ray leaves the source. */
            flag = WARP_MASK_FRINGE;
            da = db;
        } else {
            dfront = da;
            da = refine_hit(c, pix, piy, ex, ey, da, fa, db, fb);
        }
    }
    *dhit = da;
    return edge_rules(c, pix, piy, ex, ey, len, da, dfront, flag, hx, hy);
}

void warp_raytrace_rows(const warp_raytrace_setup *s, warp_image_rgba8 *dst, warp_image_u8 *mask, int y0, int y1,
                        warp_raytrace_stats *st)
{
    const warp_view *v = s->src;
    const ray_ctx c = ray_ctx_make(s);
    long steps_total = 0, edges = 0, fringes = 0, samples = 0;

    for (int y = y0; y < y1; y++) {
        double py = y + 0.5;
        double bx = s->h.m[0][0] * 0.5 + s->h.m[0][1] * py + s->h.m[0][2];
        double by = s->h.m[1][0] * 0.5 + s->h.m[1][1] * py + s->h.m[1][2];
        double bw = s->h.m[2][0] * 0.5 + s->h.m[2][1] * py + s->h.m[2][2];
        warp_rgba8 *out = &WARP_AT(dst, 0, y);
        uint8_t *m = mask ? &WARP_AT(mask, 0, y) : NULL;
        for (int x = 0; x < dst->w; x++, bx += s->h.m[0][0], by += s->h.m[1][0], bw += s->h.m[2][0]) {
            float hx, hy;
            double dhit;
            uint8_t flag = trace_ray(&c, bx, by, bw, &hx, &hy, &dhit, &steps_total, &samples);
            if (flag == WARP_MASK_EDGE && s->p.edge_fill == WARP_EDGE_FILL_FAR) {
                int tx, ty;
                far_texel_at(v, hx, hy, &tx, &ty);
                out[x] = WARP_AT(v->color, tx, ty);
            } else {
                out[x] = warp_sample_bilinear(v->color, hx, hy);
            }
            if (m) m[x] = flag;
            edges += flag == WARP_MASK_EDGE;
            fringes += flag == WARP_MASK_FRINGE;
        }
    }
    if (st) {
        st->rays += (long)(y1 - y0) * dst->w;
        st->steps += steps_total;
        st->edge_pixels += edges;
        st->fringe_pixels += fringes;
        st->samples += samples;
    }
}

/* The source position whose bilinear sample is the colour of a ray with flag and hit (hx, hy). */
static void point_source(const warp_raytrace_setup *s, uint8_t flag, float hx, float hy, double *sx, double *sy)
{
    if (flag == WARP_MASK_EDGE && s->p.edge_fill == WARP_EDGE_FILL_FAR) {
        /* the far texel's centre, where a bilinear sample returns exactly that texel */
        int fx, fy;
        far_texel_at(s->src, hx, hy, &fx, &fy);
        *sx = fx + 0.5;
        *sy = fy + 0.5;
    } else {
        *sx = hx;
        *sy = hy;
    }
}

int warp_raytrace_point(const warp_raytrace_setup *s, double tx, double ty, double *sx, double *sy,
                        warp_raytrace_stats *st)
{
    return warp_raytrace_point_depth(s, tx, ty, sx, sy, NULL, st);
}

int warp_raytrace_point_depth(const warp_raytrace_setup *s, double tx, double ty, double *sx, double *sy, double *d,
                              warp_raytrace_stats *st)
{
    const ray_ctx c = ray_ctx_make(s);
    double bx, by, bw;
    ray_at_infinity(s, tx, ty, &bx, &by, &bw);
    long steps = 0, samples = 0;
    float hx, hy;
    double dhit;
    uint8_t flag = trace_ray(&c, bx, by, bw, &hx, &hy, &dhit, &steps, &samples);
    point_source(s, flag, hx, hy, sx, sy);
    if (d) *d = dhit;
    if (st) {
        st->rays++;
        st->steps += steps;
        st->edge_pixels += flag == WARP_MASK_EDGE;
        st->fringe_pixels += flag == WARP_MASK_FRINGE;
        st->samples += samples;
    }
    return flag;
}

/* Height of the height map over the ray at the full search's k-th step (k = n: its far end exactly, as trace_ray
 * takes it); >= 0: at or behind the surface. */
static inline double grid_height(const ray_ctx *c, const ray_span *g, int k, double *dk)
{
    const double dv = k >= g->n ? g->lo : g->hi - g->dd * k;
    *dk = dv;
    return inv_at(c->dimg, (float)(g->pix + dv * g->ex), (float)(g->piy + dv * g->ey), c->jump) - dv;
}

/* The bilinear value and gradient (per source pixel) of the height map at (x, y) (cell_fetch's texels) into *v,
 * *gx, *gy, and the nearest and farthest of the texels into *near_d and *far_d (as cell_range). */
static inline void cell_at(const warp_image_f32 *d, float x, float y, float *v, float *gx, float *gy, float *near_d,
                           float *far_d)
{
    const cell_texels t = cell_fetch(d, x, y);
    const float m0 = t.d00 > t.d10 ? t.d00 : t.d10, m1 = t.d01 > t.d11 ? t.d01 : t.d11;
    const float n0 = t.d00 < t.d10 ? t.d00 : t.d10, n1 = t.d01 < t.d11 ? t.d01 : t.d11;
    const float top = t.d00 + (t.d10 - t.d00) * t.ax, bot = t.d01 + (t.d11 - t.d01) * t.ax;
    *v = top + (bot - top) * t.ay;
    *gx = (t.d10 - t.d00) + ((t.d11 - t.d01) - (t.d10 - t.d00)) * t.ay;
    *gy = bot - top;
    *near_d = m0 > m1 ? m0 : m1;
    *far_d = n0 < n1 ? n0 : n1;
}

/* How close (source pixels along the ray) the hit that guess_on_surface solves for must come to the height map: the
 * full search's refinement stops at a bracket of 1/64 pixel. */
#define GUESS_RESIDUAL_PX (1.0 / 32)

enum { GUESS_UNSURE, GUESS_HIT, GUESS_FRONT };

/* The ray's hit near inverse depth dg where the height map is one smooth surface there (003 §3.5 with no edge
 * rule to apply): one Newton step from dg on the bilinear surface under the ray, accepted when it lands within half
 * a pixel, the surface under it (and up to one search step nearer, where the full search's last sample in front
 * lies) spans no depth edge, and the height map there is within GUESS_RESIDUAL_PX of the ray. Then the full search
 * would find this hit too (if it is the ray's first), to its refinement's precision, and leave it where it is:
 * GUESS_HIT with the hit's inverse depth in *dh. Two or three cell reads, where the search, its refinement and its
 * edge rules take some ten. GUESS_FRONT where the ray passes in front of a smooth surface there by more than
 * margin (inverse depth): it does not meet that surface near dg. */
static int guess_on_surface(const ray_ctx *c, const ray_span *g, double dg, double margin, double *dh, int *taken)
{
    if (!(dg > g->lo && dg < g->hi - 2 * g->dd)) return GUESS_UNSURE;
    float v, gx, gy, nd, fd;
    (*taken)++;
    cell_at(c->dimg, (float)(g->pix + dg * g->ex), (float)(g->piy + dg * g->ey), &v, &gx, &gy, &nd, &fd);
    if (nd - fd > c->jump * nd) return GUESS_UNSURE;
    if (nd < dg - margin) return GUESS_FRONT;
    /* f(D) = h(S(D)) - D falls through 0 at the hit: its slope is h's gradient along e, less 1 */
    const double slope = 1 - ((double)gx * g->ex + (double)gy * g->ey);
    /* a ray grazing the surface (or one leaving it) is the full search's to resolve */
    if (!(slope > 0.25)) return GUESS_UNSURE;
    const double d1 = dg + (v - dg) / slope;
    if (!(fabs(d1 - dg) * g->epx <= 0.5 && d1 > g->lo && d1 < g->hi - 2 * g->dd)) return GUESS_UNSURE;
    float v1, gx1, gy1, nd1, fd1, v2, gx2, gy2, nd2, fd2;
    *taken += 2;
    cell_at(c->dimg, (float)(g->pix + d1 * g->ex), (float)(g->piy + d1 * g->ey), &v1, &gx1, &gy1, &nd1, &fd1);
    const double df = d1 + g->dd;
    cell_at(c->dimg, (float)(g->pix + df * g->ex), (float)(g->piy + df * g->ey), &v2, &gx2, &gy2, &nd2, &fd2);
    const float near_d = nd1 > nd2 ? nd1 : nd2, far_d = fd1 < fd2 ? fd1 : fd2;
    if (near_d - far_d > c->jump * near_d) return GUESS_UNSURE;
    if (!(fabs(v1 - d1) / slope * g->epx <= GUESS_RESIDUAL_PX)) return GUESS_UNSURE;
    *dh = d1;
    return GUESS_HIT;
}

int warp_raytrace_point_guess(const warp_raytrace_setup *s, double tx, double ty, const double *cand, int n_cand,
                              double margin_px, double *sx, double *sy, double *d, int *samples)
{
    const ray_ctx c = ray_ctx_make(s);
    double bx, by, bw;
    ray_at_infinity(s, tx, ty, &bx, &by, &bw);
    ray_span g;
    if (ray_span_make(&c, bx, by, bw, &g) != RAY_SPAN_OK || !(g.epx > 1e-9)) return WARP_GUESS_MISSED;
    const double m = margin_px / g.epx;
    int taken = 0;
    /* The candidates at their word, nearest first, while the ray passes clearly in front of the smooth surfaces at
     * the nearer ones: a ray in front of an edge's near side at its depth and on the far side at the far side's
     * depth did not meet the near side's wall between (a straight silhouette between the two points does not cross
     * the straight line between them; a thin object there is the caller's to exclude, as for the search below). */
    double dh;
    for (int i = 0; i < n_cand; i++) {
        const int r = guess_on_surface(&c, &g, cand[i], m, &dh, &taken);
        if (r == GUESS_FRONT) continue;
        if (r == GUESS_HIT) {
            if (samples) *samples += taken;
            *sx = (float)(g.pix + dh * g.ex);
            *sy = (float)(g.piy + dh * g.ey);
            if (d) *d = dh;
            return 0;
        }
        break;
    }
    /* Samples on the full search's step grid only (step k at hi - k dd), so that the two bracketing the crossing,
     * on which the refinement and the edge rules decide, are the ones the full search would take: the last step
     * known in front of the height map (kf) and, once found, the first behind it (kb). */
    int kf = 0, kb = 0;
    double da = 0, fa = 0, db = 0, fb = 0;
    bool front = false, hit = false;
    for (int i = 0; i < n_cand && !hit; i++) {
        const double kt = floor((g.hi - (cand[i] + m)) / g.dd), kl = ceil((g.hi - (cand[i] - m)) / g.dd);
        /* A bracket reaching the search's near end would also have to repeat its image-border rule: the full ray.
         * One beyond its far end searches nothing. */
        if (!(kt >= 1) || !(kt < g.n)) break;
        const int kbot = kl < g.n ? (int)kl : g.n;
        /* every step of the candidate's bracket (a few: a thin surface may lie between two), from its near end or
         * the previous candidate's far end, where that lies below it */
        for (int k = front && kf >= (int)kt ? kf + 1 : (int)kt; k <= kbot; k++) {
            double dk;
            const double fk = grid_height(&c, &g, k, &dk);
            taken++;
            if (fk < 0) {
                kf = k;
                da = dk;
                fa = fk;
                front = true;
                continue;
            }
            if (!front) {
                /* behind the height map already in front of the nearest surface: something nearer stands in the
                 * ray's way, which only the full search finds */
                if (samples) *samples += taken;
                return WARP_GUESS_BEHIND;
            }
            /* behind: the crossing lies after kf (at this candidate's near end after passing in front of the
             * previous candidate's surface: what lies between them, at a disocclusion the near side's wall) */
            kb = k;
            db = dk;
            fb = fk;
            hit = true;
            break;
        }
    }
    if (!hit) {
        if (samples) *samples += taken;
        return WARP_GUESS_MISSED;
    }
    /* halve the bracket down to one step */
    while (kb - kf > 1) {
        const int km = kf + (kb - kf) / 2;
        double dm;
        const double fm = grid_height(&c, &g, km, &dm);
        taken++;
        if (fm >= 0) {
            kb = km;
            db = dm;
            fb = fm;
        } else {
            kf = km;
            da = dm;
            fa = fm;
        }
    }
    if (samples) *samples += taken;
    const double dfront = da;
    dh = refine_hit(&c, g.pix, g.piy, g.ex, g.ey, da, fa, db, fb);
    float hx, hy;
    const uint8_t flag = edge_rules(&c, g.pix, g.piy, g.ex, g.ey, g.len, dh, dfront, 0, &hx, &hy);
    point_source(s, flag, hx, hy, sx, sy);
    if (d) *d = dh;
    return flag;
}

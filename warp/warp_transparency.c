/* SPDX-License-Identifier: MIT */
/* warp_transparency: A-buffer ray casting (000 §4.2, §5.3). */
#include "warp/warp_transparency.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "warp/warp_srgb.h"

/* Geometry of one ray. The target pixel's ray, at target inverse depth d, has the source homogeneous position
 * H(d) = d * ka + b (ka = K_src * eye, b = K_src * R * (u, v, -1)): source pixel H.xy / H.w, source inverse depth
 * D = d / H.w. Between two such points the source pixel moves on a straight line and D is affine along it (inverse
 * depth is affine in screen space along a ray), so the ray is a 2D segment S(s) = Sa + s (Sb - Sa) with
 * D(s) = Da + s (Db - Da), s in [0, 1], from the target's near plane (s = 0) to the warped opaque surface (s = 1).
 *
 * Colours are 8-bit sRGB; "over" is applied to linear light, as renderers blend (a blend of the encoded values is
 * darker at partial coverage, so un-blending a renderer's image that way leaves opaque values outside 0..255 and
 * the identity warp does not give its input back, issue #21). Codes decode by a table; the result encodes exactly. */
static inline float lin(uint8_t c) { return warp_srgb_to_linear_u8[c]; }

warp_transparency_params warp_transparency_default_params(void)
{
    warp_transparency_params p = {0.99f, 0.02f, 4096};
    return p;
}

bool warp_minmax_alloc(warp_minmax_tree *t, int w, int h)
{
    memset(t, 0, sizeof *t);
    if (w < 1 || h < 1 || w > 65535 || h > 65535) return false;
    t->w = w;
    t->h = h;
    long total = 0;
    int k = 0;
    for (;; k++) {
        t->lw[k] = (w + (1 << k) - 1) >> k;
        t->lh[k] = (h + (1 << k) - 1) >> k;
        t->off[k] = total;
        total += (long)t->lw[k] * t->lh[k];
        if (t->lw[k] == 1 && t->lh[k] == 1) break;
    }
    t->levels = k + 1;
    t->mn = malloc((size_t)total * sizeof *t->mn);
    t->mx = malloc((size_t)total * sizeof *t->mx);
    if (!t->mn || !t->mx) {
        warp_minmax_free(t);
        return false;
    }
    return true;
}

void warp_minmax_free(warp_minmax_tree *t)
{
    free(t->mn);
    free(t->mx);
    memset(t, 0, sizeof *t);
}

long warp_minmax_build(warp_minmax_tree *t, const warp_image_layers *l)
{
    long bad = 0, n = 0;
    /* first step of §4.2: min and max fragment depth per pixel */
    for (int y = 0; y < t->h; y++)
        for (int x = 0; x < t->w; x++) {
            float mn = INFINITY, mx = -INFINITY;
            if (l && x < l->w && y < l->h) {
                size_t pix = (size_t)y * (size_t)l->w + (size_t)x;
                int c = l->count[pix] < l->max_layers ? l->count[pix] : l->max_layers;
                for (int k = 0; k < c; k++) {
                    float z = l->frag[pix * (size_t)l->max_layers + (size_t)k].z;
                    if (!(z > 0) || !isfinite(z)) {
                        bad++;
                        continue;
                    }
                    float d = 1.0f / z;
                    mn = fminf(mn, d);
                    mx = fmaxf(mx, d);
                    n++;
                }
            }
            t->mn[(size_t)y * t->w + x] = mn;
            t->mx[(size_t)y * t->w + x] = mx;
        }
    /* then the parallel reductions, one level at a time */
    for (int k = 1; k < t->levels; k++)
        for (int iy = 0; iy < t->lh[k]; iy++)
            for (int ix = 0; ix < t->lw[k]; ix++) {
                float mn = INFINITY, mx = -INFINITY;
                for (int j = 0; j < 4; j++) {
                    int cx = 2 * ix + (j & 1), cy = 2 * iy + (j >> 1);
                    if (cx >= t->lw[k - 1] || cy >= t->lh[k - 1]) continue;
                    long ci = t->off[k - 1] + (long)cy * t->lw[k - 1] + cx;
                    mn = fminf(mn, t->mn[ci]);
                    mx = fmaxf(mx, t->mx[ci]);
                }
                long i = t->off[k] + (long)iy * t->lw[k] + ix;
                t->mn[i] = mn;
                t->mx[i] = mx;
            }
    t->fragments = n;
    return bad;
}

const char *warp_transparency_prepare(warp_transparency_setup *s, const warp_view *src, const warp_minmax_tree *tree,
                                      const warp_camera *dst_cam, warp_pose dst_pose, const warp_transparency_params *p)
{
    const char *bad = warp_poses_check(src->pose, dst_pose);
    if (bad) return bad;
    if (!src->layers) return "transparency warp needs a layers plane";
    if (tree->w != src->cam.width || tree->h != src->cam.height || src->layers->w != tree->w ||
        src->layers->h != tree->h)
        return "min-max tree, layers and source camera differ in size";
    if (!(p->thickness >= 0) || !(p->opacity_threshold > 0) || p->max_steps < 1)
        return "transparency parameters are not valid";
    memset(s, 0, sizeof *s);
    s->src = src;
    s->tree = tree;
    s->p = *p;
    warp_pose rel = warp_pose_relative(src->pose, dst_pose); /* source_from_target */
    s->rot = warp_quat_to_mat3(rel.q);
    s->k = warp_camera_K(&src->cam);
    s->ka = warp_mat3_apply(&s->k, rel.p);
    s->dst_cam = *dst_cam;
    return NULL;
}

typedef struct {
    float s, d;
    const warp_fragment *f;
} hit;

/* Clips [*s0, *s1] to the s where a + s * b lies in [lo, hi]. */
static inline void clip_lin(double a, double b, double lo, double hi, double *s0, double *s1)
{
    if (b == 0) {
        if (a < lo || a > hi) *s1 = *s0 - 1;
        return;
    }
    double ta = (lo - a) / b, tb = (hi - a) / b;
    if (ta > tb) {
        double t = ta;
        ta = tb;
        tb = t;
    }
    if (ta > *s0) *s0 = ta;
    if (tb < *s1) *s1 = tb;
}

/* Casts one ray; returns the composited colour over `opaque`. */
static warp_rgba8 cast(const warp_transparency_setup *s, double px, double py, double d_far, warp_rgba8 opaque,
                       warp_transparency_stats *st)
{
    const warp_minmax_tree *t = s->tree;
    const warp_image_layers *L = s->src->layers;
    const double th = s->p.thickness;
    const int top = t->levels - 1;
    const double root_lo = t->mn[t->off[top]] * (1 - th), root_hi = t->mx[t->off[top]] * (1 + th);
    if (!(root_hi >= root_lo)) return opaque; /* no fragments at all */
    double u, v;
    warp_camera_pixel_to_tan(&s->dst_cam, px, py, &u, &v);
    warp_vec3 b = warp_mat3_apply(&s->k, warp_mat3_apply(&s->rot, warp_v3(u, v, -1.0)));
    /* target inverse-depth interval [d_far, d_near] where the point is in front of the source camera */
    double d_near = 1.0 / s->dst_cam.near_z, d_lo = d_far > 0 ? d_far : 0, d_hi = d_near;
    const double eps = 1e-9;
    /* H.w(d) = d * ka.z + b.z > eps */
    if (s->ka.z > 0) {
        double dm = (eps - b.z) / s->ka.z;
        if (dm > d_lo) d_lo = dm;
    } else if (s->ka.z < 0) {
        double dm = (eps - b.z) / s->ka.z;
        if (dm < d_hi) d_hi = dm;
    } else if (!(b.z > eps)) {
        return opaque;
    }
    if (!(d_hi > d_lo)) return opaque;
    double wa = d_hi * s->ka.z + b.z, wb = d_lo * s->ka.z + b.z;
    double ax = (d_hi * s->ka.x + b.x) / wa, ay = (d_hi * s->ka.y + b.y) / wa, Da = d_hi / wa;
    double bx = (d_lo * s->ka.x + b.x) / wb, by = (d_lo * s->ka.y + b.y) / wb, Db = d_lo / wb;
    double dx = bx - ax, dy = by - ay, dD = Db - Da;
    /* clip to the image and to the tree's depth range */
    double s0 = 0, s1 = 1;
    clip_lin(ax, dx, 0, t->w, &s0, &s1);
    clip_lin(ay, dy, 0, t->h, &s0, &s1);
    clip_lin(Da, dD, root_lo, root_hi, &s0, &s1);
    if (!(s1 > s0)) return opaque;
    if (st) st->rays++;
    const int stepx = dx > 0 ? 1 : -1, stepy = dy > 0 ? 1 : -1;
    /* node of level k the ray is in at s, with direction-aware rounding on boundaries */
#define CELL(k, P, dd, n) ((int)((dd) < 0 ? ceil((P) / (double)(1 << (k))) - 1 : floor((P) / (double)(1 << (k)))))
    int k = top;
    double sx0 = ax + s0 * dx, sy0 = ay + s0 * dy;
    int ix = CELL(k, sx0, dx, 0), iy = CELL(k, sy0, dy, 0);
    double sc = s0;
    float acc[3] = {0, 0, 0}, trans = 1.0f;
    double last_d = -1;
    int steps = 0, composited = 0;
    while (steps++ < s->p.max_steps) {
        if (ix < 0 || iy < 0 || ix >= t->lw[k] || iy >= t->lh[k]) break;
        if (st) st->nodes++;
        const double n = (double)(1 << k);
        /* exit of the node's square */
        double ex = INFINITY, ey = INFINITY;
        if (dx != 0) ex = ((dx > 0 ? (ix + 1) * n : ix * n) - ax) / dx;
        if (dy != 0) ey = ((dy > 0 ? (iy + 1) * n : iy * n) - ay) / dy;
        double se = fmin(fmin(ex, ey), s1);
        if (se < sc) se = sc;
        double Dp = Da + sc * dD, Dq = Da + se * dD;
        double rlo = fmin(Dp, Dq), rhi = fmax(Dp, Dq);
        long ni = t->off[k] + (long)iy * t->lw[k] + ix;
        bool overlap = t->mx[ni] * (1 + th) >= rlo && t->mn[ni] * (1 - th) <= rhi;
        if (overlap && k > 0) {
            /* descend into the child the ray is in at sc */
            k--;
            double qx = ax + sc * dx, qy = ay + sc * dy;
            int cx = CELL(k, qx, dx, 0), cy = CELL(k, qy, dy, 0);
            ix = cx < 2 * ix ? 2 * ix : cx > 2 * ix + 1 ? 2 * ix + 1 : cx;
            iy = cy < 2 * iy ? 2 * iy : cy > 2 * iy + 1 ? 2 * iy + 1 : cy;
            continue;
        }
        if (overlap) {
            /* leaf: intersect the extruded fragment boxes of this pixel's list (§5.3), nearest along the ray first */
            if (st) st->leaves++;
            size_t pix = (size_t)iy * (size_t)L->w + (size_t)ix;
            int c = L->count[pix] < L->max_layers ? L->count[pix] : L->max_layers;
            hit hs[16];
            int nh = 0;
            for (int q = 0; q < c && nh < 16; q++) {
                const warp_fragment *f = &L->frag[pix * (size_t)L->max_layers + (size_t)q];
                if (!(f->z > 0) || !isfinite(f->z)) continue;
                if (st) st->fragment_tests++;
                double fd = 1.0 / f->z, a0 = sc, a1 = se;
                clip_lin(Da, dD, fd * (1 - th), fd * (1 + th), &a0, &a1);
                if (a1 < a0) continue;
                int j = nh++;
                while (j > 0 && hs[j - 1].s > a0) hs[j] = hs[j - 1], j--;
                hs[j] = (hit){(float)a0, (float)fd, f};
            }
            for (int q = 0; q < nh; q++) {
                /* the boxes of one surface overlap from pixel to pixel: never hit a fragment inside the box of the
                 * one just composited (§5.3) */
                if (last_d > 0 && fabs(hs[q].d - last_d) <= th * (hs[q].d + last_d)) continue;
                last_d = hs[q].d;
                const warp_rgba8 cf = hs[q].f->rgba;
                float a = cf.a * (1.0f / 255.0f), wgt = trans * a;
                acc[0] += wgt * lin(cf.r), acc[1] += wgt * lin(cf.g), acc[2] += wgt * lin(cf.b);
                trans *= 1.0f - a;
                composited++;
                if (1.0f - trans >= s->p.opacity_threshold) break;
            }
            if (1.0f - trans >= s->p.opacity_threshold) {
                if (st) st->early_exits++;
                break;
            }
        }
        if (se >= s1) break;
        /* step to the neighbour; ascend one level when it has another parent (Tevs et al.) */
        int ox = ix, oy = iy;
        if (ex <= ey) ix += stepx;
        if (ey <= ex) iy += stepy;
        sc = se;
        if (k < top && ((ox >> 1) != (ix >> 1) || (oy >> 1) != (iy >> 1))) {
            k++;
            ix >>= 1; /* arithmetic shift: -1 stays -1 (outside) */
            iy >>= 1;
        }
    }
#undef CELL
    if (st) {
        st->fragments += composited;
        st->rays_hit += composited > 0;
    }
    if (!composited) return opaque;
    warp_rgba8 r;
    r.r = warp_srgb_from_linear_u8(acc[0] + trans * lin(opaque.r));
    r.g = warp_srgb_from_linear_u8(acc[1] + trans * lin(opaque.g));
    r.b = warp_srgb_from_linear_u8(acc[2] + trans * lin(opaque.b));
    r.a = 255;
    return r;
}

void warp_transparency_rows(const warp_transparency_setup *s, const warp_image_f32 *opaque_inv, warp_image_rgba8 *dst,
                            int y0, int y1, warp_transparency_stats *st)
{
    if (y0 < 0) y0 = 0;
    if (y1 > dst->h) y1 = dst->h;
    for (int y = y0; y < y1; y++)
        for (int x = 0; x < dst->w; x++) {
            float d = opaque_inv ? WARP_AT(opaque_inv, x, y) : 0.0f;
            WARP_AT(dst, x, y) = cast(s, x + 0.5, y + 0.5, d > 0 ? d : 0.0, WARP_AT(dst, x, y), st);
        }
}

const char *warp_transparency_run(warp_grid *g, warp_minmax_tree *t, const warp_view *src, const warp_camera *dst_cam,
                                  warp_pose dst_pose, const warp_grid_params *gp, const warp_transparency_params *p,
                                  warp_image_rgba8 *dst, warp_image_f32 *dst_inv, warp_image_u8 *mask,
                                  warp_grid_stats *gst, warp_transparency_stats *st)
{
    if (!src->layers) return "transparency warp needs a layers plane";
    const char *err = warp_grid_run(g, src, dst_cam, dst_pose, gp, dst, dst_inv, mask, gst);
    if (err) return err;
    warp_minmax_build(t, src->layers);
    warp_transparency_setup s;
    err = warp_transparency_prepare(&s, src, t, dst_cam, dst_pose, p);
    if (err) return err;
    warp_transparency_rows(&s, dst_inv, dst, 0, dst->h, st);
    return NULL;
}

void warp_transparency_front_depth(const warp_image_f32 *opaque_inv, const warp_image_layers *l, warp_image_f32 *out)
{
    for (int y = 0; y < out->h; y++)
        for (int x = 0; x < out->w; x++) {
            float d = WARP_AT(opaque_inv, x, y);
            size_t pix = (size_t)y * (size_t)l->w + (size_t)x;
            if (l->count[pix] > 0) {
                float z = l->frag[pix * (size_t)l->max_layers].z;
                if (z > 0 && isfinite(z) && 1.0f / z > d) d = 1.0f / z;
            }
            WARP_AT(out, x, y) = d;
        }
}

long warp_transparency_unblend(const warp_image_rgba8 *blended, const warp_image_layers *l, warp_image_rgba8 *opaque)
{
    long lost = 0;
    for (int y = 0; y < blended->h; y++)
        for (int x = 0; x < blended->w; x++) {
            warp_rgba8 c = WARP_AT(blended, x, y);
            size_t pix = (size_t)y * (size_t)l->w + (size_t)x;
            int n = l->count[pix] < l->max_layers ? l->count[pix] : l->max_layers;
            float acc[3] = {0, 0, 0}, trans = 1.0f;
            for (int k = 0; k < n; k++) { /* front to back, in linear light: blended = acc + trans * opaque */
                warp_rgba8 f = l->frag[pix * (size_t)l->max_layers + (size_t)k].rgba;
                float a = f.a * (1.0f / 255.0f);
                acc[0] += trans * a * lin(f.r), acc[1] += trans * a * lin(f.g), acc[2] += trans * a * lin(f.b);
                trans *= 1.0f - a;
            }
            if (n > 0 && trans < 0.02f) {
                lost++;
            } else if (n > 0) {
                float it = 1.0f / trans; /* the encoder clamps to [0, 1] */
                c.r = warp_srgb_from_linear_u8((lin(c.r) - acc[0]) * it);
                c.g = warp_srgb_from_linear_u8((lin(c.g) - acc[1]) * it);
                c.b = warp_srgb_from_linear_u8((lin(c.b) - acc[2]) * it);
            }
            WARP_AT(opaque, x, y) = c;
        }
    return lost;
}

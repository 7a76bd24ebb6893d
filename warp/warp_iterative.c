/* SPDX-License-Identifier: MIT */
/* warp_iterative: the iterative backward warp of 001 §3: per target pixel, N stratified seeds in a min-max-mipmap
 * search bound, T fixed-point steps q <- p - v(q) each, over L depth layers; dilation and approximate hole fills. */
#include "warp/warp_iterative.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "warp/warp_rand.h"
#include "warp/warp_reproject.h"

/* The convergence test of the adaptive iteration budget: a step must shrink the previous one to this fraction or
 * less to count as contracting; ITER_STALLS steps in a row that do not end the seed. A contracting seed runs on up
 * to the cap T, so slow convergence (strong motion, 001 §4.2 Fig. 11: "more than T = 8") costs only where it
 * occurs, and non-convergent seeds (disocclusions) stop after a few steps instead of using the whole cap. */
#define ITER_CONTRACT 0.8
#define ITER_STALLS 2

/* Scratch bits per target pixel for the dilation. */
enum { ST_HOLE = 1, ST_APPROX = 2, ST_NEW = 4 };

warp_iter_params warp_iter_default_params(void)
{
    warp_iter_params p = {
        .seeds = 8,
        .iters = 32,
        .layers = 1,
        .bound = WARP_ITER_BOUND_PCA,
        .bound_iters = 3,
        .tol = 0.05f,
        .early_exit = true,
        .cross_layer = true,
        .dilate = false,
        .dilate_radius = 2,
        .approximate = false,
        .pca_samples = 64,
        .derotate = true,
    };
    return p;
}

long warp_iter_peel_mask(const warp_image_f32 *front, warp_image_f32 *layer, float rel_eps)
{
    long kept = 0;
    for (int y = 0; y < layer->h && y < front->h; y++)
        for (int x = 0; x < layer->w && x < front->w; x++) {
            float f = WARP_AT(front, x, y), *l = &WARP_AT(layer, x, y);
            if (!(*l >= 0) || fabsf(*l - f) <= rel_eps * (f > *l ? f : *l)) *l = -1.0f;
            else kept++;
        }
    return kept;
}

bool warp_iter_alloc(warp_iter_ctx *c, int src_w, int src_h, int dst_w, int dst_h, int max_layers)
{
    memset(c, 0, sizeof *c);
    if (max_layers < 1 || max_layers > WARP_ITER_MAX_LAYERS) return false;
    c->src_w = src_w;
    c->src_h = src_h;
    c->dst_w = dst_w;
    c->dst_h = dst_h;
    c->max_layers = max_layers;
    bool ok = warp_image_f32_alloc(&c->dst_depth, dst_w, dst_h) && warp_image_u8_alloc(&c->scratch, dst_w, dst_h);
    for (int l = 0; ok && l < max_layers; l++)
        ok = warp_motion_alloc(&c->motion[l], src_w, src_h) && warp_motion_mip_alloc(&c->mip[l], src_w, src_h);
    if (!ok) warp_iter_free(c);
    return ok;
}

void warp_iter_free(warp_iter_ctx *c)
{
    for (int l = 0; l < WARP_ITER_MAX_LAYERS; l++) {
        warp_motion_free(&c->motion[l]);
        warp_motion_mip_free(&c->mip[l]);
    }
    warp_image_free(&c->dst_depth);
    warp_image_free(&c->scratch);
    memset(c, 0, sizeof *c);
}

/* Target pixel (x, y) through the homography g; false when it lies in a direction at or behind the source
 * camera's image plane (no source pixel there). */
static inline bool through(const warp_mat3 *g, double x, double y, double *ox, double *oy)
{
    double hw = g->m[2][0] * x + g->m[2][1] * y + g->m[2][2];
    if (!(hw > 1e-9)) return false;
    *ox = (g->m[0][0] * x + g->m[0][1] * y + g->m[0][2]) / hw;
    *oy = (g->m[1][0] * x + g->m[1][1] * y + g->m[1][2]) / hw;
    return true;
}

/* Re-expresses a layer's motions in the rotation-compensated frame: u(q) = G(q + v(q)) - q, with G the rotation
 * homography target -> source. The fixed point q = G(p) - u(q) has the same solutions as q = p - v(q), but the
 * head's rotation, however large, is solved exactly before the iteration starts: u is zero for any rotation and
 * holds only the parallax of the translation and the objects' own motion. The map's Jacobian is then -du/dq,
 * small, where the plain map's is I - J_rotation, with J up to a 2x scaling at a 45 degree turn: no contraction
 * (001 §3.2 names the Jacobian as what guarantees convergence; the rotation's part of it is known exactly). */
static void derotate_motion(warp_motion_buffer *m, const warp_mat3 *g)
{
    for (int y = 0; y < m->h; y++)
        for (int x = 0; x < m->w; x++) {
            warp_motion_texel *t = &m->px[(size_t)y * (size_t)m->w + (size_t)x];
            if (!(t->d >= 0)) continue;
            const double qx = x + 0.5, qy = y + 0.5;
            double sx, sy;
            /* seen from the target in a direction the source does not face: no target pixel can reach it in this
             * frame (those pixels are fringe), so it is left out of the bounds */
            if (!through(g, qx + t->x, qy + t->y, &sx, &sy) || !(fabs(sx - qx) < 1e6 && fabs(sy - qy) < 1e6)) {
                *t = (warp_motion_texel){0, 0, -1};
                continue;
            }
            t->x = (float)(sx - qx);
            t->y = (float)(sy - qy);
        }
}

static bool same_size_f32(const warp_image_f32 *a, int w, int h) { return a && a->w == w && a->h == h; }

const char *warp_iter_prepare(warp_iter_ctx *c, const warp_view *src, const warp_iter_layer *extra, int n_extra,
                              const warp_iter_target *dst, const warp_iter_params *p)
{
    if (!c->mip[0].mem) return "iterative warp context is not allocated";
    if (!src->color || !src->inv_depth) return "iterative warp needs colour and depth planes";
    const int w = c->src_w, h = c->src_h;
    if (src->color->w != w || src->color->h != h || !same_size_f32(src->inv_depth, w, h))
        return "source planes differ from the context's source size";
    if (src->cam.width != w || src->cam.height != h) return "source camera differs from the context's source size";
    if (dst->cam.width != c->dst_w || dst->cam.height != c->dst_h) return "target camera differs from the context's size";
    if (warp_camera_check(&src->cam) || warp_camera_check(&dst->cam)) return "camera is not usable";
    const char *bad = warp_poses_check(src->pose, dst->pose);
    if (!bad) bad = warp_object_poses_check(src->object_pose, dst->object_pose, src->n_objects);
    if (bad) return bad;
    if (!isfinite(dst->time) || !isfinite(src->time)) return "source or target time is not finite";
    if (p->seeds < 1 || p->seeds > 1024) return "seed count N must be 1..1024";
    if (p->iters < 1 || p->iters > 256) return "iteration count T must be 1..256";
    if (!(p->tol > 0)) return "convergence tolerance must be positive";
    if (p->bound_iters < 0 || p->bound < WARP_ITER_BOUND_GLOBAL || p->bound > WARP_ITER_BOUND_PCA)
        return "bad search-bound settings";
    if (p->layers < 1 || p->layers > c->max_layers) return "layer count L exceeds the context's layers";
    if (p->layers > 1 + (extra ? n_extra : 0)) return "layer count L exceeds the layers given";
    if (src->ids && (src->ids->w != w || src->ids->h != h)) return "id plane differs in size";
    if (src->motion && (src->motion->w != w || src->motion->h != h)) return "motion plane differs in size";
    for (int l = 1; l < p->layers; l++) {
        const warp_iter_layer *e = &extra[l - 1];
        if (!e->color || e->color->w != w || e->color->h != h || !same_size_f32(e->inv_depth, w, h))
            return "extra layer planes differ from the source size";
        if ((e->ids && (e->ids->w != w || e->ids->h != h)) || (e->motion && (e->motion->w != w || e->motion->h != h)))
            return "extra layer planes differ from the source size";
    }
    c->src = src;
    c->p = *p;
    c->layers = p->layers;

    warp_motion_setup ms = {
        .src_cam = src->cam,
        .dst_cam = dst->cam,
        .src_pose = src->pose,
        .dst_pose = dst->pose,
        .dt = dst->time - src->time,
        .n_objects = src->n_objects,
        .src_object_pose = dst->object_pose ? src->object_pose : NULL,
        .dst_object_pose = src->object_pose ? dst->object_pose : NULL,
    };
    c->src_from_dst = (warp_mat3){{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
    if (p->derotate) c->src_from_dst = warp_reproject_homography(src, &dst->cam, dst->pose.q);
    const warp_motion_buffer *upper[WARP_ITER_MAX_LAYERS];
    for (int l = 0; l < c->layers; l++) {
        const warp_image_f32 *d = l ? extra[l - 1].inv_depth : src->inv_depth;
        const warp_image_u16 *ids = l ? extra[l - 1].ids : src->ids;
        const warp_image_vec2f *mo = l ? extra[l - 1].motion : src->motion;
        c->color[l] = l ? extra[l - 1].color : src->color;
        warp_motion_compute_rows(&c->motion[l], &ms, d, ids, mo, 0, h);
        if (p->derotate) derotate_motion(&c->motion[l], &c->src_from_dst);
        double theta = p->bound == WARP_ITER_BOUND_PCA ? warp_motion_pca(&c->motion[l], p->pca_samples) : 0.0;
        /* the layers above, nearest to this one first (001 Fig. 6 walks j = layer-1 .. 0) */
        int nu = 0;
        if (p->cross_layer)
            for (int j = l - 1; j >= 0; j--) upper[nu++] = &c->motion[j];
        warp_motion_mip_build(&c->mip[l], &c->motion[l], upper, nu, theta);
    }
    return NULL;
}

/* ---- lookups ---- */

typedef struct {
    double x, y;  /* motion */
    float d;      /* target inverse depth */
    int layer;    /* the layer that answered */
} lookup;

/* Bilinear motion of `layer` at q (clamped to the image), over the texels that are not empty (weights
 * renormalised, so a layer's edge does not blend with its empty texels). With cross-layer seeding, a lookup whose
 * four texels are all empty reads the nearest layer above that has any (001 Fig. 6). False when none has. */
static bool look(const warp_iter_ctx *c, int layer, double qx, double qy, bool cross, lookup *out, long *crossed)
{
    const int w = c->src_w, h = c->src_h;
    double fx = qx - 0.5, fy = qy - 0.5;
    fx = fx < 0 ? 0 : (fx > w - 1 ? w - 1 : fx);
    fy = fy < 0 ? 0 : (fy > h - 1 ? h - 1 : fy);
    int x0 = (int)fx, y0 = (int)fy;
    int x1 = x0 + (x0 + 1 < w), y1 = y0 + (y0 + 1 < h);
    double ax = fx - x0, ay = fy - y0;
    const size_t i00 = (size_t)y0 * (size_t)w + (size_t)x0, i10 = (size_t)y0 * (size_t)w + (size_t)x1;
    const size_t i01 = (size_t)y1 * (size_t)w + (size_t)x0, i11 = (size_t)y1 * (size_t)w + (size_t)x1;
    const double wt[4] = {(1 - ax) * (1 - ay), ax * (1 - ay), (1 - ax) * ay, ax * ay};
    for (int l = layer; l >= 0; l--) {
        const warp_motion_texel *m = c->motion[l].px;
        const warp_motion_texel *t[4] = {&m[i00], &m[i10], &m[i01], &m[i11]};
        double sw = 0, sx = 0, sy = 0, sd = 0;
        for (int k = 0; k < 4; k++)
            if (t[k]->d >= 0) {
                sw += wt[k];
                sx += wt[k] * t[k]->x;
                sy += wt[k] * t[k]->y;
                sd += wt[k] * t[k]->d;
            }
        bool any = t[0]->d >= 0 || t[1]->d >= 0 || t[2]->d >= 0 || t[3]->d >= 0;
        if (any) {
            if (!(sw > 1e-12)) { /* valid texels with zero weight: take them unweighted */
                sw = sx = sy = sd = 0;
                for (int k = 0; k < 4; k++)
                    if (t[k]->d >= 0) sw += 1, sx += t[k]->x, sy += t[k]->y, sd += t[k]->d;
            }
            out->x = sx / sw;
            out->y = sy / sw;
            out->d = (float)(sd / sw);
            out->layer = l;
            if (l != layer) (*crossed)++;
            return true;
        }
        if (!cross) return false;
    }
    return false;
}

/* Colour of `layer` at q, bilinear over its non-empty texels (clamped to the image like the fringe fill). */
static warp_rgba8 sample_layer(const warp_iter_ctx *c, int layer, double qx, double qy)
{
    const warp_image_rgba8 *img = c->color[layer];
    if (layer == 0) return warp_sample_bilinear(img, (float)qx, (float)qy);
    const int w = c->src_w, h = c->src_h;
    double fx = qx - 0.5, fy = qy - 0.5;
    fx = fx < 0 ? 0 : (fx > w - 1 ? w - 1 : fx);
    fy = fy < 0 ? 0 : (fy > h - 1 ? h - 1 : fy);
    int x0 = (int)fx, y0 = (int)fy;
    int xs[2] = {x0, x0 + (x0 + 1 < w)}, ys[2] = {y0, y0 + (y0 + 1 < h)};
    double ax = fx - x0, ay = fy - y0;
    const warp_motion_texel *m = c->motion[layer].px;
    double s[4] = {0, 0, 0, 0}, sw = 0;
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 2; i++) {
            if (!(m[(size_t)ys[j] * (size_t)w + (size_t)xs[i]].d >= 0)) continue;
            double wt = (i ? ax : 1 - ax) * (j ? ay : 1 - ay) + 1e-9;
            warp_rgba8 px = WARP_AT(img, xs[i], ys[j]);
            s[0] += wt * px.r, s[1] += wt * px.g, s[2] += wt * px.b, s[3] += wt * px.a;
            sw += wt;
        }
    if (!(sw > 0)) return warp_sample_bilinear(img, (float)qx, (float)qy);
    warp_rgba8 o = {(uint8_t)(s[0] / sw + 0.5), (uint8_t)(s[1] / sw + 0.5), (uint8_t)(s[2] / sw + 0.5),
                    (uint8_t)(s[3] / sw + 0.5)};
    return o;
}

/* Deterministic jitter in [0, 1) for seed k of layer l at target pixel (x, y): stratified sampling needs
 * a random position per stratum, and the same frame must give the same image. */
static inline double jitter(uint32_t x, uint32_t y, uint32_t l, uint32_t k, uint32_t axis)
{
    uint64_t z = ((uint64_t)x << 40) ^ ((uint64_t)y << 20) ^ ((uint64_t)l << 12) ^ ((uint64_t)k << 1) ^ axis;
    return warp_unit53(warp_splitmix64(z));
}

/* Image-space bounding rectangle of the search region: the box [P - hi, P - lo] in rotated coordinates, where
 * P = R p, mapped back by R^T. */
static void region_aabb(const warp_motion_mip *mip, double pa, double pb, const warp_motion_box *b, double r[4])
{
    double a0 = pa - b->hi[0], a1 = pa - b->lo[0], b0 = pb - b->hi[1], b1 = pb - b->lo[1];
    double c = mip->c, s = mip->s;
    r[0] = r[1] = INFINITY;
    r[2] = r[3] = -INFINITY;
    const double ca[4] = {a0, a1, a0, a1}, cb[4] = {b0, b0, b1, b1};
    for (int k = 0; k < 4; k++) {
        double x = c * ca[k] - s * cb[k], y = s * ca[k] + c * cb[k];
        if (x < r[0]) r[0] = x;
        if (y < r[1]) r[1] = y;
        if (x > r[2]) r[2] = x;
        if (y > r[3]) r[3] = y;
    }
}

/* The search bound of target pixel p in layer l: the global bound, then 001 Fig. 5's tightening. */
static warp_motion_box search_bound(const warp_iter_ctx *c, int l, double px, double py, long *lookups)
{
    const warp_motion_mip *mip = &c->mip[l];
    warp_motion_box b = warp_motion_mip_global(mip);
    if (c->p.bound == WARP_ITER_BOUND_GLOBAL || !warp_motion_box_valid(&b)) return b;
    double pa, pb;
    warp_motion_rotate(mip->c, mip->s, px, py, &pa, &pb);
    for (int k = 0; k < c->p.bound_iters; k++) {
        double r[4];
        region_aabb(mip, pa, pb, &b, r);
        warp_motion_box m = warp_motion_mip_query(mip, r[0], r[1], r[2], r[3]);
        *lookups += 4;
        if (!warp_motion_box_valid(&m)) return b; /* "usually background" */
        /* the new bound comes from a region inside the old one, so it can only shrink; intersecting guards
         * against float noise widening it */
        for (int i = 0; i < 2; i++) {
            if (m.lo[i] < b.lo[i]) m.lo[i] = b.lo[i];
            if (m.hi[i] > b.hi[i]) m.hi[i] = b.hi[i];
        }
        if (!warp_motion_box_valid(&m)) return b;
        if (m.lo[0] == b.lo[0] && m.hi[0] == b.hi[0] && m.lo[1] == b.lo[1] && m.hi[1] == b.hi[1]) break;
        b = m;
    }
    return b;
}

typedef struct {
    bool found;
    double qx, qy;
    float d;
    int layer;
} candidate;

static inline bool inside_src(const warp_iter_ctx *c, double x, double y)
{
    return x >= 0 && x <= c->src_w && y >= 0 && y <= c->src_h;
}

/* Keeps the nearer solution (larger target inverse depth); ties keep the first (the shallower layer). */
static inline void keep_nearest(candidate *best, double qx, double qy, float d, int layer)
{
    if (!best->found || d > best->d) {
        best->found = true;
        best->qx = qx;
        best->qy = qy;
        best->d = d;
        best->layer = layer;
    }
}

void warp_iter_rows(warp_iter_ctx *c, warp_image_rgba8 *dst, warp_image_u8 *mask, int y0, int y1,
                    warp_iter_stats *st)
{
    const warp_iter_params *p = &c->p;
    const int N = p->seeds, T = p->iters;
    const double tol2 = (double)p->tol * p->tol;
    long seeds = 0, iters = 0, lookups = 0, converged = 0, fringe = 0, holes = 0, approx = 0, crossed = 0;
    long conv_layer[WARP_ITER_MAX_LAYERS] = {0};
    double area = 0;
    if (y0 < 0) y0 = 0;
    if (y1 > c->dst_h) y1 = c->dst_h;
    for (int y = y0; y < y1; y++) {
        warp_rgba8 *out = &WARP_AT(dst, 0, y);
        uint8_t *m = mask ? &WARP_AT(mask, 0, y) : NULL;
        float *dd = &WARP_AT(&c->dst_depth, 0, y);
        uint8_t *sc = &WARP_AT(&c->scratch, 0, y);
        for (int x = 0; x < c->dst_w; x++) {
            /* the pixel the search solves for: p, or G(p) in the rotation-compensated frame */
            double px = x + 0.5, py = y + 0.5;
            const bool behind = p->derotate && !through(&c->src_from_dst, x + 0.5, y + 0.5, &px, &py);
            candidate in = {0}, out_c = {0};
            warp_motion_box b0 = {{0, 0}, {0, 0}};
            bool b0_valid = false;
            for (int l = 0; l < c->layers && !behind; l++) {
                const warp_motion_mip *mip = &c->mip[l];
                warp_motion_box b = search_bound(c, l, px, py, &lookups);
                if (l == 0) {
                    b0 = b;
                    b0_valid = warp_motion_box_valid(&b);
                }
                if (!warp_motion_box_valid(&b)) continue; /* the layer is empty everywhere */
                double pa, pb;
                warp_motion_rotate(mip->c, mip->s, px, py, &pa, &pb);
                /* the search region in rotated coordinates: q = p - v with v in the bound */
                const double a0 = pa - b.hi[0], b0r = pb - b.hi[1];
                const double ea = (double)b.hi[0] - b.lo[0], eb = (double)b.hi[1] - b.lo[1];
                area += ea * eb;
                int n = N, nx = 1;
                if (p->early_exit && ea < 1 && eb < 1) n = 1;
                if (n > 1) {
                    /* strata: an nx x ny grid shaped like the region, ny = ceil(n / nx) rows */
                    double r = eb > 1e-6 ? sqrt(n * ea / eb) : n;
                    nx = (int)(r + 0.5);
                    nx = nx < 1 ? 1 : (nx > n ? n : nx);
                }
                const int ny = (n + nx - 1) / nx;
                for (int k = 0; k < n; k++) {
                    double ua = 0.5, ub = 0.5;
                    if (n > 1) {
                        ua = ((k % nx) + jitter((uint32_t)x, (uint32_t)y, (uint32_t)l, (uint32_t)k, 0)) / nx;
                        ub = ((k / nx) + jitter((uint32_t)x, (uint32_t)y, (uint32_t)l, (uint32_t)k, 1)) / ny;
                    }
                    double sa = a0 + ua * ea, sb = b0r + ub * eb;
                    double qx = mip->c * sa - mip->s * sb, qy = mip->s * sa + mip->c * sb;
                    seeds++;
                    int empties = 0, stalls = 0;
                    double prev2 = INFINITY;
                    for (int t = 0; t < T; t++) {
                        lookup lk;
                        iters++;
                        long cr = 0;
                        bool ok = look(c, l, qx, qy, p->cross_layer, &lk, &cr);
                        crossed += cr;
                        /* a search ending in an empty area: without cross-layer seeding it cannot go on; with it,
                         * the second time makes the seed non-convergent (001 §3.4) */
                        if (!ok || cr) {
                            if (!ok || ++empties >= 2) break;
                        }
                        double wx = px - lk.x, wy = py - lk.y;
                        double ddx = wx - qx, ddy = wy - qy;
                        qx = wx;
                        qy = wy;
                        const double r2 = ddx * ddx + ddy * ddy;
                        if (r2 < tol2) {
                            if (inside_src(c, qx, qy)) keep_nearest(&in, qx, qy, lk.d, lk.layer);
                            else keep_nearest(&out_c, qx, qy, lk.d, lk.layer);
                            break;
                        }
                        /* the adaptive budget: a seed goes on while the map contracts and stops after
                         * ITER_STALLS steps that do not (bouncing across a depth edge, or diverging) */
                        if (r2 > ITER_CONTRACT * ITER_CONTRACT * prev2) {
                            if (++stalls >= ITER_STALLS) break;
                        } else {
                            stalls = 0;
                        }
                        prev2 = r2;
                    }
                }
            }
            uint8_t flag = 0, state = 0;
            if (in.found) {
                out[x] = sample_layer(c, in.layer, in.qx, in.qy);
                dd[x] = in.d;
                converged++;
                conv_layer[in.layer]++;
            } else if (behind) {
                /* no source pixel in that direction: the nearest border colour, as the rotation warp (003 §4.3) */
                const warp_mat3 *g = &c->src_from_dst;
                double hx = g->m[0][0] * (x + 0.5) + g->m[0][1] * (y + 0.5) + g->m[0][2];
                double hy = g->m[1][0] * (x + 0.5) + g->m[1][1] * (y + 0.5) + g->m[1][2];
                out[x] = warp_sample_bilinear(c->color[0], hx > 0 ? (float)c->src_w : 0.0f,
                                              hy > 0 ? (float)c->src_h : 0.0f);
                dd[x] = 0;
                flag = WARP_MASK_FRINGE;
                fringe++;
            } else if (out_c.found) {
                /* the solution lies outside the source: clamped, as the rotation warp's fringe (003 §4.3) */
                out[x] = warp_sample_bilinear(c->color[0], (float)out_c.qx, (float)out_c.qy);
                dd[x] = out_c.d;
                flag = WARP_MASK_FRINGE;
                fringe++;
            } else {
                flag = WARP_MASK_HOLE;
                state = ST_HOLE;
                holes++;
                out[x] = (warp_rgba8){0, 0, 0, 0};
                dd[x] = -1;
                if (p->approximate && b0_valid) {
                    /* AWOC (001 §5): the source pixels the bound's extreme motions point at do not converge,
                     * but the nearest of them is taken as an approximation */
                    const warp_motion_mip *mip = &c->mip[0];
                    candidate ap = {0};
                    for (int k = 0; k < 4; k++) {
                        double va = (k & 1) ? b0.hi[0] : b0.lo[0], vb = (k & 2) ? b0.hi[1] : b0.lo[1];
                        double vx = mip->c * va - mip->s * vb, vy = mip->s * va + mip->c * vb;
                        lookup lk;
                        long cr = 0;
                        if (look(c, 0, px - vx, py - vy, false, &lk, &cr)) keep_nearest(&ap, px - vx, py - vy, lk.d, 0);
                    }
                    if (ap.found) {
                        out[x] = warp_sample_bilinear(c->color[0], (float)ap.qx, (float)ap.qy);
                        dd[x] = ap.d;
                        flag |= WARP_MASK_FILLED;
                        state |= ST_APPROX;
                        approx++;
                    }
                }
            }
            if (m) m[x] = flag;
            sc[x] = state;
        }
    }
    if (st) {
        st->pixels += (long)(y1 - y0) * c->dst_w;
        st->seeds += seeds;
        st->iterations += iters;
        st->bound_lookups += lookups;
        st->converged += converged;
        for (int l = 0; l < WARP_ITER_MAX_LAYERS; l++) st->converged_layer[l] += conv_layer[l];
        st->cross_layer += crossed;
        st->fringe += fringe;
        st->holes += holes;
        st->approximated += approx;
        st->bound_area += area;
    }
}

void warp_iter_finish(warp_iter_ctx *c, warp_image_rgba8 *dst, warp_image_u8 *mask, warp_iter_stats *st)
{
    if (!c->p.dilate) return;
    const int w = c->dst_w, h = c->dst_h;
    long dilated = 0, unapprox = 0;
    /* 001 §3.4 (Fig. 8): a hole next to successful searches takes a neighbour's depth, one ring per pass. Of the
     * converged 8-neighbours the farthest is propagated: what a warp uncovers is the background (as 003 §4.4). */
    for (int pass = 0; pass < c->p.dilate_radius; pass++) {
        long changed = 0;
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                uint8_t *s = &WARP_AT(&c->scratch, x, y);
                if (!(*s & ST_HOLE)) continue;
                int bx = -1, by = -1;
                float best = INFINITY;
                for (int j = -1; j <= 1; j++)
                    for (int i = -1; i <= 1; i++) {
                        int xx = x + i, yy = y + j;
                        if ((i == 0 && j == 0) || xx < 0 || yy < 0 || xx >= w || yy >= h) continue;
                        uint8_t ns = WARP_AT(&c->scratch, xx, yy);
                        if (ns & (ST_HOLE | ST_NEW)) continue; /* still a hole, or filled in this very pass */
                        if (mask && (WARP_AT(mask, xx, yy) & WARP_MASK_FRINGE)) continue;
                        float d = WARP_AT(&c->dst_depth, xx, yy);
                        if (d < best) {
                            best = d;
                            bx = xx;
                            by = yy;
                        }
                    }
                if (bx < 0) continue;
                WARP_AT(dst, x, y) = WARP_AT(dst, bx, by);
                WARP_AT(&c->dst_depth, x, y) = best;
                if (mask) WARP_AT(mask, x, y) = WARP_MASK_HOLE | WARP_MASK_FILLED;
                unapprox += (*s & ST_APPROX) != 0;
                *s = ST_NEW;
                changed++;
            }
        /* the ring filled in this pass is a source for the next one */
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) WARP_AT(&c->scratch, x, y) &= (uint8_t)~ST_NEW;
        dilated += changed;
        if (!changed) break;
    }
    if (st) {
        st->dilated += dilated;
        st->approximated -= unapprox;
    }
}

const char *warp_iter_run(warp_iter_ctx *c, const warp_view *src, const warp_iter_layer *extra, int n_extra,
                          const warp_iter_target *dst, const warp_iter_params *p, warp_image_rgba8 *out,
                          warp_image_u8 *mask, warp_iter_stats *st)
{
    if (!out || out->w != c->dst_w || out->h != c->dst_h || !mask || mask->w != c->dst_w || mask->h != c->dst_h)
        return "output planes differ from the context's target size";
    const char *err = warp_iter_prepare(c, src, extra, n_extra, dst, p);
    if (err) return err;
    warp_iter_rows(c, out, mask, 0, c->dst_h, st);
    warp_iter_finish(c, out, mask, st);
    return NULL;
}

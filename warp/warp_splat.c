/* SPDX-License-Identifier: MIT */
/* warp_splat: reconstruction of forward-warped samples (002 §3.3): square point splats sized from the warp's
 * Jacobian, quadrilateral splats (the Jacobian image of the pixel) and a mesh of the source pixels that is not
 * connected across depth discontinuities or object borders. Runs on the samples warp_forward maps. */
#include "warp/warp_splat.h"

#include <math.h>
#include <string.h>

warp_splat_params warp_splat_default_params(warp_splat_kind kind)
{
    warp_splat_params p = {kind, WARP_FWD_ZBUFFER, 1, 4, 8.0f, 0.1f};
    return p;
}

typedef struct {
    const warp_view *v;
    warp_fwd_scratch *sc;
    warp_image_rgba8 *dst;
    bool ztest;
    long fragments, writes, rejects;
} draw_ctx;

/* One covered target pixel: the depth test (z-buffer mode; ties go to the later sample, as the painter's order
 * would) or a plain overwrite (sheet order). */
static inline void fragment(draw_ctx *c, int i, int j, float d, warp_rgba8 col)
{
    int32_t t = j * c->sc->dst_w + i;
    c->fragments++;
    if (c->ztest && d < c->sc->zbuf[t]) {
        c->rejects++;
        return;
    }
    WARP_AT(c->dst, i, j) = col;
    c->sc->zbuf[t] = d;
    c->writes++;
}

/* Pixels whose centres lie in [lo, hi): the half-open rule keeps abutting splats from sharing pixels. */
static inline void span(double lo, double hi, int n, int *a, int *b)
{
    double fa = ceil(lo - 0.5), fb = ceil(hi - 0.5);
    *a = fa < 0 ? 0 : (fa > n ? n : (int)fa);
    *b = fb < 0 ? 0 : (fb > n ? n : (int)fb);
}

/* A point splat's own pixels are those within its true footprint's box (the unrounded sides |J11| + |J12| and
 * |J21| + |J22|, grown by this factor, at least min_size); the rest of the rounded-up square only pads: it fills
 * what no splat's own pixels cover, so rounding up does not widen a near surface over the one behind it. */
#define POINT_CORE_GROW 1.1
/* Added to a padding fragment's squared distance: larger than any own one (sides are at most a few pixels). */
#define POINT_PAD 1e4f

/* A point splat's fragment. Splat sides are rounded up so that splats never crack (002 §3.3), so neighbouring splats
 * overlap; when the later one simply won, every overlap went the way of the drawing order and the image shifted by
 * up to half a splat (0.5 px for the 2x2 splats of a slight magnification, against raster order). So between
 * fragments of one surface (inverse depths within edge_jump) the one whose warped position is nearer the pixel
 * centre wins (ties: the later), and every pixel shows its nearest sample. Across surfaces a splat's own pixel beats
 * another's padding, and otherwise the z-buffer or the painter's order decides as for the other kinds. r2 carries
 * POINT_PAD for padding. */
static inline void point_fragment(draw_ctx *c, int i, int j, float d, float r2, float jump, warp_rgba8 col)
{
    int32_t t = j * c->sc->dst_w + i;
    float z = c->sc->zbuf[t], o = c->sc->near2[t];
    c->fragments++;
    if (z >= 0) {
        bool pad = r2 >= POINT_PAD, opad = o >= POINT_PAD;
        if (fabsf(d - z) <= jump * fmaxf(d, z) || pad != opad) {
            if (r2 > o) return;
        } else if (c->ztest && d < z) {
            c->rejects++;
            return;
        }
    }
    WARP_AT(c->dst, i, j) = col;
    c->sc->zbuf[t] = d;
    c->sc->near2[t] = r2;
    c->writes++;
}

static void point_splat(draw_ctx *c, const warp_splat_params *p, int32_t k)
{
    const float *j = &c->sc->jac[4 * k];
    double ext = fmax(fabs(j[0]) + fabs(j[1]), fabs(j[2]) + fabs(j[3]));
    /* ceil (002 §3.3) so that splats never leave cracks; the small slack keeps an exact 1:1 warp at size 1 */
    double sz = isfinite(ext) ? ceil(ext - 1e-3) : p->max_size;
    if (sz < p->min_size) sz = p->min_size;
    if (sz > p->max_size) sz = p->max_size;
    double cx = c->sc->x2[k], cy = c->sc->y2[k];
    double hx = 0.5 * fmax(POINT_CORE_GROW * (fabs(j[0]) + fabs(j[1])), p->min_size);
    double hy = 0.5 * fmax(POINT_CORE_GROW * (fabs(j[2]) + fabs(j[3])), p->min_size);
    int x0, x1, y0, y1;
    /* the sz x sz pixels nearest the warped position: centred on it to within half a pixel */
    span(cx - sz * 0.5, cx + sz * 0.5, c->sc->dst_w, &x0, &x1);
    span(cy - sz * 0.5, cy + sz * 0.5, c->sc->dst_h, &y0, &y1);
    warp_rgba8 col = WARP_AT(c->v->color, k % c->v->color->w, k / c->v->color->w);
    float d = c->sc->d2[k];
    for (int y = y0; y < y1; y++) {
        double dy = y + 0.5 - cy;
        for (int x = x0; x < x1; x++) {
            double dx = x + 0.5 - cx;
            float r2 = (float)(dx * dx + dy * dy);
            if (!(fabs(dx) <= hx && fabs(dy) <= hy)) r2 += POINT_PAD;
            point_fragment(c, x, y, d, r2, p->edge_jump, col);
        }
    }
}

/* Returns false when the quad degenerated and a 1-pixel point was drawn instead. */
static bool quad_splat(draw_ctx *c, const warp_splat_params *p, int32_t k)
{
    const float *j = &c->sc->jac[4 * k];
    /* half-axes: the images of the pixel's half-width steps (x +- 1/2, y +- 1/2) under J */
    double ax = 0.5 * j[0], ay = 0.5 * j[2], bx = 0.5 * j[1], by = 0.5 * j[3];
    double ex = fabs(ax) + fabs(bx), ey = fabs(ay) + fabs(by);
    double lim = 0.5 * p->max_extent;
    if (!(ex <= lim && ey <= lim)) {
        double s = lim / fmax(ex, ey);
        if (!isfinite(s)) s = 0;
        ax *= s, ay *= s, bx *= s, by *= s, ex *= s, ey *= s;
    }
    double det = ax * by - bx * ay;
    double cx = c->sc->x2[k], cy = c->sc->y2[k];
    warp_rgba8 col = WARP_AT(c->v->color, k % c->v->color->w, k / c->v->color->w);
    float d = c->sc->d2[k];
    if (!(fabs(det) > 1e-4)) {
        int x = (int)floor(cx), y = (int)floor(cy);
        if (x >= 0 && y >= 0 && x < c->sc->dst_w && y < c->sc->dst_h) fragment(c, x, y, d, col);
        return false;
    }
    int x0, x1, y0, y1;
    span(cx - ex, cx + ex + 1e-9, c->sc->dst_w, &x0, &x1);
    span(cy - ey, cy + ey + 1e-9, c->sc->dst_h, &y0, &y1);
    for (int y = y0; y < y1; y++) {
        double dy = y + 0.5 - cy;
        for (int x = x0; x < x1; x++) {
            double dx = x + 0.5 - cx;
            /* coordinates in the (a, b) frame: inside when both are in [-1, 1) */
            double al = (by * dx - bx * dy) / det, be = (ax * dy - ay * dx) / det;
            if (al >= -1 && al < 1 && be >= -1 && be < 1) fragment(c, x, y, d, col);
        }
    }
    return true;
}

typedef struct {
    double x, y;
    float d;
    warp_rgba8 c;
} vtx;

static inline double edge(const vtx *a, const vtx *b, double px, double py)
{
    return (b->x - a->x) * (py - a->y) - (b->y - a->y) * (px - a->x);
}

/* Returns false when the triangle is culled. */
static bool triangle(draw_ctx *c, const warp_splat_params *p, const vtx *a, const vtx *b, const vtx *t)
{
    double area = edge(a, b, t->x, t->y);
    if (!(fabs(area) > 1e-9)) return false;
    double minx = fmin(a->x, fmin(b->x, t->x)), maxx = fmax(a->x, fmax(b->x, t->x));
    double miny = fmin(a->y, fmin(b->y, t->y)), maxy = fmax(a->y, fmax(b->y, t->y));
    if (maxx - minx > p->max_extent || maxy - miny > p->max_extent) return false;
    int x0, x1, y0, y1;
    /* inclusive bounds: a pixel centre exactly on a vertex (the 1:1 warp) belongs to the triangle */
    span(minx, maxx + 1e-6, c->sc->dst_w, &x0, &x1);
    span(miny, maxy + 1e-6, c->sc->dst_h, &y0, &y1);
    const double eps = -1e-7 * fabs(area), inv = 1.0 / area;
    for (int y = y0; y < y1; y++) {
        double py = y + 0.5;
        for (int x = x0; x < x1; x++) {
            double px = x + 0.5;
            double w0 = edge(b, t, px, py) * inv, w1 = edge(t, a, px, py) * inv, w2 = edge(a, b, px, py) * inv;
            if (w0 * fabs(area) < eps || w1 * fabs(area) < eps || w2 * fabs(area) < eps) continue;
            /* target inverse depth is affine in target screen space over a planar triangle */
            float d = (float)(w0 * a->d + w1 * b->d + w2 * t->d);
            warp_rgba8 col;
            col.r = (uint8_t)fmin(255, fmax(0, w0 * a->c.r + w1 * b->c.r + w2 * t->c.r + 0.5));
            col.g = (uint8_t)fmin(255, fmax(0, w0 * a->c.g + w1 * b->c.g + w2 * t->c.g + 0.5));
            col.b = (uint8_t)fmin(255, fmax(0, w0 * a->c.b + w1 * b->c.b + w2 * t->c.b + 0.5));
            col.a = (uint8_t)fmin(255, fmax(0, w0 * a->c.a + w1 * b->c.a + w2 * t->c.a + 0.5));
            fragment(c, x, y, d, col);
        }
    }
    return true;
}

/* Whether the three source samples belong to one surface: all mapped, one object, no depth edge between them. */
static bool connected(const draw_ctx *c, const warp_splat_params *p, int32_t k0, int32_t k1, int32_t k2)
{
    const warp_fwd_scratch *sc = c->sc;
    if (!(sc->x2[k0] == sc->x2[k0]) || !(sc->x2[k1] == sc->x2[k1]) || !(sc->x2[k2] == sc->x2[k2])) return false;
    const warp_image_f32 *di = c->v->inv_depth;
    int w = c->v->color->w;
    float d0 = WARP_AT(di, k0 % w, k0 / w), d1 = WARP_AT(di, k1 % w, k1 / w), d2 = WARP_AT(di, k2 % w, k2 / w);
    float mx = fmaxf(d0, fmaxf(d1, d2)), mn = fminf(d0, fminf(d1, d2));
    if (mx - mn > p->edge_jump * mx) return false;
    if (c->v->ids) {
        const warp_image_u16 *id = c->v->ids;
        uint16_t i0 = WARP_AT(id, k0 % w, k0 / w);
        if (WARP_AT(id, k1 % w, k1 / w) != i0 || WARP_AT(id, k2 % w, k2 / w) != i0) return false;
    }
    return true;
}

static vtx vertex(const draw_ctx *c, int32_t k)
{
    vtx v = {c->sc->x2[k], c->sc->y2[k], c->sc->d2[k], WARP_AT(c->v->color, k % c->v->color->w, k / c->v->color->w)};
    return v;
}

/* One triangle (k0, k1, k2) of a mesh cell: drawn when its samples are connected and it passes triangle()'s tests,
 * else counted as culled. always_inline: the cell loop is the mesh's hot path and calls this twice a pixel. */
static inline __attribute__((always_inline)) void mesh_triangle(draw_ctx *c, const warp_splat_params *p, int32_t k0,
                                                                int32_t k1, int32_t k2, long *prims, long *culled)
{
    if (connected(c, p, k0, k1, k2)) {
        vtx a = vertex(c, k0), b = vertex(c, k1), t = vertex(c, k2);
        if (triangle(c, p, &a, &b, &t))
            (*prims)++;
        else
            (*culled)++;
    } else {
        (*culled)++;
    }
}

/* Whether source samples (x, y) and (u, v) lie on one surface: both mapped, one object, no depth edge between. */
static inline bool joined(const draw_ctx *c, const warp_splat_params *p, int x, int y, int u, int v)
{
    const warp_fwd_scratch *sc = c->sc;
    const int w = c->v->color->w;
    if (!(sc->x2[v * w + u] == sc->x2[v * w + u])) return false;
    float d0 = WARP_AT(c->v->inv_depth, x, y), d1 = WARP_AT(c->v->inv_depth, u, v);
    if (fabsf(d0 - d1) > p->edge_jump * (d0 > d1 ? d0 : d1)) return false;
    return !c->v->ids || WARP_AT(c->v->ids, x, y) == WARP_AT(c->v->ids, u, v);
}

static void mesh_skirt(draw_ctx *c, const warp_splat_params *p, int x, int y)
{
    const warp_fwd_scratch *sc = c->sc;
    const int w = c->v->color->w, h = c->v->color->h;
    const int32_t k = y * w + x;
    if (!(sc->x2[k] == sc->x2[k])) return;
    bool l = x > 0 && joined(c, p, x, y, x - 1, y), r = x + 1 < w && joined(c, p, x, y, x + 1, y);
    bool u = y > 0 && joined(c, p, x, y, x, y - 1), d = y + 1 < h && joined(c, p, x, y, x, y + 1);
    if ((l || x == 0) && (r || x + 1 == w) && (u || y == 0) && (d || y + 1 == h)) return; /* inside a surface */
    if (!(l || r) || !(u || d)) return; /* a sliver: no footprint to span; the point pass below draws it */
    int32_t xa = r ? k + 1 : k, xb = r ? k : k - 1, ya = d ? k + w : k, yb = d ? k : k - w;
    double ax = 0.5 * (sc->x2[xa] - sc->x2[xb]), ay = 0.5 * (sc->y2[xa] - sc->y2[xb]);
    double bx = 0.5 * (sc->x2[ya] - sc->x2[yb]), by = 0.5 * (sc->y2[ya] - sc->y2[yb]);
    double ex = fabs(ax) + fabs(bx), ey = fabs(ay) + fabs(by), det = ax * by - bx * ay;
    if (!(fabs(det) > 1e-4) || !(2 * ex <= p->max_extent && 2 * ey <= p->max_extent)) return;
    double cx = sc->x2[k], cy = sc->y2[k];
    const float dk = sc->d2[k], behind = dk * (1 - p->edge_jump);
    const warp_rgba8 col = WARP_AT(c->v->color, x, y);
    int x0, x1, y0, y1;
    span(cx - ex, cx + ex + 1e-9, sc->dst_w, &x0, &x1);
    span(cy - ey, cy + ey + 1e-9, sc->dst_h, &y0, &y1);
    for (int j = y0; j < y1; j++) {
        double dy = j + 0.5 - cy;
        for (int i = x0; i < x1; i++) {
            double dx = i + 0.5 - cx;
            double al = (by * dx - bx * dy) / det, be = (ax * dy - ay * dx) / det;
            if (!(al >= -1 && al < 1 && be >= -1 && be < 1)) continue;
            float z = sc->zbuf[j * sc->dst_w + i];
            if (z < 0 || z < behind) fragment(c, i, j, dk, col);
        }
    }
}

void warp_splat_draw(const warp_fwd_setup *s, warp_fwd_scratch *sc, const warp_splat_params *p,
                     warp_image_rgba8 *dst, warp_splat_stats *st)
{
    draw_ctx c = {s->src, sc, dst, p->vis == WARP_FWD_ZBUFFER, 0, 0, 0};
    const int w = s->src->color->w, h = s->src->color->h, n = w * h;
    long prims = 0, culled = 0;
    for (int q = 0; q < n; q++) {
        int32_t k = sc->order[q];
        if (p->kind == WARP_SPLAT_MESH) {
            /* The cell whose top-left corner is this pixel: triangles (00, 10, 01) and (10, 11, 01). */
            int x = k % w, y = k / w;
            if (x + 1 >= w || y + 1 >= h) continue;
            int32_t k10 = k + 1, k01 = k + w, k11 = k + w + 1;
            mesh_triangle(&c, p, k, k10, k01, &prims, &culled);
            mesh_triangle(&c, p, k10, k11, k01, &prims, &culled);
            continue;
        }
        if (!(sc->x2[k] == sc->x2[k])) continue; /* behind the target eye */
        /* a splat centred far outside cannot reach in */
        float m = (float)(p->kind == WARP_SPLAT_QUAD ? p->max_extent : p->max_size);
        if (sc->x2[k] < -m || sc->y2[k] < -m || sc->x2[k] > sc->dst_w + m || sc->y2[k] > sc->dst_h + m) continue;
        prims++;
        if (p->kind == WARP_SPLAT_QUAD) {
            if (!quad_splat(&c, p, k)) culled++;
        } else {
            point_splat(&c, p, k);
        }
    }
    if (p->kind == WARP_SPLAT_MESH) {
        /* raster order: a footprint only writes over a surface farther by a depth edge, so order hardly matters */
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) mesh_skirt(&c, p, x, y);
        /* Samples cut off from every triangle (slivers between depth edges, the last column and row) still show
         * as points where nothing else landed, as a 1-pixel forward warp would draw them. */
        for (int q = 0; q < n; q++) {
            int32_t k = sc->order[q];
            float x = sc->x2[k], y = sc->y2[k];
            if (!(x >= 0 && y >= 0 && x < (float)sc->dst_w && y < (float)sc->dst_h)) continue;
            int i = (int)x, j = (int)y;
            if (i >= sc->dst_w || j >= sc->dst_h || sc->zbuf[j * sc->dst_w + i] >= 0) continue;
            fragment(&c, i, j, sc->d2[k], WARP_AT(s->src->color, k % w, k / w));
            prims++;
        }
    }
    if (st) {
        st->primitives += prims;
        st->culled += culled;
        st->fragments += c.fragments;
        st->fwd.writes += c.writes;
        st->fwd.depth_rejects += c.rejects;
    }
}

const char *warp_splat_check_params(const warp_splat_params *p)
{
    if (p->kind != WARP_SPLAT_POINT && p->kind != WARP_SPLAT_QUAD && p->kind != WARP_SPLAT_MESH)
        return "unknown splat kind";
    if (p->min_size < 1 || p->max_size < p->min_size) return "point splat sizes must satisfy 1 <= min <= max";
    if (!(p->max_extent >= 1)) return "splat extent must be at least 1 pixel";
    return NULL;
}

const char *warp_splat_run(const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose,
                           const warp_splat_params *p, warp_fwd_scratch *sc, warp_image_rgba8 *dst,
                           warp_image_u8 *mask, warp_splat_stats *st)
{
    const char *err = warp_splat_check_params(p);
    if (err) return err;
    warp_forward_params fp = warp_forward_default_params();
    fp.vis = p->vis;
    fp.edge_jump = p->edge_jump;
    warp_fwd_setup s;
    err = warp_forward_prepare(&s, src, dst_cam, dst_pose, &fp);
    if (err) return err;
    err = warp_fwd_check_sizes(src, dst_cam, sc, dst, mask);
    if (err) return err;
    warp_splat_stats local;
    memset(&local, 0, sizeof local);
    warp_forward_map_rows(&s, sc, p->kind != WARP_SPLAT_MESH, 0, src->color->h, &local.fwd);
    local.fwd.sheets = warp_forward_order(&s, p->vis, sc);
    warp_forward_clear(sc);
    warp_splat_draw(&s, sc, p, dst, &local);
    warp_forward_finish_rows(&s, sc, dst, mask, 0, dst->h, &local.fwd);
    if (st) *st = local;
    return NULL;
}

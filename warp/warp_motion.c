/* SPDX-License-Identifier: MIT */
/* warp_motion: the motion buffer of 001 §3.1 (where each source pixel lands in the target view, from its depth, the
 * camera motion and per-object motion) and the min-max motion mipmap of 001 §3.3 that bounds the iterative search. */
#include "warp/warp_motion.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

bool warp_motion_alloc(warp_motion_buffer *m, int w, int h)
{
    memset(m, 0, sizeof *m);
    if (w <= 0 || h <= 0 || w > WARP_MAX_SIDE || h > WARP_MAX_SIDE) return false;
    m->px = calloc((size_t)w * (size_t)h, sizeof *m->px);
    if (!m->px) return false;
    m->w = w;
    m->h = h;
    return true;
}

void warp_motion_free(warp_motion_buffer *m)
{
    free(m->px);
    memset(m, 0, sizeof *m);
}

/* target_eye_from_source_eye for a pixel of object `id` (0 = static): the camera motion, composed with the
 * object's motion when its poses at both times are known. */
static warp_pose eye_transform(const warp_motion_setup *s, int id)
{
    warp_pose src = s->src_pose;
    if (id > 0 && id <= s->n_objects && s->src_object_pose && s->dst_object_pose) {
        /* source eye -> world -> object (at the source time) -> world (at the target time) */
        warp_pose obj = warp_pose_mul(s->dst_object_pose[id - 1], warp_pose_inverse(s->src_object_pose[id - 1]));
        src = warp_pose_mul(obj, src);
    }
    /* relative() subtracts positions first: precision for heads far from the world origin */
    return warp_pose_relative(s->dst_pose, src);
}

void warp_motion_compute_rows(warp_motion_buffer *m, const warp_motion_setup *s, const warp_image_f32 *inv_depth,
                              const warp_image_u16 *ids, const warp_image_vec2f *motion, int y0, int y1)
{
    const bool exact_objects = s->src_object_pose && s->dst_object_pose && s->n_objects > 0;
    const bool plane_motion = !exact_objects && motion && s->dt != 0;
    const warp_mat3 kinv = warp_camera_K_inverse(&s->src_cam), kd = warp_camera_K(&s->dst_cam);
    int cur_id = -1;
    warp_mat3 a = {{{0}}}; /* K_dst R: homogeneous target pixel of a source direction */
    warp_vec3 kt = {0, 0, 0}; /* K_dst t: what a unit of inverse depth adds (parallax) */
    if (y0 < 0) y0 = 0;
    if (y1 > m->h) y1 = m->h;
    for (int y = y0; y < y1; y++) {
        const float *drow = &WARP_AT(inv_depth, 0, y);
        const uint16_t *irow = ids ? &WARP_AT(ids, 0, y) : NULL;
        const warp_vec2f *mrow = motion ? &WARP_AT(motion, 0, y) : NULL;
        warp_motion_texel *out = m->px + (size_t)y * (size_t)m->w;
        for (int x = 0; x < m->w; x++) {
            const float d = drow[x];
            warp_motion_texel t = {0, 0, -1};
            if (!(d >= 0)) { /* empty (or NaN): no surface */
                out[x] = t;
                continue;
            }
            int id = exact_objects && irow ? irow[x] : 0;
            if (id > s->n_objects) id = 0;
            if (id != cur_id) {
                warp_pose e = eye_transform(s, id);
                warp_mat3 r = warp_quat_to_mat3(e.q);
                a = warp_mat3_mul(&kd, &r);
                a = warp_mat3_mul(&a, &kinv);
                kt = warp_mat3_apply(&kd, e.p);
                cur_id = id;
            }
            double qx = x + 0.5, qy = y + 0.5;
            if (plane_motion && mrow && (mrow[x].x != 0 || mrow[x].y != 0)) {
                /* first order: the object's point slides along its screen motion at constant inverse depth */
                qx += mrow[x].x * s->dt;
                qy += mrow[x].y * s->dt;
            }
            /* P_dst = R P_src + t with P_src = K^-1 q / d: in homogeneous target pixels, d-scaled,
             * h = K R K^-1 q + d K t; the target inverse depth is d / h.w (K's last row gives w = -Z). */
            double hx = a.m[0][0] * qx + a.m[0][1] * qy + a.m[0][2] + d * kt.x;
            double hy = a.m[1][0] * qx + a.m[1][1] * qy + a.m[1][2] + d * kt.y;
            double hw = a.m[2][0] * qx + a.m[2][1] * qy + a.m[2][2] + d * kt.z;
            if (hw > 1e-9) {
                double iw = 1.0 / hw;
                t.x = (float)(hx * iw - (x + 0.5));
                t.y = (float)(hy * iw - (y + 0.5));
                t.d = (float)(d * iw);
                /* absurd motions (points grazing the target eye plane) are unusable: empty */
                if (!(fabsf(t.x) < 1e6f && fabsf(t.y) < 1e6f)) t = (warp_motion_texel){0, 0, -1};
            }
            out[x] = t;
        }
    }
}

double warp_motion_pca(const warp_motion_buffer *m, int samples)
{
    /* 001 §3.3: "a small number (e.g., 64) usually suffices" */
    if (samples < 4) samples = 4;
    int g = (int)ceil(sqrt((double)samples));
    double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
    long n = 0;
    for (int j = 0; j < g; j++)
        for (int i = 0; i < g; i++) {
            int x = (int)((i + 0.5) * m->w / g), y = (int)((j + 0.5) * m->h / g);
            const warp_motion_texel *t = &m->px[(size_t)y * (size_t)m->w + (size_t)x];
            if (!(t->d >= 0)) continue;
            sx += t->x;
            sy += t->y;
            sxx += (double)t->x * t->x;
            syy += (double)t->y * t->y;
            sxy += (double)t->x * t->y;
            n++;
        }
    if (n < 2) return 0;
    double mx = sx / n, my = sy / n;
    double cxx = sxx / n - mx * mx, cyy = syy / n - my * my, cxy = sxy / n - mx * my;
    if (fabs(cxy) < 1e-12 && cxx >= cyy) return 0;
    return 0.5 * atan2(2 * cxy, cxx - cyy);
}

bool warp_motion_mip_alloc(warp_motion_mip *mip, int w, int h)
{
    memset(mip, 0, sizeof *mip);
    if (w <= 0 || h <= 0 || w > WARP_MAX_SIDE || h > WARP_MAX_SIDE) return false;
    size_t total = 0;
    int lw = w, lh = h, n = 0;
    for (;;) {
        mip->w[n] = lw;
        mip->h[n] = lh;
        total += (size_t)lw * (size_t)lh;
        n++;
        if (lw == 1 && lh == 1) break;
        lw = (lw + 1) / 2;
        lh = (lh + 1) / 2;
    }
    mip->levels = n;
    warp_motion_box *mem = calloc(total, sizeof *mem);
    if (!mem) {
        memset(mip, 0, sizeof *mip);
        return false;
    }
    mip->mem = mem;
    for (int i = 0; i < n; i++) {
        mip->lvl[i] = mem;
        mem += (size_t)mip->w[i] * (size_t)mip->h[i];
    }
    mip->c = 1;
    return true;
}

void warp_motion_mip_free(warp_motion_mip *mip)
{
    free(mip->mem);
    memset(mip, 0, sizeof *mip);
}

static inline void box_union(warp_motion_box *a, const warp_motion_box *b)
{
    for (int k = 0; k < 2; k++) {
        if (b->lo[k] < a->lo[k]) a->lo[k] = b->lo[k];
        if (b->hi[k] > a->hi[k]) a->hi[k] = b->hi[k];
    }
}

static const warp_motion_box empty_box = {{INFINITY, INFINITY}, {-INFINITY, -INFINITY}};

void warp_motion_mip_build(warp_motion_mip *mip, const warp_motion_buffer *m, const warp_motion_buffer *const *fallback,
                           int n_fallback, double theta)
{
    mip->theta = theta;
    mip->c = cos(theta);
    mip->s = sin(theta);
    for (int y = 0; y < m->h; y++)
        for (int x = 0; x < m->w; x++) {
            const size_t i = (size_t)y * (size_t)m->w + (size_t)x;
            const warp_motion_texel *t = &m->px[i];
            for (int k = 0; k < n_fallback && !(t->d >= 0); k++) t = &fallback[k]->px[i];
            warp_motion_box b = empty_box;
            if (t->d >= 0) {
                double a, c;
                warp_motion_rotate(mip->c, mip->s, t->x, t->y, &a, &c);
                /* float rounding of the rotated value must not make the bound exclude the texel itself */
                b.lo[0] = nextafterf((float)a, -INFINITY);
                b.hi[0] = nextafterf((float)a, INFINITY);
                b.lo[1] = nextafterf((float)c, -INFINITY);
                b.hi[1] = nextafterf((float)c, INFINITY);
            }
            mip->lvl[0][(size_t)y * (size_t)m->w + (size_t)x] = b;
        }
    for (int l = 1; l < mip->levels; l++) {
        const warp_motion_box *src = mip->lvl[l - 1];
        const int sw = mip->w[l - 1], sh = mip->h[l - 1];
        for (int y = 0; y < mip->h[l]; y++)
            for (int x = 0; x < mip->w[l]; x++) {
                warp_motion_box b = empty_box;
                for (int j = 0; j < 2; j++)
                    for (int i = 0; i < 2; i++) {
                        int xs = 2 * x + i, ys = 2 * y + j;
                        if (xs < sw && ys < sh) box_union(&b, &src[(size_t)ys * (size_t)sw + (size_t)xs]);
                    }
                mip->lvl[l][(size_t)y * (size_t)mip->w[l] + (size_t)x] = b;
            }
    }
}

warp_motion_box warp_motion_mip_query(const warp_motion_mip *mip, double x0, double y0, double x1, double y1)
{
    const int w = mip->w[0], h = mip->h[0];
    if (!(x0 <= x1 && y0 <= y1)) return empty_box;
    /* texels a bilinear lookup in the rectangle touches (centres at +0.5), clamped like the lookups */
    double fx0 = floor(x0 - 0.5), fy0 = floor(y0 - 0.5), fx1 = floor(x1 - 0.5) + 1, fy1 = floor(y1 - 0.5) + 1;
    int ix0 = fx0 < 0 ? 0 : (fx0 > w - 1 ? w - 1 : (int)fx0);
    int iy0 = fy0 < 0 ? 0 : (fy0 > h - 1 ? h - 1 : (int)fy0);
    int ix1 = fx1 < 0 ? 0 : (fx1 > w - 1 ? w - 1 : (int)fx1);
    int iy1 = fy1 < 0 ? 0 : (fy1 > h - 1 ? h - 1 : (int)fy1);
    int span = ix1 - ix0 > iy1 - iy0 ? ix1 - ix0 : iy1 - iy0;
    /* smallest level whose texels are at least `span` wide: span + 1 consecutive texels then fall in at most two
     * of its texels per axis, and the four corner texels cover them (001 §3.3: level ceil(log2 max(a, b))) */
    int l = 0;
    while (l < mip->levels - 1 && (1 << l) < span) l++;
    int ax = ix0 >> l, ay = iy0 >> l, bx = ix1 >> l, by = iy1 >> l;
    const warp_motion_box *lv = mip->lvl[l];
    const size_t lw = (size_t)mip->w[l];
    warp_motion_box r = lv[(size_t)ay * lw + (size_t)ax];
    box_union(&r, &lv[(size_t)ay * lw + (size_t)bx]);
    box_union(&r, &lv[(size_t)by * lw + (size_t)ax]);
    box_union(&r, &lv[(size_t)by * lw + (size_t)bx]);
    return r;
}

/* SPDX-License-Identifier: MIT */
/* sim_render: the ground-truth ray caster behind sim_render_rows: analytic ray/primitive intersection, screen-tile
 * culling, view-independent band-limited shading, and only the planes (colour, depth, ids, motion, layers) asked for. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "sim/sim_internal.h"
#include "sim/sim_scene.h"
#include "warp/warp_srgb.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

/* Tiles for culling: each pixel tests only the primitives whose bounding capsule can reach its tile. Tiles are
 * aligned to absolute pixel coordinates so that a pixel sees the same candidates whatever the row split. */
#define TILE 16
/* Transparent fragments gathered per pixel before keeping the nearest max_layers (all of them are blended). */
#define MAX_FRAGS 16
/* Box-filter width of the textures in pixel footprints: wide enough that a bilinear resampling of a render
 * matches a render from the resampled pose (the rotation warp of "room" must stay well above 30 dB). */
#define FILTER_PX 1.6f

/* Pixels are traced and shaded in groups of 4 along a row with GCC/Clang vector extensions (SSE2 on x86-64, NEON
 * on aarch64; only min/max use an SSE intrinsic, with a generic fallback). Groups are aligned to absolute x, and
 * every pixel goes through the same vector code whatever its neighbours, so results do not depend on how rows are
 * split or which path a neighbour took. */
#define VW 4
typedef float v4f __attribute__((vector_size(16)));
typedef int32_t v4i __attribute__((vector_size(16)));
typedef uint32_t v4u __attribute__((vector_size(16)));

typedef struct {
    float m[3][3];    /* object_from_camera rotation: d_obj = m d_cam */
    float o[3];       /* camera origin in the object frame */
    float size[3];
    float k0;         /* per-call constant of the quadric: |o|^2 - r^2 (sphere), ox^2 + oz^2 - r^2 (cylinder) */
    float zmin;       /* lower bound of the planar depth of the primitive (front-to-back culling order) */
    float rgb[3], alpha;
    float light[2][3];      /* the fixed world lights in the object frame */
    float face_light[6];    /* lighting of each planar face (box, room; rect uses face 0) */
    float face_rgb[6][3];   /* base colour of each planar face */
    float tex_inv_scale;    /* pattern units per metre */
    float vc[3], wc[3], cc[3]; /* camera-frame velocity of the origin, angular velocity, origin (motion plane) */
    double ca[3], cb[3], cr;   /* bounding capsule in the camera frame: segment ca-cb, radius cr */
    int type, tex, id;
    bool moving, unbounded, transparent;
} prim;

typedef struct {
    int *start; /* [ntiles + 1] */
    int *item;  /* primitive indices per tile, sorted by (zmin, index) */
} bins;

typedef struct {
    const warp_camera *cam;
    prim *p;
    int n;
    int nc, tr0, tr1;          /* tile columns; tile rows [tr0, tr1) of this call */
    double *colu, *coln;       /* column boundary k: u_k and 1/sqrt(1 + u_k^2) */
    double *rowv, *rown;       /* row boundary k (absolute tile row index tr0 + k) */
} setup;

/* ---- vector helpers (written so that compilers emit plain min/max/and/or; NaN goes to the lower bound) ---- */

static inline v4f vf(float x) { return (v4f){x, x, x, x}; }
static inline v4i vi(int32_t x) { return (v4i){x, x, x, x}; }
static inline v4f vsel(v4i m, v4f a, v4f b) { return (v4f)((m & (v4i)a) | (~m & (v4i)b)); }
static inline v4i visel(v4i m, v4i a, v4i b) { return (m & a) | (~m & b); }
#if defined(__SSE2__)
/* one instruction each, with exactly the semantics of the generic form below */
static inline v4f vmin(v4f a, v4f b) { return (v4f)_mm_min_ps((__m128)a, (__m128)b); }
static inline v4f vmax(v4f a, v4f b) { return (v4f)_mm_max_ps((__m128)a, (__m128)b); }
#else
static inline v4f vmin(v4f a, v4f b) { return vsel(a < b, a, b); }
static inline v4f vmax(v4f a, v4f b) { return vsel(a > b, a, b); }
#endif
static inline v4f vclamp(v4f x, float lo, float hi) { return vmin(vmax(x, vf(lo)), vf(hi)); }
static inline v4f vabs(v4f x) { return (v4f)((v4i)x & vi(0x7fffffff)); }
/* Round to nearest for |x| < 2^22 by the float magic number: no conversions, defined for any input. */
static inline v4f vround(v4f x) { return (x + 12582912.0f) - 12582912.0f; }
/* 1/sqrt by the bit-level first guess and Newton steps (2 steps: 5e-6, 3 steps: float precision). */
static inline v4f vrsqrt(v4f x, int steps)
{
    v4f y = (v4f)((v4u){0x5f3759df, 0x5f3759df, 0x5f3759df, 0x5f3759df} - ((v4u)x >> 1));
    v4f hx = x * 0.5f;
    for (int i = 0; i < steps; i++) y = y * (1.5f - hx * y * y);
    return y;
}
static inline v4f vsqrt(v4f x) { return x * vrsqrt(x, 3); } /* exact 0 at 0; x >= 0 */
/* [0, 1] -> 0..255 rounded, as to_u8 below does per channel */
static inline v4u vquant(v4f c) { return (v4u)__builtin_convertvector(vclamp(c, 0.0f, 1.0f) * 255.0f + 0.5f, v4i); }

typedef struct { v4f x, y, z; } v3f;

/* ---- scalar helpers (transparent fragments) ---- */

static inline float minf_(float a, float b) { return a < b ? a : b; }
static inline float maxf_(float a, float b) { return a > b ? a : b; }
static inline float clampf(float x, float lo, float hi) { return minf_(maxf_(x, lo), hi); }
static inline float round_near(float x) { return (x + 12582912.0f) - 12582912.0f; }
static inline uint8_t to_u8(float v) { return (uint8_t)(int)(clampf(v, 0.0f, 1.0f) * 255.0f + 0.5f); }

/* ---- band-limited pattern primitives ---- */

static inline v4f vsmooth01(v4f x)
{
    x = vclamp(x, 0.0f, 1.0f);
    return x * x * (3.0f - 2.0f * x);
}
/* sin(2 pi x) to ~0.1 %: a refined parabola, cheaper than sinf and identical on every platform. */
static inline v4f vwave(v4f x)
{
    x = vclamp(x - vround(x), -0.5f, 0.5f); /* the clamp only matters for |x| >= 2^22 */
    v4f y = 8.0f * x - 16.0f * x * vabs(x);
    return y + 0.225f * (y * vabs(y) - y);
}
static inline float wave1(float x)
{
    x = clampf(x - round_near(x), -0.5f, 0.5f);
    float y = 8.0f * x - 16.0f * x * fabsf(x);
    return y + 0.225f * (y * fabsf(y) - y);
}
/* Contrast left of a sinusoid with `c` cycles per filter width: 1 while well resolved, 0 before it aliases. */
static inline v4f vfade(v4f c) { return 1.0f - vsmooth01((c - 0.12f) * 3.0f); }
/* Square wave of period 2 (cells of size 1, values +-1) box-filtered over width w (iw = 1/w): within a cell it
 * is the signed distance to the nearest edge over w/2, clamped, i.e. the exact box filter while at most one edge
 * falls in the window (w <= 1); wider windows fade it to the mean, reaching 0 at w = 2. */
static inline v4f vsqw(v4f x, v4f w, v4f iw)
{
    x = x * 0.5f - 0.25f;
    v4f e = x - vround(x); /* 0 mid +1 cell, +-0.5 mid -1 cell (|e| > 0.5 only for absurd |x|: clamped) */
    return vclamp((1.0f - 4.0f * vabs(e)) * iw, -1.0f, 1.0f) * vclamp(2.0f - w, 0.0f, 1.0f);
}
/* sqrt(1 + r^2) within 4 %, never below: the footprint stretch of a surface seen at a slant. */
static inline v4f vstretch(v4f r)
{
    r = vmin(vabs(r), vf(100.0f));
    return vsel(r > 1.0f, r + 0.41f, 1.0f + 0.41f * r);
}
static inline v4f vatan2(v4f y, v4f x) /* max error ~1e-5 rad */
{
    v4f ax = vabs(x), ay = vabs(y);
    v4f mx = vmax(ax, ay), mn = vmin(ax, ay);
    v4f a = mn / vsel(mx > 0.0f, mx, vf(1.0f)), s = a * a;
    v4f r = ((-0.0464964749f * s + 0.15931422f) * s - 0.327622764f) * s * a + a;
    r = vsel(ay > ax, 1.57079637f - r, r);
    r = vsel(x < 0.0f, 3.14159274f - r, r);
    return vsel(y < 0.0f, -r, r);
}

/* ---- textures: functions of object-space position only, filtered over the pixel footprint ---- */

/* 2D surface pattern, a, b and the footprints wa, wb in pattern units: 0.5-unit tiles, 0.1-unit fine tiles,
 * diagonal stripes (0.23 units) and slow colour gradients (~3 units), so that a misregistered warp shows errors
 * at several scales. */
static inline void pattern2d(v4f a, v4f b, v4f wa, v4f wb, const float base[3], v3f *out)
{
    v4f iwa = 1.0f / wa, iwb = 1.0f / wb;
    v4f big = vsqw(a * 2.0f + 0.37f, wa * 2.0f, iwa * 0.5f) * vsqw(b * 2.0f + 0.61f, wb * 2.0f, iwb * 0.5f);
    v4f small = vsqw(a * 10.0f + 0.5f, wa * 10.0f, iwa * 0.1f) * vsqw(b * 10.0f + 0.5f, wb * 10.0f, iwb * 0.1f);
    const float fs = 1.0f / 0.23f;
    v4f stripe = vwave((a + 0.6f * b) * fs) * vfade(vmax(wa, wb) * (fs * 1.17f));
    v4f lum = 1.0f + 0.18f * big + 0.07f * small + 0.07f * stripe;
    v4f gr = vwave(a * (1.0f / 3.1f) + 0.13f), gg = vwave(b * (1.0f / 2.3f) + 0.41f);
    out->x = base[0] * lum * (1.0f + 0.12f * gr);
    out->y = base[1] * lum * (1.0f + 0.12f * gg);
    out->z = base[2] * lum * (1.0f - 0.06f * (gr + gg));
}

/* 3D (solid) pattern for curved surfaces, metres, isotropic footprint w: no parametrisation, no poles. */
static inline void pattern3d(v3f p, v4f w, const float base[3], v3f *out)
{
    v4f w4 = w * 4.0f, iw = 1.0f / w4;
    v4f big = vsqw(p.x * 4.0f + 0.29f, w4, iw) * vsqw(p.y * 4.0f + 0.53f, w4, iw) * vsqw(p.z * 4.0f + 0.71f, w4, iw);
    const float fs = 1.0f / 0.12f;
    v4f stripe = vwave((p.y + 0.3f * p.x) * fs) * vfade(w * fs);
    v4f lum = 1.0f + 0.18f * big + 0.08f * stripe;
    v4f g = vwave((p.x + p.z) * 0.9f);
    out->x = base[0] * lum * (1.0f + 0.10f * g);
    out->y = base[1] * lum * (1.0f + 0.10f * vwave(p.y * 0.9f + 0.3f));
    out->z = base[2] * lum * (1.0f - 0.10f * g);
}

/* Sky at infinity: a function of the world direction (plus the pixel size, which only matters for cameras far
 * finer than 1/3 degree per pixel): horizon-to-zenith gradient, soft grid (meridians every 15 degrees of
 * azimuth, parallels every 0.25 in sin(elevation)), band-limited clouds. */
static void sky_color(v3f d, v4f pix, v3f *out)
{
    v4f inv = vrsqrt(d.x * d.x + d.y * d.y + d.z * d.z, 3);
    v4f x = d.x * inv, y = d.y * inv, z = d.z * inv;
    v4f h2 = x * x + z * z, horiz = h2 * vrsqrt(vmax(h2, vf(1e-12f)), 2);
    v4f az = vatan2(x, -z);
    v4f su = 1.0f - (1.0f - y) * (1.0f - y), sd = vclamp(-y * 3.0f, 0.0f, 1.0f);
    v4i up = y >= 0.0f;
    v3f base = {vsel(up, 0.80f + (0.28f - 0.80f) * su, 0.80f + (0.50f - 0.80f) * sd),
                vsel(up, 0.85f + (0.46f - 0.85f) * su, 0.85f + (0.50f - 0.85f) * sd),
                vsel(up, 0.93f + (0.86f - 0.93f) * su, 0.93f + (0.55f - 0.93f) * sd)};
    /* line half-width 0.35 degrees or 1.5 pixels, whichever is wider, keeping the line's integral */
    const float step = 0.261799388f, hw0 = 0.006f;
    v4f hw = vmax(1.5f * pix, vf(hw0)), ihw = 1.0f / hw, gain = hw0 * ihw;
    v4f e = y * 4.0f;
    v4f de = vabs(e - vround(e)) * 0.25f * ihw / vmax(horiz, vf(0.05f));
    v4f a = az * (1.0f / step);
    v4f da = vabs(a - vround(a)) * step * horiz * ihw;
    v4f le = vmax(1.0f - de * de, vf(0.0f)), la = vmax(1.0f - da * da, vf(0.0f));
    le = le * le;
    la = la * la * vsmooth01((horiz - 0.15f) * 5.0f); /* meridians converge at the zenith */
    v4f grid = gain * vmax(le, la);
    /* clouds: plane waves over the direction sphere (1.6-5.3 cycles per radian) */
    v4f c = 0.45f * vwave(1.3f * x + 0.4f * y - 0.9f * z + 0.10f) + 0.35f * vwave(-0.7f * x + 1.1f * y + 1.6f * z + 0.35f);
    c += (0.25f * vwave(2.6f * x - 0.5f * y + 0.8f * z + 0.62f) + 0.15f * vwave(3.7f * x + 1.5f * y + 3.1f * z + 0.83f)) *
         vfade(pix * 20.0f);
    v4f cloud = vsmooth01((c - 0.05f) * 1.6f) * vsmooth01(y * 8.0f) * 0.7f, dark = 1.0f - 0.35f * grid;
    out->x = (base.x + (0.97f - base.x) * cloud) * dark;
    out->y = (base.y + (0.97f - base.y) * cloud) * dark;
    out->z = (base.z + (0.97f - base.z) * cloud) * dark;
}

/* ---- lighting: Lambert with two fixed directional lights and ambient (view-independent) ---- */

static const double light_dir[2][3] = {{0.35, 0.85, 0.40}, {-0.60, 0.20, -0.75}};
static const float light_gain[2] = {0.50f, 0.22f};
#define AMBIENT 0.42f

static float lighting(const prim *p, const float n[3])
{
    float l = AMBIENT;
    for (int i = 0; i < 2; i++) {
        float d = n[0] * p->light[i][0] + n[1] * p->light[i][1] + n[2] * p->light[i][2];
        if (d > 0) l += light_gain[i] * d;
    }
    return l;
}

static inline v4f vlighting(const prim *p, v3f n)
{
    v4f l = vf(AMBIENT);
    for (int i = 0; i < 2; i++) {
        v4f d = n.x * p->light[i][0] + n.y * p->light[i][1] + n.z * p->light[i][2];
        l += light_gain[i] * vmax(d, vf(0.0f));
    }
    return l;
}

/* ---- intersection ----
 * Rays are d = (u, v, -1) in the camera frame, so the ray parameter is the planar depth z. A miss is INFINITY.
 * face: box/room: axis * 2 + (1 if the face is on the + side); cylinder: 0 side, 1 cap; others 0. */

static inline v3f vto_object(const prim *p, v4f u, v4f v)
{
    v3f d = {p->m[0][0] * u + p->m[0][1] * v - p->m[0][2], p->m[1][0] * u + p->m[1][1] * v - p->m[1][2],
             p->m[2][0] * u + p->m[2][1] * v - p->m[2][2]};
    return d;
}

static inline v4f vnz(v4f x) { return vsel(x == 0.0f, vf(1e-30f), x); } /* keeps divisions finite */

/* Near and far roots of a t^2 + 2 b t + k0 = 0 in the stable form (exact near root for small, far quadrics). */
static inline v4i vroots(v4f a, v4f b, float k0, v4f *t0, v4f *t1)
{
    v4f disc = b * b - a * k0;
    v4f sq = vsqrt(vmax(disc, vf(0.0f)));
    v4f q = vsel(b > 0.0f, -(b + sq), sq - b);
    v4f r0 = k0 / vnz(q), r1 = q / vnz(a);
    v4i sw = r0 > r1;
    *t0 = vsel(sw, r1, r0);
    *t1 = vsel(sw, r0, r1);
    return disc >= 0.0f;
}

static inline __attribute__((always_inline)) v4f vhit(const prim *p, v3f d, float nearz, v4i *face)
{
    const float *o = p->o, *s = p->size;
    const v4f inf = vf(INFINITY);
    switch (p->type) {
    case SIM_PRIM_ROOM: { /* exit point of the box: the wall seen from inside */
        /* t_i = n_i / |d_i| with n_i the distance to the wall ahead on axis i; the smallest is picked by
         * cross-multiplying, then one division */
        v4i p0 = d.x > 0.0f, p1 = d.y > 0.0f, p2 = d.z > 0.0f;
        v4f n0 = vsel(p0, vf(s[0] - o[0]), vf(s[0] + o[0])), a0 = vabs(d.x);
        v4f n1 = vsel(p1, vf(s[1] - o[1]), vf(s[1] + o[1])), a1 = vabs(d.y);
        v4f n2 = vsel(p2, vf(s[2] - o[2]), vf(s[2] + o[2])), a2 = vabs(d.z);
        v4f nb = n0, ab = a0;
        v4i f = p0 & 1;
        v4i m = n1 * ab < nb * a1;
        nb = vsel(m, n1, nb), ab = vsel(m, a1, ab), f = visel(m, 2 + (p1 & 1), f);
        m = n2 * ab < nb * a2;
        nb = vsel(m, n2, nb), ab = vsel(m, a2, ab), f = visel(m, 4 + (p2 & 1), f);
        *face = f;
        v4f th = nb / ab;
        return vsel(th >= nearz, th, inf);
    }
    case SIM_PRIM_BOX: {
        v4f tn = vf(-INFINITY), tf = inf;
        v4i fn = vi(0), ff = vi(0);
        const v4f dd[3] = {d.x, d.y, d.z};
        for (int i = 0; i < 3; i++) {
            v4f inv = 1.0f / vnz(dd[i]);
            v4f a = (-s[i] - o[i]) * inv, b = (s[i] - o[i]) * inv;
            v4i sw = a > b;
            v4f lo = vsel(sw, b, a), hi = vsel(sw, a, b);
            v4i flo = visel(sw, vi(i * 2 + 1), vi(i * 2)), fhi = visel(sw, vi(i * 2), vi(i * 2 + 1));
            v4i mn = lo > tn, mf = hi < tf;
            tn = vsel(mn, lo, tn), fn = visel(mn, flo, fn);
            tf = vsel(mf, hi, tf), ff = visel(mf, fhi, ff);
        }
        /* eye inside the box (near-plane clipped): its far side, as a GPU without culling shows */
        v4i front = tn >= nearz;
        *face = visel(front, fn, ff);
        v4f th = vsel(front, tn, vsel(tf >= nearz, tf, inf));
        return vsel(tn <= tf, th, inf);
    }
    case SIM_PRIM_SPHERE: {
        v4f t0, t1;
        v4i hit = vroots(d.x * d.x + d.y * d.y + d.z * d.z, o[0] * d.x + o[1] * d.y + o[2] * d.z, p->k0, &t0, &t1);
        *face = vi(0);
        v4f th = vsel(t0 >= nearz, t0, vsel(t1 >= nearz, t1, inf));
        return vsel(hit, th, inf);
    }
    case SIM_PRIM_CYLINDER: {
        v4f t0, t1, a = d.x * d.x + d.z * d.z;
        v4i hit = vroots(a, o[0] * d.x + o[2] * d.z, p->k0, &t0, &t1) & (a > 0.0f);
        v4f inv = 1.0f / vnz(d.y);
        v4f s0 = (-s[1] - o[1]) * inv, s1 = (s[1] - o[1]) * inv;
        v4i sw = s0 > s1;
        v4f slo = vsel(sw, s1, s0), shi = vsel(sw, s0, s1);
        v4f tn = vmax(t0, slo), tf = vmin(t1, shi);
        v4i front = tn >= nearz;
        *face = visel(front, (t0 < slo) & 1, (t1 > shi) & 1);
        v4f th = vsel(front, tn, vsel(tf >= nearz, tf, inf));
        return vsel(hit & (tn <= tf), th, inf);
    }
    case SIM_PRIM_RECT: {
        v4f t = -o[2] / vnz(d.z);
        v4f x = o[0] + t * d.x, y = o[1] + t * d.y;
        *face = vi(0);
        v4i ok = (t >= nearz) & (t < INFINITY) & (vabs(x) <= s[0]) & (vabs(y) <= s[1]);
        return vsel(ok, t, inf);
    }
    }
    return inf;
}

/* Scalar form for the transparent fragments of one pixel: the same vector code on a broadcast ray, lane 0. */
static inline float hit1(const prim *p, float u, float v, float nearz)
{
    v4i face = vi(0);
    return vhit(p, vto_object(p, vf(u), vf(v)), nearz, &face)[0];
}

/* ---- shading of one (primitive, face) over the 4 lanes (lanes not on it compute garbage that is discarded) ---- */

static void vshade(const prim *p, int face, v4f u, v4f v, v4f t, v4f rho1, v3f *out)
{
    v3f d = vto_object(p, u, v);
    v3f q = {p->o[0] + t * d.x, p->o[1] + t * d.y, p->o[2] + t * d.z};
    v4f rho = rho1 * t; /* metres covered by the filter perpendicular to the ray */
    v3f tex;
    switch (p->type) {
    case SIM_PRIM_ROOM:
    case SIM_PRIM_BOX:
    case SIM_PRIM_RECT: {
        int k = p->type == SIM_PRIM_RECT ? 2 : face >> 1;
        v4f dn = k == 0 ? d.x : (k == 1 ? d.y : d.z), di = k == 0 ? d.y : d.x, dj = k == 2 ? d.y : d.z;
        v4f qi = k == 0 ? q.y : q.x, qj = k == 2 ? q.y : q.z;
        /* anisotropic footprint: along an in-plane axis a the pixel covers rho * sqrt(1 + (d_a / d_n)^2) */
        v4f idn = 1.0f / vsel(vabs(dn) > 1e-6f, dn, vf(1e-6f));
        float is = p->tex_inv_scale;
        v4f wi = rho * is * vstretch(di * idn), wj = rho * is * vstretch(dj * idn);
        float off = 0.37f * (float)face; /* face-dependent offsets so that faces do not look alike */
        pattern2d((qi + off) * is, (qj - off) * is, wi, wj, p->face_rgb[face], &tex);
        float l = p->face_light[face];
        out->x = tex.x * l, out->y = tex.y * l, out->z = tex.z * l;
        return;
    }
    case SIM_PRIM_SPHERE:
    case SIM_PRIM_CYLINDER: {
        v3f n;
        if (p->type == SIM_PRIM_SPHERE) {
            float r = 1.0f / p->size[0];
            n.x = q.x * r, n.y = q.y * r, n.z = q.z * r;
        } else if (face == 0) {
            v4f r = vrsqrt(vmax(q.x * q.x + q.z * q.z, vf(1e-20f)), 3);
            n.x = q.x * r, n.y = vf(0.0f), n.z = q.z * r;
        } else {
            n.x = vf(0.0f), n.y = vsel(q.y > 0.0f, vf(1.0f), vf(-1.0f)), n.z = vf(0.0f);
        }
        /* isotropic footprint, widened towards the silhouette where the surface is seen edge-on */
        v4f dl = vsqrt(d.x * d.x + d.y * d.y + d.z * d.z);
        v4f c = vabs(n.x * d.x + n.y * d.y + n.z * d.z);
        v4f w = rho * dl / vmax(c, 0.25f * dl);
        if (p->tex == SIM_TEX_PLAIN) {
            const float fs = 1.0f / 0.05f;
            v4f g = 1.0f + 0.12f * vwave(q.y * fs) * vfade(w * fs);
            tex.x = p->rgb[0] * g, tex.y = p->rgb[1] * g, tex.z = p->rgb[2] * g;
        } else {
            pattern3d(q, w, p->rgb, &tex);
        }
        v4f l = vlighting(p, n);
        out->x = tex.x * l, out->y = tex.y * l, out->z = tex.z * l;
        return;
    }
    }
    out->x = out->y = out->z = vf(0.0f);
}

/* Colour of a transparent fragment (straight alpha): glass is unlit, its tint with a gentle gradient. */
static void pane_color(const prim *p, float u, float v, float t, float rgba[4])
{
    float d[3];
    for (int i = 0; i < 3; i++) d[i] = p->m[i][0] * u + p->m[i][1] * v - p->m[i][2];
    float g = 0.88f + 0.12f * wave1((p->o[0] + t * d[0]) * 0.45f + (p->o[1] + t * d[1]) * 0.3f);
    rgba[0] = p->rgb[0] * g, rgba[1] = p->rgb[1] * g, rgba[2] = p->rgb[2] * g, rgba[3] = p->alpha;
}

/* ---- per-call setup: primitives in the camera frame, bounding capsules, tile bins ---- */

static void fill_prim(prim *pr, const sim_object *o, int id, double t, warp_pose eye)
{
    memset(pr, 0, sizeof *pr);
    pr->type = o->prim;
    pr->tex = o->tex;
    pr->id = id;
    pr->alpha = o->alpha;
    pr->transparent = o->alpha < 1.0f;
    memcpy(pr->rgb, o->rgb, sizeof pr->rgb);
    memcpy(pr->size, o->size, sizeof pr->size);

    warp_pose wo = sim_object_pose(o, t);
    warp_quat ce = warp_quat_conj(eye.q);
    warp_quat co = warp_quat_mul(ce, wo.q);     /* camera_from_object rotation */
    warp_vec3 cc = warp_quat_rotate(ce, warp_v3_sub(wo.p, eye.p)); /* object origin, camera frame */
    warp_quat oc = warp_quat_conj(co);
    warp_vec3 ex = warp_quat_rotate(oc, warp_v3(1, 0, 0)), ey = warp_quat_rotate(oc, warp_v3(0, 1, 0)),
              ez = warp_quat_rotate(oc, warp_v3(0, 0, 1));
    /* columns of object_from_camera are the camera axes expressed in the object frame */
    pr->m[0][0] = (float)ex.x, pr->m[1][0] = (float)ex.y, pr->m[2][0] = (float)ex.z;
    pr->m[0][1] = (float)ey.x, pr->m[1][1] = (float)ey.y, pr->m[2][1] = (float)ey.z;
    pr->m[0][2] = (float)ez.x, pr->m[1][2] = (float)ez.y, pr->m[2][2] = (float)ez.z;
    warp_vec3 oo = warp_quat_rotate(oc, warp_v3_scale(cc, -1.0));
    pr->o[0] = (float)oo.x, pr->o[1] = (float)oo.y, pr->o[2] = (float)oo.z;
    if (o->prim == SIM_PRIM_SPHERE) pr->k0 = (float)(warp_v3_dot(oo, oo) - (double)o->size[0] * o->size[0]);
    if (o->prim == SIM_PRIM_CYLINDER) pr->k0 = (float)(oo.x * oo.x + oo.z * oo.z - (double)o->size[0] * o->size[0]);
    warp_quat ow = warp_quat_conj(wo.q);
    for (int i = 0; i < 2; i++) {
        warp_vec3 l = warp_v3(light_dir[i][0], light_dir[i][1], light_dir[i][2]);
        l = warp_quat_rotate(ow, warp_v3_scale(l, 1.0 / warp_v3_norm(l)));
        pr->light[i][0] = (float)l.x, pr->light[i][1] = (float)l.y, pr->light[i][2] = (float)l.z;
    }
    /* planar faces: lighting and base colour are constant per face, so they are computed here once */
    static const float room_rgb[6][3] = {
        {0.60f, 0.74f, 0.84f}, {0.70f, 0.82f, 0.60f}, /* left, right */
        {0.66f, 0.50f, 0.36f}, {0.88f, 0.88f, 0.84f}, /* floor, ceiling */
        {0.86f, 0.78f, 0.64f}, {0.74f, 0.62f, 0.80f}, /* front (-z), back (+z) */
    };
    for (int f = 0; f < 6; f++) {
        float n[3] = {0, 0, 0};
        if (o->prim == SIM_PRIM_RECT) n[2] = 1.0f; /* one-sided on purpose: shading must not depend on the side seen */
        else n[f >> 1] = ((f & 1) ? 1.0f : -1.0f) * (o->prim == SIM_PRIM_ROOM ? -1.0f : 1.0f); /* room faces inwards */
        pr->face_light[f] = lighting(pr, n);
        memcpy(pr->face_rgb[f], o->tex == SIM_TEX_ROOM ? room_rgb[f] : o->rgb, sizeof pr->face_rgb[f]);
    }
    pr->tex_inv_scale = o->tex == SIM_TEX_GROUND ? 0.25f : (o->prim == SIM_PRIM_BOX ? 2.0f : 1.0f);
    pr->moving = sim_object_moves(o);
    if (pr->moving) {
        warp_vec3 lin, ang;
        sim_object_velocity(o, t, &lin, &ang);
        lin = warp_quat_rotate(ce, lin);
        ang = warp_quat_rotate(ce, ang);
        pr->vc[0] = (float)lin.x, pr->vc[1] = (float)lin.y, pr->vc[2] = (float)lin.z;
        pr->wc[0] = (float)ang.x, pr->wc[1] = (float)ang.y, pr->wc[2] = (float)ang.z;
        pr->cc[0] = (float)cc.x, pr->cc[1] = (float)cc.y, pr->cc[2] = (float)cc.z;
    }

    /* Bounding capsule: the segment along the longest extent plus the radius covering the rest. */
    double s0 = o->size[0], s1 = o->size[1], s2 = o->size[2];
    warp_vec3 axis = warp_v3(0, 0, 0);
    double r = 0;
    switch (o->prim) {
    case SIM_PRIM_ROOM: pr->unbounded = true; break;
    case SIM_PRIM_SPHERE: r = s0; break;
    case SIM_PRIM_CYLINDER: axis = warp_v3(0, s1, 0), r = s0; break;
    case SIM_PRIM_BOX:
        if (s0 >= s1 && s0 >= s2) axis = warp_v3(s0, 0, 0), r = sqrt(s1 * s1 + s2 * s2);
        else if (s1 >= s2) axis = warp_v3(0, s1, 0), r = sqrt(s0 * s0 + s2 * s2);
        else axis = warp_v3(0, 0, s2), r = sqrt(s0 * s0 + s1 * s1);
        break;
    case SIM_PRIM_RECT:
        if (isinf(s0) || isinf(s1)) pr->unbounded = true;
        else if (s0 >= s1) axis = warp_v3(s0, 0, 0), r = s1;
        else axis = warp_v3(0, s1, 0), r = s0;
        break;
    }
    if (pr->unbounded) {
        pr->zmin = 0.0f;
        return;
    }
    warp_vec3 ac = warp_quat_rotate(co, axis);
    warp_vec3 a = warp_v3_add(cc, ac), b = warp_v3_sub(cc, ac);
    pr->ca[0] = a.x, pr->ca[1] = a.y, pr->ca[2] = a.z;
    pr->cb[0] = b.x, pr->cb[1] = b.y, pr->cb[2] = b.z;
    pr->cr = r * (1.0 + 1e-6) + 1e-6; /* float intersection vs double culling: a hair of slack */
    pr->zmin = (float)fmax(fmin(-a.z, -b.z) - pr->cr, 0.0);
}

/* Tile rows/columns are bounded by planes through the eye; a capsule can reach a tile only if its axis comes
 * within its radius of the inside of all four. Column c: f_c >= 0 and f_{c+1} <= 0 with
 * f_k(P) = (P.x + u_k P.z) / sqrt(1 + u_k^2); row r: g_r <= 0 and g_{r+1} >= 0 with g_k(P) = (P.y + v_k P.z) / ... */
static inline double plane_dist(double a, double nrm, const double *p, int comp) { return (p[comp] + a * p[2]) * nrm; }

static bool col_reaches(const setup *S, int c, const double *a, const double *b, double r)
{
    double fa = plane_dist(S->colu[c], S->coln[c], a, 0), fb = plane_dist(S->colu[c], S->coln[c], b, 0);
    double ga = plane_dist(S->colu[c + 1], S->coln[c + 1], a, 0), gb = plane_dist(S->colu[c + 1], S->coln[c + 1], b, 0);
    return fmax(fa, fb) >= -r && fmin(ga, gb) <= r;
}

/* Clips segment a-b to the slab of tile row k (local index) widened by r; false when nothing is left. */
static bool clip_row(const setup *S, int k, const double *a, const double *b, double r, double *a2, double *b2)
{
    double lo = 0, hi = 1;
    /* g_top(P) <= r and g_bottom(P) >= -r, both linear along the segment */
    double t0 = plane_dist(S->rowv[k], S->rown[k], a, 1), t1 = plane_dist(S->rowv[k], S->rown[k], b, 1);
    double u0 = plane_dist(S->rowv[k + 1], S->rown[k + 1], a, 1), u1 = plane_dist(S->rowv[k + 1], S->rown[k + 1], b, 1);
    double f0[2] = {r - t0, u0 + r}, f1[2] = {r - t1, u1 + r}; /* both must be >= 0 */
    for (int i = 0; i < 2; i++) {
        if (f0[i] < 0 && f1[i] < 0) return false;
        if (f0[i] < 0) lo = fmax(lo, f0[i] / (f0[i] - f1[i]));
        else if (f1[i] < 0) hi = fmin(hi, f0[i] / (f0[i] - f1[i]));
    }
    if (lo > hi) return false;
    for (int i = 0; i < 3; i++) {
        a2[i] = a[i] + lo * (b[i] - a[i]);
        b2[i] = a[i] + hi * (b[i] - a[i]);
    }
    return true;
}

typedef struct {
    int *v;
    size_t n, cap;
} ivec;

static bool ivec_push2(ivec *iv, int tile, int prim_index)
{
    if (iv->n + 2 > iv->cap) {
        size_t cap = iv->cap ? iv->cap * 2 : 4096;
        int *nv = realloc(iv->v, cap * sizeof(int));
        if (!nv) return false;
        iv->v = nv;
        iv->cap = cap;
    }
    iv->v[iv->n++] = tile;
    iv->v[iv->n++] = prim_index;
    return true;
}

static bool build_bins(const setup *S, bool transparent, bins *B)
{
    int nr = S->tr1 - S->tr0, ntiles = nr * S->nc;
    ivec pairs = {NULL, 0, 0};
    B->start = calloc((size_t)ntiles + 1, sizeof(int));
    if (!B->start) return false;
    for (int i = 0; i < S->n; i++) {
        const prim *p = &S->p[i];
        if (p->transparent != transparent) continue;
        if (p->unbounded) {
            for (int tl = 0; tl < ntiles; tl++)
                if (!ivec_push2(&pairs, tl, i)) goto fail;
            continue;
        }
        double r = p->cr;
        for (int k = 0; k < nr; k++) {
            double a2[3], b2[3];
            if (!clip_row(S, k, p->ca, p->cb, r, a2, b2)) continue;
            for (int c = 0; c < S->nc; c++)
                if (col_reaches(S, c, a2, b2, r) && !ivec_push2(&pairs, k * S->nc + c, i)) goto fail;
        }
    }
    /* counting sort by tile (stable: primitive order kept), then each tile front to back by (zmin, index) */
    for (size_t j = 0; j < pairs.n; j += 2) B->start[pairs.v[j] + 1]++;
    for (int tl = 0; tl < ntiles; tl++) B->start[tl + 1] += B->start[tl];
    B->item = malloc((pairs.n / 2 + 1) * sizeof(int));
    int *fillp = malloc(((size_t)ntiles + 1) * sizeof(int));
    if (!B->item || !fillp) {
        free(fillp);
        goto fail;
    }
    memcpy(fillp, B->start, (size_t)ntiles * sizeof(int));
    for (size_t j = 0; j < pairs.n; j += 2) B->item[fillp[pairs.v[j]]++] = pairs.v[j + 1];
    free(fillp);
    free(pairs.v);
    for (int tl = 0; tl < ntiles; tl++) {
        int *it = B->item + B->start[tl], cnt = B->start[tl + 1] - B->start[tl];
        for (int x = 1; x < cnt; x++) {
            int v = it[x], y = x - 1;
            while (y >= 0 && (S->p[it[y]].zmin > S->p[v].zmin || (S->p[it[y]].zmin == S->p[v].zmin && it[y] > v))) {
                it[y + 1] = it[y];
                y--;
            }
            it[y + 1] = v;
        }
    }
    return true;
fail:
    free(pairs.v);
    free(B->start);
    free(B->item);
    B->start = B->item = NULL;
    return false;
}

/* ---- the per-pixel loop ---- */

typedef struct {
    float t;
    int prim;
    float rgba[4];
} frag;

/* Transparent fragments of one pixel in front of depth `best`, nearest first (ties: lower index first), at most
 * MAX_FRAGS kept; returns the count. */
static int gather_frags(const setup *S, const int *list, int n, float u, float v, float best, float nearz, frag *fr)
{
    int nf = 0;
    for (int k = 0; k < n; k++) {
        const prim *p = &S->p[list[k]];
        if (!(p->zmin < best)) break;
        float th = hit1(p, u, v, nearz);
        if (!(th < best)) continue;
        int pos = nf < MAX_FRAGS ? nf : MAX_FRAGS - 1;
        if (nf == MAX_FRAGS && !(th < fr[pos].t)) continue;
        while (pos > 0 && (fr[pos - 1].t > th || (fr[pos - 1].t == th && fr[pos - 1].prim > list[k]))) {
            fr[pos] = fr[pos - 1];
            pos--;
        }
        fr[pos].t = th;
        fr[pos].prim = list[k];
        if (nf < MAX_FRAGS) nf++;
    }
    for (int k = 0; k < nf; k++) pane_color(&S->p[fr[k].prim], u, v, fr[k].t, fr[k].rgba);
    return nf;
}

void sim_render_rows(const sim_scene *s, double t, warp_pose eye, const warp_camera *cam, unsigned planes,
                     sim_buffers *b, int y0, int y1)
{
    if (!s || !cam || !b || warp_camera_check(cam)) return;
    planes &= b->planes;
    const int W = cam->width, H = cam->height;
    /* a plane smaller than the camera image is not written (it would overflow) */
    if ((planes & SIM_PLANE_COLOR) && (b->color.w < W || b->color.h < H)) planes &= ~(unsigned)SIM_PLANE_COLOR;
    if ((planes & SIM_PLANE_DEPTH) && (b->depth.w < W || b->depth.h < H)) planes &= ~(unsigned)SIM_PLANE_DEPTH;
    if ((planes & SIM_PLANE_IDS) && (b->ids.w < W || b->ids.h < H)) planes &= ~(unsigned)SIM_PLANE_IDS;
    if ((planes & SIM_PLANE_MOTION) && (b->motion.w < W || b->motion.h < H)) planes &= ~(unsigned)SIM_PLANE_MOTION;
    if ((planes & SIM_PLANE_LAYERS) && (b->layers.w < W || b->layers.h < H || b->layers.max_layers < 1))
        planes &= ~(unsigned)SIM_PLANE_LAYERS;
    if (y0 < 0) y0 = 0;
    if (y1 > H) y1 = H;
    if (!planes || y0 >= y1) return;
    if (!warp_quat_normalize(eye.q, &eye.q) || !warp_v3_isfinite(eye.p) || !isfinite(t)) return;

    const bool want_color = planes & SIM_PLANE_COLOR, want_depth = planes & SIM_PLANE_DEPTH,
               want_ids = planes & SIM_PLANE_IDS, want_motion = planes & SIM_PLANE_MOTION,
               want_layers = planes & SIM_PLANE_LAYERS;
    const double sx = warp_camera_pixels_per_tan_x(cam), sy = warp_camera_pixels_per_tan_y(cam);
    const float nearz = (float)cam->near_z;
    /* filter width in metres per metre of planar depth: the pixel's angular size (geometric mean of its two
     * directions, ~1 / (ppt (1 + u^2 + v^2)^(3/4))) times the ray length per unit depth, times FILTER_PX */
    const float rho_k = (float)(FILTER_PX / sqrt(sx * sy));

    setup S;
    memset(&S, 0, sizeof S);
    S.cam = cam;
    S.n = sim_scene_nobjects(s);
    S.nc = (W + TILE - 1) / TILE;
    S.tr0 = y0 / TILE;
    S.tr1 = (y1 - 1) / TILE + 1;
    int nr = S.tr1 - S.tr0;
    bins opq = {NULL, NULL}, trn = {NULL, NULL};
    /* u per column, padded to whole groups by repeating the last column (those lanes are never stored) */
    int wpad = S.nc * TILE;
    float *utab = malloc((size_t)wpad * sizeof(float));
    S.p = malloc((size_t)(S.n > 0 ? S.n : 1) * sizeof(prim));
    S.colu = malloc((size_t)(S.nc + 1) * 2 * sizeof(double));
    S.rowv = malloc((size_t)(nr + 1) * 2 * sizeof(double));
    if (!utab || !S.p || !S.colu || !S.rowv) goto done;
    S.coln = S.colu + S.nc + 1;
    S.rown = S.rowv + nr + 1;
    for (int x = 0; x < wpad; x++) {
        double u, v;
        warp_camera_pixel_to_tan(cam, (x < W ? x : W - 1) + 0.5, 0.5, &u, &v);
        utab[x] = (float)u;
    }
    for (int k = 0; k <= S.nc; k++) {
        int x = k * TILE < W ? k * TILE : W;
        double u, v;
        warp_camera_pixel_to_tan(cam, x, 0, &u, &v);
        S.colu[k] = u;
        S.coln[k] = 1.0 / sqrt(1.0 + u * u);
    }
    for (int k = 0; k <= nr; k++) {
        int y = (S.tr0 + k) * TILE < H ? (S.tr0 + k) * TILE : H;
        double u, v;
        warp_camera_pixel_to_tan(cam, 0, y, &u, &v);
        S.rowv[k] = v;
        S.rown[k] = 1.0 / sqrt(1.0 + v * v);
    }
    bool any_transparent = false;
    for (int i = 0; i < S.n; i++) {
        sim_object o;
        sim_scene_object(s, i, &o);
        fill_prim(&S.p[i], &o, i + 1, t, eye);
        any_transparent |= S.p[i].transparent;
    }
    const bool want_frags = any_transparent && (want_color || want_layers);
    if (!build_bins(&S, false, &opq)) goto done;
    if (want_frags && !build_bins(&S, true, &trn)) goto done;

    float rwe[3][3]; /* world_from_eye rotation, for sky directions */
    {
        warp_mat3 m = warp_quat_to_mat3(eye.q);
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++) rwe[i][j] = (float)m.m[i][j];
    }
    const bool sky = sim_scene_has_sky(s);
    const float fsx = (float)sx, fsy = (float)sy;
    const int maxl = want_layers ? b->layers.max_layers : 0;
    const v4i lane = {0, 1, 2, 3};

    for (int tr = S.tr0; tr < S.tr1; tr++) {
        int ry0 = tr * TILE > y0 ? tr * TILE : y0, ry1 = (tr + 1) * TILE < y1 ? (tr + 1) * TILE : y1;
        for (int tc = 0; tc < S.nc; tc++) {
            int tl = (tr - S.tr0) * S.nc + tc;
            const int *ol = opq.item + opq.start[tl], on = opq.start[tl + 1] - opq.start[tl];
            const int *tlist = want_frags ? trn.item + trn.start[tl] : NULL;
            const int tn = want_frags ? trn.start[tl + 1] - trn.start[tl] : 0;
            for (int y = ry0; y < ry1; y++) {
                double ud, vd;
                warp_camera_pixel_to_tan(cam, 0.5, y + 0.5, &ud, &vd);
                const float v1 = (float)vd;
                const v4f v = vf(v1);
                for (int x0 = tc * TILE; x0 < (tc + 1) * TILE && x0 < W; x0 += VW) {
                    const int nl = W - x0 < VW ? W - x0 : VW; /* lanes inside the image */
                    const v4f u = {utab[x0], utab[x0 + 1], utab[x0 + 2], utab[x0 + 3]};
                    /* nearest opaque surface; ties go to the lower index, so the candidate order never matters */
                    v4f best = vf(INFINITY);
                    v4i bi = vi(-1), bface = vi(0);
                    for (int k = 0; k < on; k++) {
                        const prim *p = &S.p[ol[k]];
                        float worst = maxf_(maxf_(best[0], best[1]), maxf_(best[2], best[3]));
                        if (p->zmin > worst) break;
                        v4i face = vi(0);
                        v4f th = vhit(p, vto_object(p, u, v), nearz, &face);
                        v4i m = (th < best) | ((th == best) & (th < INFINITY) & (vi(ol[k]) < bi));
                        best = vsel(m, th, best);
                        bi = visel(m, vi(ol[k]), bi);
                        bface = visel(m, face, bface);
                    }
                    v3f col = {vf(0.0f), vf(0.0f), vf(0.0f)};
                    if (want_color) {
                        /* dd^(-1/4) and dd^(-1/2) with dd = |(u, v, -1)|^2: footprint and sky pixel angle */
                        v4f r2 = vrsqrt(1.0f + u * u + v * v, 2), r4 = r2 * vrsqrt(r2, 2);
                        v4f rho1 = rho_k * r4;
                        /* shade each distinct (primitive, face) present once over all lanes, keep its lanes */
                        v4i done = lane >= nl;
                        while (!(done[0] & done[1] & done[2] & done[3])) {
                            int l0 = !done[0] ? 0 : !done[1] ? 1 : !done[2] ? 2 : 3;
                            int pi = bi[l0], pf = bface[l0];
                            v4i m = (bi == pi) & (bface == pf) & ~done;
                            v3f c;
                            if (pi >= 0) {
                                vshade(&S.p[pi], pf, u, v, best, rho1, &c);
                            } else if (sky) {
                                v3f dw = {rwe[0][0] * u + rwe[0][1] * v - rwe[0][2], rwe[1][0] * u + rwe[1][1] * v - rwe[1][2],
                                          rwe[2][0] * u + rwe[2][1] * v - rwe[2][2]};
                                sky_color(dw, rho1 * (r2 * (1.0f / FILTER_PX)), &c);
                            } else {
                                c.x = c.y = c.z = vf(0.0f); /* enclosed scenes: never seen */
                            }
                            col.x = vsel(m, c.x, col.x), col.y = vsel(m, c.y, col.y), col.z = vsel(m, c.z, col.z);
                            done |= m;
                        }
                    }
                    if (!tn && nl == VW && !want_motion && !want_layers) {
                        /* the common case, whole group, no per-pixel extras: vector conversion and stores */
                        if (want_color) {
                            v4u px = vquant(col.x) | (vquant(col.y) << 8) | (vquant(col.z) << 16) | 0xff000000u;
                            memcpy(&WARP_AT(&b->color, x0, y), &px, sizeof px);
                        }
                        if (want_depth) memcpy(&WARP_AT(&b->depth, x0, y), &best, sizeof best);
                        if (want_ids)
                            for (int l = 0; l < VW; l++) WARP_AT(&b->ids, x0 + l, y) = (uint16_t)(bi[l] >= 0 ? S.p[bi[l]].id : 0);
                        continue;
                    }
                    for (int l = 0; l < nl; l++) {
                        const int x = x0 + l;
                        const float ul = u[l], bl = best[l];
                        const int bil = bi[l];
                        frag fr[MAX_FRAGS];
                        int nf = tn ? gather_frags(&S, tlist, tn, ul, v1, bl, nearz, fr) : 0;
                        if (want_color) {
                            /* clamped first, as in an 8-bit target: the layers then blend onto what the plane
                             * would hold without them */
                            float c[3] = {clampf(col.x[l], 0.0f, 1.0f), clampf(col.y[l], 0.0f, 1.0f),
                                          clampf(col.z[l], 0.0f, 1.0f)};
                            /* "over", back to front (000 §4.2): straight-alpha fragments onto the opaque colour,
                             * in linear light as renderers blend (colours are sRGB-encoded; warp_transparency
                             * un-blends and composites the same way) */
                            if (nf > 0) {
                                for (int i = 0; i < 3; i++) c[i] = warp_srgb_decode(c[i]);
                                for (int k = nf - 1; k >= 0; k--) {
                                    float a = fr[k].rgba[3];
                                    for (int i = 0; i < 3; i++)
                                        c[i] = warp_srgb_decode(fr[k].rgba[i]) * a + c[i] * (1.0f - a);
                                }
                                for (int i = 0; i < 3; i++) c[i] = warp_srgb_encode(c[i]);
                            }
                            warp_rgba8 px = {to_u8(c[0]), to_u8(c[1]), to_u8(c[2]), 255};
                            WARP_AT(&b->color, x, y) = px;
                        }
                        if (want_depth) WARP_AT(&b->depth, x, y) = bil >= 0 ? bl : INFINITY;
                        if (want_ids) WARP_AT(&b->ids, x, y) = (uint16_t)(bil >= 0 ? S.p[bil].id : 0);
                        if (want_motion) {
                            warp_vec2f mv = {0.0f, 0.0f};
                            if (bil >= 0 && S.p[bil].moving) {
                                /* velocity of the surface point (camera frame), then d/dt of its projection:
                                 * du/dt = (Vx + u Vz) / z, dv/dt = (Vy + v Vz) / z for u = X / -Z, v = Y / -Z */
                                const prim *p = &S.p[bil];
                                float P[3] = {ul * bl - p->cc[0], v1 * bl - p->cc[1], -bl - p->cc[2]};
                                float V[3] = {p->vc[0] + p->wc[1] * P[2] - p->wc[2] * P[1],
                                              p->vc[1] + p->wc[2] * P[0] - p->wc[0] * P[2],
                                              p->vc[2] + p->wc[0] * P[1] - p->wc[1] * P[0]};
                                mv.x = fsx * (V[0] + ul * V[2]) / bl;
                                mv.y = -fsy * (V[1] + v1 * V[2]) / bl;
                            }
                            WARP_AT(&b->motion, x, y) = mv;
                        }
                        if (want_layers) {
                            size_t pix = (size_t)y * (size_t)b->layers.w + (size_t)x;
                            int nk = nf < maxl ? nf : maxl;
                            warp_fragment *out = b->layers.frag + pix * (size_t)maxl;
                            for (int k = 0; k < nk; k++) {
                                out[k].z = fr[k].t;
                                out[k].rgba.r = to_u8(fr[k].rgba[0]);
                                out[k].rgba.g = to_u8(fr[k].rgba[1]);
                                out[k].rgba.b = to_u8(fr[k].rgba[2]);
                                out[k].rgba.a = to_u8(fr[k].rgba[3]);
                                out[k].id = (uint16_t)S.p[fr[k].prim].id;
                            }
                            b->layers.count[pix] = (uint8_t)nk;
                        }
                    }
                }
            }
        }
    }
done:
    free(opq.start);
    free(opq.item);
    free(trn.start);
    free(trn.item);
    free(utab);
    free(S.p);
    free(S.colu);
    free(S.rowv);
}

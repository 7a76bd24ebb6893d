/* SPDX-License-Identifier: MIT */
/* drv_v4l2_convert: pixel formats of V4L2 capture/output buffers (YUYV, NV12, BGR32/XBGR32, RGB24) to and from
 * RGBA8 with integer BT.601/BT.709 limited/full-range math, plus the luma-level access the in-band layout uses. */
#include "drivers/drv_v4l2_convert.h"

#include <ctype.h>
#include <math.h>
#include <string.h>

/* Fixed-point coefficients (x 2^16) of one colour space, derived from Kr/Kb so both matrices and both ranges share
 * one code path. */
typedef struct {
    int32_t yr, yg, yb, yoff;       /* Y  = yr R + yg G + yb B + yoff */
    int32_t ur, ug, ub;             /* Cb = ur R + ug G + ub B + 128 */
    int32_t vr, vg, vb;             /* Cr = vr R + vg G + vb B + 128 */
    int32_t ky, kyoff, krv, kgu, kgv, kbu; /* R = ky (Y - kyoff) + krv Cr'; G = .. - kgu Cb' - kgv Cr'; B = .. + kbu Cb' */
} coeffs;

static int32_t fx(double v) { return (int32_t)lround(v * 65536.0); }

static coeffs coeffs_make(const drv_v4l2_colorspace *cs)
{
    double kr = 0.299, kb = 0.114; /* BT.601 */
    if (cs && cs->matrix == DRV_V4L2_BT709) kr = 0.2126, kb = 0.0722;
    double kg = 1.0 - kr - kb;
    bool full = cs && cs->full_range;
    double ys = full ? 1.0 : 219.0 / 255.0, cs_ = full ? 1.0 : 224.0 / 255.0;
    coeffs c;
    c.yr = fx(ys * kr), c.yg = fx(ys * kg), c.yb = fx(ys * kb), c.yoff = full ? 0 : 16;
    c.ur = fx(-cs_ * kr / (2 * (1 - kb))), c.ug = fx(-cs_ * kg / (2 * (1 - kb))), c.ub = fx(cs_ / 2);
    c.vr = fx(cs_ / 2), c.vg = fx(-cs_ * kg / (2 * (1 - kr))), c.vb = fx(-cs_ * kb / (2 * (1 - kr)));
    c.ky = fx(1.0 / ys), c.kyoff = full ? 0 : 16;
    c.krv = fx(2 * (1 - kr) / cs_), c.kbu = fx(2 * (1 - kb) / cs_);
    c.kgu = fx(2 * kb * (1 - kb) / (kg * cs_)), c.kgv = fx(2 * kr * (1 - kr) / (kg * cs_));
    return c;
}

static inline uint8_t clamp8(int32_t v) { return (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v); }

/* >> on negative values is arithmetic on every compiler we build with (gcc, clang); the clamp follows. */
#define ROUND16(v) (((v) + (1 << 15)) >> 16)

static inline uint8_t rgb_to_y(const coeffs *c, int r, int g, int b)
{
    return clamp8(ROUND16(c->yr * r + c->yg * g + c->yb * b) + c->yoff);
}
/* Chroma of the sum of n = 1 << sh pixels' components. */
static inline void rgb_to_uv(const coeffs *c, int r, int g, int b, int sh, uint8_t *u, uint8_t *v)
{
    int32_t rr = 1 << (15 + sh);
    *u = clamp8(((c->ur * r + c->ug * g + c->ub * b + rr) >> (16 + sh)) + 128);
    *v = clamp8(((c->vr * r + c->vg * g + c->vb * b + rr) >> (16 + sh)) + 128);
}
static inline void yuv_to_rgb(const coeffs *c, int y, int u, int v, warp_rgba8 *o)
{
    int32_t yy = c->ky * (y - c->kyoff) + (1 << 15);
    u -= 128, v -= 128;
    o->r = clamp8((yy + c->krv * v) >> 16);
    o->g = clamp8((yy - c->kgu * u - c->kgv * v) >> 16);
    o->b = clamp8((yy + c->kbu * u) >> 16);
    o->a = 255;
}

bool drv_v4l2_fourcc_supported(uint32_t f)
{
    return f == DRV_V4L2_YUYV || f == DRV_V4L2_NV12 || f == DRV_V4L2_BGR32 || f == DRV_V4L2_XBGR32 ||
           f == DRV_V4L2_RGB24;
}

uint32_t drv_v4l2_fourcc_parse(const char *name)
{
    static const struct { const char *n; uint32_t f; } t[] = {
        {"yuyv", DRV_V4L2_YUYV},     {"nv12", DRV_V4L2_NV12},   {"bgr32", DRV_V4L2_BGR32},
        {"xbgr32", DRV_V4L2_XBGR32}, {"rgb24", DRV_V4L2_RGB24},
    };
    if (!name) return 0;
    for (size_t i = 0; i < sizeof t / sizeof t[0]; i++)
        if (strcasecmp(name, t[i].n) == 0) return t[i].f;
    return 0;
}

const char *drv_v4l2_fourcc_str(uint32_t f, char *buf)
{
    for (int i = 0; i < 4; i++) {
        char ch = (char)((f >> (8 * i)) & 0xff);
        buf[i] = isprint((unsigned char)ch) ? ch : '?';
    }
    buf[4] = 0;
    return buf;
}

static int bytes_per_pixel(uint32_t f)
{
    switch (f) {
    case DRV_V4L2_YUYV: return 2;
    case DRV_V4L2_NV12: return 1; /* of the Y plane */
    case DRV_V4L2_BGR32:
    case DRV_V4L2_XBGR32: return 4;
    case DRV_V4L2_RGB24: return 3;
    default: return 0;
    }
}

int drv_v4l2_min_bytesperline(uint32_t f, int width)
{
    int bpp = bytes_per_pixel(f);
    if (!bpp || width <= 0 || width > (1 << 16)) return 0;
    return bpp * width;
}

size_t drv_v4l2_image_size(uint32_t f, int height, int bytesperline)
{
    if (height <= 0 || bytesperline <= 0) return 0;
    size_t n = (size_t)height * (size_t)bytesperline;
    return f == DRV_V4L2_NV12 ? n + (size_t)((height + 1) / 2) * (size_t)bytesperline : n;
}

bool drv_v4l2_geom_init(drv_v4l2_geom *g, uint32_t f, int width, int height, int bytesperline)
{
    memset(g, 0, sizeof *g);
    int min = drv_v4l2_min_bytesperline(f, width);
    if (!min || height <= 0 || height > (1 << 16)) return false;
    if (bytesperline == 0) bytesperline = min;
    if (bytesperline < min) return false;
    g->fourcc = f, g->width = width, g->height = height, g->bytesperline = bytesperline;
    g->size = drv_v4l2_image_size(f, height, bytesperline);
    return true;
}

const char *drv_v4l2_geom_check(const drv_v4l2_geom *g)
{
    if (!drv_v4l2_fourcc_supported(g->fourcc)) return "unsupported pixel format";
    int min = drv_v4l2_min_bytesperline(g->fourcc, g->width);
    if (!min || g->height <= 0 || g->height > (1 << 16)) return "bad image size";
    if (g->bytesperline < min) return "bytesperline smaller than the width needs";
    if ((g->fourcc == DRV_V4L2_YUYV || g->fourcc == DRV_V4L2_NV12) && (g->width & 1)) return "odd width";
    if (g->fourcc == DRV_V4L2_NV12 && (g->height & 1)) return "odd height";
    if (g->size < drv_v4l2_image_size(g->fourcc, g->height, g->bytesperline)) return "buffer smaller than the image";
    return NULL;
}

static inline const uint8_t *row_at(const uint8_t *img, const drv_v4l2_geom *g, int y)
{
    return img + (size_t)y * (size_t)g->bytesperline;
}
static inline const uint8_t *nv12_uv_row(const uint8_t *img, const drv_v4l2_geom *g, int y)
{
    return img + (size_t)g->height * (size_t)g->bytesperline + (size_t)(y / 2) * (size_t)g->bytesperline;
}

void drv_v4l2_to_rgba(const uint8_t *img, const drv_v4l2_geom *g, const drv_v4l2_colorspace *cs, int x0, int y0,
                      int w, int h, warp_rgba8 *dst, int dst_stride)
{
    coeffs c = coeffs_make(cs);
    for (int j = 0; j < h; j++) {
        int y = y0 + j;
        const uint8_t *s = row_at(img, g, y);
        warp_rgba8 *o = dst + (size_t)j * (size_t)dst_stride;
        switch (g->fourcc) {
        case DRV_V4L2_YUYV:
            s += 2 * x0;
            for (int i = 0; i + 1 < w; i += 2, s += 4) {
                yuv_to_rgb(&c, s[0], s[1], s[3], &o[i]);
                yuv_to_rgb(&c, s[2], s[1], s[3], &o[i + 1]);
            }
            break;
        case DRV_V4L2_NV12: {
            const uint8_t *uv = nv12_uv_row(img, g, y) + x0;
            s += x0;
            for (int i = 0; i + 1 < w; i += 2) {
                yuv_to_rgb(&c, s[i], uv[i], uv[i + 1], &o[i]);
                yuv_to_rgb(&c, s[i + 1], uv[i], uv[i + 1], &o[i + 1]);
            }
            break;
        }
        case DRV_V4L2_BGR32:
        case DRV_V4L2_XBGR32:
            s += 4 * x0;
            for (int i = 0; i < w; i++, s += 4) o[i] = (warp_rgba8){s[2], s[1], s[0], 255};
            break;
        case DRV_V4L2_RGB24:
            s += 3 * x0;
            for (int i = 0; i < w; i++, s += 3) o[i] = (warp_rgba8){s[0], s[1], s[2], 255};
            break;
        default: return;
        }
    }
}

void drv_v4l2_from_rgba(const warp_rgba8 *src, int src_stride, int w, int h, const drv_v4l2_colorspace *cs,
                        uint8_t *img, const drv_v4l2_geom *g, int x0, int y0)
{
    coeffs c = coeffs_make(cs);
    for (int j = 0; j < h; j++) {
        int y = y0 + j;
        uint8_t *d = img + (size_t)y * (size_t)g->bytesperline;
        const warp_rgba8 *s = src + (size_t)j * (size_t)src_stride;
        switch (g->fourcc) {
        case DRV_V4L2_YUYV:
            d += 2 * x0;
            for (int i = 0; i + 1 < w; i += 2, d += 4) {
                const warp_rgba8 a = s[i], b = s[i + 1];
                d[0] = rgb_to_y(&c, a.r, a.g, a.b);
                d[2] = rgb_to_y(&c, b.r, b.g, b.b);
                rgb_to_uv(&c, a.r + b.r, a.g + b.g, a.b + b.b, 1, &d[1], &d[3]);
            }
            break;
        case DRV_V4L2_NV12: {
            d += x0;
            for (int i = 0; i < w; i++) d[i] = rgb_to_y(&c, s[i].r, s[i].g, s[i].b);
            /* Chroma once per row pair, from the 2x2 block (the last row alone if h is odd). */
            if ((y & 1) == 0) {
                const warp_rgba8 *s2 = j + 1 < h ? s + src_stride : s;
                uint8_t *uv = img + (size_t)g->height * (size_t)g->bytesperline +
                              (size_t)(y / 2) * (size_t)g->bytesperline + x0;
                for (int i = 0; i + 1 < w; i += 2) {
                    int r = s[i].r + s[i + 1].r + s2[i].r + s2[i + 1].r;
                    int gg = s[i].g + s[i + 1].g + s2[i].g + s2[i + 1].g;
                    int b = s[i].b + s[i + 1].b + s2[i].b + s2[i + 1].b;
                    rgb_to_uv(&c, r, gg, b, 2, &uv[i], &uv[i + 1]);
                }
            }
            break;
        }
        case DRV_V4L2_BGR32:
        case DRV_V4L2_XBGR32:
            d += 4 * x0;
            for (int i = 0; i < w; i++, d += 4) d[0] = s[i].b, d[1] = s[i].g, d[2] = s[i].r, d[3] = 255;
            break;
        case DRV_V4L2_RGB24:
            d += 3 * x0;
            for (int i = 0; i < w; i++, d += 3) d[0] = s[i].r, d[1] = s[i].g, d[2] = s[i].b;
            break;
        default: return;
        }
    }
}

void drv_v4l2_read_luma(const uint8_t *img, const drv_v4l2_geom *g, int x0, int y, int w, uint8_t *out)
{
    const uint8_t *s = row_at(img, g, y);
    switch (g->fourcc) {
    case DRV_V4L2_YUYV:
        s += 2 * x0;
        for (int i = 0; i < w; i++) out[i] = s[2 * i];
        break;
    case DRV_V4L2_NV12: memcpy(out, s + x0, (size_t)w); break;
    case DRV_V4L2_BGR32:
    case DRV_V4L2_XBGR32:
        s += 4 * x0;
        for (int i = 0; i < w; i++, s += 4) out[i] = (uint8_t)((s[0] + 2 * s[1] + s[2] + 2) >> 2);
        break;
    case DRV_V4L2_RGB24:
        s += 3 * x0;
        for (int i = 0; i < w; i++, s += 3) out[i] = (uint8_t)((s[0] + 2 * s[1] + s[2] + 2) >> 2);
        break;
    default: memset(out, 0, (size_t)w); break;
    }
}

void drv_v4l2_write_grey(uint8_t *img, const drv_v4l2_geom *g, int x0, int y, int w, const uint8_t *level)
{
    uint8_t *d = img + (size_t)y * (size_t)g->bytesperline;
    switch (g->fourcc) {
    case DRV_V4L2_YUYV:
        d += 2 * x0;
        for (int i = 0; i < w; i++) d[2 * i] = level[i], d[2 * i + 1] = 128;
        break;
    case DRV_V4L2_NV12:
        memcpy(d + x0, level, (size_t)w);
        memset(img + (size_t)g->height * (size_t)g->bytesperline + (size_t)(y / 2) * (size_t)g->bytesperline + x0, 128,
               (size_t)w);
        break;
    case DRV_V4L2_BGR32:
    case DRV_V4L2_XBGR32:
        d += 4 * x0;
        for (int i = 0; i < w; i++, d += 4) d[0] = d[1] = d[2] = level[i], d[3] = 255;
        break;
    case DRV_V4L2_RGB24:
        d += 3 * x0;
        for (int i = 0; i < w; i++, d += 3) d[0] = d[1] = d[2] = level[i];
        break;
    default: break;
    }
}

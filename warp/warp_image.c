/* SPDX-License-Identifier: MIT */
/* warp_image: the image planes a frame can carry (RGBA8 colour, float depth, u16 object ids, float2 motion,
 * u8 masks, A-buffer fragment layers), their allocation, and bilinear sampling of colour. */
#include "warp/warp_image.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static void *alloc_plane(int w, int h, size_t elem, int *stride)
{
    if (w <= 0 || h <= 0 || w > 32768 || h > 32768) return NULL;
    size_t per_line = 64 / elem ? 64 / elem : 1; /* pad rows to 64-byte multiples: whole cache lines per row */
    size_t s = ((size_t)w + per_line - 1) / per_line * per_line;
    /* One spare row keeps 4-byte gathers at the last pixel inside the allocation. */
    size_t bytes = s * elem * ((size_t)h + 1);
    bytes = (bytes + 63) / 64 * 64;
    void *p = aligned_alloc(64, bytes);
    if (!p) return NULL;
    memset(p, 0, bytes);
    *stride = (int)s;
    return p;
}

#define DEFINE_ALLOC(name, type, T)                                        \
    bool name(type *img, int w, int h)                                     \
    {                                                                      \
        memset(img, 0, sizeof *img);                                       \
        img->px = (T *)alloc_plane(w, h, sizeof(T), &img->stride);         \
        if (!img->px) return false;                                        \
        img->w = w;                                                        \
        img->h = h;                                                        \
        return true;                                                       \
    }
DEFINE_ALLOC(warp_image_rgba8_alloc, warp_image_rgba8, warp_rgba8)
DEFINE_ALLOC(warp_image_f32_alloc, warp_image_f32, float)
DEFINE_ALLOC(warp_image_u16_alloc, warp_image_u16, uint16_t)
DEFINE_ALLOC(warp_image_vec2f_alloc, warp_image_vec2f, warp_vec2f)
DEFINE_ALLOC(warp_image_u8_alloc, warp_image_u8, uint8_t)

bool warp_image_layers_alloc(warp_image_layers *img, int w, int h, int max_layers)
{
    memset(img, 0, sizeof *img);
    if (w <= 0 || h <= 0 || max_layers <= 0 || max_layers > 64) return false;
    size_t n = (size_t)w * (size_t)h;
    img->count = calloc(n, 1);
    img->frag = calloc(n * (size_t)max_layers, sizeof(warp_fragment));
    if (!img->count || !img->frag) {
        warp_image_layers_free(img);
        return false;
    }
    img->w = w;
    img->h = h;
    img->max_layers = max_layers;
    return true;
}

void warp_image_free_ptr(void **px, int *w, int *h)
{
    free(*px);
    *px = NULL;
    *w = *h = 0;
}

void warp_image_layers_free(warp_image_layers *img)
{
    free(img->count);
    free(img->frag);
    memset(img, 0, sizeof *img);
}

void warp_image_rgba8_fill(warp_image_rgba8 *img, warp_rgba8 c)
{
    for (int y = 0; y < img->h; y++)
        for (int x = 0; x < img->w; x++) WARP_AT(img, x, y) = c;
}

void warp_image_u8_fill(warp_image_u8 *img, uint8_t v)
{
    for (int y = 0; y < img->h; y++) memset(&WARP_AT(img, 0, y), v, (size_t)img->w);
}

void warp_image_rgba8_copy(warp_image_rgba8 *dst, const warp_image_rgba8 *src)
{
    for (int y = 0; y < src->h && y < dst->h; y++)
        memcpy(&WARP_AT(dst, 0, y), &WARP_AT(src, 0, y), sizeof(warp_rgba8) * (size_t)(src->w < dst->w ? src->w : dst->w));
}

static inline float clampf(float v, float lo, float hi) { return v < lo ? lo : (v > hi ? hi : v); }

/* The four texels around pixel-centre coordinates (x, y) of a w x h image, clamped at the border, and the
 * weights' fractions: shared by both samplers so colour and depth sample the same texels. */
typedef struct {
    int x0, y0, x1, y1;
    float ax, ay;
} bilinear_taps;

static inline bilinear_taps bilinear_at(int w, int h, float x, float y)
{
    /* NaN coordinates would make the index undefined: send them to the origin (callers flag such pixels). */
    if (!(x == x)) x = 0.5f;
    if (!(y == y)) y = 0.5f;
    float fx = clampf(x - 0.5f, 0.0f, (float)(w - 1));
    float fy = clampf(y - 0.5f, 0.0f, (float)(h - 1));
    bilinear_taps t;
    t.x0 = (int)fx;
    t.y0 = (int)fy;
    t.x1 = t.x0 + 1 < w ? t.x0 + 1 : t.x0;
    t.y1 = t.y0 + 1 < h ? t.y0 + 1 : t.y0;
    t.ax = fx - (float)t.x0;
    t.ay = fy - (float)t.y0;
    return t;
}

warp_rgba8 warp_sample_bilinear(const warp_image_rgba8 *img, float x, float y)
{
    const bilinear_taps t = bilinear_at(img->w, img->h, x, y);
    const int x0 = t.x0, y0 = t.y0, x1 = t.x1, y1 = t.y1;
    const float ax = t.ax, ay = t.ay;
    const warp_rgba8 p00 = WARP_AT(img, x0, y0), p10 = WARP_AT(img, x1, y0);
    const warp_rgba8 p01 = WARP_AT(img, x0, y1), p11 = WARP_AT(img, x1, y1);
    float w00 = (1 - ax) * (1 - ay), w10 = ax * (1 - ay), w01 = (1 - ax) * ay, w11 = ax * ay;
    warp_rgba8 o;
    o.r = (uint8_t)(p00.r * w00 + p10.r * w10 + p01.r * w01 + p11.r * w11 + 0.5f);
    o.g = (uint8_t)(p00.g * w00 + p10.g * w10 + p01.g * w01 + p11.g * w11 + 0.5f);
    o.b = (uint8_t)(p00.b * w00 + p10.b * w10 + p01.b * w01 + p11.b * w11 + 0.5f);
    o.a = (uint8_t)(p00.a * w00 + p10.a * w10 + p01.a * w01 + p11.a * w11 + 0.5f);
    return o;
}

float warp_sample_f32(const warp_image_f32 *img, float x, float y)
{
    const bilinear_taps t = bilinear_at(img->w, img->h, x, y);
    const int x0 = t.x0, y0 = t.y0, x1 = t.x1, y1 = t.y1;
    const float ax = t.ax, ay = t.ay;
    float top = WARP_AT(img, x0, y0) + (WARP_AT(img, x1, y0) - WARP_AT(img, x0, y0)) * ax;
    float bot = WARP_AT(img, x0, y1) + (WARP_AT(img, x1, y1) - WARP_AT(img, x0, y1)) * ax;
    return top + (bot - top) * ay;
}

/* SPDX-License-Identifier: MIT */
/* warp_image: the image planes a frame can carry (RGBA8 colour, float depth, u16 object ids, float2 motion,
 * u8 masks, A-buffer fragment layers), their allocation, and bilinear sampling of colour. */
#ifndef WARP_IMAGE_H
#define WARP_IMAGE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef struct { uint8_t r, g, b, a; } warp_rgba8;
typedef struct { float x, y; } warp_vec2f;

/* Every plane: w x h pixels, rows `stride` elements apart (stride >= w), px owned by whoever allocated it. */
typedef struct { int w, h, stride; warp_rgba8 *px; } warp_image_rgba8;
typedef struct { int w, h, stride; float *px; } warp_image_f32;
typedef struct { int w, h, stride; uint16_t *px; } warp_image_u16;
typedef struct { int w, h, stride; warp_vec2f *px; } warp_image_vec2f;
typedef struct { int w, h, stride; uint8_t *px; } warp_image_u8;

/* Transparent fragments of one pixel, nearest first (A-buffer, 000 §4.2). Colour is straight (not premultiplied)
 * alpha; z is linear view depth in metres. */
typedef struct { float z; warp_rgba8 rgba; uint16_t id; } warp_fragment;
typedef struct {
    int w, h, max_layers;
    uint8_t *count;       /* [y*w + x]: fragments stored for the pixel (<= max_layers) */
    warp_fragment *frag;  /* [(y*w + x) * max_layers + k] */
} warp_image_layers;

/* The largest image side any part accepts (eye buffers, panels, host frames, files read): far above any headset
 * panel, small enough that w * h * 16 bytes and every pixel index stay within size_t and int arithmetic. */
#define WARP_MAX_SIDE 16384

#define WARP_AT(img, x, y) ((img)->px[(size_t)(y) * (size_t)(img)->stride + (size_t)(x)])

/* Allocation: rows padded to 64 bytes; returns false on bad size or out of memory (the image is then zeroed). */
bool warp_image_rgba8_alloc(warp_image_rgba8 *img, int w, int h);
bool warp_image_f32_alloc(warp_image_f32 *img, int w, int h);
bool warp_image_u16_alloc(warp_image_u16 *img, int w, int h);
bool warp_image_vec2f_alloc(warp_image_vec2f *img, int w, int h);
bool warp_image_u8_alloc(warp_image_u8 *img, int w, int h);
bool warp_image_layers_alloc(warp_image_layers *img, int w, int h, int max_layers);
/* Free any of the above (safe on a zeroed image). */
#define warp_image_free(img) warp_image_free_ptr((void **)&(img)->px, &(img)->w, &(img)->h)
void warp_image_free_ptr(void **px, int *w, int *h);
void warp_image_layers_free(warp_image_layers *img);

void warp_image_rgba8_fill(warp_image_rgba8 *img, warp_rgba8 c);
void warp_image_u8_fill(warp_image_u8 *img, uint8_t v);
void warp_image_rgba8_copy(warp_image_rgba8 *dst, const warp_image_rgba8 *src); /* same size */

/* Bilinear colour at continuous coordinates (pixel centres at +0.5), clamped to the image: sampling outside
 * repeats the border, which is exactly the fringe fill of 003 §4.3. */
warp_rgba8 warp_sample_bilinear(const warp_image_rgba8 *img, float x, float y);
/* Bilinear float sample with the same conventions. */
float warp_sample_f32(const warp_image_f32 *img, float x, float y);

/* Mask values written by warps (bit flags). */
enum {
    WARP_MASK_FRINGE = 1, /* sampled outside the source image: clamped fill (003 §4.3) */
    WARP_MASK_EDGE = 2,   /* disocclusion: stretched across a depth edge (003 §4.4) */
    WARP_MASK_HOLE = 4,   /* no source sample reached the pixel (forward warps) or the search did not converge
                           * (iterative warps); a hole filler has written it, if one ran */
    WARP_MASK_FILLED = 8, /* written by a hole filler */
};

#endif

/* SPDX-License-Identifier: MIT */
/* plat_png: PNG image file I/O through libpng, for snapshots, tools and test artefacts.
 * Never called on the vsync path (file I/O). */
#ifndef PLAT_PNG_H
#define PLAT_PNG_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "warp/warp_image.h"

/* Writes an RGBA8 image as an 8-bit RGBA PNG (rgb_only drops alpha). On failure returns false and writes a
 * message naming the file and the cause into err (may be NULL). */
bool plat_png_write(const char *path, const warp_image_rgba8 *img, bool rgb_only, char *err, int errlen);
/* Writes an 8-bit grey PNG. */
bool plat_png_write_u8(const char *path, const warp_image_u8 *img, char *err, int errlen);
/* What the readers take: at most PLAT_PNG_MAX_SIDE per side and PLAT_PNG_MAX_PIXELS in all (a 16384 x 16384 frame),
 * and never more pixels than the file's bytes can decompress to; checked before anything is allocated. */
#define PLAT_PNG_MAX_SIDE WARP_MAX_SIDE
#define PLAT_PNG_MAX_PIXELS ((size_t)WARP_MAX_SIDE * WARP_MAX_SIDE)

/* Reads any PNG (grey, RGB, palette, 16-bit, with or without alpha) into a newly allocated RGBA8 image. */
bool plat_png_read(const char *path, warp_image_rgba8 *img, char *err, int errlen);
/* The same with a smaller bound on the pixel count (a caller that knows its frames' size; the fuzzer). */
bool plat_png_read_max(const char *path, warp_image_rgba8 *img, size_t max_pixels, char *err, int errlen);

/* Reads a 16-bit PNG as 16-bit grey values, exactly (depth and object-id planes; 8-bit files are refused since
 * libpng would treat them as sRGB). Allocates *px (w*h values, row-major); free() it. */
bool plat_png_read_u16(const char *path, uint16_t **px, int *w, int *h, char *err, int errlen);
bool plat_png_read_u16_max(const char *path, uint16_t **px, int *w, int *h, size_t max_pixels, char *err,
                           int errlen);
/* Writes w*h 16-bit grey values as a 16-bit PNG. */
bool plat_png_write_u16(const char *path, const uint16_t *px, int w, int h, char *err, int errlen);

#endif

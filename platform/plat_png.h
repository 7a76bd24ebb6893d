/* SPDX-License-Identifier: MIT */
/* plat_png: PNG image file I/O through libpng, for snapshots, tools and test artefacts.
 * Never called on the vsync path (file I/O). */
#ifndef PLAT_PNG_H
#define PLAT_PNG_H

#include <stdbool.h>
#include <stdint.h>

#include "warp/warp_image.h"

/* Writes an RGBA8 image as an 8-bit RGBA PNG (rgb_only drops alpha). On failure returns false and writes a
 * message naming the file and the cause into err (may be NULL). */
bool plat_png_write(const char *path, const warp_image_rgba8 *img, bool rgb_only, char *err, int errlen);
/* Writes an 8-bit grey PNG. */
bool plat_png_write_u8(const char *path, const warp_image_u8 *img, char *err, int errlen);
/* Reads any PNG (grey, RGB, palette, 16-bit, with or without alpha) into a newly allocated RGBA8 image. */
bool plat_png_read(const char *path, warp_image_rgba8 *img, char *err, int errlen);

/* Reads a 16-bit PNG as 16-bit grey values, exactly (depth and object-id planes; 8-bit files are refused since
 * libpng would treat them as sRGB). Allocates *px (w*h values, row-major); free() it. */
bool plat_png_read_u16(const char *path, uint16_t **px, int *w, int *h, char *err, int errlen);
/* Writes w*h 16-bit grey values as a 16-bit PNG. */
bool plat_png_write_u16(const char *path, const uint16_t *px, int w, int h, char *err, int errlen);

#endif

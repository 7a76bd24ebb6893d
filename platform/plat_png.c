/* SPDX-License-Identifier: MIT */
/* plat_png: PNG image file I/O through libpng, for snapshots, tools and test artefacts.
 * Never called on the vsync path (file I/O). */
#include "platform/plat_png.h"

#include <errno.h>
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "warp/warp_err.h"

static bool write_png(const char *path, int w, int h, int color_type, png_bytep *rows, char *err, int errlen)
{
    FILE *f = fopen(path, "wb");
    if (!f) return warp_err(err, errlen, "cannot write %s: %s", path, strerror(errno));
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!png || !info) {
        png_destroy_write_struct(&png, &info);
        fclose(f);
        return warp_err(err, errlen, "cannot write %s: %s", path, "out of memory");
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        fclose(f);
        return warp_err(err, errlen, "cannot write %s: %s", path, "libpng error");
    }
    png_init_io(png, f);
    /* Fast compression: snapshots are for looking at, and the writer thread should keep up. */
    png_set_compression_level(png, 1);
    png_set_IHDR(png, info, (png_uint_32)w, (png_uint_32)h, 8, color_type, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    png_write_image(png, rows);
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    if (fclose(f) != 0) return warp_err(err, errlen, "cannot write %s: %s", path, strerror(errno));
    return true;
}

bool plat_png_write(const char *path, const warp_image_rgba8 *img, bool rgb_only, char *err, int errlen)
{
    png_bytep *rows = malloc(sizeof(png_bytep) * (size_t)img->h);
    unsigned char *rgb = NULL;
    if (!rows) return warp_err(err, errlen, "cannot write %s: %s", path, "out of memory");
    if (rgb_only) {
        rgb = malloc((size_t)img->w * (size_t)img->h * 3);
        if (!rgb) {
            free(rows);
            return warp_err(err, errlen, "cannot write %s: %s", path, "out of memory");
        }
        for (int y = 0; y < img->h; y++) {
            unsigned char *d = rgb + (size_t)y * (size_t)img->w * 3;
            const warp_rgba8 *s = &WARP_AT(img, 0, y);
            for (int x = 0; x < img->w; x++) {
                d[3 * x] = s[x].r;
                d[3 * x + 1] = s[x].g;
                d[3 * x + 2] = s[x].b;
            }
            rows[y] = d;
        }
    } else {
        for (int y = 0; y < img->h; y++) rows[y] = (png_bytep)&WARP_AT(img, 0, y);
    }
    bool ok = write_png(path, img->w, img->h, rgb_only ? PNG_COLOR_TYPE_RGB : PNG_COLOR_TYPE_RGBA, rows, err, errlen);
    free(rgb);
    free(rows);
    return ok;
}

bool plat_png_write_u8(const char *path, const warp_image_u8 *img, char *err, int errlen)
{
    png_bytep *rows = malloc(sizeof(png_bytep) * (size_t)img->h);
    if (!rows) return warp_err(err, errlen, "cannot write %s: %s", path, "out of memory");
    for (int y = 0; y < img->h; y++) rows[y] = (png_bytep)&WARP_AT(img, 0, y);
    bool ok = write_png(path, img->w, img->h, PNG_COLOR_TYPE_GRAY, rows, err, errlen);
    free(rows);
    return ok;
}

/* Opens path and starts libpng's simplified read; checks the declared size before anything is allocated. A header
 * is 33 bytes, so a file could declare 2^31 x 2^31 pixels: the size must fit max_pixels and also the file itself.
 * Deflate expands at most 1032:1, and every row holds a filter byte plus at least w/8 bytes (1-bit pixels), so a
 * file of n bytes can only hold rows adding up to about 1032 n bytes (plus slack for the chunks around them). */
static bool begin_read(const char *path, png_image *pi, FILE **fp, size_t max_pixels, char *err, int errlen)
{
    memset(pi, 0, sizeof *pi);
    pi->version = PNG_IMAGE_VERSION;
    FILE *f = fopen(path, "rb");
    if (!f) return warp_err(err, errlen, "cannot read %s: %s", path, strerror(errno));
    struct stat st;
    if (fstat(fileno(f), &st) != 0 || !S_ISREG(st.st_mode)) {
        fclose(f);
        return warp_err(err, errlen, "cannot read %s: %s", path, "not a regular file");
    }
    if (!png_image_begin_read_from_stdio(pi, f)) {
        fclose(f);
        return warp_err(err, errlen, "cannot read %s: %s", path, pi->message);
    }
    size_t w = pi->width, h = pi->height;
    unsigned long long raw_min = (unsigned long long)h * (1 + (w + 7) / 8);
    unsigned long long raw_max = 1032ull * (unsigned long long)st.st_size + 65536;
    char why[160];
    if (w == 0 || h == 0 || w > PLAT_PNG_MAX_SIDE || h > PLAT_PNG_MAX_SIDE || w * h > max_pixels) {
        snprintf(why, sizeof why, "%zux%zu pixels is larger than this reader takes (%d per side, %zu in all)", w, h,
                 PLAT_PNG_MAX_SIDE, max_pixels);
    } else if (raw_min > raw_max) {
        snprintf(why, sizeof why, "declares %zux%zu pixels, more than a file of %lld bytes can hold", w, h,
                 (long long)st.st_size);
    } else {
        *fp = f;
        return true;
    }
    png_image_free(pi);
    fclose(f);
    return warp_err(err, errlen, "cannot read %s: %s", path, why);
}

bool plat_png_read_max(const char *path, warp_image_rgba8 *img, size_t max_pixels, char *err, int errlen)
{
    /* libpng's simplified API converts every PNG flavour to RGBA8 for us. */
    png_image pi;
    FILE *f;
    memset(img, 0, sizeof *img);
    if (!begin_read(path, &pi, &f, max_pixels, err, errlen)) return false;
    pi.format = PNG_FORMAT_RGBA;
    if (!warp_image_rgba8_alloc(img, (int)pi.width, (int)pi.height)) {
        png_image_free(&pi);
        fclose(f);
        return warp_err(err, errlen, "cannot read %s: %s", path, "out of memory");
    }
    bool ok = png_image_finish_read(&pi, NULL, img->px, (png_int_32)(img->stride * 4), NULL);
    fclose(f);
    if (!ok) {
        warp_image_free(img);
        return warp_err(err, errlen, "cannot read %s: %s", path, pi.message);
    }
    return true;
}

bool plat_png_read(const char *path, warp_image_rgba8 *img, char *err, int errlen)
{
    return plat_png_read_max(path, img, PLAT_PNG_MAX_PIXELS, err, errlen);
}

bool plat_png_read_u16_max(const char *path, uint16_t **px, int *w, int *h, size_t max_pixels, char *err,
                           int errlen)
{
    png_image pi;
    FILE *f;
    *px = NULL;
    if (!begin_read(path, &pi, &f, max_pixels, err, errlen)) return false;
    /* libpng's simplified API reads 16-bit files as linear data, exactly; an 8-bit file would be taken as sRGB
     * and converted, which would corrupt depth values and object ids: refuse it. */
    if (!(pi.format & PNG_FORMAT_FLAG_LINEAR)) {
        png_image_free(&pi);
        fclose(f);
        return warp_err(err, errlen, "cannot read %s: %s", path, "expected a 16-bit PNG (depth or id plane)");
    }
    pi.format = PNG_FORMAT_LINEAR_Y;
    *px = malloc(sizeof(uint16_t) * (size_t)pi.width * (size_t)pi.height); /* bounded by begin_read */
    if (!*px) {
        png_image_free(&pi);
        fclose(f);
        return warp_err(err, errlen, "cannot read %s: %s", path, "out of memory");
    }
    bool ok = png_image_finish_read(&pi, NULL, *px, 0, NULL);
    fclose(f);
    if (!ok) {
        free(*px);
        *px = NULL;
        return warp_err(err, errlen, "cannot read %s: %s", path, pi.message);
    }
    *w = (int)pi.width;
    *h = (int)pi.height;
    return true;
}

bool plat_png_read_u16(const char *path, uint16_t **px, int *w, int *h, char *err, int errlen)
{
    return plat_png_read_u16_max(path, px, w, h, PLAT_PNG_MAX_PIXELS, err, errlen);
}

bool plat_png_write_u16(const char *path, const uint16_t *px, int w, int h, char *err, int errlen)
{
    png_image pi;
    memset(&pi, 0, sizeof pi);
    pi.version = PNG_IMAGE_VERSION;
    pi.width = (png_uint_32)w;
    pi.height = (png_uint_32)h;
    pi.format = PNG_FORMAT_LINEAR_Y;
    if (!png_image_write_to_file(&pi, path, 0, px, 0, NULL))
        return warp_err(err, errlen, "cannot write %s: %s", path, pi.message);
    return true;
}

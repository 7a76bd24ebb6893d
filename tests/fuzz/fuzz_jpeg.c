/* SPDX-License-Identifier: MIT */
/* Fuzzes the JPEG slice decoder (drivers/drv_codec_jpeg.c, libturbojpeg): [width-1][height-1][JPEG bytes] decoded
 * into a plane of exactly that size; an accepted slice has alpha 255 and re-encodes and decodes at its size. */
#include <stdlib.h>
#include <string.h>
#include <turbojpeg.h>

#include "drivers/drv_codec_jpeg.h"
#include "tests/fuzz/fuzz.h"

/* Slices up to 256 x 256: the decoder's checks do not depend on size, and small planes keep executions fast. */
static void check_round_trip(drv_jpeg *enc, drv_jpeg *dec, const uint8_t *rgba, int w, int h)
{
    size_t cap = drv_jpeg_bound(w, h, DRV_JPEG_444);
    uint8_t *jpeg = malloc(cap), *back = malloc((size_t)w * h * 4);
    char err[256];
    size_t len = drv_jpeg_encode(enc, rgba, w, h, (size_t)w * 4, 90, DRV_JPEG_444, jpeg, cap, err, sizeof err);
    if (len == 0 || len > cap) abort();
    if (drv_jpeg_decode(dec, jpeg, len, back, w, h, (size_t)w * 4, err, sizeof err) != DRV_FRAME_OK) abort();
    free(jpeg);
    free(back);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static drv_jpeg *enc, *dec;
    char err[256];
    if (!dec && (!(enc = drv_jpeg_create(true, err, sizeof err)) || !(dec = drv_jpeg_create(false, err, sizeof err))))
        abort();
    if (size < 2) return 0;
    int w = data[0] + 1, h = data[1] + 1;
    /* Exactly the plane, so a write past it is a sanitizer report. */
    uint8_t *px = malloc((size_t)w * h * 4);
    drv_frame_err e = drv_jpeg_decode(dec, data + 2, size - 2, px, w, h, (size_t)w * 4, err, sizeof err);
    if (e == DRV_FRAME_OK) {
        for (size_t i = 3; i < (size_t)w * h * 4; i += 4)
            if (px[i] != 255) abort();
        check_round_trip(enc, dec, px, w, h);
    } else if (e != DRV_FRAME_ERR_BAD_FORMAT && e != DRV_FRAME_ERR_BAD_SIZE) {
        abort();
    } else if (!err[0]) {
        abort(); /* every refusal says why */
    }
    free(px);
    return 0;
}

static void seed(drv_jpeg *enc, const char *name, int w, int h, int quality, drv_jpeg_sub sub)
{
    uint8_t *rgba = malloc((size_t)w * h * 4);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            uint8_t *p = rgba + ((size_t)y * w + x) * 4;
            p[0] = (uint8_t)(x * 255 / w), p[1] = (uint8_t)(y * 255 / h), p[2] = x == y ? 250 : 60, p[3] = 0;
        }
    size_t cap = drv_jpeg_bound(w, h, sub);
    uint8_t *buf = malloc(2 + cap);
    char err[256];
    size_t len = drv_jpeg_encode(enc, rgba, w, h, (size_t)w * 4, quality, sub, buf + 2, cap, err, sizeof err);
    if (len == 0) abort();
    buf[0] = (uint8_t)(w - 1), buf[1] = (uint8_t)(h - 1);
    fuzz_seed(name, buf, 2 + len);
    free(buf);
    free(rgba);
}

/* Flavours the project's encoder never makes but a host's libjpeg could: progressive (many scans: the scan limit)
 * and greyscale (one component, converted to RGBA), made with libturbojpeg directly. */
static void seed_flavour(const char *name, int sub, int flags)
{
    enum { W = 24, H = 16 };
    uint8_t rgb[W * H * 3];
    for (int i = 0; i < W * H * 3; i++) rgb[i] = (uint8_t)(i * 37 / 5);
    tjhandle tj = tjInitCompress();
    unsigned char *jpeg = NULL;
    unsigned long len = 0;
    if (!tj || tjCompress2(tj, rgb, W, W * 3, H, TJPF_RGB, &jpeg, &len, sub, 85, flags) != 0) abort();
    uint8_t *buf = malloc(2 + len);
    buf[0] = W - 1, buf[1] = H - 1;
    memcpy(buf + 2, jpeg, len);
    fuzz_seed(name, buf, 2 + len);
    free(buf);
    tjFree(jpeg);
    tjDestroy(tj);
}

void fuzz_write_seeds(void)
{
    seed_flavour("24x16-progressive", TJSAMP_420, TJFLAG_PROGRESSIVE);
    seed_flavour("24x16-grey", TJSAMP_GRAY, 0);
    char err[256];
    drv_jpeg *enc = drv_jpeg_create(true, err, sizeof err);
    if (!enc) abort();
    seed(enc, "16x8-420", 16, 8, 80, DRV_JPEG_420);
    seed(enc, "3x5-444", 3, 5, 95, DRV_JPEG_444);
    seed(enc, "1x1-420", 1, 1, 50, DRV_JPEG_420);
    seed(enc, "40x24-444", 40, 24, 30, DRV_JPEG_444);
    drv_jpeg_destroy(enc);
}

/* SPDX-License-Identifier: MIT */
/* Fuzzes the PNG readers (platform/plat_png.c, libpng's simplified API): any PNG flavour to RGBA8, and 16-bit grey
 * exactly; sizes bounded before allocation (here to 2^20 pixels, the check plat_png_read makes at 16384^2). */
#include <stdio.h>
#include <stdlib.h>

#include "platform/plat_png.h"
#include "tests/fuzz/fuzz.h"

#define MAX_PIXELS ((size_t)1 << 20)

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fuzz_file(data, size);
    char err[512];
    warp_image_rgba8 img;
    if (plat_png_read_max(path, &img, MAX_PIXELS, err, sizeof err)) {
        if ((size_t)img.w * (size_t)img.h > MAX_PIXELS) abort();
        warp_image_free(&img);
    }
    uint16_t *px;
    int w, h;
    if (plat_png_read_u16_max(path, &px, &w, &h, MAX_PIXELS, err, sizeof err)) {
        if ((size_t)w * (size_t)h > MAX_PIXELS) abort();
        free(px);
    }
    return 0;
}

void fuzz_write_seeds(void)
{
    char path[256], err[256];
    warp_image_rgba8 img;
    if (!warp_image_rgba8_alloc(&img, 5, 3)) abort();
    for (int y = 0; y < 3; y++)
        for (int x = 0; x < 5; x++) WARP_AT(&img, x, y) = (warp_rgba8){(uint8_t)(x * 50), (uint8_t)(y * 80), 9, 200};
    snprintf(path, sizeof path, "%s/seed-rgba", fuzz_seed_dir);
    if (!plat_png_write(path, &img, false, err, sizeof err)) abort();
    snprintf(path, sizeof path, "%s/seed-rgb", fuzz_seed_dir);
    if (!plat_png_write(path, &img, true, err, sizeof err)) abort();
    warp_image_free(&img);
    uint16_t px[4 * 3];
    for (int i = 0; i < 12; i++) px[i] = (uint16_t)(i * 5000);
    snprintf(path, sizeof path, "%s/seed-u16", fuzz_seed_dir);
    if (!plat_png_write_u16(path, px, 4, 3, err, sizeof err)) abort();
}

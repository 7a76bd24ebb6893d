/* SPDX-License-Identifier: MIT */
/* hil_imgcmp: compares the last panel image of two raw sink streams (hmdwarpd's display.sink = raw: RGBA8 images
 * of the panel's size, appended) and prints PSNR and the largest channel difference, for the HIL scenarios. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "warp/warp_image.h"
#include "warp/warp_metrics.h"

/* The stream's last complete w x h image into img; false with a message when there is none. */
static int last_image(const char *path, int w, int h, warp_image_rgba8 *img)
{
    FILE *f = fopen(path, "rb");
    if (!f) return fprintf(stderr, "hil_imgcmp: %s: %s\n", path, strerror(errno)), 0;
    long sz = (long)w * h * 4;
    if (fseek(f, 0, SEEK_END) != 0 || ftell(f) < sz) {
        fclose(f);
        return fprintf(stderr, "hil_imgcmp: %s holds no complete %dx%d image\n", path, w, h), 0;
    }
    long n = ftell(f) / sz;
    fseek(f, (n - 1) * sz, SEEK_SET);
    int ok = 1;
    for (int y = 0; y < h && ok; y++) ok = fread(&WARP_AT(img, 0, y), 4, (size_t)w, f) == (size_t)w;
    fclose(f);
    if (!ok) fprintf(stderr, "hil_imgcmp: %s: short read\n", path);
    return ok;
}

int main(int argc, char **argv)
{
    if (argc != 5) {
        fprintf(stderr, "usage: hil_imgcmp A.rgba B.rgba WIDTH HEIGHT\n"
                        "Prints 'psnr=DB maxdiff=N' for the last image of each raw stream (psnr=inf when equal).\n");
        return 2;
    }
    int w = atoi(argv[3]), h = atoi(argv[4]);
    if (w < 1 || h < 1 || w > WARP_MAX_SIDE || h > WARP_MAX_SIDE)
        return fprintf(stderr, "hil_imgcmp: bad size %sx%s\n", argv[3], argv[4]), 2;
    warp_image_rgba8 a, b;
    if (!warp_image_rgba8_alloc(&a, w, h) || !warp_image_rgba8_alloc(&b, w, h)) return 1;
    if (!last_image(argv[1], w, h, &a) || !last_image(argv[2], w, h, &b)) return 1;
    int maxd = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            warp_rgba8 p = WARP_AT(&a, x, y), q = WARP_AT(&b, x, y);
            int d[3] = {abs(p.r - q.r), abs(p.g - q.g), abs(p.b - q.b)};
            for (int c = 0; c < 3; c++)
                if (d[c] > maxd) maxd = d[c];
        }
    double psnr = warp_psnr(&a, &b, NULL, 0);
    printf("psnr=%.2f maxdiff=%d\n", psnr, maxd);
    warp_image_free(&a);
    warp_image_free(&b);
    return 0;
}

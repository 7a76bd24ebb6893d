/* SPDX-License-Identifier: MIT */
/* Fuzzes hmdwarp-warp's layers (A-buffer) reader (tools/common/warp_files.c) for an 8 x 6 view: header,
 * per-pixel counts against max_layers, truncation; nothing stays allocated when it fails. */
#include <stdio.h>
#include <stdlib.h>

#include "tests/fuzz/fuzz.h"
#include "tools/common/warp_files.h"

static const warp_camera cam = {FUZZ_EYE_W, FUZZ_EYE_H, 1, 1, 0.8, 0.8, 0.05, 100};

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    warp_image_layers l = {0};
    char err[512];
    if (!warpfile_read_layers(fuzz_file(data, size), &cam, &l, err, sizeof err)) {
        if (l.count || l.frag) abort(); /* a failed read keeps nothing allocated */
        return 0;
    }
    for (int i = 0; i < l.w * l.h; i++)
        if (l.count[i] > l.max_layers) abort();
    warp_image_layers_free(&l);
    return 0;
}

void fuzz_write_seeds(void)
{
    drv_frame f;
    fuzz_example_frame(&f, DRV_PLANE_COLOR | DRV_PLANE_LAYERS, 1);
    char path[256];
    snprintf(path, sizeof path, "%s/seed-layers", fuzz_seed_dir);
    if (!warpfile_write_layers(path, &f.layers[0])) abort();
    drv_frame_free(&f);
}

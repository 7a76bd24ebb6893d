/* SPDX-License-Identifier: MIT */
/* Fuzzes the framelink frame decoder (drivers/drv_framelink.c) with the bytes as a host could send them: peek,
 * decode into a frame allocated with every plane, validate, and re-encode what was accepted. */
#include <stdio.h>

#include "tests/fuzz/framelink_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fl_run(data, size);
    return 0;
}

void fuzz_write_seeds(void)
{
    static const unsigned planes[] = {DRV_PLANE_COLOR, DRV_PLANE_COLOR | DRV_PLANE_DEPTH, FUZZ_PLANES,
                                      DRV_PLANE_COLOR | DRV_PLANE_IDS | DRV_PLANE_MOTION,
                                      DRV_PLANE_COLOR | DRV_PLANE_LAYERS};
    uint8_t *buf = malloc(FUZZ_MAX_FRAME);
    for (int i = 0; i < (int)(sizeof planes / sizeof planes[0]); i++) {
        for (int unorm = 0; unorm < 2; unorm++) {
            drv_frame f;
            fuzz_example_frame(&f, planes[i], i);
            drv_framelink_tx tx = {4990000000LL, 100000, 200000, 300000, 400000,
                                   unorm ? DRV_FRAMELINK_FMT_UNORM16 : 0};
            if (unorm && (!(planes[i] & DRV_PLANE_DEPTH) || f.depth_encoding == WARP_DEPTH_LINEAR)) {
                drv_frame_free(&f);
                continue;
            }
            size_t n = drv_framelink_encode_ex(&f, &tx, buf, FUZZ_MAX_FRAME);
            if (!n) abort();
            char name[32];
            snprintf(name, sizeof name, "frame-%d%s", i, unorm ? "-unorm16" : "");
            fuzz_seed(name, buf, n);
            drv_frame_free(&f);
        }
    }
    free(buf);
}

/* SPDX-License-Identifier: MIT */
/* Fuzzes the framelink frame decoder behind its CRCs: both CRCs of the input are rewritten to match before
 * decoding, so mutations of the counts, descriptors, times, poses and planes reach the checks that follow. */
#include "tests/fuzz/framelink_common.h"

#include <stdio.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    uint8_t *copy = malloc(size ? size : 1);
    memcpy(copy, data, size);
    fl_repair(copy, size);
    fl_run(copy, size);
    free(copy);
    return 0;
}

void fuzz_write_seeds(void)
{
    static const unsigned planes[] = {DRV_PLANE_COLOR, FUZZ_PLANES, DRV_PLANE_COLOR | DRV_PLANE_LAYERS};
    uint8_t *buf = malloc(FUZZ_MAX_FRAME);
    for (int i = 0; i < 3; i++) {
        drv_frame f;
        fuzz_example_frame(&f, planes[i], i + 1);
        drv_framelink_tx tx = {4990000000LL, 100000, 200000, 300000, 400000, 0};
        size_t n = drv_framelink_encode_ex(&f, &tx, buf, FUZZ_MAX_FRAME);
        if (!n) abort();
        char name[32];
        snprintf(name, sizeof name, "frame-%d", i);
        fuzz_seed(name, buf, n);
        drv_frame_free(&f);
    }
    free(buf);
}

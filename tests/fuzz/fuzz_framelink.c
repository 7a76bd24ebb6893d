/* SPDX-License-Identifier: MIT */
/* Fuzzes the framelink frame decoder (drivers/drv_framelink.c, and drv_framelink_dec for v2's compressed planes)
 * with the bytes as a host could send them: peek, decode into a frame allocated with every plane, validate, and
 * re-encode what was accepted. */
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
    /* framelink v2: zstd planes (F32 and INV16 depth, ids, motion, layers), depth at 1/2 and 1/4 resolution. */
    static const struct {
        unsigned planes;
        int depth_format, depth_scale;
        drv_codec_id depth, other;
    } v2[] = {
        {FUZZ_PLANES, 0, 0, DRV_CODEC_ZSTD, DRV_CODEC_ZSTD},
        {FUZZ_PLANES, DRV_FRAMELINK_FMT_INV16, 0, DRV_CODEC_ZSTD, DRV_CODEC_ZSTD},
        {DRV_PLANE_COLOR | DRV_PLANE_DEPTH, DRV_FRAMELINK_FMT_INV16, 1, DRV_CODEC_ZSTD, DRV_CODEC_RAW},
        {DRV_PLANE_COLOR | DRV_PLANE_DEPTH | DRV_PLANE_IDS, DRV_FRAMELINK_FMT_INV16, 2, DRV_CODEC_RAW, DRV_CODEC_ZSTD},
    };
    for (int i = 0; i < (int)(sizeof v2 / sizeof v2[0]); i++) {
        drv_frame f;
        fuzz_example_frame(&f, v2[i].planes, 3 * i); /* seed a multiple of 3: linear depth (INV16 needs metres) */
        drv_framelink_enc_params p = drv_framelink_enc_params_raw();
        p.depth_format = v2[i].depth_format, p.depth_scale = v2[i].depth_scale;
        p.depth = v2[i].depth, p.other = v2[i].other;
        drv_framelink_enc *enc = drv_framelink_enc_create(&p, FUZZ_EYE_W, FUZZ_EYE_H, NULL, 0);
        drv_framelink_tx tx = {4990000000LL, 100000, 200000, 300000, 400000, 0};
        size_t n = enc ? drv_framelink_enc_encode(enc, &f, &tx, false, buf, FUZZ_MAX_FRAME, NULL, 0) : 0;
        if (!n) abort();
        char name[32];
        snprintf(name, sizeof name, "v2-%d", i);
        fuzz_seed(name, buf, n);
        drv_framelink_enc_destroy(enc);
        drv_frame_free(&f);
    }
    free(buf);
}

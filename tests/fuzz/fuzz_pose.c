/* SPDX-License-Identifier: MIT */
/* Fuzzes the board -> host message decoders (pose "HWP1", camera "HWC1", visibility mask "HWV1"; the host side decodes
 * them): as received, then with the CRC repaired; an accepted message re-encodes and decodes to the same values. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "drivers/drv_codec.h"
#include "drivers/drv_framelink.h"
#include "tests/fuzz/fuzz.h"

static void run_cams(const uint8_t *data, size_t size)
{
    drv_framelink_cams c, d;
    if (drv_framelink_cams_decode(data, size, &c) != DRV_FRAME_OK) return;
    if (c.cam[0].width <= 0 || c.cam[1].height <= 0 || !(c.planes & DRV_PLANE_COLOR)) abort();
    uint8_t buf[DRV_FRAMELINK_CAMS_BYTES];
    if (drv_framelink_cams_encode(&c, buf, sizeof buf) != sizeof buf) abort();
    if (drv_framelink_cams_decode(buf, sizeof buf, &d) != DRV_FRAME_OK || memcmp(&c.cam, &d.cam, sizeof c.cam) ||
        c.seq != d.seq || c.planes != d.planes || c.max_frame_bytes != d.max_frame_bytes || c.codecs != d.codecs ||
        !(c.codecs & DRV_CODEC_BIT(DRV_CODEC_RAW)))
        abort();
}

static void run_mask(const uint8_t *data, size_t size)
{
    drv_framelink_mask m, d;
    memset(&m, 0, sizeof m);
    memset(&d, 0, sizeof d);
    if (drv_framelink_mask_decode(data, size, &m) != DRV_FRAME_OK) return;
    for (int e = 0; e < 2; e++)
        if (m.n[e] < 0 || m.n[e] > DRV_FRAMELINK_MASK_MAX || m.n[e] == 1 || m.n[e] == 2) abort();
    uint8_t buf[DRV_FRAMELINK_MASK_BYTES(DRV_FRAMELINK_MASK_MAX, DRV_FRAMELINK_MASK_MAX)];
    size_t n = drv_framelink_mask_encode(&m, buf, sizeof buf);
    if (n != DRV_FRAMELINK_MASK_BYTES(m.n[0], m.n[1]) || drv_framelink_mask_decode(buf, n, &d) != DRV_FRAME_OK ||
        memcmp(&m, &d, sizeof m))
        abort();
}

static void run(const uint8_t *data, size_t size)
{
    size_t declared = 0;
    uint32_t kind = drv_framelink_msg_peek(data, size, &declared);
    if (kind == DRV_FRAMELINK_CAMS_MAGIC) {
        run_cams(data, size);
        return;
    }
    if (kind == DRV_FRAMELINK_MASK_MAGIC) {
        run_mask(data, size);
        return;
    }
    drv_framelink_pose p, q;
    if (drv_framelink_pose_decode(data, size, &p) != DRV_FRAME_OK) return;
    if (p.board_t_ns < 0 || p.target_t_ns < 0) abort();
    uint8_t buf[DRV_FRAMELINK_POSE_BYTES];
    if (drv_framelink_pose_encode(&p, buf, sizeof buf) != sizeof buf) abort();
    if (drv_framelink_pose_decode(buf, sizeof buf, &q) != DRV_FRAME_OK || memcmp(&p.head, &q.head, sizeof p.head) ||
        p.seq != q.seq || p.board_t_ns != q.board_t_ns || p.target_t_ns != q.target_t_ns)
        abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    run(data, size);
    if (size >= DRV_FRAMELINK_POSE_BYTES) {
        uint8_t copy[DRV_FRAMELINK_POSE_BYTES];
        memcpy(copy, data, sizeof copy);
        uint32_t c = (uint32_t)crc32_z(0, copy, 200);
        for (int i = 0; i < 4; i++) copy[200 + i] = (uint8_t)(c >> (8 * i));
        run(copy, sizeof copy);
    }
    if (size >= DRV_FRAMELINK_CAMS_BYTES) {
        uint8_t copy[DRV_FRAMELINK_CAMS_BYTES];
        memcpy(copy, data, sizeof copy);
        uint32_t c = (uint32_t)crc32_z(0, copy, DRV_FRAMELINK_CAMS_BYTES - 4);
        for (int i = 0; i < 4; i++) copy[DRV_FRAMELINK_CAMS_BYTES - 4 + i] = (uint8_t)(c >> (8 * i));
        run(copy, sizeof copy);
    }
    /* a mask message's CRC sits where its declared size says */
    size_t declared = 0;
    if (drv_framelink_msg_peek(data, size, &declared) == DRV_FRAMELINK_MASK_MAGIC && declared >= 24 &&
        declared <= size && declared <= DRV_FRAMELINK_MASK_BYTES(DRV_FRAMELINK_MASK_MAX, DRV_FRAMELINK_MASK_MAX)) {
        uint8_t copy[DRV_FRAMELINK_MASK_BYTES(DRV_FRAMELINK_MASK_MAX, DRV_FRAMELINK_MASK_MAX)];
        memcpy(copy, data, declared);
        uint32_t c = (uint32_t)crc32_z(0, copy, declared - 4);
        for (int i = 0; i < 4; i++) copy[declared - 4 + i] = (uint8_t)(c >> (8 * i));
        run(copy, declared);
    }
    return 0;
}

void fuzz_write_seeds(void)
{
    drv_framelink_pose p = {7, 0, 5000000000LL, 5020000000LL, {{1, 0, 0, 0}, {0, 1.6, 0}},
                            {{{1, 0, 0, 0}, {-0.032, 1.6, 0}}, {{1, 0, 0, 0}, {0.032, 1.6, 0}}}};
    uint8_t buf[DRV_FRAMELINK_POSE_BYTES];
    drv_framelink_pose_encode(&p, buf, sizeof buf);
    fuzz_seed("pose", buf, sizeof buf);
    p.head.q = (warp_quat){0.5, 0.5, 0.5, 0.5};
    drv_framelink_pose_encode(&p, buf, sizeof buf);
    fuzz_seed("pose-turned", buf, sizeof buf);
    drv_framelink_cams c = {.seq = 1, .planes = DRV_PLANE_COLOR | DRV_PLANE_DEPTH, .max_frame_bytes = 32u << 20,
                            .refresh_hz = 90, .pose_rate_hz = 180};
    c.cam[0] = c.cam[1] = warp_camera_symmetric(720, 800, 100, 104, 0.05, 1000);
    uint8_t cb[DRV_FRAMELINK_CAMS_BYTES];
    drv_framelink_cams_encode(&c, cb, sizeof cb);
    fuzz_seed("cams", cb, sizeof cb);
    c.codecs = DRV_CODEC_BIT(DRV_CODEC_RAW) | DRV_CODEC_BIT(DRV_CODEC_ZSTD) | DRV_CODEC_BIT(DRV_CODEC_JPEG);
    drv_framelink_cams_encode(&c, cb, sizeof cb); /* version 2: the board's codecs */
    fuzz_seed("cams-v2", cb, sizeof cb);
    drv_framelink_mask m = {.seq = 1, .n = {24, 24}};
    for (int e = 0; e < 2; e++)
        for (int k = 0; k < 24; k++) {
            m.uv[e][2 * k] = (float)(1.6 * cos(k * 2 * WARP_PI / 24));
            m.uv[e][2 * k + 1] = (float)(1.6 * sin(k * 2 * WARP_PI / 24));
        }
    uint8_t mb[DRV_FRAMELINK_MASK_BYTES(24, 24)];
    drv_framelink_mask_encode(&m, mb, sizeof mb);
    fuzz_seed("mask", mb, sizeof mb);
    m.n[1] = 0; /* one eye without a mask */
    size_t n = drv_framelink_mask_encode(&m, mb, sizeof mb);
    fuzz_seed("mask-one-eye", mb, n);
}

/* SPDX-License-Identifier: MIT */
/* The framelink frame harnesses' shared body (fuzz_framelink.c takes the bytes as they come, fuzz_framelink_crc.c
 * repairs both CRCs first so the checks behind them are reached). */
#ifndef HMDWARP_FUZZ_FRAMELINK_COMMON_H
#define HMDWARP_FUZZ_FRAMELINK_COMMON_H

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "drivers/drv_framelink.h"
#include "drivers/drv_framelink_codec.h"
#include "tests/fuzz/fuzz.h"

#define FUZZ_MAX_FRAME (1u << 20)

static inline uint32_t fl_get32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}
static inline void fl_put32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++) p[i] = (uint8_t)(v >> (8 * i));
}

/* Rewrites the header CRC (and the payload CRC when the declared total fits) of a frame starting at buf. */
static inline void fl_repair(uint8_t *buf, size_t len)
{
    if (len < DRV_FRAMELINK_PREFIX_BYTES) return;
    size_t hdr = (size_t)buf[6] | (size_t)buf[7] << 8;
    if (hdr < 8 || hdr > len) return;
    fl_put32(buf + hdr - 4, (uint32_t)crc32_z(0, buf, hdr - 4));
    size_t total = fl_get32(buf + 8);
    if (total >= hdr + 4 && total <= len) fl_put32(buf + total - 4, (uint32_t)crc32_z(0, buf + hdr, total - hdr - 4));
}

/* What an accepted frame must hold: times in range, finite unit poses (what the warps take without checking). */
static inline void fl_check_accepted(const drv_frame *f)
{
    drv_frame_validate(f);
    if (f->pose_t_ns < 0 || f->pose_t_ns > DRV_FRAMELINK_TIME_MAX_NS || f->render_start_ns < 0 ||
        f->render_start_ns > DRV_FRAMELINK_TIME_MAX_NS)
        abort();
    for (int i = -2; i < f->n_objects; i++) { /* eyes, then objects */
        warp_pose p = i < 0 ? f->eye_pose[i + 2] : f->object_pose[i];
        if (!warp_pose_isfinite(p) || !(fabs(warp_quat_norm(p.q) - 1.0) <= 1e-3)) abort();
    }
}

/* Decodes (peek, decode, validate) with drv_framelink_decode_ex and through a drv_framelink_dec (framelink v2's
 * compressed planes); a v1 frame that decodes re-encodes to the same bytes (f32 depth: exact), and the decoder
 * object accepts whatever decode_ex does, with the same pixels. */
static inline void fl_run(const uint8_t *data, size_t size)
{
    static drv_frame f, g;
    static uint8_t *again;
    static drv_framelink_dec *dec;
    if (!again) {
        if (!drv_frame_alloc(&f, FUZZ_EYE_W, FUZZ_EYE_H, FUZZ_PLANES, FUZZ_MAX_LAYERS) ||
            !drv_frame_alloc(&g, FUZZ_EYE_W, FUZZ_EYE_H, FUZZ_PLANES, FUZZ_MAX_LAYERS))
            abort();
        again = malloc(FUZZ_MAX_FRAME);
        dec = drv_framelink_dec_create(FUZZ_EYE_W, FUZZ_EYE_H, FUZZ_PLANES, FUZZ_MAX_LAYERS, 1, "", NULL, 0);
        if (!again || !dec) abort();
    }
    size_t total = 0;
    drv_framelink_peek(data, size, 0, &total);
    drv_framelink_peek(data, size, 4096, &total);
    drv_framelink_find_magic(data, size);
    char detail[160];
    drv_framelink_rx rx, rx2;
    drv_frame_err e1 = drv_framelink_decode_ex(data, size, FUZZ_MAX_FRAME, &f, &rx, detail, sizeof detail);
    if (e1 == DRV_FRAME_OK && strlen(detail) != 0) abort(); /* OK clears the detail */
    drv_frame_err e2 = drv_framelink_dec_decode(dec, data, size, FUZZ_MAX_FRAME, &g, &rx2, detail, sizeof detail);
    if (e2 == DRV_FRAME_OK) {
        if (strlen(detail) != 0) abort();
        fl_check_accepted(&g);
    }
    if (e1 != DRV_FRAME_OK) return;
    if (e2 != DRV_FRAME_OK || rx2.total_bytes != rx.total_bytes) abort(); /* the decoder reads all decode_ex reads */
    fl_check_accepted(&f);
    if (size >= 6 && data[4] != 1) return; /* v2 (INV16 depth): its own round trip is test_framelink_v2's */
    for (int e = 0; e < 2; e++)
        if (memcmp(f.color[e].px, g.color[e].px, sizeof(warp_rgba8) * (size_t)f.color[e].stride * FUZZ_EYE_H)) abort();
    if (rx.tx.depth_format == DRV_FRAMELINK_FMT_UNORM16) return; /* float depth in between: not bit exact */
    size_t n = drv_framelink_encode_ex(&f, &rx.tx, again, FUZZ_MAX_FRAME);
    if (n != rx.total_bytes || memcmp(again, data, n) != 0) abort();
}

#endif

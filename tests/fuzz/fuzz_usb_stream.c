/* SPDX-License-Identifier: MIT */
/* Fuzzes the USB receive state machine (drivers/drv_frames_usb.c, fed from memory): resync after garbage, partial
 * headers, oversize frames skipped unread, rejections and frames. Input: byte 0 bit 0 = repair the CRCs of every
 * frame found first; bytes 1-2 seed the chunk sizes the stream arrives in (1 byte up to a whole USB read); then the
 * stream. Whatever arrives, the receiver keeps taking bytes and never hands out more frames than there are magics. */
#include <stdlib.h>
#include <string.h>

#include "drivers/drv_frames_usb.h"
#include <stdio.h>

#include "tests/fuzz/framelink_common.h"

#define MAX_FRAME 16384

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static drv_frame f;
    static bool ready;
    if (!ready) {
        if (!drv_frame_alloc(&f, FUZZ_EYE_W, FUZZ_EYE_H, FUZZ_PLANES, FUZZ_MAX_LAYERS)) abort();
        ready = true;
    }
    if (size < 3) return 0;
    bool repair = data[0] & 1;
    uint32_t rng = (uint32_t)data[1] << 8 | data[2] | 1u;
    data += 3, size -= 3;
    uint8_t *s = malloc(size ? size : 1);
    memcpy(s, data, size);
    size_t magics = 0;
    for (size_t i = 0; i + 4 <= size; i++) {
        if (fl_get32(s + i) != DRV_FRAMELINK_MAGIC) continue;
        magics++;
        if (repair) fl_repair(s + i, size - i);
    }

    drv_frames_usb_params p = {.max_frame_bytes = MAX_FRAME, .eye_w = FUZZ_EYE_W, .eye_h = FUZZ_EYE_H,
                               .planes = FUZZ_PLANES};
    char err[160];
    drv_frames *fr = drv_frames_usb_create_fed(&p, err, sizeof err);
    if (!fr) abort();
    size_t off = 0, frames = 0;
    for (;;) {
        size_t took = 0;
        if (off < size) {
            /* chunk sizes from a xorshift: mostly small, sometimes up to a whole USB read */
            rng ^= rng << 13, rng ^= rng >> 17, rng ^= rng << 5;
            size_t chunk = (rng & 0x300) == 0x300 ? 1 + rng % 65536 : 1 + rng % 97;
            if (chunk > size - off) chunk = size - off;
            took = drv_frames_usb_feed(fr, s + off, chunk);
            off += took;
        }
        int got = 0, r;
        while ((r = drv_frames_receive(fr, &f, 0)) != 0) {
            got++;
            if (r == 1) {
                frames++;
                /* what reaches the runtime: finite poses (the warps do not check them), times in range */
                for (int i = 0; i < f.n_objects; i++)
                    if (!warp_pose_isfinite(f.object_pose[i])) abort();
                if (f.pose_t_ns < 0 || f.pose_t_ns > DRV_FRAMELINK_TIME_MAX_NS || f.render_start_ns < 0) abort();
            }
            if (r > 1 || r <= -DRV_FRAME_ERR_COUNT) abort(); /* 1, 0 or -reason */
        }
        if (took == 0 && got == 0) break;
    }
    if (off < size) abort(); /* the receiver stalled: it neither took bytes nor produced anything */
    drv_frames_usb_stats st;
    drv_frames_usb_stats_get(fr, &st);
    if (frames > magics || st.frames != frames || st.bytes > size) abort();
    drv_frames_destroy(fr);
    free(s);
    return 0;
}

void fuzz_write_seeds(void)
{
    uint8_t *buf = malloc(4 * MAX_FRAME);
    size_t n = 0;
    buf[n++] = 0, buf[n++] = 0x12, buf[n++] = 0x34;
    static const unsigned planes[] = {DRV_PLANE_COLOR, FUZZ_PLANES, DRV_PLANE_COLOR | DRV_PLANE_DEPTH};
    for (int i = 0; i < 3; i++) {
        drv_frame fr;
        fuzz_example_frame(&fr, planes[i], i);
        drv_framelink_tx tx = {4990000000LL, 100000, 200000, 300000, 400000, 0};
        n += drv_framelink_encode_ex(&fr, &tx, buf + n, 4 * MAX_FRAME - n);
        if (i == 0) memcpy(buf + n, "garbage!", 8), n += 8;
        drv_frame_free(&fr);
    }
    fuzz_seed("three-frames", buf, n);
    buf[0] = 1;
    fuzz_seed("three-frames-repaired", buf, n);
    free(buf);
}

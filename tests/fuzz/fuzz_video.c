/* SPDX-License-Identifier: MIT */
/* Fuzzes the video colour decoders (drivers/drv_codec_video.c, libavcodec H.264 / HEVC): a stream of access units
 * decoded in order into planes of exactly the eye's size; what is accepted has alpha 255, what is refused says why. */
#include <stdlib.h>
#include <string.h>

#include "drivers/drv_codec_video.h"
#include "tests/fuzz/fuzz.h"

/* Input: [flags: bit 0 HEVC, bit 1 an odd eye (37x29, else 64x48), bit 2 reset after each refusal] then records
 * [u16 little-endian length][access unit], at most MAX_AUS of them (a stream: references carry from one to the
 * next). Small eyes keep executions fast; the checks do not depend on size. */
#define MAX_AUS 8

static drv_video_dec *decoder(int codec_i, int size_i)
{
    static drv_video_dec *dec[2][2];
    static const int w[2] = {64, 37}, h[2] = {48, 29};
    char err[256];
    if (!dec[codec_i][size_i]) {
        drv_codec_id c = codec_i ? DRV_CODEC_HEVC : DRV_CODEC_H264;
        if (!drv_video_can_decode(c)) return NULL;
        dec[codec_i][size_i] = drv_video_dec_create(c, w[size_i], h[size_i], NULL, err, sizeof err);
        if (!dec[codec_i][size_i]) abort();
    }
    return dec[codec_i][size_i];
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1) return 0;
    uint8_t flags = data[0];
    int odd = (flags >> 1) & 1, w = odd ? 37 : 64, h = odd ? 29 : 48;
    drv_video_dec *d = decoder(flags & 1, odd);
    if (!d) return 0; /* this libavcodec lacks the decoder */
    drv_video_dec_reset(d); /* each input its own stream */
    /* Exactly the plane, so a write past it is a sanitizer report. */
    size_t bytes = (size_t)w * h * 4;
    uint8_t *px = malloc(bytes);
    size_t at = 1;
    for (int i = 0; i < MAX_AUS && at + 2 <= size; i++) {
        size_t len = data[at] | (size_t)data[at + 1] << 8;
        at += 2;
        if (len > size - at) len = size - at;
        char err[256] = "";
        drv_frame_err e = drv_video_decode(d, data + at, len, px, (size_t)w * 4, err, sizeof err);
        at += len;
        if (e == DRV_FRAME_OK) {
            for (size_t k = 3; k < bytes; k += 4)
                if (px[k] != 255) abort();
        } else if (e != DRV_FRAME_ERR_BAD_FORMAT && e != DRV_FRAME_ERR_BAD_SIZE && e != DRV_FRAME_ERR_TRUNCATED) {
            abort();
        } else if (!err[0]) {
            abort(); /* every refusal says why */
        } else if (flags & 4) {
            drv_video_dec_reset(d);
        }
    }
    free(px);
    return 0;
}

/* A stream from the project's encoder: a key frame, P-frames, and (forced) a second key frame. */
static void seed(const char *name, drv_codec_id c, int w, int h, int refresh, int frames)
{
    drv_video_params p = {.codec = c, .w = w, .h = h, .fps = 45, .quality = 30, .refresh_frames = refresh};
    char err[256];
    drv_video_enc *e = drv_video_enc_create(&p, err, sizeof err);
    if (!e) return; /* no such encoder here: no seed */
    size_t cap = (size_t)w * h * 4 + 4096;
    uint8_t *rgba = malloc((size_t)w * h * 4), *au = malloc(cap), *buf = malloc(1 + MAX_AUS * (2 + cap));
    size_t n = 0;
    buf[n++] = (uint8_t)((c == DRV_CODEC_HEVC) | (w == 37) << 1);
    for (int t = 0; t < frames && t < MAX_AUS; t++) {
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                uint8_t *q = rgba + ((size_t)y * w + x) * 4;
                q[0] = (uint8_t)((x + 2 * t) * 255 / w), q[1] = (uint8_t)(y * 255 / h), q[2] = x == y + t ? 250 : 60;
                q[3] = 255;
            }
        bool key;
        size_t len = drv_video_encode(e, rgba, (size_t)w * 4, t == frames - 1 && frames > 2, au, cap, &key, err,
                                      sizeof err);
        if (len == 0 || len > 0xffff) abort();
        buf[n++] = (uint8_t)len, buf[n++] = (uint8_t)(len >> 8);
        memcpy(buf + n, au, len);
        n += len;
    }
    fuzz_seed(name, buf, n);
    free(buf);
    free(au);
    free(rgba);
    drv_video_enc_destroy(e);
}

void fuzz_write_seeds(void)
{
    seed("h264-64x48", DRV_CODEC_H264, 64, 48, 0, 4);
    seed("h264-37x29-refresh", DRV_CODEC_H264, 37, 29, 3, 5);
    seed("hevc-64x48", DRV_CODEC_HEVC, 64, 48, 0, 4);
    seed("hevc-37x29-refresh", DRV_CODEC_HEVC, 37, 29, 3, 5);
    seed("h264-key", DRV_CODEC_H264, 64, 48, 0, 1);
    seed("hevc-key", DRV_CODEC_HEVC, 37, 29, 0, 1);
}

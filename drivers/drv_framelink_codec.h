/* SPDX-License-Identifier: MIT */
/* drv_framelink_codec: framelink v2's frame encoder (host) and decoder (board): a drv_frame to a frame with a codec
 * per plane and back, compressed chunks decoded in parallel on threads made at start-up; v1 frames stay readable. */
#ifndef DRV_FRAMELINK_CODEC_H
#define DRV_FRAMELINK_CODEC_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "drivers/drv_codec.h"
#include "drivers/drv_codec_jpeg.h"
#include "drivers/drv_framelink.h"
#include "drivers/drv_frames.h"

/* How a host encodes each plane (docs/framelink.md, version 2). All RAW (drv_framelink_enc_params_raw) sends v1
 * frames, byte for byte what drv_framelink_encode_ex writes, so an old board still reads them. */
typedef struct {
    drv_codec_id color;   /* RAW, JPEG, H264 or HEVC */
    int quality;          /* JPEG: 1..100; video: quantiser 1..51 when video_kbps is 0 */
    drv_jpeg_sub jpeg_sub;
    int slices;           /* JPEG: slices per eye 1..16 (each decodes on its own thread) */
    int video_kbps;       /* video: > 0 constant bit rate, 0 constant quality */
    int refresh_frames;   /* video: intra refresh period (frames); 0: key frames only when asked */
    double fps;           /* video rate control: the host's frame rate */
    drv_codec_id depth;   /* RAW or ZSTD */
    int depth_format;     /* 0 (F32), DRV_FRAMELINK_FMT_F32, _UNORM16 (window depth) or _INV16 (linear metres) */
    int depth_scale;      /* depth sent at 1/2^depth_scale resolution per axis: 0, 1 or 2 (board upsamples) */
    drv_codec_id other;   /* ids, motion, layers: RAW or ZSTD */
    int zstd_level;       /* 1..19 */
} drv_framelink_enc_params;

/* Everything raw: v1 frames. */
drv_framelink_enc_params drv_framelink_enc_params_raw(void);

/* What a host sends on auto (libhmdwarp-host, the mock USB host), measured by `make bench`'s link section
 * (docs/bench/link.md) at the rpi5 size (1440x1600 eyes, colour + depth, 45 Hz): JPEG q75 4:2:0 is the lowest
 * quality step above 38 dB colour PSNR (39.0), and with zstd INV16 depth at full resolution (exact for the warps)
 * a frame is 0.58 MB, 26 MB/s: USB 2.0 with margin. q85 with full-resolution depth is past 30 MB/s; q85 with depth
 * at half resolution is as many bytes and 1 dB better for the raytrace, but decodes in twice the time (the
 * colour-guided upsample), and on the board decode time is frame rate. */
#define DRV_FRAMELINK_AUTO_JPEG_QUALITY 75
#define DRV_FRAMELINK_AUTO_JPEG_SLICES 4
#define DRV_FRAMELINK_AUTO_VIDEO_QUANTISER 23
/* Auto against a board's announced codecs (DRV_CODEC_BIT()s): JPEG colour when announced, zstd depth (INV16 for
 * linear depth, UNORM16 for window depth) and zstd ids, motion and layers when zstd is; raw otherwise. */
drv_framelink_enc_params drv_framelink_enc_params_auto(unsigned codecs, warp_depth_encoding enc);
/* Checks p (codec per plane allowed, ranges); false with the field named in err. */
bool drv_framelink_enc_params_check(const drv_framelink_enc_params *p, char *err, int errlen);

/* Host side, one per stream: the codec state (video streams per eye, JPEG and zstd contexts, scratch for eyes of
 * up to w x h). */
typedef struct drv_framelink_enc drv_framelink_enc;
drv_framelink_enc *drv_framelink_enc_create(const drv_framelink_enc_params *p, int w, int h, char *err, int errlen);
void drv_framelink_enc_destroy(drv_framelink_enc *e);
/* The most bytes drv_framelink_enc_encode can write for f (0: f cannot be encoded with these parameters). */
size_t drv_framelink_enc_bound(const drv_framelink_enc *e, const drv_frame *f);
/* Encodes f into buf[cap]; want_key forces video key frames (the board asked: DRV_FRAMELINK_POSE_WANT_KEY).
 * Returns the frame's length, or 0 with the reason in err. */
size_t drv_framelink_enc_encode(drv_framelink_enc *e, const drv_frame *f, const drv_framelink_tx *tx, bool want_key,
                                uint8_t *buf, size_t cap, char *err, int errlen);

/* Board side, one per frame source: decoders for every codec of drv_codec_decodable(), scratch for eyes of w x h
 * and the planes it accepts, and `threads` decode threads (1: decode on the caller's thread). video_hw: as
 * drv_video_dec_create's hw. Made at start-up (it allocates); decode allocates nothing of its own. */
typedef struct drv_framelink_dec drv_framelink_dec;
drv_framelink_dec *drv_framelink_dec_create(int w, int h, unsigned planes, int max_layers, int threads,
                                            const char *video_hw, char *err, int errlen);
void drv_framelink_dec_destroy(drv_framelink_dec *d);
/* Decodes a v1 or v2 frame as drv_framelink_decode_ex does (same checks, same errors, *out untouched on any of
 * them), decompressing its planes. A corrupt JPEG or bitstream, a truncated zstd block or a missing video reference
 * is BAD_FORMAT (BAD_SIZE for sizes that disagree) with the reason in detail; after such a codec error the pixel
 * planes may be partly written (never the frame's header fields: receivers decode into a back buffer). A video
 * stream that lost a reference drops frames until its next key frame and sets want_key. One thread at a time. */
drv_frame_err drv_framelink_dec_decode(drv_framelink_dec *d, const uint8_t *buf, size_t len, size_t max_frame,
                                       drv_frame *out, drv_framelink_rx *rx, char *detail, int detail_len);
/* True (once, then cleared) when a video stream needs a key frame: the board sets DRV_FRAMELINK_POSE_WANT_KEY in
 * its next pose message. Any thread (the pose thread). */
bool drv_framelink_dec_take_want_key(drv_framelink_dec *d);

typedef struct {
    uint64_t frames;                  /* decoded */
    uint64_t compressed_frames;       /* of them, with at least one plane not RAW */
    uint64_t codec_errors;            /* rejected for a codec's reason (corrupt, truncated, missing reference) */
    uint64_t key_requests;            /* times want_key was raised */
    uint64_t wire_bytes, plane_bytes; /* frame bytes on the wire and what they decoded to */
    double decode_ms_last;            /* wall time of the last frame's decode (all threads) */
    unsigned codecs_seen;             /* DRV_CODEC_BIT()s of codecs met */
    char video_decoder[32];           /* "software", "hevc_v4l2m2m", ... ("" before a video frame) */
} drv_framelink_dec_stats;
void drv_framelink_dec_stats_get(const drv_framelink_dec *d, drv_framelink_dec_stats *st);

#endif

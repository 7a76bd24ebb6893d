/* SPDX-License-Identifier: MIT */
/* drv_codec_video: framelink v2's video colour codecs (H.264, HEVC through FFmpeg's libavcodec): one low-delay
 * stream per eye, an RGBA8 eye image in, one access unit out, and back; software or V4L2 M2M hardware decoders. */
#ifndef DRV_CODEC_VIDEO_H
#define DRV_CODEC_VIDEO_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "drivers/drv_codec.h"
#include "drivers/drv_frames.h"

typedef struct {
    drv_codec_id codec;  /* DRV_CODEC_H264 or DRV_CODEC_HEVC */
    int w, h;            /* the eye image; odd sizes are allowed (the encoder pads) */
    double fps;          /* the host's frame rate (rate control) */
    int bitrate_kbps;    /* > 0: constant bit rate with a one-frame VBV; 0: constant quality */
    int quality;         /* 1..51 quantiser (CRF/QP) when bitrate_kbps is 0 */
    int refresh_frames;  /* > 0: periodic intra refresh over that many frames (no big key frames after the first);
                          * 0: a key frame every gop frames */
    int gop;             /* key frame interval when refresh_frames is 0 (0: only the first and requested ones) */
} drv_video_params;

/* Host side: one encoder per eye. No B-frames, no look-ahead, one frame in and its access unit out at once. */
typedef struct drv_video_enc drv_video_enc;
drv_video_enc *drv_video_enc_create(const drv_video_params *p, char *err, int errlen);
void drv_video_enc_destroy(drv_video_enc *e);
/* Encodes one RGBA8 image (row stride in bytes) into out[cap]; force_key asks for a key frame (IDR: the board asked
 * for one). Returns the access unit's length (Annex B) and *is_key, or 0 with the reason in err. is_key: the access
 * unit holds an IDR (H.264) / IRAP (HEVC) picture, one a reset decoder shows at once: the first, forced ones and
 * each GOP's first; in intra-refresh mode only the first and forced ones. */
size_t drv_video_encode(drv_video_enc *e, const uint8_t *rgba, size_t stride, bool force_key, uint8_t *out,
                        size_t cap, bool *is_key, char *err, int errlen);

/* Board side: one decoder per eye. hw: "" or NULL for libavcodec's software decoder, "v4l2m2m" for the board's
 * V4L2 memory-to-memory decoder (h264_v4l2m2m, hevc_v4l2m2m), falling back to software with a note in err when
 * the hardware one cannot be opened (the return is then non-NULL and err non-empty). */
typedef struct drv_video_dec drv_video_dec;
drv_video_dec *drv_video_dec_create(drv_codec_id codec, int w, int h, const char *hw, char *err, int errlen);
void drv_video_dec_destroy(drv_video_dec *d);
/* Decodes one access unit into RGBA8 (alpha 255) at rgba (stride in bytes); the decoder's output must be w x h.
 * BAD_FORMAT for a corrupt stream or one that needs a reference it does not have, BAD_SIZE for another size (or a
 * stride under 4w), TRUNCATED for an empty one, TOO_LARGE for one over 2 bytes a pixel, each with the reason in err;
 * after a failure the caller drops frames until the next key frame (and asks the host for one), then
 * drv_video_dec_reset(). Never returns a frame late: one access unit in, its picture out. Writes nothing outside
 * the w x h image. Runs on the caller's thread (one decoding thread per decoder).
 * What libavcodec 59 lets it see (tests/unit/test_codec_video.c), each refused as BAD_FORMAT:
 * - an access unit it rejects (err_recognition explode), a picture flagged corrupt or with decode_error_flags;
 * - a picture it concealed: a P-frame whose reference was lost (an H.264 frame_num gap, a missing HEVC reference;
 *   shown, it would score 23 dB / 12 dB), a damaged slice header;
 * - a P-frame after drv_video_dec_reset (no parameter sets), an access unit that gives no picture.
 * Not seen: bit errors that still parse (of 24 damaged access units, H.264 decoded 5 and HEVC 20 without a
 * complaint); the link must deliver whole chunks. */
drv_frame_err drv_video_decode(drv_video_dec *d, const uint8_t *au, size_t len, uint8_t *rgba, size_t stride,
                               char *err, int errlen);
/* Forgets the stream (references, parameter sets) before a key frame after a loss. */
void drv_video_dec_reset(drv_video_dec *d);
/* Which hw decoder is in use: "software", "h264_v4l2m2m", ... (for the start-up line and --stats). */
const char *drv_video_dec_name(const drv_video_dec *d);

/* Whether this build and machine can encode / decode codec (an encoder library or decoder present). */
bool drv_video_can_encode(drv_codec_id codec);
bool drv_video_can_decode(drv_codec_id codec);

#endif

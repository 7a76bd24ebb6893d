/* SPDX-License-Identifier: MIT */
/* drv_codec_video: framelink v2's video colour codecs (H.264 via libx264, HEVC via libx265, decoded by libavcodec's
 * software or V4L2 M2M decoders), one low-delay stream per eye: an RGBA8 eye image in, one access unit out, and back.
 *
 * Colour: RGBA8 -> full-range BT.601 YUV 4:2:0 (the VUI says so; the decoder converts by what the stream declares),
 * odd sizes padded to even by repeating the last column / row (x264 and x265 need even 4:2:0 sizes; the decoder
 * converts only the top-left w x h back). Low delay: no B-frames, no look-ahead, no scene cut, frame threads off
 * (tune zerolatency), so avcodec_send_frame's frame is in the next receive_packet; a codec that holds a frame back is
 * an error, never a late frame.
 *
 * Key frames: is_key means the access unit holds an IDR (H.264 NAL 5) or IRAP (HEVC NAL 16..23) picture, i.e. a
 * decoder that was reset shows it at once. Forced key frames are IDRs (forced-idr), so a board that lost a reference
 * asks for one (WANT_KEY) and resumes on it. In intra-refresh mode the stream has no IDR after the first and x264's
 * "keyframe" flag on refresh starts is not a key frame here (decoding from it shows no picture until the refresh
 * wave has passed).
 *
 * What the decoder refuses (drv_codec_video.h lists it; tests/unit/test_codec_video.c checks it): libavcodec
 * conceals what it can and says so only in its log, so the log is read (silenced, kept per thread; decoding runs on
 * the caller's thread) as well as the return codes and the picture's corrupt flags. */
#include "drivers/drv_codec_video.h"

#include <limits.h>
#include <pthread.h>
#include <stdio.h>
#include <string.h>

#include <libavcodec/avcodec.h>
#include <libavutil/frame.h>
#include <libavutil/log.h>
#include <libavutil/opt.h>
#include <libavutil/pixdesc.h>
#include <libswscale/swscale.h>

#include "warp/warp_err.h"
#include "warp/warp_image.h"

/* Encoder presets, measured for one 1440x1600 eye of the simulator's scenes at quality 23: H.264 superfast costs the
 * host the same CPU as ultrafast for a fifth of the bytes, but CABAC and deblocking make the board's decode ~40%
 * slower, and decode time is the budget that binds (bytes are a tenth of USB 2.0's); HEVC ultrafast is already
 * 2.5x H.264's encode CPU. Overridable at build time (-DVIDEO_PRESET_H264=...) to measure others. */
#ifndef VIDEO_PRESET_H264
#define VIDEO_PRESET_H264 "ultrafast"
#endif
#ifndef VIDEO_PRESET_HEVC
#define VIDEO_PRESET_HEVC "ultrafast"
#endif
/* swscale for RGBA -> YUV (encoder): bilinear chroma. */
#define VIDEO_SWS_FLAGS SWS_BILINEAR
/* YUV -> RGBA (decoder): libswscale's fast unscaled path (SIMD; 1.8 ms CPU for 1440x1600 here, against 7.4 ms for
 * the exact path) is right only for widths that are a multiple of 16: at others it writes alpha 0 at a row's end
 * and up to 32 bytes past it (measured on x86-64, libswscale 6.7). Other widths take the exact path; and the last
 * rows always go through a padded scratch, so no path writes past the caller's image. */
#define VIDEO_SWS_FAST_WIDTH 16
#define VIDEO_SWS_FAST SWS_BILINEAR
#define VIDEO_SWS_EXACT (SWS_BILINEAR | SWS_ACCURATE_RND | SWS_FULL_CHR_H_INT)
#define VIDEO_TAIL_PAD 1024
/* An access unit larger than this many bytes per coded pixel (+ headroom) is no stream of ours: refused before
 * libavcodec copies it. PCM macroblocks, the worst case, are 1.5 bytes a pixel. */
#define VIDEO_AU_BYTES_PER_PIXEL 2
#define VIDEO_AU_HEADROOM (64 * 1024)
/* "no key frame interval": x264's and x265's way to say only the first and forced ones. */
#define VIDEO_GOP_INFINITE_X264 "infinite"
#define VIDEO_GOP_INFINITE_X265 "-1"

/* ---- libav's log: silenced, its last error kept per thread for our messages ---- */

static _Thread_local char av_last[160];
/* Set when libavcodec's H.264 decoder conceals a frame_num gap (a lost reference): it says so only in a debug line,
 * and the picture after it comes out as if whole. Its format string is the one signal there is. */
static _Thread_local bool av_gap;
#define H264_GAP_LOG "Frame num gap"

static void av_log_to_err(void *avcl, int level, const char *fmt, va_list ap)
{
    (void)avcl;
    if (level >= AV_LOG_DEBUG && strncmp(fmt, H264_GAP_LOG, sizeof H264_GAP_LOG - 1) == 0) av_gap = true;
    if (level > AV_LOG_ERROR) return;
    vsnprintf(av_last, sizeof av_last, fmt, ap);
    size_t n = strlen(av_last);
    while (n && (av_last[n - 1] == '\n' || av_last[n - 1] == '\r')) av_last[--n] = 0;
}

static pthread_once_t video_once = PTHREAD_ONCE_INIT;
static bool have_enc[DRV_CODEC_COUNT], have_dec[DRV_CODEC_COUNT];

static const char *enc_name(drv_codec_id c) { return c == DRV_CODEC_H264 ? "libx264" : "libx265"; }
static enum AVCodecID av_id(drv_codec_id c) { return c == DRV_CODEC_H264 ? AV_CODEC_ID_H264 : AV_CODEC_ID_HEVC; }
static bool is_video(drv_codec_id c) { return c == DRV_CODEC_H264 || c == DRV_CODEC_HEVC; }

/* Once per process: libav's log goes to av_last instead of stderr (bad input from a host must not spray the
 * board's log; the reason reaches the caller's err instead), and which codecs this libavcodec has. */
static void video_init(void)
{
    av_log_set_callback(av_log_to_err);
    for (int c = DRV_CODEC_H264; c <= DRV_CODEC_HEVC; c++) {
        have_enc[c] = avcodec_find_encoder_by_name(enc_name((drv_codec_id)c)) != NULL;
        have_dec[c] = avcodec_find_decoder(av_id((drv_codec_id)c)) != NULL;
    }
}

bool drv_video_can_encode(drv_codec_id codec)
{
    pthread_once(&video_once, video_init);
    return is_video(codec) && have_enc[codec];
}

bool drv_video_can_decode(drv_codec_id codec)
{
    pthread_once(&video_once, video_init);
    return is_video(codec) && have_dec[codec];
}

/* libav's error text for ret, with its last logged error when there is one (clears it). */
static const char *av_why(int ret, char *buf, size_t len)
{
    char e[AV_ERROR_MAX_STRING_SIZE];
    av_strerror(ret, e, sizeof e);
    if (av_last[0])
        snprintf(buf, len, "%s (%s)", e, av_last);
    else
        snprintf(buf, len, "%s", e);
    av_last[0] = 0;
    return buf;
}

/* Whether an Annex B access unit holds an IDR (H.264) / IRAP (HEVC) picture: what a reset decoder starts from. */
static bool au_is_key(drv_codec_id codec, const uint8_t *p, size_t n)
{
    for (size_t i = 0; i + 3 < n; i++) {
        if (p[i] != 0 || p[i + 1] != 0 || p[i + 2] != 1) continue;
        uint8_t h = p[i + 3];
        if (codec == DRV_CODEC_H264 ? (h & 0x1f) == 5 : ((h >> 1) & 0x3f) >= 16 && ((h >> 1) & 0x3f) <= 23)
            return true;
        i += 3;
    }
    return false;
}

/* ---- encoder ---- */

struct drv_video_enc {
    drv_video_params p;
    int cw, ch; /* coded size: w, h rounded up to even */
    AVCodecContext *ctx;
    AVFrame *frame;
    AVPacket *pkt;
    struct SwsContext *sws;
    int64_t pts;
};

void drv_video_enc_destroy(drv_video_enc *e)
{
    if (!e) return;
    avcodec_free_context(&e->ctx);
    av_frame_free(&e->frame);
    av_packet_free(&e->pkt);
    sws_freeContext(e->sws);
    av_free(e);
}

static bool enc_check(const drv_video_params *p, char *err, int errlen)
{
    if (!p) return warp_err(err, errlen, "video encoder: no parameters");
    if (!is_video(p->codec)) return warp_err(err, errlen, "video encoder: codec %d is not h264 or hevc", p->codec);
    if (p->w < 2 || p->h < 2 || p->w > WARP_MAX_SIDE || p->h > WARP_MAX_SIDE)
        return warp_err(err, errlen, "video encoder: eye size %dx%d outside 2..%d", p->w, p->h, WARP_MAX_SIDE);
    if (!(p->fps > 0 && p->fps <= 1000))
        return warp_err(err, errlen, "video encoder: fps %g outside (0, 1000]", p->fps);
    if (p->bitrate_kbps < 0 || p->bitrate_kbps > 10000000)
        return warp_err(err, errlen, "video encoder: bitrate_kbps %d outside 0..10000000", p->bitrate_kbps);
    if (p->bitrate_kbps == 0 && (p->quality < 1 || p->quality > 51))
        return warp_err(err, errlen, "video encoder: quality %d outside 1..51", p->quality);
    if (p->refresh_frames < 0 || p->refresh_frames > 10000)
        return warp_err(err, errlen, "video encoder: refresh_frames %d outside 0..10000", p->refresh_frames);
    if (p->refresh_frames == 1)
        return warp_err(err, errlen, "video encoder: refresh_frames 1 would make every frame a refresh; use gop 1");
    if (p->gop < 0 || p->gop > 100000) return warp_err(err, errlen, "video encoder: gop %d outside 0..100000", p->gop);
    return true;
}

drv_video_enc *drv_video_enc_create(const drv_video_params *p, char *err, int errlen)
{
    if (!enc_check(p, err, errlen)) return NULL;
    if (!drv_video_can_encode(p->codec)) {
        warp_err(err, errlen, "video encoder: this libavcodec has no %s (for %s)", enc_name(p->codec),
                 drv_codec_name(p->codec));
        return NULL;
    }
    const AVCodec *codec = avcodec_find_encoder_by_name(enc_name(p->codec));
    drv_video_enc *e = av_mallocz(sizeof *e);
    if (!e) return warp_err(err, errlen, "video encoder: out of memory"), NULL;
    e->p = *p;
    e->cw = (p->w + 1) & ~1;
    e->ch = (p->h + 1) & ~1;
    e->ctx = avcodec_alloc_context3(codec);
    e->frame = av_frame_alloc();
    e->pkt = av_packet_alloc();
    e->sws = sws_getContext(p->w, p->h, AV_PIX_FMT_RGBA, p->w, p->h, AV_PIX_FMT_YUV420P, VIDEO_SWS_FLAGS, NULL, NULL,
                            NULL);
    if (!e->ctx || !e->frame || !e->pkt || !e->sws) {
        drv_video_enc_destroy(e);
        return warp_err(err, errlen, "video encoder: out of memory"), NULL;
    }
    /* Full range both ways: limited range makes the codec's quantiser steps 16% coarser in RGB (measured at
     * 1440x1600, quality 23: 38.1 against 39.0 dB, for 12% fewer bytes); it would save swscale up to 4 ms CPU. */
    const int *cs = sws_getCoefficients(SWS_CS_ITU601);
    sws_setColorspaceDetails(e->sws, cs, 1, cs, 1, 0, 1 << 16, 1 << 16);

    AVCodecContext *c = e->ctx;
    c->width = e->cw;
    c->height = e->ch;
    c->pix_fmt = AV_PIX_FMT_YUV420P;
    c->color_range = AVCOL_RANGE_JPEG;
    c->colorspace = AVCOL_SPC_BT470BG;
    c->framerate = av_d2q(p->fps, 100000);
    c->time_base = av_inv_q(c->framerate);
    c->max_b_frames = 0;
    c->thread_count = 0; /* x264 zerolatency: sliced threads, no frame delay; x265: WPP within the frame */
    void *priv = c->priv_data;
    bool x264 = p->codec == DRV_CODEC_H264;
    av_opt_set(priv, "preset", x264 ? VIDEO_PRESET_H264 : VIDEO_PRESET_HEVC, 0);
    av_opt_set(priv, "tune", "zerolatency", 0);
    av_opt_set_int(priv, "forced-idr", 1, 0); /* a requested key frame is an IDR, not an open-GOP I */
    if (p->bitrate_kbps > 0) {
        /* CBR with a one-frame VBV: every access unit fits the link's share of one frame interval. */
        c->bit_rate = (int64_t)p->bitrate_kbps * 1000;
        c->rc_max_rate = c->bit_rate;
        c->rc_buffer_size = (int)(c->bit_rate / p->fps);
    } else {
        av_opt_set_double(priv, "crf", p->quality, 0);
    }
    char keyint[24];
    if (p->refresh_frames > 0)
        snprintf(keyint, sizeof keyint, "%d", p->refresh_frames);
    else if (p->gop > 0)
        snprintf(keyint, sizeof keyint, "%d", p->gop);
    else
        snprintf(keyint, sizeof keyint, "%s", x264 ? VIDEO_GOP_INFINITE_X264 : VIDEO_GOP_INFINITE_X265);
    /* No look-ahead and no scene cuts: one frame in, its access unit out, key frames only where asked. */
    char params[256];
    if (x264)
        snprintf(params, sizeof params, "keyint=%s:min-keyint=1:scenecut=0:rc-lookahead=0:sync-lookahead=0:bframes=0%s",
                 keyint, p->refresh_frames > 0 ? ":intra-refresh=1" : "");
    else
        snprintf(params, sizeof params,
                 "log-level=none:info=0:keyint=%s:min-keyint=1:scenecut=0:rc-lookahead=0:bframes=0:frame-threads=1:"
                 "repeat-headers=1%s",
                 keyint, p->refresh_frames > 0 ? ":intra-refresh=1" : "");
    av_opt_set(priv, x264 ? "x264-params" : "x265-params", params, 0);

    av_last[0] = 0;
    int ret = avcodec_open2(c, codec, NULL);
    if (ret < 0) {
        char why[256];
        warp_err(err, errlen, "video encoder %s %dx%d: %s", enc_name(p->codec), p->w, p->h,
                 av_why(ret, why, sizeof why));
        drv_video_enc_destroy(e);
        return NULL;
    }
    e->frame->format = AV_PIX_FMT_YUV420P;
    e->frame->width = e->cw;
    e->frame->height = e->ch;
    e->frame->color_range = AVCOL_RANGE_JPEG;
    e->frame->colorspace = AVCOL_SPC_BT470BG;
    if (av_frame_get_buffer(e->frame, 0) < 0) {
        drv_video_enc_destroy(e);
        return warp_err(err, errlen, "video encoder: out of memory"), NULL;
    }
    return e;
}

/* Odd sizes: the last column / row repeated into the padding (an edge, not a black line, for the encoder). */
static void pad_luma(AVFrame *f, int w, int h)
{
    uint8_t *y = f->data[0];
    int ls = f->linesize[0];
    if (f->width > w)
        for (int r = 0; r < h; r++) y[r * ls + w] = y[r * ls + w - 1];
    if (f->height > h) memcpy(y + h * ls, y + (h - 1) * ls, (size_t)f->width);
    /* chroma is ceil(w/2) x ceil(h/2) = the whole padded chroma plane: swscale wrote it all */
}

size_t drv_video_encode(drv_video_enc *e, const uint8_t *rgba, size_t stride, bool force_key, uint8_t *out,
                        size_t cap, bool *is_key, char *err, int errlen)
{
    if (is_key) *is_key = false;
    if (!e || !rgba || !out) return warp_err(err, errlen, "video encode: no encoder, image or output"), 0;
    if (stride < (size_t)e->p.w * 4 || stride > INT_MAX)
        return warp_err(err, errlen, "video encode: stride %zu for an eye %d pixels wide", stride, e->p.w), 0;
    char why[256];
    int ret = av_frame_make_writable(e->frame); /* no-op unless the encoder still holds the last one */
    if (ret < 0) return warp_err(err, errlen, "video encode: %s", av_why(ret, why, sizeof why)), 0;
    const uint8_t *src[4] = {rgba, NULL, NULL, NULL};
    const int src_stride[4] = {(int)stride, 0, 0, 0};
    sws_scale(e->sws, src, src_stride, 0, e->p.h, e->frame->data, e->frame->linesize);
    pad_luma(e->frame, e->p.w, e->p.h);
    e->frame->pts = e->pts++;
    e->frame->pict_type = force_key ? AV_PICTURE_TYPE_I : AV_PICTURE_TYPE_NONE;

    av_last[0] = 0;
    ret = avcodec_send_frame(e->ctx, e->frame);
    if (ret < 0) return warp_err(err, errlen, "video encode: %s", av_why(ret, why, sizeof why)), 0;
    ret = avcodec_receive_packet(e->ctx, e->pkt);
    if (ret == AVERROR(EAGAIN))
        return warp_err(err, errlen, "video encode: %s held the frame back (not low delay)", enc_name(e->p.codec)), 0;
    if (ret < 0) return warp_err(err, errlen, "video encode: %s", av_why(ret, why, sizeof why)), 0;
    size_t n = (size_t)e->pkt->size;
    bool key = au_is_key(e->p.codec, e->pkt->data, n);
    if (n > cap) {
        av_packet_unref(e->pkt);
        return warp_err(err, errlen, "video encode: access unit of %zu bytes, room for %zu", n, cap), 0;
    }
    memcpy(out, e->pkt->data, n);
    av_packet_unref(e->pkt);
    if (is_key) *is_key = key;
    return n;
}

/* ---- decoder ---- */

struct drv_video_dec {
    drv_codec_id codec;
    int w, h, cw, ch;
    const AVCodec *impl;
    const char *name; /* "software" or the hw decoder's name */
    AVCodecContext *ctx;
    AVFrame *frame;
    AVPacket *pkt;
    struct SwsContext *sws, *sws_tail; /* rows [0, h - tail) into the caller's image, the rest into tail_buf */
    int tail;                          /* 2 rows (one chroma row), 1 for an odd height */
    uint8_t *tail_buf;                 /* tail rows of w RGBA pixels + VIDEO_TAIL_PAD */
    int sws_fmt, sws_range, sws_space; /* what sws is set up for (-1: nothing yet) */
};

/* A fresh context: low delay, errors reported (not concealed), one thread (framelink decodes the eyes in
 * parallel, one decoder each). */
static int dec_open(drv_video_dec *d)
{
    d->ctx = avcodec_alloc_context3(d->impl);
    if (!d->ctx) return AVERROR(ENOMEM);
    d->ctx->flags |= AV_CODEC_FLAG_LOW_DELAY;
    d->ctx->flags2 |= AV_CODEC_FLAG2_FAST;
    d->ctx->err_recognition = AV_EF_EXPLODE | AV_EF_BITSTREAM | AV_EF_BUFFER | AV_EF_CRCCHECK;
    d->ctx->thread_count = 1;
    d->ctx->width = d->cw;
    d->ctx->height = d->ch;
    int ret = avcodec_open2(d->ctx, d->impl, NULL);
    if (ret < 0) avcodec_free_context(&d->ctx);
    return ret;
}

void drv_video_dec_destroy(drv_video_dec *d)
{
    if (!d) return;
    avcodec_free_context(&d->ctx);
    av_frame_free(&d->frame);
    av_packet_free(&d->pkt);
    sws_freeContext(d->sws);
    sws_freeContext(d->sws_tail);
    av_free(d->tail_buf);
    av_free(d);
}

/* Converters for the picture format fmt (4:2:0 only: the tail's chroma row must start at an even luma row). */
static bool dec_sws(drv_video_dec *d, int fmt, int range, int space)
{
    if (fmt != AV_PIX_FMT_YUV420P && fmt != AV_PIX_FMT_YUVJ420P && fmt != AV_PIX_FMT_NV12) return false;
    int flags = d->w % VIDEO_SWS_FAST_WIDTH == 0 ? VIDEO_SWS_FAST : VIDEO_SWS_EXACT;
    int main_h = d->h - d->tail;
    if (main_h > 0) {
        d->sws = sws_getCachedContext(d->sws, d->w, main_h, (enum AVPixelFormat)fmt, d->w, main_h, AV_PIX_FMT_RGBA,
                                      flags, NULL, NULL, NULL);
        if (!d->sws) return false;
    }
    d->sws_tail = sws_getCachedContext(d->sws_tail, d->w, d->tail, (enum AVPixelFormat)fmt, d->w, d->tail,
                                       AV_PIX_FMT_RGBA, flags, NULL, NULL, NULL);
    if (!d->sws_tail) return false;
    const int *cs = sws_getCoefficients(space), *rgb = sws_getCoefficients(SWS_CS_DEFAULT);
    if (main_h > 0) sws_setColorspaceDetails(d->sws, cs, range, rgb, 1, 0, 1 << 16, 1 << 16);
    sws_setColorspaceDetails(d->sws_tail, cs, range, rgb, 1, 0, 1 << 16, 1 << 16);
    return true;
}

drv_video_dec *drv_video_dec_create(drv_codec_id codec, int w, int h, const char *hw, char *err, int errlen)
{
    if (err && errlen > 0) err[0] = 0;
    if (!is_video(codec)) return warp_err(err, errlen, "video decoder: codec %d is not h264 or hevc", codec), NULL;
    if (w < 2 || h < 2 || w > WARP_MAX_SIDE || h > WARP_MAX_SIDE)
        return warp_err(err, errlen, "video decoder: eye size %dx%d outside 2..%d", w, h, WARP_MAX_SIDE), NULL;
    if (hw && hw[0] && strcmp(hw, "v4l2m2m") != 0)
        return warp_err(err, errlen, "video decoder: unknown hw decoder '%s' (\"\" or v4l2m2m)", hw), NULL;
    if (!drv_video_can_decode(codec))
        return warp_err(err, errlen, "video decoder: this libavcodec has no %s decoder", drv_codec_name(codec)), NULL;
    drv_video_dec *d = av_mallocz(sizeof *d);
    if (!d) return warp_err(err, errlen, "video decoder: out of memory"), NULL;
    d->codec = codec;
    d->w = w, d->h = h;
    d->cw = (w + 1) & ~1, d->ch = (h + 1) & ~1;
    d->sws_fmt = AV_PIX_FMT_YUV420P, d->sws_range = 1, d->sws_space = AVCOL_SPC_BT470BG;
    d->tail = h % 2 ? 1 : 2;
    d->frame = av_frame_alloc();
    d->pkt = av_packet_alloc();
    d->tail_buf = av_malloc((size_t)d->tail * (size_t)w * 4 + VIDEO_TAIL_PAD);
    if (!d->frame || !d->pkt || !d->tail_buf) {
        drv_video_dec_destroy(d);
        return warp_err(err, errlen, "video decoder: out of memory"), NULL;
    }
    char why[256];
    av_last[0] = 0;
    if (hw && hw[0]) {
        const char *hw_name = codec == DRV_CODEC_H264 ? "h264_v4l2m2m" : "hevc_v4l2m2m";
        d->impl = avcodec_find_decoder_by_name(hw_name);
        int ret = d->impl ? dec_open(d) : AVERROR_DECODER_NOT_FOUND;
        if (ret >= 0) {
            d->name = hw_name;
        } else {
            warp_err(err, errlen, "video decoder: %s unavailable (%s), using software", hw_name,
                     av_why(ret, why, sizeof why));
        }
    }
    if (!d->ctx) {
        d->impl = avcodec_find_decoder(av_id(codec));
        d->name = "software";
        int ret = dec_open(d);
        if (ret < 0) {
            warp_err(err, errlen, "video decoder %s: %s", drv_codec_name(codec), av_why(ret, why, sizeof why));
            drv_video_dec_destroy(d);
            return NULL;
        }
    }
    /* The usual case's converters now (our streams: full range BT.601, as the first picture will confirm). */
    if (!dec_sws(d, AV_PIX_FMT_YUV420P, 1, AVCOL_SPC_BT470BG)) {
        drv_video_dec_destroy(d);
        return warp_err(err, errlen, "video decoder: out of memory"), NULL;
    }
    return d;
}

void drv_video_dec_reset(drv_video_dec *d)
{
    if (!d) return;
    /* Reopened, not flushed: a flush keeps the parameter sets, and the next key frame brings its own. Without
     * them a P-frame after the reset is refused outright instead of being concealed against nothing. */
    avcodec_free_context(&d->ctx);
    av_last[0] = 0;
    if (dec_open(d) < 0) d->ctx = NULL; /* decode reports it */
}

const char *drv_video_dec_name(const drv_video_dec *d) { return d ? d->name : "none"; }

drv_frame_err drv_video_decode(drv_video_dec *d, const uint8_t *au, size_t len, uint8_t *rgba, size_t stride,
                               char *err, int errlen)
{
    if (!d || !au || !rgba)
        return drv_frame_fail(err, errlen, DRV_FRAME_ERR_BAD_FORMAT, "video decode: no decoder, data or image");
    if (!d->ctx)
        return drv_frame_fail(err, errlen, DRV_FRAME_ERR_BAD_FORMAT, "video decode: %s decoder could not be reopened",
                              drv_codec_name(d->codec));
    if (stride < (size_t)d->w * 4 || stride > INT_MAX)
        return drv_frame_fail(err, errlen, DRV_FRAME_ERR_BAD_SIZE, "video decode: stride %zu for an eye %d pixels wide",
                              stride, d->w);
    if (len == 0) return drv_frame_fail(err, errlen, DRV_FRAME_ERR_TRUNCATED, "video decode: empty access unit");
    size_t most = (size_t)d->cw * (size_t)d->ch * VIDEO_AU_BYTES_PER_PIXEL + VIDEO_AU_HEADROOM;
    if (len > most)
        return drv_frame_fail(err, errlen, DRV_FRAME_ERR_TOO_LARGE,
                              "video decode: access unit of %zu bytes, more than %zu for a %dx%d eye", len, most, d->w,
                              d->h);
    const char *cn = drv_codec_name(d->codec);
    char why[256];
    /* A picture a codec held back from an earlier access unit is not this one's: dropped, never returned late. */
    while (avcodec_receive_frame(d->ctx, d->frame) >= 0) av_frame_unref(d->frame);
    /* Not refcounted: libavcodec copies it into a padded buffer of its own (its readers over-read the end). */
    d->pkt->data = (uint8_t *)(uintptr_t)au;
    d->pkt->size = (int)len;
    av_last[0] = 0;
    av_gap = false;
    int ret = avcodec_send_packet(d->ctx, d->pkt);
    d->pkt->data = NULL, d->pkt->size = 0;
    if (ret < 0)
        return drv_frame_fail(err, errlen, DRV_FRAME_ERR_BAD_FORMAT, "video decode: %s stream refused: %s", cn,
                              av_why(ret, why, sizeof why));
    /* One access unit in, its picture out: the first picture is this access unit's (low delay); none is kept
     * back for a later call (any left over was dropped above). */
    bool got = false;
    ret = avcodec_receive_frame(d->ctx, d->frame);
    if (ret >= 0)
        got = true;
    else if (ret != AVERROR(EAGAIN))
        return drv_frame_fail(err, errlen, DRV_FRAME_ERR_BAD_FORMAT, "video decode: %s: %s", cn,
                              av_why(ret, why, sizeof why));
    if (got && ((d->frame->flags & AV_FRAME_FLAG_CORRUPT) || d->frame->decode_error_flags)) {
        int flags = d->frame->decode_error_flags;
        av_frame_unref(d->frame);
        return drv_frame_fail(err, errlen, DRV_FRAME_ERR_BAD_FORMAT,
                              "video decode: %s picture decoded with errors (corrupt flag, error flags 0x%x)", cn,
                              (unsigned)flags);
    }
    if (!got)
        return drv_frame_fail(err, errlen, DRV_FRAME_ERR_BAD_FORMAT,
                              "video decode: %s access unit gave no picture (a missing reference or parameter set, "
                              "or not a whole access unit)%s%s",
                              cn, av_last[0] ? ": " : "", av_last);
    AVFrame *f = d->frame;
    if (!((f->width == d->w || f->width == d->cw) && (f->height == d->h || f->height == d->ch))) {
        int fw = f->width, fh = f->height;
        av_frame_unref(f);
        return drv_frame_fail(err, errlen, DRV_FRAME_ERR_BAD_SIZE,
                              "video decode: %s picture is %dx%d, this eye is %dx%d", cn, fw, fh, d->w, d->h);
    }
    /* libavcodec conceals what it can and says so only in its log (one decoding thread: this one's). A missing HEVC
     * reference ("Could not find ref"), a damaged slice header, or an H.264 frame_num gap all give a picture that
     * looks whole: refused here. */
    if (av_last[0] || av_gap) {
        av_frame_unref(f);
        return drv_frame_fail(err, errlen, DRV_FRAME_ERR_BAD_FORMAT, "video decode: %s picture concealed: %s", cn,
                              av_gap ? "a missing reference (frame_num gap)" : av_last);
    }
    int range = f->color_range == AVCOL_RANGE_MPEG ? 0 : 1; /* ours are full range; honour a stream that says not */
    if (f->format != d->sws_fmt || range != d->sws_range || (int)f->colorspace != d->sws_space) {
        /* Another layout (a hw decoder's NV12) or colour space: libswscale allocates here, once per change. */
        d->sws_fmt = -1;
        if (!dec_sws(d, f->format, range, (int)f->colorspace)) {
            const char *fmt = av_get_pix_fmt_name((enum AVPixelFormat)f->format);
            av_frame_unref(f);
            return drv_frame_fail(err, errlen, DRV_FRAME_ERR_BAD_FORMAT,
                                  "video decode: %s picture format %s is not 4:2:0 8-bit", cn, fmt ? fmt : "?");
        }
        d->sws_fmt = f->format, d->sws_range = range, d->sws_space = (int)f->colorspace;
    }
    int main_h = d->h - d->tail;
    if (main_h > 0) {
        uint8_t *dst[4] = {rgba, NULL, NULL, NULL};
        const int dst_stride[4] = {(int)stride, 0, 0, 0};
        sws_scale(d->sws, (const uint8_t *const *)f->data, f->linesize, 0, main_h, dst, dst_stride);
    }
    /* The last rows through the padded scratch: whatever a SIMD path writes past a row's end stays there. */
    const uint8_t *src[4] = {f->data[0] + (ptrdiff_t)main_h * f->linesize[0],
                             f->data[1] + (ptrdiff_t)(main_h / 2) * f->linesize[1],
                             f->data[2] ? f->data[2] + (ptrdiff_t)(main_h / 2) * f->linesize[2] : NULL, NULL};
    uint8_t *tdst[4] = {d->tail_buf, NULL, NULL, NULL};
    const int tstride[4] = {d->w * 4, 0, 0, 0};
    sws_scale(d->sws_tail, src, f->linesize, 0, d->tail, tdst, tstride);
    for (int r = 0; r < d->tail; r++)
        memcpy(rgba + (size_t)(main_h + r) * stride, d->tail_buf + (size_t)r * (size_t)d->w * 4, (size_t)d->w * 4);
    av_frame_unref(f);
    return DRV_FRAME_OK;
}

/* SPDX-License-Identifier: MIT */
/* drv_framelink_codec: framelink v2's frame encoder (host) and decoder (board), a codec per plane.
 * Placeholder with the final interface until the v2 implementation lands: raw planes only (v1 frames). */
#include "drivers/drv_framelink_codec.h"

#include <stdlib.h>
#include <string.h>

#include "warp/warp_err.h"

drv_framelink_enc_params drv_framelink_enc_params_raw(void)
{
    return (drv_framelink_enc_params){.color = DRV_CODEC_RAW, .quality = 85, .slices = 1, .depth = DRV_CODEC_RAW,
                                      .other = DRV_CODEC_RAW, .zstd_level = 1, .fps = 45};
}

bool drv_framelink_enc_params_check(const drv_framelink_enc_params *p, char *err, int errlen)
{
    if (p->color != DRV_CODEC_RAW || p->depth != DRV_CODEC_RAW || p->other != DRV_CODEC_RAW || p->depth_scale != 0)
        return warp_err(err, errlen, "framelink v2 codecs: not built yet (raw planes only)");
    if (p->depth_format != 0 && p->depth_format != DRV_FRAMELINK_FMT_F32 &&
        p->depth_format != DRV_FRAMELINK_FMT_UNORM16)
        return warp_err(err, errlen, "depth format %d: not one of F32, UNORM16", p->depth_format);
    return true;
}

struct drv_framelink_enc {
    drv_framelink_enc_params p;
};

drv_framelink_enc *drv_framelink_enc_create(const drv_framelink_enc_params *p, int w, int h, char *err, int errlen)
{
    (void)w, (void)h;
    if (!drv_framelink_enc_params_check(p, err, errlen)) return NULL;
    drv_framelink_enc *e = calloc(1, sizeof *e);
    if (!e) return warp_err(err, errlen, "out of memory"), NULL;
    e->p = *p;
    return e;
}
void drv_framelink_enc_destroy(drv_framelink_enc *e) { free(e); }

static drv_framelink_tx with_depth(const drv_framelink_enc *e, const drv_framelink_tx *tx)
{
    drv_framelink_tx t = tx ? *tx : (drv_framelink_tx){0};
    if (e->p.depth_format) t.depth_format = e->p.depth_format;
    return t;
}

size_t drv_framelink_enc_bound(const drv_framelink_enc *e, const drv_frame *f)
{
    drv_framelink_tx t = with_depth(e, NULL);
    return drv_framelink_size_ex(f, &t);
}

size_t drv_framelink_enc_encode(drv_framelink_enc *e, const drv_frame *f, const drv_framelink_tx *tx, bool want_key,
                                uint8_t *buf, size_t cap, char *err, int errlen)
{
    (void)want_key;
    drv_framelink_tx t = with_depth(e, tx);
    size_t n = drv_framelink_encode_ex(f, &t, buf, cap);
    if (!n) warp_err(err, errlen, "frame cannot be encoded (planes, sizes or buffer of %zu bytes)", cap);
    return n;
}

struct drv_framelink_dec {
    drv_framelink_dec_stats st;
};

drv_framelink_dec *drv_framelink_dec_create(int w, int h, unsigned planes, int max_layers, int threads,
                                            const char *video_hw, char *err, int errlen)
{
    (void)w, (void)h, (void)planes, (void)max_layers, (void)threads, (void)video_hw;
    drv_framelink_dec *d = calloc(1, sizeof *d);
    if (!d) warp_err(err, errlen, "out of memory");
    return d;
}
void drv_framelink_dec_destroy(drv_framelink_dec *d) { free(d); }

drv_frame_err drv_framelink_dec_decode(drv_framelink_dec *d, const uint8_t *buf, size_t len, size_t max_frame,
                                       drv_frame *out, drv_framelink_rx *rx, char *detail, int detail_len)
{
    drv_frame_err e = drv_framelink_decode_ex(buf, len, max_frame, out, rx, detail, detail_len);
    if (e == DRV_FRAME_OK) {
        d->st.frames++;
        d->st.wire_bytes += len;
        d->st.plane_bytes += len;
        d->st.codecs_seen |= DRV_CODEC_BIT(DRV_CODEC_RAW);
    }
    return e;
}

bool drv_framelink_dec_take_want_key(drv_framelink_dec *d) { return (void)d, false; }

void drv_framelink_dec_stats_get(const drv_framelink_dec *d, drv_framelink_dec_stats *st) { *st = d->st; }

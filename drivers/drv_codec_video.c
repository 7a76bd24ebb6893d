/* SPDX-License-Identifier: MIT */
/* drv_codec_video: framelink v2's video colour codecs (H.264, HEVC through libavcodec), one stream per eye.
 * Placeholder with the final interface until the libavcodec implementation lands: no codec is available. */
#include "drivers/drv_codec_video.h"

#include "warp/warp_err.h"

drv_video_enc *drv_video_enc_create(const drv_video_params *p, char *err, int errlen)
{
    (void)p;
    warp_err(err, errlen, "video codec: not built yet");
    return NULL;
}
void drv_video_enc_destroy(drv_video_enc *e) { (void)e; }
size_t drv_video_encode(drv_video_enc *e, const uint8_t *rgba, size_t stride, bool force_key, uint8_t *out,
                        size_t cap, bool *is_key, char *err, int errlen)
{
    (void)e, (void)rgba, (void)stride, (void)force_key, (void)out, (void)cap, (void)is_key;
    warp_err(err, errlen, "video codec: not built yet");
    return 0;
}
drv_video_dec *drv_video_dec_create(drv_codec_id codec, int w, int h, const char *hw, char *err, int errlen)
{
    (void)codec, (void)w, (void)h, (void)hw;
    warp_err(err, errlen, "video codec: not built yet");
    return NULL;
}
void drv_video_dec_destroy(drv_video_dec *d) { (void)d; }
drv_frame_err drv_video_decode(drv_video_dec *d, const uint8_t *au, size_t len, uint8_t *rgba, size_t stride,
                               char *err, int errlen)
{
    (void)d, (void)au, (void)len, (void)rgba, (void)stride;
    return drv_frame_fail(err, errlen, DRV_FRAME_ERR_BAD_FORMAT, "video codec: not built yet");
}
void drv_video_dec_reset(drv_video_dec *d) { (void)d; }
const char *drv_video_dec_name(const drv_video_dec *d) { return (void)d, "none"; }
bool drv_video_can_encode(drv_codec_id codec) { return (void)codec, false; }
bool drv_video_can_decode(drv_codec_id codec) { return (void)codec, false; }

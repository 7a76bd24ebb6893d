/* SPDX-License-Identifier: MIT */
/* drv_codec_jpeg: framelink v2's JPEG colour codec (libturbojpeg), one band of rows of an eye image per JPEG.
 * Placeholder with the final interface until the libturbojpeg implementation lands: every call fails cleanly. */
#include "drivers/drv_codec_jpeg.h"

#include "warp/warp_err.h"

drv_jpeg *drv_jpeg_create(bool encoder, char *err, int errlen)
{
    (void)encoder;
    warp_err(err, errlen, "JPEG codec: not built yet");
    return NULL;
}
void drv_jpeg_destroy(drv_jpeg *j) { (void)j; }
size_t drv_jpeg_bound(int w, int h, drv_jpeg_sub sub) { return (void)w, (void)h, (void)sub, 0; }
size_t drv_jpeg_encode(drv_jpeg *j, const uint8_t *rgba, int w, int h, size_t stride, int quality, drv_jpeg_sub sub,
                       uint8_t *out, size_t cap, char *err, int errlen)
{
    (void)j, (void)rgba, (void)w, (void)h, (void)stride, (void)quality, (void)sub, (void)out, (void)cap;
    warp_err(err, errlen, "JPEG codec: not built yet");
    return 0;
}
drv_frame_err drv_jpeg_decode(drv_jpeg *j, const uint8_t *jpeg, size_t len, uint8_t *rgba, int w, int h,
                              size_t stride, char *err, int errlen)
{
    (void)j, (void)jpeg, (void)len, (void)rgba, (void)w, (void)h, (void)stride;
    return drv_frame_fail(err, errlen, DRV_FRAME_ERR_BAD_FORMAT, "JPEG codec: not built yet");
}

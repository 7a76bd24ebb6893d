/* SPDX-License-Identifier: MIT */
/* drv_codec: the plane codecs of framelink v2: names, and which of them this build and machine encode and decode
 * (what a board announces in its camera message, what a host may choose). */
#include "drivers/drv_codec.h"

#include <stdio.h>
#include <string.h>

#include "drivers/drv_codec_video.h"

static const char *const names[DRV_CODEC_COUNT] = {"raw", "zstd", "jpeg", "h264", "hevc"};

const char *drv_codec_name(drv_codec_id c) { return (unsigned)c < DRV_CODEC_COUNT ? names[c] : "?"; }

bool drv_codec_parse(const char *name, drv_codec_id *out)
{
    for (int c = 0; c < DRV_CODEC_COUNT; c++)
        if (name && strcmp(name, names[c]) == 0) {
            *out = (drv_codec_id)c;
            return true;
        }
    return false;
}

const char *drv_codec_names(unsigned mask, const char *sep, char *buf, size_t len)
{
    if (!len) return buf;
    buf[0] = 0;
    size_t at = 0;
    for (int c = 0; c < DRV_CODEC_COUNT && at < len; c++)
        if (mask & DRV_CODEC_BIT(c)) {
            int n = snprintf(buf + at, len - at, "%s%s", at ? sep : "", names[c]);
            if (n < 0) break;
            at += (size_t)n;
        }
    return buf;
}

drv_codec_id drv_codec_missing(unsigned mask, unsigned have)
{
    int c = 0;
    while (c < DRV_CODEC_COUNT && !(mask & ~have & DRV_CODEC_BIT(c))) c++;
    return (drv_codec_id)c;
}

/* zstd and libturbojpeg are linked into every build; the video codecs depend on what libavcodec has. */
unsigned drv_codec_decodable(void)
{
    unsigned m = DRV_CODEC_BIT(DRV_CODEC_RAW) | DRV_CODEC_BIT(DRV_CODEC_ZSTD) | DRV_CODEC_BIT(DRV_CODEC_JPEG);
    if (drv_video_can_decode(DRV_CODEC_H264)) m |= DRV_CODEC_BIT(DRV_CODEC_H264);
    if (drv_video_can_decode(DRV_CODEC_HEVC)) m |= DRV_CODEC_BIT(DRV_CODEC_HEVC);
    return m;
}

unsigned drv_codec_encodable(void)
{
    unsigned m = DRV_CODEC_BIT(DRV_CODEC_RAW) | DRV_CODEC_BIT(DRV_CODEC_ZSTD) | DRV_CODEC_BIT(DRV_CODEC_JPEG);
    if (drv_video_can_encode(DRV_CODEC_H264)) m |= DRV_CODEC_BIT(DRV_CODEC_H264);
    if (drv_video_can_encode(DRV_CODEC_HEVC)) m |= DRV_CODEC_BIT(DRV_CODEC_HEVC);
    return m;
}

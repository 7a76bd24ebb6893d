/* SPDX-License-Identifier: MIT */
/* drv_codec: the plane codecs of framelink v2 (docs/framelink.md): their ids on the wire, names in configs and on
 * command lines, and which of them this build can encode and decode (what a board announces in its camera message). */
#ifndef DRV_CODEC_H
#define DRV_CODEC_H

#include <stdbool.h>
#include <stddef.h>

/* A plane descriptor's codec byte (framelink v2). RAW is v1's layout; every other codec sends the plane as chunks
 * (per eye, and per horizontal slice where the codec allows it), each decodable on its own thread. */
typedef enum {
    DRV_CODEC_RAW = 0,  /* the plane's bytes as v1 sends them */
    DRV_CODEC_ZSTD = 1, /* lossless: zstd over the plane's bytes (libzstd); depth, ids, motion, layers */
    DRV_CODEC_JPEG = 2, /* colour: one JPEG per eye slice (libturbojpeg), 4:2:0 or 4:4:4 */
    DRV_CODEC_H264 = 3, /* colour: one H.264 stream per eye, low delay (libavcodec) */
    DRV_CODEC_HEVC = 4, /* colour: one HEVC stream per eye, low delay (libavcodec; the Pi 5 decodes it in hardware) */
    DRV_CODEC_COUNT
} drv_codec_id;

#define DRV_CODEC_BIT(c) (1u << (unsigned)(c))
/* Every codec's bit: what a mask from the wire is cut to. */
#define DRV_CODEC_ALL (DRV_CODEC_BIT(DRV_CODEC_COUNT) - 1u)

/* "raw", "zstd", "jpeg", "h264", "hevc"; "?" for anything else. */
const char *drv_codec_name(drv_codec_id c);
/* The id of a name above (case-sensitive); false when unknown. */
bool drv_codec_parse(const char *name, drv_codec_id *out);
/* The names of the codecs in mask, in id order, sep between them ("raw zstd jpeg" for " "), into buf (cut to len);
 * "" for none. Returns buf, so a message can take it as its argument. */
const char *drv_codec_names(unsigned mask, const char *sep, char *buf, size_t len);
/* The first codec in mask that have lacks; DRV_CODEC_COUNT when it lacks none (bits above the codecs are no codec). */
drv_codec_id drv_codec_missing(unsigned mask, unsigned have);
/* DRV_CODEC_BIT()s this build (and machine, for video) can decode / encode; RAW always. */
unsigned drv_codec_decodable(void);
unsigned drv_codec_encodable(void);

#endif

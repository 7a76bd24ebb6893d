/* SPDX-License-Identifier: MIT */
/* drv_codec_jpeg: framelink v2's JPEG colour codec (libturbojpeg): one band of rows of an RGBA8 eye image to one
 * JPEG and back, so a frame's slices encode and decode on as many threads as the caller has. */
#ifndef DRV_CODEC_JPEG_H
#define DRV_CODEC_JPEG_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "drivers/drv_frames.h"

/* One libturbojpeg handle: an encoder or a decoder, used by one thread at a time. Made at start-up; encode and
 * decode write straight into the caller's buffers (libjpeg keeps its own working memory per call, and a decoder
 * is remade after a header it refused: frames thread only, never the vsync path). */
typedef struct drv_jpeg drv_jpeg;
drv_jpeg *drv_jpeg_create(bool encoder, char *err, int errlen);
void drv_jpeg_destroy(drv_jpeg *j);

/* Chroma subsampling. */
typedef enum { DRV_JPEG_420 = 0, DRV_JPEG_444 = 1 } drv_jpeg_sub;

/* The most bytes a w x h band can encode to (libturbojpeg's tjBufSize), 0 for sizes outside 1..WARP_MAX_SIDE. */
size_t drv_jpeg_bound(int w, int h, drv_jpeg_sub sub);
/* Encodes w x h RGBA8 pixels (row stride in bytes; alpha is dropped) at quality 1..100 into out[cap]. Returns the
 * JPEG's length, or 0 with the reason in err (cap below drv_jpeg_bound is refused before encoding). */
size_t drv_jpeg_encode(drv_jpeg *j, const uint8_t *rgba, int w, int h, size_t stride, int quality, drv_jpeg_sub sub,
                       uint8_t *out, size_t cap, char *err, int errlen);
/* Decodes a JPEG that must be exactly w x h into RGBA8 (alpha 255) at rgba (row stride in bytes). BAD_SIZE when
 * its header declares another size, BAD_FORMAT for anything libturbojpeg refuses or warns about (a corrupt or
 * truncated stream), each with the reason in err; the pixels may be partly written on failure. */
drv_frame_err drv_jpeg_decode(drv_jpeg *j, const uint8_t *jpeg, size_t len, uint8_t *rgba, int w, int h,
                              size_t stride, char *err, int errlen);

#endif

/* SPDX-License-Identifier: MIT */
/* drv_framelink_wire: what drv_framelink.c (the container: header, descriptors, chunk tables, checks) shares with
 * drv_framelink_codec.c (the plane codecs) and nothing else uses: plane layouts and the raw plane converters. */
#ifndef DRV_FRAMELINK_WIRE_H
#define DRV_FRAMELINK_WIRE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "drivers/drv_framelink.h"

/* JPEG: at most 16 slices per eye; every other codec 1. A chunk table has 2 * slices entries. */
#define DRV_FRAMELINK_MAX_SLICES 16
#define DRV_FRAMELINK_MAX_CHUNKS (2 * DRV_FRAMELINK_MAX_SLICES)
#define DRV_FRAMELINK_DESC_KEY 0x1u /* descriptor flags bit 0: a video plane that is a key frame */

/* One plane as its descriptor says, and (decoding, not RAW) its chunks as the table says, checked. */
typedef struct {
    int type, format, codec, flags, scale, slices;
    unsigned param;
    size_t off, size;
    const uint8_t *data; /* decoding: the plane's bytes in the payload */
    const uint8_t *chunk[DRV_FRAMELINK_MAX_CHUNKS];
    size_t chunk_len[DRV_FRAMELINK_MAX_CHUNKS];
} drv_framelink_plane;

typedef struct {
    int version, n_planes;
    drv_framelink_plane pl[DRV_FRAMELINK_MAX_PLANES];
    int w[2], h[2];
    warp_depth_encoding depth_encoding;
    double near_z[2];
} drv_framelink_layout;

/* A plane the container leaves to the codec: not RAW, or depth at a reduced scale. */
static inline bool drv_framelink_plane_coded(const drv_framelink_plane *p) { return p->codec || p->scale; }

/* Called once every container check passed and the RAW planes are written, before any header field of *out is:
 * decodes the coded planes into *out. A failure's reason goes into detail. */
typedef struct {
    drv_frame_err (*planes)(void *ctx, const drv_framelink_layout *lay, drv_frame *out, char *detail, int dl);
    void *ctx;
} drv_framelink_hook;
drv_frame_err drv_framelink_decode_hooked(const uint8_t *buf, size_t len, size_t max_frame, drv_frame *out,
                                          drv_framelink_rx *rx, char *detail, int dl, const drv_framelink_hook *hook);

/* Bytes per pixel of a fixed-size format (0: FRAGMENTS or unknown). */
int drv_framelink_format_bpp(int format);
/* The most bytes one chunk of plane p (eye e's slice k) may declare: the plane's own bound (max_layers: the
 * receiver's layer allocation). */
size_t drv_framelink_chunk_bound(const drv_framelink_plane *p, int w, int h, int slice, int max_layers);
/* Rows [y0, y1) of slice k of n of an eye h rows high. */
static inline void drv_framelink_slice_rows(int h, int k, int n, int *y0, int *y1)
{
    *y0 = (int)((long)h * k / n);
    *y1 = (int)((long)h * (k + 1) / n);
}

/* Layers of one eye: counts within max_layers and the fragments adding up within avail; the eye's bytes or 0. */
size_t drv_framelink_layers_check(const uint8_t *p, size_t avail, int w, int h, int max_layers, int *deepest);
/* Eye e of plane `type` in `format` from / to wire bytes (w x h, tightly packed; INV16 with near_z). */
void drv_framelink_get_eye(drv_frame *out, int type, int format, int e, int w, int h, double near_z,
                           const uint8_t *p);
size_t drv_framelink_put_eye(const drv_frame *f, int type, int format, int e, uint8_t *p);
/* Bytes drv_framelink_put_eye writes. */
size_t drv_framelink_eye_bytes(const drv_frame *f, int type, int format, int e);
int drv_framelink_layers_deepest(const drv_frame *f);

/* Sending: header size, and the header (fixed part, objects, the descriptors of pl[0..n), header CRC) and payload
 * CRC of a frame of `total` bytes whose payload the caller wrote at buf + header size. false: f cannot be sent. */
size_t drv_framelink_header_size(int n_objects, int n_planes);
bool drv_framelink_finish(const drv_frame *f, const drv_framelink_tx *tx, int version, const drv_framelink_plane *pl,
                          int n_planes, uint8_t *buf, size_t total);

#endif

/* SPDX-License-Identifier: MIT */
/* drv_framelink: the frame wire protocol between host and board (one codec for both ends): frames host -> board,
 * pose and camera messages board -> host. Little-endian, versioned, CRC32-checked; byte layout in docs/framelink.md. */
#ifndef DRV_FRAMELINK_H
#define DRV_FRAMELINK_H

#include <stddef.h>
#include <stdint.h>

#include "drivers/drv_frames.h"
#include "warp/warp_math.h"

#define DRV_FRAMELINK_MAGIC 0x31465748u      /* "HWF1" as bytes on the wire */
#define DRV_FRAMELINK_POSE_MAGIC 0x31505748u /* "HWP1" */
#define DRV_FRAMELINK_VERSION 1
/* Version 2: a codec per plane (drivers/drv_framelink_codec.h). Receivers read 1 and 2; an all-raw frame is still
 * sent as version 1. Board messages: the camera message is version 2 when it announces codecs beyond raw. */
#define DRV_FRAMELINK_VERSION_2 2
#define DRV_FRAMELINK_VERSION_MAX 2
/* Fixed part of the frame header (before object poses and plane descriptors) and its CRC'd whole. */
#define DRV_FRAMELINK_FIXED_BYTES 312
#define DRV_FRAMELINK_OBJECT_BYTES 56
#define DRV_FRAMELINK_PLANE_DESC_BYTES 16
#define DRV_FRAMELINK_MAX_PLANES 5
#define DRV_FRAMELINK_MAX_HEADER                                                                                  \
    (DRV_FRAMELINK_FIXED_BYTES + DRV_MAX_OBJECTS * DRV_FRAMELINK_OBJECT_BYTES +                                   \
     DRV_FRAMELINK_MAX_PLANES * DRV_FRAMELINK_PLANE_DESC_BYTES + 4)
/* Bytes peek needs before it can tell the header size (magic, version, header size, total size). */
#define DRV_FRAMELINK_PREFIX_BYTES 12
#define DRV_FRAMELINK_POSE_BYTES 204
/* Every time on the wire (board or host clock, ns) lies in [0, DRV_FRAMELINK_TIME_MAX_NS] (146 years of uptime):
 * decoders reject anything else, so differences of two times, and sums of a time and such a difference, can never
 * overflow an int64_t on either side (the runtime's `t_photon - pose_t_ns`, the render start mapping). */
#define DRV_FRAMELINK_TIME_MAX_NS ((int64_t)1 << 62)

/* Plane types on the wire (the DRV_PLANE_* bit index) and their formats. */
enum {
    DRV_FRAMELINK_FMT_RGBA8 = 1,     /* colour: r, g, b, a bytes */
    DRV_FRAMELINK_FMT_F32 = 2,       /* depth: float32 in the frame's depth encoding */
    DRV_FRAMELINK_FMT_UNORM16 = 3,   /* depth: u16 window depth d * 65535 (STANDARD / REVERSED encodings only) */
    DRV_FRAMELINK_FMT_U16 = 4,       /* object ids */
    DRV_FRAMELINK_FMT_VEC2F32 = 5,   /* motion: x, y float32, pixels per second */
    DRV_FRAMELINK_FMT_FRAGMENTS = 6, /* layers: u8 count per pixel, then the fragments (z f32, rgba8, id u16) */
    DRV_FRAMELINK_FMT_INV16 = 7,     /* depth (v2): u16 round(65535 * near_z / z) of linear metres, 0 = sky */
};

/* What the sender adds to a drv_frame: host-clock timing for statistics and the encoding choices. */
typedef struct {
    int64_t pose_sent_ns;         /* board clock: board_t_ns of the pose message rendered for (echoed), 0 unknown */
    int64_t host_pose_rx_ns;      /* host clock: when that pose message arrived */
    int64_t host_render_start_ns; /* host clock */
    int64_t host_render_end_ns;   /* host clock */
    int64_t host_send_ns;         /* host clock: when the frame was handed to the transport */
    int depth_format;             /* 0 or DRV_FRAMELINK_FMT_F32, or DRV_FRAMELINK_FMT_UNORM16 (INV16: v2 only,
                                   * drv_framelink_enc; a receiver reports the format it got) */
} drv_framelink_tx;

/* What a receiver learns beyond the drv_frame. */
typedef struct {
    drv_framelink_tx tx;          /* the sender's fields as sent */
    size_t total_bytes;
} drv_framelink_rx;

/* Wire size of f (0 when f cannot be encoded: no colour, bad dims, too many objects, bad depth format). */
size_t drv_framelink_size(const drv_frame *f);
size_t drv_framelink_size_ex(const drv_frame *f, const drv_framelink_tx *tx);
/* Encodes f into buf; returns the bytes written, 0 when it cannot be encoded or cap is too small. */
size_t drv_framelink_encode(const drv_frame *f, uint8_t *buf, size_t cap);
size_t drv_framelink_encode_ex(const drv_frame *f, const drv_framelink_tx *tx, uint8_t *buf, size_t cap);

/* Header only, for byte streams. With len < the header it returns DRV_FRAME_ERR_TRUNCATED and *total = the bytes
 * needed to decide (the header size once the prefix is in); DRV_FRAME_OK with *total = the whole frame's size once
 * the header arrived and its CRC holds. Otherwise BAD_MAGIC, BAD_VERSION, BAD_SIZE, CRC, or TOO_LARGE (total >
 * max_frame, max_frame 0 means no limit; *total is then the declared size, so a stream can skip the frame). */
drv_frame_err drv_framelink_peek(const uint8_t *buf, size_t len, size_t max_frame, size_t *total);

/* Decodes one frame into *out, whose planes the caller allocated (drv_frame_alloc): the sizes must match the
 * cameras and the planes sent must be allocated. Never allocates; *out is untouched unless DRV_FRAME_OK.
 * received_ns is left alone (the transport knows it); render_start_ns is mapped to the board clock through the
 * echoed pose_sent_ns when known. Run drv_frame_validate() on the result. */
drv_frame_err drv_framelink_decode(const uint8_t *buf, size_t len, size_t max_frame, drv_frame *out);
/* The same, also returning the sender's fields (rx, may be NULL) and a message for logs (detail, may be NULL). */
drv_frame_err drv_framelink_decode_ex(const uint8_t *buf, size_t len, size_t max_frame, drv_frame *out,
                                      drv_framelink_rx *rx, char *detail, int detail_len);

/* Index of the first possible frame start (the magic, or a prefix of it at the end) in buf, or len if none: how a
 * byte-stream receiver resynchronises after garbage. */
size_t drv_framelink_find_magic(const uint8_t *buf, size_t len);

/* Board -> host: the head pose predicted for target_t_ns, sent at board_t_ns (both board clock). */
/* Pose message flags. WANT_KEY: a video colour stream lost a reference; the host sends key frames next (v2). */
#define DRV_FRAMELINK_POSE_WANT_KEY 0x1u
typedef struct {
    uint32_t seq;
    uint32_t flags;               /* DRV_FRAMELINK_POSE_*; unknown bits are ignored */
    int64_t board_t_ns;
    int64_t target_t_ns;
    warp_pose head;
    warp_pose eye[2];
} drv_framelink_pose;

/* Always DRV_FRAMELINK_POSE_BYTES; returns 0 when cap is too small. */
size_t drv_framelink_pose_encode(const drv_framelink_pose *p, uint8_t *buf, size_t cap);
/* TRUNCATED, BAD_MAGIC, BAD_VERSION, BAD_SIZE, CRC, or BAD_POSE (non-finite or non-unit quaternion, non-finite
 * position, a time outside [0, DRV_FRAMELINK_TIME_MAX_NS]). */
drv_frame_err drv_framelink_pose_decode(const uint8_t *buf, size_t len, drv_framelink_pose *out);

/* Board -> host: what the board wants rendered (docs/framelink.md, Camera message). Sent when a host connects and
 * then once a second, so a host that starts late or reconnects learns the eye cameras without asking. */
#define DRV_FRAMELINK_CAMS_MAGIC 0x31435748u /* "HWC1" */
#define DRV_FRAMELINK_CAMS_BYTES 168
typedef struct {
    uint32_t seq;
    unsigned planes;                    /* DRV_PLANE_* the board accepts (allocated); COLOR always */
    warp_depth_encoding depth_encoding; /* the depth encoding the board prefers (any is accepted) */
    uint64_t max_frame_bytes;           /* frames declaring more are rejected */
    double refresh_hz;                  /* the panel's refresh */
    double pose_rate_hz;                /* pose messages per second */
    warp_camera cam[2];                 /* the eye cameras (size, FOV tangents, near/far) frames must be rendered with */
    unsigned codecs;                    /* DRV_CODEC_BIT()s the board decodes (v2 message; v1 and 0: raw only) */
} drv_framelink_cams;

/* Always DRV_FRAMELINK_CAMS_BYTES (version 1 when codecs is raw only, else 2); returns 0 when cap is too small. */
size_t drv_framelink_cams_encode(const drv_framelink_cams *c, uint8_t *buf, size_t cap);
/* TRUNCATED, BAD_MAGIC, BAD_VERSION, BAD_SIZE (also a non-positive or non-finite rate, max_frame_bytes 0), CRC,
 * BAD_FORMAT (reserved fields not zero, v2 codecs without RAW, planes without COLOR or unknown bits, unknown depth
 * encoding) or BAD_CAMERA
 * (size 0 or above WARP_MAX_SIDE, warp_camera_check fails). */
drv_frame_err drv_framelink_cams_decode(const uint8_t *buf, size_t len, drv_framelink_cams *out);

/* Board -> host: the hidden-area mask (docs/framelink.md, Visibility mask message): per eye a line loop of tangent
 * space vertices (u = X/-Z, v = Y/-Z, counter-clockwise) outside which the board shows black, so a host may skip
 * shading there, like OpenXR's XR_KHR_visibility_mask. Sent right after each camera message by a board with a lens
 * mask; its seq is that camera message's. A new kind: hosts that do not know it skip it by its magic and size. */
#define DRV_FRAMELINK_MASK_MAGIC 0x31565748u /* "HWV1" */
#define DRV_FRAMELINK_MASK_MAX 64            /* vertices per eye */
#define DRV_FRAMELINK_MASK_BYTES(n0, n1) (24 + 8 * ((size_t)(n0) + (size_t)(n1)))
typedef struct {
    uint32_t seq;                             /* the camera message it belongs to */
    int n[2];                                 /* vertices per eye: 0 (no mask: every pixel shown) or 3..MASK_MAX */
    float uv[2][2 * DRV_FRAMELINK_MASK_MAX];  /* eye e's vertex k: (uv[e][2k], uv[e][2k + 1]) */
} drv_framelink_mask;

/* DRV_FRAMELINK_MASK_BYTES(n[0], n[1]); 0 when cap is too small or a count is out of range. */
size_t drv_framelink_mask_encode(const drv_framelink_mask *m, uint8_t *buf, size_t cap);
/* TRUNCATED, BAD_MAGIC, BAD_VERSION, BAD_SIZE (the declared size is not the counts'), CRC, BAD_FORMAT (flags not
 * zero, a count of 1, 2 or above DRV_FRAMELINK_MASK_MAX) or BAD_CAMERA (a vertex not finite or beyond |1e4|, i.e.
 * past 89.99 degrees). */
drv_frame_err drv_framelink_mask_decode(const uint8_t *buf, size_t len, drv_framelink_mask *out);

/* Which board -> host message starts buf: DRV_FRAMELINK_POSE_MAGIC, DRV_FRAMELINK_CAMS_MAGIC,
 * DRV_FRAMELINK_MASK_MAGIC, or 0 (unknown or fewer than 12 bytes); *size (may be NULL) = its declared size. */
uint32_t drv_framelink_msg_peek(const uint8_t *buf, size_t len, size_t *size);

#endif

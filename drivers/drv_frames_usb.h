/* SPDX-License-Identifier: MIT */
/* drv_frames_usb: host frames over USB, the board being a FunctionFS gadget (bulk OUT frames, bulk IN poses), and
 * the transport seam below it (its mock, a simulated host behind socket pairs: drv_frames_usb_mock.h). */
#ifndef DRV_FRAMES_USB_H
#define DRV_FRAMES_USB_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

#include "drivers/drv_framelink_codec.h"
#include "drivers/drv_framelink.h"
#include "drivers/drv_frames.h"
#include "warp/warp_head.h"

typedef struct {
    char ffs_dir[128];        /* FunctionFS mount, e.g. /dev/ffs-hmdwarp */
    size_t max_frame_bytes;   /* frames declaring more are rejected (TOO_LARGE) unread; also the receive buffer */
    int eye_w, eye_h;         /* the board's eye size: frames of another size are rejected (BAD_SIZE) */
    unsigned planes;          /* DRV_PLANE_* the caller allocates (drv_frames_planes reports them) */
    drv_pose_source poses;    /* predictions sent to the host */
    double pose_rate_hz;      /* pose messages per second */
    double link_mbps;         /* mock and socket transports: read at most this many MB/s (10^6 B/s; 0 = unlimited) */
    warp_head head;           /* eye offsets (IPD) for the per-eye poses sent; all zero = warp_head_default() */
    /* What the camera message (HWC1) tells each host to render: sent when a host connects, then once a second. */
    warp_camera cam[2];                 /* the eye cameras frames must be rendered with */
    double refresh_hz;                  /* the panel's refresh */
    warp_depth_encoding depth_encoding; /* the depth encoding the board prefers (any is accepted) */
    /* The visibility mask message (HWV1) sent right after each camera message when a count is not 0 (its seq is
     * set here): per eye mask.n[e] tangent-space vertices (rt_devices fills it from warp_fov_mask_loop). */
    drv_framelink_mask mask;
    /* framelink v2 (docs/framelink.md): compressed planes are decoded on the receiving thread plus helpers. */
    int max_layers;           /* fragments per pixel the caller's frames hold (DRV_PLANE_LAYERS; 0: 4) */
    unsigned codecs;          /* DRV_CODEC_BIT()s announced to hosts (0: drv_codec_decodable(), every one built) */
    int decode_threads;       /* threads a frame's chunks decode on, 1..DRV_FRAMES_USB_DECODE_THREADS_MAX (0: 2) */
    const char *video_decoder; /* one of drv_frames_usb_video_decoders (NULL: software); read at create only */
} drv_frames_usb_params;

/* What decode_threads and video_decoder may be: create checks them, and the board config's keys take these (one
 * rule, whether a config or a test makes the source). */
#define DRV_FRAMES_USB_DECODE_THREADS_MAX 8
extern const char *const drv_frames_usb_video_decoders[]; /* "software", "v4l2m2m", NULL */

/* The real gadget: writes the descriptors and strings to ffs_dir/ep0 (the gadget is bound afterwards, see
 * board/gadget.sh), then serves ep0 events, ep1 (frames) and ep2 (poses). NULL with a message in err on failure. */
drv_frames *drv_frames_usb_create(const drv_frames_usb_params *p, char *err, int errlen);

typedef struct {
    uint64_t frames;                            /* accepted */
    uint64_t bytes;                             /* read from the OUT stream */
    uint64_t rejected[DRV_FRAME_ERR_COUNT];     /* by reason */
    uint64_t skipped_bytes;                     /* dropped while looking for a frame magic */
    uint64_t discarded_bytes;                   /* oversize frames read into scratch and dropped */
    uint64_t poses_sent, poses_dropped;         /* pose messages written / not taken by the host in time */
    uint64_t disconnects;                       /* endpoint I/O failures and DISABLE/UNBIND events */
    uint64_t connections, refused;              /* hosts connected (USB: function enabled; socket: accepted) /
                                                 * turned away while one was connected (socket) */
    uint64_t cams_sent;                         /* camera messages (HWC1) written */
    uint64_t masks_sent;                        /* visibility mask messages (HWV1) written */
    bool connected;                             /* the host has configured the function (ENABLE) */
    double lead_ms;                             /* current pose lead: measured pose-to-frame latency */
    unsigned codecs;                            /* DRV_CODEC_BIT()s announced */
    drv_framelink_dec_stats dec;                /* framelink v2 decoding, as the decoder counts it (codec errors
                                                 * are in rejected[] too) */
    char usb_speed[24];                         /* usb: the speed the host negotiated ("high-speed", "super-speed",
                                                 * drv_usb_speed_name; "unknown" before the first); "" on the others */
    char last_error[160];
} drv_frames_usb_stats;

/* The lowest layer, below the framelink stream: what FunctionFS's endpoints are for the gadget (and a Unix socket
 * for drv_frames_socket.h). */
typedef struct drv_usb_transport drv_usb_transport;
struct drv_usb_transport {
    /* Up to cap bytes of the OUT stream within timeout_ms: bytes, 0 on timeout, -errno when the link failed. */
    ssize_t (*read)(drv_usb_transport *t, uint8_t *buf, size_t cap, int timeout_ms);
    /* One message on the IN endpoint: len, 0 when the host did not take it in time, -errno. */
    ssize_t (*write)(drv_usb_transport *t, const uint8_t *buf, size_t len, int timeout_ms);
    bool (*connected)(drv_usb_transport *t);
    /* Called after the pose thread stopped: ends what serves the transport, then frees it. */
    void (*destroy)(drv_usb_transport *t);
    /* Optional (NULL: each rise of connected() is a new host): how many hosts have connected so far. The pose
     * thread greets each new one with the camera message before its first pose, so write() reaches only the host
     * this last counted (a newer one gets nothing until it is counted: no pose can overtake its greeting). */
    uint64_t (*connections)(drv_usb_transport *t);
    /* Optional: adds what the transport counts itself (connections, refused) to st. */
    void (*stats)(drv_usb_transport *t, drv_frames_usb_stats *st);
};

/* The board side (receive state machine, pose thread, statistics) on any transport, owned from here on (destroyed
 * on failure too); `name` (static) names the source. NULL with a message in err on failure. */
drv_frames *drv_frames_usb_create_on_transport(const drv_frames_usb_params *p, drv_usb_transport *t,
                                               const char *name, char *err, int errlen);

/* The board side's receive state machine without a transport (tests, the fuzzer): bytes of the OUT stream are
 * given with drv_frames_usb_feed, and drv_frames_receive(fr, f, 0) parses what was fed exactly as the gadget does
 * (returning 0 once it needs more). No pose thread; p->poses may be empty. */
drv_frames *drv_frames_usb_create_fed(const drv_frames_usb_params *p, char *err, int errlen);
/* Appends up to n bytes to the stream; returns how many were taken: fewer once a whole frame (or a rejection) is
 * waiting to be received, or the buffer is full. */
size_t drv_frames_usb_feed(drv_frames *fr, const uint8_t *data, size_t n);

/* FunctionFS's ep0 events (FUNCTIONFS_BIND..RESUME) as the gadget counts them: ENABLE connects, DISABLE and UNBIND
 * disconnect. An ENABLE while already enabled is a disconnect and a new host: f_fs.c's __ffs_event_add drops the
 * pending DISABLE/UNBIND/BIND when an ENABLE is queued, so an ep0 reader that woke late (a busy board) sees a replug
 * only as a second ENABLE. Updates *enabled and st (connections, disconnects, last_error); the caller holds the
 * locks. Public for the tests. */
void drv_frames_usb_ffs_event(int type, bool *enabled, drv_frames_usb_stats *st);

/* Statistics of a usb, mock or socket frames source; safe from any thread. */
void drv_frames_usb_stats_get(drv_frames *fr, drv_frames_usb_stats *st);
/* The decode time (ms) of the frame the last drv_frames_receive returned: for the receiving thread only (no lock),
 * so its telemetry can keep a histogram without the vsync path ever touching it. */
double drv_frames_usb_decode_ms(drv_frames *fr);

#endif

/* SPDX-License-Identifier: MIT */
/* drv_frames: the interface of host frame sources (simulated host, USB gadget, V4L2 capture) and the frame they
 * deliver: per-eye planes plus the exact pose, camera and time each eye was rendered with. */
#ifndef DRV_FRAMES_H
#define DRV_FRAMES_H

#include <pthread.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdint.h>

#include "warp/warp_camera.h"
#include "warp/warp_image.h"
#include "warp/warp_math.h"

/* Planes a frame can carry (a source sends only what its scene needs); the same bits as SIM_PLANE_* (asserted in
 * drv_sim.c) and as the host library's public HMDWARP_HOST_PLANE_* (asserted in host/hmdwarp_host.c). */
enum {
    DRV_PLANE_COLOR = 1u << 0,
    DRV_PLANE_DEPTH = 1u << 1,
    DRV_PLANE_IDS = 1u << 2,
    DRV_PLANE_MOTION = 1u << 3,
    DRV_PLANE_LAYERS = 1u << 4,
};

#define DRV_MAX_OBJECTS 64

typedef struct {
    uint64_t seq;                 /* host's frame counter */
    int64_t pose_t_ns;            /* display time the host rendered for (the time of the pose it used) */
    int64_t render_start_ns;      /* when the host began rendering (board clock) */
    int64_t received_ns;          /* when the frame was complete on the board */
    unsigned planes;              /* DRV_PLANE_* present in this frame */
    warp_depth_encoding depth_encoding;
    warp_camera cam[2];
    warp_pose eye_pose[2];        /* world_from_eye each eye was rendered with */
    warp_image_rgba8 color[2];
    warp_image_f32 depth[2];
    warp_image_u16 ids[2];
    warp_image_vec2f motion[2];
    warp_image_layers layers[2];
    int n_objects;                /* per-object matrices (002 §3.2), ids 1..n_objects */
    warp_pose object_pose[DRV_MAX_OBJECTS];
    double scene_time;            /* simulated host only: scene time rendered (lets accuracy checks re-render) */
} drv_frame;

/* Allocates the planes in `planes` for two eyes of w x h (max_layers for DRV_PLANE_LAYERS). */
bool drv_frame_alloc(drv_frame *f, int w, int h, unsigned planes, int max_layers);
void drv_frame_free(drv_frame *f);

/* Where a frame source gets the head pose to render for: the board's prediction (poses travel board -> host). */
typedef struct {
    bool (*predict)(void *ctx, int64_t t_ns, warp_pose *head);
    void *ctx;
} drv_pose_source;

/* Reasons a frame is rejected (counted in telemetry by the caller). */
typedef enum {
    DRV_FRAME_OK = 0,
    DRV_FRAME_ERR_TRUNCATED = 1,
    DRV_FRAME_ERR_BAD_SIZE = 2,
    DRV_FRAME_ERR_BAD_VERSION = 3,
    DRV_FRAME_ERR_CRC = 4,
    DRV_FRAME_ERR_BAD_POSE = 5,   /* NaN/Inf or non-unit quaternion, NaN position */
    DRV_FRAME_ERR_BAD_DEPTH = 6,  /* NaN/negative depth values */
    DRV_FRAME_ERR_BAD_CAMERA = 7,
    DRV_FRAME_ERR_IO = 8,
    DRV_FRAME_ERR_BAD_MAGIC = 9,  /* not a frame (lost sync on a byte stream, wrong in-band marker) */
    DRV_FRAME_ERR_TOO_LARGE = 10, /* declares more bytes than the configured maximum frame size */
    DRV_FRAME_ERR_BAD_FORMAT = 11, /* unsupported plane format, pixel format or plane combination */
    DRV_FRAME_ERR_COUNT
} drv_frame_err;
const char *drv_frame_err_str(drv_frame_err e);
/* A decoder's failure: the detail into why[whylen] (warp_verr: printf-checked, cut to fit, why may be NULL) and e
 * returned, so a rejection reads `return drv_frame_fail(why, whylen, DRV_FRAME_ERR_BAD_CRC, "...", ...);`. */
drv_frame_err drv_frame_fail(char *why, int whylen, drv_frame_err e, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
/* A backend's last_error (the text its last_error member returns), written by its helper threads under the lock
 * that guards its stats: formatted with warp_verr (printf-checked, cut to fit) so every backend notes it one way. */
void drv_frames_vnote(pthread_mutex_t *lock, char *last_error, int len, const char *fmt, va_list ap)
    __attribute__((format(printf, 4, 0)));

typedef struct drv_frames drv_frames;
struct drv_frames {
    const char *name;
    /* Waits up to timeout_ms for the next host frame and stores it in *f (allocated by the caller for the planes
     * drv_frames_planes() reports). Returns 1 when a frame was stored, 0 on timeout, or -drv_frame_err when a
     * frame arrived and was rejected (the caller counts it and keeps warping its last good frame). */
    int (*receive)(drv_frames *fr, drv_frame *f, int timeout_ms);
    unsigned (*planes)(drv_frames *fr);
    /* Optional (NULL: none): the latest problem in words, naming the device (for the log after a rejection). */
    void (*last_error)(drv_frames *fr, char *buf, int len);
    void (*destroy)(drv_frames *fr);
};

static inline int drv_frames_receive(drv_frames *fr, drv_frame *f, int timeout_ms)
{
    return fr->receive(fr, f, timeout_ms);
}
static inline unsigned drv_frames_planes(drv_frames *fr) { return fr->planes(fr); }
static inline void drv_frames_last_error(drv_frames *fr, char *buf, int len)
{
    buf[0] = 0;
    if (fr->last_error) fr->last_error(fr, buf, len);
}
static inline void drv_frames_destroy(drv_frames *fr)
{
    if (fr) fr->destroy(fr);
}

/* Checks what any source must guarantee before a frame reaches the warps: finite unit quaternions and finite
 * positions, valid cameras matching the plane sizes. Returns DRV_FRAME_OK or the first problem. */
drv_frame_err drv_frame_validate(const drv_frame *f);

#endif

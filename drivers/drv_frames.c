/* SPDX-License-Identifier: MIT */
/* drv_frames: the interface of host frame sources (simulated host, USB gadget, V4L2 capture) and the frame they
 * deliver: per-eye planes plus the exact pose, camera and time each eye was rendered with. */
#include "drivers/drv_frames.h"

#include <math.h>
#include <stdarg.h>
#include <string.h>

#include "warp/warp_err.h"

bool drv_frame_alloc(drv_frame *f, int w, int h, unsigned planes, int max_layers)
{
    memset(f, 0, sizeof *f);
    for (int e = 0; e < 2; e++) {
        bool ok = true;
        if (planes & DRV_PLANE_COLOR) ok = ok && warp_image_rgba8_alloc(&f->color[e], w, h);
        if (planes & DRV_PLANE_DEPTH) ok = ok && warp_image_f32_alloc(&f->depth[e], w, h);
        if (planes & DRV_PLANE_IDS) ok = ok && warp_image_u16_alloc(&f->ids[e], w, h);
        if (planes & DRV_PLANE_MOTION) ok = ok && warp_image_vec2f_alloc(&f->motion[e], w, h);
        if (planes & DRV_PLANE_LAYERS) ok = ok && warp_image_layers_alloc(&f->layers[e], w, h, max_layers);
        if (!ok) {
            drv_frame_free(f);
            return false;
        }
    }
    return true;
}

void drv_frame_free(drv_frame *f)
{
    for (int e = 0; e < 2; e++) {
        warp_image_free(&f->color[e]);
        warp_image_free(&f->depth[e]);
        warp_image_free(&f->ids[e]);
        warp_image_free(&f->motion[e]);
        warp_image_layers_free(&f->layers[e]);
    }
}

const char *drv_frame_err_str(drv_frame_err e)
{
    static const char *const names[DRV_FRAME_ERR_COUNT] = {
        "ok", "truncated", "bad size", "bad version", "bad CRC", "bad pose", "bad depth", "bad camera", "I/O error",
        "bad magic", "too large", "bad format",
    };
    return e >= 0 && e < DRV_FRAME_ERR_COUNT ? names[e] : "unknown";
}

drv_frame_err drv_frame_fail(char *why, int whylen, drv_frame_err e, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    warp_verr(why, whylen, fmt, ap);
    va_end(ap);
    return e;
}

void drv_frames_vnote(pthread_mutex_t *lock, char *last_error, int len, const char *fmt, va_list ap)
{
    pthread_mutex_lock(lock);
    warp_verr(last_error, len, fmt, ap);
    pthread_mutex_unlock(lock);
}

drv_frame_err drv_frame_validate(const drv_frame *f)
{
    if (!(f->planes & DRV_PLANE_COLOR)) return DRV_FRAME_ERR_BAD_SIZE;
    for (int e = 0; e < 2; e++) {
        if (!warp_pose_isfinite(f->eye_pose[e])) return DRV_FRAME_ERR_BAD_POSE;
        /* Hosts send normalised quaternions; a norm far from 1 means corruption or a units mistake, not rounding. */
        if (fabs(warp_quat_norm(f->eye_pose[e].q) - 1.0) > 1e-3) return DRV_FRAME_ERR_BAD_POSE;
        if (warp_camera_check(&f->cam[e])) return DRV_FRAME_ERR_BAD_CAMERA;
        if (f->cam[e].width != f->color[e].w || f->cam[e].height != f->color[e].h) return DRV_FRAME_ERR_BAD_SIZE;
        if ((f->planes & DRV_PLANE_DEPTH) &&
            (f->depth[e].w != f->color[e].w || f->depth[e].h != f->color[e].h))
            return DRV_FRAME_ERR_BAD_SIZE;
    }
    return DRV_FRAME_OK;
}

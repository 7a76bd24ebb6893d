/* SPDX-License-Identifier: MIT */
/* rt_frameq: the lock-free handoff of host frames from the frames thread to the compositor (a triple buffer):
 * the producer never waits, the consumer always gets the newest complete frame without blocking. */
#ifndef RT_FRAMEQ_H
#define RT_FRAMEQ_H

#include <stdatomic.h>
#include <stdbool.h>

#include "drivers/drv_frames.h"
#include "platform/plat_workers.h"
#include "warp/warp_resample.h"
#include "warp/warp_view.h"

/* A frame slot: what the host sent plus what the board derives from it once, on the frames thread, so the vsync
 * path only reads (inverse depth and its range for depth warps, planar colour for the resampler). */
typedef struct {
    drv_frame f;
    warp_image_f32 inv_depth[2];
    float inv_min[2], inv_max[2];
    warp_planar3 planar[2];
    warp_image_rgba8 opaque[2]; /* with layers: the colour behind the transparent fragments (unblended) */
    warp_image_f32 blockmax[2]; /* with depth: nearest inverse depth per RT_BLOCK^2 texels (raytrace skipping) */
    bool has_depth;
} rt_frame;

#define RT_BLOCK 8

/* One frame slot's planes for two eyes of w x h (what rt_frameq_alloc allocates three of). */
bool rt_frame_alloc(rt_frame *s, int w, int h, unsigned planes, int max_layers);
void rt_frame_free(rt_frame *s);
/* Validates a received frame and derives what the warps read from it (inverse depth and its range, the raytrace's
 * skipping grid, planar colour, the opaque colour under layers): once per host frame, on the frames thread, never
 * per vsync. DRV_FRAME_OK, or why the frame is rejected. */
drv_frame_err rt_frame_prepare(rt_frame *s);
/* The same with each eye's part as its own task on w (the frames thread's pool; NULL: the caller alone): the same
 * result, in about half the time on two threads (both eyes at 1440x1600 take some 13 ms on one core here). */
drv_frame_err rt_frame_prepare_on(rt_frame *s, plat_workers *w);
/* Builds the warp input for one eye of a prepared frame. */
warp_view rt_frame_view(const rt_frame *fr, int eye);

typedef struct {
    rt_frame slot[3];
    /* Index of the published-but-not-taken slot, with NEW_BIT set while it holds a frame the consumer has not
     * taken. Producer and consumer each own one more slot; ownership moves only by atomic exchange. */
    _Atomic int middle;
    int back;  /* producer-owned */
    int front; /* consumer-owned */
    /* consumer-owned: whether front holds a frame yet. Not the frame's seq: a host may start counting at 0. */
    bool have_front;
} rt_frameq;

bool rt_frameq_alloc(rt_frameq *q, int w, int h, unsigned planes, int max_layers);
void rt_frameq_free(rt_frameq *q);

/* Producer: the slot to fill, and publishing it (the previous unconsumed frame, if any, is replaced: the
 * display only ever wants the newest). Returns true when a frame was replaced without being taken. */
rt_frame *rt_frameq_back(rt_frameq *q);
bool rt_frameq_publish(rt_frameq *q);

/* Consumer: the newest published frame, or the current one when nothing new arrived; NULL before the first.
 * *is_new tells whether it changed. Never blocks. */
const rt_frame *rt_frameq_latest(rt_frameq *q, bool *is_new);

#endif

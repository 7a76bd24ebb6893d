/* SPDX-License-Identifier: MIT */
/* rt_frameq: the lock-free handoff of host frames from the frames thread to the compositor (a triple buffer):
 * the producer never waits, the consumer always gets the newest complete frame without blocking. */
#include "runtime/rt_frameq.h"

#include <string.h>

#include "warp/warp_raytrace.h"
#include "warp/warp_transparency.h"

#define NEW_BIT 4

warp_view rt_frame_view(const rt_frame *fr, int eye)
{
    warp_view v;
    memset(&v, 0, sizeof v);
    v.cam = fr->f.cam[eye];
    v.pose = fr->f.eye_pose[eye];
    v.color = &fr->f.color[eye];
    v.inv_depth = fr->has_depth ? &fr->inv_depth[eye] : NULL;
    v.inv_depth_min = fr->inv_min[eye];
    v.inv_depth_max = fr->inv_max[eye];
    unsigned pl = fr->f.planes;
    v.ids = pl & DRV_PLANE_IDS ? &fr->f.ids[eye] : NULL;
    v.motion = pl & DRV_PLANE_MOTION ? &fr->f.motion[eye] : NULL;
    v.layers = pl & DRV_PLANE_LAYERS ? &fr->f.layers[eye] : NULL;
    /* with layers the warps want the opaque surface's colour: the fragments are warped on their own */
    if (v.layers && fr->opaque[eye].px) v.color = &fr->opaque[eye];
    v.n_objects = fr->f.n_objects;
    v.object_pose = fr->f.object_pose;
    v.time = fr->f.scene_time;
    return v;
}

/* One eye of rt_frame_prepare_on: everything derived from a frame is per eye. */
typedef struct {
    rt_frame *s;
    long bad[2]; /* depth values that are not depths (NaN, negative), per eye */
} prepare_job;

static void prepare_eye(void *ctx, int eye)
{
    prepare_job *j = ctx;
    rt_frame *s = j->s;
    j->bad[eye] = 0;
    if (s->has_depth) {
        j->bad[eye] = warp_inverse_depth_from(&s->f.cam[eye], s->f.depth_encoding, &s->f.depth[eye],
                                              &s->inv_depth[eye], &s->inv_min[eye], &s->inv_max[eye]);
        if (j->bad[eye]) return; /* the frame is rejected: nothing else of it is read */
        warp_raytrace_blockmax(&s->inv_depth[eye], &s->blockmax[eye], RT_BLOCK);
    }
    warp_planar3_from_rgba_rows(&s->planar[eye], &s->f.color[eye], 0, s->f.color[eye].h);
    /* The host blended its transparent fragments into the colour; the transparency warp moves them on their own,
     * over the surface behind them: recover that once per frame, here, off the vsync path. */
    if ((s->f.planes & DRV_PLANE_LAYERS) && s->opaque[eye].px)
        warp_transparency_unblend(&s->f.color[eye], &s->f.layers[eye], &s->opaque[eye]);
}

/* here rather than in the frames thread: the bench and the tests prepare their frames exactly as hmdwarpd does */
drv_frame_err rt_frame_prepare_on(rt_frame *s, plat_workers *w)
{
    drv_frame_err e = drv_frame_validate(&s->f);
    if (e != DRV_FRAME_OK) return e;
    s->has_depth = (s->f.planes & DRV_PLANE_DEPTH) != 0;
    prepare_job j = {s, {0, 0}};
    if (w)
        plat_workers_run(w, 2, prepare_eye, &j);
    else
        for (int eye = 0; eye < 2; eye++) prepare_eye(&j, eye);
    return j.bad[0] || j.bad[1] ? DRV_FRAME_ERR_BAD_DEPTH : DRV_FRAME_OK;
}

drv_frame_err rt_frame_prepare(rt_frame *s) { return rt_frame_prepare_on(s, NULL); }

bool rt_frame_alloc(rt_frame *s, int w, int h, unsigned planes, int max_layers)
{
    memset(s, 0, sizeof *s);
    bool ok = drv_frame_alloc(&s->f, w, h, planes, max_layers);
    for (int e = 0; ok && e < 2; e++) {
        ok = warp_planar3_alloc(&s->planar[e], w, h);
        if (ok && (planes & DRV_PLANE_DEPTH))
            ok = warp_image_f32_alloc(&s->inv_depth[e], w, h) &&
                 warp_image_f32_alloc(&s->blockmax[e], (w + RT_BLOCK - 1) / RT_BLOCK, (h + RT_BLOCK - 1) / RT_BLOCK);
        if (ok && (planes & DRV_PLANE_LAYERS)) ok = warp_image_rgba8_alloc(&s->opaque[e], w, h);
    }
    if (!ok) rt_frame_free(s);
    return ok;
}

void rt_frame_free(rt_frame *s)
{
    drv_frame_free(&s->f);
    for (int e = 0; e < 2; e++) {
        warp_image_free(&s->inv_depth[e]);
        warp_planar3_free(&s->planar[e]);
        warp_image_free(&s->opaque[e]);
        warp_image_free(&s->blockmax[e]);
    }
}

bool rt_frameq_alloc(rt_frameq *q, int w, int h, unsigned planes, int max_layers)
{
    memset(q, 0, sizeof *q);
    for (int i = 0; i < 3; i++)
        if (!rt_frame_alloc(&q->slot[i], w, h, planes, max_layers)) {
            rt_frameq_free(q);
            return false;
        }
    q->back = 0;
    atomic_store(&q->middle, 1);
    q->front = 2;
    return true;
}

void rt_frameq_free(rt_frameq *q)
{
    for (int i = 0; i < 3; i++) rt_frame_free(&q->slot[i]);
}

rt_frame *rt_frameq_back(rt_frameq *q) { return &q->slot[q->back]; }

bool rt_frameq_publish(rt_frameq *q)
{
    /* acq_rel: release our writes to the slot, acquire the consumer's release of the slot we get back. */
    int old = atomic_exchange_explicit(&q->middle, q->back | NEW_BIT, memory_order_acq_rel);
    q->back = old & 3;
    return (old & NEW_BIT) != 0;
}

const rt_frame *rt_frameq_latest(rt_frameq *q, bool *is_new)
{
    bool fresh = false;
    if (atomic_load_explicit(&q->middle, memory_order_relaxed) & NEW_BIT) {
        int old = atomic_exchange_explicit(&q->middle, q->front, memory_order_acq_rel);
        q->front = old & 3;
        q->have_front = true;
        fresh = true;
    }
    if (is_new) *is_new = fresh;
    /* Until the first publish the consumer's slot holds nothing. */
    return q->have_front ? &q->slot[q->front] : NULL;
}

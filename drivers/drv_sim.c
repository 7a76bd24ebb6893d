/* SPDX-License-Identifier: MIT */
/* drv_sim: the simulated board's devices: an IMU replaying a head-motion trace in real time, a vsync timer, and a
 * host PC rendering the scene at the poses the board sends it. The same interfaces as the real backends. */
#include "drivers/drv_sim.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "platform/plat_clock.h"
#include "platform/plat_workers.h"

/* The simulated host's planes are handed on as DRV_PLANE_* bits unchanged (drv_frames.h), so the enums must agree. */
_Static_assert((unsigned)DRV_PLANE_COLOR == (unsigned)SIM_PLANE_COLOR &&
                   (unsigned)DRV_PLANE_DEPTH == (unsigned)SIM_PLANE_DEPTH &&
                   (unsigned)DRV_PLANE_IDS == (unsigned)SIM_PLANE_IDS &&
                   (unsigned)DRV_PLANE_MOTION == (unsigned)SIM_PLANE_MOTION &&
                   (unsigned)DRV_PLANE_LAYERS == (unsigned)SIM_PLANE_LAYERS,
               "DRV_PLANE_* and SIM_PLANE_* must be the same bits");

/* ---- IMU ---- */

typedef struct {
    drv_imu base;
    sim_trace trace;
    sim_imu_params p;
    int64_t t0;
    uint64_t next; /* index of the next sample to deliver */
} imu_sim;

static int64_t sample_time(const imu_sim *s, uint64_t i)
{
    return s->t0 + (int64_t)llround((s->p.t_start + (double)i / s->p.rate_hz) * 1e9);
}

static int imu_sim_read(drv_imu *imu, drv_imu_sample *out, int max, int timeout_ms)
{
    imu_sim *s = (imu_sim *)imu;
    int64_t now = plat_now_ns();
    int64_t due = sample_time(s, s->next);
    if (due > now) {
        /* Sleep until the sample would have been measured, as a device interrupt would make us. */
        int64_t until = now + (int64_t)timeout_ms * PLAT_NS_PER_MS;
        plat_sleep_until_ns(due < until ? due : until);
        now = plat_now_ns();
    }
    int n = 0;
    while (n < max && sample_time(s, s->next) <= now) {
        sim_imu_sample smp;
        sim_imu_sample_at(&s->trace, &s->p, s->next, &smp);
        out[n].t_ns = sample_time(s, s->next);
        out[n].gyro[0] = smp.gyro.x;
        out[n].gyro[1] = smp.gyro.y;
        out[n].gyro[2] = smp.gyro.z;
        out[n].accel[0] = smp.accel.x;
        out[n].accel[1] = smp.accel.y;
        out[n].accel[2] = smp.accel.z;
        s->next++;
        n++;
    }
    return n;
}

static void imu_sim_destroy(drv_imu *imu) { free(imu); }

drv_imu *drv_imu_sim_create(const sim_trace *trace, const sim_imu_params *p, int64_t t0_ns)
{
    imu_sim *s = calloc(1, sizeof *s);
    if (!s) return NULL;
    s->base.name = "sim";
    s->base.read = imu_sim_read;
    s->base.destroy = imu_sim_destroy;
    s->trace = *trace;
    s->p = *p;
    s->t0 = t0_ns;
    return &s->base;
}

/* ---- vsync ---- */

typedef struct {
    drv_vsync base;
    int64_t t0, period;
} vsync_sim;

static int64_t vsync_sim_next(drv_vsync *v, int64_t after_ns, int64_t *period_ns)
{
    vsync_sim *s = (vsync_sim *)v;
    if (period_ns) *period_ns = s->period;
    if (after_ns < s->t0) return s->t0;
    int64_t k = (after_ns - s->t0) / s->period + 1;
    return s->t0 + k * s->period;
}

static void vsync_sim_destroy(drv_vsync *v) { free(v); }

drv_vsync *drv_vsync_sim_create(double refresh_hz, int64_t t0_ns)
{
    if (!(refresh_hz > 0)) return NULL;
    vsync_sim *s = calloc(1, sizeof *s);
    if (!s) return NULL;
    s->base.name = "sim";
    s->base.next = vsync_sim_next;
    s->base.destroy = vsync_sim_destroy;
    s->t0 = t0_ns;
    s->period = (int64_t)llround(1e9 / refresh_hz);
    return &s->base;
}

/* ---- host ---- */

#define BAND 32 /* rows per render task */

typedef struct {
    drv_frames base;
    drv_frames_sim_params p;
    unsigned planes;
    plat_workers *workers;
    int64_t last_start;
    double render_ms_est; /* the host's estimate of its own render time, used to predict its display time */
    uint64_t seq;
    drv_frames_sim_stats st;
    /* current render job */
    drv_frame *job_frame;
    double job_time;
} frames_sim;

static void render_task(void *ctx, int task)
{
    frames_sim *s = ctx;
    int bands = (s->p.cam[0].height + BAND - 1) / BAND;
    int eye = task / bands, y0 = (task % bands) * BAND;
    int y1 = y0 + BAND < s->p.cam[eye].height ? y0 + BAND : s->p.cam[eye].height;
    drv_frame *f = s->job_frame;
    sim_buffers b;
    memset(&b, 0, sizeof b);
    b.color = f->color[eye];
    b.depth = f->depth[eye];
    b.ids = f->ids[eye];
    b.motion = f->motion[eye];
    b.layers = f->layers[eye];
    b.planes = s->planes;
    sim_render_rows(s->p.scene, s->job_time, f->eye_pose[eye], &s->p.cam[eye], s->planes, &b, y0, y1);
}

static int frames_sim_receive(drv_frames *fr, drv_frame *f, int timeout_ms)
{
    frames_sim *s = (frames_sim *)fr;
    int64_t now = plat_now_ns();
    int64_t start = s->last_start + (int64_t)(1e9 / s->p.rate_hz);
    if (start < now) start = now;
    if (start > now + (int64_t)timeout_ms * PLAT_NS_PER_MS) {
        plat_sleep_ns((int64_t)timeout_ms * PLAT_NS_PER_MS);
        return 0;
    }
    plat_sleep_until_ns(start);
    /* Like an OpenXR application, the host renders for the time its frame is expected on screen. */
    int64_t target = start + (int64_t)((s->render_ms_est + s->p.latency_ms) * 1e6);
    warp_pose head;
    if (!s->p.poses.predict(s->p.poses.ctx, target, &head)) {
        plat_sleep_ns(PLAT_NS_PER_MS); /* tracking has not started yet */
        return 0;
    }
    s->last_start = start;
    f->planes = s->planes;
    f->depth_encoding = WARP_DEPTH_LINEAR;
    f->pose_t_ns = target;
    f->render_start_ns = start;
    f->scene_time = (double)(target - s->p.t0_ns) * 1e-9;
    for (int e = 0; e < 2; e++) {
        f->cam[e] = s->p.cam[e];
        f->eye_pose[e] = warp_head_eye_pose(&s->p.head, head, e);
    }
    f->n_objects = sim_scene_object_count(s->p.scene);
    if (f->n_objects > DRV_MAX_OBJECTS) f->n_objects = DRV_MAX_OBJECTS;
    for (int i = 0; i < f->n_objects; i++) f->object_pose[i] = sim_scene_object_pose(s->p.scene, i + 1, f->scene_time);
    s->job_frame = f;
    s->job_time = f->scene_time;
    int bands = (s->p.cam[0].height + BAND - 1) / BAND;
    plat_workers_run(s->workers, 2 * bands, render_task, s);
    int64_t done = plat_now_ns();
    double ms = (double)(done - start) * 1e-6;
    s->render_ms_est = s->render_ms_est > 0 ? 0.8 * s->render_ms_est + 0.2 * ms : ms;
    s->st.render_ns_total += done - start;
    plat_sleep_ns((int64_t)(s->p.latency_ms * 1e6));
    f->received_ns = plat_now_ns();
    f->seq = ++s->seq;
    s->st.frames++;
    for (int b = 0; b < 5; b++)
        if (s->planes & (1u << b)) s->st.plane_renders[b]++;
    return 1;
}

static unsigned frames_sim_planes(drv_frames *fr) { return ((frames_sim *)fr)->planes; }

static void frames_sim_destroy(drv_frames *fr)
{
    frames_sim *s = (frames_sim *)fr;
    plat_workers_destroy(s->workers);
    free(s);
}

drv_frames *drv_frames_sim_create(const drv_frames_sim_params *p)
{
    if (!p->scene || !p->poses.predict || !(p->rate_hz > 0)) return NULL;
    frames_sim *s = calloc(1, sizeof *s);
    if (!s) return NULL;
    s->p = *p;
    /* Only the planes the scene's effects call for: a rotation-only scene never pays for depth. */
    s->planes = (sim_planes_for_effects(sim_scene_effects(p->scene)) & p->planes_wanted) | DRV_PLANE_COLOR;
    s->workers = plat_workers_create(p->threads > 1 ? p->threads - 1 : 0, 0);
    if (!s->workers) {
        free(s);
        return NULL;
    }
    s->last_start = plat_now_ns() - PLAT_NS_PER_S;
    s->base.name = "sim";
    s->base.receive = frames_sim_receive;
    s->base.planes = frames_sim_planes;
    s->base.destroy = frames_sim_destroy;
    return &s->base;
}

void drv_frames_sim_stats_get(drv_frames *fr, drv_frames_sim_stats *st) { *st = ((frames_sim *)fr)->st; }

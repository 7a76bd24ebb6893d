/* SPDX-License-Identifier: MIT */
/* drv_sim: the simulated board's devices: an IMU replaying a head-motion trace in real time, a vsync timer, and a
 * host PC rendering the scene at the poses the board sends it. The same interfaces as the real backends. */
#ifndef DRV_SIM_H
#define DRV_SIM_H

#include <stdint.h>

#include "drivers/drv_frames.h"
#include "drivers/drv_imu.h"
#include "drivers/drv_vsync.h"
#include "sim/sim_scene.h"
#include "sim/sim_trace.h"
#include "warp/warp_head.h"

/* IMU samples of `trace` paced in real time; scene time 0 is t0_ns, the first sample is at p->t_start. */
drv_imu *drv_imu_sim_create(const sim_trace *trace, const sim_imu_params *p, int64_t t0_ns);

/* Vsync every 1/refresh_hz seconds, phase-locked to t0_ns. */
drv_vsync *drv_vsync_sim_create(double refresh_hz, int64_t t0_ns);

typedef struct {
    const sim_scene *scene;
    warp_camera cam[2];
    warp_head head;            /* IPD for the eye poses */
    double rate_hz;            /* render no more often than this */
    double latency_ms;         /* transport delay added after each render */
    int threads;               /* render threads */
    int64_t t0_ns;             /* scene time origin */
    drv_pose_source poses;     /* the board's predictions */
    unsigned planes_wanted;    /* planes the consumer can use; the host renders the intersection with what the
                                * scene's effects need (sim_planes_for_effects) */
} drv_frames_sim_params;

typedef struct {
    uint64_t frames;
    uint64_t plane_renders[5];  /* per plane bit index: how often each plane was rendered */
    int64_t render_ns_total;
} drv_frames_sim_stats;

drv_frames *drv_frames_sim_create(const drv_frames_sim_params *p);
/* Statistics of a simulated host (the caller reads them after its frames thread stopped). */
void drv_frames_sim_stats_get(drv_frames *fr, drv_frames_sim_stats *st);

#endif

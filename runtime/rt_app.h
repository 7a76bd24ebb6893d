/* SPDX-License-Identifier: MIT */
/* rt_app: one hmdwarpd instance: devices chosen by board.ini, the IMU, frames, compositor and helper threads, and
 * the run summary. hmdwarpd_main parses arguments; tests drive an instance directly. */
#ifndef RT_APP_H
#define RT_APP_H

#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include "drivers/drv_frames.h"
#include "platform/plat_display.h"
#include "runtime/rt_config.h"
#include "runtime/rt_csv.h"
#include "runtime/rt_devices.h"
#include "runtime/rt_frameq.h"
#include "runtime/rt_fusion.h"
#include "runtime/rt_gles.h"
#include "runtime/rt_live.h"
#include "runtime/rt_ring.h"
#include "runtime/rt_select.h"
#include "runtime/rt_telemetry.h"
#include "runtime/rt_render_cpu.h"
#include "warp/warp_head.h"

/* Opaque parts held by pointer: their headers are for the files that call them. */
typedef struct plat_workers plat_workers;
typedef struct rt_pacer rt_pacer;
typedef struct rt_simboard rt_simboard;

/* Older than this, the newest IMU state is not extrapolated: the device is gone or stalled (prediction off). */
#define RT_IMU_STALE_NS (150 * 1000000LL)

typedef struct {
    rt_config cfg;
    int64_t t0_ns;         /* when the display starts (the simulated board's scene time 0) */
    int64_t t_end_ns;      /* 0 = run until stopped */
    _Atomic int stop;

    rt_devices dev;        /* IMU, frames, vsync and display (rt_devices.h) */
    rt_devices_feed feed;  /* what the IMU and frames threads feed (set by rt_app_run) */

    /* tracking and frames */
    rt_fusion *fusion;
    rt_frameq fq;
    warp_head head;

    /* compositor */
    warp_camera eye_cam[2];
    plat_swapchain sc;
    plat_workers *workers;
    plat_workers *prepare_workers; /* the frames thread's: a host frame's eyes prepared in parallel (or NULL) */
    rt_render_cpu *render;      /* the CPU pass: lens meshes (GLES draws through them too), scratch, fallbacks */
    rt_pacer *pacer;            /* when to wake for which vsync, what warps cost, misses (started by the loop) */
    /* set by rt_app_run once the helper thread, which reads them for the live stats, may be running */
    _Atomic bool realtime;      /* compositor got SCHED_FIFO */
    _Atomic bool memory_locked; /* mlockall succeeded */
    /* auto selection (rt_select) and the further depth warps, allocated when the method may use them */
    rt_select sel;
    bool can_transparency, can_objects;
    warp_pose obj_prev[DRV_MAX_OBJECTS], obj_cur[DRV_MAX_OBJECTS], obj_at[DRV_MAX_OBJECTS];
    double obj_prev_t, obj_cur_t;  /* pose times of the two newest frames, seconds on the board clock */
    int obj_n;
    bool obj_two;                  /* two frames' object poses known: extrapolation possible */

    /* renderer ([render] renderer, rt_render_choose) and the GLES path (rt_gles.h) */
    char render_why[256];      /* why this renderer was chosen, for the summary */
    char kernel_why[200];      /* [render] kernel = auto: the measured times it was chosen by (rt_kernel) */
    rt_gles gl;

    /* telemetry */
    rt_telemetry *tel;
    rt_csv csv;                /* [telemetry] csv: rows queued on the vsync path, written by the helper thread */
    rt_live live;              /* the --stats text once a second: live_stats file, STATUS, abort handler */
    int64_t run_start_ns, run_end_ns; /* rt_app_run's start; the compositor's return (0 while running) */

    /* the simulated board (rt_simboard.h): scene, true head motion, host counters, evaluator; NULL unless some
     * device is simulated (rt_devices_simulated), so a real board never loads sim/ */
    rt_simboard *sim;

    pthread_t th_imu, th_frames, th_aux;
    bool th_imu_up, th_frames_up, th_aux_up;
} rt_app;

/* Opens devices and allocates everything the run needs (nothing is allocated after this on the vsync path).
 * On failure returns false with a message naming the key or device in err. */
bool rt_app_init(rt_app *a, const rt_config *cfg, char *err, int errlen);
/* Starts the IMU, frames and helper threads, then runs the compositor on the calling thread until the configured
 * duration elapses or rt_app_request_stop() is called. */
void rt_app_run(rt_app *a);
void rt_app_request_stop(rt_app *a);
/* Prints the run summary (see README "Reading the summary"). */
void rt_app_summary(rt_app *a, FILE *out);
/* The summary as key=value lines, one per counter, for scripts (hardware-in-the-loop scenarios). */
void rt_app_stats_kv(rt_app *a, FILE *out);
/* Whether the run showed at least one host frame. False, with the reason in one line, when it presented no vsync,
 * received no host frame, or rejected every one it received: such a run fails (hmdwarpd exits 1). */
bool rt_app_showed_frames(const rt_app *a, char *why, int whylen);
/* Writes the key=value lines the helper thread last published (at most a second old) to fd with write(2);
 * async-signal-safe, for the abort handler. Returns false when none was published yet. */
bool rt_app_write_last_stats(rt_app *a, int fd);
void rt_app_free(rt_app *a);

#endif

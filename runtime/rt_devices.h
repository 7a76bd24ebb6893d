/* SPDX-License-Identifier: MIT */
/* rt_devices: the devices of a run as one part: the IMU, host-frame and vsync backends board.ini names (real or
 * mock), the display output and the IMU's mounting, opened with one clear error; and the threads that read them. */
#ifndef RT_DEVICES_H
#define RT_DEVICES_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

#include "drivers/drv_frames.h"
#include "drivers/drv_imu.h"
#include "drivers/drv_sim.h"
#include "drivers/drv_vsync.h"
#include "platform/plat_display.h"
#include "platform/plat_kms.h"
#include "runtime/rt_calib.h"
#include "runtime/rt_config.h"
#include "runtime/rt_frameq.h"
#include "runtime/rt_fusion.h"
#include "runtime/rt_telemetry.h"

typedef struct {
    drv_imu *imu;
    drv_frames *frames;
    drv_vsync *vsync;
    plat_display *display;
    plat_kms *kms;         /* the KMS output (owned by display on the CPU path, by egl on GLES), NULL offscreen */
    bool sim_host;         /* frames come straight from the simulated host (its render statistics are known) */
    bool has_truth;        /* the head motion and the scene are simulated: accuracy can be scored */
    bool imu_remap;        /* the IMU calibration ([imu] mount, biases, gravity) changes samples */
    bool framelink;        /* frames is the framelink board side (usb, its mock, socket): decode times known */
    rt_calib_imu imu_cal;  /* raw samples into the head frame */
} rt_devices;

/* Opens the IMU, frames and vsync backends board.ini names; sp describes the simulated host (its head model and
 * t0 too), used by the sim backend and the mocks, and trace the simulated head motion (only read when a device is
 * simulated). A kms vsync source uses d->kms, opened before. Sets has_truth and sim_host. On failure returns false
 * with a message naming the key and device in err; rt_devices_close releases what was opened. */
bool rt_devices_open(rt_devices *d, const rt_config *c, const sim_trace *trace, const drv_frames_sim_params *sp,
                     char *err, int errlen);
/* [imu] mount (or axes), gyro_bias, accel_bias, gravity: how raw samples become the head frame's (rt_calib.h; the
 * mounting is not applied for the simulated IMU, whose samples are the head's, its biases are). */
bool rt_devices_mount(rt_devices *d, const rt_config *c, char *err, int errlen);
/* Whether the configuration has the simulator play a device (a sim backend or a mock device). */
bool rt_devices_simulated(const rt_config *c);
/* Whether every device follows plat_clock's virtual time (HMDWARP_TIME_SLOWDOWN); *real names the first that
 * does not. */
bool rt_devices_on_virtual_time(const rt_config *c, const char **real);
/* The IMU alone (hmdwarpd --calibrate-imu): as rt_devices_open opens it, a simulated one with scene time 0 at t0_ns. */
bool rt_devices_open_imu(rt_devices *d, const rt_config *c, const sim_trace *trace, int64_t t0_ns, char *err,
                         int errlen);
/* Board calibration: one sample into the head frame the tracker works in (when d->imu_remap). */
void rt_devices_remap(const rt_devices *d, drv_imu_sample *s);
/* What the devices' reading threads feed, and how (rt_devices_imu_thread, rt_devices_frames_thread). */
typedef struct {
    rt_devices *dev;
    rt_fusion *fusion;     /* IMU samples, in the head frame */
    rt_frameq *fq;         /* host frames that passed validation and prepare */
    rt_telemetry *tel;
    _Atomic int *stop;     /* the threads return once it is set */
    int rt_priority;       /* the compositor's: the IMU thread runs just below it */
    int64_t t0_ns;         /* scene time origin: a mock host's frames get their scene time from it */
    /* validation and everything derived from a frame, on the frames thread: once per host frame, never per vsync;
     * its eyes as tasks on prepare_workers (NULL: on the frames thread alone) */
    drv_frame_err (*prepare)(rt_frame *slot, plat_workers *w);
    plat_workers *prepare_workers;
} rt_devices_feed;
/* The IMU thread: samples into the tracker; a lost device is logged, counted and retried (the display holds the
 * last orientation meanwhile). arg: an rt_devices_feed. */
void *rt_devices_imu_thread(void *arg);
/* The frames thread: received frames prepared and published, rejected ones counted and logged (the last good
 * frame stays); a host that goes quiet, and when it is back. arg: an rt_devices_feed. */
void *rt_devices_frames_thread(void *arg);
/* Closes every device (the display last but one, the KMS output with it or with EGL); NULLs are skipped. */
void rt_devices_close(rt_devices *d);

#endif

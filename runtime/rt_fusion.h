/* SPDX-License-Identifier: MIT */
/* rt_fusion: orientation tracking from gyro + accelerometer (gyro integration, gyro-bias estimation,
 * accelerometer tilt correction), a timestamped pose history, and prediction to photon time. */
#ifndef RT_FUSION_H
#define RT_FUSION_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

#include "drivers/drv_imu.h"
#include "warp/warp_math.h"

typedef struct {
    double tilt_gain;        /* rad/s of correction per rad of tilt error (complementary filter Kp) */
    double bias_gain;        /* integral gain of the tilt error into the gyro bias (Ki), 1/s */
    double accel_tolerance;  /* trust the accelerometer only while | |a| - g | is below this, m/s^2 */
    double still_gyro;       /* rad/s: below this (after bias) with a steady accelerometer the head counts as still */
    double still_time;       /* seconds of stillness before the gyro mean is learned as bias (all three axes) */
    double max_prediction;   /* seconds: predictions further ahead are clamped (angular velocity only) */
    warp_vec3 lever_arm;     /* head-frame vector from the rotation centre (neck pivot) to the IMU, metres: the
                              * accelerometer's share of the head's rotation (w x (w x r) + a x r) is removed */
    double max_centripetal;  /* m/s^2: no tilt correction while w^2 |r| exceeds this (compensation too uncertain) */
} rt_fusion_params;

/* Defaults: tilt_gain 0.5, bias_gain 0.02, accel_tolerance 1.0, still_gyro 0.05, still_time 0.5,
 * max_prediction 0.1, lever_arm 0 (the IMU at the rotation centre; the runtime sets it from its neck model),
 * max_centripetal 2.0. */
rt_fusion_params rt_fusion_default_params(void);

typedef struct {
    int64_t t_ns;     /* time of the IMU sample this state includes */
    warp_quat q;      /* world_from_head */
    warp_vec3 omega;  /* bias-corrected angular velocity, head frame, rad/s */
    warp_vec3 bias;   /* current gyro bias estimate, rad/s */
} rt_fusion_state;

/* Why a sample was rejected (counted, never fatal: the last good state stays). */
typedef enum {
    RT_FUSION_OK = 0,
    RT_FUSION_BAD_VALUE,    /* NaN/Inf or absurd magnitude in gyro or accel */
    RT_FUSION_TIME_REPEAT,  /* timestamp equal to or before the previous one */
    RT_FUSION_TIME_JUMP,    /* gap larger than 0.25 s: integration restarts from the current state */
    RT_FUSION_ERR_COUNT,
} rt_fusion_result;
const char *rt_fusion_result_str(rt_fusion_result r);

#define RT_FUSION_HISTORY 4096 /* power of two: ~4 s at 1 kHz, like Monado's pose history */

typedef struct {
    _Atomic uint64_t seq; /* odd while being written: per-entry seqlock, readers retry, never block the writer */
    rt_fusion_state st;
} rt_fusion_slot;

/* One writer thread calls rt_fusion_update; any number of readers call the const functions concurrently,
 * lock-free (readers never block the writer, and never wait on it). */
typedef struct {
    rt_fusion_params p;
    /* writer-only state */
    rt_fusion_state cur;
    bool have_sample;
    bool bias_known;         /* a stillness period has measured the gyro bias at least once */
    double still_for;        /* seconds the head has been still */
    warp_vec3 still_mean;    /* running mean of raw gyro while still */
    warp_vec3 alpha;         /* low-passed angular acceleration, head frame, rad/s^2 */
    double still_n;
    _Atomic uint64_t rejected[RT_FUSION_ERR_COUNT];
    /* published history */
    _Atomic uint64_t head; /* number of states published; newest is at (head - 1) & (RT_FUSION_HISTORY - 1) */
    rt_fusion_slot hist[RT_FUSION_HISTORY];
} rt_fusion;

void rt_fusion_init(rt_fusion *f, const rt_fusion_params *p);
/* Feeds one sample (writer thread only). The first valid sample sets the tilt from gravity, with yaw 0. */
rt_fusion_result rt_fusion_update(rt_fusion *f, const drv_imu_sample *s);
/* Newest state; false before the first sample. */
bool rt_fusion_latest(const rt_fusion *f, rt_fusion_state *out);
/* Orientation at t_ns from a state, extrapolating with its angular velocity (clamped to max_prediction). */
warp_quat rt_fusion_predict(const rt_fusion *f, const rt_fusion_state *st, int64_t t_ns);
/* Orientation at t_ns from the history: slerp between the two states around t_ns, prediction past the newest,
 * the oldest kept state before that. False before the first sample. */
bool rt_fusion_at(const rt_fusion *f, int64_t t_ns, warp_quat *out);
uint64_t rt_fusion_rejected(const rt_fusion *f, rt_fusion_result why);

#endif

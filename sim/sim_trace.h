/* SPDX-License-Identifier: MIT */
/* sim_trace: head-motion traces as smooth functions of time (ground truth for the simulator), and the IMU
 * samples (gyro, accelerometer with noise and bias) a head-mounted IMU would report along them. */
#ifndef SIM_TRACE_H
#define SIM_TRACE_H

#include <stdbool.h>
#include <stdint.h>

#include "warp/warp_head.h"
#include "warp/warp_math.h"

typedef enum {
    SIM_TRACE_STILL,     /* "still": head at rest, looking ahead */
    SIM_TRACE_SLOW,      /* "slow": slow look-around, tens of degrees at < 60 deg/s */
    SIM_TRACE_FAST,      /* "fast": rest with 300 deg/s yaw/pitch bursts */
    SIM_TRACE_TRANSLATE, /* "translate": nods and turns whose neck-model translation moves the eyes by centimetres */
    SIM_TRACE_JITTER,    /* "jitter": recorded-style small tremor and drift around a fixed gaze */
} sim_trace_kind;

typedef struct {
    sim_trace_kind kind;
    uint64_t seed;  /* varies the random parts (jitter, burst timing) deterministically */
    warp_head head; /* neck model and IPD used to turn orientation into head and eye poses */
} sim_trace;

/* false for an unknown name; names are those in sim_trace_names(). */
bool sim_trace_init(sim_trace *tr, const char *name, uint64_t seed);
const char *const *sim_trace_names(void); /* NULL-terminated */
const char *sim_trace_name(const sim_trace *tr);

/* True head orientation (world_from_head) at time t seconds. For t < 0 the head rests at its t = 0 orientation. */
warp_quat sim_trace_orientation(const sim_trace *tr, double t);
/* Head pose through the trace's neck model (warp_head_pose_from_orientation). */
warp_pose sim_trace_head_pose(const sim_trace *tr, double t);
/* Angular velocity in the head frame (what an ideal gyro reads), rad/s. */
warp_vec3 sim_trace_angular_velocity(const sim_trace *tr, double t);
/* Peak angular speed over [0, duration] in rad/s (sampled), for reports. */
double sim_trace_peak_speed(const sim_trace *tr, double duration);

typedef struct {
    double rate_hz;        /* samples per second (1000) */
    double gyro_noise;     /* white noise, rad/s rms per sample */
    warp_vec3 gyro_bias;   /* constant bias, rad/s */
    double accel_noise;    /* m/s^2 rms per sample */
    warp_vec3 accel_bias;  /* m/s^2 */
    uint64_t seed;
    double t_start;        /* time of sample 0, seconds; negative: the IMU runs while the head still rests */
} sim_imu_params;

/* Defaults: 1 kHz, gyro noise 0.005 rad/s, gyro bias (0.01, -0.007, 0.004) rad/s, accel noise 0.05 m/s^2. */
sim_imu_params sim_imu_default_params(void);

typedef struct {
    double t;          /* seconds */
    warp_vec3 gyro;    /* head frame, rad/s */
    warp_vec3 accel;   /* head frame specific force, m/s^2: reads (0, +9.81, 0) when upright and at rest */
} sim_imu_sample;

/* Sample number `index` (t = t_start + index / rate_hz). Stateless and deterministic: noise comes from a counter-based
 * generator keyed by (seed, index), so any thread can produce any sample. */
void sim_imu_sample_at(const sim_trace *tr, const sim_imu_params *p, uint64_t index, sim_imu_sample *out);

#endif

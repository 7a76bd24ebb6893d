/* SPDX-License-Identifier: MIT */
/* rt_calib: the board's calibration kept apart from its configuration: the calibration file (board.ini's [lens] and
 * [imu] calibration keys, read after it), the IMU mounting as any rotation with its biases, and --calibrate-imu. */
#ifndef RT_CALIB_H
#define RT_CALIB_H

#include <stdbool.h>
#include <stdio.h>

#include "drivers/drv_imu.h"
#include "runtime/rt_config.h"

/* What an accelerometer reads at rest once calibrated (rt_fusion's RT_FUSION_G). */
#define RT_CALIB_G 9.81

/* --calibrate-imu's test of "at rest": a held or lying headset's gyro wobbles far less than this (MEMS noise is
 * ~0.005 rad/s rms at 1 kHz), and a hand-held one moves its accelerometer's reading by more than the second. */
#define RT_CALIB_REST_GYRO_SD 0.02  /* rad/s, per axis, standard deviation over the measurement */
#define RT_CALIB_REST_ACCEL_SD 0.3  /* m/s^2, per axis */
#define RT_CALIB_MIN_SAMPLES 100    /* fewer cannot say whether the headset was still */

/* The IMU's calibration as applied to every sample before fusion: raw (IMU axes) to head frame. */
typedef struct {
    double m[3][3];         /* head_from_imu: head vector = m * IMU vector */
    double gyro_bias[3];    /* IMU axes, rad/s */
    double accel_bias[3];   /* IMU axes, m/s^2 */
    double accel_scale;     /* RT_CALIB_G / [imu] gravity */
    bool identity;          /* applying it changes nothing */
} rt_calib_imu;

/* Parses an [imu] mount: signed axes ("-y +x +z", head axis i = sign * IMU axis), "quat W X Y Z" (the IMU's
 * orientation in the head frame, unit to 1e-3; normalised) or "rpy ROLL PITCH YAW" (degrees: m = Ry(yaw) Rx(pitch)
 * Rz(roll), the IMU turned from the head's axes by yaw about +y, pitch about the turned x, roll about the turned z).
 * False with the reason in err. */
bool rt_calib_parse_mount(const char *s, double m[3][3], char *err, int errlen);
/* The calibration [imu] holds: mount (or axes when mount is empty) unless use_mount is false (the simulated IMU
 * reports head-frame samples: there is nothing to turn), gyro_bias, accel_bias, gravity. */
bool rt_calib_imu_from_config(const rt_config *c, bool use_mount, rt_calib_imu *out, char *err, int errlen);
/* One sample into the head frame, biases off and gravity to RT_CALIB_G. No allocation, no I/O (IMU thread). */
void rt_calib_imu_apply(const rt_calib_imu *k, drv_imu_sample *s);

/* Reads c->calibration after board.ini and before the command line's --set. What happened goes to `what` (for
 * --check-config and the start-up log): "" in calibration = none; the default path missing is fine (nothing read);
 * any other missing path (unless may_be_missing: --calibrate-imu creates it), and every bad line (path:line), is an
 * error in err. False on an error. */
bool rt_calib_load(rt_config *c, bool may_be_missing, rt_config_errors *err, char *what, int whatlen);

/* --calibrate-imu's measurement over samples taken at rest, in IMU axes (before rt_calib_imu_apply). */
typedef struct {
    int n;
    double seconds;          /* first to last sample */
    double gyro_mean[3], gyro_sd[3];
    double accel_mean[3], accel_sd[3];
    double gravity;          /* |accel mean - accel_bias|: the [imu] gravity to write */
    double tilt_deg;         /* the headset's tilt from upright as it lay: head +y against the mounted gravity */
    bool at_rest;
    char why[240];           /* why it was not at rest (or too short); "" when at rest */
} rt_calib_rest;
/* k supplies the mounting (for the tilt) and the accelerometer bias; its gyro bias is not used (measured here). */
void rt_calib_measure(const drv_imu_sample *s, int n, const rt_calib_imu *k, rt_calib_rest *out);

/* Sets [section] key = value for each of the n keys in INI text, keeping every other line and comment: a key
 * present is replaced in place, a missing one goes after the section's last line, a missing section at the end.
 * old may be NULL (a new file: a comment saying what the file is comes first). Returns malloc'd text or NULL. */
char *rt_calib_update_text(const char *old, const char *section, const char *const *keys, const char *const *values,
                           int n);
/* The atomic update, in two steps so that a test can stop between them: _prepare writes the updated file as
 * PATH.tmp.XXXXXX beside it (the old file's mode and owner; a new one gets the directory's owner, so the service
 * user keeps it when root ran --calibrate-imu), fsynced; _commit renames it over PATH and syncs the directory. A
 * process that dies in between leaves PATH as it was. */
bool rt_calib_write_prepare(const char *path, const char *section, const char *const *keys,
                            const char *const *values, int n, char *tmp, int tmplen, char *err, int errlen);
bool rt_calib_write_commit(const char *tmp, const char *path, char *err, int errlen);

/* A board's first start: when path does not exist but its directory does (systemd made the state directory), the
 * file is created holding only a comment on what it is for, so that there is one to find and edit. 1 created, 0
 * nothing to do (there is one, or no directory), -1 on an error (in err). */
int rt_calib_create_empty(const char *path, char *err, int errlen);

/* hmdwarpd --calibrate-imu: opens the configured IMU, measures for `seconds` at rest, reports on out, and writes
 * [imu] gyro_bias and gravity to c->calibration. Returns the exit status (0 written, 1 refused or failed). */
int rt_calib_imu_run(const rt_config *c, double seconds, FILE *out);

#endif

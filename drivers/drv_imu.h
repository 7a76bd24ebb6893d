/* SPDX-License-Identifier: MIT */
/* drv_imu: the interface every IMU backend implements (sim, USB HID, I2C), Monado-style: a struct of function
 * pointers plus static inline wrappers. Samples arrive already mapped to CLOCK_MONOTONIC and SI units. */
#ifndef DRV_IMU_H
#define DRV_IMU_H

#include <stdbool.h>
#include <stdint.h>

typedef struct {
    int64_t t_ns;     /* CLOCK_MONOTONIC time the sample was taken */
    double gyro[3];   /* head frame, rad/s */
    double accel[3];  /* head frame specific force, m/s^2 ((0, +9.81, 0) upright at rest) */
} drv_imu_sample;

/* What a backend has seen so far (optional; read by the summary and telemetry, may be slightly stale). */
typedef struct {
    uint64_t reports;      /* reports / register bursts read from the device */
    uint64_t bad_reports;  /* rejected while decoding: wrong report id or length, implausible values */
    uint64_t read_errors;  /* transport errors (I/O, timeouts that should not happen) */
    uint64_t reconnects;   /* times the device was lost and found again */
    bool connected;
    char last_error[160];  /* the latest problem, naming the device and what was wrong; "" if none */
} drv_imu_stats;

typedef struct drv_imu drv_imu;
struct drv_imu {
    const char *name;
    /* Waits up to timeout_ms for samples; returns how many were stored (0 on timeout), or a negative errno when the
     * device is gone (the caller keeps the last orientation and retries). */
    int (*read)(drv_imu *imu, drv_imu_sample *out, int max, int timeout_ms);
    /* Optional (NULL: no statistics). Safe to call from another thread than read(). */
    void (*stats)(drv_imu *imu, drv_imu_stats *out);
    void (*destroy)(drv_imu *imu);
};

static inline int drv_imu_read(drv_imu *imu, drv_imu_sample *out, int max, int timeout_ms)
{
    return imu->read(imu, out, max, timeout_ms);
}
/* False when the backend keeps no statistics (*out is zeroed then). */
static inline bool drv_imu_stats_get(drv_imu *imu, drv_imu_stats *out)
{
    *out = (drv_imu_stats){0};
    if (!imu->stats) return false;
    imu->stats(imu, out);
    return true;
}
static inline void drv_imu_destroy(drv_imu *imu)
{
    if (imu) imu->destroy(imu);
}

#endif

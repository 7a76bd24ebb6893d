/* drv_imu: the interface every IMU backend implements (sim, USB HID, I2C), Monado-style: a struct of function
 * pointers plus static inline wrappers. Samples arrive already mapped to CLOCK_MONOTONIC and SI units. */
#ifndef DRV_IMU_H
#define DRV_IMU_H

#include <stdint.h>

typedef struct {
    int64_t t_ns;     /* CLOCK_MONOTONIC time the sample was taken */
    double gyro[3];   /* head frame, rad/s */
    double accel[3];  /* head frame specific force, m/s^2 ((0, +9.81, 0) upright at rest) */
} drv_imu_sample;

typedef struct drv_imu drv_imu;
struct drv_imu {
    const char *name;
    /* Waits up to timeout_ms for samples; returns how many were stored (0 on timeout), or a negative errno when the
     * device is gone (the caller keeps the last orientation and retries). */
    int (*read)(drv_imu *imu, drv_imu_sample *out, int max, int timeout_ms);
    void (*destroy)(drv_imu *imu);
};

static inline int drv_imu_read(drv_imu *imu, drv_imu_sample *out, int max, int timeout_ms)
{
    return imu->read(imu, out, max, timeout_ms);
}
static inline void drv_imu_destroy(drv_imu *imu)
{
    if (imu) imu->destroy(imu);
}

#endif

/* SPDX-License-Identifier: MIT */
/* drv_imu_i2c: the drv_imu backend for IMUs on an I2C bus (Linux i2c-dev + libi2c SMBus), polled at the sample
 * rate; its mock bus is in drv_imu_i2c_mock.h. */
#ifndef DRV_IMU_I2C_H
#define DRV_IMU_I2C_H

#include <stdbool.h>
#include <stdint.h>

#include "drivers/drv_i2c_chips.h"
#include "drivers/drv_imu.h"

typedef struct {
    char bus[128]; /* "/dev/i2c-1" (as long as [imu] device) */
    int addr;      /* 7-bit address, 0x68 (AD0 low) or 0x69 */
    char chip[16]; /* auto|mpu6050|mpu9250|icm42688 */
    double rate_hz;
    int gyro_dps;  /* full scale, e.g. 2000 */
    int accel_g;   /* full scale, e.g. 16 */
} drv_imu_i2c_params;

/* Opens the bus, identifies and initialises the chip. NULL and a message naming the bus, the address and what was
 * wrong (no such bus, no ACK, WHO_AM_I 0x12 is not an MPU-6050, ...). Samples are in the chip's axis frame. */
drv_imu *drv_imu_i2c_create(const drv_imu_i2c_params *p, char *err, int errlen);

/* The backend on any bus (owned from here on, destroyed with the result, also on failure); p->bus and p->addr only
 * name it. */
drv_imu *drv_imu_i2c_create_on_bus(drv_i2c_bus *bus, const drv_imu_i2c_params *p, char *err, int errlen);

/* What an I2C IMU was identified as and set to; NULL for another backend. */
const drv_i2c_chip *drv_imu_i2c_chip(drv_imu *imu);
const drv_i2c_setup *drv_imu_i2c_setup(drv_imu *imu);
/* The bus an I2C IMU reads through (still owned by it); NULL for another backend. */
drv_i2c_bus *drv_imu_i2c_bus(drv_imu *imu);

/* ---- the real bus: /dev/i2c-N ---- */

/* Opens `path`, selects `addr` (I2C_SLAVE) and checks the adapter (I2C_FUNCS): SMBus I2C-block reads and SMBus
 * byte writes, or plain I2C (I2C_RDWR) where those are missing. NULL and a message on failure. */
drv_i2c_bus *drv_i2c_dev_create(const char *path, int addr, char *err, int errlen);

#endif

/* SPDX-License-Identifier: MIT */
/* drv_imu_i2c: the drv_imu backend for IMUs on an I2C bus (Linux i2c-dev + libi2c SMBus), polled at the sample rate,
 * plus a mock bus that emulates the chip's register file from another drv_imu so the real chip driver runs unchanged. */
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

/* The chip emulated from `source` (owned from here on, destroyed with the result, also on failure): p->chip picks
 * the chip ("auto": MPU-6050), p->bus only names it. */
drv_imu *drv_imu_i2c_create_mock(drv_imu *source, const drv_imu_i2c_params *p, char *err, int errlen);

/* The backend on any bus (owned from here on, destroyed with the result, also on failure); p->bus and p->addr only
 * name it. */
drv_imu *drv_imu_i2c_create_on_bus(drv_i2c_bus *bus, const drv_imu_i2c_params *p, char *err, int errlen);

/* What an I2C IMU was identified as and set to; NULL for another backend. */
const drv_i2c_chip *drv_imu_i2c_chip(drv_imu *imu);
const drv_i2c_setup *drv_imu_i2c_setup(drv_imu *imu);

/* ---- the real bus: /dev/i2c-N ---- */

/* Opens `path`, selects `addr` (I2C_SLAVE) and checks the adapter (I2C_FUNCS): SMBus I2C-block reads and SMBus
 * byte writes, or plain I2C (I2C_RDWR) where those are missing. NULL and a message on failure. */
drv_i2c_bus *drv_i2c_dev_open(const char *path, int addr, char *err, int errlen);

/* ---- the mock bus: a chip's register file ---- */

typedef struct {
    bool write;
    uint8_t reg;
    uint8_t val; /* value written, or number of bytes read */
} drv_i2c_mock_op;

#define DRV_I2C_MOCK_LOG 512

typedef struct drv_i2c_mockbus {
    drv_i2c_bus bus;          /* its interface (pass &m->bus) */
    drv_i2c_chip_kind model;  /* the chip emulated */
    char name[160];
    uint8_t reg[256];         /* register file (bank 0); tests may preload it */
    /* every transfer in order (the first DRV_I2C_MOCK_LOG; n_log keeps counting) */
    drv_i2c_mock_op log[DRV_I2C_MOCK_LOG];
    int n_log;
    /* failure injection */
    bool absent;     /* NACK every transfer (-ENXIO), as an unplugged chip */
    int fail_next;   /* NACK (-EREMOTEIO) this many coming transfers */
    int who_am_i;    /* >= 0: WHO_AM_I reads this instead (survives resets) */
    /* counters */
    uint64_t transfers, resets, reopens, samples_in;
    /* the emulated sensor */
    drv_imu *source;  /* owned; NULL: data registers keep what tests preload */
    drv_imu_sample latest;
    bool have_sample;
} drv_i2c_mockbus;

/* A chip in its power-on state at `addr` fed by `source` (owned, may be NULL). NULL for AUTO or no memory. */
drv_i2c_mockbus *drv_i2c_mockbus_create(drv_i2c_chip_kind model, int addr, drv_imu *source);
/* The mock bus under a drv_imu_i2c_create_mock() device (still owned by it), else NULL. */
drv_i2c_mockbus *drv_imu_i2c_mockbus(drv_imu *imu);
/* Puts the chip's data-ready flag up (for tests that preload the data registers by hand). */
void drv_i2c_mockbus_set_ready(drv_i2c_mockbus *m);
/* The idx-th logged write (0-based): 0 and *reg, *val, or -1 when there are fewer writes. */
int drv_i2c_mockbus_write_at(const drv_i2c_mockbus *m, int idx, uint8_t *reg, uint8_t *val);

#endif

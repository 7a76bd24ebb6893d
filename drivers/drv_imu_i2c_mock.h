/* SPDX-License-Identifier: MIT */
/* drv_imu_i2c_mock: a mock I2C bus with one IMU chip on it (drv_i2c_chip_emu's register file fed by another drv_imu),
 * transfers logged and failures injectable, so the real chip driver of drv_imu_i2c runs unchanged in tests. */
#ifndef DRV_IMU_I2C_MOCK_H
#define DRV_IMU_I2C_MOCK_H

#include <stdbool.h>
#include <stdint.h>

#include "drivers/drv_imu_i2c.h"

/* The chip emulated from `source` (owned from here on, destroyed with the result, also on failure): p->chip picks
 * the chip ("auto": MPU-6050), p->bus only names it. */
drv_imu *drv_imu_i2c_create_mock(drv_imu *source, const drv_imu_i2c_params *p, char *err, int errlen);

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

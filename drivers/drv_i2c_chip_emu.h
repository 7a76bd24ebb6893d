/* SPDX-License-Identifier: MIT */
/* drv_i2c_chip_emu: the one emulation of the IMU chips' register files (MPU-6050, MPU-9250, ICM-42688-P), pure:
 * reset images, what the configuration registers select, and the data block a sample fills. The driver's mock bus
 * and the HIL chip feeder (tests/hil/src/hil_i2c_chip.c) both use it. */
#ifndef DRV_I2C_CHIP_EMU_H
#define DRV_I2C_CHIP_EMU_H

#include <stdbool.h>
#include <stdint.h>

#include "drivers/drv_i2c_chips.h"

/* The data registers, one block so a reader never sees half a sample: MPU 0x3A INT_STATUS .. 0x48 GYRO_ZOUT_L;
 * ICM bank 0 0x1D TEMP_DATA1 .. 0x2D INT_STATUS (TMST_FSYNC 0x2B-0x2C in between). */
#define DRV_I2C_EMU_MPU_DATA_LO MPU_REG_INT_STATUS
#define DRV_I2C_EMU_MPU_DATA_HI MPU_REG_GYRO_ZOUT_L
#define DRV_I2C_EMU_ICM_DATA_LO ICM_REG_TEMP_DATA1
#define DRV_I2C_EMU_ICM_DATA_HI ICM_REG_INT_STATUS
#define DRV_I2C_EMU_DATA_MAX 17
#define DRV_I2C_EMU_ICM_ENDIAN 0x10 /* INTF_CONFIG0 SENSOR_DATA_ENDIAN: 1 big-endian (reset), 0 little */

/* What the configuration registers select. */
typedef struct {
    double rate_hz;               /* output data rate */
    double gyro_lsb, accel_lsb;   /* LSB per deg/s, per g */
    double gyro_fs_dps, accel_fs_g;
    bool gyro_on, accel_on;       /* MPU: both follow SLEEP */
    bool big_endian;
    int bank;                     /* ICM REG_BANK_SEL (banks 1-4 are not emulated); 0 on the MPUs */
} drv_i2c_emu_config;

/* True for the MPU-6050/9250 register family, false for the ICM-42688-P. */
bool drv_i2c_emu_is_mpu(drv_i2c_chip_kind kind);
/* The register file after power-on or a soft reset (bank 0). */
void drv_i2c_emu_reset_image(drv_i2c_chip_kind kind, uint8_t reg[256]);
/* Decodes the configuration the driver wrote into reg. */
drv_i2c_emu_config drv_i2c_emu_config_get(drv_i2c_chip_kind kind, const uint8_t reg[256]);
/* The first data register and the block's length (see the _DATA_ defines). */
int drv_i2c_emu_data_range(drv_i2c_chip_kind kind, int *lo);
/* Fills the data block (drv_i2c_emu_data_range bytes) for one sample (rad/s, m/s^2) at temp_c, as the ADC would at
 * the configured ranges and byte order, with the status register's data-ready bit raised (MPU: only when
 * INT_ENABLE asks for it). False (block untouched) when the chip produces no data: asleep, or both sensors off. */
bool drv_i2c_emu_data_block(drv_i2c_chip_kind kind, const uint8_t reg[256], const double gyro[3],
                            const double accel[3], double temp_c, uint8_t *blk);

#endif

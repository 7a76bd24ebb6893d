/* SPDX-License-Identifier: MIT */
/* drv_i2c_chip_emu: the IMU chips' register files as the datasheets describe them, apart from the driver's
 * drv_i2c_chips.c (own field decoding and tables): a driver writing a wrong range code reads wrongly scaled data. */
#include "drivers/drv_i2c_chip_emu.h"

#include <math.h>
#include <string.h>

/* MPU-6000/6050 and MPU-9250 register maps (FS_SEL / AFS_SEL [4:3]): 131, 65.5, 32.8, 16.4 LSB/(deg/s) for +-250 ..
 * 2000 deg/s; 16384 .. 2048 LSB/g for +-2 .. 16 g. */
static const double mpu_gyro_lsb[4] = {131.0, 65.5, 32.8, 16.4};
static const double mpu_gyro_fs[4] = {250, 500, 1000, 2000};
static const double mpu_accel_lsb[4] = {16384, 8192, 4096, 2048};
static const double mpu_accel_fs[4] = {2, 4, 8, 16};
/* ICM-42688-P (DS-000347 GYRO_CONFIG0 / ACCEL_CONFIG0 [7:5]): the gyro uses all eight codes, +-2000 .. 15.625 deg/s;
 * the accelerometer only codes 0-3, +-16 .. 2 g, codes 4-7 being reserved (read as code 0, +-16 g). The HIL
 * feeder's four-entry table and the mock's eight-entry one (reserved codes padded with 2048) gave the same values;
 * this is the datasheet's four plus that rule. */
static const double icm_gyro_lsb[8] = {16.4, 32.8, 65.5, 131.0, 262.0, 524.3, 1048.6, 2097.2};
static const double icm_gyro_fs[8] = {2000, 1000, 500, 250, 125, 62.5, 31.25, 15.625};
static const double icm_accel_lsb[4] = {2048, 4096, 8192, 16384};
static const double icm_accel_fs[4] = {16, 8, 4, 2};
/* ICM-42688-P ODR codes 0..15 (GYRO_CONFIG0 [3:0]) in Hz, 0 = reserved. */
static const double icm_odr_hz[16] = {0, 32000, 16000, 8000, 4000, 2000, 1000, 200, 100, 50, 25, 12.5,
                                      6.25, 3.125, 1.5625, 500};

bool drv_i2c_emu_is_mpu(drv_i2c_chip_kind kind) { return kind != DRV_I2C_CHIP_ICM42688; }

void drv_i2c_emu_reset_image(drv_i2c_chip_kind kind, uint8_t reg[256])
{
    memset(reg, 0, 256);
    switch (kind) {
    case DRV_I2C_CHIP_MPU6050:
        reg[MPU_REG_PWR_MGMT_1] = MPU6050_PWR1_RESET_VALUE;
        reg[MPU_REG_WHO_AM_I] = MPU6050_WHO_AM_I;
        break;
    case DRV_I2C_CHIP_MPU9250:
        reg[MPU_REG_PWR_MGMT_1] = MPU9250_PWR1_RESET_VALUE;
        reg[MPU_REG_WHO_AM_I] = MPU9250_WHO_AM_I;
        break;
    default: /* ICM-42688-P bank 0 reset values (DS-000347 register map) */
        reg[ICM_REG_INT_STATUS] = ICM_INT_STATUS_RESET_DONE;
        reg[ICM_REG_INTF_CONFIG0] = 0x30;
        reg[ICM_REG_GYRO_CONFIG0] = 0x06;
        reg[ICM_REG_ACCEL_CONFIG0] = 0x06;
        reg[0x51] = 0x16; /* GYRO_CONFIG1 */
        reg[ICM_REG_GYRO_ACCEL_CONFIG0] = 0x11;
        reg[0x53] = 0x0D; /* ACCEL_CONFIG1 */
        reg[0x64] = 0x10; /* INT_CONFIG1 */
        reg[ICM_REG_INT_SOURCE0] = ICM_INT_SOURCE0_RESET_DONE_INT1_EN;
        reg[ICM_REG_WHO_AM_I] = ICM42688_WHO_AM_I;
        for (int r = ICM_REG_TEMP_DATA1; r <= ICM_REG_GYRO_DATA_Z0; r += 2) reg[r] = 0x80; /* -32768: no data */
        break;
    }
}

drv_i2c_emu_config drv_i2c_emu_config_get(drv_i2c_chip_kind kind, const uint8_t reg[256])
{
    drv_i2c_emu_config c = {.big_endian = true};
    if (drv_i2c_emu_is_mpu(kind)) {
        int dlpf = reg[MPU_REG_CONFIG] & 7;
        c.rate_hz = (dlpf == 0 || dlpf == 7 ? 8000.0 : 1000.0) / (1 + reg[MPU_REG_SMPLRT_DIV]);
        int g = (reg[MPU_REG_GYRO_CONFIG] >> 3) & 3, a = (reg[MPU_REG_ACCEL_CONFIG] >> 3) & 3;
        c.gyro_lsb = mpu_gyro_lsb[g], c.gyro_fs_dps = mpu_gyro_fs[g];
        c.accel_lsb = mpu_accel_lsb[a], c.accel_fs_g = mpu_accel_fs[a];
        c.gyro_on = c.accel_on = !(reg[MPU_REG_PWR_MGMT_1] & MPU_PWR1_SLEEP);
    } else {
        double odr = icm_odr_hz[reg[ICM_REG_GYRO_CONFIG0] & 15];
        c.rate_hz = odr > 0 ? odr : 1000;
        int g = (reg[ICM_REG_GYRO_CONFIG0] >> 5) & 7, a = (reg[ICM_REG_ACCEL_CONFIG0] >> 5) & 7;
        if (a > 3) a = 0; /* reserved codes */
        c.gyro_lsb = icm_gyro_lsb[g], c.gyro_fs_dps = icm_gyro_fs[g];
        c.accel_lsb = icm_accel_lsb[a], c.accel_fs_g = icm_accel_fs[a];
        uint8_t pw = reg[ICM_REG_PWR_MGMT0];
        c.gyro_on = ((pw >> 2) & 3) == 3;
        c.accel_on = (pw & 3) >= 2;
        c.big_endian = reg[ICM_REG_INTF_CONFIG0] & DRV_I2C_EMU_ICM_ENDIAN;
        c.bank = reg[ICM_REG_BANK_SEL] & 7;
    }
    return c;
}

int drv_i2c_emu_data_range(drv_i2c_chip_kind kind, int *lo)
{
    if (drv_i2c_emu_is_mpu(kind)) {
        *lo = DRV_I2C_EMU_MPU_DATA_LO;
        return DRV_I2C_EMU_MPU_DATA_HI - DRV_I2C_EMU_MPU_DATA_LO + 1;
    }
    *lo = DRV_I2C_EMU_ICM_DATA_LO;
    return DRV_I2C_EMU_ICM_DATA_HI - DRV_I2C_EMU_ICM_DATA_LO + 1;
}

/* A 16-bit reading saturated at [lo, 32767]: the ICM's -32768 means "no data", so its readings stop at -32767. */
static void put16(uint8_t *p, double v, int lo, bool big_endian)
{
    double r = isfinite(v) ? nearbyint(v) : 0;
    int16_t s = (int16_t)(r > 32767 ? 32767 : r < lo ? lo : r);
    uint16_t u = (uint16_t)s;
    p[big_endian ? 0 : 1] = (uint8_t)(u >> 8);
    p[big_endian ? 1 : 0] = (uint8_t)(u & 0xff);
}

bool drv_i2c_emu_data_block(drv_i2c_chip_kind kind, const uint8_t reg[256], const double gyro[3],
                            const double accel[3], double temp_c, uint8_t *blk)
{
    const double rad2deg = 180.0 / 3.14159265358979323846;
    drv_i2c_emu_config c = drv_i2c_emu_config_get(kind, reg);
    if (!c.gyro_on && !c.accel_on) return false;
    if (drv_i2c_emu_is_mpu(kind)) {
        blk[0] = (reg[MPU_REG_INT_ENABLE] & MPU_INT_DATA_RDY_EN) ? MPU_INT_STATUS_DATA_RDY : 0;
        uint8_t *d = blk + 1; /* ACCEL_XOUT_H */
        for (int i = 0; i < 3; i++) {
            put16(d + 2 * i, accel[i] / DRV_I2C_G * c.accel_lsb, -32768, true);
            put16(d + 8 + 2 * i, gyro[i] * rad2deg * c.gyro_lsb, -32768, true);
        }
        /* MPU-6050: T = raw / 340 + 36.53; MPU-9250: T = raw / 333.87 + 21 */
        double t = kind == DRV_I2C_CHIP_MPU6050 ? (temp_c - 36.53) * 340.0 : (temp_c - 21.0) * 333.87;
        put16(d + 6, t, -32768, true);
    } else {
        int n = DRV_I2C_EMU_ICM_DATA_HI - DRV_I2C_EMU_ICM_DATA_LO + 1;
        memset(blk, 0, (size_t)n);
        put16(blk, (temp_c - 25.0) * 132.48, -32768, c.big_endian); /* T = raw / 132.48 + 25 */
        for (int i = 0; i < 3; i++) {
            put16(blk + 2 + 2 * i, c.accel_on ? accel[i] / DRV_I2C_G * c.accel_lsb : -32768,
                  c.accel_on ? -32767 : -32768, c.big_endian);
            put16(blk + 8 + 2 * i, c.gyro_on ? gyro[i] * rad2deg * c.gyro_lsb : -32768, c.gyro_on ? -32767 : -32768,
                  c.big_endian);
        }
        blk[n - 1] = ICM_INT_STATUS_DATA_RDY;
    }
    return true;
}

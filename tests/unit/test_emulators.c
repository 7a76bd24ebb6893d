/* SPDX-License-Identifier: MIT */
/* Unit tests for the device emulators the mocks and the HIL programs share: drv_i2c_chip_emu (reset images, every
 * range code against the datasheets, the data block's scaling, byte order and no-data marks) and drv_te_schedule
 * (random access, jitter bounds, losses, glitches, dropout, phase jump, and the HIL player's former pulse times). */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "drivers/drv_i2c_chip_emu.h"
#include "drivers/drv_te_schedule.h"

#define DEG (3.14159265358979323846 / 180.0)

static int16_t be16(const uint8_t *p) { return (int16_t)(uint16_t)((p[0] << 8) | p[1]); }
static int16_t le16(const uint8_t *p) { return (int16_t)(uint16_t)((p[1] << 8) | p[0]); }

static void test_reset_images(void **state)
{
    (void)state;
    uint8_t r[256];
    drv_i2c_emu_reset_image(DRV_I2C_CHIP_MPU6050, r);
    assert_int_equal(r[MPU_REG_WHO_AM_I], 0x68);
    assert_int_equal(r[MPU_REG_PWR_MGMT_1], 0x40); /* asleep after reset */
    drv_i2c_emu_reset_image(DRV_I2C_CHIP_MPU9250, r);
    assert_int_equal(r[MPU_REG_WHO_AM_I], 0x71);
    assert_int_equal(r[MPU_REG_PWR_MGMT_1], 0x01);
    drv_i2c_emu_reset_image(DRV_I2C_CHIP_ICM42688, r);
    assert_int_equal(r[ICM_REG_WHO_AM_I], 0x47);
    assert_int_equal(r[ICM_REG_INT_STATUS], ICM_INT_STATUS_RESET_DONE);
    assert_int_equal(be16(&r[ICM_REG_GYRO_DATA_X1]), -32768); /* no data yet */
    assert_true(drv_i2c_emu_is_mpu(DRV_I2C_CHIP_MPU9250));
    assert_false(drv_i2c_emu_is_mpu(DRV_I2C_CHIP_ICM42688));
}

/* Every range code: sensitivity x full scale is the 16-bit span (32768 counts, within the datasheets' rounding). */
static void test_range_codes(void **state)
{
    (void)state;
    uint8_t r[256];
    drv_i2c_emu_reset_image(DRV_I2C_CHIP_MPU6050, r);
    static const double mpu_dps[4] = {250, 500, 1000, 2000}, mpu_g[4] = {2, 4, 8, 16};
    for (int code = 0; code < 4; code++) {
        r[MPU_REG_GYRO_CONFIG] = (uint8_t)(code << 3);
        r[MPU_REG_ACCEL_CONFIG] = (uint8_t)(code << 3);
        drv_i2c_emu_config c = drv_i2c_emu_config_get(DRV_I2C_CHIP_MPU6050, r);
        assert_true(c.gyro_fs_dps == mpu_dps[code] && c.accel_fs_g == mpu_g[code]);
        assert_true(fabs(c.gyro_lsb * c.gyro_fs_dps / 32768 - 1) < 0.002);
        assert_true(fabs(c.accel_lsb * c.accel_fs_g / 32768 - 1) < 1e-9);
    }
    drv_i2c_emu_reset_image(DRV_I2C_CHIP_ICM42688, r);
    static const double icm_dps[8] = {2000, 1000, 500, 250, 125, 62.5, 31.25, 15.625};
    static const double icm_g[8] = {16, 8, 4, 2, 16, 16, 16, 16}; /* codes 4-7 reserved: +-16 g */
    for (int code = 0; code < 8; code++) {
        r[ICM_REG_GYRO_CONFIG0] = (uint8_t)(code << 5 | ICM_ODR_1KHZ);
        r[ICM_REG_ACCEL_CONFIG0] = (uint8_t)(code << 5 | ICM_ODR_1KHZ);
        drv_i2c_emu_config c = drv_i2c_emu_config_get(DRV_I2C_CHIP_ICM42688, r);
        assert_true(c.gyro_fs_dps == icm_dps[code] && c.accel_fs_g == icm_g[code]);
        assert_true(fabs(c.gyro_lsb * c.gyro_fs_dps / 32768 - 1) < 0.002);
        assert_true(fabs(c.accel_lsb * c.accel_fs_g / 32768 - 1) < 1e-9);
        assert_true(c.rate_hz == 1000);
    }
}

static void test_data_block_mpu(void **state)
{
    (void)state;
    uint8_t r[256], b[DRV_I2C_EMU_DATA_MAX];
    const double gyro[3] = {100 * DEG, -100 * DEG, 0}, accel[3] = {9.80665, 0, -19.6133};
    drv_i2c_emu_reset_image(DRV_I2C_CHIP_MPU6050, r);
    memset(b, 0xEE, sizeof b);
    assert_false(drv_i2c_emu_data_block(DRV_I2C_CHIP_MPU6050, r, gyro, accel, 25, b)); /* asleep */
    assert_int_equal(b[0], 0xEE);
    r[MPU_REG_PWR_MGMT_1] = MPU_PWR1_CLKSEL_PLL;
    r[MPU_REG_GYRO_CONFIG] = 3 << 3;  /* +-2000 deg/s: 16.4 LSB */
    r[MPU_REG_ACCEL_CONFIG] = 2 << 3; /* +-8 g: 4096 LSB */
    int lo, n = drv_i2c_emu_data_range(DRV_I2C_CHIP_MPU6050, &lo);
    assert_int_equal(lo, MPU_REG_INT_STATUS);
    assert_int_equal(n, 15);
    assert_true(drv_i2c_emu_data_block(DRV_I2C_CHIP_MPU6050, r, gyro, accel, 25, b));
    assert_int_equal(b[0], 0); /* DATA_RDY_INT not enabled */
    assert_int_equal(be16(&b[MPU_REG_ACCEL_XOUT_H - lo]), 4096);
    assert_int_equal(be16(&b[MPU_REG_ACCEL_XOUT_H + 4 - lo]), -8192);
    assert_int_equal(be16(&b[MPU_REG_GYRO_XOUT_H - lo]), 1640);
    assert_int_equal(be16(&b[MPU_REG_GYRO_XOUT_H + 2 - lo]), -1640);
    assert_int_equal(be16(&b[MPU_REG_TEMP_OUT_H - lo]), (int)lround((25 - 36.53) * 340));
    r[MPU_REG_INT_ENABLE] = MPU_INT_DATA_RDY_EN;
    const double fast[3] = {5000 * DEG, -5000 * DEG, 0};
    assert_true(drv_i2c_emu_data_block(DRV_I2C_CHIP_MPU6050, r, fast, accel, 25, b));
    assert_int_equal(b[0], MPU_INT_STATUS_DATA_RDY);
    assert_int_equal(be16(&b[MPU_REG_GYRO_XOUT_H - lo]), 32767); /* saturates */
    assert_int_equal(be16(&b[MPU_REG_GYRO_XOUT_H + 2 - lo]), -32768);
}

static void test_data_block_icm(void **state)
{
    (void)state;
    uint8_t r[256], b[DRV_I2C_EMU_DATA_MAX];
    const double gyro[3] = {-5000 * DEG, 10 * DEG, 0}, accel[3] = {0, 9.80665, 0};
    drv_i2c_emu_reset_image(DRV_I2C_CHIP_ICM42688, r);
    assert_false(drv_i2c_emu_data_block(DRV_I2C_CHIP_ICM42688, r, gyro, accel, 25, b)); /* both sensors off */
    r[ICM_REG_PWR_MGMT0] = ICM_PWR_GYRO_LN;                                          /* gyro only */
    int lo, n = drv_i2c_emu_data_range(DRV_I2C_CHIP_ICM42688, &lo);
    assert_int_equal(n, 17);
    assert_true(drv_i2c_emu_data_block(DRV_I2C_CHIP_ICM42688, r, gyro, accel, 25, b));
    assert_int_equal(b[n - 1], ICM_INT_STATUS_DATA_RDY);
    assert_int_equal(be16(&b[ICM_REG_ACCEL_DATA_X1 + 2 - lo]), -32768); /* accel off: "no data" */
    assert_int_equal(be16(&b[ICM_REG_GYRO_DATA_X1 - lo]), -32767);      /* a reading never says "no data" */
    assert_int_equal(be16(&b[ICM_REG_GYRO_DATA_X1 + 2 - lo]), 164);     /* +-2000 deg/s at reset: 16.4 LSB */
    r[ICM_REG_PWR_MGMT0] = ICM_PWR_GYRO_LN | ICM_PWR_ACCEL_LN;
    r[ICM_REG_INTF_CONFIG0] &= (uint8_t)~DRV_I2C_EMU_ICM_ENDIAN; /* little-endian data */
    assert_true(drv_i2c_emu_data_block(DRV_I2C_CHIP_ICM42688, r, gyro, accel, 30, b));
    assert_int_equal(le16(&b[ICM_REG_GYRO_DATA_X1 + 2 - lo]), 164);
    assert_int_equal(le16(&b[ICM_REG_ACCEL_DATA_X1 + 2 - lo]), 2048);
    assert_int_equal(le16(&b[0]), (int)lround(5 * 132.48));
}

/* The HIL player's pulse times before the schedule moved here (seed 7, +-200 us, its own splitmix64 formula). */
static void test_te_hil_compat(void **state)
{
    (void)state;
    drv_te_schedule s = drv_te_schedule_clean(11111111, 7);
    s.jitter_ns = 200000;
    static const int64_t jit[4] = {-44070, -155555, 131752, -148220};
    for (int k = 0; k < 4; k++) {
        int64_t at;
        assert_true(drv_te_schedule_pulse(&s, k, &at));
        assert_int_equal(at, (int64_t)k * 11111111 + jit[k]);
    }
}

static void test_te_statistics(void **state)
{
    (void)state;
    drv_te_schedule s = drv_te_schedule_clean(1e9 / 90, 3);
    s.jitter_ns = 100000, s.miss_prob = 0.1, s.spurious_prob = 0.2;
    const int N = 20000;
    int lost = 0, glitches = 0;
    double sum = 0;
    for (int k = 0; k < N; k++) {
        int64_t at, again, g;
        bool on = drv_te_schedule_pulse(&s, k, &at);
        assert_true(drv_te_schedule_pulse(&s, k, &again) == on && again == at); /* random access */
        int64_t slot = drv_te_schedule_slot(&s, k);
        assert_true(llabs(at - slot) <= 100000);
        sum += (double)(at - slot);
        lost += !on;
        if (drv_te_schedule_glitch(&s, k, &g)) {
            glitches++;
            assert_true(g >= slot + s.period_ns * 0.1 - 1 && g <= slot + s.period_ns * 0.9 + 1);
        }
    }
    assert_true(fabs((double)lost / N - 0.1) < 0.01);
    assert_true(fabs((double)glitches / N - 0.2) < 0.015);
    assert_true(fabs(sum / N) < 3000); /* zero-mean jitter */
    /* Another seed, another sequence. */
    drv_te_schedule o = s;
    o.seed = 4;
    int same = 0;
    for (int k = 0; k < 100; k++) {
        int64_t a, b;
        drv_te_schedule_pulse(&s, k, &a);
        drv_te_schedule_pulse(&o, k, &b);
        same += a == b;
    }
    assert_true(same < 5);
}

static void test_te_stop_and_jump(void **state)
{
    (void)state;
    drv_te_schedule s = drv_te_schedule_clean(10e6, 1); /* 100 Hz */
    s.stop_at_ns = 95000000, s.stop_to_ns = 205000000;
    s.jump_at_ns = 300000000, s.jump_ns = 3000000;
    for (int k = 0; k < 40; k++) {
        int64_t at;
        bool on = drv_te_schedule_pulse(&s, k, &at);
        assert_true(on == (k < 10 || k > 20));
        assert_int_equal(at, (int64_t)k * 10000000 + (k >= 30 ? 3000000 : 0));
        assert_false(drv_te_schedule_glitch(&s, k, &at)); /* spurious_prob 0 */
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_reset_images),     cmocka_unit_test(test_range_codes),
        cmocka_unit_test(test_data_block_mpu),   cmocka_unit_test(test_data_block_icm),
        cmocka_unit_test(test_te_hil_compat),    cmocka_unit_test(test_te_statistics),
        cmocka_unit_test(test_te_stop_and_jump),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

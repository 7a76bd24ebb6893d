/* SPDX-License-Identifier: MIT */
/* Unit tests for the I2C IMU backend: per-chip init sequences against the datasheets, scaling at every range,
 * big-endian burst decoding, identification errors, auto-detection, the mock chip fed by the simulated IMU end to end,
 * saturation, invalid / missing data, and recovery after a failing bus. */
#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "drivers/drv_i2c_chips.h"
#include "drivers/drv_imu_i2c_mock.h"
#include "drivers/drv_sim.h"
#include "platform/plat_clock.h"
#include "sim/sim_trace.h"

#define PI 3.14159265358979323846
#define DEG (PI / 180.0)
#define G 9.80665

static drv_imu_i2c_params params(const char *chip, double rate, int dps, int g)
{
    drv_imu_i2c_params p;
    memset(&p, 0, sizeof p);
    snprintf(p.bus, sizeof p.bus, "/dev/i2c-7");
    p.addr = 0x68;
    snprintf(p.chip, sizeof p.chip, "%s", chip);
    p.rate_hz = rate;
    p.gyro_dps = dps;
    p.accel_g = g;
    return p;
}

static drv_i2c_mockbus *new_mock(drv_i2c_chip_kind model, drv_imu *source)
{
    drv_i2c_mockbus *m = drv_i2c_mockbus_create(model, 0x68, source);
    assert_non_null(m);
    snprintf(m->name, sizeof m->name, "/dev/i2c-7 addr 0x68");
    return m;
}

/* ---- test sources ---- */

typedef struct {
    drv_imu base;
    drv_imu_sample s;
} const_src;

static int const_read(drv_imu *imu, drv_imu_sample *out, int max, int timeout_ms)
{
    (void)timeout_ms;
    if (max < 1) return 0;
    out[0] = ((const_src *)imu)->s;
    out[0].t_ns = plat_now_ns();
    return 1;
}
static void free_imu(drv_imu *imu) { free(imu); }

static drv_imu *const_source(const double gyro[3], const double accel[3])
{
    const_src *c = calloc(1, sizeof *c);
    assert_non_null(c);
    c->base.name = "const";
    c->base.read = const_read;
    c->base.destroy = free_imu;
    memcpy(c->s.gyro, gyro, sizeof c->s.gyro);
    memcpy(c->s.accel, accel, sizeof c->s.accel);
    return &c->base;
}

/* Passes another IMU's samples through and remembers them all. */
#define REC_MAX 8192
typedef struct {
    drv_imu base;
    drv_imu *inner;
    drv_imu_sample rec[REC_MAX];
    int n;
} recorder;

static int rec_read(drv_imu *imu, drv_imu_sample *out, int max, int timeout_ms)
{
    recorder *r = (recorder *)imu;
    int n = drv_imu_read(r->inner, out, max, timeout_ms);
    for (int i = 0; i < n && r->n < REC_MAX; i++) r->rec[r->n++] = out[i];
    return n;
}
static void rec_destroy(drv_imu *imu)
{
    recorder *r = (recorder *)imu;
    drv_imu_destroy(r->inner);
    free(r);
}
static recorder *recorder_wrap(drv_imu *inner)
{
    recorder *r = calloc(1, sizeof *r);
    assert_non_null(r);
    r->base.name = "recorder";
    r->base.read = rec_read;
    r->base.destroy = rec_destroy;
    r->inner = inner;
    return r;
}

/* ---- bus ---- */

static void test_bus_split_long_reads(void **state)
{
    (void)state;
    drv_i2c_mockbus *m = new_mock(DRV_I2C_CHIP_MPU6050, NULL);
    for (int i = 0; i < 256; i++) m->reg[i] = (uint8_t)i;
    uint8_t buf[40];
    assert_int_equal(drv_i2c_read(&m->bus, 0x10, buf, 40), 0);
    for (int i = 0; i < 40; i++) assert_int_equal(buf[i], 0x10 + i);
    assert_int_equal(m->n_log, 2);
    assert_false(m->log[0].write);
    assert_int_equal(m->log[0].reg, 0x10);
    assert_int_equal(m->log[0].val, 32);
    assert_int_equal(m->log[1].reg, 0x30);
    assert_int_equal(m->log[1].val, 8);
    /* one transfer beyond the SMBus limit is refused, not truncated */
    assert_int_equal(m->bus.read_block(&m->bus, 0, buf, 33), -EINVAL);
    drv_i2c_bus_destroy(&m->bus);
}

/* ---- init sequences ---- */

typedef struct {
    uint8_t reg, val;
} wr;

static void expect_writes(const drv_i2c_mockbus *m, const wr *w, int n)
{
    uint8_t reg, val;
    for (int i = 0; i < n; i++) {
        assert_int_equal(drv_i2c_mockbus_write_at(m, i, &reg, &val), 0);
        if (reg != w[i].reg || val != w[i].val)
            fail_msg("write %d: reg 0x%02x = 0x%02x, expected reg 0x%02x = 0x%02x", i, reg, val, w[i].reg, w[i].val);
    }
    assert_int_equal(drv_i2c_mockbus_write_at(m, n, &reg, &val), -1);
}

static drv_imu *create_on(drv_i2c_mockbus *m, const char *chip, double rate, int dps, int g)
{
    drv_imu_i2c_params p = params(chip, rate, dps, g);
    char err[200] = "";
    drv_imu *imu = drv_imu_i2c_create_on_bus(&m->bus, &p, err, sizeof err);
    if (!imu) fail_msg("create failed: %s", err);
    return imu;
}

static void test_mpu6050_init_sequence(void **state)
{
    (void)state;
    drv_i2c_mockbus *m = new_mock(DRV_I2C_CHIP_MPU6050, NULL);
    drv_imu *imu = create_on(m, "mpu6050", 1000, 2000, 16);
    /* reset, wake on the PLL, all axes on, DLPF 188 Hz, 1 kHz / (1 + 0), FS_SEL 3, AFS_SEL 3, DATA_RDY_EN */
    const wr w[] = {{0x6B, 0x80}, {0x6B, 0x01}, {0x6C, 0x00}, {0x1A, 0x01},
                    {0x19, 0x00}, {0x1B, 0x18}, {0x1C, 0x18}, {0x38, 0x01}};
    expect_writes(m, w, 8);
    assert_int_equal(m->resets, 1);
    const drv_i2c_setup *s = drv_imu_i2c_setup(imu);
    assert_int_equal(s->steps[0].delay_ms, 100); /* datasheet: 100 ms after DEVICE_RESET */
    assert_true(s->rate_hz == 1000.0);
    assert_true(s->gyro_fs_dps == 2000 && s->accel_fs_g == 16);
    assert_true(s->filter_hz == 188);
    drv_imu_destroy(imu);

    m = new_mock(DRV_I2C_CHIP_MPU6050, NULL);
    imu = create_on(m, "mpu6050", 200, 500, 4); /* DLPF 98 Hz (< 100 Hz Nyquist), divider 4 */
    const wr w2[] = {{0x6B, 0x80}, {0x6B, 0x01}, {0x6C, 0x00}, {0x1A, 0x02},
                     {0x19, 0x04}, {0x1B, 0x08}, {0x1C, 0x08}, {0x38, 0x01}};
    expect_writes(m, w2, 8);
    assert_true(drv_imu_i2c_setup(imu)->rate_hz == 200.0);
    drv_imu_destroy(imu);

    m = new_mock(DRV_I2C_CHIP_MPU6050, NULL);
    imu = create_on(m, "mpu6050", 100, 250, 2); /* DLPF 42 Hz, divider 9, the smallest ranges */
    const wr w3[] = {{0x6B, 0x80}, {0x6B, 0x01}, {0x6C, 0x00}, {0x1A, 0x03},
                     {0x19, 0x09}, {0x1B, 0x00}, {0x1C, 0x00}, {0x38, 0x01}};
    expect_writes(m, w3, 8);
    drv_imu_destroy(imu);
}

static void test_mpu9250_init_sequence(void **state)
{
    (void)state;
    drv_i2c_mockbus *m = new_mock(DRV_I2C_CHIP_MPU9250, NULL);
    drv_imu *imu = create_on(m, "mpu9250", 1000, 1000, 8);
    /* MPU-9250 adds ACCEL_CONFIG2 (A_DLPF 218 Hz, FCHOICE_B 0); GYRO_CONFIG FCHOICE_B bits stay 0 */
    const wr w[] = {{0x6B, 0x80}, {0x6B, 0x01}, {0x6C, 0x00}, {0x1A, 0x01}, {0x19, 0x00},
                    {0x1B, 0x10}, {0x1C, 0x10}, {0x1D, 0x01}, {0x38, 0x01}};
    expect_writes(m, w, 9);
    assert_true(drv_imu_i2c_setup(imu)->filter_hz == 184);
    drv_imu_destroy(imu);

    m = new_mock(DRV_I2C_CHIP_MPU9250, NULL);
    imu = create_on(m, "mpu9250", 50, 2000, 2); /* 20 Hz gyro DLPF, 21.2 Hz accel, divider 19 */
    const wr w2[] = {{0x6B, 0x80}, {0x6B, 0x01}, {0x6C, 0x00}, {0x1A, 0x04}, {0x19, 19},
                     {0x1B, 0x18}, {0x1C, 0x00}, {0x1D, 0x04}, {0x38, 0x01}};
    expect_writes(m, w2, 9);
    drv_imu_destroy(imu);
}

static void test_icm42688_init_sequence(void **state)
{
    (void)state;
    drv_i2c_mockbus *m = new_mock(DRV_I2C_CHIP_ICM42688, NULL);
    m->reg[ICM_REG_BANK_SEL] = 2; /* left in another bank: WHO_AM_I only reads right after selecting bank 0 */
    drv_imu *imu = create_on(m, "icm42688", 1000, 2000, 16);
    /* bank 0 (identify), bank 0, soft reset, GYRO_CONFIG0 FS 2000 + ODR 1 kHz, ACCEL_CONFIG0 FS 16 g + 1 kHz,
     * data-ready routed, gyro + accel low-noise mode last */
    const wr w[] = {{0x76, 0x00}, {0x76, 0x00}, {0x11, 0x01}, {0x4F, 0x06}, {0x50, 0x06}, {0x65, 0x18}, {0x4E, 0x0F}};
    expect_writes(m, w, 7);
    assert_int_equal(m->resets, 1);
    const drv_i2c_setup *s = drv_imu_i2c_setup(imu);
    assert_int_equal(s->steps[s->n_steps - 1].delay_ms, 60); /* gyro start-up before the first read */
    drv_imu_destroy(imu);

    m = new_mock(DRV_I2C_CHIP_ICM42688, NULL);
    imu = create_on(m, "icm42688", 200, 250, 4); /* FS_SEL 3 / 2, ODR 0x07 (200 Hz) */
    const wr w2[] = {{0x76, 0x00}, {0x76, 0x00}, {0x11, 0x01}, {0x4F, 0x67}, {0x50, 0x47}, {0x65, 0x18}, {0x4E, 0x0F}};
    expect_writes(m, w2, 7);
    drv_imu_destroy(imu);

    m = new_mock(DRV_I2C_CHIP_ICM42688, NULL);
    imu = create_on(m, "icm42688", 480, 15, 2); /* nearest ODR 500 Hz (0x0F); 15 dps -> +-15.625 (FS_SEL 7) */
    const wr w3[] = {{0x76, 0x00}, {0x76, 0x00}, {0x11, 0x01}, {0x4F, 0xEF}, {0x50, 0x6F}, {0x65, 0x18}, {0x4E, 0x0F}};
    expect_writes(m, w3, 7);
    assert_true(drv_imu_i2c_setup(imu)->rate_hz == 500.0);
    assert_true(drv_imu_i2c_setup(imu)->gyro_fs_dps == 15.625);
    drv_imu_destroy(imu);
}

/* ---- scaling ---- */

static void put_be(uint8_t *p, int v)
{
    p[0] = (uint8_t)((unsigned)v >> 8 & 0xff);
    p[1] = (uint8_t)((unsigned)v & 0xff);
}

typedef struct {
    int fs_req;
    double fs;
    int raw;
    double expect; /* deg/s or g */
} scale_case;

static void check_scale(drv_i2c_chip_kind kind, const scale_case *gc, int ng, const scale_case *ac, int na)
{
    const drv_i2c_chip *c = drv_i2c_chip_get(kind);
    char err[160];
    for (int i = 0; i < ng; i++) {
        drv_i2c_request rq = {1000, gc[i].fs_req, 16};
        drv_i2c_setup s;
        assert_int_equal(drv_i2c_chip_plan(c, &rq, &s, err, sizeof err), 0);
        assert_true(s.gyro_fs_dps == gc[i].fs);
        uint8_t burst[32] = {0};
        for (int k = 0; k < 3; k++) put_be(burst + c->gyro_off + 2 * k, k == 1 ? -gc[i].raw : gc[i].raw);
        drv_i2c_sample smp;
        drv_i2c_chip_decode(c, &s, burst, &smp);
        assert_float_equal(smp.gyro[0], gc[i].expect * DEG, 1e-3 * DEG);
        assert_float_equal(smp.gyro[1], -gc[i].expect * DEG, 1e-3 * DEG);
    }
    for (int i = 0; i < na; i++) {
        drv_i2c_request rq = {1000, 2000, ac[i].fs_req};
        drv_i2c_setup s;
        assert_int_equal(drv_i2c_chip_plan(c, &rq, &s, err, sizeof err), 0);
        assert_true(s.accel_fs_g == ac[i].fs);
        uint8_t burst[32] = {0};
        for (int k = 0; k < 3; k++) put_be(burst + c->accel_off + 2 * k, k == 2 ? -ac[i].raw : ac[i].raw);
        drv_i2c_sample smp;
        drv_i2c_chip_decode(c, &s, burst, &smp);
        assert_float_equal(smp.accel[0], ac[i].expect * G, 1e-9);
        assert_float_equal(smp.accel[2], -ac[i].expect * G, 1e-9);
    }
}

static const scale_case accel_cases[] = {{2, 2, 16384, 1.0}, {4, 4, 8192, 1.0}, {8, 8, 4096, 1.0},
                                         {16, 16, 2048, 1.0}, {3, 4, 4096, 0.5}};

static void test_scaling_mpu(void **state)
{
    (void)state;
    /* datasheet sensitivities: 131, 65.5, 32.8, 16.4 LSB/(deg/s); 16384 .. 2048 LSB/g */
    const scale_case gyro[] = {{250, 250, 131, 1.0}, {500, 500, 655, 10.0}, {1000, 1000, 328, 10.0},
                               {2000, 2000, 164, 10.0}, {300, 500, 131, 2.0}};
    check_scale(DRV_I2C_CHIP_MPU6050, gyro, 5, accel_cases, 5);
    check_scale(DRV_I2C_CHIP_MPU9250, gyro, 5, accel_cases, 5);
}

static void test_scaling_icm42688(void **state)
{
    (void)state;
    const scale_case gyro[] = {{2000, 2000, 164, 10.0},  {1000, 1000, 328, 10.0}, {500, 500, 655, 10.0},
                               {250, 250, 131, 1.0},     {125, 125, 262, 1.0},    {62, 62.5, 5243, 10.0},
                               {31, 31.25, 10486, 10.0}, {15, 15.625, 20972, 10.0}};
    check_scale(DRV_I2C_CHIP_ICM42688, gyro, 8, accel_cases, 5);
}

static void test_range_errors(void **state)
{
    (void)state;
    char err[200] = "";
    drv_i2c_setup s;
    drv_i2c_request rq = {1000, 4000, 16};
    assert_int_equal(drv_i2c_chip_plan(drv_i2c_chip_get(DRV_I2C_CHIP_MPU6050), &rq, &s, err, sizeof err), -EINVAL);
    assert_non_null(strstr(err, "gyro_dps 4000"));
    assert_non_null(strstr(err, "2000"));
    rq = (drv_i2c_request){1000, 2000, 32};
    assert_int_equal(drv_i2c_chip_plan(drv_i2c_chip_get(DRV_I2C_CHIP_ICM42688), &rq, &s, err, sizeof err), -EINVAL);
    assert_non_null(strstr(err, "accel_g 32"));
    rq = (drv_i2c_request){NAN, 2000, 16};
    assert_int_equal(drv_i2c_chip_plan(drv_i2c_chip_get(DRV_I2C_CHIP_MPU9250), &rq, &s, err, sizeof err), -EINVAL);
    assert_non_null(strstr(err, "rate_hz"));
    /* 0 means the largest range; above 1 kHz the poll rate is capped */
    rq = (drv_i2c_request){8000, 0, 0};
    assert_int_equal(drv_i2c_chip_plan(drv_i2c_chip_get(DRV_I2C_CHIP_MPU6050), &rq, &s, err, sizeof err), 0);
    assert_true(s.gyro_fs_dps == 2000 && s.accel_fs_g == 16 && s.rate_hz == 1000);
    /* Tiny rates: the slowest divider, 1000 / 256 Hz (1000 / 1e-300 once overflowed lround(...) - 1). */
    const double tiny[] = {1e-300, 5e-324, 1e-9, 3.0};
    for (int i = 0; i < 4; i++)
        for (int k = DRV_I2C_CHIP_MPU6050; k <= DRV_I2C_CHIP_MPU9250; k++) {
            rq = (drv_i2c_request){tiny[i], 0, 0};
            assert_int_equal(drv_i2c_chip_plan(drv_i2c_chip_get((drv_i2c_chip_kind)k), &rq, &s, err, sizeof err), 0);
            assert_true(s.rate_hz == 1000.0 / 256);
        }
}

/* ---- burst decode through the backend ---- */

static void test_burst_decode_mpu(void **state)
{
    (void)state;
    drv_i2c_mockbus *m = new_mock(DRV_I2C_CHIP_MPU6050, NULL);
    drv_imu *imu = create_on(m, "mpu6050", 1000, 250, 2);
    const int accel[3] = {-16384, 16384, -1}, gyro[3] = {-131, -32768, 32767};
    for (int i = 0; i < 3; i++) {
        put_be(&m->reg[0x3B + 2 * i], accel[i]);
        put_be(&m->reg[0x43 + 2 * i], gyro[i]);
    }
    put_be(&m->reg[0x41], -3920); /* 25 degC on an MPU-6050 */
    drv_i2c_mockbus_set_ready(m);
    drv_imu_sample out[4];
    int64_t t0 = plat_now_ns();
    assert_int_equal(drv_imu_read(imu, out, 4, 100), 1);
    int64_t t1 = plat_now_ns();
    assert_true(out[0].t_ns >= t0 && out[0].t_ns <= t1);
    assert_float_equal(out[0].accel[0], -G, 1e-9);
    assert_float_equal(out[0].accel[1], G, 1e-9);
    assert_float_equal(out[0].accel[2], -G / 16384, 1e-12);
    assert_float_equal(out[0].gyro[0], -1.0 * DEG, 1e-12);
    assert_float_equal(out[0].gyro[1], -32768 / 131.0 * DEG, 1e-12);
    assert_float_equal(out[0].gyro[2], 32767 / 131.0 * DEG, 1e-12);
    /* INT_STATUS was read in the same 15-byte burst and cleared */
    const drv_i2c_mock_op *last = &m->log[m->n_log - 1];
    assert_int_equal(last->reg, 0x3A);
    assert_int_equal(last->val, 15);
    assert_int_equal(m->reg[0x3A], 0);
    /* temperature through the chip API */
    drv_i2c_sample smp;
    bool ready;
    char err[160];
    assert_int_equal(drv_i2c_chip_read(&m->bus, drv_imu_i2c_chip(imu), drv_imu_i2c_setup(imu), &smp, &ready, NULL,
                                       NULL, err, sizeof err),
                     0);
    assert_false(ready);
    assert_float_equal(smp.temp_c, 25.0, 0.01);
    drv_imu_destroy(imu);
}

static void test_burst_decode_icm(void **state)
{
    (void)state;
    drv_i2c_mockbus *m = new_mock(DRV_I2C_CHIP_ICM42688, NULL);
    drv_imu *imu = create_on(m, "icm42688", 1000, 2000, 16);
    const int accel[3] = {2048, -4096, -2}, gyro[3] = {-164, 16400, -1};
    put_be(&m->reg[0x1D], 1325); /* ~35 degC */
    for (int i = 0; i < 3; i++) {
        put_be(&m->reg[0x1F + 2 * i], accel[i]);
        put_be(&m->reg[0x25 + 2 * i], gyro[i]);
    }
    drv_i2c_mockbus_set_ready(m);
    drv_imu_sample out[1];
    assert_int_equal(drv_imu_read(imu, out, 1, 100), 1);
    assert_float_equal(out[0].accel[0], G, 1e-9);
    assert_float_equal(out[0].accel[1], -2 * G, 1e-9);
    assert_float_equal(out[0].accel[2], -2 * G / 2048, 1e-12);
    assert_float_equal(out[0].gyro[0], -10 * DEG, 1e-12);
    assert_float_equal(out[0].gyro[1], 1000 * DEG, 1e-9);
    assert_float_equal(out[0].gyro[2], -DEG / 16.4, 1e-12);
    drv_i2c_sample smp;
    drv_i2c_chip_decode(drv_imu_i2c_chip(imu), drv_imu_i2c_setup(imu), &m->reg[0x1D], &smp);
    assert_float_equal(smp.temp_c, 1325 / 132.48 + 25, 1e-9);
    drv_imu_destroy(imu);
}

/* ---- identification ---- */

static void test_who_am_i_mismatch(void **state)
{
    (void)state;
    char err[240] = "";
    drv_imu_i2c_params p = params("mpu6050", 1000, 2000, 16);
    drv_i2c_mockbus *m = new_mock(DRV_I2C_CHIP_MPU6050, NULL);
    m->who_am_i = 0x12;
    assert_null(drv_imu_i2c_create_on_bus(&m->bus, &p, err, sizeof err));
    assert_non_null(strstr(err, "/dev/i2c-7 addr 0x68"));
    assert_non_null(strstr(err, "WHO_AM_I (reg 0x75) 0x12 is not an MPU-6050"));
    assert_non_null(strstr(err, "expected 0x68"));

    /* a known but different chip names what it is */
    m = new_mock(DRV_I2C_CHIP_MPU9250, NULL);
    assert_null(drv_imu_i2c_create_on_bus(&m->bus, &p, err, sizeof err));
    assert_non_null(strstr(err, "0x71 is not an MPU-6050"));
    assert_non_null(strstr(err, "MPU-9250"));
    assert_non_null(strstr(err, "chip = mpu9250"));

    /* auto with an unknown chip */
    p = params("auto", 1000, 2000, 16);
    m = new_mock(DRV_I2C_CHIP_ICM42688, NULL);
    m->who_am_i = 0x98;
    assert_null(drv_imu_i2c_create_on_bus(&m->bus, &p, err, sizeof err));
    assert_non_null(strstr(err, "0x98 matches no supported chip"));
}

static void test_nack(void **state)
{
    (void)state;
    char err[240] = "";
    drv_imu_i2c_params p = params("auto", 1000, 2000, 16);
    drv_i2c_mockbus *m = new_mock(DRV_I2C_CHIP_MPU6050, NULL);
    m->absent = true;
    assert_null(drv_imu_i2c_create_on_bus(&m->bus, &p, err, sizeof err));
    assert_non_null(strstr(err, "/dev/i2c-7 addr 0x68: no ACK reading WHO_AM_I (reg 0x75)"));

    /* a NACK in the middle of the init names the register */
    m = new_mock(DRV_I2C_CHIP_MPU6050, NULL);
    drv_imu *imu = create_on(m, "mpu6050", 1000, 2000, 16);
    drv_i2c_step st = {MPU_REG_GYRO_CONFIG, 0x18, true, 0, "GYRO_CONFIG"};
    m->fail_next = 1;
    assert_int_equal(drv_i2c_chip_step(&m->bus, &st, err, sizeof err), -EREMOTEIO);
    assert_non_null(strstr(err, "no ACK writing GYRO_CONFIG (reg 0x1b) = 0x18"));
    drv_imu_destroy(imu);
}

static void test_param_and_bus_errors(void **state)
{
    (void)state;
    char err[240] = "";
    drv_imu_i2c_params p = params("bmi160", 1000, 2000, 16);
    assert_null(drv_imu_i2c_create(&p, err, sizeof err));
    assert_non_null(strstr(err, "chip 'bmi160' unknown"));
    p = params("auto", 1000, 2000, 16);
    p.addr = 0xD0; /* an 8-bit address by mistake */
    assert_null(drv_imu_i2c_create(&p, err, sizeof err));
    assert_non_null(strstr(err, "not a 7-bit I2C device address"));
    /* the real i2c-dev path */
    p = params("auto", 1000, 2000, 16);
    snprintf(p.bus, sizeof p.bus, "/dev/i2c-hmdwarp-none");
    assert_null(drv_imu_i2c_create(&p, err, sizeof err));
    assert_non_null(strstr(err, "/dev/i2c-hmdwarp-none: no such bus"));
    snprintf(p.bus, sizeof p.bus, "/dev/null");
    assert_null(drv_imu_i2c_create(&p, err, sizeof err));
    assert_non_null(strstr(err, "/dev/null: not an I2C adapter"));
    /* the mock releases its source on bad parameters too (ASan checks the leak) */
    const double z[3] = {0, 0, 0};
    p = params("nope", 1000, 2000, 16);
    assert_null(drv_imu_i2c_create_mock(const_source(z, z), &p, err, sizeof err));
}

static void test_auto_detect(void **state)
{
    (void)state;
    const struct {
        drv_i2c_chip_kind model;
        int who;
    } cases[] = {{DRV_I2C_CHIP_MPU6050, -1}, {DRV_I2C_CHIP_MPU9250, -1}, {DRV_I2C_CHIP_MPU9250, 0x73},
                 {DRV_I2C_CHIP_ICM42688, -1}};
    for (int i = 0; i < 4; i++) {
        drv_i2c_mockbus *m = new_mock(cases[i].model, NULL);
        m->who_am_i = cases[i].who;
        drv_imu *imu = create_on(m, "auto", 1000, 2000, 16);
        assert_int_equal(drv_imu_i2c_chip(imu)->kind, cases[i].model);
        assert_non_null(strstr(imu->name, drv_imu_i2c_chip(imu)->name));
        /* the detected chip's init ran: its reset register was written */
        uint8_t reg, val;
        assert_int_equal(drv_i2c_mockbus_write_at(m, cases[i].model == DRV_I2C_CHIP_ICM42688 ? 1 : 0, &reg, &val), 0);
        assert_int_equal(reg, cases[i].model == DRV_I2C_CHIP_ICM42688 ? 0x11 : 0x6B);
        drv_imu_destroy(imu);
    }
    /* the other backends are not mistaken for this one */
    assert_null(drv_imu_i2c_chip(NULL));
}

/* ---- the mock fed by the simulated IMU ---- */

static void run_end_to_end(const char *chip, int dps, int g)
{
    sim_trace tr;
    assert_true(sim_trace_init(&tr, "slow", 3));
    sim_imu_params ip = sim_imu_default_params();
    ip.rate_hz = 1000;
    ip.t_start = 0;
    recorder *rec = recorder_wrap(drv_imu_sim_create(&tr, &ip, plat_now_ns()));
    assert_non_null(rec->inner);
    drv_imu_i2c_params p = params(chip, 1000, dps, g);
    char err[200] = "";
    drv_imu *imu = drv_imu_i2c_create_mock(&rec->base, &p, err, sizeof err);
    if (!imu) fail_msg("%s", err);
    const drv_i2c_setup *s = drv_imu_i2c_setup(imu);
    double gq = 0.5 / s->gyro_lsb_per_dps * DEG + 1e-12, aq = 0.5 / s->accel_lsb_per_g * G + 1e-12;

    int n = 0, matched = 0;
    /* 300 ms and at least 50 samples (a loaded machine reads fewer a second), at most 20 s (a guard) */
    int64_t last_t = 0, t0 = plat_now_ns(), end = t0 + 300 * PLAT_NS_PER_MS, cap = t0 + 20000 * PLAT_NS_PER_MS;
    for (;;) {
        int64_t now = plat_now_ns();
        if ((now >= end && n >= 50) || now >= cap) break;
        drv_imu_sample out[8];
        int k = drv_imu_read(imu, out, 8, 20);
        assert_true(k >= 0 && k <= 1);
        if (!k) continue;
        n++;
        assert_true(out[0].t_ns > last_t);
        last_t = out[0].t_ns;
        /* equal to one of the source's samples within quantisation, one the source produced by the end of the
         * transfer (the mock latches the source during the transfer; the timestamp is its middle, and a transfer
         * preempted half way ends as long after it as the machine kept the reader off its CPU: 50 ms here, where a
         * sample from the wrong transfer would be a multiple of a second off) */
        for (int j = rec->n - 1; j >= 0; j--) {
            const drv_imu_sample *r = &rec->rec[j];
            bool eq = r->t_ns <= out[0].t_ns + 50 * PLAT_NS_PER_MS;
            for (int a = 0; a < 3 && eq; a++)
                eq = fabs(r->gyro[a] - out[0].gyro[a]) <= gq && fabs(r->accel[a] - out[0].accel[a]) <= aq;
            if (eq) {
                matched++;
                break;
            }
        }
    }
    assert_true(n >= 50); /* read until it had them */
    assert_int_equal(matched, n);
    drv_imu_stats st;
    assert_true(drv_imu_stats_get(imu, &st));
    assert_int_equal(st.reports, (uint64_t)n);
    assert_int_equal(st.read_errors, 0);
    assert_true(st.connected);
    assert_string_equal(st.last_error, "");
    drv_imu_destroy(imu);
}

static void test_mock_sim_mpu9250(void **state)
{
    (void)state;
    run_end_to_end("mpu9250", 500, 4);
}

static void test_mock_sim_icm42688(void **state)
{
    (void)state;
    run_end_to_end("icm42688", 250, 2);
}

static void test_saturation(void **state)
{
    (void)state;
    const double gyro[3] = {40.0, -40.0, 1.0}, accel[3] = {200.0, -200.0, 9.80665}; /* 2292 deg/s, 20 g */
    char err[200] = "";
    drv_imu_i2c_params p = params("mpu6050", 1000, 2000, 16);
    drv_imu *imu = drv_imu_i2c_create_mock(const_source(gyro, accel), &p, err, sizeof err);
    assert_non_null(imu);
    drv_imu_sample out[1];
    assert_int_equal(drv_imu_read(imu, out, 1, 200), 1);
    assert_float_equal(out[0].gyro[0], 32767 / 16.4 * DEG, 1e-9);
    assert_float_equal(out[0].gyro[1], -32768 / 16.4 * DEG, 1e-9);
    assert_float_equal(out[0].gyro[2], 1.0, 0.5 / 16.4 * DEG + 1e-12);
    assert_float_equal(out[0].accel[0], 32767 / 2048.0 * G, 1e-9);
    assert_float_equal(out[0].accel[1], -32768 / 2048.0 * G, 1e-9);
    assert_float_equal(out[0].accel[2], G, 0.5 / 2048 * G + 1e-12);
    drv_imu_destroy(imu);

    /* the ICM keeps -32768 for "invalid": saturates at -32767 */
    p = params("icm42688", 1000, 2000, 16);
    imu = drv_imu_i2c_create_mock(const_source(gyro, accel), &p, err, sizeof err);
    assert_non_null(imu);
    assert_int_equal(drv_imu_read(imu, out, 1, 200), 1);
    assert_float_equal(out[0].gyro[1], -32767 / 16.4 * DEG, 1e-9);
    assert_float_equal(out[0].accel[0], 32767 / 2048.0 * G, 1e-9);
    drv_imu_destroy(imu);
}

/* ---- bad data, timeouts, recovery ---- */

static void test_invalid_and_missing_data(void **state)
{
    (void)state;
    /* ICM data registers still at the reset marker -32768 although data-ready is up */
    drv_i2c_mockbus *m = new_mock(DRV_I2C_CHIP_ICM42688, NULL);
    drv_imu *imu = create_on(m, "icm42688", 1000, 2000, 16);
    drv_i2c_mockbus_set_ready(m);
    drv_imu_sample out[1];
    assert_int_equal(drv_imu_read(imu, out, 1, 20), 0);
    drv_imu_stats st;
    drv_imu_stats_get(imu, &st);
    assert_int_equal(st.bad_reports, 1);
    assert_non_null(strstr(st.last_error, "invalid marker -32768"));
    drv_imu_destroy(imu);

    /* an MPU that never raises data-ready (reset behind our back: asleep) is declared lost */
    m = new_mock(DRV_I2C_CHIP_MPU6050, NULL);
    imu = create_on(m, "mpu6050", 1000, 2000, 16);
    int rc = 0;
    int64_t end = plat_now_ns() + 1500 * PLAT_NS_PER_MS;
    while (rc == 0 && plat_now_ns() < end) rc = drv_imu_read(imu, out, 1, 50);
    assert_int_equal(rc, -ENODEV);
    drv_imu_stats_get(imu, &st);
    assert_false(st.connected);
    assert_non_null(strstr(st.last_error, "no new data"));
    drv_imu_destroy(imu);
}

static void test_rate_and_timeout(void **state)
{
    (void)state;
    const double gyro[3] = {0.1, 0.2, 0.3}, accel[3] = {0, 9.81, 0};
    char err[200] = "";
    drv_imu_i2c_params p = params("mpu6050", 10, 2000, 16);
    drv_imu *imu = drv_imu_i2c_create_mock(const_source(gyro, accel), &p, err, sizeof err);
    assert_non_null(imu);
    assert_true(drv_imu_i2c_setup(imu)->rate_hz == 10.0);
    drv_imu_sample a[1], b[1];
    assert_int_equal(drv_imu_read(imu, a, 1, 500), 1);
    /* the next sample is 100 ms away: a 5 ms wait gives nothing (and does not block for long) */
    int64_t t0 = plat_now_ns();
    assert_int_equal(drv_imu_read(imu, b, 1, 5), 0);
    assert_true(plat_now_ns() - t0 < 80 * PLAT_NS_PER_MS);
    assert_true(plat_now_ns() - t0 >= 5 * PLAT_NS_PER_MS);
    assert_int_equal(drv_imu_read(imu, b, 1, 500), 1);
    assert_true(b[0].t_ns - a[0].t_ns >= 99 * PLAT_NS_PER_MS); /* polled at the configured rate */
    assert_int_equal(drv_imu_read(imu, b, 0, 500), 0);
    drv_imu_destroy(imu);
}

static void test_recovery(void **state)
{
    (void)state;
    const double gyro[3] = {0.5, -0.25, 0.125}, accel[3] = {0, 9.80665, 0};
    char err[200] = "";
    drv_imu_i2c_params p = params("mpu9250", 1000, 2000, 16);
    drv_imu *imu = drv_imu_i2c_create_mock(const_source(gyro, accel), &p, err, sizeof err);
    assert_non_null(imu);
    drv_i2c_mockbus *m = drv_imu_i2c_mockbus(imu);
    assert_non_null(m);
    drv_imu_sample out[1];
    for (int i = 0; i < 5; i++) assert_int_equal(drv_imu_read(imu, out, 1, 100), 1);

    /* a single NACK is counted and ridden out */
    m->fail_next = 1;
    assert_int_equal(drv_imu_read(imu, out, 1, 100), 1);
    drv_imu_stats st;
    drv_imu_stats_get(imu, &st);
    assert_int_equal(st.read_errors, 1);
    assert_true(st.connected);

    /* unplugged: -ENODEV after a few failed transfers */
    m->absent = true;
    int rc = 0;
    for (int i = 0; i < 10 && rc >= 0; i++) rc = drv_imu_read(imu, out, 1, 10);
    assert_int_equal(rc, -ENODEV);
    drv_imu_stats_get(imu, &st);
    assert_false(st.connected);
    assert_true(st.read_errors >= 4);
    assert_non_null(strstr(st.last_error, "/dev/i2c-7 addr 0x68"));
    assert_non_null(strstr(st.last_error, "no ACK"));

    /* retried no more often than every 250 ms, and no call blocks far past its timeout */
    uint64_t reopens0 = m->reopens;
    int64_t t_lost = plat_now_ns(), worst = 0;
    while (plat_now_ns() - t_lost < 600 * PLAT_NS_PER_MS) {
        int64_t t0 = plat_now_ns();
        assert_int_equal(drv_imu_read(imu, out, 1, 10), -ENODEV);
        if (plat_now_ns() - t0 > worst) worst = plat_now_ns() - t0;
    }
    assert_true(m->reopens - reopens0 >= 1 && m->reopens - reopens0 <= 3);

    /* back: re-initialised (reset and the init sequence again) and delivering */
    m->absent = false;
    uint64_t resets0 = m->resets;
    int64_t end = plat_now_ns() + 1500 * PLAT_NS_PER_MS;
    rc = -ENODEV;
    while (rc != 1 && plat_now_ns() < end) {
        int64_t t0 = plat_now_ns();
        rc = drv_imu_read(imu, out, 1, 10);
        if (plat_now_ns() - t0 > worst) worst = plat_now_ns() - t0;
    }
    assert_int_equal(rc, 1);
    assert_true(worst < 90 * PLAT_NS_PER_MS); /* the 100 ms reset wait is spread over calls */
    assert_int_equal(m->resets, resets0 + 1);
    assert_float_equal(out[0].gyro[0], 0.5, 0.5 / 16.4 * DEG + 1e-12);
    drv_imu_stats_get(imu, &st);
    assert_true(st.connected);
    assert_int_equal(st.reconnects, 1);
    drv_imu_destroy(imu);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bus_split_long_reads),
        cmocka_unit_test(test_mpu6050_init_sequence),
        cmocka_unit_test(test_mpu9250_init_sequence),
        cmocka_unit_test(test_icm42688_init_sequence),
        cmocka_unit_test(test_scaling_mpu),
        cmocka_unit_test(test_scaling_icm42688),
        cmocka_unit_test(test_range_errors),
        cmocka_unit_test(test_burst_decode_mpu),
        cmocka_unit_test(test_burst_decode_icm),
        cmocka_unit_test(test_who_am_i_mismatch),
        cmocka_unit_test(test_nack),
        cmocka_unit_test(test_param_and_bus_errors),
        cmocka_unit_test(test_auto_detect),
        cmocka_unit_test(test_mock_sim_mpu9250),
        cmocka_unit_test(test_mock_sim_icm42688),
        cmocka_unit_test(test_saturation),
        cmocka_unit_test(test_invalid_and_missing_data),
        cmocka_unit_test(test_rate_and_timeout),
        cmocka_unit_test(test_recovery),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

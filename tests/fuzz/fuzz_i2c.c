/* SPDX-License-Identifier: MIT */
/* Fuzzes the I2C IMU chip drivers (drivers/drv_i2c_chips.c) against a bus whose registers answer with the input:
 * identification, the rate/range plan for a request taken from the input (any double, any range), the init writes
 * with read-back, data-ready and burst reads. Input: u8 chip (auto/6050/9250/42688), f64 rate_hz, u32 gyro_dps,
 * u32 accel_g, then the bytes every register read returns, in order (a byte 0xEE before a read: the bus fails it). */
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "drivers/drv_i2c_chips.h"
#include "tests/fuzz/fuzz.h"

typedef struct {
    drv_i2c_bus base;
    fuzz_in in;
} fuzz_bus;

static int bus_read(drv_i2c_bus *b, uint8_t reg, uint8_t *buf, int n)
{
    fuzz_bus *f = (fuzz_bus *)b;
    (void)reg;
    if (n < 1 || n > DRV_I2C_BLOCK_MAX) abort(); /* the drivers split bursts into SMBus blocks */
    if (f->in.n && f->in.p[0] == 0xEE) {
        fuzz_u8(&f->in);
        return -EREMOTEIO;
    }
    for (int i = 0; i < n; i++) buf[i] = fuzz_u8(&f->in);
    return 0;
}
static int bus_write(drv_i2c_bus *b, uint8_t reg, uint8_t val)
{
    (void)b, (void)reg, (void)val;
    return 0;
}
static void bus_destroy(drv_i2c_bus *b) { (void)b; }

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_bus bus = {{"fuzz bus", bus_read, bus_write, NULL, bus_destroy}, {data, size}};
    drv_i2c_chip_kind kind = (drv_i2c_chip_kind)(fuzz_u8(&bus.in) % DRV_I2C_CHIP_COUNT);
    drv_i2c_request rq = {fuzz_f64(&bus.in), (int)fuzz_u32(&bus.in), (int)fuzz_u32(&bus.in)};
    char err[256];
    const drv_i2c_chip *chip = NULL;
    if (drv_i2c_chip_identify(&bus.base, drv_i2c_chip_get(kind), &chip, err, sizeof err) < 0) return 0;
    drv_i2c_setup setup;
    if (drv_i2c_chip_plan(chip, &rq, &setup, err, sizeof err) < 0) return 0;
    /* A plan that was made is one the chip can run: a rate it has, finite scales, steps that fit. */
    if (!(setup.rate_hz > 0) || !(setup.rate_hz <= DRV_I2C_MAX_RATE_HZ) || !(setup.gyro_lsb_per_dps > 0) ||
        !(setup.accel_lsb_per_g > 0) || setup.n_steps < 1 || setup.n_steps > DRV_I2C_MAX_STEPS)
        abort();
    for (int i = 0; i < setup.n_steps; i++)
        if (drv_i2c_chip_step(&bus.base, &setup.steps[i], err, sizeof err) < 0) return 0;
    while (bus.in.n) {
        bool ready;
        if (drv_i2c_chip_data_ready(&bus.base, chip, &ready, err, sizeof err) < 0) continue;
        drv_i2c_sample s;
        if (drv_i2c_chip_read(&bus.base, chip, &setup, &s, &ready, NULL, NULL, err, sizeof err) < 0) continue;
        for (int k = 0; k < 3; k++)
            if (!isfinite(s.gyro[k]) || !isfinite(s.accel[k])) abort();
    }
    return 0;
}

/* The registers a chip answers with through identification, the verified init and two samples. */
static void seed_chip(const char *name, drv_i2c_chip_kind kind, double rate)
{
    uint8_t b[512];
    size_t n = 0;
    b[n++] = (uint8_t)kind;
    uint64_t r;
    memcpy(&r, &rate, 8);
    for (int i = 0; i < 8; i++) b[n++] = (uint8_t)(r >> (8 * i));
    for (int i = 0; i < 8; i++) b[n++] = 0; /* gyro_dps, accel_g 0: the widest ranges */
    const drv_i2c_chip *c = drv_i2c_chip_get(kind);
    b[n++] = c->who_am_i[0];
    drv_i2c_setup s;
    char err[256];
    drv_i2c_request rq = {rate, 0, 0};
    if (drv_i2c_chip_plan(c, &rq, &s, err, sizeof err) < 0) abort();
    for (int i = 0; i < s.n_steps; i++)
        if (s.steps[i].verify) b[n++] = s.steps[i].val;
    for (int k = 0; k < 2; k++) {
        b[n++] = c->ready_mask; /* data ready */
        for (int i = 0; i < c->data_len + 1; i++) b[n++] = (uint8_t)(i * 29 + k);
    }
    fuzz_seed(name, b, n);
}

void fuzz_write_seeds(void)
{
    seed_chip("mpu6050", DRV_I2C_CHIP_MPU6050, 500);
    seed_chip("mpu9250", DRV_I2C_CHIP_MPU9250, 1000);
    seed_chip("icm42688", DRV_I2C_CHIP_ICM42688, 200);
}

/* SPDX-License-Identifier: MIT */
/* drv_imu_i2c_mock: the mock bus below drv_imu_i2c (the drv_i2c_bus seam, what i2c-dev is on a board): SMBus
 * transfers on drv_i2c_chip_emu's register file, a transfer log and NACK injection for tests. */
#include "drivers/drv_imu_i2c_mock.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "drivers/drv_i2c_chip_emu.h"
#include "warp/warp_err.h"

static bool mock_is_mpu(const drv_i2c_mockbus *m) { return drv_i2c_emu_is_mpu(m->model); }

static void mock_defaults(drv_i2c_mockbus *m)
{
    drv_i2c_emu_reset_image(m->model, m->reg);
    m->have_sample = false;
}

/* Data registers from the latest source sample at the configured ranges, as the chip's ADC would fill them; the
 * status register's flags accumulate until read (it clears on read). */
static void mock_update_data(drv_i2c_mockbus *m)
{
    uint8_t blk[DRV_I2C_EMU_DATA_MAX];
    int lo, n = drv_i2c_emu_data_range(m->model, &lo);
    if (!drv_i2c_emu_data_block(m->model, m->reg, m->latest.gyro, m->latest.accel, 25.0, blk)) return;
    int st = mock_is_mpu(m) ? MPU_REG_INT_STATUS : ICM_REG_INT_STATUS;
    for (int i = 0; i < n; i++) {
        if (lo + i == st)
            m->reg[st] |= blk[i];
        else
            m->reg[lo + i] = blk[i];
    }
}

static void mock_poll_source(drv_i2c_mockbus *m)
{
    if (!m->source) return;
    drv_imu_sample buf[32];
    bool got = false;
    int n;
    do {
        n = drv_imu_read(m->source, buf, 32, 0);
        if (n > 0) {
            m->latest = buf[n - 1];
            m->samples_in += (uint64_t)n;
            got = true;
        }
    } while (n == 32);
    if (got) {
        m->have_sample = true;
        mock_update_data(m);
    }
}

static void mock_log(drv_i2c_mockbus *m, bool write, uint8_t reg, uint8_t val)
{
    if (m->n_log < DRV_I2C_MOCK_LOG) m->log[m->n_log] = (drv_i2c_mock_op){write, reg, val};
    m->n_log++;
}

static int mock_fail(drv_i2c_mockbus *m)
{
    m->transfers++;
    if (m->absent) return -ENXIO;
    if (m->fail_next > 0) {
        m->fail_next--;
        return -EREMOTEIO;
    }
    return 0;
}

static int mock_read_block(drv_i2c_bus *b, uint8_t reg, uint8_t *buf, int n)
{
    drv_i2c_mockbus *m = (drv_i2c_mockbus *)b;
    int rc = mock_fail(m);
    if (rc < 0) return rc;
    if (n < 1 || n > DRV_I2C_BLOCK_MAX || reg + n > 256) return -EINVAL; /* what SMBus cannot carry */
    mock_log(m, false, reg, (uint8_t)n);
    mock_poll_source(m);
    bool other_bank = !mock_is_mpu(m) && m->reg[ICM_REG_BANK_SEL] != 0;
    for (int i = 0; i < n; i++) {
        int r = reg + i;
        if (other_bank && r != ICM_REG_BANK_SEL) {
            buf[i] = 0; /* banks 1-4 are not emulated */
            continue;
        }
        buf[i] = m->reg[r];
        if (r == MPU_REG_WHO_AM_I && m->who_am_i >= 0) buf[i] = (uint8_t)m->who_am_i;
    }
    /* INT_STATUS clears on read (both families' default). */
    uint8_t st = mock_is_mpu(m) ? MPU_REG_INT_STATUS : ICM_REG_INT_STATUS;
    if (!other_bank && st >= reg && st < reg + n) m->reg[st] = 0;
    return 0;
}

static int mock_write_byte(drv_i2c_bus *b, uint8_t reg, uint8_t val)
{
    drv_i2c_mockbus *m = (drv_i2c_mockbus *)b;
    int rc = mock_fail(m);
    if (rc < 0) return rc;
    mock_log(m, true, reg, val);
    if (mock_is_mpu(m)) {
        if (reg == MPU_REG_PWR_MGMT_1 && (val & MPU_PWR1_DEVICE_RESET)) {
            mock_defaults(m); /* DEVICE_RESET self-clears; registers back to power-on values */
            m->resets++;
            return 0;
        }
        if ((reg >= MPU_REG_INT_STATUS && reg <= MPU_REG_GYRO_ZOUT_L) || reg == MPU_REG_WHO_AM_I) return 0; /* RO */
    } else {
        if (reg == ICM_REG_BANK_SEL) {
            m->reg[reg] = val & 7;
            return 0;
        }
        if (m->reg[ICM_REG_BANK_SEL] != 0) return 0;
        if (reg == ICM_REG_DEVICE_CONFIG && (val & ICM_DEVICE_CONFIG_SOFT_RESET)) {
            mock_defaults(m);
            m->resets++;
            return 0;
        }
        if ((reg >= ICM_REG_TEMP_DATA1 && reg <= ICM_REG_INT_STATUS) || reg == ICM_REG_WHO_AM_I) return 0;
    }
    m->reg[reg] = val;
    return 0;
}

static int mock_reopen(drv_i2c_bus *b)
{
    drv_i2c_mockbus *m = (drv_i2c_mockbus *)b;
    m->reopens++;
    return 0; /* a bus node that stays; a missing chip shows at the first transfer */
}

static void mock_destroy(drv_i2c_bus *b)
{
    drv_i2c_mockbus *m = (drv_i2c_mockbus *)b;
    drv_imu_destroy(m->source);
    free(m);
}

drv_i2c_mockbus *drv_i2c_mockbus_create(drv_i2c_chip_kind model, int addr, drv_imu *source)
{
    drv_i2c_mockbus *m = drv_i2c_chip_get(model) ? calloc(1, sizeof *m) : NULL;
    if (!m) {
        drv_imu_destroy(source);
        return NULL;
    }
    m->model = model;
    m->who_am_i = -1;
    m->source = source;
    snprintf(m->name, sizeof m->name, "mock addr 0x%02x", addr);
    m->bus = (drv_i2c_bus){m->name, mock_read_block, mock_write_byte, mock_reopen, mock_destroy};
    mock_defaults(m);
    return m;
}

void drv_i2c_mockbus_set_ready(drv_i2c_mockbus *m)
{
    if (mock_is_mpu(m))
        m->reg[MPU_REG_INT_STATUS] |= MPU_INT_STATUS_DATA_RDY;
    else
        m->reg[ICM_REG_INT_STATUS] |= ICM_INT_STATUS_DATA_RDY;
}

int drv_i2c_mockbus_write_at(const drv_i2c_mockbus *m, int idx, uint8_t *reg, uint8_t *val)
{
    int n = m->n_log < DRV_I2C_MOCK_LOG ? m->n_log : DRV_I2C_MOCK_LOG;
    for (int i = 0, k = 0; i < n; i++) {
        if (!m->log[i].write) continue;
        if (k++ == idx) {
            *reg = m->log[i].reg;
            *val = m->log[i].val;
            return 0;
        }
    }
    return -1;
}

drv_imu *drv_imu_i2c_create_mock(drv_imu *source, const drv_imu_i2c_params *p, char *err, int errlen)
{
    /* An unknown chip name is refused by drv_imu_i2c_create_on_bus with the backend's own message. */
    if (!p) {
        drv_imu_destroy(source);
        warp_err(err, errlen, "i2c imu: no parameters");
        return NULL;
    }
    drv_i2c_chip_kind kind;
    if (!drv_i2c_chip_parse(p->chip, &kind) || kind == DRV_I2C_CHIP_AUTO) kind = DRV_I2C_CHIP_MPU6050;
    drv_i2c_mockbus *m = drv_i2c_mockbus_create(kind, p->addr, source);
    if (!m) {
        warp_err(err, errlen, "%s addr 0x%02x: out of memory", p->bus, p->addr);
        return NULL;
    }
    snprintf(m->name, sizeof m->name, "%s addr 0x%02x (mock)", p->bus[0] ? p->bus : "mock", p->addr);
    return drv_imu_i2c_create_on_bus(&m->bus, p, err, errlen);
}

drv_i2c_mockbus *drv_imu_i2c_mockbus(drv_imu *imu)
{
    drv_i2c_bus *b = drv_imu_i2c_bus(imu);
    return b && b->read_block == mock_read_block ? (drv_i2c_mockbus *)b : NULL;
}

/* SPDX-License-Identifier: MIT */
/* drv_i2c_chips: register-level drivers for I2C IMUs (InvenSense MPU-6050, MPU-9250/9255, TDK ICM-42688-P) on top of
 * a minimal register bus interface, so the same init sequence, burst read and scaling run on i2c-dev and on the mock. */
#include "drivers/drv_i2c_chips.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "platform/plat_clock.h"
#include "warp/warp_err.h"

#define DEG2RAD (3.14159265358979323846 / 180.0)

const char *drv_i2c_strerror(int neg_errno)
{
    switch (-neg_errno) {
    case ENXIO:
    case EREMOTEIO:
    case ENODEV: return "no ACK"; /* ENODEV: i2c-stub for an address it does not emulate */
    case ETIMEDOUT: return "bus timeout";
    case EAGAIN: return "arbitration lost / bus busy";
    default: return strerror(-neg_errno);
    }
}

/* ---- range tables (datasheet sensitivities), ascending full scale ---- */

typedef struct {
    double fs;   /* +- full scale (deg/s or g) */
    uint8_t code; /* register field value */
    double lsb;  /* LSB per deg/s or per g */
} range;

static const range mpu_gyro[] = {{250, 0, 131.0}, {500, 1, 65.5}, {1000, 2, 32.8}, {2000, 3, 16.4}};
static const range mpu_accel[] = {{2, 0, 16384}, {4, 1, 8192}, {8, 2, 4096}, {16, 3, 2048}};
static const range icm_gyro[] = {{15.625, 7, 2097.2}, {31.25, 6, 1048.6}, {62.5, 5, 524.3}, {125, 4, 262.0},
                                 {250, 3, 131.0},     {500, 2, 65.5},    {1000, 1, 32.8}, {2000, 0, 16.4}};
static const range icm_accel[] = {{2, 3, 16384}, {4, 2, 8192}, {8, 1, 4096}, {16, 0, 2048}};

#define N(a) ((int)(sizeof(a) / sizeof((a)[0])))

/* The smallest range covering the request (so nothing asked for clips); <= 0 asks for the largest. */
static const range *pick_range(const range *t, int n, int want, const char *what, const char *unit,
                               const char *model, char *err, int errlen)
{
    if (want <= 0) return &t[n - 1];
    for (int i = 0; i < n; i++)
        if (t[i].fs >= want) return &t[i];
    warp_err(err, errlen, "%s %d exceeds the %s maximum of +-%g %s", what, want, model, t[n - 1].fs, unit);
    return NULL;
}

/* Low-pass settings: DLPF_CFG value and its bandwidth, widest first. */
typedef struct {
    uint8_t cfg;
    double bw_hz;
} dlpf;

static const dlpf mpu6050_dlpf[] = {{1, 188}, {2, 98}, {3, 42}, {4, 20}, {5, 10}, {6, 5}};
static const dlpf mpu9250_gyro_dlpf[] = {{1, 184}, {2, 92}, {3, 41}, {4, 20}, {5, 10}, {6, 5}};
static const dlpf mpu9250_accel_dlpf[] = {{1, 218.1}, {2, 99}, {3, 44.8}, {4, 21.2}, {5, 10.2}, {6, 5.05}};

/* Widest bandwidth below the Nyquist frequency of the sample rate (no aliasing of head motion noise). */
static const dlpf *pick_dlpf(const dlpf *t, int n, double rate_hz)
{
    for (int i = 0; i < n; i++)
        if (t[i].bw_hz <= rate_hz / 2) return &t[i];
    return &t[n - 1];
}

static bool rate_ok(const drv_i2c_request *rq, const char *model, char *err, int errlen)
{
    if (!(rq->rate_hz > 0) || !isfinite(rq->rate_hz)) {
        warp_err(err, errlen, "%s: rate_hz %g is not a positive rate", model, rq->rate_hz);
        return false;
    }
    return true;
}

static void add_step(drv_i2c_setup *s, uint8_t reg, uint8_t val, bool verify, int delay_ms, const char *what)
{
    if (s->n_steps >= DRV_I2C_MAX_STEPS) return; /* tables below stay well under the limit */
    s->steps[s->n_steps++] = (drv_i2c_step){reg, val, verify, (uint16_t)delay_ms, what};
}

/* ---- MPU-6050 / MPU-9250 ---- */

static int mpu_plan(const drv_i2c_request *rq, drv_i2c_setup *s, bool is9250, char *err, int errlen)
{
    const char *model = is9250 ? "MPU-9250" : "MPU-6050";
    if (!rate_ok(rq, model, err, errlen)) return -EINVAL;
    const range *g = pick_range(mpu_gyro, N(mpu_gyro), rq->gyro_dps, "gyro_dps", "deg/s", model, err, errlen);
    if (!g) return -EINVAL;
    const range *a = pick_range(mpu_accel, N(mpu_accel), rq->accel_g, "accel_g", "g", model, err, errlen);
    if (!a) return -EINVAL;
    /* With the DLPF on, the internal rate is 1 kHz and sample rate = 1 kHz / (1 + SMPLRT_DIV). */
    double want = rq->rate_hz > DRV_I2C_MAX_RATE_HZ ? DRV_I2C_MAX_RATE_HZ : rq->rate_hz;
    /* Clamped as a double first: 1000 / a tiny rate does not fit a long (lround's result is then unspecified and
     * the - 1 overflowed). */
    double q = 1000.0 / want;
    long div = q >= 256.0 ? 255 : lround(q) - 1;
    if (div < 0) div = 0;
    memset(s, 0, sizeof *s);
    s->rate_hz = 1000.0 / (double)(1 + div);
    const dlpf *gd = is9250 ? pick_dlpf(mpu9250_gyro_dlpf, N(mpu9250_gyro_dlpf), s->rate_hz)
                            : pick_dlpf(mpu6050_dlpf, N(mpu6050_dlpf), s->rate_hz);
    s->gyro_fs_dps = g->fs;
    s->accel_fs_g = a->fs;
    s->gyro_lsb_per_dps = g->lsb;
    s->accel_lsb_per_g = a->lsb;
    s->filter_hz = gd->bw_hz;

    /* Reset to known defaults, then wake with the PLL clock (more stable than the internal oscillator). */
    add_step(s, MPU_REG_PWR_MGMT_1, MPU_PWR1_DEVICE_RESET, false, MPU_RESET_MS, "PWR_MGMT_1");
    add_step(s, MPU_REG_PWR_MGMT_1, MPU_PWR1_CLKSEL_PLL, true, 0, "PWR_MGMT_1");
    add_step(s, MPU_REG_PWR_MGMT_2, 0x00, true, 0, "PWR_MGMT_2"); /* all six axes on */
    add_step(s, MPU_REG_CONFIG, gd->cfg, true, 0, "CONFIG");
    add_step(s, MPU_REG_SMPLRT_DIV, (uint8_t)div, true, 0, "SMPLRT_DIV");
    add_step(s, MPU_REG_GYRO_CONFIG, (uint8_t)(g->code << 3), true, 0, "GYRO_CONFIG");
    add_step(s, MPU_REG_ACCEL_CONFIG, (uint8_t)(a->code << 3), true, 0, "ACCEL_CONFIG");
    if (is9250) {
        const dlpf *ad = pick_dlpf(mpu9250_accel_dlpf, N(mpu9250_accel_dlpf), s->rate_hz);
        add_step(s, MPU9250_REG_ACCEL_CONFIG2, ad->cfg, true, 0, "ACCEL_CONFIG2");
    }
    /* DATA_RDY_INT in INT_STATUS only sets when the interrupt is enabled. */
    add_step(s, MPU_REG_INT_ENABLE, MPU_INT_DATA_RDY_EN, true, MPU_GYRO_STARTUP_MS, "INT_ENABLE");
    return 0;
}

static int mpu6050_plan(const drv_i2c_request *rq, drv_i2c_setup *s, char *err, int errlen)
{
    return mpu_plan(rq, s, false, err, errlen);
}
static int mpu9250_plan(const drv_i2c_request *rq, drv_i2c_setup *s, char *err, int errlen)
{
    return mpu_plan(rq, s, true, err, errlen);
}

/* ---- ICM-42688-P ---- */

typedef struct {
    double hz;
    uint8_t code;
} odr;

static const odr icm_odrs[] = {{12.5, ICM_ODR_12_5HZ}, {25, ICM_ODR_25HZ},   {50, ICM_ODR_50HZ}, {100, ICM_ODR_100HZ},
                               {200, ICM_ODR_200HZ},   {500, ICM_ODR_500HZ}, {1000, ICM_ODR_1KHZ}};

static int icm42688_plan(const drv_i2c_request *rq, drv_i2c_setup *s, char *err, int errlen)
{
    const char *model = "ICM-42688-P";
    if (!rate_ok(rq, model, err, errlen)) return -EINVAL;
    const range *g = pick_range(icm_gyro, N(icm_gyro), rq->gyro_dps, "gyro_dps", "deg/s", model, err, errlen);
    if (!g) return -EINVAL;
    const range *a = pick_range(icm_accel, N(icm_accel), rq->accel_g, "accel_g", "g", model, err, errlen);
    if (!a) return -EINVAL;
    /* Nearest ODR on a log scale. */
    const odr *o = &icm_odrs[0];
    for (int i = 1; i < N(icm_odrs); i++)
        if (fabs(log(icm_odrs[i].hz / rq->rate_hz)) < fabs(log(o->hz / rq->rate_hz))) o = &icm_odrs[i];
    memset(s, 0, sizeof *s);
    s->rate_hz = o->hz;
    s->gyro_fs_dps = g->fs;
    s->accel_fs_g = a->fs;
    s->gyro_lsb_per_dps = g->lsb;
    s->accel_lsb_per_g = a->lsb;
    s->filter_hz = o->hz / 4; /* GYRO_ACCEL_CONFIG0 reset value: UI filter bandwidth ODR/4 */

    add_step(s, ICM_REG_BANK_SEL, 0, true, 0, "REG_BANK_SEL");
    add_step(s, ICM_REG_DEVICE_CONFIG, ICM_DEVICE_CONFIG_SOFT_RESET, false, ICM_RESET_MS, "DEVICE_CONFIG");
    /* Configure while the sensors are still off (reset state), then power them up last: after PWR_MGMT0 leaves
     * OFF the datasheet forbids register writes for 200 us, and the gyro needs tens of ms to start. */
    add_step(s, ICM_REG_GYRO_CONFIG0, (uint8_t)(g->code << 5 | o->code), true, 0, "GYRO_CONFIG0");
    add_step(s, ICM_REG_ACCEL_CONFIG0, (uint8_t)(a->code << 5 | o->code), true, 0, "ACCEL_CONFIG0");
    add_step(s, ICM_REG_INT_SOURCE0, ICM_INT_SOURCE0_RESET_DONE_INT1_EN | ICM_INT_SOURCE0_UI_DRDY_INT1_EN, true, 0,
             "INT_SOURCE0");
    add_step(s, ICM_REG_PWR_MGMT0, ICM_PWR_GYRO_LN | ICM_PWR_ACCEL_LN, true, ICM_GYRO_STARTUP_MS, "PWR_MGMT0");
    return 0;
}

/* ---- the chip table ---- */

/* The MPU-9250 keeps the MPU-6050's registers for the data-ready flag and the 14-byte burst (accel, temp, gyro):
 * one definition, so the two entries cannot drift apart. */
#define MPU_DATA_REGISTERS                                                                                         \
    .status_reg = MPU_REG_INT_STATUS, .ready_mask = MPU_INT_STATUS_DATA_RDY, .data_reg = MPU_REG_ACCEL_XOUT_H,      \
    .data_len = MPU_REG_GYRO_ZOUT_L - MPU_REG_ACCEL_XOUT_H + 1, .accel_off = 0,                                    \
    .temp_off = MPU_REG_TEMP_OUT_H - MPU_REG_ACCEL_XOUT_H, .gyro_off = MPU_REG_GYRO_XOUT_H - MPU_REG_ACCEL_XOUT_H

static const drv_i2c_chip chips[DRV_I2C_CHIP_COUNT] = {
    [DRV_I2C_CHIP_MPU6050] = {
        .kind = DRV_I2C_CHIP_MPU6050, .name = "mpu6050", .model = "MPU-6050",
        .who_am_i_reg = MPU_REG_WHO_AM_I, .who_am_i = {MPU6050_WHO_AM_I}, .n_who_am_i = 1,
        MPU_DATA_REGISTERS,
        .temp_lsb_per_c = 340.0, .temp_offset_c = 36.53,
        .plan = mpu6050_plan,
    },
    [DRV_I2C_CHIP_MPU9250] = {
        .kind = DRV_I2C_CHIP_MPU9250, .name = "mpu9250", .model = "MPU-9250",
        .who_am_i_reg = MPU_REG_WHO_AM_I, .who_am_i = {MPU9250_WHO_AM_I, MPU9255_WHO_AM_I}, .n_who_am_i = 2,
        MPU_DATA_REGISTERS,
        .temp_lsb_per_c = 333.87, .temp_offset_c = 21.0,
        .plan = mpu9250_plan,
    },
    [DRV_I2C_CHIP_ICM42688] = {
        .kind = DRV_I2C_CHIP_ICM42688, .name = "icm42688", .model = "ICM-42688-P",
        .who_am_i_reg = ICM_REG_WHO_AM_I, .who_am_i = {ICM42688_WHO_AM_I}, .n_who_am_i = 1,
        .bank_sel_reg = ICM_REG_BANK_SEL,
        .status_reg = ICM_REG_INT_STATUS, .ready_mask = ICM_INT_STATUS_DATA_RDY,
        .data_reg = ICM_REG_TEMP_DATA1, .data_len = ICM_REG_GYRO_DATA_Z0 - ICM_REG_TEMP_DATA1 + 1,
        .temp_off = 0, .accel_off = ICM_REG_ACCEL_DATA_X1 - ICM_REG_TEMP_DATA1,
        .gyro_off = ICM_REG_GYRO_DATA_X1 - ICM_REG_TEMP_DATA1,
        .temp_lsb_per_c = 132.48, .temp_offset_c = 25.0,
        .invalid_marker = true,
        .plan = icm42688_plan,
    },
};

const drv_i2c_chip *drv_i2c_chip_get(drv_i2c_chip_kind kind)
{
    if (kind <= DRV_I2C_CHIP_AUTO || kind >= DRV_I2C_CHIP_COUNT) return NULL;
    return &chips[kind];
}

bool drv_i2c_chip_parse(const char *name, drv_i2c_chip_kind *kind)
{
    if (!name) return false;
    if (!strcmp(name, "auto") || !name[0]) {
        *kind = DRV_I2C_CHIP_AUTO;
        return true;
    }
    for (int k = DRV_I2C_CHIP_AUTO + 1; k < DRV_I2C_CHIP_COUNT; k++)
        if (!strcmp(name, chips[k].name)) {
            *kind = (drv_i2c_chip_kind)k;
            return true;
        }
    return false;
}

static bool who_matches(const drv_i2c_chip *c, uint8_t who)
{
    for (int i = 0; i < c->n_who_am_i; i++)
        if (c->who_am_i[i] == who) return true;
    return false;
}

const drv_i2c_chip *drv_i2c_chip_by_who_am_i(uint8_t who)
{
    for (int k = DRV_I2C_CHIP_AUTO + 1; k < DRV_I2C_CHIP_COUNT; k++)
        if (who_matches(&chips[k], who)) return &chips[k];
    return NULL;
}

static void who_list(const drv_i2c_chip *c, char *buf, size_t n)
{
    buf[0] = 0;
    for (int i = 0; i < c->n_who_am_i; i++) {
        size_t l = strlen(buf);
        snprintf(buf + l, n - l, "%s0x%02x", i ? "/" : "", c->who_am_i[i]);
    }
}

int drv_i2c_chip_identify(drv_i2c_bus *bus, const drv_i2c_chip *expect, const drv_i2c_chip **found, char *err,
                          int errlen)
{
    /* A banked chip left in another bank by an earlier user would show a different register at 0x75. Only done
     * when the chip is known: on an unknown device the bank register may be something else. */
    if (expect && expect->bank_sel_reg) {
        int rc = drv_i2c_write(bus, expect->bank_sel_reg, 0);
        if (rc < 0) {
            warp_err(err, errlen, "%s: %s writing REG_BANK_SEL (reg 0x%02x)", bus->name, drv_i2c_strerror(rc),
                     expect->bank_sel_reg);
            return rc;
        }
    }
    uint8_t who = 0;
    int rc = drv_i2c_read(bus, MPU_REG_WHO_AM_I, &who, 1);
    if (rc < 0) {
        warp_err(err, errlen, "%s: %s reading WHO_AM_I (reg 0x%02x)%s", bus->name, drv_i2c_strerror(rc),
                 MPU_REG_WHO_AM_I,
                 rc == -ENXIO || rc == -EREMOTEIO || rc == -ENODEV ? " - nothing at this address? check wiring, power and AD0" : "");
        return rc;
    }
    const drv_i2c_chip *c = drv_i2c_chip_by_who_am_i(who);
    if (!expect) {
        if (!c) {
            warp_err(err, errlen,
                     "%s: WHO_AM_I (reg 0x75) 0x%02x matches no supported chip (MPU-6050 0x68, MPU-9250 0x71/0x73, "
                     "ICM-42688-P 0x47)",
                     bus->name, who);
            return -ENODEV;
        }
    } else if (!who_matches(expect, who)) {
        char exp[32];
        who_list(expect, exp, sizeof exp);
        if (c)
            warp_err(err, errlen,
                     "%s: WHO_AM_I (reg 0x75) 0x%02x is not an %s (expected %s); it looks like an %s: set chip = %s "
                     "or auto",
                     bus->name, who, expect->model, exp, c->model, c->name);
        else
            warp_err(err, errlen, "%s: WHO_AM_I (reg 0x75) 0x%02x is not an %s (expected %s)", bus->name, who,
                     expect->model, exp);
        return -ENODEV;
    } else {
        c = expect;
    }
    if (found) *found = c;
    return 0;
}

int drv_i2c_chip_plan(const drv_i2c_chip *chip, const drv_i2c_request *rq, drv_i2c_setup *out, char *err,
                      int errlen)
{
    return chip->plan(rq, out, err, errlen);
}

int drv_i2c_chip_step(drv_i2c_bus *bus, const drv_i2c_step *st, char *err, int errlen)
{
    int rc = drv_i2c_write(bus, st->reg, st->val);
    if (rc < 0) {
        warp_err(err, errlen, "%s: %s writing %s (reg 0x%02x) = 0x%02x", bus->name, drv_i2c_strerror(rc),
                 st->what, st->reg, st->val);
        return rc;
    }
    if (!st->verify) return 0;
    uint8_t back = 0;
    rc = drv_i2c_read(bus, st->reg, &back, 1);
    if (rc < 0) {
        warp_err(err, errlen, "%s: %s reading back %s (reg 0x%02x)", bus->name, drv_i2c_strerror(rc),
                 st->what, st->reg);
        return rc;
    }
    if (back != st->val) {
        warp_err(err, errlen, "%s: %s (reg 0x%02x) reads 0x%02x after writing 0x%02x", bus->name, st->what,
                 st->reg, back, st->val);
        return -EIO;
    }
    return 0;
}

int drv_i2c_chip_init(drv_i2c_bus *bus, const drv_i2c_setup *setup, char *err, int errlen)
{
    for (int i = 0; i < setup->n_steps; i++) {
        int rc = drv_i2c_chip_step(bus, &setup->steps[i], err, errlen);
        if (rc < 0) return rc;
        if (setup->steps[i].delay_ms) plat_sleep_ns((int64_t)setup->steps[i].delay_ms * PLAT_NS_PER_MS);
    }
    return 0;
}

int drv_i2c_chip_data_ready(drv_i2c_bus *bus, const drv_i2c_chip *chip, bool *ready, char *err, int errlen)
{
    uint8_t st = 0;
    int rc = drv_i2c_read(bus, chip->status_reg, &st, 1);
    if (rc < 0) {
        warp_err(err, errlen, "%s: %s reading INT_STATUS (reg 0x%02x)", bus->name, drv_i2c_strerror(rc),
                 chip->status_reg);
        return rc;
    }
    *ready = (st & chip->ready_mask) != 0;
    return 0;
}

static int16_t be16(const uint8_t *p) { return (int16_t)(uint16_t)((unsigned)p[0] << 8 | p[1]); }

void drv_i2c_chip_decode(const drv_i2c_chip *chip, const drv_i2c_setup *setup, const uint8_t *burst,
                         drv_i2c_sample *out)
{
    memset(out, 0, sizeof *out);
    double gs = DEG2RAD / setup->gyro_lsb_per_dps, as = DRV_I2C_G / setup->accel_lsb_per_g;
    bool a_inv = true, g_inv = true;
    for (int i = 0; i < 3; i++) {
        out->raw_accel[i] = be16(burst + chip->accel_off + 2 * i);
        out->raw_gyro[i] = be16(burst + chip->gyro_off + 2 * i);
        a_inv &= out->raw_accel[i] == INT16_MIN;
        g_inv &= out->raw_gyro[i] == INT16_MIN;
        out->accel[i] = out->raw_accel[i] * as;
        out->gyro[i] = out->raw_gyro[i] * gs;
    }
    out->raw_temp = be16(burst + chip->temp_off);
    out->temp_c = out->raw_temp / chip->temp_lsb_per_c + chip->temp_offset_c;
    out->valid = !(chip->invalid_marker && (a_inv || g_inv));
}

int drv_i2c_chip_read(drv_i2c_bus *bus, const drv_i2c_chip *chip, const drv_i2c_setup *setup, drv_i2c_sample *out,
                      bool *ready, int64_t *t0_ns, int64_t *t1_ns, char *err, int errlen)
{
    uint8_t buf[64];
    /* INT_STATUS right before the data (MPU: 0x3A, 0x3B..): flag and data in one transfer. */
    bool joined = chip->status_reg + 1 == chip->data_reg;
    uint8_t reg = joined ? chip->status_reg : chip->data_reg;
    int len = chip->data_len + (joined ? 1 : 0);
    int64_t t0 = plat_now_ns();
    int rc = drv_i2c_read(bus, reg, buf, len);
    int64_t t1 = plat_now_ns();
    if (rc < 0) {
        warp_err(err, errlen, "%s: %s burst-reading regs 0x%02x..0x%02x", bus->name, drv_i2c_strerror(rc),
                 reg, reg + len - 1);
        return rc;
    }
    if (t0_ns) *t0_ns = t0;
    if (t1_ns) *t1_ns = t1;
    *ready = joined ? (buf[0] & chip->ready_mask) != 0 : true;
    drv_i2c_chip_decode(chip, setup, joined ? buf + 1 : buf, out);
    return 0;
}

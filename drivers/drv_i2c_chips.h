/* SPDX-License-Identifier: MIT */
/* drv_i2c_chips: register-level drivers for I2C IMUs (InvenSense MPU-6050, MPU-9250/9255, TDK ICM-42688-P) on top of
 * a minimal register bus interface, so the same init sequence, burst read and scaling run on i2c-dev and on the mock. */
#ifndef DRV_I2C_CHIPS_H
#define DRV_I2C_CHIPS_H

#include <stdbool.h>
#include <stdint.h>

/* ---- register bus ---- */

/* Largest SMBus I2C-block transfer; longer bursts are split by drv_i2c_read(). */
#define DRV_I2C_BLOCK_MAX 32

typedef struct drv_i2c_bus drv_i2c_bus;
struct drv_i2c_bus {
    const char *name; /* "/dev/i2c-1 addr 0x68", for messages */
    /* Reads n (1..DRV_I2C_BLOCK_MAX) consecutive registers from reg; 0 or a negative errno. */
    int (*read_block)(drv_i2c_bus *b, uint8_t reg, uint8_t *buf, int n);
    /* Writes one register; 0 or a negative errno. */
    int (*write_byte)(drv_i2c_bus *b, uint8_t reg, uint8_t val);
    /* Optional (NULL: nothing to do): reopens the transport before a re-initialisation. 0 or a negative errno. */
    int (*reopen)(drv_i2c_bus *b);
    void (*destroy)(drv_i2c_bus *b);
};

/* Reads n registers from reg in transfers of at most DRV_I2C_BLOCK_MAX bytes. 0 or a negative errno. */
static inline int drv_i2c_read(drv_i2c_bus *b, uint8_t reg, uint8_t *buf, int n)
{
    for (int off = 0; off < n; off += DRV_I2C_BLOCK_MAX) {
        int len = n - off < DRV_I2C_BLOCK_MAX ? n - off : DRV_I2C_BLOCK_MAX;
        int rc = b->read_block(b, (uint8_t)(reg + off), buf + off, len);
        if (rc < 0) return rc;
    }
    return 0;
}
static inline int drv_i2c_write(drv_i2c_bus *b, uint8_t reg, uint8_t val) { return b->write_byte(b, reg, val); }
static inline void drv_i2c_bus_destroy(drv_i2c_bus *b)
{
    if (b) b->destroy(b);
}
/* Short reason for a bus errno: "no ACK" for ENXIO/EREMOTEIO/ENODEV, "bus timeout", else strerror. */
const char *drv_i2c_strerror(int neg_errno);

/* ---- chips ---- */

#define DRV_I2C_G 9.80665 /* m/s^2 per g (the datasheets' g) */

typedef enum {
    DRV_I2C_CHIP_AUTO = 0,
    DRV_I2C_CHIP_MPU6050,
    DRV_I2C_CHIP_MPU9250, /* also MPU-9255 */
    DRV_I2C_CHIP_ICM42688,
    DRV_I2C_CHIP_COUNT
} drv_i2c_chip_kind;

/* One register write of an init sequence, optionally read back, then a pause. */
typedef struct {
    uint8_t reg, val;
    bool verify;       /* read back and compare (not for self-clearing reset bits) */
    uint16_t delay_ms; /* wait after the write (reset, start-up) */
    const char *what;  /* register name for messages */
} drv_i2c_step;

#define DRV_I2C_MAX_STEPS 16

/* What the caller asks for. rate_hz > 0; gyro_dps / accel_g <= 0 pick the largest range. */
typedef struct {
    double rate_hz;
    int gyro_dps;
    int accel_g;
} drv_i2c_request;

/* What the chip is set to (the nearest supported rate, the smallest range covering the request) and how. */
typedef struct {
    double rate_hz;           /* output data rate */
    double gyro_fs_dps;       /* full scale, +- */
    double accel_fs_g;
    double gyro_lsb_per_dps;  /* datasheet sensitivity at that range */
    double accel_lsb_per_g;
    double filter_hz;         /* gyro low-pass bandwidth (MPU DLPF; ICM: ODR/4 UI filter default) */
    drv_i2c_step steps[DRV_I2C_MAX_STEPS];
    int n_steps;
} drv_i2c_setup;

/* One decoded sample in the chip's axis frame. */
typedef struct {
    int16_t raw_accel[3], raw_gyro[3], raw_temp;
    double gyro[3];  /* rad/s */
    double accel[3]; /* m/s^2, specific force */
    double temp_c;
    bool valid;      /* false: the chip marked the data invalid (ICM-42688 -32768: sensor off / not ready) */
} drv_i2c_sample;

typedef struct drv_i2c_chip {
    drv_i2c_chip_kind kind;
    const char *name;  /* config name: "mpu6050" */
    const char *model; /* datasheet name: "MPU-6050" */
    uint8_t who_am_i_reg;
    uint8_t who_am_i[2]; /* accepted WHO_AM_I values */
    int n_who_am_i;
    uint8_t bank_sel_reg; /* written 0 before identification when the chip has register banks; 0: none */
    uint8_t status_reg, ready_mask; /* data-ready flag (cleared on read) */
    uint8_t data_reg, data_len;     /* burst: temperature, accelerometer, gyroscope, big-endian int16 */
    uint8_t accel_off, gyro_off, temp_off; /* byte offsets in the burst */
    double temp_lsb_per_c, temp_offset_c;  /* temp_c = raw / temp_lsb_per_c + temp_offset_c */
    bool invalid_marker; /* -32768 on all three axes means "no data" */
    int (*plan)(const drv_i2c_request *rq, drv_i2c_setup *out, char *err, int errlen);
} drv_i2c_chip;

/* NULL for DRV_I2C_CHIP_AUTO / out of range. */
const drv_i2c_chip *drv_i2c_chip_get(drv_i2c_chip_kind kind);
/* By config name ("mpu6050", "mpu9250", "icm42688"); false for an unknown name. "auto" gives *kind = AUTO. */
bool drv_i2c_chip_parse(const char *name, drv_i2c_chip_kind *kind);
/* The chip answering `who` at WHO_AM_I (0x75 on all three), or NULL. */
const drv_i2c_chip *drv_i2c_chip_by_who_am_i(uint8_t who);

/* Reads WHO_AM_I; with expect == NULL finds the chip, else checks it is `expect`. 0, or a negative errno with a
 * message naming the bus, the register and what was found. */
int drv_i2c_chip_identify(drv_i2c_bus *bus, const drv_i2c_chip *expect, const drv_i2c_chip **found, char *err,
                          int errlen);
/* Chooses ranges, rate and filter and lists the init writes. 0 or -EINVAL with a message. */
int drv_i2c_chip_plan(const drv_i2c_chip *chip, const drv_i2c_request *rq, drv_i2c_setup *out, char *err,
                      int errlen);
/* One init step: write (and verify). 0 or a negative errno (-EIO when the read-back differs) with a message. */
int drv_i2c_chip_step(drv_i2c_bus *bus, const drv_i2c_step *st, char *err, int errlen);
/* Runs all steps with their pauses (blocking). */
int drv_i2c_chip_init(drv_i2c_bus *bus, const drv_i2c_setup *setup, char *err, int errlen);
/* Reads the data-ready flag (clears it on the chip). */
int drv_i2c_chip_data_ready(drv_i2c_bus *bus, const drv_i2c_chip *chip, bool *ready, char *err, int errlen);
/* Burst-reads the data registers (and, where INT_STATUS directly precedes them, the flag in the same transfer;
 * otherwise *ready is left true). t0_ns/t1_ns (may be NULL) bracket the data transfer. */
int drv_i2c_chip_read(drv_i2c_bus *bus, const drv_i2c_chip *chip, const drv_i2c_setup *setup, drv_i2c_sample *out,
                      bool *ready, int64_t *t0_ns, int64_t *t1_ns, char *err, int errlen);
/* Decodes a burst of chip->data_len bytes (big-endian int16) and scales it to SI. */
void drv_i2c_chip_decode(const drv_i2c_chip *chip, const drv_i2c_setup *setup, const uint8_t *burst,
                         drv_i2c_sample *out);

/* ---- register maps (datasheet names and addresses) ---- */

/* InvenSense MPU-6050 (RM-MPU-6000A) and MPU-9250 (RM-MPU-9250A) */
#define MPU_REG_SMPLRT_DIV 0x19
#define MPU_REG_CONFIG 0x1A        /* DLPF_CFG [2:0] */
#define MPU_REG_GYRO_CONFIG 0x1B   /* FS_SEL [4:3]; MPU-9250 FCHOICE_B [1:0] = 0 */
#define MPU_REG_ACCEL_CONFIG 0x1C  /* AFS_SEL [4:3] */
#define MPU9250_REG_ACCEL_CONFIG2 0x1D /* ACCEL_FCHOICE_B [3] = 0, A_DLPF_CFG [2:0] */
#define MPU_REG_INT_PIN_CFG 0x37
#define MPU_REG_INT_ENABLE 0x38
#define MPU_INT_DATA_RDY_EN 0x01
#define MPU_REG_INT_STATUS 0x3A
#define MPU_INT_STATUS_DATA_RDY 0x01
#define MPU_REG_ACCEL_XOUT_H 0x3B  /* .. ACCEL_ZOUT_L 0x40, TEMP_OUT_H/L 0x41, GYRO_XOUT_H 0x43 .. GYRO_ZOUT_L 0x48 */
#define MPU_REG_TEMP_OUT_H 0x41
#define MPU_REG_GYRO_XOUT_H 0x43
#define MPU_REG_GYRO_ZOUT_L 0x48
#define MPU_REG_PWR_MGMT_1 0x6B
#define MPU_PWR1_DEVICE_RESET 0x80
#define MPU_PWR1_SLEEP 0x40
#define MPU_PWR1_CLKSEL_PLL 0x01   /* PLL with X gyro reference (MPU-9250: auto-select PLL) */
#define MPU_REG_PWR_MGMT_2 0x6C
#define MPU_REG_WHO_AM_I 0x75
#define MPU6050_WHO_AM_I 0x68
#define MPU9250_WHO_AM_I 0x71
#define MPU9255_WHO_AM_I 0x73
#define MPU6050_PWR1_RESET_VALUE 0x40 /* asleep after reset */
#define MPU9250_PWR1_RESET_VALUE 0x01
#define MPU_RESET_MS 100
#define MPU_GYRO_STARTUP_MS 35

/* TDK ICM-42688-P (DS-000347), user bank 0 */
#define ICM_REG_DEVICE_CONFIG 0x11
#define ICM_DEVICE_CONFIG_SOFT_RESET 0x01
#define ICM_REG_TEMP_DATA1 0x1D    /* TEMP_DATA1/0, ACCEL_DATA_X1 0x1F .. GYRO_DATA_Z0 0x2A */
#define ICM_REG_ACCEL_DATA_X1 0x1F
#define ICM_REG_GYRO_DATA_X1 0x25
#define ICM_REG_GYRO_DATA_Z0 0x2A
#define ICM_REG_INT_STATUS 0x2D
#define ICM_INT_STATUS_RESET_DONE 0x10
#define ICM_INT_STATUS_DATA_RDY 0x08
#define ICM_REG_INTF_CONFIG0 0x4C  /* SENSOR_DATA_ENDIAN [4] = 1 (big-endian) at reset */
#define ICM_REG_PWR_MGMT0 0x4E     /* GYRO_MODE [3:2], ACCEL_MODE [1:0]; 3 = low noise */
#define ICM_PWR_GYRO_LN 0x0C
#define ICM_PWR_ACCEL_LN 0x03
#define ICM_REG_GYRO_CONFIG0 0x4F  /* GYRO_FS_SEL [7:5], GYRO_ODR [3:0] */
#define ICM_REG_ACCEL_CONFIG0 0x50 /* ACCEL_FS_SEL [7:5], ACCEL_ODR [3:0] */
#define ICM_REG_GYRO_ACCEL_CONFIG0 0x52
#define ICM_REG_INT_SOURCE0 0x65
#define ICM_INT_SOURCE0_RESET_DONE_INT1_EN 0x10
#define ICM_INT_SOURCE0_UI_DRDY_INT1_EN 0x08
#define ICM_REG_WHO_AM_I 0x75
#define ICM42688_WHO_AM_I 0x47
#define ICM_REG_BANK_SEL 0x76
#define ICM_RESET_MS 1
#define ICM_GYRO_STARTUP_MS 60
/* ODR codes (ACCEL_ODR / GYRO_ODR) */
#define ICM_ODR_1KHZ 0x06
#define ICM_ODR_200HZ 0x07
#define ICM_ODR_100HZ 0x08
#define ICM_ODR_50HZ 0x09
#define ICM_ODR_25HZ 0x0A
#define ICM_ODR_12_5HZ 0x0B
#define ICM_ODR_500HZ 0x0F

/* Polling over I2C tops out near 1 kHz (a 15-byte burst takes ~0.45 ms at 400 kHz), so faster ODRs are not used. */
#define DRV_I2C_MAX_RATE_HZ 1000.0

#endif

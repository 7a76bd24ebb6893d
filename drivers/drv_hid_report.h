/* SPDX-License-Identifier: MIT */
/* drv_hid_report: pure decoding/encoding of IMU input reports from USB HID trackers (our vendor bridge format and
 * the Oculus Rift DK2/CV1 sensor report), 32-bit device timestamp unwrapping, and device-to-host time mapping. */
#ifndef DRV_HID_REPORT_H
#define DRV_HID_REPORT_H

#include <stdbool.h>
#include <stdint.h>

/* ---- vendor format (docs/hid-report.md) ---- */

#define DRV_HID_VENDOR_REPORT_ID 0x31
#define DRV_HID_VENDOR_VERSION 1
#define DRV_HID_VENDOR_REPORT_SIZE 64
#define DRV_HID_VENDOR_MAX_SAMPLES 4
#define DRV_HID_VENDOR_GYRO_CODES 6  /* gyro full scale 125 << code deg/s: 125 ... 4000 */
#define DRV_HID_VENDOR_ACCEL_CODES 5 /* accel full scale 2 << code g: 2 ... 32 */

/* ---- Oculus Rift DK2/CV1 tracker sensor report (report id 11, as OpenHMD and ouvrt decode it) ---- */

#define DRV_HID_RIFT_REPORT_ID 0x0b
#define DRV_HID_RIFT_REPORT_SIZE 64
#define DRV_HID_RIFT_MAX_SAMPLES 2
#define DRV_HID_RIFT_SAMPLE_US 1000 /* the Rift IMU samples at 1 kHz */

#define DRV_HID_MAX_SAMPLES 4 /* the most any format carries in one report */
#define DRV_HID_STANDARD_GRAVITY 9.80665

typedef enum {
    DRV_HID_FMT_VENDOR = 1,
    DRV_HID_FMT_RIFT = 2,
} drv_hid_format;

/* One decoded report: samples in SI units in the device's axis frame, oldest first, each with its device time. */
typedef struct {
    drv_hid_format format;
    int n;                               /* samples, 0..DRV_HID_MAX_SAMPLES (0: a Rift report without any) */
    uint16_t seq;                        /* sequence number of sample 0 (vendor) / samples since start (Rift) */
    uint32_t t_us[DRV_HID_MAX_SAMPLES];  /* device µs counter at each sample (wraps at 2^32) */
    double gyro[DRV_HID_MAX_SAMPLES][3]; /* rad/s */
    double accel[DRV_HID_MAX_SAMPLES][3];/* m/s^2, specific force */
    double gyro_lsb, accel_lsb;          /* quantisation step of this report: rad/s and m/s^2 per count */
    double temperature_c;                /* NaN when the format carries none */
} drv_hid_imu_report;

typedef enum {
    DRV_HID_OK = 0,
    DRV_HID_ERR_EMPTY,       /* zero-length or NULL buffer */
    DRV_HID_ERR_REPORT_ID,   /* not an IMU report we know */
    DRV_HID_ERR_LENGTH,      /* shorter or longer than the report's fixed size */
    DRV_HID_ERR_VERSION,     /* vendor format version we do not speak */
    DRV_HID_ERR_COUNT,       /* sample count 0 or above what the report holds */
    DRV_HID_ERR_RANGE,       /* declared full-scale range code unknown */
    DRV_HID_ERR_INTERVAL,    /* several samples but no (or an absurd) sample interval */
    DRV_HID_ERR_CRC,         /* checksum mismatch: the report was damaged */
} drv_hid_err;

const char *drv_hid_err_str(drv_hid_err e);

/* Decodes one input report as read from hidraw (byte 0 is the report id). On failure *out is unspecified and, if
 * msg is non-NULL, msg gets a short description of what was wrong ("bad version 7", "crc mismatch", ...). */
drv_hid_err drv_hid_decode(const uint8_t *buf, int len, drv_hid_imu_report *out, char *msg, int msglen);

/* What the encoder needs: SI values are quantised to the declared ranges (rounded, saturated at full scale). */
typedef struct {
    int n;                   /* 1..DRV_HID_VENDOR_MAX_SAMPLES */
    uint16_t seq;            /* sequence number of sample 0 */
    uint32_t t_us;           /* device µs counter at sample 0 */
    uint16_t interval_us;    /* device µs between consecutive samples of the report (0 only when n == 1) */
    int gyro_code;           /* 0..DRV_HID_VENDOR_GYRO_CODES-1 */
    int accel_code;          /* 0..DRV_HID_VENDOR_ACCEL_CODES-1 */
    double gyro[DRV_HID_VENDOR_MAX_SAMPLES][3];  /* rad/s */
    double accel[DRV_HID_VENDOR_MAX_SAMPLES][3]; /* m/s^2 */
} drv_hid_vendor_in;

/* Writes a DRV_HID_VENDOR_REPORT_SIZE-byte report; returns its size, or -1 for invalid input (n, codes, interval,
 * NaN values). */
int drv_hid_encode_vendor(const drv_hid_vendor_in *in, uint8_t out[DRV_HID_VENDOR_REPORT_SIZE]);

/* Full scale of a range code in SI units (rad/s, m/s^2); 0 for an unknown code. */
double drv_hid_vendor_gyro_fs(int code);
double drv_hid_vendor_accel_fs(int code);

/* ---- device time ---- */

/* Extends a wrapping 32-bit µs counter to 64 bits. Steps are taken as signed (±35 min), so a sample that is a
 * little older than the previous one stays a little older instead of jumping 71 minutes ahead. */
typedef struct {
    bool init;
    uint32_t last;
    int64_t ext; /* extended value of `last` */
} drv_hid_unwrap;

void drv_hid_unwrap_reset(drv_hid_unwrap *u);
int64_t drv_hid_unwrap_us(drv_hid_unwrap *u, uint32_t t_us);

/* Maps device time to CLOCK_MONOTONIC. Each report gives an offset sample host_receive - device_time, which is the
 * true offset plus a transport latency that is never negative: the estimate follows the lower envelope (snaps down
 * to a smaller offset at once) and rises only by slow exponential smoothing (device clock slower than the host,
 * or a latency floor that grew). Mapped times therefore mean "measured at device time + minimum transport
 * latency", and are forced to move strictly forward. */
typedef struct {
    bool init;
    int64_t offset_ns;      /* current estimate: host_ns - device_ns */
    int64_t last_dev_ns;    /* device time of the last update */
    int64_t last_out_ns;    /* last mapped time handed out (kept across resets: time never goes backward) */
    double tau_s;           /* time constant of the upward smoothing */
    int64_t resync_ns;      /* an offset sample this far from the estimate means the device clock restarted */
    uint64_t resyncs;       /* times that happened */
} drv_hid_timemap;

#define DRV_HID_TIMEMAP_TAU_S 2.0
#define DRV_HID_TIMEMAP_RESYNC_NS (250 * 1000000LL)

void drv_hid_timemap_init(drv_hid_timemap *m);
/* Forgets the offset (a reconnected device restarts its counter); keeps last_out_ns. */
void drv_hid_timemap_reset(drv_hid_timemap *m);
/* One offset observation: the newest sample of a report at device time dev_ns arrived at host time host_ns. */
void drv_hid_timemap_update(drv_hid_timemap *m, int64_t dev_ns, int64_t host_ns);
/* Host time of device time dev_ns, strictly after every time mapped before (call in sample order). */
int64_t drv_hid_timemap_map(drv_hid_timemap *m, int64_t dev_ns);

#endif

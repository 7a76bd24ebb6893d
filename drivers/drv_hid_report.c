/* SPDX-License-Identifier: MIT */
/* drv_hid_report: pure decoding/encoding of IMU input reports from USB HID trackers (our vendor bridge format and
 * the Oculus Rift DK2/CV1 sensor report), 32-bit device timestamp unwrapping, and device-to-host time mapping. */
#include "drivers/drv_hid_report.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <zlib.h>

#include "warp/warp_err.h"

#define PI 3.14159265358979323846

/* Vendor report layout (byte offsets; docs/hid-report.md is the reference). */
enum {
    V_ID = 0,
    V_VERSION = 1,
    V_COUNT = 2,
    V_RANGES = 3, /* low nibble gyro code, high nibble accel code */
    V_SEQ = 4,
    V_TIME = 6,
    V_INTERVAL = 10,
    V_SAMPLES = 12, /* 4 x (gx gy gz ax ay az) int16 */
    V_SAMPLE_SIZE = 12,
    V_CRC = 60,
};
_Static_assert(V_SAMPLES + DRV_HID_VENDOR_MAX_SAMPLES * V_SAMPLE_SIZE == V_CRC, "vendor layout");
_Static_assert(V_CRC + 4 == DRV_HID_VENDOR_REPORT_SIZE, "vendor layout");

/* Rift DK2/CV1 sensor report layout (ouvrt's struct rift_sensor_message, OpenHMD's decode_tracker_sensor_msg_dk2). */
enum {
    R_ID = 0,
    R_ECHO = 1,
    R_COUNT = 3,
    R_SAMPLE_COUNT = 4,
    R_TEMPERATURE = 6, /* int16, 1/100 degC */
    R_TIME = 8,        /* µs of the newest sample */
    R_SAMPLES = 12,    /* 2 x (accel, gyro), each 3 x 21-bit big-endian packed in 8 bytes, 1e-4 SI units */
    R_SAMPLE_SIZE = 16,
    R_MAG = 44,
};

static uint16_t get_u16(const uint8_t *p) { return (uint16_t)(p[0] | (p[1] << 8)); }
static int16_t get_i16(const uint8_t *p) { return (int16_t)get_u16(p); }
static uint32_t get_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}
static void put_u16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}
static void put_u32(uint8_t *p, uint32_t v)
{
    put_u16(p, (uint16_t)v);
    put_u16(p + 2, (uint16_t)(v >> 16));
}

const char *drv_hid_err_str(drv_hid_err e)
{
    switch (e) {
    case DRV_HID_OK: return "ok";
    case DRV_HID_ERR_EMPTY: return "empty report";
    case DRV_HID_ERR_REPORT_ID: return "unknown report id";
    case DRV_HID_ERR_LENGTH: return "wrong report length";
    case DRV_HID_ERR_VERSION: return "unsupported version";
    case DRV_HID_ERR_COUNT: return "bad sample count";
    case DRV_HID_ERR_RANGE: return "bad full-scale range";
    case DRV_HID_ERR_INTERVAL: return "bad sample interval";
    case DRV_HID_ERR_CRC: return "crc mismatch";
    }
    return "unknown error";
}

double drv_hid_vendor_gyro_fs(int code)
{
    if (code < 0 || code >= DRV_HID_VENDOR_GYRO_CODES) return 0;
    return (double)(125 << code) * (PI / 180.0);
}

double drv_hid_vendor_accel_fs(int code)
{
    if (code < 0 || code >= DRV_HID_VENDOR_ACCEL_CODES) return 0;
    return (double)(2 << code) * DRV_HID_STANDARD_GRAVITY;
}

static uint32_t vendor_crc(const uint8_t *buf)
{
    return (uint32_t)crc32(crc32(0L, Z_NULL, 0), buf, V_CRC);
}

static drv_hid_err fail(drv_hid_err e, char *msg, int msglen, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
static drv_hid_err fail(drv_hid_err e, char *msg, int msglen, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    warp_verr(msg, msglen, fmt, ap);
    va_end(ap);
    return e;
}

static drv_hid_err decode_vendor(const uint8_t *b, int len, drv_hid_imu_report *out, char *msg, int msglen)
{
    if (len != DRV_HID_VENDOR_REPORT_SIZE)
        return fail(DRV_HID_ERR_LENGTH, msg, msglen, "vendor report of %d bytes (expected %d)", len,
                    DRV_HID_VENDOR_REPORT_SIZE);
    /* Version before the checksum: a later version may lay out (or checksum) the report differently. */
    if (b[V_VERSION] != DRV_HID_VENDOR_VERSION)
        return fail(DRV_HID_ERR_VERSION, msg, msglen, "vendor report version %u (expected %d)", b[V_VERSION],
                    DRV_HID_VENDOR_VERSION);
    uint32_t want = get_u32(b + V_CRC), got = vendor_crc(b);
    if (want != got)
        return fail(DRV_HID_ERR_CRC, msg, msglen, "crc mismatch (report says %08x, bytes give %08x)", want, got);
    int n = b[V_COUNT];
    if (n < 1 || n > DRV_HID_VENDOR_MAX_SAMPLES)
        return fail(DRV_HID_ERR_COUNT, msg, msglen, "sample count %d (expected 1..%d)", n,
                    DRV_HID_VENDOR_MAX_SAMPLES);
    int gcode = b[V_RANGES] & 0x0f, acode = b[V_RANGES] >> 4;
    double gfs = drv_hid_vendor_gyro_fs(gcode), afs = drv_hid_vendor_accel_fs(acode);
    if (gfs == 0 || afs == 0)
        return fail(DRV_HID_ERR_RANGE, msg, msglen, "range codes gyro %d accel %d (valid: gyro 0..%d, accel 0..%d)",
                    gcode, acode, DRV_HID_VENDOR_GYRO_CODES - 1, DRV_HID_VENDOR_ACCEL_CODES - 1);
    uint16_t interval = get_u16(b + V_INTERVAL);
    if (n > 1 && interval == 0)
        return fail(DRV_HID_ERR_INTERVAL, msg, msglen, "%d samples with a sample interval of 0 us", n);

    memset(out, 0, sizeof *out);
    out->format = DRV_HID_FMT_VENDOR;
    out->n = n;
    out->seq = get_u16(b + V_SEQ);
    out->gyro_lsb = gfs / 32768.0;
    out->accel_lsb = afs / 32768.0;
    out->temperature_c = NAN;
    uint32_t t0 = get_u32(b + V_TIME);
    for (int i = 0; i < n; i++) {
        const uint8_t *s = b + V_SAMPLES + i * V_SAMPLE_SIZE;
        out->t_us[i] = t0 + (uint32_t)i * interval; /* wraps with the counter */
        for (int k = 0; k < 3; k++) {
            out->gyro[i][k] = get_i16(s + 2 * k) * out->gyro_lsb;
            out->accel[i][k] = get_i16(s + 6 + 2 * k) * out->accel_lsb;
        }
    }
    return DRV_HID_OK;
}

/* Three signed 21-bit values packed big-endian into the top 63 bits of 8 bytes (x first); the lowest bit is
 * unused. */
static void rift_unpack21(const uint8_t *p, int32_t v[3])
{
    uint64_t w = 0;
    for (int i = 0; i < 8; i++) w = (w << 8) | p[i];
    const int shift[3] = {43, 22, 1};
    for (int k = 0; k < 3; k++) {
        int32_t x = (int32_t)((w >> shift[k]) & 0x1fffff);
        v[k] = x >= 0x100000 ? x - 0x200000 : x; /* sign-extend bit 20 */
    }
}

static drv_hid_err decode_rift(const uint8_t *b, int len, drv_hid_imu_report *out, char *msg, int msglen)
{
    if (len != DRV_HID_RIFT_REPORT_SIZE)
        return fail(DRV_HID_ERR_LENGTH, msg, msglen, "Rift sensor report of %d bytes (expected %d)", len,
                    DRV_HID_RIFT_REPORT_SIZE);
    memset(out, 0, sizeof *out);
    out->format = DRV_HID_FMT_RIFT;
    /* num_samples counts the samples queued since the last report; only the newest two fit. */
    int queued = b[R_COUNT];
    int n = queued < DRV_HID_RIFT_MAX_SAMPLES ? queued : DRV_HID_RIFT_MAX_SAMPLES;
    out->n = n;
    out->seq = get_u16(b + R_SAMPLE_COUNT);
    out->gyro_lsb = out->accel_lsb = 1e-4;
    out->temperature_c = get_i16(b + R_TEMPERATURE) * 0.01;
    /* The timestamp is the newest sample's; the ones before it are 1 ms apart (how OpenHMD integrates them). */
    uint32_t t_last = get_u32(b + R_TIME);
    for (int i = 0; i < n; i++) {
        const uint8_t *s = b + R_SAMPLES + i * R_SAMPLE_SIZE;
        int32_t a[3], g[3];
        rift_unpack21(s, a);
        rift_unpack21(s + 8, g);
        out->t_us[i] = t_last - (uint32_t)((n - 1 - i) * DRV_HID_RIFT_SAMPLE_US);
        for (int k = 0; k < 3; k++) {
            out->accel[i][k] = a[k] * 1e-4;
            out->gyro[i][k] = g[k] * 1e-4;
        }
    }
    return DRV_HID_OK;
}

drv_hid_err drv_hid_decode(const uint8_t *buf, int len, drv_hid_imu_report *out, char *msg, int msglen)
{
    if (msg && msglen > 0) msg[0] = 0;
    if (!buf || len <= 0) return fail(DRV_HID_ERR_EMPTY, msg, msglen, "empty report (%d bytes)", len);
    switch (buf[0]) {
    case DRV_HID_VENDOR_REPORT_ID: return decode_vendor(buf, len, out, msg, msglen);
    case DRV_HID_RIFT_REPORT_ID: return decode_rift(buf, len, out, msg, msglen);
    default:
        return fail(DRV_HID_ERR_REPORT_ID, msg, msglen, "report id 0x%02x of %d bytes is no IMU report (expected "
                    "0x%02x or 0x%02x)", buf[0], len, DRV_HID_VENDOR_REPORT_ID, DRV_HID_RIFT_REPORT_ID);
    }
}

static int16_t quantise(double v, double lsb)
{
    double c = nearbyint(v / lsb);
    if (c > 32767) c = 32767;
    if (c < -32768) c = -32768;
    return (int16_t)c;
}

int drv_hid_encode_vendor(const drv_hid_vendor_in *in, uint8_t out[DRV_HID_VENDOR_REPORT_SIZE])
{
    if (in->n < 1 || in->n > DRV_HID_VENDOR_MAX_SAMPLES) return -1;
    double gfs = drv_hid_vendor_gyro_fs(in->gyro_code), afs = drv_hid_vendor_accel_fs(in->accel_code);
    if (gfs == 0 || afs == 0) return -1;
    if (in->n > 1 && in->interval_us == 0) return -1;
    for (int i = 0; i < in->n; i++)
        for (int k = 0; k < 3; k++)
            if (!isfinite(in->gyro[i][k]) || !isfinite(in->accel[i][k])) return -1;
    memset(out, 0, DRV_HID_VENDOR_REPORT_SIZE);
    out[V_ID] = DRV_HID_VENDOR_REPORT_ID;
    out[V_VERSION] = DRV_HID_VENDOR_VERSION;
    out[V_COUNT] = (uint8_t)in->n;
    out[V_RANGES] = (uint8_t)(in->gyro_code | (in->accel_code << 4));
    put_u16(out + V_SEQ, in->seq);
    put_u32(out + V_TIME, in->t_us);
    put_u16(out + V_INTERVAL, in->interval_us);
    for (int i = 0; i < in->n; i++) {
        uint8_t *s = out + V_SAMPLES + i * V_SAMPLE_SIZE;
        for (int k = 0; k < 3; k++) {
            put_u16(s + 2 * k, (uint16_t)quantise(in->gyro[i][k], gfs / 32768.0));
            put_u16(s + 6 + 2 * k, (uint16_t)quantise(in->accel[i][k], afs / 32768.0));
        }
    }
    put_u32(out + V_CRC, vendor_crc(out));
    return DRV_HID_VENDOR_REPORT_SIZE;
}

/* ---- device time ---- */

void drv_hid_unwrap_reset(drv_hid_unwrap *u) { memset(u, 0, sizeof *u); }

int64_t drv_hid_unwrap_us(drv_hid_unwrap *u, uint32_t t_us)
{
    if (!u->init) {
        u->init = true;
        u->last = t_us;
        u->ext = t_us;
        return u->ext;
    }
    uint32_t d = t_us - u->last; /* modulo 2^32 */
    int64_t step = d >= 0x80000000u ? (int64_t)d - 0x100000000LL : (int64_t)d;
    u->ext += step;
    u->last = t_us;
    return u->ext;
}

void drv_hid_timemap_init(drv_hid_timemap *m)
{
    memset(m, 0, sizeof *m);
    m->last_out_ns = INT64_MIN;
    m->tau_s = DRV_HID_TIMEMAP_TAU_S;
    m->resync_ns = DRV_HID_TIMEMAP_RESYNC_NS;
}

void drv_hid_timemap_reset(drv_hid_timemap *m) { m->init = false; }

void drv_hid_timemap_update(drv_hid_timemap *m, int64_t dev_ns, int64_t host_ns)
{
    int64_t raw = host_ns - dev_ns;
    if (!m->init) {
        m->init = true;
        m->offset_ns = raw;
        m->last_dev_ns = dev_ns;
        return;
    }
    int64_t diff = raw - m->offset_ns;
    if (diff > m->resync_ns || diff < -m->resync_ns) {
        /* No latency or drift explains this: the device counter restarted or jumped. Start over. */
        m->offset_ns = raw;
        m->resyncs++;
    } else if (diff < 0) {
        /* Arrived sooner than the estimate allows: the estimate held some latency. The envelope is the truth. */
        m->offset_ns = raw;
    } else {
        /* Weighted by device time elapsed, so the time constant does not depend on the report rate. */
        double dt = (double)(dev_ns - m->last_dev_ns) * 1e-9;
        double alpha = m->tau_s > 0 ? dt / m->tau_s : 1;
        if (alpha < 0) alpha = 0;
        if (alpha > 1) alpha = 1;
        m->offset_ns += (int64_t)llround(alpha * (double)diff);
    }
    m->last_dev_ns = dev_ns;
}

int64_t drv_hid_timemap_map(drv_hid_timemap *m, int64_t dev_ns)
{
    int64_t t = dev_ns + m->offset_ns;
    if (m->last_out_ns != INT64_MIN && t <= m->last_out_ns) t = m->last_out_ns + 1;
    m->last_out_ns = t;
    return t;
}

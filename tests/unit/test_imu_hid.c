/* SPDX-License-Identifier: MIT */
/* Unit tests for drv_hid_report and drv_imu_hid: vendor report round trip and every rejection, the Rift sensor
 * report, 32-bit timestamp unwrapping, time mapping, and the HID IMU backend end to end over the mock and injected
 * transports (roll-over, unplug/replug, corrupted reports). */
#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>
#include <cmocka.h>

#include "drivers/drv_hid_report.h"
#include "drivers/drv_imu_hid_mock.h"
#include "drivers/drv_sim.h"
#include "platform/plat_clock.h"
#include "sim/sim_trace.h"
#include "tests/support/test_util.h"

#define MS 1000000LL
#define DEG (3.14159265358979323846 / 180.0)

/* ---- vendor format ---- */

static drv_hid_vendor_in random_in(test_rng *r, int n, int gcode, int acode)
{
    drv_hid_vendor_in in;
    memset(&in, 0, sizeof in);
    in.n = n;
    in.seq = (uint16_t)test_rng_next(r);
    in.t_us = (uint32_t)test_rng_next(r);
    in.interval_us = n > 1 ? (uint16_t)(1 + test_rng_next(r) % 5000) : 0;
    in.gyro_code = gcode;
    in.accel_code = acode;
    double gfs = drv_hid_vendor_gyro_fs(gcode), afs = drv_hid_vendor_accel_fs(acode);
    for (int i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            in.gyro[i][k] = test_rng_uniform(r, -gfs, gfs) * 0.999;
            in.accel[i][k] = test_rng_uniform(r, -afs, afs) * 0.999;
        }
    return in;
}

static void test_vendor_roundtrip(void **state)
{
    (void)state;
    test_rng r = test_rng_make(11);
    for (int trial = 0; trial < 300; trial++) {
        int n = 1 + trial % DRV_HID_VENDOR_MAX_SAMPLES;
        int gcode = trial % DRV_HID_VENDOR_GYRO_CODES, acode = (trial / 3) % DRV_HID_VENDOR_ACCEL_CODES;
        drv_hid_vendor_in in = random_in(&r, n, gcode, acode);
        uint8_t buf[DRV_HID_VENDOR_REPORT_SIZE];
        assert_int_equal(drv_hid_encode_vendor(&in, buf), DRV_HID_VENDOR_REPORT_SIZE);
        assert_int_equal(buf[0], DRV_HID_VENDOR_REPORT_ID);
        drv_hid_imu_report rep;
        char msg[128];
        assert_int_equal(drv_hid_decode(buf, sizeof buf, &rep, msg, sizeof msg), DRV_HID_OK);
        assert_int_equal(rep.format, DRV_HID_FMT_VENDOR);
        assert_int_equal(rep.n, n);
        assert_int_equal(rep.seq, in.seq);
        assert_true(isnan(rep.temperature_c));
        double glsb = drv_hid_vendor_gyro_fs(gcode) / 32768, alsb = drv_hid_vendor_accel_fs(acode) / 32768;
        assert_true(fabs(rep.gyro_lsb - glsb) < 1e-15 && fabs(rep.accel_lsb - alsb) < 1e-15);
        for (int i = 0; i < n; i++) {
            assert_int_equal(rep.t_us[i], (uint32_t)(in.t_us + (uint32_t)i * in.interval_us));
            for (int k = 0; k < 3; k++) {
                assert_true(fabs(rep.gyro[i][k] - in.gyro[i][k]) <= 0.5 * glsb + 1e-12);
                assert_true(fabs(rep.accel[i][k] - in.accel[i][k]) <= 0.5 * alsb + 1e-12);
            }
        }
    }
    /* Full-scale values: 2000 deg/s and 8 g; beyond full scale saturates instead of wrapping round. */
    drv_hid_vendor_in in;
    memset(&in, 0, sizeof in);
    in.n = 1;
    in.gyro_code = 4;
    in.accel_code = 2;
    in.gyro[0][0] = 5000 * DEG;
    in.gyro[0][1] = -5000 * DEG;
    in.gyro[0][2] = 1000 * DEG;
    in.accel[0][0] = 9.80665;
    in.accel[0][1] = -100;
    uint8_t buf[DRV_HID_VENDOR_REPORT_SIZE];
    assert_int_equal(drv_hid_encode_vendor(&in, buf), DRV_HID_VENDOR_REPORT_SIZE);
    drv_hid_imu_report rep;
    assert_int_equal(drv_hid_decode(buf, sizeof buf, &rep, NULL, 0), DRV_HID_OK);
    assert_true(fabs(drv_hid_vendor_gyro_fs(4) - 2000 * DEG) < 1e-12);
    assert_true(fabs(rep.gyro[0][0] - 2000 * DEG) < 2 * rep.gyro_lsb);
    assert_true(fabs(rep.gyro[0][1] + 2000 * DEG) < 2 * rep.gyro_lsb);
    assert_true(fabs(rep.gyro[0][2] - 1000 * DEG) <= 0.5 * rep.gyro_lsb);
    assert_true(fabs(rep.accel[0][0] - 9.80665) <= 0.5 * rep.accel_lsb);
    assert_true(fabs(rep.accel[0][1] + 8 * 9.80665) < 2 * rep.accel_lsb);
    /* Timestamps of later samples wrap with the device counter. */
    in.n = 3;
    in.t_us = 0xfffffc18u; /* 2^32 - 1000 */
    in.interval_us = 1000;
    assert_int_equal(drv_hid_encode_vendor(&in, buf), DRV_HID_VENDOR_REPORT_SIZE);
    assert_int_equal(drv_hid_decode(buf, sizeof buf, &rep, NULL, 0), DRV_HID_OK);
    assert_int_equal(rep.t_us[0], 0xfffffc18u);
    assert_int_equal(rep.t_us[1], 0);
    assert_int_equal(rep.t_us[2], 1000);
}

/* Recomputes the checksum after a test edited a field, so the decoder gets as far as that field. */
static void reseal(uint8_t *buf)
{
    uint32_t c = (uint32_t)crc32(crc32(0L, Z_NULL, 0), buf, 60);
    for (int i = 0; i < 4; i++) buf[60 + i] = (uint8_t)(c >> (8 * i));
}

static void expect_reject(const uint8_t *buf, int len, drv_hid_err want, const char *needle)
{
    drv_hid_imu_report rep;
    char msg[128] = "untouched";
    drv_hid_err e = drv_hid_decode(buf, len, &rep, msg, sizeof msg);
    if (e != want || !strstr(msg, needle))
        fail_msg("expected %s containing \"%s\", got %s: \"%s\"", drv_hid_err_str(want), needle, drv_hid_err_str(e),
                 msg);
}

static void test_vendor_rejections(void **state)
{
    (void)state;
    test_rng r = test_rng_make(12);
    drv_hid_vendor_in in = random_in(&r, 2, 3, 1);
    uint8_t good[DRV_HID_VENDOR_REPORT_SIZE], b[DRV_HID_VENDOR_REPORT_SIZE + 8];
    assert_int_equal(drv_hid_encode_vendor(&in, good), DRV_HID_VENDOR_REPORT_SIZE);

    expect_reject(good, 0, DRV_HID_ERR_EMPTY, "empty");
    expect_reject(NULL, 64, DRV_HID_ERR_EMPTY, "empty");
    memcpy(b, good, sizeof good);
    b[0] = 0x30;
    expect_reject(b, 64, DRV_HID_ERR_REPORT_ID, "0x30");
    expect_reject(good, 63, DRV_HID_ERR_LENGTH, "63 bytes");
    expect_reject(good, 1, DRV_HID_ERR_LENGTH, "1 bytes");
    memset(b, 0, sizeof b);
    memcpy(b, good, sizeof good);
    expect_reject(b, 65, DRV_HID_ERR_LENGTH, "65 bytes");

    memcpy(b, good, sizeof good);
    b[1] = 2;
    expect_reject(b, 64, DRV_HID_ERR_VERSION, "version 2"); /* the version is checked before the checksum */

    memcpy(b, good, sizeof good);
    b[20] ^= 0x01; /* one bit of a sample */
    expect_reject(b, 64, DRV_HID_ERR_CRC, "crc");
    memcpy(b, good, sizeof good);
    b[63] ^= 0x80; /* the checksum itself */
    expect_reject(b, 64, DRV_HID_ERR_CRC, "crc");

    /* One header byte changed to b[at] & keep | set, with a valid checksum: refused for what it says. */
    static const struct {
        int at;
        uint8_t keep, set;
        drv_hid_err want;
        const char *needle;
    } field[] = {
        {1, 0x00, 2, DRV_HID_ERR_VERSION, "version 2"},
        {2, 0x00, 0, DRV_HID_ERR_COUNT, "count 0"},
        {2, 0x00, 5, DRV_HID_ERR_COUNT, "count 5"},
        {3, 0xf0, 6, DRV_HID_ERR_RANGE, "gyro 6"},       /* gyro code 6: 8000 deg/s, no such sensor */
        {3, 0x0f, 5 << 4, DRV_HID_ERR_RANGE, "accel 5"}, /* accel code 5: 64 g */
        {3, 0x00, 0xff, DRV_HID_ERR_RANGE, "range"},
    };
    for (size_t i = 0; i < sizeof field / sizeof *field; i++) {
        memcpy(b, good, sizeof good);
        b[field[i].at] = (uint8_t)((b[field[i].at] & field[i].keep) | field[i].set);
        reseal(b);
        expect_reject(b, 64, field[i].want, field[i].needle);
    }

    memcpy(b, good, sizeof good);
    b[10] = b[11] = 0; /* two samples, no interval */
    reseal(b);
    expect_reject(b, 64, DRV_HID_ERR_INTERVAL, "interval");
    b[2] = 1; /* one sample needs none */
    reseal(b);
    drv_hid_imu_report rep;
    assert_int_equal(drv_hid_decode(b, 64, &rep, NULL, 0), DRV_HID_OK);

    /* The encoder refuses what it cannot represent. */
    uint8_t out[DRV_HID_VENDOR_REPORT_SIZE];
    drv_hid_vendor_in bad = in;
    bad.n = 0;
    assert_int_equal(drv_hid_encode_vendor(&bad, out), -1);
    bad = in;
    bad.n = 5;
    assert_int_equal(drv_hid_encode_vendor(&bad, out), -1);
    bad = in;
    bad.gyro_code = 6;
    assert_int_equal(drv_hid_encode_vendor(&bad, out), -1);
    bad = in;
    bad.accel_code = -1;
    assert_int_equal(drv_hid_encode_vendor(&bad, out), -1);
    bad = in;
    bad.interval_us = 0;
    assert_int_equal(drv_hid_encode_vendor(&bad, out), -1);
    bad = in;
    bad.accel[1][2] = NAN;
    assert_int_equal(drv_hid_encode_vendor(&bad, out), -1);
    assert_true(drv_hid_vendor_gyro_fs(6) == 0 && drv_hid_vendor_accel_fs(5) == 0);
}

/* ---- Rift DK2/CV1 sensor report ---- */

/* Built by hand from ouvrt's struct rift_sensor_message: the 21-bit triples were packed bit by bit (big-endian,
 * x in the top bits) and cross-checked against OpenHMD's shift-based unpacking. */
static void rift_report(uint8_t b[64], uint8_t num_samples)
{
    static const uint8_t a0[8] = {0x00, 0x1f, 0x47, 0xfe, 0x0c, 0x02, 0xfe, 0x68}; /* 1000, -2000, 98100 */
    static const uint8_t g0[8] = {0x01, 0x81, 0xcf, 0xff, 0xff, 0xe0, 0x00, 0x00}; /* 12345, -1, -1048576 */
    static const uint8_t a1[8] = {0x00, 0x00, 0x00, 0x5f, 0xcd, 0x3f, 0xff, 0xf6}; /* 0, 98100, -5 */
    static const uint8_t g1[8] = {0x7f, 0xff, 0xf8, 0x00, 0x00, 0x00, 0xf5, 0x70}; /* 1048575, 0, 31416 */
    memset(b, 0, 64);
    b[0] = 0x0b;
    b[1] = 0x34, b[2] = 0x12;   /* echo of the last command */
    b[3] = num_samples;
    b[4] = 0x39, b[5] = 0x30;   /* 12345 samples since start */
    b[6] = 0x0e, b[7] = 0x0b;   /* 0x0b0e = 2830: 28.30 degC */
    b[8] = 0x10, b[9] = 0x27, b[10] = 0x00, b[11] = 0x00; /* 10000 us */
    memcpy(b + 12, a0, 8);
    memcpy(b + 20, g0, 8);
    memcpy(b + 28, a1, 8);
    memcpy(b + 36, g1, 8);
    b[44] = 0xff; /* magnetometer and camera sync fields: ignored */
}

static void test_rift_decode(void **state)
{
    (void)state;
    uint8_t b[64];
    drv_hid_imu_report rep;
    char msg[128];
    rift_report(b, 2);
    assert_int_equal(drv_hid_decode(b, 64, &rep, msg, sizeof msg), DRV_HID_OK);
    assert_int_equal(rep.format, DRV_HID_FMT_RIFT);
    assert_int_equal(rep.n, 2);
    assert_int_equal(rep.seq, 12345);
    assert_true(fabs(rep.temperature_c - 28.30) < 1e-9);
    /* The timestamp is the newest sample's; the older one is 1 ms before it. */
    assert_int_equal(rep.t_us[1], 10000);
    assert_int_equal(rep.t_us[0], 9000);
    const double want_a[2][3] = {{0.1, -0.2, 9.81}, {0, 9.81, -0.0005}};
    const double want_g[2][3] = {{1.2345, -0.0001, -104.8576}, {104.8575, 0, 3.1416}};
    for (int i = 0; i < 2; i++)
        for (int k = 0; k < 3; k++) {
            assert_true(fabs(rep.accel[i][k] - want_a[i][k]) < 1e-9);
            assert_true(fabs(rep.gyro[i][k] - want_g[i][k]) < 1e-9);
        }
    /* More queued than fit: the two in the report are decoded. One: only the first slot. None: nothing. */
    rift_report(b, 7);
    assert_int_equal(drv_hid_decode(b, 64, &rep, NULL, 0), DRV_HID_OK);
    assert_int_equal(rep.n, 2);
    rift_report(b, 1);
    assert_int_equal(drv_hid_decode(b, 64, &rep, NULL, 0), DRV_HID_OK);
    assert_int_equal(rep.n, 1);
    assert_int_equal(rep.t_us[0], 10000);
    assert_true(fabs(rep.accel[0][2] - 9.81) < 1e-9);
    rift_report(b, 0);
    assert_int_equal(drv_hid_decode(b, 64, &rep, NULL, 0), DRV_HID_OK);
    assert_int_equal(rep.n, 0);
    /* Sample timestamps wrap like the counter. */
    rift_report(b, 2);
    b[8] = 0xf4, b[9] = 0x01, b[10] = b[11] = 0; /* 500 us */
    assert_int_equal(drv_hid_decode(b, 64, &rep, NULL, 0), DRV_HID_OK);
    assert_int_equal(rep.t_us[0], (uint32_t)(500 - 1000));
    /* DK1's 62-byte report and anything else not 64 bytes long is refused. */
    rift_report(b, 2);
    expect_reject(b, 62, DRV_HID_ERR_LENGTH, "62 bytes");
}

/* ---- device time ---- */

static void test_unwrap(void **state)
{
    (void)state;
    drv_hid_unwrap u;
    drv_hid_unwrap_reset(&u);
    assert_int_equal(drv_hid_unwrap_us(&u, 0xffffff00u), 0xffffff00LL);
    assert_int_equal(drv_hid_unwrap_us(&u, 0xfffffff0u), 0xfffffff0LL);
    assert_int_equal(drv_hid_unwrap_us(&u, 0x10u), 0x100000010LL);
    assert_int_equal(drv_hid_unwrap_us(&u, 0x1000u), 0x100001000LL);
    /* a sample slightly older than the previous one stays slightly older, even across the wrap */
    assert_int_equal(drv_hid_unwrap_us(&u, 0xfffffff8u), 0xfffffff8LL);
    assert_int_equal(drv_hid_unwrap_us(&u, 0x20u), 0x100000020LL);
    /* many wraps in big forward steps (under half the range each) */
    uint32_t t = 0x20u;
    int64_t ext = 0x100000020LL;
    for (int i = 0; i < 40; i++) {
        t += 0x7ffff000u;
        ext += 0x7ffff000LL;
        assert_int_equal(drv_hid_unwrap_us(&u, t), ext);
    }
    assert_true(ext > 10 * 0x100000000LL);
    drv_hid_unwrap_reset(&u);
    assert_int_equal(drv_hid_unwrap_us(&u, 5), 5);
}

/* Device at 1 kHz with a clock 50 ppm slower than the host, reports arriving after a 300 us latency floor plus up
 * to 2 ms of jitter and occasional 20 ms stalls: mapped times are strictly increasing, never before the floor, and
 * after settling within 0.3 ms of (true measurement time + floor). */
static void test_timemap_smoothing(void **state)
{
    (void)state;
    test_rng r = test_rng_make(13);
    drv_hid_timemap m;
    drv_hid_timemap_init(&m);
    const int64_t host0 = 5000 * 1000 * MS, floor_ns = 300000;
    int64_t last = INT64_MIN, last_recv = INT64_MIN;
    double worst = 0, sum = 0;
    int counted = 0;
    for (int i = 0; i < 8000; i++) {
        int64_t true_ns = host0 + (int64_t)i * MS;                   /* when the sample was measured */
        int64_t dev_ns = 777 * MS + (int64_t)((double)i * MS * (1 - 50e-6)); /* slow device clock */
        double jitter = test_rng_uniform(&r, 0, 2e6);
        if (i % 997 == 500) jitter = 20e6;
        int64_t recv = true_ns + floor_ns + (int64_t)jitter;
        if (recv < last_recv) recv = last_recv; /* reports arrive in order */
        last_recv = recv;
        drv_hid_timemap_update(&m, dev_ns, recv);
        int64_t t = drv_hid_timemap_map(&m, dev_ns);
        assert_true(t > last);
        last = t;
        assert_true(t <= recv + 1); /* never after it arrived */
        /* hardly before it could have arrived: only by the smoothing's lag behind the drift (50 ppm x 2 s) */
        assert_true(t >= true_ns + floor_ns - 300000);
        if (i >= 2000) {
            double err = fabs((double)(t - (true_ns + floor_ns)));
            worst = fmax(worst, err);
            sum += err;
            counted++;
        }
    }
    print_message("timemap: worst %.0f us, mean %.0f us after settling\n", worst * 1e-3, sum / counted * 1e-3);
    assert_true(worst < 300e3);
    assert_true(sum / counted < 150e3);
    assert_int_equal(m.resyncs, 0);

    /* The device counter restarts (device reset without a replug): resync, and mapped time still moves forward. */
    int64_t true_ns = host0 + 9000 * MS;
    drv_hid_timemap_update(&m, 3 * MS, true_ns + floor_ns);
    assert_int_equal(m.resyncs, 1);
    int64_t t = drv_hid_timemap_map(&m, 3 * MS);
    assert_true(t > last);
    assert_true(llabs(t - (true_ns + floor_ns)) < MS);

    /* reset() forgets the offset but not the last time handed out. */
    drv_hid_timemap_reset(&m);
    drv_hid_timemap_update(&m, 0, true_ns - 10 * MS); /* would map earlier than before */
    int64_t t2 = drv_hid_timemap_map(&m, 0);
    assert_int_equal(t2, t + 1);
}

/* ---- the backend over the mock transport, fed by the simulated IMU ---- */

typedef struct {
    sim_trace tr;
    sim_imu_params p;
    int64_t t0;
} truth;

static drv_imu *make_source(truth *tt, const char *trace)
{
    assert_true(sim_trace_init(&tt->tr, trace, 3));
    tt->p = sim_imu_default_params();
    tt->p.t_start = 0;
    tt->t0 = plat_now_ns();
    drv_imu *src = drv_imu_sim_create(&tt->tr, &tt->p, tt->t0);
    assert_non_null(src);
    return src;
}

/* The source sample a delivered sample came from: the closest in value near its time, which must agree within the
 * mock's quantisation (2000 deg/s and 8 g over int16). Returns its index. */
/* the source runs at 1 kHz: also the search window, in samples (1000 was outlasted beside make test-busy: a sample
 * at +1686 ms matched nothing, its report held back more than a second) */
#define LATE_MAX_MS 5000
static int64_t match_source(const truth *tt, const drv_imu_sample *s)
{
    const double glsb = 2000 * DEG / 32768, alsb = 8 * 9.80665 / 32768;
    int64_t guess = (int64_t)llround((double)(s->t_ns - tt->t0) * 1e-9 * tt->p.rate_hz);
    int64_t best = -1;
    double best_err = 1e30;
    for (int64_t i = guess - LATE_MAX_MS; i <= guess + 5; i++) {
        if (i < 0) continue;
        sim_imu_sample x;
        sim_imu_sample_at(&tt->tr, &tt->p, (uint64_t)i, &x);
        double eg = fmax(fabs(x.gyro.x - s->gyro[0]), fmax(fabs(x.gyro.y - s->gyro[1]), fabs(x.gyro.z - s->gyro[2])));
        double ea = fmax(fabs(x.accel.x - s->accel[0]),
                         fmax(fabs(x.accel.y - s->accel[1]), fabs(x.accel.z - s->accel[2])));
        double err = fmax(eg / glsb, ea / alsb);
        if (err < best_err) best_err = err, best = i;
    }
    if (best_err > 0.5 + 1e-6) fail_msg("sample at %+.3f ms matches no source sample (%.2f lsb off)",
                                       (double)(s->t_ns - tt->t0) * 1e-6, best_err);
    /* measured at the source's time: never stamped earlier (the device clock has µs steps), and later only by the
     * latency floor the mapping has found so far (a loaded machine may stall the first reports after an open for
     * as long as it keeps the reader off the CPU: LATE_MAX_MS only tells a late stamp from a wrong one) */
    int64_t true_ns = tt->t0 + (int64_t)llround((double)best / tt->p.rate_hz * 1e9);
    if (s->t_ns < true_ns - 2000 || s->t_ns > true_ns + LATE_MAX_MS * MS)
        fail_msg("sample %lld stamped %+.3f ms from its true time", (long long)best,
                 (double)(s->t_ns - true_ns) * 1e-6);
    return best;
}

typedef struct {
    int samples, enodev, max_gap;
    int64_t last_idx, last_t;
    int64_t first_enodev_ns, slowest_enodev_ns;
    int gaps_not_multiple;
} run_log;

/* Reads for `seconds` (a device timeline's part) and then on until the log holds `until_samples` (what the checks
 * need: a loaded machine reads fewer in a second), at most RUN_CAP_S, a guard against hangs. */
#define RUN_CAP_S 20
static void run_for(drv_imu *imu, const truth *tt, double seconds, int until_samples, int timeout_ms, int per_report,
                    run_log *lg)
{
    drv_imu_sample buf[16];
    int64_t t0 = plat_now_ns(), end = t0 + (int64_t)(seconds * 1e9), cap = t0 + RUN_CAP_S * 1000 * MS;
    for (;;) {
        int64_t now = plat_now_ns();
        if ((now >= end && lg->samples >= until_samples) || now >= cap) break;
        int64_t before = plat_now_ns();
        int n = drv_imu_read(imu, buf, 16, timeout_ms);
        int64_t took = plat_now_ns() - before;
        if (n < 0) {
            assert_int_equal(n, -ENODEV);
            if (!lg->enodev) lg->first_enodev_ns = before;
            lg->enodev++;
            if (took > lg->slowest_enodev_ns) lg->slowest_enodev_ns = took;
            continue;
        }
        for (int i = 0; i < n; i++) {
            int64_t idx = match_source(tt, &buf[i]);
            if (lg->samples) {
                assert_true(buf[i].t_ns > lg->last_t);
                assert_true(idx > lg->last_idx);
                int gap = (int)(idx - lg->last_idx - 1);
                if (gap > lg->max_gap) lg->max_gap = gap;
                if (gap % per_report) lg->gaps_not_multiple++;
            }
            lg->last_idx = idx;
            lg->last_t = buf[i].t_ns;
            lg->samples++;
        }
    }
}

static void test_mock_rollover(void **state)
{
    (void)state;
    truth tt;
    drv_imu_hid_mock_params mp = {.counter_start = 0xffffffffu - 150000u, .samples_per_report = 3};
    drv_imu *imu = drv_imu_hid_create_mock(make_source(&tt, "fast"), &mp);
    assert_non_null(imu);
    assert_string_equal(imu->name, "hid-mock");
    run_log lg = {0};
    run_for(imu, &tt, 0.45, 250, 20, 3, &lg);
    drv_imu_stats st;
    assert_true(drv_imu_stats_get(imu, &st));
    print_message("rollover: %d samples, %llu reports, last error \"%s\"\n", lg.samples,
                  (unsigned long long)st.reports, st.last_error);
    assert_true(lg.samples >= 250);     /* read until it had them */
    assert_int_equal(lg.max_gap, 0);    /* nothing lost, across the roll-over at 150 ms */
    assert_true(st.connected);
    assert_int_equal(st.bad_reports, 0);
    assert_int_equal(st.reconnects, 0);
    assert_int_equal(st.read_errors, 0);
    assert_string_equal(st.last_error, ""); /* in particular no "device clock jumped" at the roll-over */
    assert_true(st.reports >= (uint64_t)lg.samples / 3);
    drv_imu_destroy(imu);
}

static void test_mock_unplug(void **state)
{
    (void)state;
    truth tt;
    drv_imu_hid_mock_params mp = {.counter_start = 1000, .samples_per_report = 2, .unplug_at_s = 0.15,
                                  .unplug_for_s = 0.3};
    drv_imu *imu = drv_imu_hid_create_mock(make_source(&tt, "slow"), &mp);
    assert_non_null(imu);
    int64_t created = plat_now_ns();
    run_log lg = {0};
    run_for(imu, &tt, 0.25, 0, 20, 2, &lg); /* through the unplug */
    drv_imu_stats st;
    drv_imu_stats_get(imu, &st);
    assert_true(lg.samples > 50);
    assert_true(lg.enodev >= 1);
    assert_true(lg.first_enodev_ns >= created + 100 * MS); /* a read spans up to 20 ms */
    assert_false(st.connected);
    assert_int_equal(st.reconnects, 0);
    assert_int_equal(st.read_errors, 1);
    assert_non_null(strstr(st.last_error, "mock"));
    int before = lg.samples;
    run_for(imu, &tt, 0.7, before + 101, 20, 2, &lg); /* replugged at 0.45 s */
    drv_imu_stats_get(imu, &st);
    print_message("unplug: %d samples (%d after), %d x -ENODEV, slowest %.1f ms, gap %d, \"%s\"\n", lg.samples,
                  lg.samples - before, lg.enodev, (double)lg.slowest_enodev_ns * 1e-6, lg.max_gap, st.last_error);
    assert_true(lg.samples - before > 100);
    assert_true(st.connected);
    assert_int_equal(st.reconnects, 1);
    assert_int_equal(st.bad_reports, 0);
    /* lost at 0.15 s; reopen tried every 250 ms: 0.40 s (still unplugged), 0.65 s (back). Only that is missing
     * (~500 samples; more when a loaded machine runs the reopen late, so the upper bound is loose). */
    assert_true(lg.max_gap >= 250 && lg.max_gap <= 3000);
    /* while gone, reads returned within their timeout (20 ms: the bound tells a timed read from one that blocks
     * until the device is back, whatever the load) */
    assert_true(lg.slowest_enodev_ns < 1000 * MS);
    drv_imu_destroy(imu);
}

static void test_mock_corrupt(void **state)
{
    (void)state;
    truth tt;
    drv_imu_hid_mock_params mp = {.counter_start = 0xfffe0000u, .samples_per_report = 2, .corrupt_every = 5};
    drv_imu *imu = drv_imu_hid_create_mock(make_source(&tt, "jitter"), &mp);
    assert_non_null(imu);
    run_log lg = {0};
    run_for(imu, &tt, 0.3, 130, 20, 2, &lg); /* 130 samples: >= 81 reports, 4 in 5 of them good */
    drv_imu_stats st;
    drv_imu_stats_get(imu, &st);
    print_message("corrupt: %d samples, %llu reports, %llu bad, \"%s\"\n", lg.samples, (unsigned long long)st.reports,
                  (unsigned long long)st.bad_reports, st.last_error);
    assert_true(st.reports >= 80);
    assert_int_equal(st.bad_reports, st.reports / 5); /* every 5th, counted... */
    assert_int_equal(lg.gaps_not_multiple, 0);        /* ...and its samples never returned */
    assert_int_equal(lg.max_gap, 2);
    assert_true(st.connected);
    assert_int_equal(st.read_errors, 0);
    assert_non_null(strstr(st.last_error, "HID IMU mock: bad report"));
    drv_imu_destroy(imu);
}

/* ---- the backend over an injected transport: scripted bytes and failures ---- */

typedef struct {
    int len;          /* bytes, or 0 for "no report", or a negative errno */
    uint8_t b[64];
} step;

typedef struct {
    step steps[16];
    int nsteps, pos;
    int open_fail;    /* the next opens that fail */
    int opens, closes;
    bool destroyed_flag;
    bool *destroyed;
} script;

static int script_open(void *ctx, const char *device, char *err, int errlen)
{
    script *s = ctx;
    assert_string_equal(device, "/dev/hidraw7");
    s->opens++;
    if (s->open_fail > 0) {
        s->open_fail--;
        snprintf(err, (size_t)errlen, "still unplugged");
        return -ENODEV;
    }
    return 0;
}

static int script_read(void *ctx, uint8_t *buf, int len, int timeout_ms)
{
    script *s = ctx;
    if (s->pos >= s->nsteps) {
        plat_sleep_ns((int64_t)timeout_ms * MS);
        return 0;
    }
    step *st = &s->steps[s->pos++];
    if (st->len <= 0) return st->len;
    assert_true(len >= st->len);
    memcpy(buf, st->b, (size_t)st->len);
    return st->len;
}

static void script_close(void *ctx) { ((script *)ctx)->closes++; }
static void script_destroy(void *ctx) { *((script *)ctx)->destroyed = true; }

static const drv_hid_transport script_transport = {script_open, script_read, script_close, script_destroy};

static void add_vendor(script *s, uint32_t t_us, int n, double gx)
{
    drv_hid_vendor_in in;
    memset(&in, 0, sizeof in);
    in.n = n;
    in.t_us = t_us;
    in.interval_us = 1000;
    in.gyro_code = 4;
    in.accel_code = 2;
    for (int i = 0; i < n; i++) {
        in.gyro[i][0] = gx + i;
        in.accel[i][1] = 9.81;
    }
    step *st = &s->steps[s->nsteps++];
    st->len = drv_hid_encode_vendor(&in, st->b);
    assert_int_equal(st->len, 64);
}

static void test_injected_transport(void **state)
{
    (void)state;
    bool destroyed = false;
    script s;
    memset(&s, 0, sizeof s);
    s.destroyed = &destroyed;
    add_vendor(&s, 100000, 4, 0.5);                     /* 0: four samples */
    s.steps[s.nsteps].len = 64;                         /* 1: garbage */
    memset(s.steps[s.nsteps++].b, 0xa5, 64);
    rift_report(s.steps[s.nsteps].b, 2);                /* 2: a Rift report */
    s.steps[s.nsteps++].len = 64;
    s.steps[s.nsteps++].len = -EIO;                     /* 3: the device fails */
    add_vendor(&s, 5000, 1, 1.0);                       /* 4: after the replug, its clock restarted */

    char err[160];
    drv_imu *imu = drv_imu_hid_create_with_transport(&script_transport, &s, "/dev/hidraw7", 1000, err, sizeof err);
    assert_non_null(imu);
    assert_int_equal(s.opens, 1);
    drv_imu_sample out[8];
    /* room for one at a time: the rest of the report waits, in order */
    int64_t prev = INT64_MIN;
    for (int i = 0; i < 4; i++) {
        assert_int_equal(drv_imu_read(imu, out, 1, 10), 1);
        assert_true(fabs(out[0].gyro[0] - (0.5 + i)) <= 0.5 * 2000 * DEG / 32768);
        assert_true(fabs(out[0].accel[1] - 9.81) <= 0.5 * 8 * 9.80665 / 32768);
        assert_true(out[0].t_ns > prev);
        if (i) assert_true(llabs(out[0].t_ns - prev - MS) < 1000); /* device spacing, kept by the mapping */
        prev = out[0].t_ns;
    }
    /* the garbage is skipped and counted, the Rift report behind it delivered in the same call */
    int n = drv_imu_read(imu, out, 8, 50);
    assert_int_equal(n, 2);
    assert_true(fabs(out[1].accel[2] + 0.0005) < 1e-9);
    drv_imu_stats st;
    drv_imu_stats_get(imu, &st);
    assert_int_equal(st.reports, 3);
    assert_int_equal(st.bad_reports, 1);
    assert_non_null(strstr(st.last_error, "/dev/hidraw7"));
    assert_non_null(strstr(st.last_error, "0xa5"));

    /* the failure: -ENODEV, disconnected, named */
    assert_int_equal(drv_imu_read(imu, out, 8, 50), -ENODEV);
    drv_imu_stats_get(imu, &st);
    assert_false(st.connected);
    assert_int_equal(st.read_errors, 1);
    assert_int_equal(s.closes, 1);
    assert_non_null(strstr(st.last_error, "/dev/hidraw7"));
    assert_non_null(strstr(st.last_error, "lost"));
    /* within 250 ms of the loss no reopen is tried, and a short read does not wait for one */
    int64_t t0 = plat_now_ns();
    assert_int_equal(drv_imu_read(imu, out, 8, 0), -ENODEV);
    assert_true(plat_now_ns() - t0 < 100 * MS);
    assert_int_equal(s.opens, 1);
    /* the first reopen fails, the second (another 250 ms on) succeeds */
    s.open_fail = 1;
    int rc;
    do rc = drv_imu_read(imu, out, 8, 100);
    while (rc == -ENODEV && s.opens < 3 && plat_now_ns() - t0 < 3000 * MS);
    drv_imu_stats_get(imu, &st);
    assert_int_equal(s.opens, 3);
    assert_non_null(strstr(st.last_error, "still unplugged"));
    if (rc == 0) rc = drv_imu_read(imu, out, 8, 100);
    assert_int_equal(rc, 1);
    assert_true(fabs(out[0].gyro[0] - 1.0) <= 0.5 * 2000 * DEG / 32768);
    assert_true(out[0].t_ns > prev);
    /* the mapping restarted: the new device clock is not taken for a 95 ms jump back */
    assert_true(llabs(out[0].t_ns - plat_now_ns()) < 100 * MS);
    drv_imu_stats_get(imu, &st);
    assert_true(st.connected);
    assert_int_equal(st.reconnects, 1);
    /* silence is noticed (nominal 1 kHz: no report for 200+ ms is no normal timeout) */
    for (int i = 0; i < 6; i++) assert_int_equal(drv_imu_read(imu, out, 8, 50), 0);
    drv_imu_stats_get(imu, &st);
    assert_int_equal(st.read_errors, 2);
    assert_non_null(strstr(st.last_error, "no report"));
    drv_imu_destroy(imu);
    assert_true(destroyed);
}

static void test_create_errors(void **state)
{
    (void)state;
    uint16_t v, p;
    assert_true(drv_hid_parse_vid_pid("045e:1234", &v, &p));
    assert_int_equal(v, 0x045e);
    assert_int_equal(p, 0x1234);
    assert_true(drv_hid_parse_vid_pid("2833:0031", &v, &p) && v == 0x2833 && p == 0x31);
    assert_true(drv_hid_parse_vid_pid("ABCD:ef01", &v, &p) && v == 0xabcd && p == 0xef01);
    assert_false(drv_hid_parse_vid_pid("45e:1234", &v, &p));
    assert_false(drv_hid_parse_vid_pid("045e-1234", &v, &p));
    assert_false(drv_hid_parse_vid_pid("045e:12345", &v, &p));
    assert_false(drv_hid_parse_vid_pid("045g:1234", &v, &p));
    assert_false(drv_hid_parse_vid_pid("", &v, &p));

    char err[160];
    drv_imu_hid_params hp = {.device = "/dev/hidraw-missing-test", .rate_hz = 1000};
    assert_null(drv_imu_hid_create(&hp, err, sizeof err));
    print_message("missing path: %s\n", err);
    assert_non_null(strstr(err, "/dev/hidraw-missing-test"));
    snprintf(hp.device, sizeof hp.device, "sideways");
    assert_null(drv_imu_hid_create(&hp, err, sizeof err));
    assert_non_null(strstr(err, "sideways"));
    assert_non_null(strstr(err, "VVVV:PPPP"));
    snprintf(hp.device, sizeof hp.device, "fffe:fffd"); /* no such device on a test machine */
    assert_null(drv_imu_hid_create(&hp, err, sizeof err));
    print_message("missing id: %s\n", err);
    assert_non_null(strstr(err, "fffe:fffd"));

    /* a failing open is reported with the device name, and the transport context is still released */
    bool destroyed = false;
    script s;
    memset(&s, 0, sizeof s);
    s.destroyed = &destroyed;
    s.open_fail = 1;
    assert_null(drv_imu_hid_create_with_transport(&script_transport, &s, "/dev/hidraw7", 1000, err, sizeof err));
    assert_non_null(strstr(err, "/dev/hidraw7"));
    assert_non_null(strstr(err, "still unplugged"));
    assert_true(destroyed);

    /* bad mock parameters: NULL, and the source is not leaked (ASan checks) */
    truth tt;
    drv_imu_hid_mock_params mp = {.samples_per_report = 5};
    assert_null(drv_imu_hid_create_mock(make_source(&tt, "still"), &mp));
    mp.samples_per_report = 1;
    mp.corrupt_every = -1;
    assert_null(drv_imu_hid_create_mock(make_source(&tt, "still"), &mp));
    assert_null(drv_imu_hid_create_mock(make_source(&tt, "still"), NULL));
    assert_null(drv_imu_hid_create_mock(NULL, &mp));
}

int main(void)
{
    test_paced_by_sim(TEST_EMULATOR_SLOWDOWN);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_vendor_roundtrip),   cmocka_unit_test(test_vendor_rejections),
        cmocka_unit_test(test_rift_decode),        cmocka_unit_test(test_unwrap),
        cmocka_unit_test(test_timemap_smoothing),  cmocka_unit_test(test_mock_rollover),
        cmocka_unit_test(test_mock_unplug),        cmocka_unit_test(test_mock_corrupt),
        cmocka_unit_test(test_injected_transport), cmocka_unit_test(test_create_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

/* SPDX-License-Identifier: MIT */
/* Fuzzes the HID IMU report decoder (drivers/drv_hid_report.c) and what the HID backend does with a decoded report:
 * device time unwrapping and the device-to-host time map. Input: records of [u8 length, bit 7: repair the vendor
 * report's CRC][report][u8 host delay ms]; mapped sample times must move strictly forward whatever the device sends. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "drivers/drv_hid_report.h"
#include "tests/fuzz/fuzz.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    drv_hid_imu_report rep;
    char msg[128];
    drv_hid_decode(data, (int)(size > 4096 ? 4096 : size), &rep, msg, sizeof msg);

    drv_hid_unwrap uw;
    drv_hid_timemap map;
    drv_hid_unwrap_reset(&uw);
    drv_hid_timemap_init(&map);
    int64_t host_ns = 1000000000LL, last = INT64_MIN;
    fuzz_in in = {data, size};
    while (in.n) {
        int len = fuzz_u8(&in);
        bool repair = len & 0x80; /* rewrite the vendor report's CRC first: reach the checks behind it */
        len &= 0x7f;
        if ((size_t)len > in.n) len = (int)in.n;
        uint8_t buf[128];
        memcpy(buf, in.p, (size_t)len);
        in.p += len, in.n -= (size_t)len;
        if (repair && len == DRV_HID_VENDOR_REPORT_SIZE) {
            uint32_t c = (uint32_t)crc32(0, buf, DRV_HID_VENDOR_REPORT_SIZE - 4);
            for (int i = 0; i < 4; i++) buf[DRV_HID_VENDOR_REPORT_SIZE - 4 + i] = (uint8_t)(c >> (8 * i));
        }
        host_ns += (int64_t)fuzz_u8(&in) * 1000000;
        drv_hid_err e = drv_hid_decode(buf, len, &rep, msg, sizeof msg);
        if (e != DRV_HID_OK) {
            if (!msg[0]) abort(); /* every rejection says why */
            continue;
        }
        if (rep.n < 0 || rep.n > DRV_HID_MAX_SAMPLES) abort();
        for (int i = 0; i < rep.n; i++)
            for (int k = 0; k < 3; k++)
                if (!isfinite(rep.gyro[i][k]) || !isfinite(rep.accel[i][k])) abort();
        if (rep.n == 0) continue;
        int64_t dev_ns[DRV_HID_MAX_SAMPLES];
        for (int i = 0; i < rep.n; i++) dev_ns[i] = drv_hid_unwrap_us(&uw, rep.t_us[i]) * 1000;
        drv_hid_timemap_update(&map, dev_ns[rep.n - 1], host_ns);
        for (int i = 0; i < rep.n; i++) {
            int64_t t = drv_hid_timemap_map(&map, dev_ns[i]);
            if (t <= last) abort();
            last = t;
        }
    }
    return 0;
}

void fuzz_write_seeds(void)
{
    uint8_t out[512];
    size_t n = 0;
    for (int r = 0; r < 4; r++) {
        drv_hid_vendor_in v = {.n = 1 + r % 4, .seq = (uint16_t)(r * 4), .t_us = 1000000u + 4000u * (uint32_t)r,
                               .interval_us = 1000, .gyro_code = r % 6, .accel_code = r % 5};
        for (int i = 0; i < v.n; i++)
            for (int k = 0; k < 3; k++) v.gyro[i][k] = 0.1 * (k + 1), v.accel[i][k] = k == 1 ? 9.8 : 0.2;
        out[n++] = (uint8_t)(DRV_HID_VENDOR_REPORT_SIZE | (r % 2 ? 0x80 : 0));
        if (drv_hid_encode_vendor(&v, out + n) != DRV_HID_VENDOR_REPORT_SIZE) abort();
        n += DRV_HID_VENDOR_REPORT_SIZE;
        out[n++] = 4;
    }
    fuzz_seed("vendor-4", out, n);
    /* A Rift sensor report: id 11, two samples queued, a timestamp and a temperature. */
    uint8_t rift[1 + DRV_HID_RIFT_REPORT_SIZE + 1] = {DRV_HID_RIFT_REPORT_SIZE, DRV_HID_RIFT_REPORT_ID, 0, 0, 2, 5, 0,
                                                      0x10, 0x09, 0x40, 0x42, 0x0f, 0x00};
    for (int i = 16; i < 48; i++) rift[i] = (uint8_t)(i * 37);
    rift[sizeof rift - 1] = 2;
    fuzz_seed("rift", rift, sizeof rift);
}

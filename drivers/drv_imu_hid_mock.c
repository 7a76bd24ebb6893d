/* SPDX-License-Identifier: MIT */
/* drv_imu_hid_mock: the HID IMU backend's mock transport (drv_hid_transport, the layer hidapi fills on a board):
 * another drv_imu's samples encoded as vendor reports with a device clock, unplugs and garbled reports. */
#include "drivers/drv_imu_hid_mock.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "drivers/drv_hid_report.h"
#include "platform/plat_clock.h"
#include "warp/warp_err.h"

/* ---- mock transport: another drv_imu's samples encoded as vendor reports ---- */

typedef struct {
    drv_imu *src;
    drv_imu_hid_mock_params p;
    int per_report;
    int64_t created_ns;
    bool open;
    bool have_origin;
    int64_t origin_ns;  /* source time at which the device counter reads counter_start */
    int64_t last_t_ns;  /* source time of the last sample sent, for the interval of 1-sample reports */
    uint16_t seq;
    uint64_t reports;
    drv_imu_sample buf[DRV_HID_VENDOR_MAX_SAMPLES];
    int nbuf;
} mock_ctx;

static bool mock_unplugged(const mock_ctx *m, int64_t now)
{
    if (!(m->p.unplug_at_s > 0) || !(m->p.unplug_for_s > 0)) return false;
    int64_t a = m->created_ns + (int64_t)(m->p.unplug_at_s * 1e9);
    int64_t b = a + (int64_t)(m->p.unplug_for_s * 1e9);
    return now >= a && now < b;
}

static int mock_open(void *vctx, const char *device, char *err, int errlen)
{
    mock_ctx *m = vctx;
    (void)device;
    if (mock_unplugged(m, plat_now_ns())) {
        warp_err(err, errlen, "mock device unplugged");
        return -ENODEV;
    }
    if (m->reports > 0 || m->nbuf > 0) {
        /* Replugged: what the source measured meanwhile is lost, and the device clock restarts. */
        drv_imu_sample junk[64];
        while (drv_imu_read(m->src, junk, 64, 0) > 0) {
        }
        m->nbuf = 0;
        m->have_origin = false;
        m->last_t_ns = 0;
    }
    m->open = true;
    return 0;
}

static int mock_read(void *vctx, uint8_t *out, int len, int timeout_ms)
{
    mock_ctx *m = vctx;
    if (!m->open) return -EBADF;
    int64_t now = plat_now_ns();
    const int64_t deadline = now + (int64_t)timeout_ms * PLAT_NS_PER_MS;
    while (m->nbuf < m->per_report) {
        if (mock_unplugged(m, now)) return -ENODEV;
        int left_ms = (int)((deadline - now) / PLAT_NS_PER_MS);
        if (left_ms < 0) left_ms = 0;
        int r = drv_imu_read(m->src, m->buf + m->nbuf, m->per_report - m->nbuf, left_ms);
        if (r < 0) return r;
        m->nbuf += r;
        now = plat_now_ns();
        if (m->nbuf < m->per_report && (left_ms == 0 || now >= deadline)) return 0;
    }
    if (mock_unplugged(m, now)) return -ENODEV;

    int n = m->per_report;
    if (!m->have_origin) {
        m->have_origin = true;
        m->origin_ns = m->buf[0].t_ns;
    }
    drv_hid_vendor_in in;
    memset(&in, 0, sizeof in);
    in.n = n;
    in.seq = m->seq;
    /* µs since the origin, modulo 2^32 like the device's free-running counter */
    in.t_us = m->p.counter_start + (uint32_t)(uint64_t)((m->buf[0].t_ns - m->origin_ns) / 1000);
    int64_t step_ns = n > 1 ? (m->buf[n - 1].t_ns - m->buf[0].t_ns) / (n - 1)
                            : (m->last_t_ns ? m->buf[0].t_ns - m->last_t_ns : 0);
    int64_t step_us = (step_ns + 500) / 1000;
    in.interval_us = (uint16_t)(step_us < 1 ? (n > 1 ? 1 : 0) : step_us > 65535 ? 65535 : step_us);
    in.gyro_code = 4;  /* +-2000 deg/s */
    in.accel_code = 2; /* +-8 g */
    for (int i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            in.gyro[i][k] = m->buf[i].gyro[k];
            in.accel[i][k] = m->buf[i].accel[k];
        }
    m->last_t_ns = m->buf[n - 1].t_ns;
    m->seq = (uint16_t)(m->seq + n);
    m->nbuf = 0;
    uint8_t rep[DRV_HID_VENDOR_REPORT_SIZE];
    int size = drv_hid_encode_vendor(&in, rep);
    if (size < 0) return 0; /* a NaN from the source: the device would not have sent it either */
    m->reports++;
    if (m->p.corrupt_every > 0 && m->reports % (uint64_t)m->p.corrupt_every == 0) {
        switch ((m->reports / (uint64_t)m->p.corrupt_every) % 4) {
        case 0: rep[12 + (int)(m->reports % 48)] ^= 0x10; break; /* a flipped bit in the samples: crc */
        case 1: size = 40; break;                                /* truncated */
        case 2: rep[0] = 0x32; break;                            /* someone else's report */
        case 3: rep[1] = DRV_HID_VENDOR_VERSION + 1; break;      /* a firmware we do not know */
        }
    }
    if (size > len) size = len;
    memcpy(out, rep, (size_t)size);
    return size;
}

static void mock_close(void *vctx) { ((mock_ctx *)vctx)->open = false; }

static void mock_destroy(void *vctx)
{
    mock_ctx *m = vctx;
    drv_imu_destroy(m->src);
    free(m);
}

static const drv_hid_transport mock_transport = {
    .open = mock_open,
    .read = mock_read,
    .close = mock_close,
    .destroy = mock_destroy,
};

drv_imu *drv_imu_hid_create_mock(drv_imu *source, const drv_imu_hid_mock_params *mp)
{
    if (!source) return NULL;
    int per = mp ? mp->samples_per_report : 1;
    if (per == 0) per = 1;
    if (!mp || per < 1 || per > DRV_HID_VENDOR_MAX_SAMPLES || mp->corrupt_every < 0 || !(mp->unplug_at_s >= 0) ||
        !(mp->unplug_for_s >= 0)) {
        drv_imu_destroy(source);
        return NULL;
    }
    mock_ctx *m = calloc(1, sizeof *m);
    if (!m) {
        drv_imu_destroy(source);
        return NULL;
    }
    m->src = source;
    m->p = *mp;
    m->per_report = per;
    m->created_ns = plat_now_ns();
    drv_imu *imu = drv_imu_hid_create_with_transport(&mock_transport, m, "mock", 0, NULL, 0);
    if (imu) imu->name = "hid-mock";
    return imu;
}

/* SPDX-License-Identifier: MIT */
/* drv_imu_hid: IMU over USB HID (hidapi, hidraw backend): vendor IMU-bridge and Rift sensor reports decoded, device
 * time mapped to CLOCK_MONOTONIC, unplug/replug survived. The mock transport is in drv_imu_hid_mock.c. */
#include "drivers/drv_imu_hid.h"

#include <errno.h>
#include <hidapi/hidapi.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "drivers/drv_hid_report.h"
#include "platform/plat_clock.h"
#include "warp/warp_err.h"

#define REPORT_BUF 256 /* larger than any report we accept, so an oversized one shows as such */

/* ---- backend: transport -> decode -> time mapping -> samples ---- */

typedef struct {
    drv_imu base;
    drv_hid_transport t;
    void *ctx;
    char device[128];
    double rate_hz;
    bool connected;
    int64_t next_open_ns;   /* earliest next reopen attempt while disconnected */
    int64_t last_report_ns; /* host time of the last report, to notice a silent device */
    bool stall_noted;
    drv_hid_unwrap unwrap;
    drv_hid_timemap map;
    drv_imu_sample pending[DRV_HID_MAX_SAMPLES]; /* decoded samples the caller had no room for */
    int npending, pending_pos;
    pthread_mutex_t lock; /* guards st: stats() may run on another thread */
    drv_imu_stats st;
} imu_hid;

/* Sets last_error and bumps *count (a field of h->st, or NULL) in one step, as stats() readers see them. */
static void note_error(imu_hid *h, uint64_t *count, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static void note_error(imu_hid *h, uint64_t *count, const char *fmt, ...)
{
    char msg[sizeof h->st.last_error];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    pthread_mutex_lock(&h->lock);
    if (count) (*count)++;
    memcpy(h->st.last_error, msg, sizeof msg);
    pthread_mutex_unlock(&h->lock);
}

static int take_pending(imu_hid *h, drv_imu_sample *out, int max)
{
    int n = 0;
    while (n < max && h->pending_pos < h->npending) out[n++] = h->pending[h->pending_pos++];
    return n;
}

static void lost(imu_hid *h, int rc, int64_t now)
{
    h->t.close(h->ctx);
    h->connected = false;
    h->npending = h->pending_pos = 0;
    h->next_open_ns = now + DRV_IMU_HID_REOPEN_MS * PLAT_NS_PER_MS;
    pthread_mutex_lock(&h->lock);
    h->st.connected = false;
    pthread_mutex_unlock(&h->lock);
    note_error(h, &h->st.read_errors, "HID IMU %s: device lost (%s); retrying every %d ms", h->device, strerror(-rc),
               DRV_IMU_HID_REOPEN_MS);
}

static bool try_open(imu_hid *h, int64_t now)
{
    char msg[128] = "";
    h->next_open_ns = now + DRV_IMU_HID_REOPEN_MS * PLAT_NS_PER_MS;
    int rc = h->t.open(h->ctx, h->device, msg, sizeof msg);
    if (rc < 0) {
        note_error(h, NULL, "HID IMU %s: still gone: %s", h->device, msg[0] ? msg : strerror(-rc));
        return false;
    }
    /* A replugged device restarted its clock: both the unwrapping and the offset start over. */
    h->connected = true;
    drv_hid_unwrap_reset(&h->unwrap);
    drv_hid_timemap_reset(&h->map);
    h->last_report_ns = now;
    h->stall_noted = false;
    pthread_mutex_lock(&h->lock);
    h->st.connected = true;
    h->st.reconnects++;
    pthread_mutex_unlock(&h->lock);
    return true;
}

/* Decodes one report into out[] (and pending[] beyond max); returns the samples stored in out. */
static int handle_report(imu_hid *h, const uint8_t *buf, int len, int64_t recv_ns, drv_imu_sample *out, int max)
{
    pthread_mutex_lock(&h->lock);
    h->st.reports++;
    pthread_mutex_unlock(&h->lock);
    h->last_report_ns = recv_ns;
    h->stall_noted = false;
    drv_hid_imu_report rep;
    char why[128];
    drv_hid_err e = drv_hid_decode(buf, len, &rep, why, sizeof why);
    if (e != DRV_HID_OK) {
        note_error(h, &h->st.bad_reports, "HID IMU %s: bad report: %s", h->device, why);
        return 0;
    }
    if (rep.n == 0) return 0;
    int64_t dev_ns[DRV_HID_MAX_SAMPLES];
    for (int i = 0; i < rep.n; i++) dev_ns[i] = drv_hid_unwrap_us(&h->unwrap, rep.t_us[i]) * 1000;
    /* The report left the device after its newest sample: that one bounds the offset. */
    uint64_t resyncs = h->map.resyncs;
    int64_t offset = h->map.offset_ns;
    drv_hid_timemap_update(&h->map, dev_ns[rep.n - 1], recv_ns);
    if (h->map.resyncs != resyncs)
        note_error(h, NULL, "HID IMU %s: device clock jumped by %lld ms; time mapping restarted", h->device,
                   (long long)((offset - h->map.offset_ns) / PLAT_NS_PER_MS));
    int n = 0;
    h->npending = h->pending_pos = 0;
    for (int i = 0; i < rep.n; i++) {
        drv_imu_sample s;
        s.t_ns = drv_hid_timemap_map(&h->map, dev_ns[i]);
        for (int k = 0; k < 3; k++) {
            s.gyro[k] = rep.gyro[i][k];
            s.accel[k] = rep.accel[i][k];
        }
        if (n < max)
            out[n++] = s;
        else
            h->pending[h->npending++] = s;
    }
    return n;
}

static int imu_hid_read(drv_imu *imu, drv_imu_sample *out, int max, int timeout_ms)
{
    imu_hid *h = (imu_hid *)imu;
    if (max <= 0) return 0;
    int n = take_pending(h, out, max);
    if (n > 0) return n;
    if (timeout_ms < 0) timeout_ms = 0;
    int64_t now = plat_now_ns();
    const int64_t deadline = now + (int64_t)timeout_ms * PLAT_NS_PER_MS;
    if (!h->connected) {
        /* Wait for the next attempt only as long as the caller allows, so a lost device is no busy loop. */
        if (h->next_open_ns > deadline) {
            plat_sleep_until_ns(deadline);
            return -ENODEV;
        }
        plat_sleep_until_ns(h->next_open_ns);
        now = plat_now_ns();
        if (!try_open(h, now)) return -ENODEV;
    }
    for (;;) {
        int left_ms = (int)((deadline - now) / PLAT_NS_PER_MS);
        if (left_ms < 0) left_ms = 0;
        uint8_t buf[REPORT_BUF];
        int r = h->t.read(h->ctx, buf, (int)sizeof buf, left_ms);
        now = plat_now_ns();
        if (r < 0) {
            lost(h, r, now);
            return -ENODEV;
        }
        if (r > 0) {
            n = handle_report(h, buf, r, now, out, max);
            if (n > 0) return n;
            if (now >= deadline) return 0;
            continue; /* a bad or empty report: read on until the deadline */
        }
        /* Silence far beyond the nominal period is no normal timeout: note it once per stall. */
        int64_t stall_ns = (int64_t)(20e9 / h->rate_hz);
        if (stall_ns < 200 * PLAT_NS_PER_MS) stall_ns = 200 * PLAT_NS_PER_MS;
        if (!h->stall_noted && now - h->last_report_ns > stall_ns) {
            h->stall_noted = true;
            note_error(h, &h->st.read_errors, "HID IMU %s: no report for %lld ms (nominal %.0f Hz)", h->device,
                       (long long)((now - h->last_report_ns) / PLAT_NS_PER_MS), h->rate_hz);
        }
        if (left_ms == 0 || now >= deadline) return 0;
    }
}

static void imu_hid_stats(drv_imu *imu, drv_imu_stats *out)
{
    imu_hid *h = (imu_hid *)imu;
    pthread_mutex_lock(&h->lock);
    *out = h->st;
    pthread_mutex_unlock(&h->lock);
}

static void imu_hid_destroy(drv_imu *imu)
{
    imu_hid *h = (imu_hid *)imu;
    if (h->connected) h->t.close(h->ctx);
    if (h->t.destroy) h->t.destroy(h->ctx);
    pthread_mutex_destroy(&h->lock);
    free(h);
}

drv_imu *drv_imu_hid_create_with_transport(const drv_hid_transport *t, void *ctx, const char *device, double rate_hz,
                                           char *err, int errlen)
{
    if (!t || !t->open || !t->read || !t->close) {
        warp_err(err, errlen, "HID IMU %s: incomplete transport", device ? device : "?");
        if (t && t->destroy) t->destroy(ctx);
        return NULL;
    }
    if (!device || !device[0] || !(rate_hz >= 0) || rate_hz > 100000) {
        warp_err(err, errlen, "HID IMU %s: bad parameters (rate %g Hz)", device ? device : "(no device)", rate_hz);
        if (t->destroy) t->destroy(ctx);
        return NULL;
    }
    imu_hid *h = calloc(1, sizeof *h);
    if (!h) {
        warp_err(err, errlen, "HID IMU %s: out of memory", device);
        if (t->destroy) t->destroy(ctx);
        return NULL;
    }
    h->base.name = "hid";
    h->base.read = imu_hid_read;
    h->base.stats = imu_hid_stats;
    h->base.destroy = imu_hid_destroy;
    h->t = *t;
    h->ctx = ctx;
    snprintf(h->device, sizeof h->device, "%s", device);
    h->rate_hz = rate_hz > 0 ? rate_hz : 1000;
    pthread_mutex_init(&h->lock, NULL);
    drv_hid_timemap_init(&h->map);
    char msg[128] = "";
    int rc = t->open(ctx, h->device, msg, sizeof msg);
    if (rc < 0) {
        warp_err(err, errlen, "HID IMU %s: %s", h->device, msg[0] ? msg : strerror(-rc));
        imu_hid_destroy(&h->base);
        return NULL;
    }
    h->connected = true;
    h->st.connected = true;
    h->last_report_ns = plat_now_ns();
    return &h->base;
}

/* ---- hidapi transport ---- */

bool drv_hid_parse_vid_pid(const char *s, uint16_t *vid, uint16_t *pid)
{
    if (!s || strlen(s) != 9 || s[4] != ':') return false;
    unsigned v[2] = {0, 0};
    for (int part = 0; part < 2; part++)
        for (int i = 0; i < 4; i++) {
            char c = s[part * 5 + i];
            int d = c >= '0' && c <= '9' ? c - '0' : c >= 'a' && c <= 'f' ? c - 'a' + 10
                  : c >= 'A' && c <= 'F' ? c - 'A' + 10 : -1;
            if (d < 0) return false;
            v[part] = v[part] * 16 + (unsigned)d;
        }
    *vid = (uint16_t)v[0];
    *pid = (uint16_t)v[1];
    return true;
}

typedef struct {
    hid_device *dev;
} hidapi_ctx;

static const wchar_t *hid_why(hid_device *dev)
{
    const wchar_t *w = hid_error(dev);
    return w ? w : L"unknown error";
}

static int hidapi_open(void *vctx, const char *device, char *err, int errlen)
{
    hidapi_ctx *c = vctx;
    if (hid_init() != 0) {
        warp_err(err, errlen, "hid_init failed: %ls", hid_why(NULL));
        return -EIO;
    }
    char path[256];
    uint16_t vid, pid;
    if (device[0] == '/') {
        snprintf(path, sizeof path, "%s", device);
    } else if (drv_hid_parse_vid_pid(device, &vid, &pid)) {
        struct hid_device_info *list = hid_enumerate(vid, pid);
        if (!list) {
            warp_err(err, errlen, "no HID device %04x:%04x present", vid, pid);
            return -ENODEV;
        }
        snprintf(path, sizeof path, "%s", list->path);
        hid_free_enumeration(list);
    } else {
        warp_err(err, errlen, "neither a /dev/hidrawN path nor a VVVV:PPPP vendor:product id");
        return -EINVAL;
    }
    errno = 0;
    c->dev = hid_open_path(path);
    if (!c->dev) {
        int e = errno ? errno : ENODEV;
        warp_err(err, errlen, "cannot open %s: %ls%s", path, hid_why(NULL),
                 e == EACCES ? " (no permission: see the udev rule in docs/hid-report.md)" : "");
        return -e;
    }
    return 0;
}

static int hidapi_read(void *vctx, uint8_t *buf, int len, int timeout_ms)
{
    hidapi_ctx *c = vctx;
    if (!c->dev) return -ENODEV;
    int r = hid_read_timeout(c->dev, buf, (size_t)len, timeout_ms);
    /* hidraw reports an unplugged device (POLLHUP, ENODEV) and any read failure alike as -1. */
    return r < 0 ? -ENODEV : r;
}

static void hidapi_close(void *vctx)
{
    hidapi_ctx *c = vctx;
    if (c->dev) hid_close(c->dev);
    c->dev = NULL;
}

static void hidapi_destroy(void *vctx) { free(vctx); }

static const drv_hid_transport hidapi_transport = {
    .open = hidapi_open,
    .read = hidapi_read,
    .close = hidapi_close,
    .destroy = hidapi_destroy,
};

drv_imu *drv_imu_hid_create(const drv_imu_hid_params *p, char *err, int errlen)
{
    if (!p) {
        warp_err(err, errlen, "HID IMU: no parameters");
        return NULL;
    }
    char device[sizeof p->device];
    snprintf(device, sizeof device, "%.*s", (int)sizeof p->device - 1, p->device);
    uint16_t vid, pid;
    if (device[0] != '/' && !drv_hid_parse_vid_pid(device, &vid, &pid)) {
        warp_err(err, errlen, "HID IMU \"%s\": neither a /dev/hidrawN path nor a VVVV:PPPP vendor:product id",
                 device);
        return NULL;
    }
    hidapi_ctx *c = calloc(1, sizeof *c);
    if (!c) {
        warp_err(err, errlen, "HID IMU %s: out of memory", device);
        return NULL;
    }
    return drv_imu_hid_create_with_transport(&hidapi_transport, c, device, p->rate_hz, err, errlen);
}

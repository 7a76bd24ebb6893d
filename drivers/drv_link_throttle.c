/* SPDX-License-Identifier: MIT */
/* drv_link_throttle: the rate-limited transport: each read waits (within its timeout) until the bucket holds a
 * token, reads at most a burst and takes what it read. */
#include "drivers/drv_link_throttle.h"

#include <stdlib.h>

#include "drivers/drv_token_bucket.h"
#include "platform/plat_clock.h"

typedef struct {
    drv_usb_transport base;
    drv_usb_transport *in;
    drv_token_bucket bucket; /* only the reader (the frames thread) touches it */
} throttle;

static ssize_t th_read(drv_usb_transport *bt, uint8_t *buf, size_t cap, int timeout_ms)
{
    throttle *t = (throttle *)bt;
    int64_t now = plat_now_ns(), ready = drv_token_bucket_ready_ns(&t->bucket, now);
    if (ready > now) {
        /* timeout_ms < 0 waits as long as the bucket needs; the clock is the board's (virtual on a sim board) */
        int64_t wait = ready - now, most = (int64_t)timeout_ms * PLAT_NS_PER_MS;
        plat_sleep_ns(timeout_ms >= 0 && most < wait ? most : wait);
        if (plat_now_ns() < ready) return 0;
    }
    /* at most a burst per read, so a frame arrives spread over its transfer time rather than in one lump first */
    size_t burst = (size_t)t->bucket.burst;
    ssize_t n = t->in->read(t->in, buf, cap < burst ? cap : burst, timeout_ms);
    if (n > 0) drv_token_bucket_take(&t->bucket, (size_t)n, plat_now_ns());
    return n;
}

static ssize_t th_write(drv_usb_transport *bt, const uint8_t *buf, size_t len, int timeout_ms)
{
    throttle *t = (throttle *)bt;
    return t->in->write(t->in, buf, len, timeout_ms);
}

static bool th_connected(drv_usb_transport *bt)
{
    throttle *t = (throttle *)bt;
    return t->in->connected(t->in);
}

static uint64_t th_connections(drv_usb_transport *bt)
{
    throttle *t = (throttle *)bt;
    return t->in->connections(t->in);
}

static void th_stats(drv_usb_transport *bt, drv_frames_usb_stats *st)
{
    throttle *t = (throttle *)bt;
    t->in->stats(t->in, st);
}

static void th_destroy(drv_usb_transport *bt)
{
    throttle *t = (throttle *)bt;
    t->in->destroy(t->in);
    free(t);
}

drv_usb_transport *drv_link_throttle(drv_usb_transport *in, double mbps)
{
    if (mbps <= 0) return in;
    throttle *t = calloc(1, sizeof *t);
    if (!t) {
        in->destroy(in);
        return NULL;
    }
    t->in = in;
    const double rate = mbps * 1e6;
    drv_token_bucket_init(&t->bucket, rate, drv_token_bucket_burst_for(rate), plat_now_ns());
    t->base.read = th_read;
    t->base.write = th_write;
    t->base.connected = th_connected;
    t->base.destroy = th_destroy;
    /* the optional members only where the wrapped transport has them (NULL keeps their defaults) */
    t->base.connections = in->connections ? th_connections : NULL;
    t->base.stats = in->stats ? th_stats : NULL;
    return &t->base;
}

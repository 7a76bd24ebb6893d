/* SPDX-License-Identifier: MIT */
/* The link's rate and budget: the token bucket on an injected clock, the throttled transport in front of a counting
 * one, USB speed names and the sysfs/configfs walk to a UDC's speed (a tree in a temporary directory), and the
 * start-up budget line's numbers and verdicts. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "drivers/drv_frames.h"
#include "drivers/drv_link_budget.h"
#include "drivers/drv_link_throttle.h"
#include "drivers/drv_token_bucket.h"
#include "drivers/drv_usb_speed.h"
#include "tests/support/test_util.h"

#define NS 1000000000LL

static void test_bucket_starts_full_then_paces(void **state)
{
    (void)state;
    drv_token_bucket b;
    drv_token_bucket_init(&b, 1000.0, 500.0, 7 * NS); /* 1000 B/s, 500 B burst, a clock not starting at 0 */
    assert_int_equal(drv_token_bucket_ready_ns(&b, 7 * NS), 7 * NS);
    /* the burst goes at once; the next byte after 1 ms */
    assert_int_equal(drv_token_bucket_take(&b, 500, 7 * NS), 7 * NS + 1000000);
    /* overdrawn by 1000: ready once 1001 bytes accrued */
    assert_int_equal(drv_token_bucket_take(&b, 1000, 7 * NS), 7 * NS + 1001000000LL);
    /* idle for long: no more than the burst accrues */
    drv_token_bucket_take(&b, 0, 100 * NS);
    assert_true(b.tokens == 500.0);
}

/* A reader that reads whenever the bucket allows, 300 bytes at a time, for 10 simulated seconds: the bytes are the
 * rate's plus at most one burst and one read. */
static void test_bucket_averages_the_rate(void **state)
{
    (void)state;
    const double rate = 40e6; /* USB 2.0's */
    drv_token_bucket b;
    drv_token_bucket_init(&b, rate, drv_token_bucket_burst_for(rate), 0);
    assert_true(b.burst == rate * DRV_TOKEN_BUCKET_BURST_MS * 1e-3);
    int64_t now = 0;
    double bytes = 0;
    const size_t chunk = 262144;
    for (;;) {
        int64_t ready = drv_token_bucket_ready_ns(&b, now);
        if (ready > now) now = ready;
        if (now >= 10 * NS) break;
        bytes += (double)chunk;
        drv_token_bucket_take(&b, chunk, now);
    }
    assert_true(bytes <= rate * 10 + b.burst + (double)chunk);
    assert_true(bytes >= rate * 10 - (double)chunk);
    assert_true(drv_token_bucket_burst_for(1000) == DRV_TOKEN_BUCKET_MIN_BURST);
}

/* ---- the throttled transport in front of one that has every byte at once ---- */

typedef struct {
    drv_usb_transport base;
    size_t reads, bytes, writes;
    bool *destroyed;
} counting;

static ssize_t c_read(drv_usb_transport *t, uint8_t *buf, size_t cap, int timeout_ms)
{
    (void)timeout_ms;
    counting *c = (counting *)t;
    memset(buf, 0xA5, cap);
    c->reads++;
    c->bytes += cap;
    return (ssize_t)cap;
}
static ssize_t c_write(drv_usb_transport *t, const uint8_t *buf, size_t len, int timeout_ms)
{
    (void)buf, (void)timeout_ms;
    ((counting *)t)->writes++;
    return (ssize_t)len;
}
static bool c_connected(drv_usb_transport *t) { return t != NULL; }
static uint64_t c_connections(drv_usb_transport *t) { return ((counting *)t)->reads + 40; }
static void c_destroy(drv_usb_transport *t)
{
    *((counting *)t)->destroyed = true;
    free(t);
}

static counting *counting_new(bool *destroyed)
{
    counting *c = calloc(1, sizeof *c);
    assert_non_null(c);
    c->base.read = c_read;
    c->base.write = c_write;
    c->base.connected = c_connected;
    c->base.connections = c_connections;
    c->base.destroy = c_destroy;
    c->destroyed = destroyed;
    return c;
}

static void test_throttle_transport(void **state)
{
    (void)state;
    static uint8_t buf[1 << 20];
    bool destroyed = false;
    /* unlimited: the transport itself */
    counting *c = counting_new(&destroyed);
    assert_ptr_equal(drv_link_throttle(&c->base, 0), &c->base);
    /* 1 byte a second: the first read gets one burst, the next (not waiting) nothing, without reading the link */
    drv_usb_transport *t = drv_link_throttle(&c->base, 1e-6);
    assert_non_null(t);
    assert_ptr_not_equal(t, &c->base);
    assert_int_equal(t->read(t, buf, sizeof buf, 0), DRV_TOKEN_BUCKET_MIN_BURST);
    assert_int_equal(t->read(t, buf, sizeof buf, 0), 0);
    assert_int_equal(c->reads, 1);
    assert_int_equal(c->bytes, DRV_TOKEN_BUCKET_MIN_BURST);
    /* the rest passes through: writes, connected, the optional members only where the link has them */
    assert_int_equal(t->write(t, buf, 12, 0), 12);
    assert_int_equal(c->writes, 1);
    assert_true(t->connected(t));
    assert_non_null(t->connections);
    assert_int_equal(t->connections(t), 41);
    assert_null(t->stats);
    t->destroy(t);
    assert_true(destroyed);
}

/* ---- USB speeds and where the kernel says them ---- */

static void test_usb_speed_names(void **state)
{
    (void)state;
    assert_int_equal(drv_usb_speed_parse("super-speed\n"), DRV_USB_SPEED_SUPER);
    assert_int_equal(drv_usb_speed_parse("super-speed-plus"), DRV_USB_SPEED_SUPER_PLUS);
    assert_int_equal(drv_usb_speed_parse("high-speed\n"), DRV_USB_SPEED_HIGH);
    assert_int_equal(drv_usb_speed_parse("full-speed"), DRV_USB_SPEED_FULL);
    assert_int_equal(drv_usb_speed_parse("UNKNOWN\n"), DRV_USB_SPEED_UNKNOWN);
    assert_int_equal(drv_usb_speed_parse("low-speed"), DRV_USB_SPEED_UNKNOWN);
    assert_int_equal(drv_usb_speed_parse("super-speed-plus-ultra"), DRV_USB_SPEED_UNKNOWN);
    assert_int_equal(drv_usb_speed_parse("super"), DRV_USB_SPEED_UNKNOWN);
    assert_string_equal(drv_usb_speed_name(DRV_USB_SPEED_SUPER), "super-speed");
    assert_string_equal(drv_usb_speed_name((drv_usb_speed)99), "unknown");
    assert_true(drv_usb_speed_mbps(DRV_USB_SPEED_HIGH) == 40 && drv_usb_speed_mbps(DRV_USB_SPEED_SUPER) == 400);
    assert_true(drv_usb_speed_mbps(DRV_USB_SPEED_FULL) < drv_usb_speed_mbps(DRV_USB_SPEED_HIGH));
    assert_true(drv_usb_speed_mbps(DRV_USB_SPEED_UNKNOWN) == 0);
}

static void put(const char *root, const char *rel, const char *text)
{
    char path[512], dir[512];
    snprintf(path, sizeof path, "%s/%s", root, rel);
    snprintf(dir, sizeof dir, "%s", path);
    for (char *s = dir + strlen(root) + 1; (s = strchr(s, '/')); s++) {
        *s = 0;
        assert_true(mkdir(dir, 0755) == 0 || errno == EEXIST);
        *s = '/';
    }
    if (!text) {
        assert_true(mkdir(path, 0755) == 0 || errno == EEXIST);
        return;
    }
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

static void test_udc_walk(void **state)
{
    (void)state;
    char root[48];
    assert_true(test_tmpdir_make(root, sizeof root, "test_link_budget"));
    char udc[64];
    /* no mountinfo, no UDC: nothing */
    assert_false(drv_usb_udc_of(root, "/dev/ffs-hmdwarp", udc, sizeof udc));
    assert_string_equal(udc, "");
    assert_int_equal(drv_usb_udc_speed(root, "", false), DRV_USB_SPEED_UNKNOWN);
    /* two UDCs, the gadget not bound yet: the first by name, as board/gadget.sh takes it */
    put(root, "sys/class/udc/b_udc.1/maximum_speed", "high-speed\n");
    put(root, "sys/class/udc/a_udc.0/maximum_speed", "super-speed\n");
    put(root, "sys/class/udc/a_udc.0/current_speed", "UNKNOWN\n");
    put(root, "sys/class/udc/b_udc.1/current_speed", "high-speed\n");
    put(root, "proc/self/mountinfo",
        "22 1 0:21 / /sys rw,nosuid shared:7 - sysfs sysfs rw\n"
        "36 25 0:32 / /dev/ffs\\040hmd rw,relatime shared:9 - functionfs hmdwarp rw\n"
        "37 25 0:33 / /dev/ffs-other rw,relatime - functionfs other rw\n");
    put(root, "sys/kernel/config/usb_gadget/g_other/functions/ffs.other", NULL);
    put(root, "sys/kernel/config/usb_gadget/g_other/UDC", "a_udc.0\n");
    put(root, "sys/kernel/config/usb_gadget/g_hmd/functions/ffs.hmdwarp", NULL);
    put(root, "sys/kernel/config/usb_gadget/g_hmd/UDC", "\n");
    assert_true(drv_usb_udc_of(root, "/dev/ffs hmd/", udc, sizeof udc));
    assert_string_equal(udc, "a_udc.0");
    assert_int_equal(drv_usb_udc_speed(root, udc, true), DRV_USB_SPEED_SUPER);
    assert_int_equal(drv_usb_udc_speed(root, udc, false), DRV_USB_SPEED_UNKNOWN);
    /* bound: the gadget's own UDC (the escaped mount point matched), its negotiated speed */
    put(root, "sys/kernel/config/usb_gadget/g_hmd/UDC", "b_udc.1\n");
    assert_true(drv_usb_udc_of(root, "/dev/ffs hmd", udc, sizeof udc));
    assert_string_equal(udc, "b_udc.1");
    assert_int_equal(drv_usb_udc_speed(root, udc, false), DRV_USB_SPEED_HIGH);
    /* a directory that is no FunctionFS mount: the fallback again */
    assert_true(drv_usb_udc_of(root, "/dev/ffs-none", udc, sizeof udc));
    assert_string_equal(udc, "a_udc.0");
    assert_true(test_tmpdir_remove(root));
}

/* ---- the budget ---- */

/* The rpi5 board: 1440x1600 eyes, colour + depth, 45 Hz. */
static drv_link_budget_in rpi5(void)
{
    drv_link_budget_in in = {.kind = DRV_LINK_USB, .usb_speed = DRV_USB_SPEED_HIGH, .usb_negotiated = true,
                             .eye_w = 1440, .eye_h = 1600, .planes = DRV_PLANE_COLOR | DRV_PLANE_DEPTH,
                             .host_hz = 45,
                             .codecs = DRV_CODEC_BIT(DRV_CODEC_RAW) | DRV_CODEC_BIT(DRV_CODEC_ZSTD) |
                                       DRV_CODEC_BIT(DRV_CODEC_JPEG) | DRV_CODEC_BIT(DRV_CODEC_HEVC)};
    return in;
}

static void test_budget_numbers(void **state)
{
    (void)state;
    drv_link_budget_in in = rpi5();
    drv_link_budget b;
    drv_link_budget_compute(&in, &b);
    /* raw: 8 bytes a pixel, 2 x 1440 x 1600 pixels, 45 times a second (the 1.66 GB/s) */
    assert_float_equal(b.raw_mbps, 8.0 * 2 * 1440 * 1600 * 45 / 1e6, 1e-6);
    assert_float_equal(b.link_mbps, 40, 0);
    assert_false(b.raw_fits);
    /* coded: one row per announced colour codec, in JPEG, H.264, HEVC order; depth zstd at full resolution; with
     * the measured figures JPEG's row is about 26 MB/s on USB 2.0's 40 */
    assert_int_equal(b.n_coded, 2);
    assert_int_equal(b.colour[0], DRV_CODEC_JPEG);
    assert_int_equal(b.colour[1], DRV_CODEC_HEVC);
    const double px_s = 2.0 * 1440 * 1600 * 45;
    assert_float_equal(b.coded_mbps[0],
                       (drv_link_budget_bytes_per_px(DRV_PLANE_COLOR, DRV_CODEC_JPEG, 0) +
                        drv_link_budget_bytes_per_px(DRV_PLANE_DEPTH, DRV_CODEC_ZSTD, 0)) * px_s / 1e6,
                       1e-6);
    assert_true(b.coded_mbps[0] > 20 && b.coded_mbps[0] < 30);
    assert_true(b.coded_mbps[1] < b.coded_mbps[0]);
    assert_true(b.coded_fits);
    /* the table: raw sizes are v1's; pairs that do not exist are -1 */
    assert_true(drv_link_budget_bytes_per_px(DRV_PLANE_COLOR, DRV_CODEC_RAW, 0) == 4);
    assert_true(drv_link_budget_bytes_per_px(DRV_PLANE_DEPTH, DRV_CODEC_RAW, 1) == 1);
    assert_true(drv_link_budget_bytes_per_px(DRV_PLANE_COLOR, DRV_CODEC_ZSTD, 0) < 0);
    assert_true(drv_link_budget_bytes_per_px(DRV_PLANE_DEPTH, DRV_CODEC_JPEG, 0) < 0);
    assert_true(drv_link_budget_bytes_per_px(DRV_PLANE_COLOR, DRV_CODEC_JPEG, 1) < 0);
    assert_true(drv_link_budget_bytes_per_px(DRV_PLANE_DEPTH, DRV_CODEC_ZSTD, 3) < 0);
    /* more planes cost more; ids with zstd far less than raw */
    in.planes |= DRV_PLANE_IDS;
    drv_link_budget c;
    drv_link_budget_compute(&in, &c);
    assert_float_equal(c.raw_mbps, 10.0 * px_s / 1e6, 1e-6);
    assert_true(c.coded_mbps[0] > b.coded_mbps[0] && c.coded_mbps[0] < b.coded_mbps[0] + 2.0 * px_s / 1e6);
}

static void test_budget_line(void **state)
{
    (void)state;
    char line[512];
    drv_link_budget_in in = rpi5();
    assert_true(drv_link_budget_line(&in, line, sizeof line));
    assert_non_null(strstr(line, "link: usb high-speed ~40 MB/s; colour+depth 1440x1600x2 @45 Hz: raw needs "
                                 "1.66 GB/s, does not fit; coded (depth and other planes zstd): jpeg ~"));
    assert_non_null(strstr(line, "hevc ~"));
    assert_null(strstr(line, "h264"));
    /* full speed: nothing fits, the line says so and asks for the warning */
    in.usb_speed = DRV_USB_SPEED_FULL;
    assert_false(drv_link_budget_line(&in, line, sizeof line));
    assert_non_null(strstr(line, "nothing announced fits"));
    /* a v1 board (raw only) on USB 2.0 */
    in = rpi5();
    in.codecs = DRV_CODEC_BIT(DRV_CODEC_RAW);
    assert_false(drv_link_budget_line(&in, line, sizeof line));
    assert_non_null(strstr(line, "the board announces raw only"));
    /* before a host: the UDC's maximum, named */
    in = rpi5();
    in.usb_speed = DRV_USB_SPEED_SUPER;
    in.usb_negotiated = false;
    in.udc = "dummy_udc.0";
    assert_true(drv_link_budget_line(&in, line, sizeof line));
    assert_non_null(strstr(line, "link: usb up to super-speed ~400 MB/s (dummy_udc.0, until a host connects)"));
    /* no UDC found: high speed assumed */
    in.usb_speed = DRV_USB_SPEED_UNKNOWN;
    in.udc = NULL;
    assert_true(drv_link_budget_line(&in, line, sizeof line));
    assert_non_null(strstr(line, "high-speed ~40 MB/s assumed"));
    /* socket: unlimited fits anything; limited like USB 2.0, the same verdicts as USB 2.0 */
    in = rpi5();
    in.kind = DRV_LINK_SOCKET;
    in.codecs = DRV_CODEC_BIT(DRV_CODEC_RAW);
    assert_true(drv_link_budget_line(&in, line, sizeof line));
    assert_non_null(strstr(line, "link: socket, unlimited; colour+depth 1440x1600x2 @45 Hz: raw needs 1.66 GB/s;"));
    in.link_mbps = 40;
    assert_false(drv_link_budget_line(&in, line, sizeof line));
    assert_non_null(strstr(line, "socket limited to 40 MB/s ([frames] link_mbps)"));
    /* the mock with zstd alone: colour raw, the row named raw */
    in.kind = DRV_LINK_MOCK;
    in.codecs = DRV_CODEC_BIT(DRV_CODEC_RAW) | DRV_CODEC_BIT(DRV_CODEC_ZSTD);
    in.link_mbps = 4000;
    in.eye_w = 64, in.eye_h = 64;
    assert_true(drv_link_budget_line(&in, line, sizeof line));
    assert_non_null(strstr(line, "link: usb mock limited to 4.00 GB/s"));
    assert_non_null(strstr(line, ": raw ~"));
    /* v4l2: raw pixels, no codec rows, its mode's rate when known */
    in = rpi5();
    in.kind = DRV_LINK_V4L2;
    assert_true(drv_link_budget_line(&in, line, sizeof line));
    assert_non_null(strstr(line, "link: v4l2 capture, raw pixels in-band (its mode decides"));
    assert_null(strstr(line, "coded"));
    /* a short buffer is cut, terminated */
    char small[24];
    drv_link_budget_line(&in, small, sizeof small);
    assert_int_equal(strlen(small), sizeof small - 1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bucket_starts_full_then_paces),
        cmocka_unit_test(test_bucket_averages_the_rate),
        cmocka_unit_test(test_throttle_transport),
        cmocka_unit_test(test_usb_speed_names),
        cmocka_unit_test(test_udc_walk),
        cmocka_unit_test(test_budget_numbers),
        cmocka_unit_test(test_budget_line),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

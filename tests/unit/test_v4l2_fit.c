/* SPDX-License-Identifier: MIT */
/* Which capture modes hold the V4L2 in-band layout (drv_v4l2_fit_check): exact figures, the largest eyes really the
 * largest, the start-up refusal naming mode, eyes, planes and bytes, and docs/v4l2-inband.md's table (`--table`). */
#include <errno.h>
#include <linux/videodev2.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "drivers/drv_frames_v4l2.h"
#include "drivers/drv_v4l2_inband.h"
#include "runtime/rt_config.h"

#ifndef DOCS_DIR
#define DOCS_DIR "docs"
#endif

#define COLOR DRV_PLANE_COLOR
#define DEPTH (DRV_PLANE_COLOR | DRV_PLANE_DEPTH)

/* The layout's rows from docs/v4l2-inband.md's formula, computed here independently of drv_v4l2_layout_get. */
static int band_rows(int eye_w) { return 2 * ((2080 + eye_w - 1) / eye_w); }

static void test_figures(void **state)
{
    (void)state;
    drv_v4l2_fit f;
    char why[400];
    /* 960x1080 eyes do not fit 1080p even without depth: the band takes 6 rows. */
    assert_false(drv_v4l2_fit_check(1920, 1080, DRV_V4L2_YUYV, 960, 1080, COLOR, &f, why, sizeof why));
    assert_int_equal(f.need_w, 1920);
    assert_int_equal(f.need_h, 1080 + band_rows(960));
    assert_int_equal(f.need_bytes, (size_t)1920 * 1086 * 2);
    assert_int_equal(f.have_bytes, (size_t)1920 * 1080 * 2);
    assert_int_equal(f.max_eye_w, 960);
    assert_int_equal(f.max_eye_h, 1074);
    assert_string_equal(why, "eyes 960x1080 (colour) need a 1920x1086 in-band frame (4.0 MiB of YUYV); the capture "
                             "mode 1920x1080 YUYV has 4.0 MiB: it holds eyes up to 960x1074");
    /* ... 1200p does (the band and the rest of the mode below the eyes). */
    assert_true(drv_v4l2_fit_check(1920, 1200, DRV_V4L2_YUYV, 960, 1080, COLOR, &f, why, sizeof why));
    assert_int_equal(f.need_h, 1086);
    /* With depth: three eye heights and the band. */
    assert_false(drv_v4l2_fit_check(1920, 1080, DRV_V4L2_RGB24, 960, 1080, DEPTH, &f, why, sizeof why));
    assert_int_equal(f.need_h, 3 * 1080 + 6);
    assert_int_equal(f.need_bytes, (size_t)1920 * 3246 * 3);
    assert_int_equal(f.have_bytes, (size_t)1920 * 1080 * 3);
    assert_int_equal(f.max_eye_h, (1080 - 6) / 3 & ~1);
    assert_string_equal(why, "eyes 960x1080 (colour + depth) need a 1920x3246 in-band frame (17.8 MiB of RGB3); the "
                             "capture mode 1920x1080 RGB3 has 5.9 MiB: it holds eyes up to 960x358 with depth, "
                             "960x1074 colour only");
    /* A narrower eye than the mode allows: the largest height is given at that width (its band is taller). */
    assert_false(drv_v4l2_fit_check(1920, 1080, DRV_V4L2_YUYV, 640, 720, DEPTH, &f, why, sizeof why));
    assert_int_equal(f.max_eye_w, 960);
    assert_int_equal(f.max_eye_h, (1080 - band_rows(640)) / 3 & ~1);
    assert_true(drv_v4l2_fit_check(1920, 1080, DRV_V4L2_YUYV, 640, f.max_eye_h, DEPTH, &f, why, sizeof why));
    /* NV12's chroma plane counts in its bytes. */
    assert_true(drv_v4l2_fit_check(1280, 720, DRV_V4L2_NV12, 640, 640, COLOR, &f, why, sizeof why));
    assert_int_equal(f.need_bytes, (size_t)1280 * (640 + band_rows(640)) * 3 / 2);
    assert_int_equal(f.have_bytes, (size_t)1280 * 720 * 3 / 2);
    /* A mode too narrow for any eye. */
    assert_false(drv_v4l2_fit_check(100, 1080, DRV_V4L2_YUYV, 64, 64, COLOR, &f, why, sizeof why));
    assert_int_equal(f.max_eye_w, 0);
    assert_non_null(strstr(why, "it holds no eyes at all"));
}

static void test_refusals(void **state)
{
    (void)state;
    drv_v4l2_fit f;
    char why[400];
    assert_false(drv_v4l2_fit_check(1920, 1080, DRV_V4L2_YUYV, 720, 800, DEPTH | DRV_PLANE_IDS, &f, why, sizeof why));
    assert_non_null(strstr(why, "colour and optionally depth only"));
    assert_int_equal(f.need_w, 0);
    assert_false(drv_v4l2_fit_check(1920, 1080, DRV_V4L2_YUYV, 720, 800, DRV_PLANE_DEPTH, &f, why, sizeof why));
    assert_false(drv_v4l2_fit_check(1920, 1080, DRV_V4L2_YUYV, 721, 800, COLOR, &f, why, sizeof why));
    assert_string_equal(why,
                        "eyes 721x800 have no V4L2 in-band layout (even sizes, width 64..8192, height up to 8192)");
    assert_false(drv_v4l2_fit_check(1920, 1080, DRV_V4L2_YUYV, 32, 800, COLOR, &f, why, sizeof why));
    assert_false(drv_v4l2_fit_check(1920, 1080, DRV_V4L2_FOURCC('M', 'J', 'P', 'G'), 720, 800, COLOR, &f, why,
                                    sizeof why));
    assert_non_null(strstr(why, "MJPG"));
    assert_false(drv_v4l2_fit_check(0, 1080, DRV_V4L2_YUYV, 720, 800, COLOR, &f, why, sizeof why));
    assert_false(drv_v4l2_fit_check(1920, -1, DRV_V4L2_YUYV, 720, 800, COLOR, &f, why, sizeof why));
    assert_false(drv_v4l2_fit_check(1920, 1080, DRV_V4L2_YUYV, 720, 800, COLOR | DEPTH, &f, NULL, 0));
}

/* For every common mode: the largest eyes fit, and two more pixels either way do not. */
static void test_largest_eyes_are_largest(void **state)
{
    (void)state;
    for (int i = 0; i < drv_v4l2_common_mode_count; i++)
        for (int d = 0; d < 2; d++) {
            const drv_v4l2_mode *m = &drv_v4l2_common_modes[i];
            unsigned planes = d ? DEPTH : COLOR;
            drv_v4l2_fit f, g;
            drv_v4l2_fit_check(m->w, m->h, DRV_V4L2_YUYV, 64, 2, planes, &f, NULL, 0);
            int w = f.max_eye_w;
            drv_v4l2_fit_check(m->w, m->h, DRV_V4L2_YUYV, w, 2, planes, &f, NULL, 0);
            int h = f.max_eye_h;
            assert_true(w >= 64 && h >= 2);
            if (!drv_v4l2_fit_check(m->w, m->h, DRV_V4L2_YUYV, w, h, planes, &g, NULL, 0))
                fail_msg("%s: %dx%d should fit", m->name, w, h);
            assert_false(drv_v4l2_fit_check(m->w, m->h, DRV_V4L2_YUYV, w, h + 2, planes, &g, NULL, 0));
            assert_false(drv_v4l2_fit_check(m->w, m->h, DRV_V4L2_YUYV, w + 2, 2, planes, &g, NULL, 0));
        }
}

/* ---- a capture device whose mode is fixed (as an HDMI bridge's is: the incoming signal's) ---- */

static int fake_w, fake_h;

static int fake_open(void *ctx, const char *path, int flags) { return (void)ctx, (void)path, (void)flags, 3; }
static int fake_close(void *ctx, int fd) { return (void)ctx, (void)fd, 0; }
static int fake_ioctl(void *ctx, int fd, unsigned long req, void *arg)
{
    (void)ctx, (void)fd;
    if (req == VIDIOC_QUERYCAP) {
        struct v4l2_capability *c = arg;
        memset(c, 0, sizeof *c);
        c->capabilities = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING;
        return 0;
    }
    if (req == VIDIOC_ENUM_FMT) {
        struct v4l2_fmtdesc *d = arg;
        if (d->index > 0) return errno = EINVAL, -1;
        d->pixelformat = V4L2_PIX_FMT_YUYV;
        return 0;
    }
    if (req == VIDIOC_S_FMT) {
        struct v4l2_format *f = arg;
        f->fmt.pix.width = (uint32_t)fake_w, f->fmt.pix.height = (uint32_t)fake_h;
        f->fmt.pix.bytesperline = (uint32_t)fake_w * 2;
        f->fmt.pix.sizeimage = (uint32_t)(fake_w * fake_h * 2);
        f->fmt.pix.field = V4L2_FIELD_NONE;
        return 0;
    }
    return errno = ENOTTY, -1; /* buffers: not this test's business */
}
static void *fake_mmap(void *ctx, size_t len, int fd, off_t off)
{
    return (void)ctx, (void)len, (void)fd, (void)off, NULL;
}
static int fake_munmap(void *ctx, void *p, size_t len) { return (void)ctx, (void)p, (void)len, 0; }
static int fake_poll(void *ctx, int fd, short ev, int ms, short *rev)
{
    return (void)ctx, (void)fd, (void)ev, (void)ms, *rev = 0, 0;
}
static const drv_v4l2_dev_ops fake_ops = {fake_open, fake_close, fake_ioctl, fake_mmap, fake_munmap, fake_poll, NULL};

static const char *start(int mode_w, int mode_h, int eye_w, int eye_h, bool depth, char *err, int errlen)
{
    fake_w = mode_w, fake_h = mode_h;
    drv_frames_v4l2_params p;
    memset(&p, 0, sizeof p);
    snprintf(p.device, sizeof p.device, "/dev/video7");
    snprintf(p.format, sizeof p.format, "auto");
    p.eye_w = eye_w, p.eye_h = eye_h, p.depth = depth;
    err[0] = 0;
    drv_frames *fr = drv_frames_v4l2_create_on_ops(&p, &fake_ops, NULL, "v4l2-fake", err, errlen);
    assert_null(fr); /* the fake has no buffers: it never starts, but for which reason is the test */
    return err;
}

static void test_startup_refuses_what_does_not_fit(void **state)
{
    (void)state;
    char err[400];
    assert_string_equal(start(1920, 1080, 960, 1080, true, err, sizeof err),
                        "/dev/video7: eyes 960x1080 (colour + depth) need a 1920x3246 in-band frame (11.9 MiB of "
                        "YUYV); the capture mode 1920x1080 YUYV has 4.0 MiB: it holds eyes up to 960x358 with depth, "
                        "960x1074 colour only");
    /* Eyes that fit get past the mode to the buffers (which the fake refuses). */
    start(1920, 1080, 960, 358, true, err, sizeof err);
    assert_null(strstr(err, "in-band frame"));
    assert_non_null(strstr(err, "REQBUFS"));
}

/* --check-config: an eye size without a layout is an error, one larger than every common mode a warning. */
static bool any_has(const rt_config_errors *e, const char *what)
{
    for (int i = 0; i < e->count; i++)
        if (strstr(e->msg[i], what)) return true;
    return false;
}

static void check_config(int eye_w, int eye_h, bool depth, const char *device, rt_config_errors *err,
                         rt_config_errors *warn)
{
    rt_config c;
    rt_config_defaults(&c);
    char sets[5][160];
    snprintf(sets[0], sizeof sets[0], "frames.backend=v4l2");
    snprintf(sets[1], sizeof sets[1], "frames.device=%s", device);
    snprintf(sets[2], sizeof sets[2], "eye.width=%d", eye_w);
    snprintf(sets[3], sizeof sets[3], "eye.height=%d", eye_h);
    snprintf(sets[4], sizeof sets[4], "frames.depth=%s", depth ? "true" : "false");
    memset(err, 0, sizeof *err);
    memset(warn, 0, sizeof *warn);
    for (int i = 0; i < 5; i++)
        if (!rt_config_set(&c, sets[i], err)) fail_msg("%s: %s", sets[i], err->msg[0]);
    rt_config_validate(&c, err);
    rt_config_warnings(&c, warn);
}

static void test_check_config(void **state)
{
    (void)state;
    rt_config_errors err, warn;
    check_config(720, 800, false, "/dev/video0", &err, &warn);
    assert_false(any_has(&err, "v4l2"));
    assert_false(any_has(&warn, "v4l2"));
    check_config(722, 801, false, "/dev/video0", &err, &warn);
    assert_true(any_has(&err, "[frames] backend = v4l2: eyes 722x801 have no V4L2 in-band layout"));
    check_config(1440, 1600, false, "/dev/video0", &err, &warn);
    assert_false(any_has(&warn, "v4l2")); /* 4K UHD holds it */
    check_config(1440, 1600, true, "/dev/video0", &err, &warn);
    assert_false(any_has(&err, "v4l2"));
    assert_true(any_has(&warn, "[frames] backend = v4l2: eyes 1440x1600 (colour + depth) need a 2880x4804 in-band "
                               "frame, larger than every common capture mode up to DCI 4K 4096x2160"));
    check_config(1440, 1600, true, "mock", &err, &warn); /* the mock delivers any layout */
    assert_false(any_has(&warn, "v4l2"));
}

/* ---- docs/v4l2-inband.md's tables ---- */

static const struct {
    int w, h;
    const char *note;
} eyes[] = {
    {640, 352, ""}, {960, 540, ""}, {640, 720, ""}, {720, 800, " (simulator)"}, {960, 1080, ""}, {1080, 1200, ""},
    {1440, 1600, " (rpi5, generic-aarch64)"}, {1832, 1920, ""},
};

static void held_by(int w, int h, unsigned planes, char *buf, size_t len)
{
    buf[0] = 0;
    for (int i = 0; i < drv_v4l2_common_mode_count; i++) {
        drv_v4l2_fit f;
        if (!drv_v4l2_fit_check(drv_v4l2_common_modes[i].w, drv_v4l2_common_modes[i].h, DRV_V4L2_YUYV, w, h, planes,
                                &f, NULL, 0))
            continue;
        size_t n = strlen(buf);
        snprintf(buf + n, len - n, "%s%s", n ? ", " : "", drv_v4l2_common_modes[i].name);
    }
    if (!buf[0]) snprintf(buf, len, "none");
}

static void print_tables(FILE *out)
{
    const double mib = 1024.0 * 1024.0;
    fprintf(out, "| capture mode | a frame: YUYV/UYVY, RGB24 | largest eyes, colour | "
                 "largest eyes, colour + depth |\n");
    fprintf(out, "|---|---:|---:|---:|\n");
    for (int i = 0; i < drv_v4l2_common_mode_count; i++) {
        const drv_v4l2_mode *m = &drv_v4l2_common_modes[i];
        drv_v4l2_fit y, r, c, d;
        drv_v4l2_fit_check(m->w, m->h, DRV_V4L2_YUYV, 8192, 2, COLOR, &y, NULL, 0);
        drv_v4l2_fit_check(m->w, m->h, DRV_V4L2_RGB24, 8192, 2, COLOR, &r, NULL, 0);
        drv_v4l2_fit_check(m->w, m->h, DRV_V4L2_YUYV, y.max_eye_w, 2, COLOR, &c, NULL, 0);
        drv_v4l2_fit_check(m->w, m->h, DRV_V4L2_YUYV, y.max_eye_w, 2, DEPTH, &d, NULL, 0);
        fprintf(out, "| %s %dx%d | %.1f, %.1f MiB | %dx%d | %dx%d |\n", m->name, m->w, m->h, y.have_bytes / mib,
                r.have_bytes / mib, c.max_eye_w, c.max_eye_h, d.max_eye_w, d.max_eye_h);
    }
    fprintf(out, "\n| eyes | colour: frame (YUYV) | held by | colour + depth: frame (YUYV) | held by |\n");
    fprintf(out, "|---|---:|---|---:|---|\n");
    for (size_t i = 0; i < sizeof eyes / sizeof eyes[0]; i++) {
        drv_v4l2_fit c, d;
        char hc[128], hd[128];
        drv_v4l2_fit_check(1 << 16, 1 << 16, DRV_V4L2_YUYV, eyes[i].w, eyes[i].h, COLOR, &c, NULL, 0);
        drv_v4l2_fit_check(1 << 16, 1 << 16, DRV_V4L2_YUYV, eyes[i].w, eyes[i].h, DEPTH, &d, NULL, 0);
        held_by(eyes[i].w, eyes[i].h, COLOR, hc, sizeof hc);
        held_by(eyes[i].w, eyes[i].h, DEPTH, hd, sizeof hd);
        fprintf(out, "| %dx%d%s | %dx%d (%.1f MiB) | %s | %dx%d (%.1f MiB) | %s |\n", eyes[i].w, eyes[i].h,
                eyes[i].note, c.need_w, c.need_h, c.need_bytes / mib, hc, d.need_w, d.need_h, d.need_bytes / mib, hd);
    }
}

#define TABLE_BEGIN "<!-- fit tables: build/tests/unit/test_v4l2_fit --table writes them -->\n"
#define TABLE_END "<!-- end of fit tables -->"

static void test_docs_table_is_current(void **state)
{
    (void)state;
    FILE *f = fopen(DOCS_DIR "/v4l2-inband.md", "r");
    if (!f) fail_msg("%s: %s", DOCS_DIR "/v4l2-inband.md", strerror(errno));
    static char doc[1 << 16];
    size_t n = fread(doc, 1, sizeof doc - 1, f);
    fclose(f);
    doc[n] = 0;
    char *begin = strstr(doc, TABLE_BEGIN), *end = begin ? strstr(begin, TABLE_END) : NULL;
    if (!begin || !end) fail_msg("docs/v4l2-inband.md has no '%s' ... '%s' section", TABLE_BEGIN, TABLE_END);
    begin += strlen(TABLE_BEGIN);
    *end = 0;
    char *gen = NULL;
    size_t glen = 0;
    FILE *m = open_memstream(&gen, &glen);
    print_tables(m);
    fclose(m);
    if (strcmp(begin, gen) != 0)
        fail_msg("docs/v4l2-inband.md's fit tables are out of date: paste `build/tests/unit/test_v4l2_fit --table`");
    free(gen);
}

int main(int argc, char **argv)
{
    if (argc == 2 && strcmp(argv[1], "--table") == 0) {
        print_tables(stdout);
        return 0;
    }
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_figures),
        cmocka_unit_test(test_refusals),
        cmocka_unit_test(test_largest_eyes_are_largest),
        cmocka_unit_test(test_startup_refuses_what_does_not_fit),
        cmocka_unit_test(test_check_config),
        cmocka_unit_test(test_docs_table_is_current),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

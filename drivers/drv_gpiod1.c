/* SPDX-License-Identifier: MIT */
/* drv_gpiod1: the TE-line edge source on libgpiod 1.6 (the v1 GPIO character device API). All libgpiod use is in
 * this file, so a libgpiod v2 source can sit beside it behind the same drv_edge_source interface.
 *
 * The kernel stamps each event in its IRQ handler (CLOCK_MONOTONIC since Linux 5.7, CLOCK_REALTIME before), so the
 * edge times do not depend on when this thread gets to run. The v1 event FIFO holds 16 events and drops new ones
 * when full; a late reader therefore sees missed edges, which the estimator tolerates. */
#include "drivers/drv_gpiod1.h"

#include <errno.h>
#include <gpiod.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "warp/warp_err.h"

#define CONSUMER "hmdwarp-vsync"
#define FIFO 16 /* events the v1 kernel FIFO holds */

typedef struct {
    drv_edge_source base;
    struct gpiod_chip *chip;
    struct gpiod_line *line;
    int event_type; /* GPIOD_LINE_EVENT_RISING_EDGE or _FALLING_EDGE */
    char name[112];
} gpiod1_src;

static int64_t clock_ns(clockid_t id)
{
    struct timespec ts;
    clock_gettime(id, &ts);
    return (int64_t)ts.tv_sec * 1000000000LL + ts.tv_nsec;
}

/* the text by warp_verr; the value as libgpiod v2 returns it (-errno) */
static int fail(char *err, int errlen, int e, const char *fmt, ...) __attribute__((format(printf, 4, 5)));
static int fail(char *err, int errlen, int e, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    warp_verr(err, errlen, fmt, ap);
    va_end(ap);
    return e > 0 ? -e : -EIO;
}

static int gpiod1_wait(drv_edge_source *src, int64_t *t_ns, int max, int timeout_ms, char *err, int errlen)
{
    gpiod1_src *s = (gpiod1_src *)src;
    if (timeout_ms < 0) timeout_ms = 0;
    struct timespec to = {timeout_ms / 1000, (long)(timeout_ms % 1000) * 1000000L};
    int rc = gpiod_line_event_wait(s->line, &to);
    if (rc < 0) {
        int e = errno;
        return fail(err, errlen, e, "vsync gpio: waiting for edges on %s: %s", s->name, strerror(e));
    }
    if (rc == 0 || max <= 0) return 0;
    struct gpiod_line_event ev[FIFO];
    int n = gpiod_line_event_read_multiple(s->line, ev, (unsigned)(max < FIFO ? max : FIFO));
    if (n < 0) {
        int e = errno;
        return fail(err, errlen, e, "vsync gpio: reading edge events of %s: %s", s->name, strerror(e));
    }
    /* Kernels before 5.7 stamp v1 events with CLOCK_REALTIME: map those onto CLOCK_MONOTONIC (the offset is taken
     * now, so a wall-clock step between the edge and now shifts that edge; the estimator gates it out). */
    int64_t mono = clock_ns(CLOCK_MONOTONIC), real = 0;
    bool have_real = false;
    int out = 0;
    for (int i = 0; i < n; i++) {
        if (ev[i].event_type != s->event_type) continue; /* only the requested edge is asked for; be sure */
        int64_t t = (int64_t)ev[i].ts.tv_sec * 1000000000LL + ev[i].ts.tv_nsec;
        if (t > mono + 1000000000LL || t < mono - 60 * 1000000000LL) {
            if (!have_real) real = clock_ns(CLOCK_REALTIME), have_real = true;
            if (t > real - 60 * 1000000000LL && t < real + 1000000000LL) t += mono - real;
        }
        t_ns[out++] = t;
    }
    return out;
}

static void gpiod1_close(drv_edge_source *src)
{
    gpiod1_src *s = (gpiod1_src *)src;
    if (s->line) gpiod_line_release(s->line);
    if (s->chip) gpiod_chip_close(s->chip);
    free(s);
}

drv_edge_source *drv_gpiod1_edges_open(const char *chip, int line, bool falling_edge, char *err, int errlen)
{
    if (!chip || !chip[0]) {
        fail(err, errlen, EINVAL, "vsync gpio: no GPIO chip configured ([vsync] chip = gpiochipN, N or a path)");
        return NULL;
    }
    gpiod1_src *s = calloc(1, sizeof *s);
    if (!s) {
        fail(err, errlen, ENOMEM, "vsync gpio: out of memory");
        return NULL;
    }
    errno = 0;
    s->chip = gpiod_chip_open_lookup(chip);
    if (!s->chip) {
        int e = errno ? errno : ENOENT;
        if (e == ENOENT || e == ENODEV || e == ENOTTY)
            fail(err, errlen, e,
                 "vsync gpio: no such GPIO chip \"%s\" (looked up as path, name, number and label; `gpiodetect` "
                 "lists the chips)", chip);
        else if (e == EACCES || e == EPERM)
            fail(err, errlen, e,
                 "vsync gpio: permission denied opening GPIO chip \"%s\": run as root or give this user access to "
                 "/dev/gpiochip* (a udev rule or the gpio group)", chip);
        else
            fail(err, errlen, e, "vsync gpio: cannot open GPIO chip \"%s\": %s", chip, strerror(e));
        free(s);
        return NULL;
    }
    const char *cname = gpiod_chip_name(s->chip), *clabel = gpiod_chip_label(s->chip);
    unsigned nlines = gpiod_chip_num_lines(s->chip);
    if (line < 0 || (unsigned)line >= nlines) {
        fail(err, errlen, EINVAL, "vsync gpio: no such line %d on %s (\"%s\"), which has lines 0..%u", line, cname,
             clabel ? clabel : "", nlines ? nlines - 1 : 0);
        gpiod1_close(&s->base);
        return NULL;
    }
    snprintf(s->name, sizeof s->name, "%s line %d", cname, line);
    s->line = gpiod_chip_get_line(s->chip, (unsigned)line);
    if (!s->line) {
        int e = errno;
        fail(err, errlen, e, "vsync gpio: cannot get %s: %s", s->name, strerror(e));
        gpiod1_close(&s->base);
        return NULL;
    }
    int rc = falling_edge ? gpiod_line_request_falling_edge_events(s->line, CONSUMER)
                          : gpiod_line_request_rising_edge_events(s->line, CONSUMER);
    if (rc < 0) {
        int e = errno;
        if (e == EBUSY) {
            gpiod_line_update(s->line); /* re-read who holds it now */
            const char *who = gpiod_line_consumer(s->line);
            fail(err, errlen, e, "vsync gpio: %s is busy: used by %s%s%s (see `gpioinfo %s`)", s->name,
                 who ? "\"" : "", who ? who : "an unnamed consumer (kernel driver or another process)",
                 who ? "\"" : "", cname);
        } else if (e == EACCES || e == EPERM) {
            fail(err, errlen, e, "vsync gpio: permission denied requesting %s for edge events", s->name);
        } else if (e == ENXIO || e == EOPNOTSUPP || e == ENOTSUP) {
            fail(err, errlen, e, "vsync gpio: %s cannot generate edge interrupts (%s); wire TE to an IRQ-capable "
                 "pin", s->name, strerror(e));
        } else {
            fail(err, errlen, e, "vsync gpio: cannot request %s edge events on %s: %s",
                 falling_edge ? "falling" : "rising", s->name, strerror(e));
        }
        s->line = NULL; /* not requested: nothing to release */
        gpiod1_close(&s->base);
        return NULL;
    }
    s->event_type = falling_edge ? GPIOD_LINE_EVENT_FALLING_EDGE : GPIOD_LINE_EVENT_RISING_EDGE;
    s->base.name = s->name;
    s->base.wait = gpiod1_wait;
    s->base.close = gpiod1_close;
    return &s->base;
}

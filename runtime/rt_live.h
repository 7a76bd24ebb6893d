/* SPDX-License-Identifier: MIT */
/* rt_live: the live view of a running hmdwarpd, once a second from the helper thread: the --stats text in one of two
 * buffers (the abort handler writes the published one), the [telemetry] live_stats file and systemd's STATUS. */
#ifndef RT_LIVE_H
#define RT_LIVE_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "runtime/rt_telemetry.h"

/* Writes the key=value text (rt_summary_kv); live: the run goes on. */
typedef void (*rt_live_text)(void *ctx, FILE *out, bool live);

typedef struct {
    char path[256];       /* [telemetry] live_stats resolved ("" = no file) */
    char *buf[2];         /* one published, the other being rewritten */
    _Atomic size_t len[2];
    _Atomic int pub;      /* the buffer complete and published, -1 none yet */
    rt_hist_mark *m2p, *age; /* the histograms' counts a second ago (STATUS's "last second") */
    /* the helper thread's, from one update to the next (rates are differences over the second) */
    int64_t prev_ns;
    uint64_t prev_vsyncs, prev_frames, prev_bytes;
    bool write_failed;    /* said once, not every second */
} rt_live;

/* Marks nothing published yet: call first, before anything can fail (the abort handler may ask). */
void rt_live_reset(rt_live *l);
/* [telemetry] live_stats: auto means the runtime directory systemd makes (RuntimeDirectory=hmdwarp) when it is
 * there; a path named outright must be writable now. False with "[telemetry] live_stats = PATH: why". */
bool rt_live_alloc(rt_live *l, const char *setting, char *err, int errlen);
/* Once a second: the text (file and abort handler) and, with notify, systemd's STATUS line. The STATUS percentiles
 * are over the last second; the file's, like --stats, over the whole run. */
void rt_live_update(rt_live *l, const rt_telemetry *t, rt_live_text text, void *ctx, bool notify);
/* The last word of the file once every thread has stopped: what --stats says (running=0). */
void rt_live_final(rt_live *l, rt_live_text text, void *ctx);
/* Writes the last published text to fd with write(2); async-signal-safe. False when none was published yet. */
bool rt_live_write_last(rt_live *l, int fd);
void rt_live_free(rt_live *l);

#endif

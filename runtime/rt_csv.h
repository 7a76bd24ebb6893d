/* SPDX-License-Identifier: MIT */
/* rt_csv: the per-vsync CSV ([telemetry] csv): rows queued allocation-free on the vsync path through a ring that
 * drops rather than waits, written and rotated ([telemetry] csv_max_mb) by the helper thread. */
#ifndef RT_CSV_H
#define RT_CSV_H

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include "runtime/rt_ring.h"

/* One CSV row per vsync, produced on the vsync path and written by the telemetry thread. */
typedef struct {
    uint64_t vsync_no, frame_seq;
    int64_t vsync_ns;
    float warp_ms, m2p_ms, frame_age_ms;
    int method;
    int missed;
} rt_csv_row;

typedef struct {
    FILE *f;              /* NULL: no CSV this run; the compositor queues rows only when set */
    rt_ring ring;
    uint64_t bytes;       /* written to the current file (helper thread), for csv_max_mb */
    uint64_t max_bytes;   /* 0: never rotated */
    bool dead;            /* rotation could not reopen the file: rows are dropped, f is closed */
    char path[256];
} rt_csv;

/* Opens path (an empty path: no CSV, true) and writes the header. False with "[telemetry] csv = PATH: why". */
bool rt_csv_open(rt_csv *w, const char *path, double max_mb, char *err, int errlen);
/* Writes every queued row (the helper thread), rotating the file when it has grown to max_bytes. */
void rt_csv_drain(rt_csv *w);
void rt_csv_close(rt_csv *w);

#endif

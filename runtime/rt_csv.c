/* SPDX-License-Identifier: MIT */
/* rt_csv: the per-vsync CSV ([telemetry] csv): rows queued allocation-free on the vsync path through a ring that
 * drops rather than waits, written and rotated ([telemetry] csv_max_mb) by the helper thread. */
#include "runtime/rt_csv.h"

#include <errno.h>
#include <string.h>

#include "platform/plat_log.h"
#include "runtime/rt_config.h"
#include "warp/warp_err.h"

#define CSV_HEADER "vsync,vsync_ns,frame_seq,method,warp_ms,missed,m2p_ms,frame_age_ms\n"

bool rt_csv_open(rt_csv *w, const char *path, double max_mb, char *err, int errlen)
{
    memset(w, 0, sizeof *w);
    if (!path[0]) return true;
    snprintf(w->path, sizeof w->path, "%s", path);
    w->max_bytes = (uint64_t)(max_mb * 1024 * 1024);
    w->f = fopen(path, "w");
    if (!w->f) return warp_err(err, errlen, "[telemetry] csv = %s: %s", path, strerror(errno));
    w->bytes = (uint64_t)fprintf(w->f, "%s", CSV_HEADER);
    if (!rt_ring_alloc(&w->ring, sizeof(rt_csv_row), 8192)) return warp_err(err, errlen, "out of memory");
    return true;
}

/* The full file becomes FILE.1 (replacing the one before) and FILE starts again with its header. freopen keeps the
 * FILE pointer, which the compositor tests to decide whether to queue rows. */
static void rotate(rt_csv *w)
{
    char old[300];
    snprintf(old, sizeof old, "%s.1", w->path);
    fflush(w->f);
    if (rename(w->path, old) != 0)
        plat_log(PLAT_LOG_WARNING, "[telemetry] csv = %s: cannot rotate to %s (%s): starting it again", w->path, old,
                 strerror(errno));
    if (!freopen(w->path, "w", w->f)) {
        plat_log(PLAT_LOG_ERR, "[telemetry] csv = %s: cannot reopen (%s): no more CSV rows this run", w->path,
                 strerror(errno));
        w->dead = true; /* freopen closed the stream */
        return;
    }
    w->bytes = (uint64_t)fprintf(w->f, "%s", CSV_HEADER);
}

void rt_csv_drain(rt_csv *w)
{
    if (!w->f) return;
    rt_csv_row r;
    while (rt_ring_pop(&w->ring, &r)) {
        if (w->dead) continue;
        int n = fprintf(w->f, "%llu,%lld,%llu,%s,%.3f,%d,%.3f,%.3f\n", (unsigned long long)r.vsync_no,
                        (long long)r.vsync_ns, (unsigned long long)r.frame_seq, rt_method_name((rt_method)r.method),
                        r.warp_ms, r.missed, r.m2p_ms, r.frame_age_ms);
        if (n > 0) w->bytes += (uint64_t)n;
        if (w->max_bytes && w->bytes >= w->max_bytes) rotate(w);
    }
}

void rt_csv_close(rt_csv *w)
{
    rt_ring_free(&w->ring);
    if (w->f && !w->dead) fclose(w->f);
    memset(w, 0, sizeof *w);
}

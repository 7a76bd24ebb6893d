/* SPDX-License-Identifier: MIT */
/* rt_telemetry: counters and latency histograms of a run (vsyncs, misses, warp times per method, motion-to-photon,
 * frame age, rejected input by reason), written allocation-free from the real-time threads, summarised at exit. */
#include "runtime/rt_telemetry.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

void rt_hist_add(rt_hist *h, double ms)
{
    if (!(ms == ms)) return;
    long b = ms <= 0 ? 0 : (long)(ms * 100.0);
    if (b > RT_HIST_BINS) b = RT_HIST_BINS;
    /* one writer: relaxed load and store, no read-modify-write */
#define BUMP(field, v) atomic_store_explicit(&(field), atomic_load_explicit(&(field), memory_order_relaxed) + (v), \
                                             memory_order_relaxed)
    BUMP(h->bin[b], 1);
    uint64_t n = atomic_load_explicit(&h->count, memory_order_relaxed) + 1;
    BUMP(h->sum, ms);
    if (n == 1 || ms > atomic_load_explicit(&h->max, memory_order_relaxed))
        atomic_store_explicit(&h->max, ms, memory_order_relaxed);
    atomic_store_explicit(&h->count, n, memory_order_relaxed);
#undef BUMP
}

double rt_hist_pct(const rt_hist *h, double p) { return rt_hist_pct_of(h, 1, p); }

double rt_hist_pct_of(const rt_hist *h, int n, double p)
{
    uint64_t count = 0;
    double max = 0;
    for (int i = 0; i < n; i++) {
        uint64_t c = atomic_load_explicit(&h[i].count, memory_order_relaxed);
        double m = atomic_load_explicit(&h[i].max, memory_order_relaxed);
        if (c && (!count || m > max)) max = m;
        count += c;
    }
    if (!count) return NAN;
    uint64_t want = (uint64_t)ceil(p / 100.0 * (double)count);
    if (want < 1) want = 1;
    uint64_t acc = 0;
    for (long b = 0; b <= RT_HIST_BINS; b++) {
        for (int i = 0; i < n; i++) acc += atomic_load_explicit(&h[i].bin[b], memory_order_relaxed);
        if (acc >= want) return b == RT_HIST_BINS ? max : (b + 0.5) / 100.0;
    }
    return max;
}

double rt_hist_pct_since(const rt_hist *h, rt_hist_mark *mark, double p)
{
    /* Two passes: count what came since the mark, then walk to the percentile, moving the mark to the counts the
     * walk read (a sample added between the passes lands in this interval's walk and not again in the next). */
    uint64_t total = 0;
    for (long b = 0; b <= RT_HIST_BINS; b++)
        total += (uint32_t)(atomic_load_explicit(&h->bin[b], memory_order_relaxed) - mark->bin[b]);
    uint64_t want = (uint64_t)ceil(p / 100.0 * (double)total), acc = 0;
    if (want < 1) want = 1;
    double r = NAN;
    for (long b = 0; b <= RT_HIST_BINS; b++) {
        uint32_t now = atomic_load_explicit(&h->bin[b], memory_order_relaxed);
        acc += (uint32_t)(now - mark->bin[b]);
        mark->bin[b] = now;
        if (total && isnan(r) && acc >= want) r = (b + 0.5) / 100.0;
    }
    return r;
}

rt_telemetry *rt_telemetry_create(void) { return calloc(1, sizeof(rt_telemetry)); }

void rt_telemetry_destroy(rt_telemetry *t) { free(t); }

const char *rt_miss_name(rt_miss m)
{
    static const char *const names[RT_MISS_COUNT] = {"own", "late_wake", "descheduled", "no_buffer"};
    return m >= 0 && m < RT_MISS_COUNT ? names[m] : "?";
}

void rt_miss_advice(const uint64_t missed_by[RT_MISS_COUNT], bool gles, bool software_gpu, char *buf, int len)
{
    uint64_t total = 0, top = 0;
    rt_miss cause = RT_MISS_OWN;
    for (int m = 0; m < RT_MISS_COUNT; m++) {
        total += missed_by[m];
        if (missed_by[m] > top) top = missed_by[m], cause = (rt_miss)m;
    }
    buf[0] = 0;
    /* a stray miss or two says nothing about the set-up; advice follows the cause of most of them */
    if (total < 3) return;
    const char *s;
    if (cause == RT_MISS_OWN)
        s = !gles ? "the warp is too dear for this panel: a cheaper [warp] method, smaller eye buffers or more [render] "
                    "threads"
            : software_gpu ? "the GPU pass is too dear: this GPU is a software rasterizer, on which the CPU path is "
                             "faster ([render] renderer = cpu, or auto)"
                           : "the GPU pass is too dear for this panel: a cheaper [warp] method or smaller eye buffers";
    else if (cause == RT_MISS_NO_BUFFER)
        s = "the display held every swapchain image: a slow sink (png/raw: raise sink_every) or page flips that do not "
            "complete";
    else
        s = "the scheduler kept the compositor from its CPU: SCHED_FIFO ([render] rt_priority with CAP_SYS_NICE), "
            "cores of its own (CPUAffinity), or [render] stall_reserve_ms on a shared machine";
    snprintf(buf, (size_t)len, "%s", s);
}

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
    h->bin[b]++;
    h->count++;
    h->sum += ms;
    if (ms > h->max || h->count == 1) h->max = ms;
}

double rt_hist_pct(const rt_hist *h, double p)
{
    if (!h->count) return NAN;
    uint64_t want = (uint64_t)ceil(p / 100.0 * (double)h->count);
    if (want < 1) want = 1;
    uint64_t acc = 0;
    for (long b = 0; b <= RT_HIST_BINS; b++) {
        acc += h->bin[b];
        if (acc >= want) return b == RT_HIST_BINS ? h->max : (b + 0.5) / 100.0;
    }
    return h->max;
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

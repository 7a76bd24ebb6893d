/* rt_telemetry: counters and latency histograms of a run (vsyncs, misses, warp times per method, motion-to-photon,
 * frame age, rejected input by reason), written allocation-free from the real-time threads, summarised at exit. */
#include "runtime/rt_telemetry.h"

#include <math.h>
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

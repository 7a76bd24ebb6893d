/* SPDX-License-Identifier: MIT */
/* rt_telemetry: counters and latency histograms of a run (vsyncs, misses, warp times per method, motion-to-photon,
 * frame age, rejected input by reason), written allocation-free from the real-time threads, summarised at exit. */
#ifndef RT_TELEMETRY_H
#define RT_TELEMETRY_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include "drivers/drv_frames.h"
#include "runtime/rt_config.h"

/* Fixed-bin histogram of milliseconds: 10 us bins up to 250 ms, plus overflow. One writer thread each; the live
 * telemetry reads it while the run goes on, so every field is atomic, written with relaxed loads and stores (plain
 * moves on x86-64 and arm64: nothing on the vsync path waits). A reader sees each field whole, not all fields of
 * one instant: a percentile read live may lag its count by the sample being added. */
#define RT_HIST_BINS 25000
typedef struct {
    _Atomic uint32_t bin[RT_HIST_BINS + 1];
    _Atomic uint64_t count;
    _Atomic double sum, max;
} rt_hist;

void rt_hist_add(rt_hist *h, double ms);
/* p-th percentile (0..100), bin-centre resolution; NAN when empty. */
double rt_hist_pct(const rt_hist *h, double p);
/* p-th percentile of the samples of h[0..n-1] together (the warp time over every method auto chose). */
double rt_hist_pct_of(const rt_hist *h, int n, double p);

/* A histogram's counts as they were at some moment, so a reader can take percentiles over what came since (the
 * live view's "last second"). The reader's own copy: allocate it (about 100 KB), never on the vsync path. */
typedef struct {
    uint32_t bin[RT_HIST_BINS + 1];
} rt_hist_mark;
/* p-th percentile of the samples added since *mark, then moves *mark to now; NAN when none came. The overflow bin
 * reads as 250 ms (the mark keeps no maximum). */
double rt_hist_pct_since(const rt_hist *h, rt_hist_mark *mark, double p);

/* Why a vsync was missed. Only RT_MISS_OWN is hmdwarpd's doing: its own CPU work did not fit the time it planned
 * for it. The others are the system's: the scheduler woke the compositor too late, or took the CPU away during the
 * pass from it or from a worker it then waited for (plat_workers_stalled_ns; hmdwarpd's vsync path never blocks,
 * so time off the CPU is someone else's), or the display held every image. On a board with SCHED_FIFO and isolated
 * cores only OWN should occur; elsewhere the split says what to mend. */
typedef enum { RT_MISS_OWN, RT_MISS_LATE_WAKE, RT_MISS_DESCHEDULED, RT_MISS_NO_BUFFER, RT_MISS_COUNT } rt_miss;

/* Classifies a missed pass planned to wake at `wake` for the vsync at `t_vs`, that woke at `t_start` and whose own
 * work took `work_ns`: on the CPU path its thread's CPU time, not counting time spent waiting for a worker kept off
 * its CPU; on the GLES path that plus the GPU's time (rt_miss_gles_work), which the thread spends waiting, not
 * running, and which is the pass's own work all the same. */
static inline rt_miss rt_miss_classify(int64_t wake, int64_t t_start, int64_t t_vs, int64_t work_ns, bool buffer)
{
    if (!buffer) return RT_MISS_NO_BUFFER;
    int64_t planned = t_vs - wake;
    if (work_ns > planned) return RT_MISS_OWN;
    /* all of its work fitted yet late: woken so late the work could not fit, or kept off the CPU meanwhile */
    return t_start - wake > planned - work_ns ? RT_MISS_LATE_WAKE : RT_MISS_DESCHEDULED;
}
/* A GLES pass's own work from its thread's CPU time and the GPU time the timer queries (or glFinish bracketing)
 * measured. A software rasterizer (llvmpipe) draws on the CPUs after the submission, so the two add up; a hardware
 * GPU runs beside the submitting thread, so the longer one is the least the pass needed. */
static inline int64_t rt_miss_gles_work(int64_t cpu_ns, int64_t gpu_ns, bool software_gpu)
{
    if (gpu_ns < 0) gpu_ns = 0;
    return software_gpu ? cpu_ns + gpu_ns : cpu_ns > gpu_ns ? cpu_ns : gpu_ns;
}
/* One line of advice for the summary, from how the misses split (empty when there are too few to say). */
void rt_miss_advice(const uint64_t missed_by[RT_MISS_COUNT], bool gles, bool software_gpu, char *buf, int len);
const char *rt_miss_name(rt_miss m);

/* The counters are atomic because the helper thread reads them while the run goes on (watchdog, sd_notify STATUS,
 * the live stats file). One thread writes each; its `x++` is an uncontended atomic add (tens of cycles, a few per
 * vsync), never a lock. */
typedef struct {
    /* compositor thread */
    _Atomic uint64_t vsyncs, missed, no_buffer, no_frame, new_frames_shown;
    _Atomic uint64_t missed_by[RT_MISS_COUNT]; /* sums to missed (skipped vsyncs take the cause of the pass that overran) */
    _Atomic uint64_t method_count[RT_METHOD_COUNT];
    rt_hist warp_ms[RT_METHOD_COUNT];
    rt_hist m2p_ms;        /* newest IMU sample used -> photon time */
    rt_hist frame_age_ms;  /* frame's render pose time -> photon time: how far the warp had to reach */
    rt_hist late_ms;       /* warp finish relative to the vsync deadline (negative = early), shifted by +50 ms */
    rt_hist outside_pct;   /* per shown frame: % of the visible panel pixels sampling outside the source (warp_fov;
                            * an rt_hist of ms read as percent: 0.01 % bins) */
    _Atomic uint64_t outside_px, visible_px; /* the same summed over the run: pixels outside, pixels visible */
    _Atomic uint64_t frames_dropped; /* frames that arrived but were replaced before any vsync showed them */
    _Atomic uint64_t imu_stale;      /* vsyncs warped to the last known orientation: no IMU sample for too long */
    _Atomic uint64_t select_why[16]; /* auto: how often each rt_select_why reason decided */
    _Atomic uint64_t method_switches; /* vsyncs whose warp differed from the previous vsync's */
    /* frames thread */
    _Atomic uint64_t frames_received;
    _Atomic uint64_t frames_bytes;   /* the planes of received frames: what the host link carried */
    _Atomic uint64_t frames_rejected[DRV_FRAME_ERR_COUNT];
    rt_hist host_render_ms;
    rt_hist decode_ms;     /* framelink: a frame's decode on the frames thread (and its decode threads) */
    rt_hist prepare_ms;    /* a received frame's validation and what the warps read from it (rt_frame_prepare_on) */
    /* IMU thread */
    _Atomic uint64_t imu_samples, imu_read_errors;
    _Atomic uint64_t imu_lost;   /* times the IMU went away (read() reported the device gone) */
} rt_telemetry;

/* Whether the display ran (vsyncs presented) but no host sent anything at all, not even a rejected frame: a board
 * waiting for its host, which is no failure when it is stopped so (hmdwarpd's exit status). */
static inline bool rt_telemetry_waiting_for_host(const rt_telemetry *t)
{
    uint64_t rejected = 0;
    for (int e = 1; e < DRV_FRAME_ERR_COUNT; e++) rejected += t->frames_rejected[e];
    return t->vsyncs > 0 && t->frames_received == 0 && rejected == 0;
}

/* The telemetry block is large (histograms); allocate it, do not put it on a stack. */
rt_telemetry *rt_telemetry_create(void);
void rt_telemetry_destroy(rt_telemetry *t);

#endif

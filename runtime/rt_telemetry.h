/* rt_telemetry: counters and latency histograms of a run (vsyncs, misses, warp times per method, motion-to-photon,
 * frame age, rejected input by reason), written allocation-free from the real-time threads, summarised at exit. */
#ifndef RT_TELEMETRY_H
#define RT_TELEMETRY_H

#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>

#include "drivers/drv_frames.h"
#include "runtime/rt_config.h"
#include "runtime/rt_fusion.h"

/* Fixed-bin histogram of milliseconds: 10 us bins up to 250 ms, plus overflow. One writer thread each. */
#define RT_HIST_BINS 25000
typedef struct {
    uint32_t bin[RT_HIST_BINS + 1];
    uint64_t count;
    double sum, max;
} rt_hist;

void rt_hist_add(rt_hist *h, double ms);
/* p-th percentile (0..100), bin-centre resolution; NAN when empty. */
double rt_hist_pct(const rt_hist *h, double p);

typedef struct {
    /* compositor thread */
    uint64_t vsyncs, missed, no_buffer, no_frame, new_frames_shown;
    uint64_t method_count[RT_METHOD_COUNT];
    rt_hist warp_ms[RT_METHOD_COUNT];
    rt_hist m2p_ms;        /* newest IMU sample used -> photon time */
    rt_hist frame_age_ms;  /* frame's render pose time -> photon time: how far the warp had to reach */
    rt_hist late_ms;       /* warp finish relative to the vsync deadline (negative = early), shifted by +50 ms */
    uint64_t frames_dropped; /* frames that arrived but were replaced before any vsync showed them */
    uint64_t imu_stale;      /* vsyncs warped to the last known orientation: no IMU sample for too long */
    uint64_t select_why[16]; /* auto: how often each rt_select_why reason decided */
    uint64_t method_switches; /* vsyncs whose warp differed from the previous vsync's */
    /* frames thread */
    _Atomic uint64_t frames_received;
    _Atomic uint64_t frames_rejected[DRV_FRAME_ERR_COUNT];
    rt_hist host_render_ms;
    /* IMU thread */
    _Atomic uint64_t imu_samples, imu_read_errors;
    _Atomic uint64_t imu_lost;   /* times the IMU went away (read() reported the device gone) */
} rt_telemetry;

/* The telemetry block is large (histograms); allocate it, do not put it on a stack. */
rt_telemetry *rt_telemetry_create(void);
void rt_telemetry_destroy(rt_telemetry *t);

#endif

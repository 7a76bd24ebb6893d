/* SPDX-License-Identifier: MIT */
/* drv_vsync_est: estimates the panel's vsync period and phase from TE-line edge timestamps, robust to jitter, missed
 * and spurious edges and a panel slightly off its nominal rate. Pure and deterministic: no OS calls, no allocation. */
#ifndef DRV_VSYNC_EST_H
#define DRV_VSYNC_EST_H

#include <stdbool.h>
#include <stdint.h>

#define DRV_VSYNC_EST_WINDOW 128  /* accepted edges in the line fit (~1.4 s at 90 Hz) */
#define DRV_VSYNC_EST_RAW 16      /* unexplained edges kept for (re)acquisition */
#define DRV_VSYNC_EST_ACQUIRE 8   /* edges needed to (re)lock */
#define DRV_VSYNC_EST_MAX_DEV 0.1 /* never locks onto a period further than this from nominal */
#define DRV_VSYNC_EST_RUN 6       /* accepted edges on one side of the fit that mean the phase moved a little */

typedef enum {
    DRV_VSYNC_EDGE_ACCEPTED,  /* on the predicted vsync right after the previous accepted edge */
    DRV_VSYNC_EDGE_AFTER_GAP, /* on a predicted vsync, after drv_vsync_est_last_gap() vsyncs without an edge */
    DRV_VSYNC_EDGE_SPURIOUS,  /* between predicted vsyncs, a second edge on one, or out of order: rejected */
    DRV_VSYNC_EDGE_ACQUIRING, /* kept for acquisition: no lock yet */
    DRV_VSYNC_EDGE_LOCKED,    /* this edge completed a lock (the first, or a relock after a phase jump) */
} drv_vsync_edge_kind;

/* A vsync model: vsync k is at ref_ns + k * period_ns (any integer k). */
typedef struct {
    int64_t ref_ns;
    double period_ns;
} drv_vsync_model;

typedef struct {
    uint64_t edges;    /* edges fed */
    uint64_t accepted; /* edges taken as vsyncs (ACCEPTED, AFTER_GAP, and those a lock was made of) */
    uint64_t spurious; /* edges rejected as glitches */
    uint64_t missed;   /* vsyncs between accepted edges that had no edge */
    uint64_t locks;    /* locks gained (the first one and every relock) */
} drv_vsync_est_counters;

typedef struct {
    double nominal_ns; /* 0: invalid nominal rate, never locks */
    bool locked;
    drv_vsync_model model; /* valid when locked; ref_ns: fitted time of the newest edge in the fit */
    double rms_ns;         /* residual RMS of the fit */
    double slope_se_ns;    /* standard error of the fitted period */
    int64_t last_edge_ns;  /* newest edge fed (any kind); INT64_MIN before the first */
    int64_t last_accept_ns;
    int last_gap;
    /* fit window, a ring of accepted edges: (vsync index, time) */
    int64_t win_k[DRV_VSYNC_EST_WINDOW], win_t[DRV_VSYNC_EST_WINDOW];
    int win_n, win_head;
    int64_t base_k;     /* vsync index of the newest edge in the fit (the model's ref_ns) */
    int64_t last_acc_k; /* vsync index of the newest accepted edge (>= base_k: held edges are not in the fit yet) */
    /* accepted edges far off the fit, all on one side: held out of it until they prove a small phase jump */
    int64_t held_k[DRV_VSYNC_EST_RUN], held_t[DRV_VSYNC_EST_RUN];
    int held_n, held_sign;
    /* unexplained edges since the last accepted one, for (re)acquisition */
    int64_t raw[DRV_VSYNC_EST_RAW];
    int raw_n;
    drv_vsync_est_counters c;
} drv_vsync_est;

/* nominal_hz: the configured refresh rate; the estimator starts from it and locks only within +-10 % of it. */
void drv_vsync_est_init(drv_vsync_est *e, double nominal_hz);
/* Feeds one edge (CLOCK_MONOTONIC ns, in increasing order) and says what it was taken for. */
drv_vsync_edge_kind drv_vsync_est_edge(drv_vsync_est *e, int64_t t_ns);
bool drv_vsync_est_locked(const drv_vsync_est *e);
/* First predicted vsync strictly after after_ns and the period (the nominal one until locked). 0 when not locked. */
int64_t drv_vsync_est_next(const drv_vsync_est *e, int64_t after_ns, int64_t *period_ns);
/* The current model; false (and *m untouched) when not locked. */
bool drv_vsync_est_model(const drv_vsync_est *e, drv_vsync_model *m);
/* Vsyncs skipped before the latest AFTER_GAP edge. */
int drv_vsync_est_last_gap(const drv_vsync_est *e);
/* RMS edge-time residual against the fit, microseconds (0 until locked). */
double drv_vsync_est_jitter_us(const drv_vsync_est *e);
const drv_vsync_est_counters *drv_vsync_est_counters_get(const drv_vsync_est *e);
const char *drv_vsync_edge_kind_name(drv_vsync_edge_kind k);

/* First vsync of model m strictly after after_ns; *period_ns (if not NULL) gets the rounded period. */
int64_t drv_vsync_model_next(const drv_vsync_model *m, int64_t after_ns, int64_t *period_ns);

#endif

/* SPDX-License-Identifier: MIT */
/* drv_te_schedule: the one model of a panel's TE pulses, pure: vsync k's pulse with jitter, a lost pulse, a glitch
 * between two vsyncs, a dropout window and a phase jump, each deterministic per (seed, k). The GPIO vsync mock and the
 * HIL TE player (tests/hil/src/hil_te.c) both follow it. */
#ifndef DRV_TE_SCHEDULE_H
#define DRV_TE_SCHEDULE_H

#include <stdbool.h>
#include <stdint.h>

typedef struct {
    double period_ns;               /* the true panel period */
    double jitter_ns;               /* each pulse uniformly within +-jitter_ns of its slot */
    double miss_prob;               /* each pulse lost with this probability */
    double spurious_prob;           /* per period, one glitch between 0.1 and 0.9 of the way to the next slot */
    int64_t stop_at_ns, stop_to_ns; /* no pulses starting in [stop_at, stop_to) (relative to pulse 0) */
    int64_t jump_at_ns, jump_ns;    /* slots from jump_at_ns on are jump_ns later (INT64_MAX: never) */
    uint64_t seed;
} drv_te_schedule;

/* A schedule without faults at `period_ns`: no stop window, no jump, no jitter. */
drv_te_schedule drv_te_schedule_clean(double period_ns, uint64_t seed);

/* Slot k (its nominal start) relative to pulse 0, the jump included. */
int64_t drv_te_schedule_slot(const drv_te_schedule *s, int64_t k);

/* Start of pulse k relative to pulse 0 (the jitter may make pulse 0 negative) in *at; false when there is none: the
 * TE is stopped then, or (miss_prob) the pulse is lost. */
bool drv_te_schedule_pulse(const drv_te_schedule *s, int64_t k, int64_t *at);

/* The glitch after slot k, relative to pulse 0, in *at; false when there is none. */
bool drv_te_schedule_glitch(const drv_te_schedule *s, int64_t k, int64_t *at);

#endif

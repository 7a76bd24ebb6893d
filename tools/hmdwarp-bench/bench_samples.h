/* SPDX-License-Identifier: MIT */
/* bench_samples: the timings hmdwarp-bench's sections collect (ms per repetition or per frame) and the median and
 * percentiles their tables print. */
#ifndef BENCH_SAMPLES_H
#define BENCH_SAMPLES_H

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "warp/warp_math.h"

/* --reps is clamped to this; the link section adds at most MAX_FRAMES per scene to a row. */
#define BENCH_MAX_SAMPLES 400

typedef struct {
    double v[BENCH_MAX_SAMPLES];
    int n;
} bench_samples;

/* Adds v; beyond BENCH_MAX_SAMPLES samples are dropped. */
static inline void bench_add(bench_samples *s, double v)
{
    if (s->n < BENCH_MAX_SAMPLES) s->v[s->n++] = v;
}

/* s's samples sorted into t (BENCH_MAX_SAMPLES long); their count. */
static inline int bench_sorted(const bench_samples *s, double *t)
{
    memcpy(t, s->v, sizeof(double) * (size_t)s->n);
    qsort(t, (size_t)s->n, sizeof(double), warp_cmp_double);
    return s->n;
}

/* The p-th percentile (nearest rank: the smallest sample with at least p % at or below it); NAN when empty. */
static inline double bench_pct(const bench_samples *s, double p)
{
    if (!s->n) return NAN;
    double t[BENCH_MAX_SAMPLES];
    int n = bench_sorted(s, t);
    int i = (int)ceil(p / 100.0 * n) - 1;
    return t[i < 0 ? 0 : (i >= n ? n - 1 : i)];
}

/* The median (the mean of the middle two of an even count); NAN when empty. */
static inline double bench_median(const bench_samples *s)
{
    if (!s->n) return NAN;
    double t[BENCH_MAX_SAMPLES];
    int n = bench_sorted(s, t);
    return n % 2 ? t[n / 2] : 0.5 * (t[n / 2 - 1] + t[n / 2]);
}

#endif

/* SPDX-License-Identifier: MIT */
/* test_util: small helpers shared by the test programs (deterministic random numbers, random rotations).
 * Header-only pieces are static inline so each test binary stays self-contained. */
#ifndef TEST_UTIL_H
#define TEST_UTIL_H

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include "warp/warp_lens.h"
#include "warp/warp_math.h"

/* Prefix for the programs a test starts: the runner the test itself runs under (TEST_RUNNER, e.g.
 * qemu-aarch64-static in make check-cross) plus a space, or "". A cross-built test cannot exec a cross-built
 * program without it. */
static inline const char *test_runner(void)
{
    static char buf[256];
    const char *r = getenv("TEST_RUNNER");
    snprintf(buf, sizeof buf, "%s%s", r ? r : "", r && *r ? " " : "");
    return buf;
}

/* The reference headset's lens shape (barrel k1 0.22, k2 0.24, lateral CA red 0.996 / blue 1.008) centred at
 * (cx, cy) panel pixels with the given scale. */
static inline warp_lens test_reference_lens(double cx, double cy, double scale)
{
    warp_lens l;
    const double ca[3] = {0.996, 1.0, 1.008};
    for (int c = 0; c < 3; c++) {
        l.ch[c].k[0] = ca[c];
        l.ch[c].k[1] = 0.22 * ca[c];
        l.ch[c].k[2] = 0.24 * ca[c];
        l.ch[c].k[3] = 0;
    }
    l.center_x = cx;
    l.center_y = cy;
    l.scale = scale;
    return l;
}

typedef struct { uint64_t s; } test_rng;

static inline test_rng test_rng_make(uint64_t seed)
{
    test_rng r = {seed * 0x9E3779B97F4A7C15ull + 1};
    return r;
}
/* splitmix64: tiny, fixed-seed reproducible across platforms */
static inline uint64_t test_rng_next(test_rng *r)
{
    uint64_t z = (r->s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}
static inline double test_rng_uniform(test_rng *r, double lo, double hi)
{
    return lo + (hi - lo) * ((double)(test_rng_next(r) >> 11) * (1.0 / 9007199254740992.0));
}
static inline warp_quat test_random_quat(test_rng *r)
{
    warp_quat q = {test_rng_uniform(r, -1, 1), test_rng_uniform(r, -1, 1), test_rng_uniform(r, -1, 1),
                   test_rng_uniform(r, -1, 1)};
    warp_quat o;
    warp_quat_normalize(q, &o);
    return o;
}

#endif

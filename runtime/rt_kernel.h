/* SPDX-License-Identifier: MIT */
/* rt_kernel: [render] kernel = auto chosen by measurement at start-up: every CPU resampling kernel this build and
 * CPU run is timed on the configured lens mesh and eye, and the fastest runs (warp_resample_kernel_pick decides). */
#ifndef RT_KERNEL_H
#define RT_KERNEL_H

#include <stdbool.h>

#include "runtime/rt_config.h"
#include "runtime/rt_render_cpu.h"
#include "warp/warp_resample.h"

typedef struct {
    double ms[WARP_RESAMPLE_KERNELS]; /* median ms of one eye's rotation pass on one thread, per kernel id; 0: not
                                       * run (unavailable, or clearly slower after the warm-up round) */
    bool usable[WARP_RESAMPLE_KERNELS];
    warp_resample_kernel_id picked;
    char why[200]; /* "measured 5.83 ms vs avx512 6.12 ms, vector 21.30 ms" */
} rt_kernel_choice;

/* Times the kernels on pass's eye 0 lens mesh (with its hidden-area mask) and c's eye buffer, warped by a 5 deg yaw,
 * in the pass's tiles on the calling thread (its CPU time: a busy machine's preemption does not count), and fills
 * *out. The mesh's source positions are left at that yaw: the pass rewrites them before every draw. Start-up only:
 * it allocates, and takes some 15 to 30 ms on a PC (1440x1600 eyes), about a second under qemu-user. False (the
 * reason in err) when out of memory. */
bool rt_kernel_measure(const rt_config *c, rt_render_cpu *pass, rt_kernel_choice *out, char *err, int errlen);

#endif

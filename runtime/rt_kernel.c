/* SPDX-License-Identifier: MIT */
/* rt_kernel: [render] kernel = auto chosen by measurement at start-up: every CPU resampling kernel this build and
 * CPU run is timed on the configured lens mesh and eye, and the fastest runs (warp_resample_kernel_pick decides). */
#include "runtime/rt_kernel.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "platform/plat_clock.h"
#include "runtime/rt_render_cpu.h"
#include "warp/warp_err.h"
#include "warp/warp_math.h"
#include "warp/warp_mesh.h"

/* About this many pixels are timed per kernel and round: every so many rows of tiles, so that the lens's centre,
 * middle and rim all count (every 8th at 1440x1600). Natively the whole measurement then takes some 20 ms at
 * start-up; under an emulator (qemu-user runs the tests 20-50x slower) about a second, not tens. */
#define MEASURE_PIXELS 300000
/* Timed rounds after the warm-up; the kernels take turns within a round, so a slow spell of a busy machine hits
 * them alike, and the median drops the rounds it hit hardest. */
#define ROUNDS 5
/* A kernel this many times slower than the fastest in the warm-up round is not timed further: the scalar
 * reference costs 5-10x the SIMD kernels, and no noise makes up for that. */
#define CUTOFF 2.0
/* The head motion the pass is timed under (the bench's, 5 deg of yaw): a small rotation keeps the source
 * positions near the lens's own, as at a display's vsync. */
#define YAW_DEG 5.0

typedef struct {
    warp_mesh *mesh; /* the pass's eye 0, with its hidden-area mask */
    warp_planar3 src;
    warp_image_rgba8 dst;
    int step; /* rows of tiles: every step-th is timed */
} bench_bufs;

static void bufs_free(bench_bufs *b)
{
    warp_planar3_free(&b->src);
    warp_image_free(&b->dst);
}

/* One kernel over the timed tiles; ms of this thread's CPU time. The caller's forced kernel comes back after. */
static double time_kernel(bench_bufs *b, warp_resample_kernel_id k)
{
    const int step = b->step;
    const warp_resample_kernel_id before = warp_resample_forced_kernel();
    warp_resample_force_kernel(k);
    const warp_mesh *m = b->mesh;
    const int64_t t = plat_thread_cpu_ns();
    for (int y0 = 0; y0 < m->vp_h; y0 += RT_RENDER_CPU_TILE_H * step)
        for (int x0 = 0; x0 < m->vp_w; x0 += RT_RENDER_CPU_TILE_W)
            warp_mesh_resample(m, &b->src, &b->dst, x0, y0, x0 + RT_RENDER_CPU_TILE_W, y0 + RT_RENDER_CPU_TILE_H);
    const double ms = (double)(plat_thread_cpu_ns() - t) * 1e-6;
    warp_resample_force_kernel(before);
    return ms;
}

bool rt_kernel_measure(const rt_config *c, rt_render_cpu *pass, rt_kernel_choice *out, char *err, int errlen)
{
    memset(out, 0, sizeof *out);
    bench_bufs b;
    memset(&b, 0, sizeof b);
    /* the pass's own lens mesh and hidden-area mask, not a second copy built here from the same config */
    b.mesh = rt_render_cpu_mesh(pass, 0);
    const int vw = b.mesh->vp_w, h = b.mesh->vp_h;
    if (!warp_planar3_alloc(&b.src, c->eye_w, c->eye_h) || !warp_image_rgba8_alloc(&b.dst, b.mesh->vp_x + vw, h)) {
        bufs_free(&b);
        return warp_err(err, errlen, "[render] kernel = auto: out of memory for the kernels' measurement");
    }
    const long px = (long)vw * h;
    b.step = (int)((px + MEASURE_PIXELS - 1) / MEASURE_PIXELS);
    /* the source stays black (warp_planar3_alloc zeroes it): no kernel branches on the colours, only on the
     * positions, so its values do not change the timing */
    const warp_camera cam = rt_config_eye_camera(c, 0);
    warp_mesh_update(b.mesh, &cam, warp_quat_from_ypr(YAW_DEG * WARP_PI / 180, 0, 0));

    for (int k = WARP_RESAMPLE_SCALAR; k < WARP_RESAMPLE_KERNELS; k++)
        out->usable[k] = warp_resample_kernel_available((warp_resample_kernel_id)k);
    /* the warm-up round: caches, page faults, and which kernels are worth timing */
    double warm[WARP_RESAMPLE_KERNELS] = {0}, best = 0;
    for (int k = WARP_RESAMPLE_SCALAR; k < WARP_RESAMPLE_KERNELS; k++)
        if (out->usable[k]) {
            warm[k] = time_kernel(&b, (warp_resample_kernel_id)k);
            if (best == 0 || warm[k] < best) best = warm[k];
        }
    double t[WARP_RESAMPLE_KERNELS][ROUNDS];
    for (int r = 0; r < ROUNDS; r++)
        for (int k = WARP_RESAMPLE_SCALAR; k < WARP_RESAMPLE_KERNELS; k++)
            if (out->usable[k] && warm[k] <= best * CUTOFF) t[k][r] = time_kernel(&b, (warp_resample_kernel_id)k);
    /* per whole eye: the timed tile rows are a fraction of it */
    int rows = 0, timed = 0;
    for (int y0 = 0; y0 < h; y0 += RT_RENDER_CPU_TILE_H, rows++) timed += rows % b.step == 0;
    for (int k = WARP_RESAMPLE_SCALAR; k < WARP_RESAMPLE_KERNELS; k++)
        if (out->usable[k] && warm[k] <= best * CUTOFF) {
            qsort(t[k], ROUNDS, sizeof t[k][0], warp_cmp_double);
            out->ms[k] = t[k][ROUNDS / 2] * rows / timed;
        }
    bufs_free(&b);

    out->picked = warp_resample_kernel_pick(out->ms, out->usable);
    int n = snprintf(out->why, sizeof out->why, "measured %.2f ms", out->ms[out->picked]);
    const char *sep = " vs ";
    for (int k = WARP_RESAMPLE_KERNELS - 1; k >= WARP_RESAMPLE_SCALAR; k--)
        if (k != (int)out->picked && out->usable[k] && n < (int)sizeof out->why) {
            const char *name = warp_resample_kernel_name((warp_resample_kernel_id)k);
            char *at = out->why + n;
            const size_t left = sizeof out->why - (size_t)n;
            n += out->ms[k] > 0 ? snprintf(at, left, "%s%s %.2f ms", sep, name, out->ms[k])
                                : snprintf(at, left, "%s%s > %.0fx", sep, name, CUTOFF);
            sep = ", ";
        }
    if (n < (int)sizeof out->why) snprintf(out->why + n, sizeof out->why - (size_t)n, " for one eye on one thread");
    return true;
}

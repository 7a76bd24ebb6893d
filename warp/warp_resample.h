/* SPDX-License-Identifier: MIT */
/* warp_resample: the CPU resampler of the display path: per-channel bilinear sampling through a distortion mesh,
 * in fixed point from planar 8-bit sources, tile by tile; portable, AVX2 and AVX-512 kernels, bit-identical. */
#ifndef WARP_RESAMPLE_H
#define WARP_RESAMPLE_H

#include <stdbool.h>
#include <stdint.h>

#include "warp/warp_image.h"
#include "warp/warp_mesh.h"

/* Source colour prepared for per-channel sampling: one plane per channel (R, G, B) in which element (x, y) holds
 * the 16-bit pair (p[y][x], p[y+1][x]). A single 32-bit load (or gather element) at (x, y) then fetches all four
 * bilinear taps of one channel, and two 64-byte loads of neighbouring row pairs give the AVX-512 kernel a table
 * of 32 columns x 3 rows to pick 16 pixels' taps from. Rows are padded so that loads at any clamped sample
 * position stay in the buffer, including those 64-byte windows. Built once per host frame, off the vsync path. */
typedef struct {
    int w, h, stride; /* stride in elements */
    uint16_t *plane[3];
    void *mem;
} warp_planar3;

bool warp_planar3_alloc(warp_planar3 *p, int w, int h);
void warp_planar3_free(warp_planar3 *p);
/* Deinterleaves rows [y0, y1) of src (same size as p). */
void warp_planar3_from_rgba_rows(warp_planar3 *p, const warp_image_rgba8 *src, int y0, int y1);

/* Resamples the viewport-relative rectangle [x0, x1) x [y0, y1) of the mesh's viewport into dst, which is the
 * whole panel image (written at vp_x + x, vp_y + y). Positions outside the source are clamped to its border
 * (003 §4.3 fringe fill). Alpha is written as 255. Allocation-free; rectangles are independent (threads), and a
 * pixel's value does not depend on how the viewport is cut into rectangles.
 * Precision: sample positions are rounded to 1/64 source pixel and the bilinear weights are 6-bit (OpenCV's
 * remap uses 1/32 pixel); the result is rounded to nearest. All kernels compute exactly the same values. */
void warp_mesh_resample(const warp_mesh *m, const warp_planar3 *src, warp_image_rgba8 *dst, int x0, int y0, int x1,
                        int y1);

/* The kernels, narrowest first: SCALAR is the per-pixel reference; VECTOR is portable SIMD (GCC/clang vector
 * extensions: NEON on aarch64); AVX2 and AVX-512 (F and BW) are chosen at run time on x86-64. AUTO runs the one
 * warp_resample_set_auto chose (by measurement, warp_resample_kernel_pick), else the widest available. */
typedef enum {
    WARP_RESAMPLE_AUTO = 0,
    WARP_RESAMPLE_SCALAR,
    WARP_RESAMPLE_VECTOR,
    WARP_RESAMPLE_AVX2,
    WARP_RESAMPLE_AVX512,
    WARP_RESAMPLE_KERNELS /* the count, AUTO included */
} warp_resample_kernel_id;

/* Times within this fraction of the fastest count as a tie, which the narrower kernel wins: a wider one must be
 * clearly faster to be worth its power and its frequency drop on some CPUs (AVX-512), and a start-up measurement
 * on a busy machine is noisier than that anyway. */
#define WARP_RESAMPLE_PICK_TIE 0.02

/* AUTO's choice from measured times: ms[k] is kernel k's time on a representative mesh and eye (k a kernel id;
 * ms[AUTO] is ignored; <= 0 or NaN: not measured), usable[k] whether this build and CPU run it. Returns the
 * narrowest usable, measured kernel within WARP_RESAMPLE_PICK_TIE of the fastest; the widest available when none
 * was measured. Pure: the caller times the kernels (warp/ has no clock). */
warp_resample_kernel_id warp_resample_kernel_pick(const double ms[WARP_RESAMPLE_KERNELS],
                                                  const bool usable[WARP_RESAMPLE_KERNELS]);
/* The widest kernel this build and CPU run: AUTO's choice until warp_resample_set_auto. */
warp_resample_kernel_id warp_resample_kernel_widest(void);
/* Makes AUTO run kernel k (a measured choice); AUTO restores the widest. False, changing nothing, when k is not
 * available. Not thread-safe: set it before resampling. */
bool warp_resample_set_auto(warp_resample_kernel_id k);
/* Name of kernel k ("auto", "scalar", "vector", "avx2", "avx512"; "?" out of range). */
const char *warp_resample_kernel_name(warp_resample_kernel_id k);

/* Name of the kernel in use ("avx512", "avx2", "vector" or "scalar"). */
const char *warp_resample_kernel(void);
/* Whether this build and CPU can run kernel k (AUTO, SCALAR and VECTOR always can). */
bool warp_resample_kernel_available(warp_resample_kernel_id k);
/* Forces kernel k for all later calls (tests compare kernels bit for bit; benchmarks report each); AUTO undoes it.
 * Returns false, changing nothing, when k is not available. Not thread-safe: set it before resampling. */
bool warp_resample_force_kernel(warp_resample_kernel_id k);
/* The kernel forced, AUTO when none. */
warp_resample_kernel_id warp_resample_forced_kernel(void);
/* Forces the scalar reference kernel, or back to AUTO. */
void warp_resample_force_scalar(bool force);

#endif

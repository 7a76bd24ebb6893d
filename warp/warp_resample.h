/* warp_resample: the CPU resampler of the display path: per-channel bilinear sampling through a distortion mesh,
 * in 8.8 fixed point from planar 8-bit sources, tile by tile, with an AVX2 kernel chosen at run time. */
#ifndef WARP_RESAMPLE_H
#define WARP_RESAMPLE_H

#include <stdbool.h>
#include <stdint.h>

#include "warp/warp_image.h"
#include "warp/warp_mesh.h"

/* Source colour split into R, G, B planes. Per-channel sampling (chromatic aberration) reads one byte pair per
 * row from each plane, so a plane needs a quarter of the memory traffic of interleaved RGBA. Rows are padded so
 * that a 4-byte load at any clamped sample position stays inside the buffer. Built once per host frame, off the
 * vsync path. */
typedef struct {
    int w, h, stride;
    uint8_t *plane[3];
    void *mem;
} warp_planar3;

bool warp_planar3_alloc(warp_planar3 *p, int w, int h);
void warp_planar3_free(warp_planar3 *p);
/* Deinterleaves rows [y0, y1) of src (same size as p). */
void warp_planar3_from_rgba_rows(warp_planar3 *p, const warp_image_rgba8 *src, int y0, int y1);

/* Resamples the viewport-relative rectangle [x0, x1) x [y0, y1) of the mesh's viewport into dst, which is the
 * whole panel image (written at vp_x + x, vp_y + y). Positions outside the source are clamped to its border
 * (003 §4.3 fringe fill). Alpha is written as 255. Allocation-free; rectangles are independent (threads). */
void warp_mesh_resample(const warp_mesh *m, const warp_planar3 *src, warp_image_rgba8 *dst, int x0, int y0, int x1,
                        int y1);

/* Name of the kernel in use ("avx2" or "scalar"). */
const char *warp_resample_kernel(void);
/* Forces the portable kernel (tests compare the two bit for bit; benchmarks report both). */
void warp_resample_force_scalar(bool force);

#endif

/* SPDX-License-Identifier: MIT */
/* warp_mesh_trace: the per-pixel part of the display path's depth warp: lens mesh cells whose rays meet a depth
 * discontinuity (000 §3: refine the grid only there) are raytraced per pixel (003 §3.5), the rest interpolated. */
#ifndef WARP_MESH_TRACE_H
#define WARP_MESH_TRACE_H

#include <stdbool.h>
#include <stdint.h>

#include "warp/warp_image.h"
#include "warp/warp_mesh.h"
#include "warp/warp_raytrace.h"
#include "warp/warp_resample.h"
#include "warp/warp_scan.h"

/* When a cell is traced per pixel: some pixel of it is shown (the hidden-area mask), and a vertex's ray crossed a
 * depth edge, or the ray through its centre lands more than `parallax_px` source pixels from where the interpolation
 * between its vertices puts it (000 §4.1's error test): an edge through the cell, an object between its vertices, a
 * surface too curved to interpolate, or the border of what the source saw where a translation uncovers it. A
 * slanted plane interpolates well and is not traced; nor is the ring where the lens sees beyond the eye buffer,
 * whose clamped fringe fill (003 §4.3) the interpolation already gives. */
typedef struct {
    float parallax_px; /* source pixels */
} warp_mesh_trace_params;

/* parallax_px 0.5: at a silhouette whose sides lie a few pixels of parallax apart (an object before the wall it
 * nearly touches) the centre ray of a cell it crosses lands 0.8-0.9 px from the interpolation while the pixels
 * beside the silhouette are 1-2 px off: at 1 px such cells went untraced and raytrace_mesh fell 1.4-1.7 dB below the
 * per-pixel raytrace and the grid in the depth-edge band (`make bench`, room and glass); at 0.5 within 0.7 dB, for
 * some 10 % more cells traced. */
warp_mesh_trace_params warp_mesh_trace_default_params(void);

/* What warp_mesh_trace_rect did, summed over the rectangles traced while warp_mesh_trace.stats points here: counts
 * for tests and the bench (what the per-pixel work costs, not its time). One atomic add per field per rectangle, so
 * threads may share it. */
typedef struct {
    _Atomic long pixels;       /* shown pixels of marked cells written */
    _Atomic long lattice_rays; /* full rays (green) on the lattice of the marked cells */
    _Atomic long pixel_rays;   /* full rays (green) for single pixels */
    _Atomic long channel_rays; /* full rays of red or blue beside depth edges */
    _Atomic long samples;      /* depth samples the searches took: the lattice's, the single pixels' (full or at
                                * their block's surfaces, where a surface read counts one), red's and blue's (the
                                * refinement's not counted) */
} warp_mesh_trace_stats;

/* The per-cell marks of one mesh: allocated once (start-up), rewritten per vsync by warp_mesh_trace_mark. */
typedef struct {
    int cells_x, cells_y; /* the mesh's cols - 1 and rows - 1 */
    uint8_t *cell;        /* [j * cells_x + i]: 1 = cell (i, j) is traced per pixel */
    int marked;           /* cells marked by the last warp_mesh_trace_mark */
    warp_mesh_trace_stats *stats; /* NULL (warp_mesh_trace_alloc's), or where warp_mesh_trace_rect adds its counts */
} warp_mesh_trace;

bool warp_mesh_trace_alloc(warp_mesh_trace *t, const warp_mesh *m);
void warp_mesh_trace_free(warp_mesh_trace *t);

/* Marks the cells of m, just updated by warp_mesh_update_raytrace for dst_cam under s (or, last and scan not NULL,
 * by warp_mesh_update_raytrace_rolling under s and last), that are to be traced per pixel. Returns the count.
 * Allocation-free: vsync path. */
int warp_mesh_trace_mark(warp_mesh_trace *t, const warp_mesh *m, const warp_camera *dst_cam,
                         const warp_raytrace_setup *s, const warp_raytrace_setup *last, const warp_scan *scan,
                         const warp_mesh_trace_params *p);

/* Overwrites the marked cells' pixels within the viewport rectangle [x0, x1) x [y0, y1) of dst (the panel, as
 * warp_mesh_resample writes it) with rays: green's through the eye-buffer position of the pixel's lens direction
 * (interpolated between the cell's vertices, as the two-pass path's lens mesh does), traced under s; red and blue at
 * their own lens directions on the surface green hit, except beside depth edges, where a channel half a pixel or more
 * from green's (chromatic aberration) gets its own ray when that surface is not there or something nearer may stop it;
 * sampled from src as the resampler samples (1/64 pixel, clamped border). Rays run on a lattice 4 pixels apart first,
 * and per pixel only in the 4 x 4 blocks whose corners disagree (a flag, or their hits' parallax by more than a pixel);
 * the rest is interpolated between them. A pixel's ray is sought only where it would meet the surfaces its block's
 * corners hit (their depths interpolated to it: one surface read where that surface is smooth, a few steps at an
 * edge: warp_raytrace_point_guess), and over the whole depth range only where it finds nothing there. On a rolling
 * panel (last and scan not NULL) each pixel is traced under s (the first line's pose) and last and interpolated by
 * its scan fraction, as the mesh's vertices are. Hidden pixels (m->visible) are left alone. Allocation-free;
 * rectangles are independent (threads). */
void warp_mesh_trace_rect(const warp_mesh_trace *t, const warp_mesh *m, const warp_camera *dst_cam,
                          const warp_raytrace_setup *s, const warp_raytrace_setup *last, const warp_scan *scan,
                          const warp_planar3 *src, warp_image_rgba8 *dst, int x0, int y0, int x1, int y1);

/* The display path's depth warp on one mesh (raytrace_mesh), in its two steps and whole; the runtime's pass, the
 * evaluator, the tools and the tests all draw it through these. Rolling panel: last and scan not NULL (s is then
 * the first line's setup). t NULL: the vertices alone (rays at the mesh's vertices, interpolated between them;
 * p unused).
 * Per vsync, once per mesh: the rays at the vertices (warp_mesh_update_raytrace or _rolling), then the cells they
 * mark for per-pixel rays under p (warp_mesh_trace_mark). Returns the marked count (0 with t NULL).
 * Allocation-free: vsync path. */
int warp_mesh_raytrace_vertices(warp_mesh *m, warp_mesh_trace *t, const warp_camera *dst_cam,
                                const warp_raytrace_setup *s, const warp_raytrace_setup *last, const warp_scan *scan,
                                const warp_mesh_trace_params *p);
/* Then per rectangle of the viewport (as warp_mesh_resample and warp_mesh_trace_rect take it): the resampling
 * through the mesh from src into dst, the marked cells overwritten with rays. Independent rectangles (threads);
 * the kernel is the resampler's (warp_resample_force_kernel). Allocation-free: vsync path. */
void warp_mesh_raytrace_rect(const warp_mesh *m, const warp_mesh_trace *t, const warp_camera *dst_cam,
                             const warp_raytrace_setup *s, const warp_raytrace_setup *last, const warp_scan *scan,
                             const warp_planar3 *src, warp_image_rgba8 *dst, int x0, int y0, int x1, int y1);
/* Both steps over the whole viewport on the calling thread. Returns the marked count. Allocation-free. */
int warp_mesh_raytrace_draw(warp_mesh *m, warp_mesh_trace *t, const warp_camera *dst_cam,
                            const warp_raytrace_setup *s, const warp_raytrace_setup *last, const warp_scan *scan,
                            const warp_mesh_trace_params *p, const warp_planar3 *src, warp_image_rgba8 *dst);

#endif

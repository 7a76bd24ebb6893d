/* SPDX-License-Identifier: MIT */
/* warp_mesh: the distortion mesh that fuses a rotation warp with lens distortion and chromatic aberration, so the
 * display image of each eye is produced in one resampling pass (the approach of Monado's and Cardboard's meshes). */
#ifndef WARP_MESH_H
#define WARP_MESH_H

#include <stdbool.h>
#include <stdint.h>

#include "warp/warp_camera.h"
#include "warp/warp_image.h"
#include "warp/warp_lens.h"
#include "warp/warp_raytrace.h"
#include "warp/warp_scan.h"

/* Values per mesh cell in `lines`: for each channel c (R, G, B) and axis a (x, y) an offset p and a slope q, at
 * index WARP_MESH_LINE(c, a, 0) and WARP_MESH_LINE(c, a, 1). */
#define WARP_MESH_LINE_VALUES 12
#define WARP_MESH_LINE(c, a, pq) ((c) * 4 + (a) * 2 + (pq))

/* A grid of `rows` x `cols` vertices over one eye's viewport of the panel. n, the size asked for, means "about n
 * vertices per side":
 *  - rows = n, spread evenly: vertex row j at y = j * vp_h / (n - 1), from the viewport's top to its bottom edge;
 *  - columns are cell_w pixels apart, cell_w a multiple of 8 near vp_w / (n - 1) (8 * round(vp_w / (n-1) / 8),
 *    at least 8): vertex column i at x = i * cell_w, cols = ceil(vp_w / cell_w) + 1, so the last column may lie
 *    beyond the viewport's right edge. Every aligned run of 8 pixels then lies in one cell, which lets the SIMD
 *    resampler treat 8 (or 16) pixels with one set of coefficients instead of looking a cell up per pixel.
 * x and y are continuous viewport coordinates (pixel (x, y) has its centre at (x + 0.5, y + 0.5)); the lens and
 * the warp are evaluated exactly there, and the resampler interpolates bilinearly in between.
 * Per vertex and channel the mesh holds the lens direction (fixed at start-up) and the source pixel position for
 * the current warp; per cell it holds those positions in the form the resampler evaluates (`lines`). Both are
 * rebuilt every vsync. */
typedef struct {
    int n;                      /* vertices per side asked for (= rows) */
    int rows, cols;             /* vertex rows and columns */
    int cell_w;                 /* horizontal vertex spacing, pixels, a multiple of 8 */
    int vp_x, vp_y, vp_w, vp_h; /* viewport on the panel, pixels */
    warp_vec2f *tan;            /* [(j*cols + i)*3 + c] lens tangent direction (u, v) */
    warp_vec2f *src;            /* [(j*cols + i)*3 + c] source pixel position for the current warp */
    /* Per cell band j (between vertex rows j and j+1), value k and cell i:
     *   lines[((j * 2 + 0) * WARP_MESH_LINE_VALUES + k) * line_stride + i]  value at the band's top edge,
     *   lines[((j * 2 + 1) * WARP_MESH_LINE_VALUES + k) * line_stride + i]  change across the band,
     * so a row at fraction ty of the band has value(k) = top + change * ty. For channel c and axis a the source
     * position of the pixel at xl pixels right of its cell's left edge (xl = x + 0.5 - i * cell_w), interpolated
     * bilinearly between the cell's corners, is
     *   64 * pos - 31.5 = value(p) + value(q) * xl,
     * i.e. in 1/64 source pixel, shifted by the half pixel between centres and corners, plus 0.5 so that
     * truncating rounds to the nearest 1/64 (see warp_resample.c). */
    float *lines;
    int line_stride; /* a multiple of 8, with room for 8-wide loads starting at the last cell */
    double *work;    /* scratch of warp_mesh_update (allocated here: the update runs on the vsync path) */
    /* The hidden-area mask (warp_fov_spans), set by the mesh's owner, who keeps it alive: NULL shows every pixel,
     * else viewport row y shows pixels [visible[2 y], visible[2 y + 1]) and the resamplers (CPU and GLES) write the
     * rest opaque black without sampling: outside the lens's visible disc nothing is seen, and a clamped edge smeared
     * there would show in the periphery whenever the lens lets a little light through. */
    const int32_t *visible;
    int behind;      /* vertices of the last update that pointed behind the source camera (warp_mesh_update) or
                      * whose ray left the source (warp_mesh_update_raytrace) */
    uint8_t *flags;  /* [j*cols + i] the raytrace's flags of vertex (i, j) (WARP_MASK_FRINGE / WARP_MASK_EDGE, OR over
                      * channels and rolling endpoints) after warp_mesh_update_raytrace*, 0 after a rotation update:
                      * warp_mesh_trace reads them to find the cells whose vertices disagree */
} warp_mesh;

/* Allocates the mesh and evaluates the lens at every vertex (start-up only). n must be in [2, 1024], the viewport
 * at most WARP_MAX_SIDE pixels on a side. Returns false on bad arguments or out of memory. */
bool warp_mesh_alloc(warp_mesh *m, int n, const warp_lens *lens, int vp_x, int vp_y, int vp_w, int vp_h);
/* A mesh over an eye camera's own image, without a lens: vertex (x, y) sees the direction of cam's continuous
 * pixel position (x, y), viewport (0, 0, width, height). Resampled through it, a warp gives the eye-buffer image
 * a depth warp would (tests and benchmarks compare it with them and with ground truth). Start-up only. */
bool warp_mesh_alloc_eye(warp_mesh *m, int n, const warp_camera *cam);
void warp_mesh_free(warp_mesh *m);

/* Rebuilds the source positions for a rotation warp: a vertex seeing tangent direction t of the target eye
 * samples the source at K_src * src_from_dst * (t, -1). Identity rotation = distortion only (e.g. after a
 * depth warp has already produced the target view). Allocation-free: safe on the vsync path. */
void warp_mesh_update(warp_mesh *m, const warp_camera *src_cam, warp_quat src_from_dst);
/* The same on a rolling-scan panel (warp_scan.h): each vertex is warped with the rotation at its own scan
 * fraction, slerped between `first` (src_from_dst for the pose at the scan's first line) and `last` (its last
 * line), per vertex row (vertical scans) or column (horizontal ones), so rolling-scan compensation costs nothing per
 * pixel. first == last gives warp_mesh_update's mesh bit for bit. Allocation-free: safe on the vsync path. */
void warp_mesh_update_rolling(warp_mesh *m, const warp_camera *src_cam, warp_quat first, warp_quat last,
                              const warp_scan *scan);

/* Rebuilds the source positions for a depth warp traced at the vertices only (a grid variant of the raytrace,
 * cf. 000's adaptive grid): a vertex seeing tangent direction t of the target eye takes the source position of
 * the ray through t's position in dst_cam's image, traced with warp_raytrace_point under s (prepared for dst_cam),
 * per channel (red and blue sought first at the surface green's ray met, warp_raytrace_point_guess), so lens
 * distortion, chromatic aberration and the depth warp are one resampling pass straight from the host frame. In
 * between, the resampler interpolates: parallax is smeared across depth edges inside a cell (a rubber sheet) where
 * the per-pixel raytrace keeps them sharp. Vertices whose ray leaves the source sample where the fringe fill does
 * (clamped to the border). Allocation-free: safe on the vsync path. */
void warp_mesh_update_raytrace(warp_mesh *m, const warp_camera *dst_cam, const warp_raytrace_setup *s);
/* The same on a rolling-scan panel: each vertex traced under `first` (prepared for the pose at the scan's first
 * line) and `last` (its last line) and its source position interpolated by the vertex's scan fraction (ILLIXR
 * interpolates the warp between a start and an end pose the same way). Setups for one pose give
 * warp_mesh_update_raytrace's mesh bit for bit. Allocation-free: safe on the vsync path. */
void warp_mesh_update_raytrace_rolling(warp_mesh *m, const warp_camera *dst_cam, const warp_raytrace_setup *first,
                                       const warp_raytrace_setup *last, const warp_scan *scan);

#endif

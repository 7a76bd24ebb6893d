/* SPDX-License-Identifier: MIT */
/* warp_grid: the adaptive-grid forward warp of 000 §4.1 and §5.1: a surface-estimation quadtree per tile (Didyk et
 * al. min/max baseline, cross-kernel, partial cross-kernel, irregular grid), cells warped and rasterised on the CPU. */
#ifndef WARP_GRID_H
#define WARP_GRID_H

#include <stdbool.h>
#include <stdint.h>

#include "warp/warp_camera.h"
#include "warp/warp_image.h"
#include "warp/warp_math.h"
#include "warp/warp_view.h"

typedef enum {
    WARP_GRID_DIDYK = 0,     /* Didyk et al. [6]: split while the node's disparity range is too large (000 §4.1) */
    WARP_GRID_CROSS = 1,     /* cross-kernel surface reduction: all 8 collinearity tests (000 §4.1.1, Fig. 5a) */
    WARP_GRID_PARTIAL = 2,   /* partial cross-kernel: collinear towards >= 1 horizontal and 1 vertical side (§4.1.2) */
    WARP_GRID_IRREGULAR = 3, /* partial cross-kernel plus 2:1 rectangular merges (000 §4.1.3, Fig. 6) */
} warp_grid_strategy;

typedef enum {
    WARP_GRID_FILTER_ADAPTIVE = 0, /* linear on surfaces, nearest next to a depth discontinuity (000 §5.1) */
    WARP_GRID_FILTER_LINEAR = 1,
    WARP_GRID_FILTER_NEAREST = 2,
} warp_grid_filter;

typedef struct {
    warp_grid_strategy strategy;
    int tile;               /* quadtree root size in pixels, a power of two in [2, 64]; 000 §6 uses 32 */
    float collinear_eps;    /* eq. 2's tolerance, relative: |d[i-1] - 2 d[i] + d[i+1]| <= eps * max(d) on 1/z */
    float max_error;        /* §4.1.4: a connected cell is split while its planar-fit error bound, relative 1/z,
                             * exceeds this (bound = curvature * size^2 / 8) */
    float didyk_disparity_px; /* Didyk: split while the node's disparity range for didyk_baseline_m exceeds this */
    float didyk_baseline_m;
    warp_grid_filter filter; /* Didyk ignores this and always filters linearly (rubber sheets, no discontinuities) */
    bool fill_holes;        /* fill uncovered pixels from the farther side along the row (a stand-in for §5.2) */
} warp_grid_params;

/* Irregular grid, tile 32, eps 0.02, max_error 0.02 (about Didyk's 0.5 px at 0.064 m for surfaces 0.4 m away),
 * Didyk 0.5 px at 0.064 m, adaptive filter, fill on. */
warp_grid_params warp_grid_default_params(void);
const char *warp_grid_strategy_name(warp_grid_strategy s);

typedef struct {
    long cells;             /* primitives of the grid (quads; 1x1 up to tile x tile, 2:1 rectangles for irregular) */
    long cells_1px;         /* of which single pixels (the discontinuity cost) */
    long triangles;         /* 2 per cell: what a GPU would draw */
    long discontinuous_vertices; /* cell corners that took their depth from the cell's own pixels (§5.1) */
    long bad_depth;         /* build: NaN, infinite or negative inverse depths (their cells are dropped: holes) */
    long triangles_drawn;   /* warp: triangles rasterised (clipped or behind the eye ones excluded) */
    long fragments;         /* warp: pixel samples that passed the z test */
    long linear_samples, nearest_samples; /* warp: texture filter chosen per fragment (§5.1) */
    long holes;             /* warp: target pixels no cell covered */
} warp_grid_stats;

/* A grid cell: pixels [x0, x1) x [y0, y1) of the source; d[4] are the inverse depths of its corners
 * (x0,y0), (x1,y0), (x0,y1), (x1,y1), taken between pixels on a connected surface, from the cell's own corner
 * pixel across a discontinuity (000 §5.1). */
typedef struct {
    uint16_t x0, y0, x1, y1;
    float d[4];
} warp_grid_cell;

/* Per-pixel collinearity bits (eq. 2), kept for vertex depths and the texture filter. */
enum {
    WARP_GRID_PX_H = 1,  /* (x-1, x, x+1) collinear in 1/z (or a neighbour missing) */
    WARP_GRID_PX_V = 2,  /* (y-1, y, y+1) */
    WARP_GRID_PX_D1 = 4, /* (x-1,y-1), (x,y), (x+1,y+1) */
    WARP_GRID_PX_D2 = 8, /* (x+1,y-1), (x,y), (x-1,y+1) */
};

/* Everything is allocated once per image size by warp_grid_alloc; build and warp do not allocate. */
typedef struct {
    int w, h, tile, levels;  /* level 0 nodes are 2x2 pixels, level levels-1 nodes are tile x tile */
    int lw[8], lh[8];        /* nodes per row / column at each level */
    long loff[8];            /* offset of each level in node[] / curv[] / dmin[] / dmax[] */
    uint16_t *node;          /* surface flag, side and diagonal connectedness, irregular merge type */
    float *curv;             /* max relative second difference of 1/z over the node's passing tests */
    float *dmin, *dmax;      /* inverse depth range (Didyk's criterion) */
    uint8_t *px;             /* WARP_GRID_PX_* per pixel */
    float *pxcurv;           /* per-pixel relative second difference (max over its passing tests) */
    warp_grid_cell *cell;
    long n_cells, max_cells;
    warp_grid_strategy strategy; /* what the last build used */
    warp_grid_filter filter;
} warp_grid;

bool warp_grid_alloc(warp_grid *g, int w, int h, int tile);
void warp_grid_free(warp_grid *g);

/* Preprocessing (000 §4.1): quadtree and cells for src (needs inverse depth, same size as the grid). Independent
 * of the target pose, so one build serves both eyes and several frames. Returns NULL or what is wrong. */
const char *warp_grid_build(warp_grid *g, const warp_view *src, const warp_grid_params *p, warp_grid_stats *st);

/* Re-rendering (000 §5.1): warps the cells to the eye pose dst_pose (world_from_eye) through dst_cam and rasterises
 * rows [y0, y1) with a z-buffer: dst colour, dst_inv (target 1/z, -1 where nothing landed: the z-buffer, which the
 * transparency pass and hole fillers use), mask (WARP_MASK_HOLE | WARP_MASK_FILLED where no cell landed; may be
 * NULL). The caller clears nothing. Rows are independent (each call rasterises all cells clipped to its rows). */
const char *warp_grid_warp_rows(const warp_grid *g, const warp_view *src, const warp_camera *dst_cam,
                                warp_pose dst_pose, const warp_grid_params *p, warp_image_rgba8 *dst,
                                warp_image_f32 *dst_inv, warp_image_u8 *mask, int y0, int y1, warp_grid_stats *st);

/* Entry point for tools: build + warp of the whole image. */
const char *warp_grid_run(warp_grid *g, const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose,
                          const warp_grid_params *p, warp_image_rgba8 *dst, warp_image_f32 *dst_inv,
                          warp_image_u8 *mask, warp_grid_stats *st);

/* Source pixel pair connectivity used for vertex depths and the adaptive filter: true when (x, y) and
 * (x + dx, y + dy), |dx|, |dy| <= 1, lie on one surface by eq. 2 (the test through either of them passes). */
bool warp_grid_connected(const warp_grid *g, int x, int y, int dx, int dy);

#endif

/* SPDX-License-Identifier: MIT */
/* warp_iterative: the iterative backward warp of 001 §3: per target pixel, N stratified seeds in a min-max-mipmap
 * search bound, T fixed-point steps q <- p - v(q) each, over L depth layers; dilation and approximate hole fills. */
#ifndef WARP_ITERATIVE_H
#define WARP_ITERATIVE_H

#include <stdbool.h>

#include "warp/warp_camera.h"
#include "warp/warp_image.h"
#include "warp/warp_motion.h"
#include "warp/warp_view.h"

#define WARP_ITER_MAX_LAYERS 4

/* A hidden depth layer of the source (001 §3.4, depth peeling): same camera, pose and time as the view.
 * inv_depth < 0 marks texels where the layer is empty. ids and motion are optional, as in warp_view. */
typedef struct {
    const warp_image_rgba8 *color;
    const warp_image_f32 *inv_depth;
    const warp_image_u16 *ids;
    const warp_image_vec2f *motion;
} warp_iter_layer;

/* Marks empty (-1) the texels of `layer` (inverse depth) where it shows the same surface as `front` (relative
 * inverse-depth difference <= rel_eps): turns a render of the scene without its foreground objects into a peeled
 * layer holding only what the front layer hides. Returns the number of texels left non-empty. */
long warp_iter_peel_mask(const warp_image_f32 *front, warp_image_f32 *layer, float rel_eps);

typedef enum {
    WARP_ITER_BOUND_GLOBAL = 0, /* the whole image's motion bound (the mipmap's top texel) for every pixel */
    WARP_ITER_BOUND_TIGHT = 1,  /* iterative tightening with the min-max mipmap (001 Fig. 5), axis-aligned */
    WARP_ITER_BOUND_PCA = 2,    /* tightening in the principal axes of the motion vectors (001 §3.3, oriented) */
} warp_iter_bound;

typedef struct {
    int seeds;          /* N: stratified seeds per pixel and layer (001 §3.2) */
    int iters;          /* T: fixed-point steps per seed at most (a seed stops earlier once converged or stalled) */
    int layers;         /* L: depth layers searched (1 = the view only; at most 1 + the extra layers given) */
    warp_iter_bound bound;
    int bound_iters;    /* tightening steps of 001 Fig. 5 ("two to three such narrowing steps suffice") */
    float tol;          /* convergence: a step moving q by less than this (source pixels) */
    bool early_exit;    /* one seed where the local bound is under a pixel wide: a homogeneous region (001 §3.3) */
    bool cross_layer;   /* cross-layer seeding (001 Fig. 6): empty texels of a deeper layer read the layer above */
    bool dilate;        /* close non-convergent holes from converged neighbours (001 §3.4, Fig. 8) */
    int dilate_radius;  /* ... up to this many pixels from a converged pixel */
    bool approximate;   /* AWOC of 001 §5: fill non-convergent pixels from the search bound's extreme motions */
    int pca_samples;    /* motion vectors sampled for the PCA (001 §3.3: 64) */
    bool derotate;      /* search in the rotation-compensated frame: seeds around the rotation-only reprojection G(p)
                         * of the target pixel, motions as u(q) = G(q + v(q)) - q (warp_iterative.c) */
} warp_iter_params;

/* N 8, T 32 (a cap: seeds stop when converged or no longer contracting), L 1, PCA bound with 3 tightening steps,
 * tol 0.05 px, early exit, cross-layer seeding, no dilation (radius 2 when turned on), no approximate fill, 64 PCA
 * samples, derotated search. */
warp_iter_params warp_iter_default_params(void);

typedef struct {
    long pixels;        /* target pixels searched */
    long seeds;         /* fixed-point searches started (N per pixel and layer, 1 where the early exit took) */
    long iterations;    /* fixed-point steps (motion lookups) */
    long bound_lookups; /* mipmap texel reads of the bound tightening */
    long converged;     /* pixels at least one search converged for, inside the source image */
    long converged_layer[WARP_ITER_MAX_LAYERS]; /* ... whose chosen (nearest) solution came from layer l */
    long cross_layer;   /* lookups that found their layer empty and read a nearer one (001 Fig. 6) */
    long fringe;        /* pixels whose solution lies outside the source image (clamped fill, 003 §4.3) */
    long holes;         /* pixels no search converged for (WARP_MASK_HOLE), before any fill */
    long dilated;       /* holes closed by dilation */
    long approximated;  /* holes filled by the approximate fallback */
    double bound_area;  /* sum of the search regions' areas, source pixels^2 (mean = bound_area / pixels / L) */
} warp_iter_stats;

/* Everything the warp of one source to one target needs besides the output: per-layer motion buffers, their
 * mipmaps, scratch. Allocate once per image size; prepare per frame; rows and finish per frame. */
typedef struct {
    int src_w, src_h, dst_w, dst_h, max_layers;
    warp_motion_buffer motion[WARP_ITER_MAX_LAYERS]; /* v, or u when p.derotate */
    warp_motion_mip mip[WARP_ITER_MAX_LAYERS];
    warp_image_f32 dst_depth;   /* target inverse depth of the chosen solution (dilation picks by it) */
    warp_image_u8 scratch;      /* dilation bookkeeping */
    /* set by prepare */
    const warp_view *src;
    const warp_image_rgba8 *color[WARP_ITER_MAX_LAYERS];
    warp_iter_params p;
    int layers;
    warp_mat3 src_from_dst;     /* the rotation homography target -> source pixel when p.derotate, else identity */
} warp_iter_ctx;

/* Allocates for sources of src_w x src_h, targets of dst_w x dst_h and up to max_layers layers. */
bool warp_iter_alloc(warp_iter_ctx *c, int src_w, int src_h, int dst_w, int dst_h, int max_layers);
void warp_iter_free(warp_iter_ctx *c);

/* The target of a warp: eye camera and pose (world_from_eye), the scene time it shows and, optionally, the
 * objects' poses at that time ([id - 1], world_from_object; NULL: object motion comes from the view's motion
 * plane extrapolated to dst_time, or, without one, objects are taken as static). */
typedef struct {
    warp_camera cam;
    warp_pose pose;
    double time;
    const warp_pose *object_pose;
} warp_iter_target;

/* Builds the motion buffers (001 §3.1), the PCA and the min-max mipmaps (001 §3.3) of the view and of the first
 * p->layers - 1 extra layers. Returns NULL when usable, else a static string naming what is wrong. */
const char *warp_iter_prepare(warp_iter_ctx *c, const warp_view *src, const warp_iter_layer *extra, int n_extra,
                              const warp_iter_target *dst, const warp_iter_params *p);

/* After a successful prepare: searches rows [y0, y1) of the target (001 Fig. 2, backward depth warping) and writes
 * dst; mask (may be NULL) gets WARP_MASK_FRINGE, or WARP_MASK_HOLE where no search converged (colour transparent
 * black unless the approximate fill wrote it: then WARP_MASK_HOLE | WARP_MASK_FILLED). Adds to *st (may be NULL;
 * one per thread). Rows are independent: threads may split them. Allocation-free. */
void warp_iter_rows(warp_iter_ctx *c, warp_image_rgba8 *dst, warp_image_u8 *mask, int y0, int y1,
                    warp_iter_stats *st);

/* After all rows: the dilation of non-convergent holes when p.dilate (whole image; not split by rows). */
void warp_iter_finish(warp_iter_ctx *c, warp_image_rgba8 *dst, warp_image_u8 *mask, warp_iter_stats *st);

/* The whole warp in one call: prepare, all rows, finish. mask must be non-NULL. */
const char *warp_iter_run(warp_iter_ctx *c, const warp_view *src, const warp_iter_layer *extra, int n_extra,
                          const warp_iter_target *dst, const warp_iter_params *p, warp_image_rgba8 *out,
                          warp_image_u8 *mask, warp_iter_stats *st);

#endif

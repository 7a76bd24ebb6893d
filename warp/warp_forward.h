/* SPDX-License-Identifier: MIT */
/* warp_forward: McMillan's forward 3D warp (004 eq. 1): every source pixel is moved to where the target eye sees
 * it; epipoles, occlusion-compatible traversal in 4 or 8 sheets (004 §2, §4.3), a z-buffered version, the two-pass
 * binned warp (004 §5) and the worst-case pixel movement bound p (004 eqs. 5-7). Unreached pixels are holes. */
#ifndef WARP_FORWARD_H
#define WARP_FORWARD_H

#include <stdbool.h>
#include <stdint.h>

#include "warp/warp_camera.h"
#include "warp/warp_image.h"
#include "warp/warp_math.h"
#include "warp/warp_view.h"

/* ---- the warp equation ----
 * With inverse depth delta = 1/z of a source pixel xbar1 = (x, y, 1) (centres at +0.5) and dst_from_src = (R, t):
 *     xbar2 = H xbar1 + delta e,   H = K2 R K1^-1 (the projective part), e = K2 t (the translation part),
 * which is 004 eq. 1 in our camera convention (w = -Z, so delta is the generalized disparity). xbar2 / xbar2.w is
 * the target pixel position and xbar2.w = z2 / z1, so the target inverse depth is delta / xbar2.w. Per object
 * (002 §3.2) there is one such pair (H, e): the 4x4 matrix M^i of 002 written for inverse depth. */
typedef struct {
    warp_mat3 h;
    warp_vec3 e;
} warp_fwd_xform;

warp_fwd_xform warp_fwd_xform_make(const warp_camera *src, const warp_camera *dst, warp_pose dst_from_src);

/* Maps one source sample: false when it lands behind the target eye (or the numbers are not finite). */
bool warp_fwd_xform_apply(const warp_fwd_xform *xf, double x, double y, double inv_depth, double *x2, double *y2,
                          double *inv_depth2);

/* ---- epipoles (004 §2) ----
 * The source-image epipole is the target eye's centre projected into the source image. positive: the target eye is
 * in front of the source eye's image plane (moving towards the scene); the back-to-front occlusion-compatible order
 * then moves towards the epipole, warping it last. Negative: the order moves away from it, warping it first. */
typedef struct {
    bool defined;   /* false for a pure rotation (no baseline): every order is occlusion compatible */
    bool positive;
    double hx, hy, hw; /* homogeneous source position K1 * C2 */
    double x, y;       /* after the divide (pixels; far outside the image when hw is near 0), valid when defined */
} warp_fwd_epipole;

/* Epipole of the target eye whose centre is c2_src (in the source eye's frame, metres). */
warp_fwd_epipole warp_fwd_epipole_make(const warp_camera *src, warp_vec3 c2_src);

/* ---- worst-case pixel movement (004 §3.1) ----
 * Inputs: the output display (vertical pixel count V, horizontal/vertical aspect A of the image extent, vertical
 * FOV v in radians, on-centre projection), T_max (metres: the largest distance between the source and target eye
 * centres the warp is asked to cover) and d_min (metres: the smallest distance from the source eye to any surface).
 * Output: p, the largest distance in target pixels between where a point lands and where the rotation-only
 * (projective) warp puts it: p = a_max * asin(T_max / d_min) (eqs. 5-7). INFINITY when T_max >= d_min (the target
 * eye may be inside the scene) and NAN for invalid inputs. */
double warp_fwd_pixel_bound(int v_pixels, double aspect, double vfov_rad, double t_max, double d_min);
/* The same for any camera (asymmetric frusta, non-square pixels): a_max taken at the frustum corner farthest from
 * the axis with the larger of the two pixel densities. Equals the above for a symmetric camera with square pixels. */
double warp_fwd_pixel_bound_camera(const warp_camera *dst, double t_max, double d_min);

/* ---- forward warp ---- */
typedef enum {
    WARP_FWD_ZBUFFER = 0, /* raster order, the nearest sample wins (depth test on target inverse depth) */
    WARP_FWD_SHEETS4 = 1, /* occlusion-compatible order in 4 sheets split at the epipole (004 Fig. 2), no depth test */
    WARP_FWD_SHEETS8 = 2, /* 8 sheets: the minor direction stays >= 45 degrees off the epipolar lines (004 Fig. 11) */
} warp_fwd_visibility;

typedef struct {
    warp_fwd_visibility vis;
    bool two_pass;  /* 004 §5: bin samples by post-translation pre-rotation x, then warp bin by bin (sheets only) */
    int bin_width;  /* b of 004 eq. 8, source pixels */
    float edge_jump; /* relative inverse-depth jump between neighbours that counts as a depth edge (splat sizes) */
    /* true: each sample covers its Jacobian footprint and colours it by resampling the source (see
     * warp_forward_draw_points); false: 1-pixel points, as 004 draws them (they crack wherever the warp stretches) */
    bool footprint;
} warp_forward_params;

/* SHEETS8, single pass, bin width 16, edge_jump 0.1, footprints. */
warp_forward_params warp_forward_default_params(void);

typedef struct {
    long samples;        /* source pixels warped */
    long dropped;        /* samples behind the target eye or outside the target image */
    long writes;         /* target pixel writes, overdraw included */
    long depth_rejects;  /* writes refused by the depth test (z-buffer) */
    long holes;          /* target pixels no sample reached (flagged WARP_MASK_HOLE) */
    long fringe;         /* of those, pixels whose ray at infinity leaves the source image (also WARP_MASK_FRINGE) */
    long bad_ids;        /* samples with an object id beyond the transform table: warped with the camera's */
    int sheets;          /* non-empty sheets traversed (1 for a z-buffer or an undefined epipole) */
    int bins;            /* two-pass bins */
    long seam_resolves;  /* two-pass: target pixels contested by samples of different bins (decided by order) */
} warp_forward_stats;

/* Per-frame working memory, allocated once per image size (no allocation on the warp path). Per source pixel: the
 * mapped target position and inverse depth (x = NAN: dropped) and the 2x2 Jacobian d(x2, y2)/d(x1, y1); the
 * traversal order; per target pixel: depth (or written flag), the writer's rank and distance; two-pass bins. */
typedef struct {
    int src_w, src_h, dst_w, dst_h;
    float *x2, *y2, *d2;
    float *jac;          /* 4 per source pixel: dx2/dx, dx2/dy, dy2/dx, dy2/dy */
    int32_t *order;      /* source pixel indices y * src_w + x in traversal order */
    float *zbuf;         /* per target pixel: inverse depth of the sample shown, < 0 = not written */
    int32_t *rank;       /* per target pixel: order position of the writer (two-pass seams) */
    float *near2;        /* per target pixel: squared distance from its centre to the writer's warped position (point
                          * splats: of overlapping splats of one surface the nearest wins) */
    int32_t *bin_of;     /* per target pixel: bin of the writer (two-pass) */
    int32_t *binned;     /* order positions sorted by bin, stable */
    int32_t *bin_start;  /* n_bins + 1 */
    int32_t *bin_fill;   /* n_bins: counting-sort cursors */
    int32_t *bin_key;    /* per order position: its bin */
    int n_bins_max;
} warp_fwd_scratch;

bool warp_fwd_scratch_alloc(warp_fwd_scratch *s, int src_w, int src_h, int dst_w, int dst_h);
void warp_fwd_scratch_free(warp_fwd_scratch *s);
/* NULL when sc was allocated for src and dst_cam's sizes and dst (and mask, may be NULL) are dst_cam's size, else
 * what differs: the checks every forward-family entry point (points, splats, objects) makes before drawing. */
const char *warp_fwd_check_sizes(const warp_view *src, const warp_camera *dst_cam, const warp_fwd_scratch *sc,
                                 const warp_image_rgba8 *dst, const warp_image_u8 *mask);

/* Everything constant over one warp of one eye. */
typedef struct {
    const warp_view *src;
    warp_camera dst_cam;
    warp_forward_params p;
    warp_fwd_xform cam_xf;          /* the camera change alone */
    const warp_fwd_xform *obj_xf;   /* NULL, or per object id 0..n_obj_xf-1 (id 0: static scene): src->ids picks */
    int n_obj_xf;
    warp_fwd_epipole ep;            /* of the camera change (per-object warps use the z-buffer) */
    warp_vec3 c2_src;               /* target eye centre in the source eye frame */
    warp_mat3 dst_to_src_inf;       /* target pixel -> source pixel at infinite depth (fringe classification) */
} warp_fwd_setup;

/* Prepares a warp of src (colour + inverse depth) to the eye pose dst_pose (world_from_eye) seen through dst_cam.
 * Returns NULL when usable, else a static string naming what is missing or wrong. */
const char *warp_forward_prepare(warp_fwd_setup *s, const warp_view *src, const warp_camera *dst_cam,
                                 warp_pose dst_pose, const warp_forward_params *p);

/* Pass 1: maps source rows [y0, y1) into the scratch (positions, inverse depth and, when jacobian, the Jacobian).
 * Rows are independent, so threads may split them. Adds samples/dropped/bad_ids to *st (may be NULL). */
void warp_forward_map_rows(const warp_fwd_setup *s, warp_fwd_scratch *sc, bool jacobian, int y0, int y1,
                           warp_forward_stats *st);

/* Writes the traversal order of vis into sc->order (a permutation of the source pixels): raster order for the
 * z-buffer and for an undefined epipole, else the occlusion-compatible sheets (see warp_forward.c for how the
 * sheets advance together). Returns the non-empty sheet count. */
int warp_forward_order(const warp_fwd_setup *s, warp_fwd_visibility vis, warp_fwd_scratch *sc);
/* The same into caller memory: order and tmp hold src_w * src_h entries each. */
int warp_forward_order_into(const warp_fwd_setup *s, warp_fwd_visibility vis, int32_t *order, int32_t *tmp);

/* Clears the target buffers before drawing. */
void warp_forward_clear(warp_fwd_scratch *sc);

/* Pass 2: draws the mapped samples into dst in the order of sc->order (painter's algorithm, or depth-tested for the
 * z-buffer), or bin by bin when two_pass. With p.footprint (needs the Jacobian from pass 1) a sample covers the
 * pixels whose centres lie in its footprint, the parallelogram J [-1/2, 1/2]^2 around its warped position (002
 * §3.3; grown 10 %, at most 4 pixels a side), and always the pixel it lands in; each such pixel is coloured from the
 * source, bilinearly, at the point the footprint's linearisation maps the pixel centre back to. So abutting
 * footprints tile a stretched surface without cracks, the colour sits where the warp puts it rather than where the
 * sample's centre rounds to, and a pure rotation gives the backward rotation warp's image. Without: 1-pixel points. */
void warp_forward_draw_points(const warp_fwd_setup *s, warp_fwd_scratch *sc, warp_image_rgba8 *dst,
                              warp_forward_stats *st);

/* Marks target rows [y0, y1): pixels no sample reached get colour (0,0,0,0) and WARP_MASK_HOLE (plus
 * WARP_MASK_FRINGE when their ray at infinity leaves the source image); others get mask 0. */
void warp_forward_finish_rows(const warp_fwd_setup *s, const warp_fwd_scratch *sc, warp_image_rgba8 *dst,
                              warp_image_u8 *mask, int y0, int y1, warp_forward_stats *st);

/* The entry point: prepare, map (with the Jacobian for footprints), order, draw, finish. dst and mask (may be NULL)
 * are dst_cam's size; st (may be NULL) receives this warp's counts. Returns NULL on success, else what was wrong
 * (dst untouched). */
const char *warp_forward_run(const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose,
                             const warp_forward_params *p, warp_fwd_scratch *sc, warp_image_rgba8 *dst,
                             warp_image_u8 *mask, warp_forward_stats *st);

#endif

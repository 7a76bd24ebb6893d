/* SPDX-License-Identifier: MIT */
/* hmdwarp-warp's catalogue: every warp of the registry (warp/warp_registry.h) behind one signature; names, papers,
 * planes and knobs come from the registry, only the entry points are here. */
#include "tools/common/cat_warps.h"

#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "warp/warp_forward.h"
#include "warp/warp_grid.h"
#include "warp/warp_objects.h"
#include "warp/warp_splat.h"
#include "warp/warp_holes.h"
#include "warp/warp_transparency.h"
#include "warp/warp_iterative.h"
#include "warp/warp_mesh.h"
#include "warp/warp_mesh_trace.h"
#include "warp/warp_raytrace.h"
#include "warp/warp_reproject.h"
#include "warp/warp_resample.h"

double cat_param(const char *params, const char *key, double def, bool *bad)
{
    if (!params) return def;
    size_t kl = strlen(key);
    for (const char *p = params; *p;) {
        const char *end = strchr(p, ',');
        size_t len = end ? (size_t)(end - p) : strlen(p);
        if (len > kl && strncmp(p, key, kl) == 0 && p[kl] == '=') {
            char buf[64];
            snprintf(buf, sizeof buf, "%.*s", (int)(len - kl - 1), p + kl + 1);
            char *e;
            double v = strtod(buf, &e);
            if (e == buf || *e) {
                if (bad) *bad = true;
                return def;
            }
            return v;
        }
        p += len + (end ? 1 : 0);
    }
    return def;
}

const char *cat_check_params(warp_method m, const char *params)
{
    static char msg[300];
    return warp_method_check_params(m, params, msg, sizeof msg);
}

static void count_mask(const warp_image_u8 *mask, cat_stats *st)
{
    st->fringe = st->holes = 0;
    for (int y = 0; y < mask->h; y++)
        for (int x = 0; x < mask->w; x++) {
            uint8_t m = WARP_AT(mask, x, y);
            st->fringe += (m & WARP_MASK_FRINGE) != 0;
            st->holes += (m & WARP_MASK_HOLE) != 0;
        }
}

/* ---- 003: rotation reprojection and the height-map raytrace ---- */

/* none and rotation: the frame reprojected to the orientation q (none passes the source's own: the frame as
 * rendered); samples as given (-1: not counted). */
static const char *reproject(warp_method m, const warp_view *src, const warp_camera *dst_cam, warp_quat q,
                             const char *params, warp_image_rgba8 *dst, warp_image_u8 *mask, cat_stats *st, long samples)
{
    const char *why = cat_check_params(m, params);
    if (why) return why;
    warp_mat3 h;
    if ((why = warp_reproject_prepare(&h, src, dst_cam, q))) return why;
    warp_reproject_rows(src, &h, dst, mask, 0, dst->h);
    st->primitives = -1;
    st->samples = samples;
    count_mask(mask, st);
    return NULL;
}

static const char *run_none(const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose, double dst_time, const char *params,
                            warp_image_rgba8 *dst, warp_image_u8 *mask, cat_stats *st)
{
    (void)dst_pose;
    (void)dst_time;
    /* The frame as rendered: what the wearer sees without any warp. */
    return reproject(WARP_METHOD_NONE, src, dst_cam, src->pose.q, params, dst, mask, st, -1);
}

static const char *run_rotation(const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose, double dst_time,
                                const char *params, warp_image_rgba8 *dst, warp_image_u8 *mask, cat_stats *st)
{
    (void)dst_time;
    return reproject(WARP_METHOD_ROTATION, src, dst_cam, dst_pose.q, params, dst, mask, st, (long)dst->w * dst->h);
}

static const char *run_raytrace(const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose, double dst_time,
                                const char *params, warp_image_rgba8 *dst, warp_image_u8 *mask, cat_stats *st)
{
    (void)dst_time;
    const char *why = cat_check_params(WARP_METHOD_RAYTRACE, params);
    if (why) return why;
    warp_raytrace_params p = warp_raytrace_default_params();
    bool bad = false;
    p.max_steps = (int)cat_param(params, "steps", p.max_steps, &bad);
    p.refine_iters = (int)cat_param(params, "refine", p.refine_iters, &bad);
    p.edge_fill = (warp_edge_fill)(int)cat_param(params, "fill", p.edge_fill, &bad);
    p.edge_jump = (float)cat_param(params, "edge_jump", p.edge_jump, &bad);
    if (bad) return "raytrace: a parameter value is not a number";
    if (p.edge_fill != WARP_EDGE_FILL_FAR && p.edge_fill != WARP_EDGE_FILL_LINEAR)
        return "raytrace: fill must be 0 (far side) or 1 (linear)";
    warp_raytrace_setup s;
    why = warp_raytrace_prepare(&s, src, dst_cam, dst_pose, &p);
    if (why) return why;
    /* the skipping grid, as the runtime builds it once per host frame (skip=0: the plain linear search) */
    int skip = (int)cat_param(params, "skip", 1, &bad);
    warp_image_f32 bmax = {0};
    if (skip && warp_image_f32_alloc(&bmax, (src->inv_depth->w + 7) / 8, (src->inv_depth->h + 7) / 8)) {
        warp_raytrace_blockmax(src->inv_depth, &bmax, 8);
        warp_raytrace_use_blockmax(&s, &bmax, 8);
    }
    warp_raytrace_stats rs = {0};
    warp_raytrace_rows(&s, dst, mask, 0, dst->h, &rs);
    warp_image_free(&bmax);
    st->primitives = -1;
    st->samples = rs.samples;
    count_mask(mask, st);
    snprintf(st->note, sizeof st->note, "%d steps max, %ld edge px", p.max_steps, rs.edge_pixels);
    return NULL;
}

/* ---- hole filling, for every warp that leaves holes (fill=K on its parameters) ---- */


/* fill = 0 none, 1 epipolar far (002 §3.3), 2 depth-aware low-pass (000 §5.2), 3 nearest stretch, 4 background
 * stretch, 5 rubber sheet. Needs the warped image's inverse depth (0 where unknown). */
static const char *fill_holes(int fill, const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose,
                              const warp_image_f32 *dst_inv, warp_image_rgba8 *dst, warp_image_u8 *mask, cat_stats *st)
{
    if (fill == 0) return NULL;
    static const warp_holes_method m[] = {0, WARP_HOLES_EPIPOLAR_FAR, WARP_HOLES_LOWPASS, WARP_HOLES_STRETCH_NEAREST,
                                          WARP_HOLES_STRETCH_BACKGROUND, WARP_HOLES_RUBBER_SHEET};
    if (fill < 0 || fill > 5) return "fill must be 0..5 (none epifar lowpass stretch background rubber)";
    warp_holes_ctx hc;
    if (!warp_holes_alloc(&hc, dst->w, dst->h, 12)) return "out of memory";
    warp_holes_params hp = warp_holes_default_params();
    hp.method = m[fill];
    warp_epipole e = warp_epipole_from_poses(dst_cam, dst_pose, src->pose);
    warp_holes_stats hs = {0};
    const char *why = warp_holes_fill(&hc, dst, mask, dst_inv, &e, &hp, &hs);
    warp_holes_free(&hc);
    if (why) return why;
    if (st->samples >= 0) st->samples += hs.search_steps;
    snprintf(st->note + strlen(st->note), sizeof st->note - strlen(st->note), "%sfilled %ld by %s",
             st->note[0] ? ", " : "", hs.filled, warp_holes_method_name(hp.method));
    return NULL;
}

/* ---- 001: iterative backward warp ---- */

static const char *run_iterative(const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose, double dst_time,
                                 const char *params, warp_image_rgba8 *dst, warp_image_u8 *mask, cat_stats *st)
{
    const char *why = cat_check_params(WARP_METHOD_ITERATIVE, params);
    if (why) return why;
    warp_iter_params p = warp_iter_default_params();
    bool bad = false;
    p.seeds = (int)cat_param(params, "seeds", p.seeds, &bad);
    p.iters = (int)cat_param(params, "iters", p.iters, &bad);
    p.bound = (warp_iter_bound)(int)cat_param(params, "bound", p.bound, &bad);
    p.dilate = cat_param(params, "dilate", p.dilate, &bad) != 0;
    p.approximate = cat_param(params, "awoc", p.approximate, &bad) != 0;
    int fill = (int)cat_param(params, "fill", 0, &bad);
    if (bad) return "iterative: a parameter value is not a number";
    if (p.bound < WARP_ITER_BOUND_GLOBAL || p.bound > WARP_ITER_BOUND_PCA) return "iterative: bound must be 0 (global), 1 (tight) or 2 (PCA)";
    warp_iter_ctx c;
    if (!warp_iter_alloc(&c, src->color->w, src->color->h, dst->w, dst->h, 1)) return "out of memory";
    warp_iter_target t = {*dst_cam, dst_pose, dst_time, NULL};
    warp_iter_stats is;
    memset(&is, 0, sizeof is);
    why = warp_iter_run(&c, src, NULL, 0, &t, &p, dst, mask, &is);
    if (!why) {
        st->primitives = -1;
        st->samples = is.seeds + is.iterations;
        snprintf(st->note, sizeof st->note, "N%d T%d %s, %.1f %% converged", p.seeds, p.iters,
                 p.bound == WARP_ITER_BOUND_GLOBAL ? "global" : p.bound == WARP_ITER_BOUND_TIGHT ? "tight" : "PCA",
                 is.pixels ? 100.0 * (double)is.converged / (double)is.pixels : 0.0);
        why = fill_holes(fill, src, dst_cam, dst_pose, &c.dst_depth, dst, mask, st);
        count_mask(mask, st);
    }
    warp_iter_free(&c);
    return why;
}

/* ---- 000: adaptive grid warping and A-buffer transparency ---- */

static const char *grid_params(const char *params, warp_grid_params *g, int *fill)
{
    bool bad = false;
    *g = warp_grid_default_params();
    g->strategy = (warp_grid_strategy)(int)cat_param(params, "strategy", g->strategy, &bad);
    g->tile = (int)cat_param(params, "tile", g->tile, &bad);
    g->max_error = (float)cat_param(params, "max_error", g->max_error, &bad);
    g->filter = (warp_grid_filter)(int)cat_param(params, "filter", g->filter, &bad);
    *fill = (int)cat_param(params, "fill", 0, &bad);
    /* a real hole filler replaces the grid's own row stretch */
    if (*fill) g->fill_holes = false;
    if (bad) return "grid: a parameter value is not a number";
    if (g->strategy < WARP_GRID_DIDYK || g->strategy > WARP_GRID_IRREGULAR)
        return "grid: strategy must be 0 (Didyk), 1 (cross), 2 (partial cross) or 3 (irregular)";
    return NULL;
}

static const char *run_grid(const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose, double dst_time,
                            const char *params, warp_image_rgba8 *dst, warp_image_u8 *mask, cat_stats *st)
{
    (void)dst_time;
    const char *why = cat_check_params(WARP_METHOD_GRID, params);
    if (why) return why;
    warp_grid_params gp;
    int fill;
    if ((why = grid_params(params, &gp, &fill))) return why;
    warp_grid g;
    warp_image_f32 zb;
    if (!warp_grid_alloc(&g, src->color->w, src->color->h, gp.tile)) return "grid: bad tile or out of memory";
    if (!warp_image_f32_alloc(&zb, dst->w, dst->h)) return warp_grid_free(&g), "out of memory";
    warp_grid_stats gs;
    memset(&gs, 0, sizeof gs);
    why = warp_grid_run(&g, src, dst_cam, dst_pose, &gp, dst, &zb, mask, &gs);
    if (!why) {
        st->primitives = gs.cells;
        st->samples = gs.fragments;
        snprintf(st->note, sizeof st->note, "%s, %ld 1-px cells", warp_grid_strategy_name(gp.strategy), gs.cells_1px);
        why = fill_holes(fill, src, dst_cam, dst_pose, &zb, dst, mask, st);
        count_mask(mask, st);
    }
    warp_image_free(&zb);
    warp_grid_free(&g);
    return why;
}

static const char *run_transparency(const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose,
                                    double dst_time, const char *params, warp_image_rgba8 *dst, warp_image_u8 *mask,
                                    cat_stats *st)
{
    (void)dst_time;
    const char *why = cat_check_params(WARP_METHOD_TRANSPARENCY, params);
    if (why) return why;
    if (!src->layers) return "transparency: the frame has no A-buffer layers";
    warp_grid_params gp;
    int fill;
    if ((why = grid_params(params, &gp, &fill))) return why;
    warp_transparency_params tp = warp_transparency_default_params();
    bool bad = false;
    tp.opacity_threshold = (float)cat_param(params, "opacity", tp.opacity_threshold, &bad);
    tp.thickness = (float)cat_param(params, "thickness", tp.thickness, &bad);
    if (bad) return "transparency: a parameter value is not a number";
    /* The host's colour has the fragments blended in; the hybrid warp wants the opaque G-buffer colour (000 §5):
     * recover it, as a receiver of such a frame would. */
    warp_image_rgba8 opaque;
    warp_grid g;
    warp_minmax_tree t;
    warp_image_f32 zb;
    if (!warp_image_rgba8_alloc(&opaque, src->color->w, src->color->h)) return "out of memory";
    bool ok = warp_grid_alloc(&g, src->color->w, src->color->h, gp.tile) &&
              warp_minmax_alloc(&t, src->color->w, src->color->h) && warp_image_f32_alloc(&zb, dst->w, dst->h);
    if (ok) {
        warp_transparency_unblend(src->color, src->layers, &opaque);
        warp_view v = *src;
        v.color = &opaque;
        warp_grid_stats gs;
        warp_transparency_stats ts;
        memset(&gs, 0, sizeof gs);
        memset(&ts, 0, sizeof ts);
        why = warp_transparency_run(&g, &t, &v, dst_cam, dst_pose, &gp, &tp, dst, &zb, mask, &gs, &ts);
        if (!why) {
            st->primitives = gs.cells;
            st->samples = ts.nodes + ts.fragment_tests;
            snprintf(st->note, sizeof st->note, "%ld rays hit fragments", ts.rays_hit);
            why = fill_holes(fill, src, dst_cam, dst_pose, &zb, dst, mask, st);
            count_mask(mask, st);
        }
    } else {
        why = "out of memory";
    }
    warp_image_free(&opaque);
    warp_image_free(&zb);
    warp_grid_free(&g);
    warp_minmax_free(&t);
    return why;
}

/* ---- 004 / 002: forward warps ---- */

static const warp_pose *g_dst_objects; /* set by cat_set_target_objects */

void cat_set_target_objects(const warp_pose *poses) { g_dst_objects = poses; }

/* Holes of a forward warp, filled from its z-buffer (target inverse depth; < 0 where nothing landed). */
static const char *fwd_fill(int fill, const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose,
                            const warp_fwd_scratch *sc, warp_image_rgba8 *dst, warp_image_u8 *mask, cat_stats *st)
{
    warp_image_f32 zb = {dst->w, dst->h, dst->w, sc->zbuf};
    return fill_holes(fill, src, dst_cam, dst_pose, &zb, dst, mask, st);
}

/* What forward, splat and objects share once their knobs are read: one scratch, the warp, its counts, then the
 * holes filled from the scratch's z-buffer. */
typedef struct {
    warp_method m;              /* WARP_METHOD_FORWARD, _SPLAT or _OBJECTS */
    warp_forward_params fwd;    /* forward */
    warp_splat_params splat;    /* splat, objects */
    bool keep_static;           /* objects: where the source saw them */
    int fill;
} fwd_job;

static const char *run_fwd_job(const fwd_job *j, const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose,
                               warp_image_rgba8 *dst, warp_image_u8 *mask, cat_stats *st)
{
    warp_objects_setup *os = j->m == WARP_METHOD_OBJECTS ? calloc(1, sizeof *os) : NULL;
    warp_fwd_scratch sc;
    if ((j->m == WARP_METHOD_OBJECTS && !os) ||
        !warp_fwd_scratch_alloc(&sc, src->color->w, src->color->h, dst->w, dst->h)) {
        free(os);
        return "out of memory";
    }
    const char *why;
    if (j->m == WARP_METHOD_FORWARD) {
        warp_forward_stats fs;
        memset(&fs, 0, sizeof fs);
        why = warp_forward_run(src, dst_cam, dst_pose, &j->fwd, &sc, dst, mask, &fs);
        st->primitives = fs.samples;
        st->samples = fs.writes;
        snprintf(st->note, sizeof st->note, "%s%s, %d sheets", j->fwd.vis == WARP_FWD_ZBUFFER ? "z-buffer" : "painter",
                 j->fwd.two_pass ? ", two-pass binned" : "", fs.sheets);
    } else if (j->m == WARP_METHOD_SPLAT) {
        warp_splat_stats ss;
        memset(&ss, 0, sizeof ss);
        why = warp_splat_run(src, dst_cam, dst_pose, &j->splat, &sc, dst, mask, &ss);
        st->primitives = ss.primitives;
        st->samples = ss.fragments;
        int kind = (int)j->splat.kind;
        snprintf(st->note, sizeof st->note, "%s splats", kind == 0 ? "point" : kind == 1 ? "quad" : "mesh");
    } else {
        warp_objects_stats ob;
        memset(&ob, 0, sizeof ob);
        /* the objects where they are at the target time (002 §3.2), or where the source saw them (static=1) */
        why = warp_objects_run(os, src, dst_cam, dst_pose, j->keep_static ? NULL : g_dst_objects, &j->splat, &sc, dst,
                               mask, &ob);
        st->primitives = ob.splat.primitives;
        st->samples = ob.splat.fragments;
        snprintf(st->note, sizeof st->note, "%d objects, %d moved%s", ob.objects, ob.moved,
                 g_dst_objects && !j->keep_static ? "" : " (no target poses: static)");
    }
    if (!why) {
        why = fwd_fill(j->fill, src, dst_cam, dst_pose, &sc, dst, mask, st);
        count_mask(mask, st);
    }
    warp_fwd_scratch_free(&sc);
    free(os);
    return why;
}

static const char *run_forward(const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose, double dst_time,
                               const char *params, warp_image_rgba8 *dst, warp_image_u8 *mask, cat_stats *st)
{
    (void)dst_time;
    const char *why = cat_check_params(WARP_METHOD_FORWARD, params);
    if (why) return why;
    fwd_job j = {.m = WARP_METHOD_FORWARD, .fwd = warp_forward_default_params()};
    bool bad = false;
    j.fwd.vis = (warp_fwd_visibility)(int)cat_param(params, "vis", j.fwd.vis, &bad);
    j.fwd.two_pass = cat_param(params, "twopass", j.fwd.two_pass, &bad) != 0;
    j.fill = (int)cat_param(params, "fill", 0, &bad);
    if (bad || j.fwd.vis < WARP_FWD_ZBUFFER || j.fwd.vis > WARP_FWD_SHEETS8)
        return "forward: vis must be 0 (z-buffer), 1 (4 sheets) or 2 (8 sheets)";
    return run_fwd_job(&j, src, dst_cam, dst_pose, dst, mask, st);
}

static const char *run_splat(const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose, double dst_time,
                             const char *params, warp_image_rgba8 *dst, warp_image_u8 *mask, cat_stats *st)
{
    (void)dst_time;
    const char *why = cat_check_params(WARP_METHOD_SPLAT, params);
    if (why) return why;
    bool bad = false;
    int kind = (int)cat_param(params, "kind", WARP_SPLAT_MESH, &bad);
    if (bad || kind < WARP_SPLAT_POINT || kind > WARP_SPLAT_MESH) return "splat: kind must be 0 (point), 1 (quad), 2 (mesh)";
    fwd_job j = {.m = WARP_METHOD_SPLAT, .splat = warp_splat_default_params((warp_splat_kind)kind)};
    j.splat.vis = (warp_fwd_visibility)(int)cat_param(params, "vis", j.splat.vis, &bad);
    j.fill = (int)cat_param(params, "fill", 0, &bad);
    if (bad) return "splat: a parameter value is not a number";
    return run_fwd_job(&j, src, dst_cam, dst_pose, dst, mask, st);
}

static const char *run_objects(const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose, double dst_time,
                               const char *params, warp_image_rgba8 *dst, warp_image_u8 *mask, cat_stats *st)
{
    (void)dst_time;
    const char *why = cat_check_params(WARP_METHOD_OBJECTS, params);
    if (why) return why;
    if (!src->ids) return "objects: the frame has no object ids";
    bool bad = false;
    int kind = (int)cat_param(params, "kind", WARP_SPLAT_MESH, &bad);
    fwd_job j = {.m = WARP_METHOD_OBJECTS};
    j.fill = (int)cat_param(params, "fill", 2, &bad);
    j.keep_static = cat_param(params, "static", 0, &bad) != 0;
    if (bad || kind < 0 || kind > 2) return "objects: kind must be 0..2, fill 0..5, static 0|1";
    j.splat = warp_splat_default_params((warp_splat_kind)kind);
    return run_fwd_job(&j, src, dst_cam, dst_pose, dst, mask, st);
}

/* ---- 003 §3.5 at the lens mesh's vertices: the display path's raytrace ---- */

/* Rays at the vertices of a lens-free mesh over the eye buffer (mesh=N per side), the resampler in between: the
 * runtime's raytrace_mesh scored one eye before the lens, like every other warp here. */
static const char *run_raytrace_mesh(const warp_view *src, const warp_camera *dst_cam, warp_pose dst_pose,
                                     double dst_time, const char *params, warp_image_rgba8 *dst, warp_image_u8 *mask,
                                     cat_stats *st)
{
    (void)dst_time;
    (void)mask; /* the resampler flags nothing */
    const char *why = cat_check_params(WARP_METHOD_RAYTRACE_MESH, params);
    if (why) return why;
    int n = (int)cat_param(params, "mesh", warp_method_knob(WARP_METHOD_RAYTRACE_MESH, "mesh")->def, NULL);
    const bool cells = cat_param(params, "cells", warp_method_knob(WARP_METHOD_RAYTRACE_MESH, "cells")->def, NULL);
    warp_raytrace_params p = warp_raytrace_default_params();
    warp_raytrace_setup s;
    if ((why = warp_raytrace_prepare(&s, src, dst_cam, dst_pose, &p))) return why;
    warp_mesh m;
    warp_planar3 planar;
    warp_image_f32 bmax = {0};
    memset(&m, 0, sizeof m);
    memset(&planar, 0, sizeof planar);
    if (warp_mesh_alloc_eye(&m, n, dst_cam) && warp_planar3_alloc(&planar, src->color->w, src->color->h) &&
        warp_image_f32_alloc(&bmax, (src->inv_depth->w + 7) / 8, (src->inv_depth->h + 7) / 8)) {
        /* what the runtime does once per host frame: the planar source and the skipping grid */
        warp_planar3_from_rgba_rows(&planar, src->color, 0, src->color->h);
        warp_raytrace_blockmax(src->inv_depth, &bmax, 8);
        warp_raytrace_use_blockmax(&s, &bmax, 8);
        /* the display path's depth warp as the runtime's pass draws it: rays at the vertices, and per pixel in the
         * cells with a depth discontinuity (cells=0: the vertices alone) */
        warp_mesh_trace tr;
        if (warp_mesh_trace_alloc(&tr, &m)) {
            const warp_mesh_trace_params tp = warp_mesh_trace_default_params();
            warp_mesh_raytrace_draw(&m, cells ? &tr : NULL, dst_cam, &s, NULL, NULL, &tp, &planar, dst);
            st->primitives = (long)(m.rows - 1) * (m.cols - 1);
            warp_mesh_trace_free(&tr);
        } else {
            why = "out of memory";
        }
        st->samples = -1;
        st->fringe = st->holes = 0;
    } else {
        why = "out of memory";
    }
    warp_mesh_free(&m);
    warp_planar3_free(&planar);
    warp_image_free(&bmax);
    return why;
}

/* The entry points, indexed like the registry. */
typedef const char *(*cat_run_fn)(const warp_view *, const warp_camera *, warp_pose, double, const char *,
                                  warp_image_rgba8 *, warp_image_u8 *, cat_stats *);
static const cat_run_fn runs[] = {
    [WARP_METHOD_NONE] = run_none,           [WARP_METHOD_ROTATION] = run_rotation,
    [WARP_METHOD_RAYTRACE] = run_raytrace,   [WARP_METHOD_TRANSPARENCY] = run_transparency,
    [WARP_METHOD_OBJECTS] = run_objects,     [WARP_METHOD_RAYTRACE_MESH] = run_raytrace_mesh,
    [WARP_METHOD_ITERATIVE] = run_iterative, [WARP_METHOD_GRID] = run_grid,
    [WARP_METHOD_FORWARD] = run_forward,     [WARP_METHOD_SPLAT] = run_splat,
};
_Static_assert(sizeof runs / sizeof runs[0] == WARP_METHOD_COUNT, "an entry point per registry method");

static cat_warp entries[WARP_METHOD_COUNT];
static const cat_warp *catalogue[WARP_METHOD_COUNT + 1];
static char helps[WARP_METHOD_COUNT][600];
static pthread_once_t built = PTHREAD_ONCE_INIT;

static void build(void)
{
    for (int m = 0; m < WARP_METHOD_COUNT; m++) {
        const warp_method_info *w = warp_method_get((warp_method)m);
        char knobs[500];
        warp_method_knobs_str((warp_method)m, knobs, sizeof knobs);
        snprintf(helps[m], sizeof helps[m], "%s%s%s", w->summary, knobs[0] ? "; " : "", knobs);
        entries[m] = (cat_warp){(warp_method)m, w->name, w->cite, helps[m], w->needs, runs[m]};
        catalogue[m] = &entries[m];
    }
    catalogue[WARP_METHOD_COUNT] = NULL;
}

const cat_warp *const *cat_all(void)
{
    pthread_once(&built, build);
    return catalogue;
}

const cat_warp *cat_find(const char *name)
{
    int m = warp_method_find(name);
    return m < 0 ? NULL : cat_all()[m];
}

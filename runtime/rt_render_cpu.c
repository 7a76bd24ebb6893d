/* SPDX-License-Identifier: MIT */
/* rt_render_cpu: the CPU render pass: per vsync, the warp the frame and the method allow, then the lens pass
 * (distortion and chromatic aberration) into the panel image, split into tasks over the compositor's workers. */
#include "runtime/rt_render_cpu.h"

#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "warp/warp_err.h"
#include "warp/warp_forward.h"
#include "warp/warp_fov.h"
#include "warp/warp_grid.h"
#include "warp/warp_holes.h"
#include "warp/warp_mesh_trace.h"
#include "warp/warp_objects.h"
#include "warp/warp_registry.h"
#include "warp/warp_resample.h"
#include "warp/warp_transparency.h"

#define BAND_H 16

/* One vsync's work, shared with the worker threads. */
typedef struct {
    rt_render_cpu *r;
    const rt_frame *frame;
    warp_image_rgba8 *out;
    const warp_planar3 *src[2];
    int tiles_x[2], tiles_y[2];
    warp_view views[2]; /* the raytrace setups point at these */
    warp_raytrace_setup rts[2];
    int bands;
    rt_method method;   /* depth_task: which further warp */
    warp_pose eyes[2];
    const warp_pose *objects_at; /* depth_task: the objects at photon time, NULL = as the frame saw them */
    warp_quat src_from_dst[2]; /* mesh_task */
    /* rolling scanout (rt_render_cpu_frame_scan): the eye poses at the scan's first and last line, NULL on a global
     * panel; mesh_task and mesh_raytrace_task then warp each vertex at its own line's time */
    const warp_pose *first, *last;
    bool mesh_rolling;                 /* mesh_task: src_from_dst_last set, not a lens-only pass */
    warp_quat src_from_dst_last[2];    /* mesh_task: src_from_dst is then the first line's */
    warp_raytrace_setup rts_last[2];   /* mesh_raytrace_task: rts is then the first line's */
    bool trace_cells;                  /* resample_task: raytrace_mesh's marked cells get per-pixel rays after */
} job;

struct rt_render_cpu {
    rt_render_cpu_params p;
    plat_workers *workers;
    job j;                         /* here, not on the caller's stack: a vsync's job is a few KB */
    warp_mesh mesh[2];
    warp_mesh_trace mtrace[2];     /* raytrace_mesh: the cells traced per pixel (allocated with the depth warps) */
    warp_image_rgba8 inter[2];     /* eye-space warps' output, before the lens pass */
    warp_planar3 inter_planar[2];
    /* the further depth warps, allocated when the method may use them */
    warp_grid grid[2];
    warp_minmax_tree abuf[2];
    const void *abuf_frame[2];     /* the frame slot and sequence the grid and tree were built from: they depend */
    uint64_t abuf_seq[2];          /* on the source only, so they are built once per host frame, not per vsync */
    warp_image_f32 zb[2];          /* warped opaque inverse depth (transparency) */
    warp_image_u8 wmask[2];        /* the depth warps' masks (holes, fringe) */
    warp_fwd_scratch fwd[2];
    warp_objects_setup *objs[2];
    warp_holes_ctx holes[2];
    /* counted on the vsync path, read by the helper thread for the live stats: relaxed atomics */
    _Atomic uint64_t raytrace_fallbacks, plane_fallbacks;
    int32_t *visible[2];           /* the hidden-area masks the meshes point at (warp_fov_spans), or NULL */
    warp_fov_weights weights[2];   /* the out-of-source share's per-vertex pixel counts */
};

rt_render_cpu_params rt_render_cpu_params_from_config(const rt_config *c)
{
    rt_render_cpu_params p;
    memset(&p, 0, sizeof p);
    p.panel_w = c->panel_w;
    p.panel_h = c->panel_h;
    p.eye_w = c->eye_w;
    p.eye_h = c->eye_h;
    p.mesh_n = c->mesh_n;
    for (int e = 0; e < 2; e++) {
        p.lens[e] = rt_config_lens(c, e);
        p.visible_radius[e] = rt_config_visible_radius(c, e);
    }
    p.raytrace = warp_raytrace_default_params();
    p.raytrace.max_steps = c->raytrace_steps;
    p.raytrace.edge_fill = (warp_edge_fill)c->edge_fill;
    p.raytrace.edge_jump = (float)c->edge_jump;
    p.mesh_trace = warp_mesh_trace_default_params();
    p.mesh_cells = c->mesh_cells != 0;
    p.depth_warps = c->method != RT_METHOD_NONE && c->method != RT_METHOD_ROTATION;
    p.transparency = c->method == RT_METHOD_TRANSPARENCY || c->method == RT_METHOD_AUTO;
    p.objects = c->method == RT_METHOD_OBJECTS || c->method == RT_METHOD_AUTO;
    p.scan = rt_config_scan(c);
    return p;
}

static rt_render_cpu *fail(rt_render_cpu *r, char *err, int errlen, const char *what)
{
    warp_err(err, errlen, "%s", what);
    rt_render_cpu_destroy(&r);
    return NULL;
}

static const char *method_without_pass(void);

rt_render_cpu *rt_render_cpu_create(const rt_render_cpu_params *p, plat_workers *workers, char *err, int errlen)
{
    /* the ranges rt_config enforces for [lens] mesh and the sizes; a caller that built its own params gets told */
    if (p->mesh_n < 2 || p->mesh_n > 1024) {
        warp_err(err, errlen, "[lens] mesh = %d: the distortion mesh takes 2..1024 vertices per side", p->mesh_n);
        return NULL;
    }
    if (p->panel_w < 2 || p->panel_h < 1 || p->eye_w < 1 || p->eye_h < 1) {
        warp_err(err, errlen, "a %dx%d panel with %dx%d eyes: no pixels to render", p->panel_w, p->panel_h, p->eye_w,
                 p->eye_h);
        return NULL;
    }
    if (!workers) {
        warp_err(err, errlen, "the CPU pass needs the compositor's workers");
        return NULL;
    }
    const char *no_pass = method_without_pass();
    if (no_pass) {
        warp_err(err, errlen, "warp %s: no CPU pass in runtime/rt_render_cpu.c's passes[]", no_pass);
        return NULL;
    }
    rt_render_cpu *r = calloc(1, sizeof *r);
    if (!r) return fail(r, err, errlen, "out of memory");
    r->p = *p;
    r->workers = workers;
    r->j.r = r;
    int vw = p->panel_w / 2;
    for (int e = 0; e < 2; e++)
        if (!warp_mesh_alloc(&r->mesh[e], p->mesh_n, &r->p.lens[e], e * vw, 0, vw, p->panel_h))
            return fail(r, err, errlen, "[lens] mesh: cannot allocate the distortion mesh");
    for (int e = 0; e < 2; e++) {
        if (p->visible_radius[e] > 0) {
            r->visible[e] = malloc(sizeof *r->visible[e] * 2 * (size_t)p->panel_h);
            if (!r->visible[e]) return fail(r, err, errlen, "out of memory");
            warp_fov_spans(&r->p.lens[e], p->visible_radius[e], vw, p->panel_h, r->visible[e]);
            r->mesh[e].visible = r->visible[e];
        }
        if (!warp_fov_weights_alloc(&r->weights[e], &r->mesh[e], r->visible[e])) return fail(r, err, errlen, "out of memory");
    }
    for (int e = 0; e < 2 && p->depth_warps; e++) {
        bool ok = warp_mesh_trace_alloc(&r->mtrace[e], &r->mesh[e]) &&
                  warp_image_rgba8_alloc(&r->inter[e], p->eye_w, p->eye_h) &&
                  warp_planar3_alloc(&r->inter_planar[e], p->eye_w, p->eye_h) &&
                  warp_image_u8_alloc(&r->wmask[e], p->eye_w, p->eye_h);
        if (ok && p->transparency)
            ok = warp_grid_alloc(&r->grid[e], p->eye_w, p->eye_h, warp_grid_default_params().tile) &&
                 warp_minmax_alloc(&r->abuf[e], p->eye_w, p->eye_h) &&
                 warp_image_f32_alloc(&r->zb[e], p->eye_w, p->eye_h);
        if (ok && p->objects) {
            r->objs[e] = calloc(1, sizeof *r->objs[e]);
            ok = r->objs[e] && warp_fwd_scratch_alloc(&r->fwd[e], p->eye_w, p->eye_h, p->eye_w, p->eye_h) &&
                 warp_holes_alloc(&r->holes[e], p->eye_w, p->eye_h, 12);
        }
        if (!ok) return fail(r, err, errlen, "cannot allocate the depth warps' buffers");
    }
    return r;
}

void rt_render_cpu_destroy(rt_render_cpu **rp)
{
    rt_render_cpu *r = rp ? *rp : NULL;
    if (!r) return;
    for (int e = 0; e < 2; e++) {
        warp_mesh_free(&r->mesh[e]);
        warp_mesh_trace_free(&r->mtrace[e]);
        free(r->visible[e]);
        warp_fov_weights_free(&r->weights[e]);
        warp_image_free(&r->inter[e]);
        warp_planar3_free(&r->inter_planar[e]);
        warp_image_free(&r->wmask[e]);
        warp_image_free(&r->zb[e]);
        if (r->grid[e].w) warp_grid_free(&r->grid[e]);
        warp_minmax_free(&r->abuf[e]);
        warp_fwd_scratch_free(&r->fwd[e]);
        if (r->objs[e]) warp_holes_free(&r->holes[e]);
        free(r->objs[e]);
    }
    free(r);
    *rp = NULL;
}

rt_render_cpu_stats rt_render_cpu_stats_get(const rt_render_cpu *r)
{
    rt_render_cpu_stats st = {atomic_load_explicit(&r->raytrace_fallbacks, memory_order_relaxed),
                              atomic_load_explicit(&r->plane_fallbacks, memory_order_relaxed)};
    return st;
}
warp_mesh *rt_render_cpu_mesh(rt_render_cpu *r, int eye) { return &r->mesh[eye]; }
const warp_mesh_trace *rt_render_cpu_mesh_trace(const rt_render_cpu *r, int eye)
{
    return r->mtrace[eye].cell ? &r->mtrace[eye] : NULL;
}
int64_t rt_render_cpu_visible(const rt_render_cpu *r, int eye) { return r->weights[eye].visible; }
int64_t rt_render_cpu_outside(const rt_render_cpu *r, int eye, int src_w, int src_h)
{
    return warp_fov_outside(&r->weights[eye], &r->mesh[eye], src_w, src_h);
}
const warp_raytrace_params *rt_render_cpu_raytrace_params(const rt_render_cpu *r) { return &r->p.raytrace; }
const warp_mesh_trace_params *rt_render_cpu_mesh_trace_params(const rt_render_cpu *r) { return &r->p.mesh_trace; }
/* the params' mesh_cells is the switch: the config sets it at creation, the bench flips it between passes */
void rt_render_cpu_mesh_vertices_only(rt_render_cpu *r, bool on) { r->p.mesh_cells = !on; }
bool rt_render_cpu_mesh_cells(const rt_render_cpu *r) { return r->p.mesh_cells; }

/* The marks raytrace_mesh's passes draw with: NULL, the vertices alone, when asked. */
static warp_mesh_trace *cells_of(rt_render_cpu *r, int e) { return r->p.mesh_cells ? &r->mtrace[e] : NULL; }

static void resample_task(void *ctx, int task)
{
    job *j = ctx;
    int per_eye = j->tiles_x[0] * j->tiles_y[0];
    int e = task >= per_eye ? 1 : 0;
    int t = task - e * per_eye;
    const warp_mesh *m = &j->r->mesh[e];
    int tx = t % j->tiles_x[e], ty = t / j->tiles_x[e];
    int x0 = tx * RT_RENDER_CPU_TILE_W, y0 = ty * RT_RENDER_CPU_TILE_H;
    int x1 = x0 + RT_RENDER_CPU_TILE_W < m->vp_w ? x0 + RT_RENDER_CPU_TILE_W : m->vp_w;
    int y1 = y0 + RT_RENDER_CPU_TILE_H < m->vp_h ? y0 + RT_RENDER_CPU_TILE_H : m->vp_h;
    if (j->trace_cells)
        warp_mesh_raytrace_rect(m, cells_of(j->r, e), &j->frame->f.cam[e], &j->rts[e],
                                j->first ? &j->rts_last[e] : NULL, j->first ? &j->r->p.scan : NULL, j->src[e], j->out,
                                x0, y0, x1, y1);
    else
        warp_mesh_resample(m, j->src[e], j->out, x0, y0, x1, y1);
}

/* Task `task` of 2 * j->bands: one band of one eye, rows [*y0, *y1). */
static int band(const job *j, int task, int *y0, int *y1)
{
    int e = task >= j->bands ? 1 : 0;
    int h = j->r->inter[e].h;
    *y0 = (task - e * j->bands) * BAND_H;
    *y1 = *y0 + BAND_H < h ? *y0 + BAND_H : h;
    return e;
}

/* Raytrace one band of one eye into eye space. */
static void raytrace_task(void *ctx, int task)
{
    job *j = ctx;
    int y0, y1, e = band(j, task, &y0, &y1);
    warp_raytrace_rows(&j->rts[e], &j->r->inter[e], NULL, y0, y1, NULL);
}

/* Deinterleave one band for the lens pass, once every band is traced: a planar row pairs its row with the next
 * one, which for a band's last row is the next band's first (done in the trace's task, it raced that band's
 * thread and showed a row of the previous vsync or of uninitialised memory). */
static void planar_task(void *ctx, int task)
{
    job *j = ctx;
    int y0, y1, e = band(j, task, &y0, &y1);
    warp_planar3_from_rgba_rows(&j->r->inter_planar[e], &j->r->inter[e], y0, y1);
}

/* The rotation each eye's mesh applies, source from display (003 §3.4: only orientations matter; NONE and a
 * lens-only pass show the frame as rendered): the first line's into *from and the last line's into *from_last on a
 * rolling panel (true), else the one for eye_pose (false). The CPU pass and the GLES renderer both ask here. */
static bool mesh_rotation(const rt_render_cpu *r, const rt_frame *frame, int e, rt_method method, warp_pose eye_pose,
                          const warp_pose *first, const warp_pose *last, warp_quat *from, warp_quat *from_last)
{
    if (method != RT_METHOD_ROTATION) {
        *from = *from_last = warp_quat_identity();
        return false;
    }
    const warp_quat src_q = warp_quat_conj(frame->f.eye_pose[e].q);
    const bool rolling = r->p.scan.rolling && first && last;
    *from = warp_quat_mul(src_q, rolling ? first[e].q : eye_pose.q);
    *from_last = rolling ? warp_quat_mul(src_q, last[e].q) : *from;
    return rolling;
}

static void mesh_update(rt_render_cpu *r, const rt_frame *frame, int e, bool rolling, warp_quat from,
                        warp_quat from_last)
{
    if (rolling)
        warp_mesh_update_rolling(&r->mesh[e], &frame->f.cam[e], from, from_last, &r->p.scan);
    else
        warp_mesh_update(&r->mesh[e], &frame->f.cam[e], from);
}

warp_mesh *rt_render_cpu_mesh_for(rt_render_cpu *r, const rt_frame *frame, int e, rt_method method,
                                  warp_pose eye_pose, const warp_pose *first, const warp_pose *last)
{
    warp_quat from, from_last;
    const bool rolling = mesh_rotation(r, frame, e, method, eye_pose, first, last, &from, &from_last);
    mesh_update(r, frame, e, rolling, from, from_last);
    return &r->mesh[e];
}

/* One eye's distortion mesh for a rotation (both eyes at once: done in turn they took a sixth of the pass while
 * the other thread waited). */
static void mesh_task(void *ctx, int e)
{
    job *j = ctx;
    mesh_update(j->r, j->frame, e, j->mesh_rolling, j->src_from_dst[e], j->src_from_dst_last[e]);
}

/* raytrace_mesh: one eye's rays, at its lens mesh's vertices, and which cells the resample tasks then trace per
 * pixel (the depth discontinuities, warp_mesh_trace): the resample reads the frame. */
static void mesh_raytrace_task(void *ctx, int e)
{
    job *j = ctx;
    rt_render_cpu *r = j->r;
    const warp_camera *cam = &j->frame->f.cam[e];
    warp_mesh_raytrace_vertices(&r->mesh[e], cells_of(r, e), cam, &j->rts[e], j->first ? &j->rts_last[e] : NULL,
                                j->first ? &r->p.scan : NULL, &r->p.mesh_trace);
}

/* The warps that need a whole eye at once (they rasterise or splat): one task per eye, into eye space, holes
 * filled, then deinterleaved for the lens pass. */
static void depth_task(void *ctx, int e)
{
    job *j = ctx;
    rt_render_cpu *r = j->r;
    const rt_frame *fr = j->frame;
    warp_image_u8 *m = &r->wmask[e];
    warp_image_u8_fill(m, 0);
    if (j->method == RT_METHOD_TRANSPARENCY) {
        warp_grid_params gp = warp_grid_default_params();
        warp_transparency_params tp = warp_transparency_default_params();
        /* warp_transparency_run would rebuild the source's grid and fragment tree every vsync */
        bool ok = true;
        if (r->abuf_frame[e] != fr || r->abuf_seq[e] != fr->f.seq) {
            ok = !warp_grid_build(&r->grid[e], &j->views[e], &gp, NULL);
            warp_minmax_build(&r->abuf[e], j->views[e].layers);
            r->abuf_frame[e] = ok ? fr : NULL;
            r->abuf_seq[e] = fr->f.seq;
        }
        warp_transparency_setup ts;
        ok = ok && !warp_grid_warp_rows(&r->grid[e], &j->views[e], &fr->f.cam[e], j->eyes[e], &gp, &r->inter[e],
                                        &r->zb[e], m, 0, r->inter[e].h, NULL);
        ok = ok && !warp_transparency_prepare(&ts, &j->views[e], &r->abuf[e], &fr->f.cam[e], j->eyes[e], &tp);
        if (ok) warp_transparency_rows(&ts, &r->zb[e], &r->inter[e], 0, r->inter[e].h, NULL);
    } else {
        warp_splat_params sp = warp_splat_default_params(WARP_SPLAT_MESH);
        warp_objects_run(r->objs[e], &j->views[e], &fr->f.cam[e], j->eyes[e], j->objects_at, &sp, &r->fwd[e],
                         &r->inter[e], m, NULL);
        /* Disocclusions the splats left: the depth-aware low-pass fill (000 §5.2) from the warped depth. */
        warp_image_f32 zb = {fr->f.cam[e].width, fr->f.cam[e].height, fr->f.cam[e].width, r->fwd[e].zbuf};
        warp_holes_params hp = warp_holes_default_params();
        warp_epipole ep = warp_epipole_from_poses(&fr->f.cam[e], j->eyes[e], fr->f.eye_pose[e]);
        warp_holes_fill(&r->holes[e], &r->inter[e], m, &zb, &ep, &hp, NULL);
    }
    warp_planar3_from_rgba_rows(&r->inter_planar[e], &r->inter[e], 0, r->inter[e].h);
}

static void run_resample(rt_render_cpu *r, job *j)
{
    for (int e = 0; e < 2; e++) {
        j->tiles_x[e] = (r->mesh[e].vp_w + RT_RENDER_CPU_TILE_W - 1) / RT_RENDER_CPU_TILE_W;
        j->tiles_y[e] = (r->mesh[e].vp_h + RT_RENDER_CPU_TILE_H - 1) / RT_RENDER_CPU_TILE_H;
    }
    plat_workers_run(r->workers, j->tiles_x[0] * j->tiles_y[0] + j->tiles_x[1] * j->tiles_y[1], resample_task, j);
}

/* The lens pass: both eyes' meshes for j->src_from_dst at once, then the resampling from j->src. */
static void lens_pass(rt_render_cpu *r, job *j)
{
    plat_workers_run(r->workers, 2, mesh_task, j);
    run_resample(r, j);
}

/* The lens pass after a warp into eye space (inter_planar): distortion and CA only. */
static void lens_pass_eye_space(rt_render_cpu *r, job *j)
{
    for (int e = 0; e < 2; e++) {
        j->src_from_dst[e] = warp_quat_identity();
        j->src[e] = &r->inter_planar[e];
    }
    j->mesh_rolling = false; /* the warp is done: the lens alone */
    lens_pass(r, j);
}

/* none and rotation: both eyes' meshes, then the resampling from the host frame. */
static rt_method pass_lens(rt_render_cpu *r, job *j, const rt_frame *frame, const warp_pose eyes[2],
                           rt_method method)
{
    /* on a rolling panel the rotation runs from the first line's pose to the last's per vertex */
    for (int e = 0; e < 2; e++) {
        j->mesh_rolling = mesh_rotation(r, frame, e, method, eyes[e], j->first, j->last, &j->src_from_dst[e],
                                        &j->src_from_dst_last[e]);
        j->src[e] = &frame->planar[e];
    }
    lens_pass(r, j);
    return method;
}

/* The raytrace setups of both eyes into j->rts (and j->rts_last for raytrace_mesh on a rolling panel: j->rts then
 * the first line's), with the frame's skipping grid. False when the frame cannot give one. */
static bool raytrace_setups(rt_render_cpu *r, job *j, const rt_frame *frame, const warp_pose eyes[2],
                            rt_method method)
{
    bool ok = true;
    for (int e = 0; e < 2 && ok; e++) {
        j->views[e] = rt_frame_view(frame, e);
        ok = warp_raytrace_prepare(&j->rts[e], &j->views[e], &frame->f.cam[e], eyes[e], &r->p.raytrace) == NULL;
        if (ok) warp_raytrace_use_blockmax(&j->rts[e], &frame->blockmax[e], RT_BLOCK);
    }
    if (ok && method == RT_METHOD_RAYTRACE_MESH && j->first) {
        /* rolling: the mesh traces each vertex at the first and the last line's pose (the per-pixel raytrace keeps
         * the mid-scan pose: a setup per pixel row would cost its prepare per band) */
        for (int e = 0; e < 2 && ok; e++) {
            ok = warp_raytrace_prepare(&j->rts[e], &j->views[e], &frame->f.cam[e], j->first[e], &r->p.raytrace) ==
                     NULL &&
                 warp_raytrace_prepare(&j->rts_last[e], &j->views[e], &frame->f.cam[e], j->last[e], &r->p.raytrace) ==
                     NULL;
            if (ok) {
                warp_raytrace_use_blockmax(&j->rts[e], &frame->blockmax[e], RT_BLOCK);
                warp_raytrace_use_blockmax(&j->rts_last[e], &frame->blockmax[e], RT_BLOCK);
            }
        }
    }
    return ok;
}

/* raytrace and raytrace_mesh: the per-host-frame setup (prepare, skipping grid), then per pixel in bands, or at
 * the mesh's vertices. A setup the frame cannot give falls to rotation. */
static rt_method pass_raytrace(rt_render_cpu *r, job *j, const rt_frame *frame, const warp_pose eyes[2],
                               rt_method method)
{
    if (!raytrace_setups(r, j, frame, eyes, method)) return pass_lens(r, j, frame, eyes, RT_METHOD_ROTATION);
    if (method == RT_METHOD_RAYTRACE_MESH) {
        /* no eye-space image: depth warp, lens and CA in the one resampling pass from the host frame */
        plat_workers_run(r->workers, 2, mesh_raytrace_task, j);
        for (int e = 0; e < 2; e++) j->src[e] = &frame->planar[e];
        j->trace_cells = true;
        run_resample(r, j);
        j->trace_cells = false;
        return method;
    }
    j->bands = (r->inter[0].h + BAND_H - 1) / BAND_H;
    plat_workers_run(r->workers, 2 * j->bands, raytrace_task, j);
    plat_workers_run(r->workers, 2 * j->bands, planar_task, j);
    lens_pass_eye_space(r, j);
    return method;
}

/* transparency and objects: a whole eye at once into eye space (depth_task), then the lens. */
static rt_method pass_depth(rt_render_cpu *r, job *j, const rt_frame *frame, const warp_pose eyes[2],
                            rt_method method)
{
    j->method = method;
    for (int e = 0; e < 2; e++) {
        j->views[e] = rt_frame_view(frame, e);
        j->eyes[e] = eyes[e];
    }
    plat_workers_run(r->workers, 2, depth_task, j);
    lens_pass_eye_space(r, j);
    return method;
}

/* The CPU half of the warp registry (warp/warp_registry.h has names, planes and fallbacks), indexed the same. */
typedef rt_method (*cpu_pass)(rt_render_cpu *r, job *j, const rt_frame *frame, const warp_pose eyes[2],
                              rt_method method);
static const cpu_pass passes[WARP_METHOD_RUNTIME_COUNT] = {
    [WARP_METHOD_NONE] = pass_lens,
    [WARP_METHOD_ROTATION] = pass_lens,
    [WARP_METHOD_RAYTRACE] = pass_raytrace,
    [WARP_METHOD_TRANSPARENCY] = pass_depth,
    [WARP_METHOD_OBJECTS] = pass_depth,
    [WARP_METHOD_RAYTRACE_MESH] = pass_raytrace,
};

/* A runtime method added to the registry without a pass here leaves a NULL: rt_render_cpu_create refuses to start
 * (every test that makes the pass says so) rather than the vsync path calling it. */
static const char *method_without_pass(void)
{
    for (int m = 0; m < WARP_METHOD_RUNTIME_COUNT; m++)
        if (!passes[m]) return warp_method_name((warp_method)m);
    return NULL;
}
_Static_assert((int)RT_METHOD_COUNT == (int)WARP_METHOD_RUNTIME_COUNT, "rt_method is the registry's runtime part");
#define SAME_(id, name) _Static_assert((int)RT_METHOD_##id == (int)WARP_METHOD_##id, "rt_method order: " name);
WARP_RUNTIME_METHODS(SAME_)
#undef SAME_
/* the registry's plane bits are the frames' */
_Static_assert((unsigned)WARP_NEEDS_DEPTH == (unsigned)DRV_PLANE_DEPTH &&
                   (unsigned)WARP_NEEDS_IDS == (unsigned)DRV_PLANE_IDS &&
                   (unsigned)WARP_NEEDS_MOTION == (unsigned)DRV_PLANE_MOTION &&
                   (unsigned)WARP_NEEDS_LAYERS == (unsigned)DRV_PLANE_LAYERS,
               "WARP_NEEDS_* == DRV_PLANE_*");

rt_method rt_render_cpu_usable(rt_render_cpu *r, const rt_frame *frame, rt_method method, unsigned planes)
{
    unsigned have = planes & ~(unsigned)DRV_PLANE_DEPTH;
    /* without its eye buffers the pass cannot run a depth warp (hmdwarpd asks for none then; a caller might) */
    if (frame->has_depth && r->p.depth_warps) have |= DRV_PLANE_DEPTH;
    if (!r->p.transparency) have &= ~(unsigned)DRV_PLANE_LAYERS;
    if (!r->p.objects) have &= ~(unsigned)DRV_PLANE_IDS;
    unsigned missing = 0;
    rt_method m = (rt_method)warp_method_usable(rt_method_warp(method), have, &missing);
    if (missing & ~(unsigned)DRV_PLANE_DEPTH) atomic_fetch_add_explicit(&r->plane_fallbacks, 1, memory_order_relaxed);
    if (missing & DRV_PLANE_DEPTH) atomic_fetch_add_explicit(&r->raytrace_fallbacks, 1, memory_order_relaxed);
    return m;
}

bool rt_render_cpu_mesh_traced(rt_render_cpu *r, const rt_frame *frame, const warp_pose eyes[2],
                               const warp_pose first[2], const warp_pose last[2], const warp_raytrace_setup *rts[2],
                               const warp_raytrace_setup *rts_last[2], const warp_scan **scan)
{
    job *j = &r->j;
    const bool rolling = r->p.scan.rolling && first && last;
    j->first = rolling ? first : NULL;
    j->last = rolling ? last : NULL;
    j->frame = frame;
    if (!r->mtrace[0].cell || !frame->has_depth || !raytrace_setups(r, j, frame, eyes, RT_METHOD_RAYTRACE_MESH))
        return false;
    /* the vertices' own setups: mid-scan on a global panel, the first and the last line's on a rolling one */
    for (int e = 0; e < 2; e++) {
        rts[e] = &j->rts[e];
        rts_last[e] = j->first ? &j->rts_last[e] : NULL;
    }
    *scan = j->first ? &r->p.scan : NULL;
    plat_workers_run(r->workers, 2, mesh_raytrace_task, j);
    return true;
}

rt_method rt_render_cpu_frame(rt_render_cpu *r, const rt_frame *frame, const warp_pose eyes[2], rt_method method,
                              const warp_pose *objects_at, warp_image_rgba8 *out)
{
    return rt_render_cpu_frame_scan(r, frame, eyes, NULL, NULL, method, objects_at, out);
}

rt_method rt_render_cpu_frame_scan(rt_render_cpu *r, const rt_frame *frame, const warp_pose eyes[2],
                                   const warp_pose first[2], const warp_pose last[2], rt_method method,
                                   const warp_pose *objects_at, warp_image_rgba8 *out)
{
    job *j = &r->j;
    const bool rolling = r->p.scan.rolling && first && last;
    j->first = rolling ? first : NULL;
    j->last = rolling ? last : NULL;
    j->frame = frame;
    j->out = out;
    j->objects_at = objects_at;
    method = rt_render_cpu_usable(r, frame, method, frame->f.planes);
    return passes[method](r, j, frame, eyes, method);
}

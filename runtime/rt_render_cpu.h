/* SPDX-License-Identifier: MIT */
/* rt_render_cpu: the CPU render pass: one host frame warped to the eye poses and distorted for the lens into a
 * panel image, on the compositor's workers. hmdwarpd, hmdwarp-bench and the tests all run this one pass. */
#ifndef RT_RENDER_CPU_H
#define RT_RENDER_CPU_H

#include <stdbool.h>
#include <stdint.h>

#include "platform/plat_workers.h"
#include "runtime/rt_config.h"
#include "runtime/rt_frameq.h"
#include "warp/warp_lens.h"
#include "warp/warp_mesh.h"
#include "warp/warp_mesh_trace.h"
#include "warp/warp_raytrace.h"

/* What the pass is built for: the panel, the lens, the raytrace's knobs, and which warps it allocates for (a
 * method not allocated for falls down its ladder: rt_render_cpu_usable). */
typedef struct {
    int panel_w, panel_h;   /* the panel: the left eye's viewport is its left half */
    int eye_w, eye_h;       /* the host frame's eye buffers */
    int mesh_n;             /* lens mesh vertices per side */
    warp_lens lens[2];
    double visible_radius[2]; /* the lens's visible disc per eye (warp_fov); 0: no hidden-area mask */
    warp_raytrace_params raytrace;
    warp_mesh_trace_params mesh_trace; /* raytrace_mesh: which lens mesh cells get per-pixel rays */
    bool mesh_cells;        /* raytrace_mesh traces those cells per pixel; false: its vertices alone */
    bool depth_warps;       /* the eye-space warps (raytrace, transparency, objects): their eye buffers */
    bool transparency;      /* the A-buffer warp's grid, tree and depth buffer */
    bool objects;           /* the per-object warp's splat and hole-filling scratch */
    warp_scan scan;         /* how the panel lights its lines ([display] scanout) */
} rt_render_cpu_params;

/* The pass's tiles: the lens pass resamples (and raytrace_mesh traces) an eye in rectangles of this size, one task
 * each; rt_kernel times the kernels on them too, since the kernels' prefetch and cache behaviour depend on them. */
#define RT_RENDER_CPU_TILE_W 128
#define RT_RENDER_CPU_TILE_H 32

/* The pass as hmdwarpd configures it from c ([display], [lens], [warp]); the bench and the tests use this too, so
 * they run what the daemon runs. */
rt_render_cpu_params rt_render_cpu_params_from_config(const rt_config *c);

typedef struct rt_render_cpu rt_render_cpu;

/* Allocates everything the pass will use (the vsync path never allocates). The workers are borrowed: they must
 * outlive the pass. NULL with the reason in err on failure. */
rt_render_cpu *rt_render_cpu_create(const rt_render_cpu_params *p, plat_workers *workers, char *err, int errlen);
/* Frees the pass and clears *r; NULL or *r NULL is fine. */
void rt_render_cpu_destroy(rt_render_cpu **r);

/* Where the registry method `method` lands for `frame` (whose planes are `planes`; depth counts only when the frame
 * has it): down its fallback ladder past what lacks a plane or was not allocated for, counting a raytrace fallback
 * (no depth) or a plane fallback (no ids, no layers). The GLES path asks it too (planes 0: depth at most). */
rt_method rt_render_cpu_usable(rt_render_cpu *r, const rt_frame *frame, rt_method method, unsigned planes);

/* Renders `frame` warped to the eye poses `eyes` with `method` (or what its ladder gives the frame) into `out`
 * (panel-sized). objects_at: the objects' poses at photon time for the per-object warp (NULL: where the frame saw
 * them). Returns the method actually run. Allocation-, lock- and I/O-free: the vsync path. */
rt_method rt_render_cpu_frame(rt_render_cpu *r, const rt_frame *frame, const warp_pose eyes[2], rt_method method,
                              const warp_pose *objects_at, warp_image_rgba8 *out);

/* The same on a rolling-scan panel (params.scan.rolling): first and last are the eye poses predicted for the scan's
 * first and last lit line, eyes for its middle. rotation and raytrace_mesh warp each lens mesh vertex at its own
 * line's pose (warp_mesh_update_rolling, warp_mesh_update_raytrace_rolling: nothing extra per pixel); the
 * per-pixel warps (raytrace, transparency, objects) use the mid-scan eyes. first/last NULL or a global panel:
 * rt_render_cpu_frame exactly. Allocation-, lock- and I/O-free: the vsync path. */
rt_method rt_render_cpu_frame_scan(rt_render_cpu *r, const rt_frame *frame, const warp_pose eyes[2],
                                   const warp_pose first[2], const warp_pose last[2], rt_method method,
                                   const warp_pose *objects_at, warp_image_rgba8 *out);

typedef struct {
    uint64_t raytrace_fallbacks; /* a depth warp requested, but the frame had no depth */
    uint64_t plane_fallbacks;    /* transparency / objects requested, but the frame lacked layers / ids */
} rt_render_cpu_stats;
/* Any thread (the helper thread reads them live). */
rt_render_cpu_stats rt_render_cpu_stats_get(const rt_render_cpu *r);

/* The lens meshes (the GLES renderer draws through the same ones) and the raytrace's and raytrace_mesh's knobs (the
 * GLES raytrace, the accuracy evaluator and the bench use the pass's). */
warp_mesh *rt_render_cpu_mesh(rt_render_cpu *r, int eye);
/* Eye e's cells traced per pixel by the last raytrace_mesh pass (warp_mesh_trace: marked of cells_x * cells_y);
 * NULL without the depth warps. */
const warp_mesh_trace *rt_render_cpu_mesh_trace(const rt_render_cpu *r, int eye);
/* Eye e's lens mesh updated for `method` (rotation; anything else draws the frame as rendered) from frame to
 * eye_pose, or per vertex between the scan's first and last line's poses when the panel scans out rolling and both
 * are given, exactly as the CPU pass does: the GLES renderer draws through it. */
warp_mesh *rt_render_cpu_mesh_for(rt_render_cpu *r, const rt_frame *frame, int e, rt_method method,
                                  warp_pose eye_pose, const warp_pose *first, const warp_pose *last);
/* raytrace_mesh on the GLES renderer: both eyes' lens meshes traced at their vertices and their cells marked
 * (rt_render_cpu_mesh, rt_render_cpu_mesh_trace), exactly as the CPU pass does before its resampling, on the pass's
 * threads; rts points at the setups the GPU's per-pixel rays take, as the CPU's take them (the pass's own, valid
 * until its next frame): the mid-scan ones (eyes), or, on a rolling panel (first and last given), the first line's,
 * with rts_last at the last line's and *scan at the panel's scan (else both NULL). False, nothing done, when the
 * frame or the pass has no depth or the frame cannot give a raytrace setup. Allocation-free: the vsync path. */
bool rt_render_cpu_mesh_traced(rt_render_cpu *r, const rt_frame *frame, const warp_pose eyes[2],
                               const warp_pose first[2], const warp_pose last[2], const warp_raytrace_setup *rts[2],
                               const warp_raytrace_setup *rts_last[2], const warp_scan **scan);
const warp_raytrace_params *rt_render_cpu_raytrace_params(const rt_render_cpu *r);
const warp_mesh_trace_params *rt_render_cpu_mesh_trace_params(const rt_render_cpu *r);
/* raytrace_mesh with its vertices alone (on: no marks, no per-pixel rays; the last marks stay for
 * rt_render_cpu_mesh_trace): what the per-pixel cells cost is then the difference, as `make bench` shows it. At
 * creation on where the params' mesh_cells is false ([warp] mesh_cells); the caller's thread, between passes. */
void rt_render_cpu_mesh_vertices_only(rt_render_cpu *r, bool on);
/* Whether raytrace_mesh traces its marked cells per pixel (not its vertices alone): the GLES renderer asks. */
bool rt_render_cpu_mesh_cells(const rt_render_cpu *r);

/* The eye's visible panel pixels (the whole viewport without a mask), and how many of them the mesh's current warp
 * samples outside a src_w x src_h source (warp_fov_outside: per mesh vertex, the pixels nearest it). Allocation-free:
 * the compositor reads it after each pass. */
int64_t rt_render_cpu_visible(const rt_render_cpu *r, int eye);
int64_t rt_render_cpu_outside(const rt_render_cpu *r, int eye, int src_w, int src_h);

#endif

/* SPDX-License-Identifier: MIT */
/* plat_gles: the warp on the GPU with OpenGL ES 3.0 (GLSL ES 3.00): host frame upload, the min-max depth pyramid,
 * the height-map raytrace with its edge fills, and the lens pass through the distortion mesh (with per-pixel rays in
 * raytrace_mesh's marked cells); per-pass GPU times. */
#ifndef PLAT_GLES_H
#define PLAT_GLES_H

#include <stdbool.h>
#include <stdint.h>

#include "platform/plat_egl.h"
#include "warp/warp_image.h"
#include "warp/warp_camera.h"
#include "warp/warp_mesh.h"
#include "warp/warp_mesh_trace.h"
#include "warp/warp_raytrace.h"
#include "warp/warp_scan.h"

typedef struct plat_gles plat_gles;

/* The passes timed separately (plat_gles_pass_name gives "upload", "pyramid", "raytrace", "lens", "readback"). */
typedef enum {
    PLAT_GLES_UPLOAD = 0, /* host frame colour (+ inverse depth) into textures: glTexSubImage2D */
    PLAT_GLES_PYRAMID,    /* the depth pyramid's reduction passes, once per host frame */
    PLAT_GLES_RAYTRACE,   /* eye-space raytrace into the intermediate image, per eye */
    PLAT_GLES_LENS,       /* mesh upload + the fused rotation / lens / chromatic aberration draw, per eye */
    PLAT_GLES_READBACK,   /* glReadPixels of the panel (offscreen output) */
    PLAT_GLES_PASSES
} plat_gles_pass;
const char *plat_gles_pass_name(plat_gles_pass p);

typedef struct {
    int panel_w, panel_h;   /* the image the lens pass draws (both eyes side by side) */
    int src_w, src_h;       /* host eye frames; also the size of the raytrace's eye-space output */
    int mesh_cols, mesh_rows; /* the distortion mesh's vertex grid (both eyes alike) */
    bool depth;             /* allocate the depth, pyramid and raytrace resources */
    bool to_window;         /* draw into the default framebuffer (KMS, panel row 0 at the top) instead of an FBO */
    bool timing;            /* time each pass: EXT_disjoint_timer_query when offered, else glFinish bracketing */
    bool cpu_pyramid;       /* build the pyramid on the CPU and upload it (automatic without EXT_color_buffer_float) */
} plat_gles_params;

/* Compiles the shaders and allocates every texture and framebuffer (start-up only; the context must be current
 * on the calling thread). NULL with err naming the missing feature or the shader log. */
plat_gles *plat_gles_create(plat_egl *egl, const plat_gles_params *p, char *err, int errlen);
void plat_gles_destroy(plat_gles *g); /* context current */

/* Per host frame: uploads one eye's colour and, when inv_depth is not NULL (params.depth), its inverse depth,
 * then builds that eye's depth pyramid. Sizes must be src_w x src_h. False on bad sizes or a GL error. */
bool plat_gles_upload(plat_gles *g, int eye, const warp_image_rgba8 *color, const warp_image_f32 *inv_depth);

/* Per vsync. The raytrace of 003 §3.5 for one eye into its eye-space intermediate (colour; the fringe / edge
 * mask in alpha), from the frame uploaded last; s from warp_raytrace_prepare (its params apply). */
void plat_gles_raytrace(plat_gles *g, int eye, const warp_raytrace_setup *s);
/* The lens pass of one eye into its viewport (m->vp_*): per channel the source position interpolated bilinearly
 * between the mesh's vertices exactly as warp_mesh_resample does, then one bilinear sample per channel with
 * clamp-to-edge (the 003 §4.3 fringe fill). Source: the uploaded frame, or the raytrace output. */
void plat_gles_lens(plat_gles *g, int eye, const warp_mesh *m, bool from_raytrace);
/* The display path's depth warp (raytrace_mesh) in one lens pass from the uploaded frame (params.depth): m's
 * vertices hold their raytraced source positions (warp_mesh_raytrace_vertices, which also marked t's cells) and are
 * interpolated as plat_gles_lens does, except in the cells t marks, where each channel's ray is traced per pixel
 * from the pixel's own eye-buffer position (m's lens directions through cam) as plat_gles_raytrace traces under s.
 * On a rolling panel (last and scan not NULL, s the first line's setup, as warp_mesh_trace_rect takes them) each
 * such ray is traced under s and last and its source positions interpolated at the pixel's scan fraction, so the
 * traced pixels meet the vertices, which were warped at their own line's pose. Timed as the lens pass. Per vsync:
 * uploads the marks and the vertices' eye-buffer positions, allocates nothing. */
void plat_gles_lens_traced(plat_gles *g, int eye, const warp_mesh *m, const warp_mesh_trace *t,
                           const warp_camera *cam, const warp_raytrace_setup *s, const warp_raytrace_setup *last,
                           const warp_scan *scan);
/* Clears the panel to black (no frame yet). */
void plat_gles_clear(plat_gles *g);
/* Reads the panel image into dst (panel-sized); waits for the GPU. False on a GL error (err filled). */
bool plat_gles_read(plat_gles *g, warp_image_rgba8 *dst, char *err, int errlen);
/* Closes one vsync's timing and collects finished timer queries (never waits for the GPU). */
void plat_gles_end_frame(plat_gles *g);

/* Per-pass GPU milliseconds of the newest frame whose timings are complete; `seq` grows with every new result
 * (valid[p]: the pass ran in that frame). False when none yet or timing is off. */
typedef struct {
    double ms[PLAT_GLES_PASSES];
    bool valid[PLAT_GLES_PASSES];
    uint64_t seq;
} plat_gles_times;
bool plat_gles_times_latest(const plat_gles *g, plat_gles_times *t);
/* "timer queries (EXT_disjoint_timer_query)", "glFinish bracketing" or "off". */
const char *plat_gles_timing_method(const plat_gles *g);
/* Whether the pyramid is built on the GPU (false: on the CPU, uploaded). */
bool plat_gles_gpu_pyramid(const plat_gles *g);

/* A benchmark of every pass at this renderer's sizes (e.g. panel 2880x1600, eyes 1440x1600 for the reference
 * headset): `reps` vsyncs, each uploading eye e's colour[e] (and inv[e], its inverse depth, when inv is not NULL:
 * the pyramid too), raytracing both eyes with rt[e] when rt is not NULL (else the rotation mesh as it is), the lens
 * pass of both eyes through mesh[e], and the readback. Writes the mean GPU milliseconds per pass and vsync to mean
 * (valid: the pass ran and was timed). Needs params.timing. Allocates (not for the vsync path). A bench tool
 * calls plat_egl_open_offscreen, plat_gles_create, warp_mesh_alloc/update, warp_raytrace_prepare, then this, and
 * prints mean.ms[p] under plat_gles_pass_name(p) next to the CPU path's times. */
bool plat_gles_bench(plat_gles *g, const warp_image_rgba8 *const color[2], const warp_image_f32 *const inv[2],
                     const warp_raytrace_setup *const rt[2], const warp_mesh *const mesh[2], int reps,
                     plat_gles_times *mean);
/* The same for raytrace_mesh: the lens pass is plat_gles_lens_traced through mesh[e] (its vertices traced and t[e]'s
 * cells marked under rt[e], warp_mesh_raytrace_vertices), with no raytrace pass. False also without inv or depth. */
bool plat_gles_bench_traced(plat_gles *g, const warp_image_rgba8 *const color[2], const warp_image_f32 *const inv[2],
                            const warp_raytrace_setup *const rt[2], const warp_mesh *const mesh[2],
                            const warp_mesh_trace *const t[2], const warp_camera *const cam[2], int reps,
                            plat_gles_times *mean);

/* Tests and diagnostics: the raytrace output of one eye (colour into rgb, may be NULL; mask values
 * WARP_MASK_FRINGE / WARP_MASK_EDGE into mask, may be NULL), and pyramid level `level` (max inverse depth over
 * the level's block of bilinear cells) into dst (at least the level's size). */
bool plat_gles_read_raytrace(plat_gles *g, int eye, warp_image_rgba8 *rgb, warp_image_u8 *mask);
bool plat_gles_read_pyramid(plat_gles *g, int eye, int level, warp_image_f32 *dst);
/* Diagnostics: when on, the raytrace writes the number of search steps each ray sampled depth at (low byte in red,
 * high in green; the first sample and the refinement not counted, as in warp_raytrace_stats.steps) instead of
 * its colour: how much the pyramid saves over the CPU's one sample per source pixel. */
void plat_gles_count_samples(plat_gles *g, bool on);

/* The pyramid's geometry and its CPU reference. Level 0 cell (x, y) holds the largest inverse depth among the
 * texels a bilinear sample in that cell reads: (x..x+1, y..y+1), clamped to the image; level L cell (x, y) the
 * largest of level L-1 cells (2x..2x+1, 2y..2y+1). Level sizes round up, so no edge cell is lost. */
#define PLAT_GLES_MAX_LEVELS 16
int plat_gles_pyramid_levels(int w, int h);
void plat_gles_pyramid_level_size(int w, int h, int level, int *lw, int *lh);
/* Writes level `level` of inv's pyramid into out (at least that size); scratch must hold w*h floats. */
void plat_gles_pyramid_cpu(const warp_image_f32 *inv, int level, warp_image_f32 *out, float *scratch);

#endif

/* SPDX-License-Identifier: MIT */
/* rt_gles: the GLES path's part of a run: which renderer [render] renderer chose and why (rt_render_choose), the EGL
 * context and GLES renderer, the frame in its textures, its GPU times per pass and its errors. */
#ifndef RT_GLES_H
#define RT_GLES_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

#include "runtime/rt_frameq.h"
#include "runtime/rt_telemetry.h"

typedef struct plat_egl plat_egl;
typedef struct plat_gles plat_gles;

/* Written by rt_app_init and the compositor thread; use and errors also read live by the helper thread (atomic;
 * last_error only by the summary once the compositor has returned). */
typedef struct {
    _Atomic bool use;          /* the GLES path runs (else the CPU path); the compositor may fall back once */
    _Atomic bool fell_back;    /* the compositor could not make the context current: the CPU path runs instead */
    bool software;             /* a software rasterizer: its GPU time is CPU time after the submit */
    plat_egl *egl;             /* EGL display + context (GLES only); made current by the compositor thread */
    plat_gles *renderer;
    bool depth;                /* the GLES resources include depth, pyramid and raytrace */
    const rt_frame *frame;     /* the frame whose planes are in the GLES textures */
    uint64_t frame_seq;
    _Atomic uint64_t errors;   /* failed uploads, readbacks or page flips */
    char last_error[200];
    rt_hist *ms;               /* [PLAT_GLES_PASSES] GPU time per pass and vsync (compositor thread) */
    uint64_t times_seq;
    double gpu_ms;             /* newest complete frame's GPU time, all passes */
    int64_t submit_ns;         /* when the last vsync's GL work was all submitted */
} rt_gles;

/* Decides the renderer from [render] renderer (`setting`: auto, cpu, gles), the GL_RENDERER string of the context
 * EGL gave (NULL when it gave none; egl_err then says why) and whether the output is KMS. Returns true for GLES
 * and writes the reason in one line to why. auto picks GLES on a hardware GPU and the CPU path when only a
 * software rasterizer (llvmpipe) or no EGL is there: there the CPU path is faster, and vsync comes first. With
 * KMS output the choice is the same (the CPU path shows through dumb buffers). A forced gles without EGL returns
 * true: the caller fails. */
bool rt_render_choose(const char *setting, const char *gl_renderer, const char *egl_err, bool kms, char *why,
                      int whylen);
/* Destroys the renderer (in its context), closes EGL and frees the times; a zeroed part is fine. */
void rt_gles_free(rt_gles *g);

#endif

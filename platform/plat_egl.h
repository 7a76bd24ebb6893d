/* SPDX-License-Identifier: MIT */
/* plat_egl: EGL display and OpenGL ES 3 context for the GPU renderer: surfaceless (rendering into FBOs, tests
 * and the simulated board) or a real panel through DRM/KMS + GBM with page flips on its connector. */
#ifndef PLAT_EGL_H
#define PLAT_EGL_H

#include <stdbool.h>
#include <stdint.h>

#include "platform/plat_kms.h"

typedef struct plat_egl plat_egl;

/* Where KMS output goes (the connector/mode/CRTC choice is plat_kms's, shared with the CPU path). */
typedef plat_kms_params plat_egl_kms_params;

/* A context for rendering into FBOs only: Mesa's EGL_MESA_platform_surfaceless when the client library has it,
 * else the default display with a 1x1 pbuffer. NULL with a message naming what is missing in err. */
plat_egl *plat_egl_open_offscreen(char *err, int errlen);
/* A context whose default framebuffer is the panel: opens the DRM device, picks a connected connector, its mode
 * and a CRTC, creates a GBM surface and an EGL window surface on it. Nothing is shown before the first
 * plat_egl_present(). NULL with a message in err (e.g. "no DRM device: /dev/dri/card0: No such file or
 * directory"). */
plat_egl *plat_egl_open_kms(const plat_egl_kms_params *p, char *err, int errlen);
void plat_egl_close(plat_egl *e);

/* Makes the context current on the calling thread (GL calls work only there); false when EGL refuses. */
bool plat_egl_make_current(plat_egl *e);
/* Releases it from the calling thread (before another thread makes it current). */
void plat_egl_release(plat_egl *e);

/* GL_RENDERER / GL_VERSION strings of the context ("llvmpipe (LLVM 15.0.6, 256 bits)", ...). */
const char *plat_egl_renderer(const plat_egl *e);
const char *plat_egl_version(const plat_egl *e);
/* Whether `renderer` names a software rasterizer (llvmpipe, softpipe, swrast, lavapipe, SwiftShader): there the
 * CPU path of this project is faster than GLES emulated on the same cores. */
bool plat_egl_renderer_is_software(const char *renderer);
/* Whether the context offers GL extension `name` (whole-word match). */
bool plat_egl_has_extension(const plat_egl *e, const char *name);

/* KMS: whether this context drives a panel, and the mode's size and refresh. */
bool plat_egl_is_kms(const plat_egl *e);
void plat_egl_kms_mode(const plat_egl *e, int *w, int *h, double *hz, const char **connector);

/* KMS: shows what was rendered into the default framebuffer since the last call: eglSwapBuffers, then a page
 * flip of the new front buffer at the next vblank (plat_kms_commit: atomic where the driver has it; the first call
 * sets the mode instead). Waits for the previous flip's completion first (100 ms at most), which plat_kms's event
 * thread has normally reported long before (one flip per vsync). Offscreen: nothing.
 * False with err when the flip failed (counted; the next call tries again) or the previous one is still pending (this
 * frame is not shown: committing then would be refused EBUSY; a flip pending for a second is taken as lost). */
bool plat_egl_present(plat_egl *e, char *err, int errlen);
/* Page flips done and failed so far. */
void plat_egl_flip_stats(const plat_egl *e, uint64_t *flips, uint64_t *failed);
/* The KMS output under the context (flip statistics, vblank times for a vsync source), NULL when offscreen. */
plat_kms *plat_egl_kms(const plat_egl *e);

#endif

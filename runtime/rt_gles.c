/* SPDX-License-Identifier: MIT */
/* rt_gles: the GLES path's part of a run: which renderer [render] renderer chose and why (rt_render_choose), the EGL
 * context and GLES renderer, the frame in its textures, its GPU times per pass and its errors. */
#include "runtime/rt_gles.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "platform/plat_egl.h"
#include "platform/plat_gles.h"

bool rt_render_choose(const char *setting, const char *gl_renderer, const char *egl_err, bool kms, char *why,
                      int whylen)
{
    size_t n = (size_t)whylen;
    if (strcmp(setting, "cpu") == 0) {
        snprintf(why, n, "renderer = cpu");
        return false;
    }
    if (strcmp(setting, "gles") == 0) {
        if (gl_renderer)
            snprintf(why, n, "renderer = gles%s", plat_egl_renderer_is_software(gl_renderer)
                                                      ? " (forced onto a software rasterizer)"
                                                      : "");
        else
            snprintf(why, n, "renderer = gles, but no EGL: %s", egl_err ? egl_err : "unknown error");
        return true;
    }
    /* with output = kms the CPU path shows through dumb buffers, so the choice is the same as offscreen */
    const char *via = kms ? "; KMS through dumb buffers" : "";
    if (!gl_renderer) {
        snprintf(why, n, "auto: no usable EGL / OpenGL ES 3 (%s)%s", egl_err ? egl_err : "unknown error", via);
        return false;
    }
    if (!plat_egl_renderer_is_software(gl_renderer)) {
        snprintf(why, n, "auto: EGL offers a hardware GPU");
        return true;
    }
    snprintf(why, n, "auto: EGL offers only a software rasterizer (%s); the CPU path is faster there and vsync "
                     "comes first%s",
             gl_renderer, via);
    return false;
}

void rt_gles_free(rt_gles *g)
{
    if (g->renderer && plat_egl_make_current(g->egl)) plat_gles_destroy(g->renderer);
    plat_egl_close(g->egl);
    free(g->ms);
    memset(g, 0, sizeof *g);
}

/* SPDX-License-Identifier: MIT */
/* bench_display: the display path hmdwarp-bench times, as hmdwarpd runs it: no pass of its own, only the panel the
 * bench measures on and the host frame it feeds hmdwarpd's CPU render pass. */
#include "bench_display.h"

#include <stdio.h>
#include <string.h>

void bench_config(rt_config *cfg, bool quick, int eye_w, int eye_h)
{
    rt_config_defaults(cfg);
    if (quick) {
        cfg->panel_w = 1440, cfg->panel_h = 800, cfg->eye_w = 720, cfg->eye_h = 800;
        cfg->lens_scale = 360, cfg->lens_center[0] = 380, cfg->lens_center[1] = 400;
    }
    if (eye_w > 0) {
        double sx = (double)eye_w / 1440, sy = (double)eye_h / 1600;
        rt_config ref;
        rt_config_defaults(&ref);
        cfg->panel_w = 2 * eye_w, cfg->panel_h = eye_h, cfg->eye_w = eye_w, cfg->eye_h = eye_h;
        cfg->lens_scale = ref.lens_scale * sx;
        cfg->lens_center[0] = ref.lens_center[0] * sx, cfg->lens_center[1] = ref.lens_center[1] * sy;
    }
    cfg->method = RT_METHOD_RAYTRACE;
}

bool bench_display_init(bench_display *d, const rt_config *cfg, plat_workers *workers, plat_workers *workers1,
                        char *err, int errlen)
{
    memset(d, 0, sizeof *d);
    rt_render_cpu_params p = rt_render_cpu_params_from_config(cfg);
    d->pass[0] = rt_render_cpu_create(&p, workers, err, errlen);
    if (!d->pass[0]) return false;
    if (workers1 && !(d->pass[1] = rt_render_cpu_create(&p, workers1, err, errlen))) return false;
    if (!rt_frame_alloc(&d->frame, cfg->eye_w, cfg->eye_h, DRV_PLANE_COLOR | DRV_PLANE_DEPTH, 0) ||
        !warp_image_rgba8_alloc(&d->panel, cfg->panel_w, cfg->panel_h)) {
        snprintf(err, (size_t)errlen, "out of memory");
        return false;
    }
    return true;
}

bool bench_display_set_frame(bench_display *d, const warp_camera cam[2], const warp_pose pose[2],
                             const warp_image_rgba8 *const color[2], const warp_image_f32 *const depth[2],
                             uint64_t seq, char *err, int errlen)
{
    drv_frame *f = &d->frame.f;
    f->seq = seq;
    f->planes = DRV_PLANE_COLOR | DRV_PLANE_DEPTH;
    f->depth_encoding = WARP_DEPTH_LINEAR;
    f->n_objects = 0;
    for (int e = 0; e < 2; e++) {
        if (color[e]->w != f->color[e].w || color[e]->h != f->color[e].h || depth[e]->w != f->depth[e].w ||
            depth[e]->h != f->depth[e].h) {
            snprintf(err, (size_t)errlen, "eye %d: %dx%d planes for a %dx%d frame", e, color[e]->w, color[e]->h,
                     f->color[e].w, f->color[e].h);
            return false;
        }
        f->cam[e] = cam[e];
        f->eye_pose[e] = pose[e];
        for (int y = 0; y < f->color[e].h; y++) {
            memcpy(&WARP_AT(&f->color[e], 0, y), &WARP_AT(color[e], 0, y), sizeof(warp_rgba8) * (size_t)color[e]->w);
            memcpy(&WARP_AT(&f->depth[e], 0, y), &WARP_AT(depth[e], 0, y), sizeof(float) * (size_t)depth[e]->w);
        }
    }
    drv_frame_err e = rt_frame_prepare(&d->frame);
    if (e != DRV_FRAME_OK) {
        snprintf(err, (size_t)errlen, "hmdwarpd would reject the frame: %s", drv_frame_err_str(e));
        return false;
    }
    return true;
}

rt_method bench_display_run(bench_display *d, int which, const warp_pose eyes[2], rt_method method)
{
    return rt_render_cpu_frame(d->pass[which], &d->frame, eyes, method, NULL, &d->panel);
}

void bench_display_free(bench_display *d)
{
    rt_render_cpu_destroy(&d->pass[0]);
    rt_render_cpu_destroy(&d->pass[1]);
    rt_frame_free(&d->frame);
    warp_image_free(&d->panel);
}

/* SPDX-License-Identifier: MIT */
/* bench_display: the display path hmdwarp-bench times: hmdwarpd's own CPU render pass (runtime/rt_render_cpu),
 * built from the bench's panel configuration the way rt_app_init builds it, on a host frame prepared as hmdwarpd
 * prepares one. tests/unit/test_render_cpu checks it gives the daemon's bytes. */
#ifndef BENCH_DISPLAY_H
#define BENCH_DISPLAY_H

#include <stdbool.h>
#include <stdint.h>

#include "platform/plat_workers.h"
#include "runtime/rt_config.h"
#include "runtime/rt_frameq.h"
#include "runtime/rt_render_cpu.h"

/* The bench's panel: the reference 2880x1600 with 1440x1600 eyes (quick: 1440x800 and 720x800), or with eye_w > 0
 * eyes of eye_w x eye_h, the reference lens scaled alike (its scale and centre are in panel pixels); [warp]
 * method raytrace, so the pass has the eye buffers of the depth warps the bench times. */
void bench_config(rt_config *cfg, bool quick, int eye_w, int eye_h);

typedef struct {
    rt_render_cpu *pass[2];  /* on the bench's workers, and on one thread ([1], NULL when not asked for) */
    rt_frame frame;          /* the host frame: colour and depth */
    warp_image_rgba8 panel;  /* what the panel would show */
} bench_display;

/* The passes from cfg (rt_render_cpu_params_from_config, as hmdwarpd), on `workers` and on `workers1` (may be
 * NULL), and a frame of cfg's eye size. False with the reason in err. */
bool bench_display_init(bench_display *d, const rt_config *cfg, plat_workers *workers, plat_workers *workers1,
                        char *err, int errlen);
/* The host frame: per eye its camera, the pose it was rendered from, its colour and linear depth (the camera's
 * size); seq tells the frame from the previous one. Prepared as hmdwarpd's frames thread does (rt_frame_prepare):
 * false with the reason in err when it would reject it. */
bool bench_display_set_frame(bench_display *d, const warp_camera cam[2], const warp_pose pose[2],
                             const warp_image_rgba8 *const color[2], const warp_image_f32 *const depth[2],
                             uint64_t seq, char *err, int errlen);
/* One vsync of hmdwarpd's CPU path to the eye poses `eyes` into d->panel, on pass[which]: the method run. */
rt_method bench_display_run(bench_display *d, int which, const warp_pose eyes[2], rt_method method);
void bench_display_free(bench_display *d);

#endif

/* SPDX-License-Identifier: MIT */
/* Fuzzes the V4L2 in-band decoder (drivers/drv_v4l2_inband.c) on captured pictures as they come: the metadata band
 * (preamble, CRC, values), colour conversion and depth rows. Input: u8 pixel format, u8 colour space, then the
 * picture's bytes (missing bytes read as black). */
#include <stdio.h>

#include "tests/fuzz/v4l2_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 2) return 0;
    drv_v4l2_geom g;
    drv_frame *f;
    v4_setup(data[0], &g, &f);
    uint8_t *img = calloc(1, g.size);
    memcpy(img, data + 2, size - 2 < g.size ? size - 2 : g.size);
    v4_unpack(img, &g, data[1] & 1, f);
    free(img);
    return 0;
}

void fuzz_write_seeds(void)
{
    for (uint8_t sel = 0; sel < 5; sel++) {
        drv_v4l2_geom g;
        drv_frame *unused, f;
        v4_setup(sel, &g, &unused);
        fuzz_example_frame(&f, DRV_PLANE_COLOR | DRV_PLANE_DEPTH, sel);
        drv_frame_free(&f);
        if (!drv_frame_alloc(&f, V4_EYE_W, V4_EYE_H, DRV_PLANE_COLOR | DRV_PLANE_DEPTH, 1)) abort();
        drv_frame ex;
        fuzz_example_frame(&ex, DRV_PLANE_COLOR, sel);
        f.planes = DRV_PLANE_COLOR | DRV_PLANE_DEPTH;
        f.seq = ex.seq, f.pose_t_ns = ex.pose_t_ns, f.render_start_ns = ex.render_start_ns;
        f.depth_encoding = WARP_DEPTH_LINEAR;
        for (int e = 0; e < 2; e++) {
            f.cam[e] = ex.cam[e], f.cam[e].width = V4_EYE_W, f.cam[e].height = V4_EYE_H;
            f.eye_pose[e] = ex.eye_pose[e];
            for (int y = 0; y < V4_EYE_H; y++)
                for (int x = 0; x < V4_EYE_W; x++) {
                    WARP_AT(&f.color[e], x, y) = (warp_rgba8){(uint8_t)(x * 4), (uint8_t)(y * 100), 77, 255};
                    WARP_AT(&f.depth[e], x, y) = 1.0f + 0.1f * (float)x;
                }
        }
        drv_frame_free(&ex);
        uint8_t *buf = malloc(2 + g.size);
        buf[0] = sel, buf[1] = 0;
        drv_v4l2_colorspace cs = DRV_V4L2_CS_DEFAULT;
        if (drv_v4l2_pack(&f, true, &g, &cs, buf + 2) != DRV_FRAME_OK) abort();
        char name[32];
        snprintf(name, sizeof name, "picture-%u", sel);
        fuzz_seed(name, buf, 2 + g.size);
        free(buf);
        drv_frame_free(&f);
    }
}

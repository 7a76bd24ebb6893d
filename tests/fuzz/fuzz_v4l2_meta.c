/* SPDX-License-Identifier: MIT */
/* Fuzzes the checks behind the V4L2 band's CRC: the metadata values come from the input and are packed by the
 * encoder (drv_v4l2_pack computes the CRC), so any time, pose, camera or depth encoding reaches the decoder's value
 * checks. Input: u8 format, u8 depth encoding, u64 seq, i64 pose_t_ns, i64 render_start_ns, f64 scene_time, per eye
 * 7 f64 pose (w x y z, px py pz) and 6 f64 camera (tan left right up down, near, far). */
#include <stdio.h>

#include "tests/fuzz/v4l2_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_in in = {data, size};
    drv_v4l2_geom g;
    drv_frame *out;
    v4_setup(fuzz_u8(&in), &g, &out);
    static drv_frame f;
    static bool ready;
    if (!ready) {
        if (!drv_frame_alloc(&f, V4_EYE_W, V4_EYE_H, DRV_PLANE_COLOR | DRV_PLANE_DEPTH, 1)) abort();
        for (int e = 0; e < 2; e++)
            for (int y = 0; y < V4_EYE_H; y++)
                for (int x = 0; x < V4_EYE_W; x++) WARP_AT(&f.depth[e], x, y) = 2.0f;
        ready = true;
    }
    f.planes = DRV_PLANE_COLOR | DRV_PLANE_DEPTH;
    f.depth_encoding = (warp_depth_encoding)(fuzz_u8(&in) % 4);
    f.seq = fuzz_u64(&in);
    f.pose_t_ns = (int64_t)fuzz_u64(&in);
    f.render_start_ns = (int64_t)fuzz_u64(&in);
    f.scene_time = fuzz_f64(&in);
    for (int e = 0; e < 2; e++) {
        double v[13];
        for (int i = 0; i < 13; i++) v[i] = fuzz_f64(&in);
        f.eye_pose[e] = (warp_pose){{v[0], v[1], v[2], v[3]}, {v[4], v[5], v[6]}};
        f.cam[e] = (warp_camera){V4_EYE_W, V4_EYE_H, v[7], v[8], v[9], v[10], v[11], v[12]};
    }
    uint8_t *img = malloc(g.size);
    drv_v4l2_colorspace cs = DRV_V4L2_CS_DEFAULT;
    if (drv_v4l2_pack(&f, f.depth_encoding <= WARP_DEPTH_REVERSED, &g, &cs, img) == DRV_FRAME_OK)
        v4_unpack(img, &g, false, out);
    free(img);
    return 0;
}

static void put(uint8_t *b, size_t *n, uint64_t v, int bytes)
{
    for (int i = 0; i < bytes; i++) b[(*n)++] = (uint8_t)(v >> (8 * i));
}
static void putd(uint8_t *b, size_t *n, double d)
{
    uint64_t v;
    memcpy(&v, &d, 8);
    put(b, n, v, 8);
}

void fuzz_write_seeds(void)
{
    for (int sel = 0; sel < 2; sel++) {
        uint8_t b[512];
        size_t n = 0;
        put(b, &n, (uint64_t)sel, 1);
        put(b, &n, WARP_DEPTH_LINEAR, 1);
        put(b, &n, 42, 8);
        put(b, &n, 5000000000u, 8);
        put(b, &n, 4990000000u, 8);
        putd(b, &n, 0.5);
        for (int e = 0; e < 2; e++) {
            const double v[13] = {1, 0, 0, 0, e ? 0.032 : -0.032, 1.6, 0, 1, 1, 0.8, 0.8, 0.05, 100};
            for (int i = 0; i < 13; i++) putd(b, &n, v[i]);
        }
        char name[32];
        snprintf(name, sizeof name, "meta-%d", sel);
        fuzz_seed(name, b, n);
    }
}

/* SPDX-License-Identifier: MIT */
/* test_frame_prepare: what the frames thread derives from a host frame (inverse depth, the raytrace's skipping grid,
 * planar colour) is the same from the vectorised loops as from the plain ones, and the same with each eye on its
 * own thread. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "platform/plat_workers.h"
#include "runtime/rt_frameq.h"
#include "tests/support/test_util.h"
#include "warp/warp_raytrace.h"
#include "warp/warp_view.h"

#define W 37 /* not a multiple of the vectors' 4 or the blocks' 8: every loop's tail runs */
#define H 21

/* Depth with every kind of value a host may send: ordinary, at and nearer than the near plane, sky, zero,
 * negative, NaN, the smallest and largest floats. */
static float depth_value(test_rng *r, warp_depth_encoding enc, int i)
{
    static const float odd[] = {INFINITY, 0.0f, -0.0f, -1.0f, NAN, 1e-45f, 1e-38f, 3.4e38f, 0.05f, 0.0499f, 1.0f};
    if (i % 7 == 3) return odd[(i / 7) % (int)(sizeof odd / sizeof odd[0])];
    if (enc == WARP_DEPTH_LINEAR) return (float)test_rng_uniform(r, 0.03, 40.0);
    return (float)test_rng_uniform(r, -0.01, 1.01);
}

/* warp_inverse_depth_from's per-pixel rule in double, as it was before the 4-wide loop. */
static long inverse_reference(const warp_camera *cam, warp_depth_encoding enc, const warp_image_f32 *depth,
                              warp_image_f32 *inv, float *mn_out, float *mx_out)
{
    const double in = 1.0 / cam->near_z, inf = 1.0 / cam->far_z;
    double a = 0, b = 0;
    if (enc == WARP_DEPTH_STANDARD) a = in, b = inf - in;
    if (enc == WARP_DEPTH_REVERSED) a = inf, b = in - inf;
    long bad = 0;
    float mn = INFINITY, mx = 0;
    for (int y = 0; y < depth->h; y++)
        for (int x = 0; x < depth->w; x++) {
            double d = WARP_AT(depth, x, y), v;
            if (enc == WARP_DEPTH_LINEAR)
                v = d > 0 ? 1.0 / d : NAN;
            else
                v = (d >= 0 && d <= 1) ? a + b * d : NAN;
            if (v > in) v = in;
            if (!(v >= 0)) bad++, v = 0;
            float f = (float)v;
            WARP_AT(inv, x, y) = f;
            mn = f < mn ? f : mn;
            mx = f > mx ? f : mx;
        }
    if (!(mn <= mx)) mn = mx = 0;
    *mn_out = mn, *mx_out = mx;
    return bad;
}

static bool same_bits(float a, float b) { return memcmp(&a, &b, sizeof a) == 0; }

static void test_inverse_depth_matches_reference(void **state)
{
    (void)state;
    warp_image_f32 depth, inv, ref;
    assert_true(warp_image_f32_alloc(&depth, W, H) && warp_image_f32_alloc(&inv, W, H) &&
                warp_image_f32_alloc(&ref, W, H));
    const warp_camera cam = warp_camera_symmetric(W, H, 90, 80, 0.05, 100);
    for (int enc = 0; enc < 3; enc++)
        for (int clean = 0; clean < 2; clean++) {
            test_rng r = test_rng_make(7 + (uint64_t)enc);
            for (int y = 0, i = 0; y < H; y++)
                for (int x = 0; x < W; x++, i++)
                    WARP_AT(&depth, x, y) = clean ? (enc == WARP_DEPTH_LINEAR ? (float)test_rng_uniform(&r, 0.03, 40)
                                                                              : (float)test_rng_uniform(&r, 0, 1))
                                                  : depth_value(&r, (warp_depth_encoding)enc, i);
            float mn, mx, rmn, rmx;
            long bad = warp_inverse_depth_from(&cam, (warp_depth_encoding)enc, &depth, &inv, &mn, &mx);
            long rbad = inverse_reference(&cam, (warp_depth_encoding)enc, &depth, &ref, &rmn, &rmx);
            assert_int_equal(bad, rbad);
            assert_true(clean ? bad == 0 : bad > 0);
            assert_true(same_bits(mn, rmn) && same_bits(mx, rmx));
            for (int y = 0; y < H; y++)
                for (int x = 0; x < W; x++)
                    if (!same_bits(WARP_AT(&inv, x, y), WARP_AT(&ref, x, y)))
                        fail_msg("encoding %d (%d,%d): depth %.9g gives %.9g, want %.9g", enc, x, y,
                                 WARP_AT(&depth, x, y), WARP_AT(&inv, x, y), WARP_AT(&ref, x, y));
        }
    warp_image_free(&depth), warp_image_free(&inv), warp_image_free(&ref);
}

/* The skipping grid: every block's largest value (a NaN never is), whole blocks of 8 and the partial ones at the
 * right and bottom edges, and other block sizes. */
static void test_blockmax_matches_reference(void **state)
{
    (void)state;
    warp_image_f32 inv, bmax;
    assert_true(warp_image_f32_alloc(&inv, W, H) && warp_image_f32_alloc(&bmax, W, H));
    test_rng r = test_rng_make(3);
    for (int y = 0, i = 0; y < H; y++)
        for (int x = 0; x < W; x++, i++)
            WARP_AT(&inv, x, y) = i % 13 == 5 ? NAN : i % 17 == 2 ? -0.0f : (float)test_rng_uniform(&r, 0, 20);
    static const int blocks[] = {8, 5, 1, 16};
    for (size_t k = 0; k < sizeof blocks / sizeof blocks[0]; k++) {
        const int b = blocks[k];
        warp_raytrace_blockmax(&inv, &bmax, b);
        for (int by = 0; by < (H + b - 1) / b; by++)
            for (int bx = 0; bx < (W + b - 1) / b; bx++) {
                float m = 0;
                for (int y = by * b; y < (by + 1) * b && y < H; y++)
                    for (int x = bx * b; x < (bx + 1) * b && x < W; x++)
                        if (WARP_AT(&inv, x, y) > m) m = WARP_AT(&inv, x, y);
                if (!same_bits(WARP_AT(&bmax, bx, by), m))
                    fail_msg("block %d (%d,%d): %.9g, want %.9g", b, bx, by, WARP_AT(&bmax, bx, by), m);
            }
    }
    warp_image_free(&inv), warp_image_free(&bmax);
}

static void fill_frame(rt_frame *s, uint64_t seed)
{
    test_rng r = test_rng_make(seed);
    s->f.planes = DRV_PLANE_COLOR | DRV_PLANE_DEPTH;
    s->f.depth_encoding = WARP_DEPTH_LINEAR;
    for (int e = 0; e < 2; e++) {
        s->f.cam[e] = warp_camera_symmetric(W, H, 90, 80, 0.05 * (1 + e), 100);
        s->f.eye_pose[e] = (warp_pose){{1, 0, 0, 0}, {0.03 * e, 0, 0}};
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                WARP_AT(&s->f.depth[e], x, y) = (float)test_rng_uniform(&r, 0.02, 30);
                WARP_AT(&s->f.color[e], x, y) = (warp_rgba8){(uint8_t)test_rng_uniform(&r, 0, 255),
                                                            (uint8_t)test_rng_uniform(&r, 0, 255),
                                                            (uint8_t)test_rng_uniform(&r, 0, 255), 255};
            }
    }
}

/* Each eye on its own thread (the frames thread's pool) derives exactly what one thread does, and a depth that
 * is not a depth in either eye rejects the frame either way. */
static void test_prepare_on_workers_same(void **state)
{
    (void)state;
    rt_frame a, b;
    assert_true(rt_frame_alloc(&a, W, H, DRV_PLANE_COLOR | DRV_PLANE_DEPTH, 0));
    assert_true(rt_frame_alloc(&b, W, H, DRV_PLANE_COLOR | DRV_PLANE_DEPTH, 0));
    plat_workers *w = plat_workers_create(1, 0);
    assert_non_null(w);
    for (int round = 0; round < 4; round++) {
        fill_frame(&a, 11 + (uint64_t)round);
        fill_frame(&b, 11 + (uint64_t)round);
        assert_int_equal(rt_frame_prepare(&a), DRV_FRAME_OK);
        assert_int_equal(rt_frame_prepare_on(&b, w), DRV_FRAME_OK);
        for (int e = 0; e < 2; e++) {
            assert_true(same_bits(a.inv_min[e], b.inv_min[e]) && same_bits(a.inv_max[e], b.inv_max[e]));
            for (int y = 0; y < H; y++) {
                assert_memory_equal(&WARP_AT(&a.inv_depth[e], 0, y), &WARP_AT(&b.inv_depth[e], 0, y),
                                    sizeof(float) * W);
                for (int c = 0; c < 3; c++)
                    assert_memory_equal(a.planar[e].plane[c] + (size_t)y * a.planar[e].stride,
                                        b.planar[e].plane[c] + (size_t)y * b.planar[e].stride,
                                        sizeof(uint16_t) * (W + 1));
            }
            for (int y = 0; y < a.blockmax[e].h; y++)
                assert_memory_equal(&WARP_AT(&a.blockmax[e], 0, y), &WARP_AT(&b.blockmax[e], 0, y),
                                    sizeof(float) * (size_t)a.blockmax[e].w);
        }
        /* a NaN in one eye's depth: rejected alone or in parallel */
        WARP_AT(&a.f.depth[round & 1], 3, 4) = NAN;
        WARP_AT(&b.f.depth[round & 1], 3, 4) = NAN;
        assert_int_equal(rt_frame_prepare(&a), DRV_FRAME_ERR_BAD_DEPTH);
        assert_int_equal(rt_frame_prepare_on(&b, w), DRV_FRAME_ERR_BAD_DEPTH);
    }
    plat_workers_destroy(w);
    rt_frame_free(&a);
    rt_frame_free(&b);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_inverse_depth_matches_reference),
        cmocka_unit_test(test_blockmax_matches_reference),
        cmocka_unit_test(test_prepare_on_workers_same),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

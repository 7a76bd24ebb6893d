/* SPDX-License-Identifier: MIT */
/* Unit tests for drv_codec_depth's upsample: drv_depth_upsample_prepare and _rows against a copy of the
 * per-pixel code the fast paths replaced (ref_upsample_prepare, ref_upsample_rows), bit for bit. An equivalence
 * test: it passed on the old code by construction; it is here so the fast paths can never drift from what the
 * per-pixel code computes. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "drivers/drv_codec_depth.h"
#include "tests/support/test_util.h"

/* ---- The reference: drv_depth_upsample_prepare and _rows as they were before the fast paths (d49a3f1),
 * unchanged but for the ref_ prefix. ---- */

static float ref_from_inverse(double q, warp_depth_encoding enc)
{
    switch (enc) {
    case WARP_DEPTH_LINEAR: return q > 0.0 ? (float)(1.0 / q) : INFINITY;
    case WARP_DEPTH_STANDARD: return (float)(1.0 - q);
    default: return (float)q;
    }
}

static double ref_inverse(float d, warp_depth_encoding enc)
{
    switch (enc) {
    case WARP_DEPTH_LINEAR: return d > 0.0f ? 1.0 / d : 0.0;
    case WARP_DEPTH_STANDARD: return 1.0 - d;
    default: return d;
    }
}

static bool ref_one_surface(const float *q, int lw, int lh, int bx, int by)
{
    float qmin = INFINITY, qmax = -INFINITY;
    for (int sy = by - 1; sy <= by + 1; sy++)
        for (int sx = bx - 1; sx <= bx + 1; sx++) {
            if (sx < 0 || sy < 0 || sx >= lw || sy >= lh) continue;
            float v = q[(size_t)sy * (size_t)lw + (size_t)sx];
            if (isnan(v)) return false;
            qmin = v < qmin ? v : qmin, qmax = v > qmax ? v : qmax;
        }
    return qmax - qmin <= (float)DRV_DEPTH_EDGE_REL * qmax;
}

static void ref_upsample_prepare(const float *lo, int lw, int lh, warp_depth_encoding enc, void *scratch)
{
    float *q = scratch;
    uint8_t *flat = (uint8_t *)(q + (size_t)lw * (size_t)lh);
    for (size_t i = 0, n = (size_t)lw * (size_t)lh; i < n; i++) q[i] = (float)ref_inverse(lo[i], enc);
    for (int by = 0; by < lh; by++)
        for (int bx = 0; bx < lw; bx++)
            flat[(size_t)by * (size_t)lw + (size_t)bx] = ref_one_surface(q, lw, lh, bx, by);
}

static int ref_colour_dist(warp_rgba8 a, warp_rgba8 b)
{
    return abs(a.r - b.r) + abs(a.g - b.g) + abs(a.b - b.b);
}

static void ref_upsample_rows(const float *lo, int lw, int lh, int scale, warp_depth_encoding enc,
                              const warp_image_rgba8 *color, float *dst, int w, int h, size_t stride, int row0,
                              int row1, const void *scratch)
{
    const int b = 1 << scale;
    const float inv_b = 1.0f / (float)b;
    const float *q = scratch;
    const uint8_t *flat = (const uint8_t *)(q + (size_t)lw * (size_t)lh);
    for (int y = row0; y < row1; y++) {
        float fy = ((float)y + 0.5f) * inv_b - 0.5f;
        int y0 = (int)floorf(fy), by = y >> scale;
        float ty = fy - (float)y0;
        int ys[2] = {y0 < 0 ? 0 : y0 >= lh ? lh - 1 : y0, y0 + 1 >= lh ? lh - 1 : y0 + 1 < 0 ? 0 : y0 + 1};
        const float *q0 = q + (size_t)ys[0] * (size_t)lw, *q1 = q + (size_t)ys[1] * (size_t)lw;
        const uint8_t *frow = flat + (size_t)by * (size_t)lw;
        float *drow = dst + (size_t)y * stride;
        for (int x = 0; x < w; x++) {
            float fx = ((float)x + 0.5f) * inv_b - 0.5f;
            int x0 = (int)floorf(fx), bx = x >> scale;
            float tx = fx - (float)x0;
            int xa = x0 < 0 ? 0 : x0 >= lw ? lw - 1 : x0, xb = x0 + 1 >= lw ? lw - 1 : x0 + 1 < 0 ? 0 : x0 + 1;
            float a = q0[xa], bq = q0[xb], c = q1[xa], d = q1[xb];
            bool one = frow[bx];
            if (!one && !color) {
                float mn = fminf(fminf(a, bq), fminf(c, d)), mx = fmaxf(fmaxf(a, bq), fmaxf(c, d));
                one = !isnan(a + bq + c + d) && mx - mn <= (float)DRV_DEPTH_EDGE_REL * mx;
            }
            if (one) {
                float s = (a + (bq - a) * tx) + ((c + (d - c) * tx) - (a + (bq - a) * tx)) * ty;
                drow[x] = ref_from_inverse(s, enc);
            } else if (!color) {
                drow[x] = lo[(size_t)ys[ty >= 0.5f] * (size_t)lw + (size_t)(tx >= 0.5f ? xb : xa)];
            } else {
                warp_rgba8 px = WARP_AT(color, x, y);
                int bd = 1 << 30;
                float best_q = INFINITY, out = lo[(size_t)by * (size_t)lw + (size_t)bx];
                static const int off[3] = {0, -1, 1};
                for (int i = 0; i < 9; i++) {
                    int sx = bx + off[i % 3], sy = by + off[i / 3];
                    if (sx < 0 || sy < 0 || sx >= lw || sy >= lh) continue;
                    int cx = sx * b + b / 2, cy = sy * b + b / 2;
                    if (cx >= w) cx = w - 1;
                    if (cy >= h) cy = h - 1;
                    size_t si = (size_t)sy * (size_t)lw + (size_t)sx;
                    int dist = ref_colour_dist(px, WARP_AT(color, cx, cy));
                    if (dist < bd || (dist == bd && q[si] < best_q)) bd = dist, best_q = q[si], out = lo[si];
                }
                drow[x] = out;
            }
        }
    }
}

/* ---- Inputs ---- */

#define PAD 5           /* dst and colour strides run past w: the padding must stay untouched */
#define SENTINEL -7.25f /* what the padding (and any pixel never written) holds */

/* Inverse depth (0 = sky) of low-resolution sample (x, y): a background slope, two foreground slabs with their
 * own slopes (depth edges), a sky band, and a few random samples and NaNs (isolated edges). */
static float scene_q(int x, int y, int lw, int lh, test_rng *r)
{
    uint64_t v = test_rng_next(r);
    if (v % 97 == 0) return NAN;
    if (v % 23 == 0) return (float)test_rng_uniform(r, 0.01, 0.9);
    if (y < lh / 5) return 0.0f;                                     /* sky */
    if (x > lw / 3 && x < lw / 2 + 2 && y > lh / 3) return 0.6f + 0.004f * (float)x - 0.002f * (float)y;
    if ((x - 2 * lw / 3) * (x - 2 * lw / 3) + (y - lh / 2) * (y - lh / 2) < lw * lh / 16)
        return 0.35f + 0.003f * (float)y;
    return 0.1f + 0.0011f * (float)x + 0.0007f * (float)y;
}

/* The sample in encoding enc: sky as the encoding stores it (+inf, 1, 0), NaN kept. */
static float encode_q(float q, warp_depth_encoding enc)
{
    if (isnan(q)) return q;
    switch (enc) {
    case WARP_DEPTH_LINEAR: return q > 0 ? 1.0f / q : INFINITY;
    case WARP_DEPTH_STANDARD: return 1.0f - q;
    default: return q;
    }
}

/* Colour blocks from a small palette (so colour distances tie) with noise on some pixels. */
static void make_colour(warp_image_rgba8 *c, int w, int h, test_rng *r)
{
    static const warp_rgba8 pal[4] = {{200, 40, 40, 255}, {40, 200, 40, 255}, {40, 40, 200, 255}, {120, 120, 120, 255}};
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            uint64_t v = test_rng_next(r);
            warp_rgba8 p = pal[((x / 3) ^ (y / 5) ^ (x * y / 37)) & 3];
            if (v % 7 == 0) p.r = (uint8_t)(v >> 8), p.g = (uint8_t)(v >> 16), p.b = (uint8_t)(v >> 24);
            WARP_AT(c, x, y) = p;
        }
}

/* Blocks seen, and of them flat ones (one surface): both paths must be exercised. */
static size_t blocks_seen, blocks_flat;

/* One size, scale, encoding and colour choice: the reference over all rows against drv_depth_upsample (one call)
 * and drv_depth_upsample_rows in uneven bands, every float of dst compared as bits (padding included). */
static void check_case(int w, int h, int scale, warp_depth_encoding enc, bool with_colour, uint64_t seed)
{
    test_rng r = test_rng_make(seed);
    int lw = drv_depth_scaled(w, scale), lh = drv_depth_scaled(h, scale);
    size_t stride = (size_t)w + PAD, n = stride * (size_t)h;
    float *lo = malloc(sizeof(float) * (size_t)lw * (size_t)lh);
    size_t scratch_bytes = drv_depth_upsample_scratch(lw, lh);
    void *scratch = malloc(scratch_bytes), *ref_scratch = malloc(scratch_bytes);
    float *want = malloc(sizeof(float) * n), *got = malloc(sizeof(float) * n);
    warp_image_rgba8 col = {w, h, w + PAD, malloc(sizeof(warp_rgba8) * (size_t)(w + PAD) * (size_t)h)};
    assert_true(lo && scratch && ref_scratch && want && got && col.px);
    for (int y = 0; y < lh; y++)
        for (int x = 0; x < lw; x++) lo[(size_t)y * (size_t)lw + (size_t)x] = encode_q(scene_q(x, y, lw, lh, &r), enc);
    make_colour(&col, w, h, &r);
    const warp_image_rgba8 *cp = with_colour ? &col : NULL;

    for (size_t i = 0; i < n; i++) want[i] = SENTINEL;
    /* prepare's inverse depths and flat flags, byte for byte */
    ref_upsample_prepare(lo, lw, lh, enc, ref_scratch);
    drv_depth_upsample_prepare(lo, lw, lh, enc, scratch);
    for (size_t i = 0; i < scratch_bytes; i++)
        if (((const uint8_t *)scratch)[i] != ((const uint8_t *)ref_scratch)[i])
            fail_msg("%dx%d scale %d enc %d: prepare's scratch differs at byte %zu of %zu", w, h, scale, (int)enc, i,
                     scratch_bytes);
    ref_upsample_rows(lo, lw, lh, scale, enc, cp, want, w, h, stride, 0, h, ref_scratch);
    for (size_t i = 0, nb = (size_t)lw * (size_t)lh; i < nb; i++)
        blocks_flat += ((const uint8_t *)ref_scratch)[sizeof(float) * nb + i], blocks_seen++;

    for (int mode = 0; mode < 3; mode++) {
        for (size_t i = 0; i < n; i++) got[i] = SENTINEL;
        if (mode == 0) {
            drv_depth_upsample(lo, lw, lh, scale, enc, cp, got, w, h, stride, scratch);
        } else {
            /* bands of 1..7 rows (mode 1) or three uneven bands (mode 2), in reverse order */
            int cuts[64], nc = 0, y = h;
            while (y > 0 && nc < 62) {
                cuts[nc++] = y;
                y -= mode == 1 ? 1 + (int)(test_rng_next(&r) % 7) : (h + 2) / 3 + (int)(test_rng_next(&r) % 3);
            }
            cuts[nc++] = 0;
            for (int i = 0; i + 1 < nc; i++) /* the last band takes whatever the 62 cuts left */
                drv_depth_upsample_rows(lo, lw, lh, scale, enc, cp, got, w, h, stride, cuts[i + 1], cuts[i], scratch);
        }
        for (size_t i = 0; i < n; i++)
            if (memcmp(&want[i], &got[i], sizeof(float)))
                fail_msg("%dx%d scale %d enc %d colour %d mode %d: (%zu,%zu) got %a, want %a", w, h, scale, (int)enc,
                         with_colour, mode, i % stride, i / stride, (double)got[i], (double)want[i]);
    }
    free(lo), free(scratch), free(ref_scratch), free(want), free(got), free(col.px);
}

/* Sizes that are and are not multiples of the block, single rows and columns, and widths past several of the fast
 * path's column tiles; scales 0 (a copy through the same code), 1 and 2; every encoding; colour off and on. */
static void test_upsample_bit_identical(void **state)
{
    (void)state;
    static const int sizes[][2] = {{1, 1}, {2, 3}, {5, 4}, {7, 9}, {16, 16}, {37, 23}, {64, 48},
                                   {3, 40}, {129, 5}, {300, 17}, {613, 11}, {1031, 6}};
    uint64_t seed = 1;
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++)
        for (int scale = 0; scale <= 2; scale++)
            for (int enc = WARP_DEPTH_LINEAR; enc <= WARP_DEPTH_REVERSED; enc++)
                for (int c = 0; c < 2; c++)
                    check_case(sizes[s][0], sizes[s][1], scale, (warp_depth_encoding)enc, c, seed++);
    print_message("%zu of %zu blocks flat\n", blocks_flat, blocks_seen);
    assert_true(blocks_flat > blocks_seen / 4 && blocks_flat < blocks_seen * 3 / 4);
}

/* The framelink eye size at half resolution (the case the fast path is for), once per encoding. */
static void test_upsample_bit_identical_eye(void **state)
{
    (void)state;
    for (int enc = WARP_DEPTH_LINEAR; enc <= WARP_DEPTH_REVERSED; enc++)
        check_case(360, 400, enc == WARP_DEPTH_STANDARD ? 2 : 1, (warp_depth_encoding)enc, enc != WARP_DEPTH_REVERSED,
                   100 + (uint64_t)enc);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_upsample_bit_identical),
        cmocka_unit_test(test_upsample_bit_identical_eye),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

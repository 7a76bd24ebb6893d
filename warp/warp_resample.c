/* SPDX-License-Identifier: MIT */
/* warp_resample: the CPU resampler of the display path: per-channel bilinear sampling through a distortion mesh,
 * in fixed point from planar 8-bit sources, tile by tile; portable, AVX2 and AVX-512 kernels, bit-identical. */
#include "warp/warp_resample.h"

#include <stdlib.h>
#include <string.h>

#include "warp/warp_v4.h"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define HAVE_X86_KERNELS 1
#endif

/* The maths every kernel follows, so that they agree bit for bit (the build disables FMA contraction, which
 * would let the compiler fuse the scalar multiply-adds but not the intrinsics):
 *  1. Per output row, each mesh cell's six source coordinates (x and y of R, G, B) are lines in the pixel's
 *     offset xl = x + 0.5 - i * cell_w from the cell's left edge: f = p + q * xl in float, p and q interpolated
 *     between the cell band's edges once per row (row_table_build). f is in 1/64 source pixel with the centre
 *     shift and a rounding bias folded in (warp_mesh.h), so
 *  2. a = (int)f, clamped to [0, 64 (w - 1)] (resp. h: fringe fill), is the position rounded to the nearest
 *     1/64 pixel; the taps are at (a >> 6, a >> 6 + 1), the weight is a & 63. The mesh keeps positions within
 *     +-65536 pixels, so |f| < 2^27 and the conversion never overflows.
 *  3. Bilinear in integers with 6-bit weights, the vertical pass first (it matches the row-pair layout):
 *     l = p00 (64 - wy) + p10 wy, r = p01 (64 - wy) + p11 wy, out = (l (64 - wx) + r wx + 2048) >> 12.
 *     In SIMD that is one pmaddubsw and one pmaddwd; nothing overflows (l, r <= 16320).
 * A pixel's result depends only on its position, never on where the rectangle being resampled starts. */

bool warp_planar3_alloc(warp_planar3 *p, int w, int h)
{
    memset(p, 0, sizeof *p);
    if (w <= 0 || h <= 0 || w > WARP_MAX_SIDE || h > WARP_MAX_SIDE) return false;
    /* +2 elements so a 4-byte load at the last column stays in the row; rows padded to 64 bytes; one row more
     * (the kernels read the row-pair below the last, never using it) and 32 elements more so a 64-byte window
     * starting at any column of that row stays in the plane. */
    int stride = (w + 2 + 31) / 32 * 32;
    size_t plane = (size_t)stride * (size_t)(h + 1) + 32;
    p->mem = aligned_alloc(64, plane * 3 * sizeof(uint16_t));
    if (!p->mem) return false;
    memset(p->mem, 0, plane * 3 * sizeof(uint16_t));
    for (int c = 0; c < 3; c++) p->plane[c] = (uint16_t *)p->mem + plane * (size_t)c;
    p->w = w;
    p->h = h;
    p->stride = stride;
    return true;
}

void warp_planar3_free(warp_planar3 *p)
{
    free(p->mem);
    memset(p, 0, sizeof *p);
}

void warp_planar3_from_rgba_rows(warp_planar3 *p, const warp_image_rgba8 *src, int y0, int y1)
{
    for (int y = y0; y < y1; y++) {
        /* the last row pairs with itself: sampling clamps there anyway */
        const warp_rgba8 *s0 = &WARP_AT(src, 0, y), *s1 = &WARP_AT(src, 0, y + 1 < src->h ? y + 1 : y);
        uint16_t *r = p->plane[0] + (size_t)y * p->stride, *g = p->plane[1] + (size_t)y * p->stride,
                 *b = p->plane[2] + (size_t)y * p->stride;
        int x = 0;
#if __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
        for (; x + 4 <= p->w; x += 4) {
            /* four pixels of each row as 32-bit words, r | g << 8 | b << 16 | a << 24 (warp_rgba8's byte order
             * read little-endian; other byte orders take the loop below) */
            warp_v4u a, c;
            memcpy(&a, s0 + x, sizeof a), memcpy(&c, s1 + x, sizeof c);
            const warp_v4h vr = __builtin_convertvector((a & 0xff) | (c & 0xff) << 8, warp_v4h);
            const warp_v4h vg = __builtin_convertvector((a >> 8 & 0xff) | (c & 0xff00), warp_v4h);
            const warp_v4h vb = __builtin_convertvector((a >> 16 & 0xff) | (c >> 8 & 0xff00), warp_v4h);
            memcpy(r + x, &vr, sizeof vr), memcpy(g + x, &vg, sizeof vg), memcpy(b + x, &vb, sizeof vb);
        }
#endif
        for (; x < p->w; x++) {
            r[x] = (uint16_t)(s0[x].r | s1[x].r << 8);
            g[x] = (uint16_t)(s0[x].g | s1[x].g << 8);
            b[x] = (uint16_t)(s0[x].b | s1[x].b << 8);
        }
        /* the element right of the last column repeats it, so x + 1 taps at the border read real data */
        r[p->w] = r[p->w - 1];
        g[p->w] = g[p->w - 1];
        b[p->w] = b[p->w - 1];
    }
}

/* Cells per strip: a row's line table lives on the stack, so wider rectangles are done in strips this wide. */
#define STRIP_CELLS 64

/* One output row's lines for the cells [first, first + STRIP_CELLS) (step 1 above); +8 for the 8-wide build. */
typedef struct {
    float v[WARP_MESH_LINE_VALUES][STRIP_CELLS + 8];
    int first;
} row_table;

#define LV(t, c, a, pq, ci) ((t)->v[WARP_MESH_LINE(c, a, pq)][ci])

/* Eight floats: plain C with GCC/clang vector extensions, which become SSE, AVX or NEON as the target has them.
 * Element-wise IEEE operations round like their scalar counterparts. */
typedef float v8f __attribute__((vector_size(32)));

/* Inlined into a plain and an AVX2 build of the same loop (row_table_build, row_table_build_avx2). */
__attribute__((always_inline)) static inline void row_table_build_inline(row_table *t, const warp_mesh *m, int y, int ia,
                                                                         int ib)
{
    const double gy = ((double)y + 0.5) * (m->rows - 1) / m->vp_h;
    int j = (int)gy;
    if (j > m->rows - 2) j = m->rows - 2;
    const float ty = (float)(gy - j);
    const size_t ls = (size_t)m->line_stride;
    const float *top = m->lines + (size_t)j * 2 * WARP_MESH_LINE_VALUES * ls, *chg = top + WARP_MESH_LINE_VALUES * ls;
    /* reads and writes up to 7 cells past ib: line_stride and the table have room for that */
    for (int k = 0; k < WARP_MESH_LINE_VALUES; k++)
        for (int i = ia; i <= ib; i += 8) {
            v8f a, b;
            memcpy(&a, top + k * ls + i, sizeof a);
            memcpy(&b, chg + k * ls + i, sizeof b);
            a = a + b * ty;
            memcpy(&t->v[k][i - ia], &a, sizeof a);
        }
    t->first = ia;
}

typedef void row_build_fn(row_table *t, const warp_mesh *m, int y, int ia, int ib);

static void row_table_build(row_table *t, const warp_mesh *m, int y, int ia, int ib)
{
    row_table_build_inline(t, m, y, ia, ib);
}

/* The four taps of one channel at element index i (see warp_planar3). */
static inline uint32_t load_u32(const uint16_t *p)
{
    uint32_t v;
    memcpy(&v, p, 4);
    return v;
}

/* Step 3 from the 32-bit tap word v = p00 | p10 << 8 | p01 << 16 | p11 << 24 (see warp_planar3). */
static inline uint32_t bilinear6(uint32_t v, uint32_t wx, uint32_t wy)
{
    uint32_t p00 = v & 255, p10 = v >> 8 & 255, p01 = v >> 16 & 255, p11 = v >> 24;
    uint32_t l = p00 * (64 - wy) + p10 * wy, r = p01 * (64 - wy) + p11 * wy;
    return (l * (64 - wx) + r * wx + 2048) >> 12;
}

/* Step 2 for one coordinate (the conversion is defined: |f| < 2^27, see above). */
static inline uint32_t fixed_pos(float f, int max)
{
    const int a = (int)f;
    return (uint32_t)(a < 0 ? 0 : (a > max ? max : a));
}

/* Pixels [x0, x1) of one row (viewport x), written to row[x]. */
static void kernel_scalar(const warp_planar3 *s, const warp_mesh *m, const row_table *t, int x0, int x1,
                          warp_rgba8 *row)
{
    const int maxx = 64 * (s->w - 1), maxy = 64 * (s->h - 1);
    const int cw = m->cell_w;
    int ci = x0 / cw, edge = (ci + 1) * cw;
    for (int x = x0; x < x1; x++) {
        if (x >= edge) {
            ci++;
            edge += cw;
        }
        const int k = ci - t->first;
        const float xl = (float)(x - ci * cw) + 0.5f;
        uint32_t v[3];
        for (int c = 0; c < 3; c++) {
            const uint32_t ax = fixed_pos(LV(t, c, 0, 0, k) + LV(t, c, 0, 1, k) * xl, maxx);
            const uint32_t ay = fixed_pos(LV(t, c, 1, 0, k) + LV(t, c, 1, 1, k) * xl, maxy);
            uint32_t taps;
            memcpy(&taps, s->plane[c] + (size_t)(ay >> 6) * (size_t)s->stride + (ax >> 6), 4);
            v[c] = bilinear6(taps, ax & 63, ay & 63);
        }
        row[x] = (warp_rgba8){(uint8_t)v[0], (uint8_t)v[1], (uint8_t)v[2], 255};
    }
}

/* Prefetch distance in row pairs: the hardware prefetchers miss the source lines of the next output rows in
 * 128-pixel-wide tiles. Fetching them three row pairs ahead took 7 % off at 1440x1600 on one thread and 20 % on
 * two (whose misses compete for the shared cache), measured with the AVX-512 kernel on a Zen 5. On a Zen 3 the
 * AVX2 kernel loses a third of its speed without the prefetch, and fetching 12 row pairs ahead instead of 3
 * took another 11 % off on one thread and 6 % on two (6 to 16 were alike; taller tiles did not help); the
 * portable kernel, which had no prefetch, got 21 % faster on one thread and 26 % on two with it there (as SSE;
 * not yet measured as NEON on a board). On a 2-core EPYC with AVX-512 (a VM, 1 MB L2 per core) the AVX-512
 * kernel at 3 row pairs was 17 % slower at 1440x1600 than at 12 (one eye on one thread 4.9 against 4.1 ms, both
 * eyes on two 10.3 against 8.6), and 20 to 32 were within the noise of 12; at 720x800 (whose source stays in
 * the caches) all were alike: it uses the far distance too. */
#define PREFETCH_ROWS_FAR 12

/* The portable SIMD kernel: 4-pixel groups in GCC/clang vector extensions, the width of NEON on the aarch64
 * board (and of SSE2), with one scalar load per lane and channel for the taps. C has no vector ?:, so
 * selections are masks: a comparison gives -1 in the lanes where it holds. */
typedef float v4f __attribute__((vector_size(16)));
typedef int32_t v4i __attribute__((vector_size(16)));
typedef uint32_t v4u __attribute__((vector_size(16)));

static inline v4i vsel(v4i m, v4i a, v4i b) { return (a & m) | (b & ~m); }

/* Step 2 for 4 lanes, exactly as fixed_pos(). */
static inline v4u vec_fixed_pos(v4f f, int max)
{
    v4i a = __builtin_convertvector(f, v4i);
    a = a & ~(a < 0);
    return (v4u)vsel(a > max, (v4i){0} + max, a);
}

static void kernel_vector(const warp_planar3 *s, const warp_mesh *m, const row_table *t, int x0, int x1,
                          warp_rgba8 *row)
{
    const int maxx = 64 * (s->w - 1), maxy = 64 * (s->h - 1);
    const v4f lane = {0.5f, 1.5f, 2.5f, 3.5f};
    const int cw = m->cell_w;
    /* groups aligned to the viewport, each inside one cell */
    int gx = x0 & ~3, ci = gx / cw, edge = (ci + 1) * cw;
    for (; gx < x1; gx += 4) {
        if (gx >= edge) {
            ci++;
            edge += cw;
        }
        const int k = ci - t->first;
        const v4f xl = lane + (float)(gx - ci * cw);
        v4u px = (v4u){0} + 0xff000000u;
        for (int c = 0; c < 3; c++) {
            const v4u ax = vec_fixed_pos(LV(t, c, 0, 0, k) + LV(t, c, 0, 1, k) * xl, maxx);
            const v4u ay = vec_fixed_pos(LV(t, c, 1, 0, k) + LV(t, c, 1, 1, k) * xl, maxy);
            const v4u idx = (ay >> 6) * (uint32_t)s->stride + (ax >> 6);
            const uint16_t *pl = s->plane[c];
            const uint32_t pf = (uint32_t)s->stride * PREFETCH_ROWS_FAR;
            if (idx[0] < (uint32_t)s->stride * (uint32_t)s->h - pf) __builtin_prefetch(pl + idx[0] + pf);
            const v4u v = {load_u32(pl + idx[0]), load_u32(pl + idx[1]), load_u32(pl + idx[2]), load_u32(pl + idx[3])};
            const v4u wx = ax & 63, wy = ay & 63;
            const v4u l = (v & 255) * (64 - wy) + (v >> 8 & 255) * wy, r = (v >> 16 & 255) * (64 - wy) + (v >> 24) * wy;
            px |= ((l * (64 - wx) + r * wx + 2048) >> 12) << (8 * c);
        }
        if (gx >= x0 && gx + 4 <= x1) {
            memcpy(&row[gx], &px, sizeof px);
        } else {
            for (int l = 0; l < 4; l++) {
                const uint32_t p = px[l];
                if (gx + l >= x0 && gx + l < x1) memcpy(&row[gx + l], &p, 4);
            }
        }
    }
}

#ifdef HAVE_X86_KERNELS

#define AVX2 __attribute__((target("avx2")))

/* The same row build compiled for AVX2: one instruction per 8 floats instead of two. */
AVX2 static void row_table_build_avx2(row_table *t, const warp_mesh *m, int y, int ia, int ib)
{
    row_table_build_inline(t, m, y, ia, ib);
}

/* Constants of the AVX2 kernel. */
typedef struct {
    __m256i maxx, maxy, stride_mul, by, sy, c64b, bx, sx, c64w, m63;
} avx2_ctx;

/* Steps 2 and 3 for 8 lanes of one channel. Three changes together took 12 % off at 1440x1600 on a Zen 3: the
 * address by one pmaddwd instead of a mullo and an add, the weights by pshufb and psign instead of multiplies,
 * and the channels unrolled in the caller. Dropping the clamps, tried for comparison, gained nothing. */
AVX2 __attribute__((always_inline)) static inline __m256i avx2_sample(const avx2_ctx *k, const warp_planar3 *s, int c,
                                                                     __m256 fx, __m256 fy)
{
    const __m256i zero = _mm256_setzero_si256();
    const __m256i ax = _mm256_min_epi32(_mm256_max_epi32(_mm256_cvttps_epi32(fx), zero), k->maxx);
    const __m256i ay = _mm256_min_epi32(_mm256_max_epi32(_mm256_cvttps_epi32(fy), zero), k->maxy);
    /* tap column and row as the two words of a dword (both < 2^14), then row * stride + column */
    const __m256i pos = _mm256_blend_epi16(_mm256_srli_epi32(ax, 6), _mm256_slli_epi32(ay, 10), 0xaa);
    const __m256i idx = _mm256_madd_epi16(pos, k->stride_mul);
    const int i0 = _mm_cvtsi128_si32(_mm256_castsi256_si128(idx)), pf = s->stride * PREFETCH_ROWS_FAR;
    if (i0 < s->stride * s->h - pf) _mm_prefetch((const char *)(s->plane[c] + i0 + pf), _MM_HINT_T0);
    /* vpgatherdd: on the Zen 5 measured it beat eight scalar loads put together through memory 1.8 : 1 in this
     * kernel (the vector load spanning the scalar stores cannot be store-forwarded and stalls) */
    const __m256i v = _mm256_i32gather_epi32((const int *)(const void *)s->plane[c], idx, 2);
    /* bytes (64 - wy, wy) twice per lane: wy in every byte, negated in the even ones, plus (64, 0) */
    const __m256i ty = _mm256_and_si256(_mm256_shuffle_epi8(ay, k->by), k->m63);
    const __m256i wy = _mm256_add_epi8(_mm256_sign_epi8(ty, k->sy), k->c64b);
    /* words (64 - wx, wx) likewise */
    const __m256i tx = _mm256_and_si256(_mm256_shuffle_epi8(ax, k->bx), k->m63);
    const __m256i wx = _mm256_add_epi16(_mm256_sign_epi16(tx, k->sx), k->c64w);
    const __m256i r = _mm256_madd_epi16(_mm256_maddubs_epi16(v, wy), wx);
    return _mm256_srli_epi32(_mm256_add_epi32(r, _mm256_set1_epi32(2048)), 12);
}

AVX2 static void kernel_avx2(const warp_planar3 *s, const warp_mesh *m, const row_table *t, int x0, int x1,
                             warp_rgba8 *row)
{
    avx2_ctx k;
    k.maxx = _mm256_set1_epi32(64 * (s->w - 1));
    k.maxy = _mm256_set1_epi32(64 * (s->h - 1));
    k.stride_mul = _mm256_set1_epi32(s->stride << 16 | 1); /* stride < 2^15 */
    /* pshufb indexes within 16-byte lanes: byte 0 of each dword is at 0, 4, 8, 12 (0x80: a zero byte) */
    k.by = _mm256_broadcastsi128_si256(_mm_setr_epi32(0, 0x04040404, 0x08080808, 0x0c0c0c0c));
    k.sy = _mm256_set1_epi16(0x01ff); /* bytes -1, 1 */
    k.c64b = _mm256_set1_epi16(0x0040);
    k.bx = _mm256_broadcastsi128_si256(
        _mm_setr_epi32((int)0x80008000u, (int)0x80048004u, (int)0x80088008u, (int)0x800c800cu));
    k.sx = _mm256_set1_epi32(0x0001ffff); /* words -1, 1 */
    k.c64w = _mm256_set1_epi32(64);
    k.m63 = _mm256_set1_epi8(63);
    const __m256 lane = _mm256_setr_ps(0.5f, 1.5f, 2.5f, 3.5f, 4.5f, 5.5f, 6.5f, 7.5f);
    const __m256i alpha = _mm256_set1_epi32((int)0xff000000u), lane_i = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    const int cw = m->cell_w;
    /* 8-pixel groups aligned to the viewport, each inside one cell; the first and last may be partial */
    int gx = x0 & ~7, ci = gx / cw, edge = (ci + 1) * cw;
    for (; gx < x1; gx += 8) {
        if (gx >= edge) {
            ci++;
            edge += cw;
        }
        const int kc = ci - t->first;
        const __m256 xl = _mm256_add_ps(_mm256_set1_ps((float)(gx - ci * cw)), lane);
#define LINE(c, a) _mm256_add_ps(_mm256_set1_ps(LV(t, c, a, 0, kc)), _mm256_mul_ps(_mm256_set1_ps(LV(t, c, a, 1, kc)), xl))
#define CHANNEL(c) avx2_sample(&k, s, c, LINE(c, 0), LINE(c, 1))
        const __m256i r = CHANNEL(0), g = CHANNEL(1), b = CHANNEL(2);
#undef CHANNEL
#undef LINE
        const __m256i px = _mm256_or_si256(_mm256_or_si256(r, _mm256_slli_epi32(g, 8)),
                                           _mm256_or_si256(_mm256_slli_epi32(b, 16), alpha));
        if (gx >= x0 && gx + 8 <= x1) {
            _mm256_storeu_si256((__m256i *)(void *)&row[gx], px);
        } else {
            /* lanes gx + l in [x0, x1) */
            const __m256i l = _mm256_add_epi32(lane_i, _mm256_set1_epi32(gx));
            const __m256i mask = _mm256_andnot_si256(_mm256_cmpgt_epi32(_mm256_set1_epi32(x0), l),
                                                     _mm256_cmpgt_epi32(_mm256_set1_epi32(x1), l));
            _mm256_maskstore_epi32((int *)(void *)&row[gx], mask, px);
        }
    }
}

#define AVX512 __attribute__((target("avx512f,avx512bw")))
#define AVX512_INLINE __attribute__((target("avx512f,avx512bw"), always_inline))

/* Constants and position of the AVX-512 kernel within one row. */
typedef struct {
    __m512 lane;
    __m512i halves, lim, maxx, maxy, e_mul, by, bx, m63, c64b, c64w, stride_mul;
    const warp_planar3 *s;
    const row_table *t;
    int cw, ia, ib, x0, x1;
    int ci, edge; /* cell of the last group, and its right edge */
} a512_ctx;

/* One channel's positions for 16 lanes (steps 1 and 2) and where to fetch their taps. */
typedef struct {
    __m512i ax, ay;
    __m512i pos;         /* tap column and row as the two words of a dword (both < 2^14) */
    __m512i d;           /* pos less the window's origin, word by word */
    const uint16_t *win; /* the window's origin */
    bool window;         /* all needed lanes' taps are in the window */
} a512_pos;

/* need32 has two bits per lane that will be stored. */
AVX512_INLINE static inline void a512_position(const a512_ctx *k, int c, __m512i sel, int ck, __m512 xl,
                                               __mmask32 need32, a512_pos *p)
{
    const row_table *t = k->t;
    const warp_planar3 *s = k->s;
    /* p and q of the two halves' cells (c1 is c0 or c0 + 1), by 8-byte loads because the row table was just
     * written, and a load inside one earlier store is forwarded, while a 64-byte load across several waits for
     * them to reach the cache */
#define CELLS2(a, pq)                                                                                                  \
    _mm512_permutexvar_ps(                                                                                             \
        sel, _mm512_castps128_ps512(_mm_castsi128_ps(_mm_loadl_epi64((const __m128i *)(const void *)&LV(t, c, a, pq, ck)))))
    const __m512 fx = _mm512_add_ps(CELLS2(0, 0), _mm512_mul_ps(CELLS2(0, 1), xl));
    const __m512 fy = _mm512_add_ps(CELLS2(1, 0), _mm512_mul_ps(CELLS2(1, 1), xl));
#undef CELLS2
    const __m512i zero = _mm512_setzero_si512();
    p->ax = _mm512_min_epi32(_mm512_max_epi32(_mm512_cvttps_epi32(fx), zero), k->maxx);
    p->ay = _mm512_min_epi32(_mm512_max_epi32(_mm512_cvttps_epi32(fy), zero), k->maxy);
    p->pos = _mm512_mask_blend_epi16(0xaaaaaaaa, _mm512_srli_epi32(p->ax, 6), _mm512_slli_epi32(p->ay, 10));
    /* Window: when every needed lane's taps lie in columns [xb, xb + 31] of the row pairs yb and yb + 1, two
     * 64-byte loads and one vpermi2w fetch all 16 lanes' taps. The window starts at the smaller column and row of
     * the first and last lanes (positions are linear across each 8-lane half, so that is nearly always the
     * minimum). Steep mappings (the outer parts of a strong lens) fail the test and are gathered. */
    const __m512i org = _mm512_min_epu16(p->pos, _mm512_alignr_epi32(p->pos, p->pos, 15));
    p->d = _mm512_sub_epi16(p->pos, _mm512_broadcastd_epi32(_mm512_castsi512_si128(org)));
    p->window = !_mm512_mask_cmpgt_epu16_mask(need32, p->d, k->lim);
    const uint32_t o = (uint32_t)_mm_cvtsi128_si32(_mm512_castsi512_si128(org));
    const int yb = (int)(o >> 16), xb = (int)(o & 0xffff);
    p->win = s->plane[c] + (size_t)yb * (size_t)s->stride + (size_t)xb;
    const int ypf = yb + PREFETCH_ROWS_FAR < s->h ? yb + PREFETCH_ROWS_FAR : s->h;
    const char *pf = (const char *)(s->plane[c] + (size_t)ypf * (size_t)s->stride + (size_t)xb);
    _mm_prefetch(pf, _MM_HINT_T0);
    _mm_prefetch(pf + 63, _MM_HINT_T0);
}

/* The taps through the window: words e and e + 1 of the 64-word table (row pair yb, row pair yb + 1), where
 * e = dx + 32 dy; the plane's padding keeps both loads inside it. */
AVX512_INLINE static inline __m512i a512_window(const a512_ctx *k, const a512_pos *p)
{
    const __m512i e = _mm512_madd_epi16(p->d, k->e_mul);
    const __m512i sel = _mm512_add_epi32(_mm512_slli_epi32(e, 16), _mm512_add_epi32(e, _mm512_set1_epi32(0x10000)));
    return _mm512_permutex2var_epi16(_mm512_loadu_si512(p->win), sel, _mm512_loadu_si512(p->win + k->s->stride));
}

/* The taps by vpgatherdd, which beat scalar loads put together through memory here, as in the AVX2 kernel. */
AVX512_INLINE static inline __m512i a512_gather(const a512_ctx *k, int c, const a512_pos *p)
{
    return _mm512_i32gather_epi32(_mm512_madd_epi16(p->pos, k->stride_mul), (const void *)k->s->plane[c], 2);
}

/* Step 3, weights from the low bytes of ay and ax: bytes (64 - wy, wy) twice per lane, words (64 - wx, wx). */
AVX512_INLINE static inline __m512i a512_bilinear(const a512_ctx *k, const a512_pos *p, __m512i v)
{
    const __m512i ty = _mm512_and_si512(_mm512_shuffle_epi8(p->ay, k->by), k->m63);
    const __m512i wy = _mm512_mask_sub_epi8(ty, 0x5555555555555555ull, k->c64b, ty);
    const __m512i tx = _mm512_and_si512(_mm512_shuffle_epi8(p->ax, k->bx), k->m63);
    const __m512i wx = _mm512_mask_sub_epi16(tx, 0x55555555, k->c64w, tx);
    const __m512i r = _mm512_madd_epi16(_mm512_maddubs_epi16(v, wy), wx);
    return _mm512_srli_epi32(_mm512_add_epi32(r, _mm512_set1_epi32(2048)), 12);
}

/* One 16-pixel group at gx (a multiple of 16; each 8-pixel half lies inside one cell). */
AVX512 static inline void a512_group(a512_ctx *k, int gx, warp_rgba8 *row)
{
    const int cw = k->cw;
    while (gx >= k->edge) {
        k->ci++;
        k->edge += cw;
    }
    /* Cells of the two halves. A half outside [ia, ib] lies wholly outside [x0, x1): any cell will do. */
    int c0 = k->ci < k->ia ? k->ia : k->ci, c1 = gx + 8 >= k->edge ? k->ci + 1 : k->ci;
    if (c1 > k->ib) c1 = k->ib;
    if (c1 < k->ia) c1 = k->ia;
    /* lanes to store, and the same with two bits per lane */
    __mmask16 need = 0xffff;
    __mmask32 need32 = 0xffffffff;
    if (gx < k->x0) {
        need = (__mmask16)(need << (k->x0 - gx));
        need32 = need32 << 2 * (k->x0 - gx);
    }
    if (gx + 16 > k->x1) {
        need = (__mmask16)(need & (0xffffu >> (gx + 16 - k->x1)));
        need32 = need32 & (0xffffffffu >> 2 * (gx + 16 - k->x1));
    }
    const __m512 xl = _mm512_add_ps(_mm512_mask_blend_ps(0xff00, _mm512_set1_ps((float)(gx - c0 * cw)),
                                                         _mm512_set1_ps((float)(gx + 8 - c1 * cw))),
                                    k->lane);
    const __m512i sel = c1 == c0 ? _mm512_setzero_si512() : k->halves;
    const int ck = c0 - k->ia;
    /* All three channels' positions first, then one branch for the group: windows for all three, or gathers.
     * The channels nearly always agree, and one branch mispredicts far less often than three (15 % faster). */
    a512_pos p0, p1, p2;
    a512_position(k, 0, sel, ck, xl, need32, &p0);
    a512_position(k, 1, sel, ck, xl, need32, &p1);
    a512_position(k, 2, sel, ck, xl, need32, &p2);
    __m512i v0, v1, v2;
    if (p0.window & p1.window & p2.window) {
        v0 = a512_window(k, &p0);
        v1 = a512_window(k, &p1);
        v2 = a512_window(k, &p2);
    } else {
        v0 = a512_gather(k, 0, &p0);
        v1 = a512_gather(k, 1, &p1);
        v2 = a512_gather(k, 2, &p2);
    }
    const __m512i px =
        _mm512_or_si512(_mm512_or_si512(a512_bilinear(k, &p0, v0), _mm512_slli_epi32(a512_bilinear(k, &p1, v1), 8)),
                        _mm512_or_si512(_mm512_slli_epi32(a512_bilinear(k, &p2, v2), 16), _mm512_set1_epi32((int)0xff000000u)));
    if (need == 0xffff)
        _mm512_storeu_si512(&row[gx], px);
    else
        _mm512_mask_storeu_epi32(&row[gx], need, px);
}

AVX512 static void kernel_avx512(const warp_planar3 *s, const warp_mesh *m, const row_table *t, int x0, int x1,
                                 warp_rgba8 *row)
{
    a512_ctx k;
    k.lane = _mm512_setr_ps(0.5f, 1.5f, 2.5f, 3.5f, 4.5f, 5.5f, 6.5f, 7.5f, 0.5f, 1.5f, 2.5f, 3.5f, 4.5f, 5.5f, 6.5f,
                            7.5f);
    /* picks element 0 for the low 8 lanes and element 1 for the high 8 */
    k.halves = _mm512_setr_epi32(0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1);
    k.lim = _mm512_set1_epi32(0x0001001e); /* dx <= 30, dy <= 1 */
    k.maxx = _mm512_set1_epi32(64 * (s->w - 1));
    k.maxy = _mm512_set1_epi32(64 * (s->h - 1));
    k.e_mul = _mm512_set1_epi32(0x00200001);
    /* pshufb indexes within 16-byte lanes: byte 0 of each dword is at 0, 4, 8, 12 */
    k.by = _mm512_broadcast_i32x4(_mm_setr_epi32(0, 0x04040404, 0x08080808, 0x0c0c0c0c));
    k.bx = _mm512_broadcast_i32x4(
        _mm_setr_epi32((int)0x80008000u, (int)0x80048004u, (int)0x80088008u, (int)0x800c800cu));
    k.m63 = _mm512_set1_epi8(63);
    k.c64b = _mm512_set1_epi8(64);
    k.c64w = _mm512_set1_epi16(64);
    k.stride_mul = _mm512_set1_epi32(s->stride << 16 | 1); /* stride < 2^15 */
    k.s = s;
    k.t = t;
    k.cw = m->cell_w;
    k.ia = t->first;
    k.ib = (x1 - 1) / m->cell_w;
    k.x0 = x0;
    k.x1 = x1;
    int gx = x0 & ~15;
    k.ci = gx / k.cw;
    k.edge = (k.ci + 1) * k.cw;
    for (; gx < x1; gx += 16) a512_group(&k, gx, row);
}
#endif

static warp_resample_kernel_id forced, auto_choice;

bool warp_resample_kernel_available(warp_resample_kernel_id k)
{
    switch (k) {
    case WARP_RESAMPLE_AUTO:
    case WARP_RESAMPLE_SCALAR:
    case WARP_RESAMPLE_VECTOR:
        return true;
#ifdef HAVE_X86_KERNELS
    case WARP_RESAMPLE_AVX2:
        return __builtin_cpu_supports("avx2");
    case WARP_RESAMPLE_AVX512:
        return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw");
#endif
    default:
        return false;
    }
}

bool warp_resample_force_kernel(warp_resample_kernel_id k)
{
    if (!warp_resample_kernel_available(k)) return false;
    forced = k;
    return true;
}

warp_resample_kernel_id warp_resample_forced_kernel(void) { return forced; }

void warp_resample_force_scalar(bool force) { forced = force ? WARP_RESAMPLE_SCALAR : WARP_RESAMPLE_AUTO; }

warp_resample_kernel_id warp_resample_kernel_widest(void)
{
    for (int k = WARP_RESAMPLE_KERNELS - 1; k > WARP_RESAMPLE_VECTOR; k--)
        if (warp_resample_kernel_available((warp_resample_kernel_id)k)) return (warp_resample_kernel_id)k;
    return WARP_RESAMPLE_VECTOR;
}

warp_resample_kernel_id warp_resample_kernel_pick(const double ms[WARP_RESAMPLE_KERNELS],
                                                  const bool usable[WARP_RESAMPLE_KERNELS])
{
    double best = 0;
    for (int k = WARP_RESAMPLE_SCALAR; k < WARP_RESAMPLE_KERNELS; k++)
        if (usable[k] && ms[k] > 0 && (best == 0 || ms[k] < best)) best = ms[k]; /* NaN compares false */
    if (best == 0) return warp_resample_kernel_widest();
    /* one pass from the narrowest: the first within the tie margin of the fastest (not pairwise, which would
     * not be transitive) */
    for (int k = WARP_RESAMPLE_SCALAR; k < WARP_RESAMPLE_KERNELS; k++)
        if (usable[k] && ms[k] > 0 && ms[k] <= best * (1 + WARP_RESAMPLE_PICK_TIE)) return (warp_resample_kernel_id)k;
    return warp_resample_kernel_widest(); /* not reached */
}

bool warp_resample_set_auto(warp_resample_kernel_id k)
{
    if (!warp_resample_kernel_available(k)) return false;
    auto_choice = k;
    return true;
}

static warp_resample_kernel_id kernel_in_use(void)
{
    if (forced != WARP_RESAMPLE_AUTO) return forced;
    if (auto_choice != WARP_RESAMPLE_AUTO) return auto_choice;
    return warp_resample_kernel_widest();
}

const char *warp_resample_kernel_name(warp_resample_kernel_id k)
{
    static const char *const names[WARP_RESAMPLE_KERNELS] = {"auto", "scalar", "vector", "avx2", "avx512"};
    return k >= 0 && k < WARP_RESAMPLE_KERNELS ? names[k] : "?";
}

const char *warp_resample_kernel(void) { return warp_resample_kernel_name(kernel_in_use()); }

/* row[x0, x1) = opaque black, four pixels a store: the hidden-area mask covers a third of a wide-FOV lens's
 * viewport, and pixel by pixel it took a tenth of the resample's time. */
static inline void fill_black(warp_rgba8 *row, int x0, int x1, v4u black)
{
    int x = x0;
    for (; x + 4 <= x1; x += 4) memcpy(&row[x], &black, sizeof black);
    for (; x < x1; x++) row[x] = (warp_rgba8){0, 0, 0, 255};
}

typedef void kernel_fn(const warp_planar3 *s, const warp_mesh *m, const row_table *t, int x0, int x1,
                       warp_rgba8 *row);

void warp_mesh_resample(const warp_mesh *m, const warp_planar3 *src, warp_image_rgba8 *dst, int x0, int y0, int x1,
                        int y1)
{
    x0 = x0 > 0 ? x0 : 0;
    y0 = y0 > 0 ? y0 : 0;
    x1 = x1 < m->vp_w ? x1 : m->vp_w;
    y1 = y1 < m->vp_h ? y1 : m->vp_h;
    if (x0 >= x1 || y0 >= y1) return;
    kernel_fn *kernel = kernel_scalar;
    row_build_fn *build = row_table_build;
    switch (kernel_in_use()) {
    case WARP_RESAMPLE_VECTOR:
        kernel = kernel_vector;
        break;
#ifdef HAVE_X86_KERNELS
    case WARP_RESAMPLE_AVX512:
        kernel = kernel_avx512;
        build = row_table_build_avx2;
        break;
    case WARP_RESAMPLE_AVX2:
        kernel = kernel_avx2;
        build = row_table_build_avx2;
        break;
#endif
    default:
        break;
    }
    const int cw = m->cell_w;
    row_table t;
    const v4u black = (v4u){0} + 0xff000000u;
    /* strips of at most STRIP_CELLS cells */
    for (int sx0 = x0; sx0 < x1;) {
        const int ia = sx0 / cw;
        const int sx1 = (ia + STRIP_CELLS) * cw < x1 ? (ia + STRIP_CELLS) * cw : x1;
        for (int y = y0; y < y1; y++) {
            warp_rgba8 *row = &WARP_AT(dst, m->vp_x, m->vp_y + y);
            int lo = sx0, hi = sx1;
            if (m->visible) {
                /* the hidden-area mask: black, and not sampled (kernels write exactly [lo, hi)) */
                const int v0 = m->visible[2 * y], v1 = m->visible[2 * y + 1];
                lo = v0 > sx0 ? (v0 < sx1 ? v0 : sx1) : sx0;
                hi = v1 < sx1 ? (v1 > lo ? v1 : lo) : sx1;
                fill_black(row, sx0, lo, black);
                fill_black(row, hi, sx1, black);
                if (lo >= hi) continue;
            }
            /* the visible cells only: the rest of the strip is not sampled */
            build(&t, m, y, lo / cw, (hi - 1) / cw);
            kernel(src, m, &t, lo, hi, row);
        }
        sx0 = sx1;
    }
}

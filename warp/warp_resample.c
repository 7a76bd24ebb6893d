/* warp_resample: the CPU resampler of the display path: per-channel bilinear sampling through a distortion mesh,
 * in 8.8 fixed point from planar 8-bit sources, tile by tile, with an AVX2 kernel chosen at run time. */
#include "warp/warp_resample.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define HAVE_AVX2_KERNEL 1
#endif

/* Pixels per kernel call: coordinates for one tile row are staged in small arrays on the stack. */
#define SPAN 128

bool warp_planar3_alloc(warp_planar3 *p, int w, int h)
{
    memset(p, 0, sizeof *p);
    if (w <= 0 || h <= 0 || w > 16384 || h > 16384) return false;
    /* +4 bytes so a 4-byte load at the last column stays in the row; a spare row for the lower bilinear tap. */
    int stride = (w + 4 + 63) / 64 * 64;
    size_t plane = (size_t)stride * (size_t)(h + 2);
    p->mem = aligned_alloc(64, plane * 3);
    if (!p->mem) return false;
    memset(p->mem, 0, plane * 3);
    for (int c = 0; c < 3; c++) p->plane[c] = (uint8_t *)p->mem + plane * (size_t)c;
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
        const warp_rgba8 *s = &WARP_AT(src, 0, y);
        uint8_t *r = p->plane[0] + (size_t)y * p->stride, *g = p->plane[1] + (size_t)y * p->stride,
                *b = p->plane[2] + (size_t)y * p->stride;
        for (int x = 0; x < p->w; x++) {
            r[x] = s[x].r;
            g[x] = s[x].g;
            b[x] = s[x].b;
        }
    }
}

/* Coordinates of one span: per channel, continuous source positions (pixel centres at +0.5). */
typedef struct {
    float x[3][SPAN], y[3][SPAN];
} span_coords;

/* One channel sample in 8.8 fixed point. The integer maths is the reference the SIMD kernel matches bit for
 * bit: rounding to 1/256 pixel first makes coordinates that differ by float noise sample identically. */
static inline uint32_t sample_channel(const uint8_t *plane, int stride, float maxx, float maxy, float fxf, float fyf)
{
    fxf -= 0.5f;
    fyf -= 0.5f;
    fxf = fxf < 0 ? 0 : (fxf > maxx ? maxx : fxf);
    fyf = fyf < 0 ? 0 : (fyf > maxy ? maxy : fyf);
    int ax = (int)(fxf * 256.0f + 0.5f), ay = (int)(fyf * 256.0f + 0.5f);
    int wx = ax & 255, wy = ay & 255;
    const uint8_t *p = plane + (size_t)(ay >> 8) * (size_t)stride + (size_t)(ax >> 8);
    int top = (p[0] << 8) + (p[1] - p[0]) * wx;
    int bot = (p[stride] << 8) + (p[stride + 1] - p[stride]) * wx;
    return (uint32_t)(((top << 8) + (bot - top) * wy + 32768) >> 16);
}

static void kernel_scalar(const warp_planar3 *s, const span_coords *sc, int from, int n, warp_rgba8 *out)
{
    const float maxx = (float)(s->w - 1), maxy = (float)(s->h - 1);
    for (int k = from; k < n; k++) {
        uint32_t r = sample_channel(s->plane[0], s->stride, maxx, maxy, sc->x[0][k], sc->y[0][k]);
        uint32_t g = sample_channel(s->plane[1], s->stride, maxx, maxy, sc->x[1][k], sc->y[1][k]);
        uint32_t b = sample_channel(s->plane[2], s->stride, maxx, maxy, sc->x[2][k], sc->y[2][k]);
        out[k] = (warp_rgba8){(uint8_t)r, (uint8_t)g, (uint8_t)b, 255};
    }
}

#ifdef HAVE_AVX2_KERNEL
__attribute__((target("avx2,fma"))) static inline __m256i avx2_channel(const uint8_t *plane, __m256i vstride,
                                                                        __m256 maxx, __m256 maxy, const float *xs,
                                                                        const float *ys)
{
    const __m256 half = _mm256_set1_ps(0.5f), zero = _mm256_setzero_ps(), s256 = _mm256_set1_ps(256.0f);
    const __m256i m255 = _mm256_set1_epi32(255);
    __m256 fx = _mm256_sub_ps(_mm256_loadu_ps(xs), half), fy = _mm256_sub_ps(_mm256_loadu_ps(ys), half);
    fx = _mm256_min_ps(_mm256_max_ps(fx, zero), maxx);
    fy = _mm256_min_ps(_mm256_max_ps(fy, zero), maxy);
    __m256i ax = _mm256_cvttps_epi32(_mm256_fmadd_ps(fx, s256, half));
    __m256i ay = _mm256_cvttps_epi32(_mm256_fmadd_ps(fy, s256, half));
    __m256i wx = _mm256_and_si256(ax, m255), wy = _mm256_and_si256(ay, m255);
    __m256i idx = _mm256_add_epi32(_mm256_mullo_epi32(_mm256_srli_epi32(ay, 8), vstride), _mm256_srli_epi32(ax, 8));
    /* One 4-byte gather per row fetches both horizontal taps. */
    __m256i g0 = _mm256_i32gather_epi32((const int *)plane, idx, 1);
    __m256i g1 = _mm256_i32gather_epi32((const int *)plane, _mm256_add_epi32(idx, vstride), 1);
    __m256i p00 = _mm256_and_si256(g0, m255), p01 = _mm256_and_si256(_mm256_srli_epi32(g0, 8), m255);
    __m256i p10 = _mm256_and_si256(g1, m255), p11 = _mm256_and_si256(_mm256_srli_epi32(g1, 8), m255);
    __m256i top = _mm256_add_epi32(_mm256_slli_epi32(p00, 8), _mm256_mullo_epi32(_mm256_sub_epi32(p01, p00), wx));
    __m256i bot = _mm256_add_epi32(_mm256_slli_epi32(p10, 8), _mm256_mullo_epi32(_mm256_sub_epi32(p11, p10), wx));
    __m256i v = _mm256_add_epi32(_mm256_slli_epi32(top, 8), _mm256_mullo_epi32(_mm256_sub_epi32(bot, top), wy));
    return _mm256_srli_epi32(_mm256_add_epi32(v, _mm256_set1_epi32(32768)), 16);
}

__attribute__((target("avx2,fma"))) static void kernel_avx2(const warp_planar3 *s, const span_coords *sc, int n,
                                                             warp_rgba8 *out)
{
    const __m256 maxx = _mm256_set1_ps((float)(s->w - 1)), maxy = _mm256_set1_ps((float)(s->h - 1));
    const __m256i vstride = _mm256_set1_epi32(s->stride), alpha = _mm256_set1_epi32((int)0xff000000u);
    int k = 0;
    for (; k + 8 <= n; k += 8) {
        __m256i r = avx2_channel(s->plane[0], vstride, maxx, maxy, &sc->x[0][k], &sc->y[0][k]);
        __m256i g = avx2_channel(s->plane[1], vstride, maxx, maxy, &sc->x[1][k], &sc->y[1][k]);
        __m256i b = avx2_channel(s->plane[2], vstride, maxx, maxy, &sc->x[2][k], &sc->y[2][k]);
        __m256i px = _mm256_or_si256(_mm256_or_si256(r, _mm256_slli_epi32(g, 8)),
                                     _mm256_or_si256(_mm256_slli_epi32(b, 16), alpha));
        _mm256_storeu_si256((__m256i *)(void *)&out[k], px);
    }
    kernel_scalar(s, sc, k, n, out);
}
#endif

static bool force_scalar;
void warp_resample_force_scalar(bool force) { force_scalar = force; }

static bool use_avx2(void)
{
#ifdef HAVE_AVX2_KERNEL
    return !force_scalar && __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#else
    return false;
#endif
}

const char *warp_resample_kernel(void) { return use_avx2() ? "avx2" : "scalar"; }

void warp_mesh_resample(const warp_mesh *m, const warp_planar3 *src, warp_image_rgba8 *dst, int x0, int y0, int x1,
                        int y1)
{
    const int n = m->n;
    const float cw = (float)m->vp_w / (float)(n - 1), ch = (float)m->vp_h / (float)(n - 1);
    const float icw = 1.0f / cw, ich = 1.0f / ch;
    const bool avx2 = use_avx2();
    span_coords sc;
    for (int y = y0; y < y1; y++) {
        /* Mesh row and fraction for this pixel row's centre. */
        float gy = ((float)y + 0.5f) * ich;
        int j = (int)gy;
        if (j > n - 2) j = n - 2;
        float ty = gy - (float)j;
        const warp_vec2f *row0 = m->src + (size_t)j * n * 3, *row1 = row0 + (size_t)n * 3;
        for (int xs = x0; xs < x1; xs += SPAN) {
            int xe = xs + SPAN < x1 ? xs + SPAN : x1;
            /* Within a mesh cell the position is linear in x: fill each cell's pixels by stepping. */
            int x = xs;
            while (x < xe) {
                int i = (int)(((float)x + 0.5f) * icw);
                if (i > n - 2) i = n - 2;
                /* last pixel whose centre lies in cell i */
                int xend = (int)ceilf((float)(i + 1) * cw - 0.5f);
                if (i == n - 2 || xend > xe) xend = xe;
                if (xend <= x) xend = x + 1;
                for (int c = 0; c < 3; c++) {
                    const warp_vec2f a = row0[i * 3 + c], b = row0[(i + 1) * 3 + c];
                    const warp_vec2f cc = row1[i * 3 + c], d = row1[(i + 1) * 3 + c];
                    float lx = a.x + (cc.x - a.x) * ty, ly = a.y + (cc.y - a.y) * ty;
                    float dx = b.x + (d.x - b.x) * ty - lx, dy = b.y + (d.y - b.y) * ty - ly;
                    float *ox = &sc.x[c][x - xs], *oy = &sc.y[c][x - xs];
                    /* Each pixel's fraction is computed from its own x (not stepped from the span start), so the
                     * result does not depend on how the viewport was cut into tiles. */
                    for (int k = 0; k < xend - x; k++) {
                        float t = ((float)(x + k) + 0.5f) * icw - (float)i;
                        ox[k] = lx + dx * t;
                        oy[k] = ly + dy * t;
                    }
                }
                x = xend;
            }
            warp_rgba8 *out = &WARP_AT(dst, m->vp_x + xs, m->vp_y + y);
#ifdef HAVE_AVX2_KERNEL
            if (avx2) {
                kernel_avx2(src, &sc, xe - xs, out);
                continue;
            }
#endif
            (void)avx2;
            kernel_scalar(src, &sc, 0, xe - xs, out);
        }
    }
}

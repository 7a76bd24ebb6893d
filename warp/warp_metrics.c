/* SPDX-License-Identifier: MIT */
/* warp_metrics: image quality against ground truth: PSNR, SSIM (Wang et al. 2004, Gaussian window) and the
 * error-pixel percentage of 002 §4 (CIE Lab distance > 20), each optionally restricted by a mask. */
#include "warp/warp_metrics.h"

#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

/* Both images (and the mask, when given) must cover the same non-empty pixel grid. */
static bool same_size(const warp_image_rgba8 *a, const warp_image_rgba8 *b, const warp_image_u8 *mask)
{
    if (!a || !b || !a->px || !b->px || a->w != b->w || a->h != b->h || a->w <= 0 || a->h <= 0) return false;
    if (mask && (!mask->px || mask->w != a->w || mask->h != a->h)) return false;
    return true;
}

static inline bool counts(const warp_image_u8 *mask, uint8_t exclude, int x, int y)
{
    return !mask || (WARP_AT(mask, x, y) & exclude) == 0;
}

double warp_psnr(const warp_image_rgba8 *a, const warp_image_rgba8 *b, const warp_image_u8 *mask, uint8_t exclude)
{
    if (!same_size(a, b, mask)) return NAN;
    /* Integer sums are exact (3 * 255^2 per pixel fits 2^64 for any image), so a uniform offset k gives
     * exactly 10 log10(255^2 / k^2). */
    uint64_t sse = 0, n = 0;
    for (int y = 0; y < a->h; y++) {
        const warp_rgba8 *pa = &WARP_AT(a, 0, y), *pb = &WARP_AT(b, 0, y);
        for (int x = 0; x < a->w; x++) {
            if (!counts(mask, exclude, x, y)) continue;
            int dr = pa[x].r - pb[x].r, dg = pa[x].g - pb[x].g, db = pa[x].b - pb[x].b;
            sse += (uint64_t)(dr * dr + dg * dg + db * db);
            n++;
        }
    }
    if (n == 0) return NAN;
    if (sse == 0) return INFINITY;
    double mse = (double)sse / (3.0 * (double)n);
    return 10.0 * log10(255.0 * 255.0 / mse);
}

/* ---- depth-edge band ---- */

/* Whether depths a and b differ by more than rel times the nearer (sky, not positive or not finite, as infinitely
 * far: an object against the sky is an edge, sky beside sky is not). */
static bool depth_jump(float a, float b, float rel)
{
    const bool fa = a > 0 && isfinite(a), fb = b > 0 && isfinite(b);
    if (!fa || !fb) return fa != fb;
    return fabsf(a - b) > rel * fminf(a, b);
}

long warp_depth_edge_band(const warp_image_f32 *depth, float rel_jump, int radius, warp_image_u8 *band)
{
    if (depth->w != band->w || depth->h != band->h) return -1;
    const int w = depth->w, h = depth->h;
    warp_image_u8_fill(band, 1);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            const float z = WARP_AT(depth, x, y);
            /* the pair with the right and the one with the lower neighbour: both pixels' squares */
            for (int k = 0; k < 2; k++) {
                const int nx = x + (k == 0), ny = y + (k == 1);
                if (nx >= w || ny >= h || !depth_jump(z, WARP_AT(depth, nx, ny), rel_jump)) continue;
                const int u0 = x - radius > 0 ? x - radius : 0, u1 = nx + radius < w ? nx + radius : w - 1;
                const int v0 = y - radius > 0 ? y - radius : 0, v1 = ny + radius < h ? ny + radius : h - 1;
                for (int v = v0; v <= v1; v++) memset(&WARP_AT(band, u0, v), 0, (size_t)(u1 - u0 + 1));
            }
        }
    long n = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) n += WARP_AT(band, x, y) == 0;
    return n;
}

/* ---- SSIM ---- */

#define SSIM_RADIUS 5
#define SSIM_TAPS (2 * SSIM_RADIUS + 1)
#define SSIM_BLOCK 4 /* columns per block: fixed-length inner loops that compilers turn into SIMD even at -O2 */
enum { Q_X, Q_Y, Q_XX, Q_YY, Q_XY, Q_COUNT }; /* the five filtered quantities */

/* d[i] = scale[i] * s * sum_k g[k] p[k][i] for the symmetric 11-tap window, taps k and 10-k paired.
 * n is a multiple of SSIM_BLOCK. */
static void sym_filter(const double *const p[SSIM_TAPS], const double g[SSIM_TAPS], const double *restrict scale,
                       double s, double *restrict d, int n)
{
    const double *p0 = p[0], *p1 = p[1], *p2 = p[2], *p3 = p[3], *p4 = p[4], *p5 = p[5];
    const double *p6 = p[6], *p7 = p[7], *p8 = p[8], *p9 = p[9], *p10 = p[10];
    const double g0 = g[0], g1 = g[1], g2 = g[2], g3 = g[3], g4 = g[4], g5 = g[5];
    for (int x = 0; x < n; x += SSIM_BLOCK)
        for (int j = 0; j < SSIM_BLOCK; j++) {
            int i = x + j;
            double acc = g5 * p5[i] + g0 * (p0[i] + p10[i]) + g1 * (p1[i] + p9[i]) + g2 * (p2[i] + p8[i]) +
                         g3 * (p3[i] + p7[i]) + g4 * (p4[i] + p6[i]);
            d[i] = acc * scale[i] * s;
        }
}

double warp_ssim(const warp_image_rgba8 *a, const warp_image_rgba8 *b, const warp_image_u8 *mask, uint8_t exclude)
{
    if (!same_size(a, b, mask)) return NAN;
    const int w = a->w, h = a->h;
    const int wb = (w + SSIM_BLOCK - 1) / SSIM_BLOCK * SSIM_BLOCK; /* columns w..wb-1 are zero padding */
    const double c1 = (0.01 * 255) * (0.01 * 255), c2 = (0.03 * 255) * (0.03 * 255);

    double g[SSIM_TAPS];
    for (int k = 0; k < SSIM_TAPS; k++) g[k] = exp(-(double)((k - SSIM_RADIUS) * (k - SSIM_RADIUS)) / (2 * 1.5 * 1.5));

    /* Streamed by rows: the horizontal pass of each image row lands in a ring of 11 rows, and each output row
     * is the vertical pass over the ring, so scratch is ~80 doubles per column (cache-resident at HMD sizes)
     * instead of five full-image planes. Double throughout: variances are E[x^2] - mu^2 of values up to 255^2,
     * which in float loses ~1e-3 absolute, visible against C2 in flat regions. The window is separable and so
     * is its clipped weight sum, so zero-padding each 1-D pass and dividing by its own partial weight sum equals
     * clipping the 11x11 window and renormalising by its total weight. */
    const size_t pw = (size_t)wb + 2 * SSIM_RADIUS; /* padded row: src[x + k] is column x + k - SSIM_RADIUS */
    const size_t row = (size_t)wb;
    const size_t n_doubles = Q_COUNT * pw + (SSIM_TAPS * Q_COUNT + Q_COUNT + 4) * row;
    double *mem = calloc(n_doubles, sizeof(double)); /* zeroed: the padding must read as zero */
    if (!mem) return NAN;
    double *padded = mem;                               /* [Q_COUNT][pw] */
    double *ring = padded + Q_COUNT * pw;               /* [SSIM_TAPS][Q_COUNT][wb] */
    double *vert = ring + SSIM_TAPS * Q_COUNT * row;    /* [Q_COUNT][wb] */
    double *inv_hsum = vert + Q_COUNT * row;            /* [wb]: 1 / horizontal weight sum per column */
    double *ones = inv_hsum + row;                      /* [wb] */
    double *zero = ones + row;                          /* [wb]: stands in for rows beyond the border */
    double *smap = zero + row;                          /* [wb]: SSIM of one output row */
    for (int x = 0; x < wb; x++) {
        double s = 0;
        for (int k = 0; k < SSIM_TAPS; k++) {
            int xx = x + k - SSIM_RADIUS;
            if (xx >= 0 && xx < w) s += g[k];
        }
        inv_hsum[x] = x < w ? 1.0 / s : 0.0;
        ones[x] = 1.0;
    }

    double sum = 0;
    long long n = 0;
    /* Row r of the image is filtered horizontally when output row r - SSIM_RADIUS needs it. */
    for (int r = 0; r < h + SSIM_RADIUS; r++) {
        if (r < h) {
            const warp_rgba8 *pa = &WARP_AT(a, 0, r), *pb = &WARP_AT(b, 0, r);
            double *restrict px = padded + Q_X * pw + SSIM_RADIUS, *restrict py = padded + Q_Y * pw + SSIM_RADIUS;
            double *restrict pxx = padded + Q_XX * pw + SSIM_RADIUS, *restrict pyy = padded + Q_YY * pw + SSIM_RADIUS;
            double *restrict pxy = padded + Q_XY * pw + SSIM_RADIUS;
            for (int x = 0; x < w; x++) {
                /* BT.601 luma, kept as float (not rounded to 8 bits) */
                double lx = 0.299f * (float)pa[x].r + 0.587f * (float)pa[x].g + 0.114f * (float)pa[x].b;
                double ly = 0.299f * (float)pb[x].r + 0.587f * (float)pb[x].g + 0.114f * (float)pb[x].b;
                px[x] = lx;
                py[x] = ly;
                pxx[x] = lx * lx; /* float * float is exact in double */
                pyy[x] = ly * ly;
                pxy[x] = lx * ly;
            }
            double *dst = ring + (size_t)(r % SSIM_TAPS) * Q_COUNT * row;
            for (int q = 0; q < Q_COUNT; q++) {
                const double *src = padded + q * pw, *taps[SSIM_TAPS];
                for (int k = 0; k < SSIM_TAPS; k++) taps[k] = src + k;
                sym_filter(taps, g, inv_hsum, 1.0, dst + q * row, wb);
            }
        }
        int y = r - SSIM_RADIUS; /* output row whose window is now complete */
        if (y < 0) continue;
        double vs = 0;
        const double *rows[SSIM_TAPS];
        for (int k = 0; k < SSIM_TAPS; k++) {
            int yy = y + k - SSIM_RADIUS;
            bool in = yy >= 0 && yy < h;
            if (in) vs += g[k];
            rows[k] = in ? ring + (size_t)(yy % SSIM_TAPS) * Q_COUNT * row : NULL;
        }
        for (int q = 0; q < Q_COUNT; q++) {
            const double *taps[SSIM_TAPS];
            for (int k = 0; k < SSIM_TAPS; k++) taps[k] = rows[k] ? rows[k] + q * row : zero;
            sym_filter(taps, g, ones, 1.0 / vs, vert + q * row, wb);
        }
        const double *restrict mx = vert + Q_X * row, *restrict my = vert + Q_Y * row;
        const double *restrict exx = vert + Q_XX * row, *restrict eyy = vert + Q_YY * row;
        const double *restrict exy = vert + Q_XY * row;
        for (int x = 0; x < wb; x += SSIM_BLOCK)
            for (int j = 0; j < SSIM_BLOCK; j++) {
                int i = x + j;
                double ux = mx[i], uy = my[i];
                double sxx = exx[i] - ux * ux, syy = eyy[i] - uy * uy, sxy = exy[i] - ux * uy;
                smap[i] = ((2 * ux * uy + c1) * (2 * sxy + c2)) / ((ux * ux + uy * uy + c1) * (sxx + syy + c2));
            }
        if (!mask) {
            for (int x = 0; x < w; x++) sum += smap[x];
            n += w;
        } else {
            const uint8_t *m = &WARP_AT(mask, 0, y);
            for (int x = 0; x < w; x++) {
                if (m[x] & exclude) continue;
                sum += smap[x];
                n++;
            }
        }
    }
    free(mem);
    return n ? sum / (double)n : NAN;
}

/* ---- CIE Lab and the error-pixel metric ---- */

/* Exact sRGB transfer curve (IEC 61966-2-1), 8-bit code -> linear [0,1]. */
static double srgb_to_linear(int v)
{
    double c = v / 255.0;
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

static double lab_f(double t)
{
    const double d = 6.0 / 29.0;
    return t > d * d * d ? cbrt(t) : t / (3 * d * d) + 4.0 / 29.0;
}

/* Linear sRGB -> XYZ (D65) -> Lab. The white point is the matrix's row sums, so sRGB white lands exactly on
 * L = 100, a = b = 0 rather than a rounding error away from it. */
static void linear_to_lab(double r, double g, double b, double lab[3])
{
    static const double m[3][3] = {{0.4124564, 0.3575761, 0.1804375},
                                   {0.2126729, 0.7151522, 0.0721750},
                                   {0.0193339, 0.1191920, 0.9503041}};
    double xyz[3], f[3];
    for (int i = 0; i < 3; i++) {
        xyz[i] = m[i][0] * r + m[i][1] * g + m[i][2] * b;
        f[i] = lab_f(xyz[i] / (m[i][0] + m[i][1] + m[i][2]));
    }
    lab[0] = 116 * f[1] - 16;
    lab[1] = 500 * (f[0] - f[1]);
    lab[2] = 200 * (f[1] - f[2]);
}

void warp_srgb_to_lab(warp_rgba8 c, double lab[3])
{
    linear_to_lab(srgb_to_linear(c.r), srgb_to_linear(c.g), srgb_to_linear(c.b), lab);
}

double warp_error_pixel_percent(const warp_image_rgba8 *a, const warp_image_rgba8 *b, const warp_image_u8 *mask,
                                uint8_t exclude, double threshold)
{
    if (!same_size(a, b, mask) || isnan(threshold)) return NAN;
    /* Built per call (256 pow, microseconds) rather than lazily in a static: no init race between threads. */
    double lin[256];
    for (int i = 0; i < 256; i++) lin[i] = srgb_to_linear(i);
    const double t2 = threshold > 0 ? threshold * threshold : threshold; /* compare squared distances */
    long long n = 0, bad = 0;
    for (int y = 0; y < a->h; y++) {
        const warp_rgba8 *pa = &WARP_AT(a, 0, y), *pb = &WARP_AT(b, 0, y);
        for (int x = 0; x < a->w; x++) {
            if (!counts(mask, exclude, x, y)) continue;
            n++;
            warp_rgba8 ca = pa[x], cb = pb[x];
            double d2 = 0;
            /* Identical colours (most pixels of a good warp) skip the two Lab conversions. */
            if (ca.r != cb.r || ca.g != cb.g || ca.b != cb.b) {
                double la[3], lb[3];
                linear_to_lab(lin[ca.r], lin[ca.g], lin[ca.b], la);
                linear_to_lab(lin[cb.r], lin[cb.g], lin[cb.b], lb);
                d2 = (la[0] - lb[0]) * (la[0] - lb[0]) + (la[1] - lb[1]) * (la[1] - lb[1]) +
                     (la[2] - lb[2]) * (la[2] - lb[2]);
            }
            if (d2 > t2) bad++;
        }
    }
    return n ? 100.0 * (double)bad / (double)n : NAN;
}

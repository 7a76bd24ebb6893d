/* SPDX-License-Identifier: MIT */
/* warp_mesh: the distortion mesh that fuses a rotation warp with lens distortion and chromatic aberration, so the
 * display image of each eye is produced in one resampling pass (the approach of Monado's and Cardboard's meshes). */
#include "warp/warp_mesh.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Allocates the mesh and sets its geometry; the tangents are the caller's. */
static bool mesh_alloc(warp_mesh *m, int n, int vp_x, int vp_y, int vp_w, int vp_h)
{
    memset(m, 0, sizeof *m);
    if (n < 2 || n > 1024 || vp_w <= 0 || vp_h <= 0 || vp_w > WARP_MAX_SIDE || vp_h > WARP_MAX_SIDE) return false;
    /* Columns a multiple of 8 pixels apart (see warp_mesh.h): the nearest such spacing to n evenly spread. */
    int cell_w = 8 * (int)((double)vp_w / (n - 1) / 8.0 + 0.5);
    if (cell_w < 8) cell_w = 8;
    const int rows = n, cols = (vp_w + cell_w - 1) / cell_w + 1;
    const int line_stride = (cols - 1 + 7) / 8 * 8 + 8;
    size_t count = (size_t)rows * (size_t)cols * 3;
    size_t lines = (size_t)(rows - 1) * 2 * WARP_MESH_LINE_VALUES * (size_t)line_stride;
    m->tan = calloc(count, sizeof *m->tan);
    m->src = calloc(count, sizeof *m->src);
    m->lines = calloc(lines, sizeof *m->lines);
    m->work = calloc((size_t)rows * 6 * (size_t)cols, sizeof *m->work);
    m->flags = calloc((size_t)rows * (size_t)cols, 1);
    if (!m->tan || !m->src || !m->lines || !m->work || !m->flags) {
        warp_mesh_free(m);
        return false;
    }
    m->n = n;
    m->rows = rows;
    m->cols = cols;
    m->cell_w = cell_w;
    m->line_stride = line_stride;
    m->vp_x = vp_x;
    m->vp_y = vp_y;
    m->vp_w = vp_w;
    m->vp_h = vp_h;
    return true;
}

/* Continuous viewport position of vertex (i, j) (warp_mesh.h). */
static void vertex_xy(const warp_mesh *m, int i, int j, double *x, double *y)
{
    *x = (double)i * m->cell_w;
    *y = (double)j * m->vp_h / (m->rows - 1);
}

bool warp_mesh_alloc(warp_mesh *m, int n, const warp_lens *lens, int vp_x, int vp_y, int vp_w, int vp_h)
{
    if (!mesh_alloc(m, n, vp_x, vp_y, vp_w, vp_h)) return false;
    for (int j = 0; j < m->rows; j++)
        for (int i = 0; i < m->cols; i++) {
            double x, y;
            vertex_xy(m, i, j, &x, &y);
            for (int c = 0; c < 3; c++) {
                double u, v;
                warp_lens_distort(lens, c, x, y, &u, &v);
                m->tan[((size_t)j * m->cols + i) * 3 + c] = (warp_vec2f){(float)u, (float)v};
            }
        }
    return true;
}

bool warp_mesh_alloc_eye(warp_mesh *m, int n, const warp_camera *cam)
{
    if (!mesh_alloc(m, n, 0, 0, cam->width, cam->height)) return false;
    for (int j = 0; j < m->rows; j++)
        for (int i = 0; i < m->cols; i++) {
            double x, y, u, v;
            vertex_xy(m, i, j, &x, &y);
            warp_camera_pixel_to_tan(cam, x, y, &u, &v);
            for (int c = 0; c < 3; c++) m->tan[((size_t)j * m->cols + i) * 3 + c] = (warp_vec2f){(float)u, (float)v};
        }
    return true;
}

void warp_mesh_free(warp_mesh *m)
{
    free(m->tan);
    free(m->src);
    free(m->lines);
    free(m->work);
    free(m->flags);
    memset(m, 0, sizeof *m);
}

/* Writes the resampler's per-cell lines of band j (layout in warp_mesh.h) from the scaled vertex positions of
 * its two vertex rows (work: per vertex row, 6 runs of cols values, channel-major, x then y). */
static void band_lines(warp_mesh *m, int j)
{
    const int cols = m->cols;
    const double icw = 1.0 / m->cell_w;
    float *top = m->lines + (size_t)j * 2 * WARP_MESH_LINE_VALUES * m->line_stride;
    float *chg = top + (size_t)WARP_MESH_LINE_VALUES * m->line_stride;
    for (int c = 0; c < 3; c++)
        for (int a = 0; a < 2; a++) {
            const double *t = m->work + ((size_t)j * 6 + (size_t)(c * 2 + a)) * (size_t)cols, *b = t + 6 * (size_t)cols;
            float *tp = top + (size_t)WARP_MESH_LINE(c, a, 0) * m->line_stride;
            float *tq = top + (size_t)WARP_MESH_LINE(c, a, 1) * m->line_stride;
            float *cp = chg + (size_t)WARP_MESH_LINE(c, a, 0) * m->line_stride;
            float *cq = chg + (size_t)WARP_MESH_LINE(c, a, 1) * m->line_stride;
            for (int i = 0; i < cols - 1; i++) {
                tp[i] = (float)t[i];
                cp[i] = (float)(b[i] - t[i]);
                tq[i] = (float)((t[i + 1] - t[i]) * icw);
                cq[i] = (float)(((b[i + 1] - b[i]) - (t[i + 1] - t[i])) * icw);
            }
        }
}

/* Records the source position (x, y) of vertex (i, j), channel c: in src, and for the lines in 1/64 pixel units,
 * minus the half pixel from centre to corner, plus the rounding bias (warp_mesh.h). Keeps it within what the
 * fixed-point resampler can represent (anything this far is fringe anyway), written so that a NaN (a broken lens
 * or pose) also ends up at the border. */
static void set_vertex(warp_mesh *m, int j, int i, int c, double x, double y)
{
    x = x > -65536 ? (x < 65536 ? x : 65536) : -65536;
    y = y > -65536 ? (y < 65536 ? y : 65536) : -65536;
    m->src[((size_t)j * m->cols + i) * 3 + c] = (warp_vec2f){(float)x, (float)y};
    double *row = m->work + (size_t)j * 6 * (size_t)m->cols;
    row[(size_t)(c * 2) * m->cols + i] = 64.0 * (float)x - 31.5;
    row[(size_t)(c * 2 + 1) * m->cols + i] = 64.0 * (float)y - 31.5;
}

/* Once every vertex is set: the resampler's lines. */
static void finish_update(warp_mesh *m, int behind)
{
    m->behind = behind;
    for (int j = 0; j < m->rows - 1; j++) band_lines(m, j);
}

/* The same after a rotation: no vertex carries a raytrace flag. */
static void finish_rotation(warp_mesh *m, int behind)
{
    memset(m->flags, 0, (size_t)m->rows * (size_t)m->cols);
    finish_update(m, behind);
}

/* Far outside the source but small enough for float-to-int conversion: the resampler clamps it to the border like
 * every other fringe position. */
#define FAR_OUT (-65536.0)

/* Source position of tangent direction t under the homography h = K_src * src_from_dst; false (and FAR_OUT) when
 * it points behind the source camera. */
static bool rotate_tan(const warp_mat3 *h, warp_vec2f t, double *xo, double *yo)
{
    double u = t.x, v = t.y;
    double x = h->m[0][0] * u + h->m[0][1] * v - h->m[0][2];
    double y = h->m[1][0] * u + h->m[1][1] * v - h->m[1][2];
    double w = h->m[2][0] * u + h->m[2][1] * v - h->m[2][2];
    if (w > 1e-6) {
        double iw = 1.0 / w;
        *xo = x * iw;
        *yo = y * iw;
        return true;
    }
    *xo = *yo = FAR_OUT;
    return false;
}

/* One vertex's three channels under h. */
static int rotate_vertex(warp_mesh *m, const warp_mat3 *h, int j, int i)
{
    int behind = 0;
    for (int c = 0; c < 3; c++) {
        double x, y;
        behind += !rotate_tan(h, m->tan[((size_t)j * m->cols + i) * 3 + c], &x, &y);
        set_vertex(m, j, i, c, x, y);
    }
    return behind;
}

static warp_mat3 rotation_homography(const warp_camera *src_cam, warp_quat src_from_dst)
{
    warp_mat3 k = warp_camera_K(src_cam), r = warp_quat_to_mat3(src_from_dst);
    return warp_mat3_mul(&k, &r);
}

void warp_mesh_update(warp_mesh *m, const warp_camera *src_cam, warp_quat src_from_dst)
{
    const warp_mat3 h = rotation_homography(src_cam, src_from_dst);
    int behind = 0;
    for (int j = 0; j < m->rows; j++)
        for (int i = 0; i < m->cols; i++) behind += rotate_vertex(m, &h, j, i);
    finish_rotation(m, behind);
}

/* Scan fraction of vertex (i, j) on the panel (its viewport's offset added). */
static double vertex_fraction(const warp_mesh *m, const warp_scan *scan, int i, int j)
{
    double x, y;
    vertex_xy(m, i, j, &x, &y);
    return warp_scan_fraction(scan, m->vp_x + x, m->vp_y + y);
}

void warp_mesh_update_rolling(warp_mesh *m, const warp_camera *src_cam, warp_quat first, warp_quat last,
                              const warp_scan *scan)
{
    int behind = 0;
    /* a vertical scan lights a vertex row at once, a horizontal one a vertex column: one homography each (a few
     * dozen slerps per eye and vsync, nothing per pixel) */
    const bool by_row = scan->dir == WARP_SCAN_TOP_TO_BOTTOM || scan->dir == WARP_SCAN_BOTTOM_TO_TOP;
    warp_mat3 h = rotation_homography(src_cam, first);
    for (int j = 0; j < m->rows; j++) {
        if (by_row) h = rotation_homography(src_cam, warp_scan_slerp(first, last, vertex_fraction(m, scan, 0, j)));
        for (int i = 0; i < m->cols; i++) {
            if (!by_row)
                h = rotation_homography(src_cam, warp_scan_slerp(first, last, vertex_fraction(m, scan, i, j)));
            behind += rotate_vertex(m, &h, j, i);
        }
    }
    finish_rotation(m, behind);
}

/* The source position the raytrace under s gives tangent direction t of the target eye; its flag (0,
 * WARP_MASK_FRINGE when the ray left the source, WARP_MASK_EDGE across a depth edge). */
static int trace_tan(const warp_camera *dst_cam, const warp_raytrace_setup *s, warp_vec2f t, double *x, double *y)
{
    /* where the per-pixel raytrace would meet this direction in the target eye buffer (continuous: a lens vertex
     * rarely sits on a pixel centre, and may lie beyond the buffer's edge, where the ray is still traced: the
     * rows' fringe rules apply to it as to any ray) */
    double tx, ty;
    warp_camera_tan_to_pixel(dst_cam, t.x, t.y, &tx, &ty);
    return warp_raytrace_point(s, tx, ty, x, y, NULL);
}

/* Red's or blue's ray of a vertex whose green ray (through eye-buffer position (gx, gy)) met a surface at inverse
 * depth dg without an edge: sought at that surface first (warp_raytrace_point_guess), within a pixel plus the
 * chromatic aberration between them, and traced in full where it is not there or meets an edge. */
static int trace_channel(const warp_camera *dst_cam, const warp_raytrace_setup *s, warp_vec2f t, double gx, double gy,
                         double dg, double *x, double *y)
{
    double tx, ty;
    warp_camera_tan_to_pixel(dst_cam, t.x, t.y, &tx, &ty);
    const double ca = sqrt((tx - gx) * (tx - gx) + (ty - gy) * (ty - gy));
    double d;
    if (warp_raytrace_point_guess(s, tx, ty, &dg, 1, 1.0 + ca, x, y, &d, NULL) == 0) return 0;
    return warp_raytrace_point(s, tx, ty, x, y, NULL);
}

/* The three channels' rays of a vertex seeing tangent directions t[0..3) under s: their source positions and
 * flags. Green first: where it meets a surface without an edge, red and blue, a chromatic aberration away, meet the
 * same one but at a silhouette (a third of the vertex's full searches where the guess finds them there). */
static void trace_vertex(const warp_camera *dst_cam, const warp_raytrace_setup *s, const warp_vec2f t[3], double x[3],
                         double y[3], int f[3])
{
    double gx, gy, dg;
    warp_camera_tan_to_pixel(dst_cam, t[1].x, t[1].y, &gx, &gy);
    f[1] = warp_raytrace_point_depth(s, gx, gy, &x[1], &y[1], &dg, NULL);
    for (int c = 0; c < 3; c += 2)
        f[c] = f[1] ? trace_tan(dst_cam, s, t[c], &x[c], &y[c])
                    : trace_channel(dst_cam, s, t[c], gx, gy, dg, &x[c], &y[c]);
}

void warp_mesh_update_raytrace(warp_mesh *m, const warp_camera *dst_cam, const warp_raytrace_setup *s)
{
    int left = 0;
    for (int j = 0; j < m->rows; j++)
        for (int i = 0; i < m->cols; i++) {
            double x[3], y[3];
            int f[3], fl = 0;
            trace_vertex(dst_cam, s, &m->tan[((size_t)j * m->cols + i) * 3], x, y, f);
            for (int c = 0; c < 3; c++) {
                left += f[c] == WARP_MASK_FRINGE;
                fl |= f[c];
                set_vertex(m, j, i, c, x[c], y[c]);
            }
            m->flags[(size_t)j * m->cols + i] = (uint8_t)fl;
        }
    finish_update(m, left);
}

void warp_mesh_update_raytrace_rolling(warp_mesh *m, const warp_camera *dst_cam, const warp_raytrace_setup *first,
                                       const warp_raytrace_setup *last, const warp_scan *scan)
{
    int left = 0;
    for (int j = 0; j < m->rows; j++)
        for (int i = 0; i < m->cols; i++) {
            const double f = vertex_fraction(m, scan, i, j);
            const warp_vec2f *t = &m->tan[((size_t)j * m->cols + i) * 3];
            double x0[3] = {0, 0, 0}, y0[3] = {0, 0, 0}, x1[3] = {0, 0, 0}, y1[3] = {0, 0, 0};
            int g0[3] = {0, 0, 0}, g1[3] = {0, 0, 0}, fl = 0;
            /* an endpoint's trace only where it has weight: the first and last vertex lines cost one */
            if (f < 1) trace_vertex(dst_cam, first, t, x0, y0, g0);
            if (f > 0) trace_vertex(dst_cam, last, t, x1, y1, g1);
            for (int c = 0; c < 3; c++) {
                const int g = g0[c] | g1[c];
                fl |= g;
                if (f <= 0) {
                    x1[c] = x0[c];
                    y1[c] = y0[c];
                } else if (f >= 1) {
                    x0[c] = x1[c];
                    y0[c] = y1[c];
                }
                left += (g & WARP_MASK_FRINGE) != 0;
                /* equal endpoints give x0 exactly (a still head: the global mesh bit for bit) */
                set_vertex(m, j, i, c, x0[c] + (x1[c] - x0[c]) * f, y0[c] + (y1[c] - y0[c]) * f);
            }
            m->flags[(size_t)j * m->cols + i] = (uint8_t)fl;
        }
    finish_update(m, left);
}

/* warp_mesh: the distortion mesh that fuses a rotation warp with lens distortion and chromatic aberration, so the
 * display image of each eye is produced in one resampling pass (the approach of Monado's and Cardboard's meshes). */
#include "warp/warp_mesh.h"

#include <stdlib.h>
#include <string.h>

bool warp_mesh_init(warp_mesh *m, int n, const warp_lens *lens, int vp_x, int vp_y, int vp_w, int vp_h)
{
    memset(m, 0, sizeof *m);
    if (n < 2 || n > 1024 || vp_w <= 0 || vp_h <= 0) return false;
    size_t count = (size_t)n * (size_t)n * 3;
    m->tan = calloc(count, sizeof *m->tan);
    m->src = calloc(count, sizeof *m->src);
    if (!m->tan || !m->src) {
        warp_mesh_free(m);
        return false;
    }
    m->n = n;
    m->vp_x = vp_x;
    m->vp_y = vp_y;
    m->vp_w = vp_w;
    m->vp_h = vp_h;
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            double x = (double)i * vp_w / (n - 1), y = (double)j * vp_h / (n - 1);
            for (int c = 0; c < 3; c++) {
                double u, v;
                warp_lens_distort(lens, c, x, y, &u, &v);
                m->tan[((size_t)j * n + i) * 3 + c] = (warp_vec2f){(float)u, (float)v};
            }
        }
    return true;
}

void warp_mesh_free(warp_mesh *m)
{
    free(m->tan);
    free(m->src);
    memset(m, 0, sizeof *m);
}

void warp_mesh_update(warp_mesh *m, const warp_camera *src_cam, warp_quat src_from_dst)
{
    warp_mat3 k = warp_camera_K(src_cam), r = warp_quat_to_mat3(src_from_dst);
    warp_mat3 h = warp_mat3_mul(&k, &r);
    /* Far outside the source but small enough for float-to-int conversion: the resampler clamps it to the
     * border like every other fringe position. */
    const float far_out = -65536.0f;
    int behind = 0;
    size_t count = (size_t)m->n * (size_t)m->n * 3;
    for (size_t i = 0; i < count; i++) {
        double u = m->tan[i].x, v = m->tan[i].y;
        double x = h.m[0][0] * u + h.m[0][1] * v - h.m[0][2];
        double y = h.m[1][0] * u + h.m[1][1] * v - h.m[1][2];
        double w = h.m[2][0] * u + h.m[2][1] * v - h.m[2][2];
        if (w > 1e-6) {
            double iw = 1.0 / w;
            x *= iw;
            y *= iw;
            /* Keep within what the fixed-point resampler can represent; anything this far is fringe anyway. */
            x = x < -65536 ? -65536 : (x > 65536 ? 65536 : x);
            y = y < -65536 ? -65536 : (y > 65536 ? 65536 : y);
            m->src[i] = (warp_vec2f){(float)x, (float)y};
        } else {
            m->src[i] = (warp_vec2f){far_out, far_out};
            behind++;
        }
    }
    m->behind = behind;
}

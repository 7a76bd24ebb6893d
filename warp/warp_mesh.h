/* warp_mesh: the distortion mesh that fuses a rotation warp with lens distortion and chromatic aberration, so the
 * display image of each eye is produced in one resampling pass (the approach of Monado's and Cardboard's meshes). */
#ifndef WARP_MESH_H
#define WARP_MESH_H

#include <stdbool.h>

#include "warp/warp_camera.h"
#include "warp/warp_image.h"
#include "warp/warp_lens.h"

/* n x n vertices spread evenly over one eye's viewport of the panel, vertex (0,0) at the viewport's top-left
 * corner and (n-1, n-1) at its bottom-right corner. Per vertex and colour channel the mesh holds the lens
 * direction (fixed at start-up) and the source pixel position for the current warp (rebuilt every vsync). */
typedef struct {
    int n;
    int vp_x, vp_y, vp_w, vp_h; /* viewport on the panel, pixels */
    warp_vec2f *tan;            /* [(j*n + i)*3 + c] lens tangent direction (u, v) */
    warp_vec2f *src;            /* [(j*n + i)*3 + c] source pixel position for the current warp */
    int behind;                 /* vertices of the last update that pointed behind the source camera */
} warp_mesh;

/* Allocates the mesh and evaluates the lens at every vertex (start-up only). n must be in [2, 1024].
 * Returns false on bad arguments or out of memory. */
bool warp_mesh_init(warp_mesh *m, int n, const warp_lens *lens, int vp_x, int vp_y, int vp_w, int vp_h);
void warp_mesh_free(warp_mesh *m);

/* Rebuilds the source positions for a rotation warp: a vertex seeing tangent direction t of the target eye
 * samples the source at K_src * src_from_dst * (t, -1). Identity rotation = distortion only (e.g. after a
 * depth warp has already produced the target view). Allocation-free: safe on the vsync path. */
void warp_mesh_update(warp_mesh *m, const warp_camera *src_cam, warp_quat src_from_dst);

#endif

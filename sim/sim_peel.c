/* SPDX-License-Identifier: MIT */
/* sim_peel: a hidden depth layer for the multi-layer warps (001 §3.4): an indoor scene's static room rendered
 * without the objects in front of it, the background layer 001 §4.1 peels "without foreground objects". */
#include "sim/sim_peel.h"

#include <string.h>

#include "sim/sim_internal.h"

/* Field by field: the struct has padding, so memcmp could differ on equal objects. */
static bool same_object(const sim_object *a, const sim_object *b)
{
    if (a->prim != b->prim || a->tex != b->tex || a->alpha != b->alpha || a->freq_hz != b->freq_hz ||
        a->phase != b->phase)
        return false;
    for (int i = 0; i < 3; i++)
        if (a->size[i] != b->size[i] || a->rgb[i] != b->rgb[i] || a->pos[i] != b->pos[i] ||
            a->ypr_deg[i] != b->ypr_deg[i] || a->vel[i] != b->vel[i] || a->amp[i] != b->amp[i] ||
            a->spin_dps[i] != b->spin_dps[i])
            return false;
    return true;
}

const sim_scene *sim_peel_background(const sim_scene *s)
{
    const sim_scene *room = sim_scene_find("room");
    if (!s || !room || s == room) return NULL;
    int n = sim_scene_nobjects(room);
    if (sim_scene_nobjects(s) <= n) return NULL;
    for (int k = 0; k < n; k++) {
        sim_object a, b;
        sim_scene_object(s, k, &a);
        sim_scene_object(room, k, &b);
        if (!same_object(&a, &b)) return NULL;
    }
    return room;
}

bool sim_peel_render_rows(const sim_scene *s, double t, warp_pose eye, const warp_camera *cam, unsigned planes,
                          sim_buffers *b, int y0, int y1)
{
    const sim_scene *bg = sim_peel_background(s);
    if (!bg) return false;
    /* the room's shading is view-independent and identical in every scene built on it, so its pixels match
     * the full scene's wherever no foreground object is in front */
    sim_render_rows(bg, t, eye, cam, planes, b, y0, y1);
    return true;
}

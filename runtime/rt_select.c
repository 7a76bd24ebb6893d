/* SPDX-License-Identifier: MIT */
/* rt_select: which warp each vsync runs: the cheapest one whose predicted error stays under a pixel budget, given
 * the head motion the frame must bridge, the nearest depth in it (004 eqs. 5-7), its planes and the time left. */
#include "runtime/rt_select.h"

#include <math.h>

#include "warp/warp_forward.h"
#include "warp/warp_registry.h"

/* Per reason its --stats key (select_KEY) and its summary text: one table, indexed by rt_select_why. */
static const struct {
    const char *key, *text;
} whys[] = {
    [RT_WHY_CONFIGURED] = {"configured", "configured"},
    [RT_WHY_NO_FRAME] = {"no_frame", "no frame yet"},
    [RT_WHY_ROTATION_ONLY] = {"rotation_only", "no depth in the frame"},
    [RT_WHY_PARALLAX_SMALL] = {"parallax_small", "parallax under budget"},
    [RT_WHY_PARALLAX] = {"parallax", "parallax"},
    [RT_WHY_TRANSPARENCY] = {"transparency", "transparent layers"},
    [RT_WHY_OBJECT_MOTION] = {"object_motion", "object motion"},
    [RT_WHY_HELD] = {"held", "held (hysteresis)"},
    [RT_WHY_TIME_BUDGET] = {"time_budget", "time budget"},
};
_Static_assert(sizeof whys / sizeof whys[0] == RT_WHY_COUNT, "a key and a text per reason");

const char *rt_select_why_key(rt_select_why w) { return w >= 0 && w < RT_WHY_COUNT ? whys[w].key : "?"; }

const char *rt_select_why_str(rt_select_why w) { return w >= 0 && w < RT_WHY_COUNT ? whys[w].text : "?"; }

rt_select_params rt_select_default_params(void)
{
    rt_select_params p = {0.5, 0.3, 45};
    return p;
}

void rt_select_init(rt_select *s, const rt_select_params *p, const warp_camera *cam)
{
    s->p = *p;
    s->cam = *cam;
    s->current = RT_METHOD_ROTATION;
    s->calm = 0;
    s->last_px = 0;
}

double rt_select_parallax_px(const warp_camera *cam, double translation_m, double inv_depth_max)
{
    if (!(translation_m > 0) || !(inv_depth_max > 0)) return 0;
    /* 004 eqs. 5-7 (warp_forward); a translation reaching the nearest surface has no bound: say "a lot" but stay
     * finite for the hysteresis arithmetic. */
    double p = warp_fwd_pixel_bound_camera(cam, translation_m, 1.0 / inv_depth_max);
    return isfinite(p) ? p : 1e6;
}

/* A method "escalates" over another when the registry ranks it dearer (and more capable). */
static int rank(rt_method m) { return warp_method_get(rt_method_warp(m))->cost_rank; }

/* One rung down the registry's fallback ladder, towards rotation. */
static rt_method cheaper(rt_method m) { return (rt_method)warp_method_get(rt_method_warp(m))->fallback; }

rt_method rt_select_choose(rt_select *s, rt_method configured, const rt_select_input *in, rt_select_why *why)
{
    if (configured != RT_METHOD_AUTO) {
        *why = RT_WHY_CONFIGURED;
        return configured;
    }
    if (!in->have_frame) {
        *why = RT_WHY_NO_FRAME;
        return RT_METHOD_ROTATION;
    }
    if (!in->has_depth) {
        /* Nothing but rotation can be done with colour alone; no state to keep. */
        s->current = RT_METHOD_ROTATION;
        s->calm = 0;
        *why = RT_WHY_ROTATION_ONLY;
        return RT_METHOD_ROTATION;
    }
    double px = rt_select_parallax_px(&s->cam, in->translation_m, in->inv_depth_max);
    s->last_px = px;
    /* The depth warp for parallax: raytrace_mesh, as accurate as the per-pixel raytrace (per pixel where depth is
     * discontinuous, 000 §3) at a fraction of its cost; the GPU draws its per-pixel raytrace for it (registry). */
    rt_method want = px > s->p.pixel_budget ? RT_METHOD_RAYTRACE_MESH : RT_METHOD_ROTATION;
    rt_select_why w = px > s->p.pixel_budget ? RT_WHY_PARALLAX : RT_WHY_PARALLAX_SMALL;
    /* Moving objects need their own matrices whatever the head does (002 §3.2); transparent layers need their own
     * warp once the head translates enough to move them against the surface behind (000 §5.3). */
    if (in->objects_moving) {
        want = RT_METHOD_OBJECTS;
        w = RT_WHY_OBJECT_MOTION;
    } else if (want == RT_METHOD_RAYTRACE_MESH && in->has_layers) {
        want = RT_METHOD_TRANSPARENCY;
        w = RT_WHY_TRANSPARENCY;
    }

    /* Escalate at once (an error now is visible now); de-escalate only after the prediction has stayed well under
     * the budget for a while, so steady motion near the threshold does not flicker between warps. */
    if (rank(want) > rank(s->current)) {
        s->current = want;
        s->calm = 0;
    } else if (rank(want) < rank(s->current)) {
        if (px < s->p.pixel_budget * (1 - s->p.hysteresis))
            s->calm++;
        else
            s->calm = 0;
        if (s->calm >= s->p.hold_vsyncs) {
            s->current = want;
            s->calm = 0;
        } else {
            w = RT_WHY_HELD;
        }
    } else {
        s->calm = 0;
    }
    rt_method m = s->current;
    /* Short of time: the cheaper warp now beats a missed vsync (which would show a stale frame unwarped). The state
     * keeps the preferred method, so the next vsync with time to spare returns to it. */
    /* Step down the registry's ladder (objects/transparency -> raytrace -> raytrace_mesh -> rotation) until the
     * estimate fits. */
    while (cheaper(m) != m && in->cost_ns[m] > 0 && in->cost_ns[m] > in->time_left_ns) {
        m = cheaper(m);
        w = RT_WHY_TIME_BUDGET;
    }
    *why = w;
    return m;
}

/* SPDX-License-Identifier: MIT */
/* rt_simboard: the simulated board as one part: the scene, the true head motion, the simulated host's render
 * counters and the accuracy evaluator. A run creates it only when some device is simulated; real boards never do. */
#include "runtime/rt_simboard.h"

#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "drivers/drv_sim.h"
#include "sim/sim_scene.h"
#include "warp/warp_err.h"

struct rt_simboard {
    const sim_scene *scene;
    sim_trace trace;
    int64_t t0_ns;
    uint64_t plane_renders[5];
    uint64_t host_frames;
    rt_eval eval;
    pthread_t eval_th;
    bool eval_up;
};

rt_simboard *rt_simboard_create(const rt_config *c, char *err, int errlen)
{
    char list[512];
    const sim_scene *scene = sim_scene_find(c->scene);
    if (!scene) {
        rt_config_join_names(sim_scene_names(), list, sizeof list);
        warp_err(err, errlen, "[sim] scene = '%s': unknown scene (available: %s)", c->scene, list);
        return NULL;
    }
    sim_trace trace;
    if (!sim_trace_init(&trace, c->trace, c->seed)) {
        rt_config_join_names(sim_trace_names(), list, sizeof list);
        warp_err(err, errlen, "[sim] trace = '%s': unknown trace (available: %s)", c->trace, list);
        return NULL;
    }
    trace.head.ipd = c->ipd;
    rt_simboard *sb = calloc(1, sizeof *sb);
    /* the evaluator's ring whether or not it runs: the vsync path never allocates, and 64 records are small */
    if (!sb || !rt_ring_alloc(&sb->eval.ring, sizeof(rt_eval_record), 64)) {
        free(sb);
        warp_err(err, errlen, "the simulated board: out of memory");
        return NULL;
    }
    sb->scene = scene;
    sb->trace = trace;
    return sb;
}

void rt_simboard_destroy(rt_simboard **sb)
{
    if (!sb || !*sb) return;
    rt_ring_free(&(*sb)->eval.ring);
    free(*sb);
    *sb = NULL;
}

const sim_scene *rt_simboard_scene(const rt_simboard *sb) { return sb->scene; }
const sim_trace *rt_simboard_trace(const rt_simboard *sb) { return &sb->trace; }
void rt_simboard_set_origin(rt_simboard *sb, int64_t t0_ns) { sb->t0_ns = t0_ns; }

double rt_simboard_orientation_error_deg(const rt_simboard *sb, int64_t t_ns, warp_quat q)
{
    warp_quat truth = sim_trace_orientation(&sb->trace, (double)(t_ns - sb->t0_ns) * 1e-9);
    return warp_quat_angle_between(truth, q) * 180 / WARP_PI;
}

const char *rt_simboard_scene_effects(const rt_simboard *sb, char *buf, int buflen)
{
    return sim_effects_str(sim_scene_effects(sb->scene), buf, buflen);
}

void rt_simboard_collect_host(rt_simboard *sb, const rt_devices *d)
{
    if (!d->sim_host || !d->frames) return;
    drv_frames_sim_stats st;
    drv_frames_sim_stats_get(d->frames, &st);
    _Static_assert(sizeof st.plane_renders == sizeof sb->plane_renders, "one counter per simulated plane");
    sb->host_frames = st.frames;
    memcpy(sb->plane_renders, st.plane_renders, sizeof st.plane_renders);
}

const uint64_t *rt_simboard_plane_renders(const rt_simboard *sb) { return sb->plane_renders; }
uint64_t rt_simboard_host_frames(const rt_simboard *sb) { return sb->host_frames; }

rt_eval *rt_simboard_eval(rt_simboard *sb) { return &sb->eval; }

bool rt_simboard_eval_start(rt_simboard *sb, const rt_eval_inputs *in)
{
    sb->eval.in = *in;
    sb->eval.in.scene = sb->scene;
    sb->eval.in.trace = &sb->trace;
    sb->eval_up = pthread_create(&sb->eval_th, NULL, rt_eval_thread, &sb->eval) == 0;
    return sb->eval_up;
}

void rt_simboard_eval_join(rt_simboard *sb)
{
    if (!sb || !sb->eval_up) return;
    pthread_join(sb->eval_th, NULL);
    sb->eval_up = false;
}

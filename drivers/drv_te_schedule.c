/* SPDX-License-Identifier: MIT */
/* drv_te_schedule: TE pulses as a pure function of (seed, k): random access, so the mock's edge thread and the HIL
 * player compute the same pulse for the same slot whatever else they asked for before. */
#include "drivers/drv_te_schedule.h"

#include <math.h>

#include "warp/warp_rand.h"

/* Draw `what` of slot k in [0, 1): independent draws, so a fault's probability never shifts the others. */
enum { DRAW_JITTER = 0, DRAW_MISS = 1, DRAW_GLITCH = 2, DRAW_WHERE = 3 };
static double draw(const drv_te_schedule *s, int64_t k, unsigned what)
{
    uint64_t x = s->seed * 0x100000001b3ULL + (uint64_t)k + (uint64_t)what * 0xd1b54a32d192ed03ULL;
    return warp_unit53(warp_splitmix64(x)); /* a well-mixed value per input: per-slot draws need no state */
}

drv_te_schedule drv_te_schedule_clean(double period_ns, uint64_t seed)
{
    return (drv_te_schedule){.period_ns = period_ns, .stop_at_ns = INT64_MAX, .stop_to_ns = INT64_MAX,
                             .jump_at_ns = INT64_MAX, .seed = seed};
}

int64_t drv_te_schedule_slot(const drv_te_schedule *s, int64_t k)
{
    int64_t t = llround((double)k * s->period_ns);
    if (t >= s->jump_at_ns) t += s->jump_ns;
    return t;
}

bool drv_te_schedule_pulse(const drv_te_schedule *s, int64_t k, int64_t *at)
{
    int64_t t = drv_te_schedule_slot(s, k);
    if (s->jitter_ns > 0) t += llround((2 * draw(s, k, DRAW_JITTER) - 1) * s->jitter_ns);
    *at = t;
    if (t >= s->stop_at_ns && t < s->stop_to_ns) return false;
    return !(s->miss_prob > 0 && draw(s, k, DRAW_MISS) < s->miss_prob);
}

bool drv_te_schedule_glitch(const drv_te_schedule *s, int64_t k, int64_t *at)
{
    if (!(s->spurious_prob > 0) || draw(s, k, DRAW_GLITCH) >= s->spurious_prob) return false;
    int64_t t = drv_te_schedule_slot(s, k) + llround((0.1 + 0.8 * draw(s, k, DRAW_WHERE)) * s->period_ns);
    *at = t;
    return !(t >= s->stop_at_ns && t < s->stop_to_ns);
}

/* SPDX-License-Identifier: MIT */
/* rt_fusion: Mahony-style complementary filter (gyro integration, accelerometer tilt correction, gyro bias from the
 * tilt error and from stillness), published into a lock-free seqlock history ring for pose lookup and prediction. */
#include "runtime/rt_fusion.h"

#include <math.h>
#include <string.h>

#define RT_FUSION_G 9.81                    /* m/s^2: what the accelerometer reads at rest */
#define RT_FUSION_MAX_GYRO 70.0             /* rad/s (~4000 deg/s): beyond any head motion, so a corrupt sample */
#define RT_FUSION_MAX_ACCEL (16.0 * RT_FUSION_G)
#define RT_FUSION_MAX_GAP_NS 250000000LL    /* longer gaps are not integrated across (the gyro was not watching) */
/* After the first still_time of a still period the bias follows the raw gyro with this time constant: long enough
 * to average the noise well below the yaw budget, short enough to follow thermal drift of the bias. */
#define RT_FUSION_STILL_LP_TAU 10.0
/* MEMS gyro biases are well below this; the clamp only stops the integral term winding up on bad accel data. */
#define RT_FUSION_MAX_BIAS 0.35
#define RT_FUSION_MASK ((uint64_t)RT_FUSION_HISTORY - 1)

_Static_assert((RT_FUSION_HISTORY & (RT_FUSION_HISTORY - 1)) == 0, "RT_FUSION_HISTORY must be a power of two");

rt_fusion_params rt_fusion_default_params(void)
{
    rt_fusion_params p = {
        .tilt_gain = 0.5,
        .bias_gain = 0.02,
        .accel_tolerance = 1.0,
        .still_gyro = 0.05,
        .still_time = 0.5,
        .max_prediction = 0.1,
        .lever_arm = {0.0, 0.0, 0.0},
        .max_centripetal = 2.0,
    };
    return p;
}

const char *rt_fusion_result_str(rt_fusion_result r)
{
    switch (r) {
    case RT_FUSION_OK: return "ok";
    case RT_FUSION_BAD_VALUE: return "bad value";
    case RT_FUSION_TIME_REPEAT: return "time repeat";
    case RT_FUSION_TIME_JUMP: return "time jump";
    default: return "unknown";
    }
}

/* ---- seqlock payload copies ----
 * A seqlock reader may copy the payload while the writer overwrites it; with plain accesses that is a data race
 * (undefined in C11, reported by TSan) even though the torn copy is thrown away. Copying field by field with relaxed
 * atomics (GNU __atomic builtins, which accept plain doubles) makes it race-free at no cost on 64-bit targets. */
#define RT_FUSION_STATE_FIELDS(X) \
    X(t_ns) X(q.w) X(q.x) X(q.y) X(q.z) X(omega.x) X(omega.y) X(omega.z) X(bias.x) X(bias.y) X(bias.z)
/* A field added to rt_fusion_state without adding it to the list above would be published torn or not at all. */
_Static_assert(sizeof(rt_fusion_state) == 11 * 8, "update RT_FUSION_STATE_FIELDS with rt_fusion_state");

static void state_store_relaxed(rt_fusion_state *dst, const rt_fusion_state *src)
{
/* via a non-const copy: clang's generic __atomic_store rejects a pointer to const as its source */
#define RT_STORE(fld) { __typeof__(dst->fld) v_ = src->fld; __atomic_store(&dst->fld, &v_, __ATOMIC_RELAXED); }
    RT_FUSION_STATE_FIELDS(RT_STORE)
#undef RT_STORE
}

static void state_load_relaxed(rt_fusion_state *dst, const rt_fusion_state *src)
{
#define RT_LOAD(fld) __atomic_load(&src->fld, &dst->fld, __ATOMIC_RELAXED);
    RT_FUSION_STATE_FIELDS(RT_LOAD)
#undef RT_LOAD
}

/* Slot sequence numbers carry the index they hold: 2i+1 while index i is being written, 2i+2 once complete.
 * A reader therefore knows, without any ABA risk, whether a slot still holds the index it wants. */
static void publish(rt_fusion *f)
{
    uint64_t i = atomic_load_explicit(&f->head, memory_order_relaxed); /* only this thread writes head */
    rt_fusion_slot *sl = &f->hist[i & RT_FUSION_MASK];
    atomic_store_explicit(&sl->seq, 2 * i + 1, memory_order_relaxed);
    atomic_thread_fence(memory_order_release); /* the odd seq is visible before any payload store */
    state_store_relaxed(&sl->st, &f->cur);
    atomic_store_explicit(&sl->seq, 2 * i + 2, memory_order_release);
    atomic_store_explicit(&f->head, i + 1, memory_order_release);
}

/* Copies history index i; false when its slot has been (or is being) reused for a newer index. Never waits: for an
 * index below head the only way to fail is being overwritten, and retrying the same index could not help. */
static bool read_slot(const rt_fusion *f, uint64_t i, rt_fusion_state *out)
{
    const rt_fusion_slot *sl = &f->hist[i & RT_FUSION_MASK];
    const uint64_t want = 2 * i + 2;
    if (atomic_load_explicit(&sl->seq, memory_order_acquire) != want) return false;
    state_load_relaxed(out, &sl->st);
    atomic_thread_fence(memory_order_acquire); /* payload loads complete before the re-check */
    return atomic_load_explicit(&sl->seq, memory_order_relaxed) == want;
}

/* p may be NULL for the defaults. Not safe against concurrent readers: call before starting them. */
void rt_fusion_init(rt_fusion *f, const rt_fusion_params *p)
{
    f->p = p ? *p : rt_fusion_default_params();
    memset(&f->cur, 0, sizeof f->cur);
    f->cur.q = warp_quat_identity();
    f->have_sample = false;
    f->bias_known = false;
    f->alpha = warp_v3(0, 0, 0);
    f->still_for = 0;
    f->still_mean = warp_v3(0, 0, 0);
    f->still_n = 0;
    for (int i = 0; i < RT_FUSION_ERR_COUNT; i++) atomic_init(&f->rejected[i], 0);
    atomic_init(&f->head, 0);
    for (int i = 0; i < RT_FUSION_HISTORY; i++) {
        atomic_init(&f->hist[i].seq, 0); /* 0 matches no index (index i completes as 2i+2) */
        memset(&f->hist[i].st, 0, sizeof f->hist[i].st);
    }
}

/* Yaw-free orientation whose head-frame up is `up`: q = Rx(pitch) * Rz(roll), i.e. warp_quat_from_ypr(0, p, r).
 * Its world up expressed in the head is (cos p sin r, cos p cos r, -sin p), solved for p and r below; forward
 * (-Z) maps to (0, sin p, -cos p), in the world's vertical Y-Z plane, so the start heading is exactly yaw 0. */
static warp_quat tilt_from_up(warp_vec3 up)
{
    double n = warp_v3_norm(up);
    if (!(n > 1e-9)) return warp_quat_identity(); /* free fall or a dead sensor: upright is the best guess */
    up = warp_v3_scale(up, 1.0 / n);
    double pitch = atan2(-up.z, hypot(up.x, up.y));
    double roll = atan2(up.x, up.y); /* atan2(0, 0) = 0: looking straight up/down, roll and yaw are one angle */
    return warp_quat_from_ypr(0.0, pitch, roll);
}

static double clamp(double v, double lo, double hi) { return v < lo ? lo : v > hi ? hi : v; }

static void stillness_reset(rt_fusion *f)
{
    f->still_for = 0;
    f->still_n = 0;
    f->still_mean = warp_v3(0, 0, 0);
}

static bool sample_values_ok(warp_vec3 g, warp_vec3 a)
{
    if (!warp_v3_isfinite(g) || !warp_v3_isfinite(a)) return false;
    return warp_v3_norm(g) <= RT_FUSION_MAX_GYRO && warp_v3_norm(a) <= RT_FUSION_MAX_ACCEL;
}

static rt_fusion_result reject(rt_fusion *f, rt_fusion_result why)
{
    atomic_fetch_add_explicit(&f->rejected[why], 1, memory_order_relaxed);
    return why;
}

rt_fusion_result rt_fusion_update(rt_fusion *f, const drv_imu_sample *s)
{
    const rt_fusion_params *p = &f->p;
    warp_vec3 g = warp_v3(s->gyro[0], s->gyro[1], s->gyro[2]);
    warp_vec3 a = warp_v3(s->accel[0], s->accel[1], s->accel[2]);
    if (!sample_values_ok(g, a)) return reject(f, RT_FUSION_BAD_VALUE);

    if (!f->have_sample) {
        f->cur.t_ns = s->t_ns;
        f->cur.q = tilt_from_up(a);
        f->cur.bias = warp_v3(0, 0, 0);
        f->cur.omega = g;
        f->have_sample = true;
        stillness_reset(f);
        publish(f);
        return RT_FUSION_OK;
    }
    if (s->t_ns <= f->cur.t_ns) return reject(f, RT_FUSION_TIME_REPEAT);
    /* Unsigned difference: exact for t > prev, with no signed overflow on absurd timestamps. */
    uint64_t gap_ns = (uint64_t)s->t_ns - (uint64_t)f->cur.t_ns;
    if (gap_ns > (uint64_t)RT_FUSION_MAX_GAP_NS) {
        /* Unknown motion in the gap: keep q (the tilt correction re-levels it), restart integration and the
         * stillness window from this sample. Counted, but the sample is used. */
        f->cur.t_ns = s->t_ns;
        f->cur.omega = warp_v3_sub(g, f->cur.bias);
        f->alpha = warp_v3(0, 0, 0);
        stillness_reset(f);
        publish(f);
        return reject(f, RT_FUSION_TIME_JUMP);
    }
    const double dt = (double)gap_ns * 1e-9;
    /* Midpoint (trapezoid) of the previous and current raw rates over the interval: exact for constant rotation. */
    const warp_vec3 g_mid = warp_v3_scale(warp_v3_add(warp_v3_add(f->cur.omega, f->cur.bias), g), 0.5);

    /* Tilt error in the head frame, e = up_measured x up_predicted (unit vectors, |e| = sin of the error), with
     * the prediction propagated to this sample's time first: against the previous q, a turning head would show a
     * spurious error of one sample's rotation and the filter would drag the estimate behind. Sign: an estimate
     * rotated by +d about head X from the truth predicts up = (0, cos d, -sin d), so e = (-sin d, 0, 0) and adding
     * +tilt_gain * e to omega turns it back. Only trusted near 1 g (no linear acceleration). */
    /* The accelerometer sits a lever arm r away from the neck pivot, so turning adds w x (w x r) (centripetal;
     * 3 m/s^2 at 300 deg/s and 11 cm: a 17 degree error in "up") and a x r (tangential, as large while a burst
     * starts or stops). Both follow from the gyro, so subtract them before reading gravity. Angular acceleration
     * is the gyro's derivative, low-passed (10 ms) because differencing 1 kHz noise is loud. */
    const warp_vec3 w_now = warp_v3_sub(g, f->cur.bias);
    const warp_vec3 w_prev = f->cur.omega;
    const double k_lp = dt / (dt + 0.01);
    f->alpha = warp_v3_add(f->alpha, warp_v3_scale(warp_v3_sub(warp_v3_scale(warp_v3_sub(w_now, w_prev), 1.0 / dt),
                                                               f->alpha), k_lp));
    const warp_vec3 r = p->lever_arm;
    const warp_vec3 a_rot = warp_v3_add(warp_v3_cross(w_now, warp_v3_cross(w_now, r)), warp_v3_cross(f->alpha, r));
    a = warp_v3_sub(a, a_rot);
    const double an = warp_v3_norm(a);
    const bool accel_ok = fabs(an - RT_FUSION_G) < p->accel_tolerance;
    /* Very fast turns make the compensation itself uncertain (lever arm, alpha lag): then trust only the gyro,
     * as Monado corrects tilt only near rest. */
    const double w_rate = warp_v3_norm(w_now);
    const bool slow = w_rate * w_rate * warp_v3_norm(r) < p->max_centripetal;
    warp_vec3 e = warp_v3(0, 0, 0);
    if (accel_ok && slow) {
        warp_vec3 step = warp_v3_scale(warp_v3_sub(g_mid, f->cur.bias), dt);
        warp_quat q_pred = warp_quat_mul(f->cur.q, warp_quat_exp(step));
        warp_vec3 up_meas = warp_v3_scale(a, 1.0 / an);
        warp_vec3 up_pred = warp_quat_rotate(warp_quat_conj(q_pred), warp_v3(0, 1, 0));
        e = warp_v3_cross(up_meas, warp_v3_scale(up_pred, 1.0 / warp_v3_norm(up_pred)));
    }

    /* Stillness: the accelerometer cannot see yaw, so the vertical part of the bias is only observable by
     * holding still. The raw gyro mean over a still period is the bias on all three axes. "Steady accelerometer"
     * is the same near-1 g gate as the tilt correction; a turn slower than still_gyro about the vertical alone is
     * indistinguishable from bias for still_time and gets learned, then unlearned at the next real stop. */
    bool learned = false;
    if (accel_ok && warp_v3_norm(warp_v3_sub(g, f->cur.bias)) < p->still_gyro) {
        f->still_for += dt;
        f->still_n += 1;
        /* exact running mean at first, then an exponential low-pass so the estimate keeps tracking drift */
        double w = fmax(1.0 / f->still_n, dt / RT_FUSION_STILL_LP_TAU);
        f->still_mean = warp_v3_add(f->still_mean, warp_v3_scale(warp_v3_sub(g, f->still_mean), w));
        if (f->still_for >= p->still_time) {
            f->cur.bias = f->still_mean;
            learned = true;
            f->bias_known = true;
        }
    } else {
        stillness_reset(f);
    }
    /* Integral term. A gyro reading high by b (bias estimate too low) about head X lets the estimate drift by +d,
     * which gives e = (-d, 0, 0) as above: so bias -= Ki e dt raises the estimate towards b. Superseded while
     * the stillness estimate is active (it also covers yaw, and is noise-averaged). */
    if (accel_ok && slow && !learned) f->cur.bias = warp_v3_sub(f->cur.bias, warp_v3_scale(e, p->bias_gain * dt));
    f->cur.bias = warp_v3(clamp(f->cur.bias.x, -RT_FUSION_MAX_BIAS, RT_FUSION_MAX_BIAS),
                          clamp(f->cur.bias.y, -RT_FUSION_MAX_BIAS, RT_FUSION_MAX_BIAS),
                          clamp(f->cur.bias.z, -RT_FUSION_MAX_BIAS, RT_FUSION_MAX_BIAS));

    const warp_vec3 omega = warp_v3_sub(g, f->cur.bias);
    warp_vec3 w_step = warp_v3_add(warp_v3_sub(g_mid, f->cur.bias), warp_v3_scale(e, p->tilt_gain));
    /* Boot calibration: a headset that lies still from power-on has not turned, whatever the not-yet-measured
     * bias makes the gyro say. Integrating it would leave a yaw offset that gravity can never correct, so until
     * the first stillness estimate only the tilt correction moves the orientation. */
    if (!f->bias_known && f->still_for > 0) {
        /* Still at boot: nothing but gravity moves the accelerometer, so level quickly (10x gain) instead of
         * keeping the single noisy first sample's tilt for seconds. */
        w_step = warp_v3_scale(e, 10 * p->tilt_gain);
    }
    warp_quat q;
    /* Renormalise every step: rounding would otherwise random-walk |q| over hours of 1 kHz steps. Inputs are
     * validated, so failure is unreachable; keeping the old q is the safe answer if it ever happens. */
    if (warp_quat_normalize(warp_quat_mul(f->cur.q, warp_quat_exp(warp_v3_scale(w_step, dt))), &q)) f->cur.q = q;
    /* omega excludes the tilt correction: it is the head's rate, which is what prediction must extrapolate. */
    f->cur.omega = omega;
    f->cur.t_ns = s->t_ns;
    publish(f);
    return RT_FUSION_OK;
}

bool rt_fusion_latest(const rt_fusion *f, rt_fusion_state *out)
{
    for (;;) { /* fails again only if the writer laps the whole ring during one copy */
        uint64_t h = atomic_load_explicit(&f->head, memory_order_acquire);
        if (h == 0) return false;
        if (read_slot(f, h - 1, out)) return true;
    }
}

/* (a - b) in seconds without signed overflow for absurd inputs (they end up clamped anyway). */
static double ns_diff_s(int64_t a, int64_t b)
{
    int64_t d;
    if (__builtin_sub_overflow(a, b, &d)) return a > b ? 1e10 : -1e10;
    return (double)d * 1e-9;
}

warp_quat rt_fusion_predict(const rt_fusion *f, const rt_fusion_state *st, int64_t t_ns)
{
    double dt = clamp(ns_diff_s(t_ns, st->t_ns), -f->p.max_prediction, f->p.max_prediction);
    warp_quat q;
    warp_quat_normalize(warp_quat_mul(st->q, warp_quat_exp(warp_v3_scale(st->omega, dt))), &q);
    return q;
}

bool rt_fusion_at(const rt_fusion *f, int64_t t_ns, warp_quat *out)
{
    /* Each pass works on one snapshot of head; a pass is abandoned only if the writer overwrote entries the
     * search still needs (it lapped the ring meanwhile), and then the next pass starts from the new head. */
    for (;;) {
        uint64_t h = atomic_load_explicit(&f->head, memory_order_acquire);
        if (h == 0) return false;
        uint64_t hi = h - 1, lo = h > RT_FUSION_HISTORY ? h - RT_FUSION_HISTORY : 0;
        rt_fusion_state st_hi, st_lo, st_mid;
        if (!read_slot(f, hi, &st_hi)) continue;
        if (t_ns >= st_hi.t_ns) {
            *out = rt_fusion_predict(f, &st_hi, t_ns);
            return true;
        }
        /* The oldest slot is the one the writer reuses next, so it may be gone already: step to newer ones. */
        while (lo < hi && !read_slot(f, lo, &st_lo)) lo++;
        if (lo == hi) continue;
        if (t_ns < st_lo.t_ns) {
            *out = st_lo.q;
            return true;
        }
        /* invariant: st_lo.t_ns <= t_ns < st_hi.t_ns (timestamps strictly increase with the index) */
        bool lapped = false;
        while (hi - lo > 1) {
            uint64_t mid = lo + (hi - lo) / 2;
            if (!read_slot(f, mid, &st_mid)) {
                lapped = true;
                break;
            }
            if (st_mid.t_ns <= t_ns) {
                lo = mid;
                st_lo = st_mid;
            } else {
                hi = mid;
                st_hi = st_mid;
            }
        }
        if (lapped) continue;
        /* unsigned differences: exact, and neighbours across a time jump can be arbitrarily far apart */
        double span = (double)((uint64_t)st_hi.t_ns - (uint64_t)st_lo.t_ns);
        double frac = (double)((uint64_t)t_ns - (uint64_t)st_lo.t_ns) / span;
        *out = warp_quat_slerp(st_lo.q, st_hi.q, frac);
        return true;
    }
}

uint64_t rt_fusion_rejected(const rt_fusion *f, rt_fusion_result why)
{
    if ((int)why < 0 || why >= RT_FUSION_ERR_COUNT) return 0;
    return atomic_load_explicit(&f->rejected[why], memory_order_relaxed);
}

/* SPDX-License-Identifier: MIT */
/* Unit tests for rt_fusion: filter accuracy on synthetic IMU data (bias, noise, rotation), prediction, the pose
 * history, sample rejection, long-run stability and torn-read freedom of the lock-free readers. */
#include <math.h>
#include <pthread.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "runtime/rt_fusion.h"
#include "sim/sim_trace.h"
#include "tests/support/test_util.h"
#include "warp/warp_math.h"

#define MS 1000000LL
#define T0 1000000000000LL /* 1000 s of uptime: real CLOCK_MONOTONIC stamps are large numbers */
#define DEG (WARP_PI / 180.0)
#define G 9.81

/* ---- synthetic IMU: piecewise-constant head-frame angular velocity from a known start orientation ---- */

#define SIM_MAX_SEG 8
typedef struct {
    int nseg;
    double seg_t[SIM_MAX_SEG];     /* seconds after T0 at which each segment starts */
    warp_vec3 seg_w[SIM_MAX_SEG];  /* head-frame rate in the segment, rad/s */
    warp_quat seg_q[SIM_MAX_SEG];  /* true orientation at the segment start */
    warp_vec3 bias;                /* constant gyro bias added to every sample */
    double gyro_noise, accel_noise;
    test_rng rng;
} sim;

static sim sim_make(warp_quat q0, warp_vec3 w0, warp_vec3 bias, double gyro_noise, double accel_noise, uint64_t seed)
{
    sim s;
    memset(&s, 0, sizeof s);
    s.nseg = 1;
    s.seg_t[0] = 0;
    s.seg_w[0] = w0;
    s.seg_q[0] = q0;
    s.bias = bias;
    s.gyro_noise = gyro_noise;
    s.accel_noise = accel_noise;
    s.rng = test_rng_make(seed);
    return s;
}

static int sim_seg(const sim *s, double t)
{
    int k = 0;
    while (k + 1 < s->nseg && t >= s->seg_t[k + 1]) k++;
    return k;
}

static warp_quat sim_truth_s(const sim *s, double t)
{
    int k = sim_seg(s, t);
    return warp_quat_mul(s->seg_q[k], warp_quat_exp(warp_v3_scale(s->seg_w[k], t - s->seg_t[k])));
}

static double sim_time(int64_t t_ns) { return (double)(t_ns - T0) * 1e-9; }
static warp_quat sim_truth(const sim *s, int64_t t_ns) { return sim_truth_s(s, sim_time(t_ns)); }

/* New segment from t (seconds after T0) with head-frame rate w. */
static void sim_add(sim *s, double t, warp_vec3 w)
{
    assert_true(s->nseg < SIM_MAX_SEG);
    s->seg_q[s->nseg] = sim_truth_s(s, t);
    s->seg_t[s->nseg] = t;
    s->seg_w[s->nseg] = w;
    s->nseg++;
}

/* Rate about the world vertical, expressed in the head frame of the orientation at time t (constant while the
 * head turns about the vertical: R(t) = Ry(wt) R0 = R0 exp(R0^T y wt)). */
static warp_vec3 sim_vertical_rate(const sim *s, double t, double w)
{
    return warp_quat_rotate(warp_quat_conj(sim_truth_s(s, t)), warp_v3(0, w, 0));
}

static double gauss(test_rng *r)
{
    double u1 = 1.0 - test_rng_uniform(r, 0, 1); /* (0, 1]: log stays finite */
    double u2 = test_rng_uniform(r, 0, 1);
    return sqrt(-2.0 * log(u1)) * cos(2.0 * WARP_PI * u2);
}

static drv_imu_sample sim_sample(sim *s, int64_t t_ns)
{
    double t = sim_time(t_ns);
    warp_vec3 w = s->seg_w[sim_seg(s, t)];
    warp_vec3 up = warp_quat_rotate(warp_quat_conj(sim_truth_s(s, t)), warp_v3(0, G, 0));
    drv_imu_sample smp = {.t_ns = t_ns};
    double wv[3] = {w.x + s->bias.x, w.y + s->bias.y, w.z + s->bias.z}, av[3] = {up.x, up.y, up.z};
    for (int i = 0; i < 3; i++) {
        smp.gyro[i] = wv[i] + (s->gyro_noise > 0 ? s->gyro_noise * gauss(&s->rng) : 0);
        smp.accel[i] = av[i] + (s->accel_noise > 0 ? s->accel_noise * gauss(&s->rng) : 0);
    }
    return smp;
}

/* ---- error measures ---- */

/* Angle between the true and estimated head-frame up vectors (what the accelerometer can see). */
static double tilt_err_deg(warp_quat est, warp_quat truth)
{
    warp_vec3 a = warp_quat_rotate(warp_quat_conj(est), warp_v3(0, 1, 0));
    warp_vec3 b = warp_quat_rotate(warp_quat_conj(truth), warp_v3(0, 1, 0));
    return atan2(warp_v3_norm(warp_v3_cross(a, b)), warp_v3_dot(a, b)) / DEG;
}

/* Heading error: twist about the world vertical of the world-frame error rotation est * truth^-1. */
static double yaw_err_deg(warp_quat est, warp_quat truth)
{
    warp_quat e = warp_quat_mul(est, warp_quat_conj(truth));
    if (e.w < 0) e = (warp_quat){-e.w, -e.x, -e.y, -e.z};
    return 2.0 * atan2(e.y, e.w) / DEG;
}

static double err_deg(warp_quat est, warp_quat truth) { return warp_quat_angle_between(est, truth) / DEG; }

static rt_fusion *fusion_new(const rt_fusion_params *p)
{
    rt_fusion *f = malloc(sizeof *f); /* ~400 KB: heap, not the stack */
    assert_non_null(f);
    rt_fusion_init(f, p);
    return f;
}

/* Feeds samples at period_ns from *t_ns (exclusive) up to t_end_ns (inclusive); every one must be accepted. */
static void feed(rt_fusion *f, sim *s, int64_t *t_ns, int64_t t_end_ns, int64_t period_ns)
{
    while (*t_ns + period_ns <= t_end_ns) {
        *t_ns += period_ns;
        drv_imu_sample smp = sim_sample(s, *t_ns);
        assert_int_equal(rt_fusion_update(f, &smp), RT_FUSION_OK);
    }
}

static void feed_first(rt_fusion *f, sim *s, int64_t t_ns)
{
    drv_imu_sample smp = sim_sample(s, t_ns);
    assert_int_equal(rt_fusion_update(f, &smp), RT_FUSION_OK);
}

/* A filter with parameters p (NULL: the defaults) that has taken s's first sample at T0; *t is that time. */
static rt_fusion *fusion_started(const rt_fusion_params *p, sim *s, int64_t *t)
{
    rt_fusion *f = fusion_new(p);
    *t = T0;
    feed_first(f, s, *t);
    return f;
}

/* f reset to parameters p and started again on s's first sample at T0, for a second run over the same data. */
static void fusion_restart(rt_fusion *f, const rt_fusion_params *p, sim *s, int64_t *t)
{
    rt_fusion_init(f, p);
    *t = T0;
    feed_first(f, s, *t);
}

static rt_fusion_state latest(const rt_fusion *f)
{
    rt_fusion_state st;
    assert_true(rt_fusion_latest(f, &st));
    return st;
}

static bool quat_close(warp_quat a, warp_quat b, double tol)
{
    return fabs(a.w - b.w) <= tol && fabs(a.x - b.x) <= tol && fabs(a.y - b.y) <= tol && fabs(a.z - b.z) <= tol;
}

static const warp_vec3 k_bias = {0.02, -0.015, 0.01};

/* The headset lying still, pitched 10 and rolled 20 degrees, with gyro bias k_bias and light noise from seed: the
 * start of the tests of what the filter learns at rest. */
static sim sim_still_tilted(uint64_t seed)
{
    return sim_make(warp_quat_from_ypr(0, 10 * DEG, 20 * DEG), warp_v3(0, 0, 0), k_bias, 0.005, 0.02, seed);
}

/* ---- tests ---- */

static void test_defaults_and_names(void **state)
{
    (void)state;
    rt_fusion_params p = rt_fusion_default_params();
    assert_true(p.tilt_gain == 0.5 && p.bias_gain == 0.02 && p.accel_tolerance == 1.0);
    assert_true(p.still_gyro == 0.05 && p.still_time == 0.5 && p.max_prediction == 0.1);
    assert_string_equal(rt_fusion_result_str(RT_FUSION_OK), "ok");
    assert_string_equal(rt_fusion_result_str(RT_FUSION_BAD_VALUE), "bad value");
    assert_string_equal(rt_fusion_result_str(RT_FUSION_TIME_REPEAT), "time repeat");
    assert_string_equal(rt_fusion_result_str(RT_FUSION_TIME_JUMP), "time jump");
}

/* The first sample sets the tilt from gravity with yaw 0: for a yaw-0 truth that is the truth itself, including
 * upside down; for any truth the head-frame up matches and forward stays in the world's vertical Y-Z plane. */
static void test_first_sample_tilt(void **state)
{
    (void)state;
    test_rng r = test_rng_make(11);
    rt_fusion *f = fusion_new(NULL);
    for (int i = 0; i < 300; i++) {
        double pitch = test_rng_uniform(&r, -85, 85) * DEG, roll = test_rng_uniform(&r, -179, 179) * DEG;
        double yaw = i % 2 ? test_rng_uniform(&r, -180, 180) * DEG : 0.0;
        warp_quat truth = warp_quat_from_ypr(yaw, pitch, roll);
        sim s = sim_make(truth, warp_v3(0, 0, 0), warp_v3(0, 0, 0), 0, 0, 1);
        rt_fusion_init(f, NULL);
        feed_first(f, &s, T0);
        rt_fusion_state st = latest(f);
        assert_true(fabs(warp_quat_norm(st.q) - 1) < 1e-12);
        assert_true(tilt_err_deg(st.q, truth) < 1e-9);
        warp_vec3 fwd = warp_quat_rotate(st.q, warp_v3(0, 0, -1));
        assert_true(fabs(fwd.x) < 1e-12);
        if (yaw == 0.0) assert_true(err_deg(st.q, truth) < 1e-9);
    }
    free(f);
}

/* 1. Still and tilted with a gyro bias: stillness learning finds the bias on all three axes, so yaw stays put. */
static void test_static_bias_and_yaw(void **state)
{
    (void)state;
    sim s = sim_still_tilted(100);
    int64_t t;
    rt_fusion *f = fusion_started(NULL, &s, &t);
    feed(f, &s, &t, T0 + 30000 * MS, MS);
    rt_fusion_state st = latest(f);
    warp_quat truth = sim_truth(&s, st.t_ns);
    assert_true(tilt_err_deg(st.q, truth) < 0.5);
    assert_true(fabs(yaw_err_deg(st.q, truth)) < 1.0);
    assert_true(fabs(st.bias.x - k_bias.x) < 0.002);
    assert_true(fabs(st.bias.y - k_bias.y) < 0.002);
    assert_true(fabs(st.bias.z - k_bias.z) < 0.002);
    assert_true(fabs(warp_quat_norm(st.q) - 1) < 1e-12);

    /* Without the integral term and without stillness learning the same data drifts in yaw by the vertical part
     * of the bias (~0.009 rad/s here, ~15 deg in 30 s): the estimator, not the data, kept yaw above. */
    rt_fusion_params p = rt_fusion_default_params();
    p.bias_gain = 0;
    p.still_gyro = 0; /* |omega| < 0 never holds: never still */
    s = sim_still_tilted(100);
    fusion_restart(f, &p, &s, &t);
    feed(f, &s, &t, T0 + 30000 * MS, MS);
    st = latest(f);
    truth = sim_truth(&s, st.t_ns);
    assert_true(fabs(yaw_err_deg(st.q, truth)) > 10.0);
    assert_true(st.bias.x == 0 && st.bias.y == 0 && st.bias.z == 0);
    free(f);
}

/* The integral term's sign: with stillness learning off it must converge the bias components the accelerometer
 * can see (perpendicular to up in the head frame) and remove the steady tilt offset a proportional-only filter
 * keeps (|b_perp| / tilt_gain ~ 2.9 deg here). It cannot see yaw, which therefore still drifts. */
static void test_integral_term_converges(void **state)
{
    (void)state;
    sim s = sim_still_tilted(200);
    warp_quat q0 = s.seg_q[0];
    warp_vec3 up = warp_quat_rotate(warp_quat_conj(q0), warp_v3(0, 1, 0));
    warp_vec3 b_perp = warp_v3_sub(k_bias, warp_v3_scale(up, warp_v3_dot(k_bias, up)));
    rt_fusion_params p = rt_fusion_default_params();
    p.still_gyro = 0;
    p.bias_gain = 0.1; /* well damped (poles at -0.25 +- 0.2i per s): settled after 60 s */
    int64_t t;
    rt_fusion *f = fusion_started(&p, &s, &t);
    feed(f, &s, &t, T0 + 60000 * MS, MS);
    rt_fusion_state st = latest(f);
    warp_quat truth = sim_truth(&s, st.t_ns);
    warp_vec3 est_perp = warp_v3_sub(st.bias, warp_v3_scale(up, warp_v3_dot(st.bias, up)));
    assert_true(warp_v3_norm(warp_v3_sub(est_perp, b_perp)) < 0.002);
    assert_true(tilt_err_deg(st.q, truth) < 0.5);
    assert_true(fabs(yaw_err_deg(st.q, truth)) > 10.0);

    p.bias_gain = 0;
    s = sim_still_tilted(200);
    fusion_restart(f, &p, &s, &t);
    feed(f, &s, &t, T0 + 60000 * MS, MS);
    st = latest(f);
    assert_true(tilt_err_deg(st.q, sim_truth(&s, st.t_ns)) > 2.0);
    free(f);
}

/* 2. 5 s still (bias learned), then 10 s turning at 1 rad/s about the vertical with a tilted head. */
static void test_rotation_tracking(void **state)
{
    (void)state;
    warp_quat q0 = warp_quat_from_ypr(0.3, -10 * DEG, 15 * DEG);
    sim s = sim_make(q0, warp_v3(0, 0, 0), warp_v3(0.01, 0.005, -0.008), 0.003, 0.02, 300);
    sim_add(&s, 5.0, sim_vertical_rate(&s, 5.0, 1.0));
    rt_fusion_params p = rt_fusion_default_params();
    int64_t t;
    rt_fusion *f = fusion_started(&p, &s, &t);
    /* the filter starts at yaw 0 while the truth has yaw 0.3: compare from the truth's own yaw frame */
    warp_quat yaw_fix = warp_quat_from_ypr(0.3, 0, 0);
    double worst = 0;
    while (t < T0 + 15000 * MS) {
        feed(f, &s, &t, t + MS, MS);
        rt_fusion_state st = latest(f);
        double e = err_deg(warp_quat_mul(yaw_fix, st.q), sim_truth(&s, t));
        if (e > worst) worst = e;
    }
    assert_true(worst < 1.0);
    /* it really turned: 10 rad about the vertical */
    assert_true(err_deg(sim_truth(&s, t), q0) > 60);
    free(f);
}

/* 3. Constant rotation, noise free: 20 ms prediction matches the truth; requests past max_prediction clamp. */
static void test_prediction(void **state)
{
    (void)state;
    warp_vec3 w = warp_v3(0.4, -1.1, 0.7);
    sim s = sim_make(warp_quat_from_ypr(0, 25 * DEG, -30 * DEG), w, warp_v3(0, 0, 0), 0, 0, 1);
    int64_t t;
    rt_fusion *f = fusion_started(NULL, &s, &t);
    for (int i = 0; i < 20; i++) {
        feed(f, &s, &t, t + 100 * MS, MS);
        rt_fusion_state st = latest(f);
        assert_true(st.t_ns == t);
        /* exact data, exact integrator: any lag (e.g. tilt error taken against the previous step's q, which
         * reads a turning head as tilted by one sample's rotation) would show here long before 0.05 deg */
        assert_true(err_deg(st.q, sim_truth(&s, t)) < 1e-6);
        warp_quat pq = rt_fusion_predict(f, &st, t + 20 * MS);
        assert_true(err_deg(pq, sim_truth(&s, t + 20 * MS)) < 0.05);
        assert_true(fabs(warp_quat_norm(pq) - 1) < 1e-12);
    }
    rt_fusion_state st = latest(f);
    /* 1 s ahead is clamped to max_prediction (0.1 s), in both directions, and to no overflow at the extremes */
    warp_quat far = rt_fusion_predict(f, &st, st.t_ns + 1000 * MS);
    assert_true(quat_close(far, rt_fusion_predict(f, &st, st.t_ns + 100 * MS), 1e-15));
    assert_true(fabs(warp_quat_angle_between(st.q, far) - warp_v3_norm(w) * 0.1) < 1e-6);
    assert_true(err_deg(far, sim_truth(&s, st.t_ns + 1000 * MS)) > 10);
    assert_true(quat_close(rt_fusion_predict(f, &st, st.t_ns - 1000 * MS),
                           rt_fusion_predict(f, &st, st.t_ns - 100 * MS), 1e-15));
    assert_true(quat_close(rt_fusion_predict(f, &st, INT64_MAX), far, 1e-15));
    assert_true(quat_close(rt_fusion_predict(f, &st, st.t_ns), st.q, 1e-15));
    free(f);
}

/* 4. History lookup against states recorded as they were published (irregular sample spacing). */
static void test_history(void **state)
{
    (void)state;
    enum { M = RT_FUSION_HISTORY + 1904 };
    sim s = sim_make(warp_quat_from_ypr(0, 5 * DEG, 5 * DEG), warp_v3(0.3, 0.8, -0.5), warp_v3(0, 0, 0), 0.01, 0.02,
                     400);
    rt_fusion *f = fusion_new(NULL);
    warp_quat q;
    rt_fusion_state st;
    assert_false(rt_fusion_latest(f, &st));
    assert_false(rt_fusion_at(f, T0, &q));
    rt_fusion_state *rec = malloc(M * sizeof *rec);
    assert_non_null(rec);
    test_rng r = test_rng_make(4);
    int64_t t = T0;
    for (int i = 0; i < M; i++) {
        if (i) t += MS - 200000 + (int64_t)test_rng_uniform(&r, 0, 400000); /* 0.8..1.2 ms */
        drv_imu_sample smp = sim_sample(&s, t);
        assert_int_equal(rt_fusion_update(f, &smp), RT_FUSION_OK);
        rec[i] = latest(f);
        assert_true(rec[i].t_ns == t);
        if (i == 99) { /* fewer states than the ring holds: before the first -> the first */
            assert_true(rt_fusion_at(f, T0 - 5 * MS, &q));
            assert_true(quat_close(q, rec[0].q, 0));
        }
    }
    assert_int_equal(atomic_load(&f->head), M);
    const int oldest = M - RT_FUSION_HISTORY;
    for (int n = 0; n < 3000; n++) {
        int k = oldest + (int)test_rng_uniform(&r, 0, RT_FUSION_HISTORY - 1); /* k + 1 <= M - 1 */
        int64_t span = rec[k + 1].t_ns - rec[k].t_ns;
        int64_t off = (int64_t)test_rng_uniform(&r, 0, (double)span);
        assert_true(rt_fusion_at(f, rec[k].t_ns + off, &q));
        warp_quat want = warp_quat_slerp(rec[k].q, rec[k + 1].q, (double)off / (double)span);
        assert_true(quat_close(q, want, 1e-12));
        assert_true(rt_fusion_at(f, rec[k].t_ns, &q)); /* exactly on a sample: that state */
        assert_true(quat_close(q, rec[k].q, 1e-12));
    }
    /* older than the ring keeps: the oldest kept state (rec[oldest]), never an overwritten one */
    assert_true(rt_fusion_at(f, rec[oldest].t_ns - 1, &q));
    assert_true(quat_close(q, rec[oldest].q, 0));
    assert_true(rt_fusion_at(f, rec[0].t_ns, &q));
    assert_true(quat_close(q, rec[oldest].q, 0));
    assert_true(rt_fusion_at(f, INT64_MIN, &q));
    assert_true(quat_close(q, rec[oldest].q, 0));
    /* after the newest: prediction from the newest (clamped further out) */
    const rt_fusion_state *nw = &rec[M - 1];
    int64_t ahead[] = {0, 1, 5 * MS, 20 * MS, 1000 * MS};
    for (size_t i = 0; i < sizeof ahead / sizeof ahead[0]; i++) {
        assert_true(rt_fusion_at(f, nw->t_ns + ahead[i], &q));
        assert_true(quat_close(q, rt_fusion_predict(f, nw, nw->t_ns + ahead[i]), 0));
    }
    assert_true(rt_fusion_at(f, INT64_MAX, &q));
    assert_true(quat_close(q, rt_fusion_predict(f, nw, INT64_MAX), 0));
    st = latest(f);
    assert_memory_equal(&st, nw, sizeof st);
    free(rec);
    free(f);
}

static void assert_state_equal(const rt_fusion *f, const rt_fusion_state *want, uint64_t head)
{
    rt_fusion_state st = latest(f);
    assert_memory_equal(&st, want, sizeof st);
    assert_int_equal(atomic_load(&f->head), head);
}

/* 5. Each kind of bad sample is counted under its reason and changes nothing; filtering then carries on. */
static void test_rejections(void **state)
{
    (void)state;
    warp_quat q0 = warp_quat_from_ypr(0, -15 * DEG, 10 * DEG);
    sim s = sim_make(q0, warp_v3(0, 0, 0), k_bias, 0.002, 0.01, 500);
    rt_fusion *f = fusion_new(NULL);

    /* a bad first sample is not a start */
    drv_imu_sample bad = sim_sample(&s, T0 - MS);
    bad.accel[1] = NAN;
    assert_int_equal(rt_fusion_update(f, &bad), RT_FUSION_BAD_VALUE);
    rt_fusion_state st;
    assert_false(rt_fusion_latest(f, &st));

    int64_t t = T0;
    feed_first(f, &s, t);
    feed(f, &s, &t, T0 + 2000 * MS, MS);
    const rt_fusion_state st0 = latest(f);
    const uint64_t h0 = atomic_load(&f->head);
    const double still_for0 = f->still_for;

    struct { int axis_gyro, i; double v; } bads[] = {
        {1, 0, NAN}, {0, 1, NAN}, {1, 2, INFINITY}, {0, 0, -INFINITY}, {1, 1, 80.0}, {0, 1, 17 * G},
    };
    for (size_t k = 0; k < sizeof bads / sizeof bads[0]; k++) {
        drv_imu_sample smp = sim_sample(&s, t + MS);
        (bads[k].axis_gyro ? smp.gyro : smp.accel)[bads[k].i] = bads[k].v;
        assert_int_equal(rt_fusion_update(f, &smp), RT_FUSION_BAD_VALUE);
        assert_state_equal(f, &st0, h0);
    }
    assert_int_equal(rt_fusion_rejected(f, RT_FUSION_BAD_VALUE), 1 + 6);

    drv_imu_sample rep = sim_sample(&s, t);
    assert_int_equal(rt_fusion_update(f, &rep), RT_FUSION_TIME_REPEAT);
    assert_state_equal(f, &st0, h0);
    rep = sim_sample(&s, t - 3 * MS);
    assert_int_equal(rt_fusion_update(f, &rep), RT_FUSION_TIME_REPEAT);
    assert_state_equal(f, &st0, h0);
    assert_int_equal(rt_fusion_rejected(f, RT_FUSION_TIME_REPEAT), 2);
    assert_true(f->still_for == still_for0);

    /* exactly 0.25 s is still integrated; more is a time jump: used as a restart, q kept as it was */
    t += 250 * MS;
    drv_imu_sample smp = sim_sample(&s, t);
    assert_int_equal(rt_fusion_update(f, &smp), RT_FUSION_OK);
    rt_fusion_state st1 = latest(f);
    t += 250 * MS + 1;
    smp = sim_sample(&s, t);
    assert_int_equal(rt_fusion_update(f, &smp), RT_FUSION_TIME_JUMP);
    assert_int_equal(rt_fusion_rejected(f, RT_FUSION_TIME_JUMP), 1);
    st = latest(f);
    assert_true(st.t_ns == t);
    assert_memory_equal(&st.q, &st1.q, sizeof st.q);
    assert_int_equal(atomic_load(&f->head), h0 + 2);

    /* filtering continues: still for 3 s, then a turn; it stays on the truth */
    sim_add(&s, sim_time(t) + 3.0, sim_vertical_rate(&s, sim_time(t) + 3.0, 0.8));
    int64_t t_end = t + 6000 * MS;
    while (t < t_end) {
        feed(f, &s, &t, t + MS, MS);
        st = latest(f);
        assert_true(err_deg(st.q, sim_truth(&s, t)) < 1.0);
    }
    assert_int_equal(rt_fusion_rejected(f, RT_FUSION_BAD_VALUE), 7);
    assert_int_equal(rt_fusion_rejected(f, RT_FUSION_TIME_REPEAT), 2);
    assert_int_equal(rt_fusion_rejected(f, RT_FUSION_TIME_JUMP), 1);
    assert_int_equal(rt_fusion_rejected(f, RT_FUSION_OK), 0);
    assert_int_equal(rt_fusion_rejected(f, RT_FUSION_ERR_COUNT), 0);
    free(f);
}

/* 6. Two hours still (at 100 Hz to keep it quick): |q| stays 1 and the orientation does not wander. */
static void test_hours(void **state)
{
    (void)state;
    sim s = sim_still_tilted(600);
    warp_quat q0 = s.seg_q[0];
    int64_t t;
    rt_fusion *f = fusion_started(NULL, &s, &t);
    double worst_norm = 0, worst_err = 0;
    const int64_t period = 10 * MS;
    for (int64_t n = 0; n < 2 * 3600 * 100; n++) {
        t += period;
        drv_imu_sample smp = sim_sample(&s, t);
        if (rt_fusion_update(f, &smp) != RT_FUSION_OK) fail_msg("sample %lld rejected", (long long)n);
        rt_fusion_state st = latest(f);
        double dn = fabs(warp_quat_norm(st.q) - 1);
        if (dn > worst_norm) worst_norm = dn;
        if (n % 1000 == 0) {
            double e = err_deg(st.q, q0);
            if (e > worst_err) worst_err = e;
        }
    }
    rt_fusion_state st = latest(f);
    assert_true(worst_norm < 1e-12);
    assert_true(worst_err < 1.0);
    assert_true(err_deg(st.q, q0) < 1.0);
    free(f);
}

/* ---- 7. concurrency: one writer, two readers; every read must be one whole published state ----
 * The filter is deterministic, so a single-threaded run over the same samples first records every state the writer
 * will publish; readers then compare what they get bit for bit (latest) or against the documented lookup (at). */

enum { CONC_SAMPLES = 500000 };

/* The gyro the writer sends at t: every field changes from sample to sample, so a state stitched together from two
 * samples cannot satisfy omega + bias == gyro(t_ns). The rates are large so q also changes fast. */
static void conc_gyro(int64_t t_ns, double g[3])
{
    int64_t ms = (t_ns - T0) / MS;
    g[0] = 1.5 * (double)(ms % 1000) / 1000.0;
    g[1] = 0.3 * ((double)(ms % 7) / 7.0 - 0.5);
    g[2] = 0.3 * ((double)(ms % 13) / 13.0 - 0.5);
}

static drv_imu_sample conc_sample(int64_t i)
{
    drv_imu_sample smp = {.t_ns = T0 + i * MS, .accel = {0, G, 0}};
    conc_gyro(smp.t_ns, smp.gyro);
    return smp;
}

typedef struct {
    rt_fusion *f;
    const rt_fusion_state *rec; /* rec[i]: the state published as index i */
    atomic_bool done;
    atomic_uint_fast64_t bad_state, bad_order, bad_norm, bad_at, bad_write;
    atomic_uint_fast64_t reads[2];
} conc_ctx;

typedef struct {
    conc_ctx *c;
    int id;
} conc_reader_arg;

static void *conc_writer(void *arg)
{
    conc_ctx *c = arg;
    for (int64_t i = 0; i < CONC_SAMPLES; i++) {
        drv_imu_sample smp = conc_sample(i);
        if (rt_fusion_update(c->f, &smp) != RT_FUSION_OK) atomic_fetch_add(&c->bad_write, 1);
    }
    atomic_store(&c->done, true);
    return NULL;
}

static bool unit(warp_quat q) { return warp_quat_isfinite(q) && fabs(warp_quat_norm(q) - 1) < 1e-12; }

/* What rt_fusion_at(t) may return for t in [rec[k].t, rec[k+1].t) while head moved from hb to ha during the call:
 * the slerp of the neighbours, the prediction from rec[k] if it was the newest, or, once rec[k] has left the ring,
 * the oldest state kept at some moment of the call. */
static bool conc_at_ok(const conc_ctx *c, int64_t k, int64_t t, uint64_t hb, uint64_t ha, warp_quat q)
{
    const rt_fusion_state *rec = c->rec;
    const int64_t n = RT_FUSION_HISTORY;
    if (k + 1 < (int64_t)ha) {
        double frac = (double)(t - rec[k].t_ns) / (double)(rec[k + 1].t_ns - rec[k].t_ns);
        if (quat_close(q, warp_quat_slerp(rec[k].q, rec[k + 1].q, frac), 1e-12)) return true;
    }
    if (k + 1 >= (int64_t)hb && quat_close(q, rt_fusion_predict(c->f, &rec[k], t), 1e-12)) return true;
    int64_t j0 = (int64_t)hb - n > k + 1 ? (int64_t)hb - n : k + 1;
    for (int64_t j = j0; j <= (int64_t)ha - n + 1 && j < (int64_t)ha; j++)
        if (quat_close(q, rec[j].q, 1e-12)) return true;
    return false;
}

static void *conc_reader(void *arg)
{
    conc_reader_arg *ra = arg;
    conc_ctx *c = ra->c;
    test_rng r = test_rng_make(700 + (uint64_t)ra->id);
    int64_t last_t = INT64_MIN;
    uint64_t n = 0;
    while (!atomic_load(&c->done)) {
        uint64_t hb = atomic_load(&c->f->head);
        rt_fusion_state st;
        if (!rt_fusion_latest(c->f, &st)) continue;
        uint64_t ha = atomic_load(&c->f->head);
        n++;
        /* latest: a whole state, published, at least as new as the head seen before the call, never older */
        int64_t k = (st.t_ns - T0) / MS;
        double g[3];
        conc_gyro(st.t_ns, g);
        if ((st.t_ns - T0) % MS != 0 || k < 0 || k >= (int64_t)ha || k + 1 < (int64_t)hb ||
            memcmp(&st, &c->rec[k], sizeof st) != 0 || fabs(st.omega.x + st.bias.x - g[0]) > 1e-12 ||
            fabs(st.omega.y + st.bias.y - g[1]) > 1e-12 || fabs(st.omega.z + st.bias.z - g[2]) > 1e-12)
            atomic_fetch_add(&c->bad_state, 1);
        if (st.t_ns < last_t) atomic_fetch_add(&c->bad_order, 1);
        last_t = st.t_ns;
        if (!unit(st.q)) atomic_fetch_add(&c->bad_norm, 1);

        /* at: anywhere in the ring and a bit before it, so that some lookups land on the oldest slots, which the
         * writer is reusing right now */
        hb = atomic_load(&c->f->head);
        int64_t kk = (int64_t)hb - 1 - (int64_t)test_rng_uniform(&r, 0, 1.1 * RT_FUSION_HISTORY);
        if (kk < 0) kk = 0;
        int64_t t = c->rec[kk].t_ns + (int64_t)test_rng_uniform(&r, 0, MS);
        warp_quat q;
        bool got = rt_fusion_at(c->f, t, &q);
        ha = atomic_load(&c->f->head);
        if (!got || !unit(q) || !conc_at_ok(c, kk, t, hb, ha, q)) atomic_fetch_add(&c->bad_at, 1);
    }
    atomic_store(&c->reads[ra->id], n);
    return NULL;
}

static void test_concurrent_readers(void **state)
{
    (void)state;
    conc_ctx c;
    memset(&c, 0, sizeof c);
    rt_fusion_state *rec = malloc(CONC_SAMPLES * sizeof *rec);
    assert_non_null(rec);
    c.f = fusion_new(NULL);
    for (int64_t i = 0; i < CONC_SAMPLES; i++) {
        drv_imu_sample smp = conc_sample(i);
        assert_int_equal(rt_fusion_update(c.f, &smp), RT_FUSION_OK);
        rec[i] = latest(c.f);
    }
    c.rec = rec;
    rt_fusion_init(c.f, NULL);
    atomic_init(&c.done, false);
    pthread_t w, rd[2];
    conc_reader_arg ra[2] = {{&c, 0}, {&c, 1}};
    for (int i = 0; i < 2; i++) assert_int_equal(pthread_create(&rd[i], NULL, conc_reader, &ra[i]), 0);
    assert_int_equal(pthread_create(&w, NULL, conc_writer, &c), 0);
    assert_int_equal(pthread_join(w, NULL), 0);
    for (int i = 0; i < 2; i++) assert_int_equal(pthread_join(rd[i], NULL), 0);
    assert_int_equal(atomic_load(&c.bad_write), 0);
    assert_int_equal(atomic_load(&c.bad_state), 0);
    assert_int_equal(atomic_load(&c.bad_order), 0);
    assert_int_equal(atomic_load(&c.bad_norm), 0);
    assert_int_equal(atomic_load(&c.bad_at), 0);
    /* the readers really ran alongside the writer */
    for (int i = 0; i < 2; i++) assert_true(atomic_load(&c.reads[i]) > 1000);
    assert_int_equal(atomic_load(&c.f->head), CONC_SAMPLES);
    free(c.f);
    free(rec);
}

/* 11. IMU on a lever arm (between the eyes, 11 cm from the neck pivot) during 300 deg/s bursts: the accelerometer
 * also measures the head's own rotation, which the filter must remove before reading gravity. With the lever arm
 * known the error stays small; assuming the IMU at the pivot, it grows several times larger. */
static double lever_arm_run(warp_vec3 lever)
{
    sim_trace tr;
    assert_true(sim_trace_init(&tr, "fast", 1));
    sim_imu_params ip = sim_imu_default_params();
    ip.t_start = -1.0; /* boots lying still */
    rt_fusion_params p = rt_fusion_default_params();
    p.lever_arm = lever;
    rt_fusion *f = fusion_new(&p);
    double sum = 0;
    int n = 0;
    for (uint64_t i = 0; i <= 9000; i++) {
        sim_imu_sample smp;
        sim_imu_sample_at(&tr, &ip, i, &smp);
        drv_imu_sample d = {T0 + (int64_t)llround(smp.t * 1e9), {smp.gyro.x, smp.gyro.y, smp.gyro.z},
                            {smp.accel.x, smp.accel.y, smp.accel.z}};
        assert_int_equal(rt_fusion_update(f, &d), RT_FUSION_OK);
        if (smp.t >= 0 && i % 10 == 0) {
            rt_fusion_state st = latest(f);
            sum += err_deg(st.q, sim_trace_orientation(&tr, smp.t));
            n++;
        }
    }
    free(f);
    return sum / n;
}

static void test_lever_arm_compensation(void **state)
{
    (void)state;
    double with = lever_arm_run(warp_head_default().neck_to_eye), without = lever_arm_run(warp_v3(0, 0, 0));
    print_message("fast trace, mean error: lever arm compensated %.3f deg, ignored %.3f deg\n", with, without);
    assert_true(with < 0.2);
    assert_true(without > 2 * with);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_lever_arm_compensation),
        cmocka_unit_test(test_defaults_and_names),
        cmocka_unit_test(test_first_sample_tilt),
        cmocka_unit_test(test_static_bias_and_yaw),
        cmocka_unit_test(test_integral_term_converges),
        cmocka_unit_test(test_rotation_tracking),
        cmocka_unit_test(test_prediction),
        cmocka_unit_test(test_history),
        cmocka_unit_test(test_rejections),
        cmocka_unit_test(test_hours),
        cmocka_unit_test(test_concurrent_readers),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

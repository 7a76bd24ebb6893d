/* SPDX-License-Identifier: MIT */
/* Unit tests for sim_trace: trace catalogue, angular velocity against the orientation it must integrate to,
 * burst speeds, and the IMU model (gravity, bias, noise statistics, stateless determinism). */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>
#include <cmocka.h>

#include "sim/sim_trace.h"
#include "tests/support/test_util.h"
#include "warp/warp_math.h"

#define DEG (WARP_PI / 180.0)

static sim_trace make(const char *name, uint64_t seed)
{
    sim_trace tr;
    assert_true(sim_trace_init(&tr, name, seed));
    return tr;
}

static void test_names(void **state)
{
    (void)state;
    static const char *const expect[] = {"still", "slow", "fast", "translate", "jitter"};
    const char *const *names = sim_trace_names();
    int n = 0;
    while (names[n]) n++;
    assert_int_equal(n, 5);
    for (int i = 0; i < 5; i++) {
        sim_trace tr;
        assert_true(sim_trace_init(&tr, expect[i], 7));
        assert_string_equal(sim_trace_name(&tr), expect[i]);
        assert_int_equal(tr.seed, 7);
        /* the default neck model: eyes at (0, 1.6, 0) when looking ahead */
        warp_pose p = warp_head_pose_from_orientation(&tr.head, warp_quat_identity());
        assert_true(fabs(p.p.y - 1.6) < 1e-12 && fabs(p.p.x) < 1e-12 && fabs(p.p.z) < 1e-12);
    }
    sim_trace tr;
    assert_false(sim_trace_init(&tr, "sideways", 0));
    assert_false(sim_trace_init(&tr, NULL, 0));
}

/* omega_body with q(t + h) = q(t) exp(omega h): the central difference of the orientation in the body frame. */
static warp_vec3 omega_fd(const sim_trace *tr, double t, double h)
{
    warp_quat a = sim_trace_orientation(tr, t - h), b = sim_trace_orientation(tr, t + h);
    return warp_v3_scale(warp_quat_log(warp_quat_mul(warp_quat_conj(a), b)), 1.0 / (2 * h));
}

static void test_omega_matches_orientation(void **state)
{
    (void)state;
    const char *const *names = sim_trace_names();
    test_rng r = test_rng_make(11);
    for (int i = 0; names[i]; i++) {
        sim_trace tr = make(names[i], 3);
        double worst = 0;
        for (int k = 0; k < 300; k++) {
            double t = test_rng_uniform(&r, 0.01, 12.0);
            warp_vec3 w = sim_trace_angular_velocity(&tr, t), f = omega_fd(&tr, t, 1e-5);
            worst = fmax(worst, warp_v3_norm(warp_v3_sub(w, f)));
        }
        assert_true(worst < 1e-6);
        /* the head pose follows the neck model of the orientation */
        warp_pose hp = sim_trace_head_pose(&tr, 1.3);
        warp_pose ref = warp_head_pose_from_orientation(&tr.head, sim_trace_orientation(&tr, 1.3));
        assert_true(warp_v3_norm(warp_v3_sub(hp.p, ref.p)) < 1e-12);
        assert_true(warp_quat_angle_between(hp.q, ref.q) < 1e-12);
    }
    /* a yaw to the left is a positive rotation about the head's +Y (at 1 s, after the ease-in) */
    sim_trace slow = make("slow", 0);
    warp_vec3 w = sim_trace_angular_velocity(&slow, 1.0);
    assert_true(w.y > 0.1 && fabs(w.x) < 0.5 * w.y);
}

/* The head rests before t = 0 (a headset lying still at boot) and every trace starts from that rest smoothly:
 * no accelerometer spike where the motion begins, which a real filter would have to reject. */
static void test_start_from_rest(void **state)
{
    (void)state;
    sim_imu_params p = sim_imu_default_params();
    p.gyro_noise = p.accel_noise = 0;
    p.gyro_bias = warp_v3(0, 0, 0);
    p.t_start = -0.2;
    for (const char *const *n = sim_trace_names(); *n; n++) {
        sim_trace tr = make(*n, 1);
        double worst = 0;
        for (uint64_t i = 0; i < 1500; i++) {
            sim_imu_sample s;
            sim_imu_sample_at(&tr, &p, i, &s);
            worst = fmax(worst, fabs(warp_v3_norm(s.accel) - 9.81));
            if (s.t < 0) {
                assert_true(warp_v3_norm(s.gyro) == 0); /* at rest */
                assert_true(warp_quat_angle_between(sim_trace_orientation(&tr, s.t), sim_trace_orientation(&tr, 0)) == 0);
            }
        }
        print_message("%-9s start: |accel| within %.3f m/s^2 of g\n", *n, worst);
        assert_true(worst < 2.0);
    }
}

static void test_speeds(void **state)
{
    (void)state;
    sim_trace still = make("still", 0), fast = make("fast", 0), slow = make("slow", 0);
    assert_true(sim_trace_peak_speed(&still, 5.0) == 0.0);
    assert_true(warp_quat_angle_between(sim_trace_orientation(&still, 3.7), warp_quat_identity()) == 0.0);
    double pf = sim_trace_peak_speed(&fast, 5.0) / DEG;
    assert_true(pf > 285.0 && pf < 315.0);
    double ps = sim_trace_peak_speed(&slow, 20.0) / DEG;
    assert_true(ps > 10.0 && ps < 60.0);

    /* fast: at rest until the first burst near 0.5 s, bursts shorter than 0.35 s sweeping 40-50 degrees,
     * consecutive yaw bursts in opposite directions */
    for (uint64_t seed = 0; seed < 4; seed++) {
        sim_trace f = make("fast", seed);
        assert_true(warp_v3_norm(sim_trace_angular_velocity(&f, 0.35)) == 0.0);
        double t_on = -1, t_off = -1;
        for (int k = 0; k < 1200; k++) {
            double t = k * 1e-3, s = warp_v3_norm(sim_trace_angular_velocity(&f, t));
            if (s > 0 && t_on < 0) t_on = t;
            if (t_on >= 0 && s == 0 && t_off < 0) t_off = t;
        }
        assert_true(t_on > 0.38 && t_on < 0.62);
        assert_true(t_off - t_on > 0.2 && t_off - t_on < 0.35);
        warp_quat q1 = sim_trace_orientation(&f, t_off);
        double sweep = warp_quat_angle_between(q1, warp_quat_identity()) / DEG;
        assert_true(sweep > 40 && sweep < 50);
        double y1 = warp_quat_rotate(q1, warp_v3(0, 0, -1)).x;
        double y2 = warp_quat_rotate(sim_trace_orientation(&f, t_off + 1.6), warp_v3(0, 0, -1)).x;
        assert_true(y1 < -0.5 && fabs(y2) < 1e-9); /* turned left, then back to centre */
    }

    /* translate: the neck model moves the eyes by centimetres; jitter: small tremor around a fixed gaze */
    sim_trace tr = make("translate", 0), ji = make("jitter", 5);
    double move = 0, dev = 0, jspeed = 0;
    warp_vec3 p0 = sim_trace_head_pose(&tr, 0).p;
    for (int k = 0; k < 5000; k++) {
        double t = k * 1e-3;
        move = fmax(move, warp_v3_norm(warp_v3_sub(sim_trace_head_pose(&tr, t).p, p0)));
        dev = fmax(dev, warp_quat_angle_between(sim_trace_orientation(&ji, t), warp_quat_identity()));
        jspeed = fmax(jspeed, warp_v3_norm(sim_trace_angular_velocity(&ji, t)));
    }
    assert_true(move > 0.01 && move < 0.15);
    assert_true(dev / DEG > 0.2 && dev / DEG < 5.0);
    assert_true(jspeed / DEG > 3.0 && jspeed / DEG < 60.0); /* tremor at ~10 Hz dominates the speed */
    /* the seed changes the jitter */
    sim_trace j2 = make("jitter", 6);
    assert_true(warp_quat_angle_between(sim_trace_orientation(&ji, 2.0), sim_trace_orientation(&j2, 2.0)) > 1e-4);
}

static void test_gyro_integrates_to_orientation(void **state)
{
    (void)state;
    sim_imu_params p = sim_imu_default_params();
    p.gyro_noise = p.accel_noise = 0;
    p.gyro_bias = p.accel_bias = warp_v3(0, 0, 0);
    static const char *const names[] = {"fast", "translate", "jitter", "slow"};
    for (int i = 0; i < 4; i++) {
        sim_trace tr = make(names[i], 9);
        warp_quat q = sim_trace_orientation(&tr, 0);
        sim_imu_sample prev, cur;
        sim_imu_sample_at(&tr, &p, 0, &prev);
        double worst = 0;
        for (uint64_t k = 1; k <= 5000; k++) {
            sim_imu_sample_at(&tr, &p, k, &cur);
            /* trapezoid on the body rate: second order in the 1 ms step */
            warp_vec3 w = warp_v3_scale(warp_v3_add(prev.gyro, cur.gyro), 0.5 / p.rate_hz);
            q = warp_quat_mul(q, warp_quat_exp(w));
            worst = fmax(worst, warp_quat_angle_between(q, sim_trace_orientation(&tr, cur.t)));
            prev = cur;
        }
        assert_true(fabs(cur.t - 5.0) < 1e-12);
        assert_true(worst < 1e-3);
    }
}

static void mean_std(const double *x, int n, double *mean, double *sd)
{
    double s = 0, ss = 0;
    for (int i = 0; i < n; i++) s += x[i];
    *mean = s / n;
    for (int i = 0; i < n; i++) ss += (x[i] - *mean) * (x[i] - *mean);
    *sd = sqrt(ss / (n - 1));
}

enum { NS = 20000 };
static double samples[6][NS];

static void test_imu_at_rest(void **state)
{
    (void)state;
    sim_trace tr = make("still", 0);
    sim_imu_params p = sim_imu_default_params();
    assert_true(p.rate_hz == 1000 && p.gyro_noise == 0.005 && p.accel_noise == 0.05);
    assert_true(p.gyro_bias.x == 0.01 && p.gyro_bias.y == -0.007 && p.gyro_bias.z == 0.004);
    p.accel_bias = warp_v3(0.1, -0.2, 0.05);
    for (int k = 0; k < NS; k++) {
        sim_imu_sample s;
        sim_imu_sample_at(&tr, &p, (uint64_t)k, &s);
        double v[6] = {s.gyro.x, s.gyro.y, s.gyro.z, s.accel.x, s.accel.y, s.accel.z};
        for (int a = 0; a < 6; a++) samples[a][k] = v[a];
    }
    const double expect[6] = {0.01, -0.007, 0.004, 0.1, 9.81 - 0.2, 0.05};
    for (int a = 0; a < 6; a++) {
        double m, sd, noise = a < 3 ? p.gyro_noise : p.accel_noise;
        mean_std(samples[a], NS, &m, &sd);
        assert_true(fabs(m - expect[a]) < 4.0 * noise / sqrt((double)NS)); /* gravity plus bias */
        assert_true(fabs(sd / noise - 1.0) < 0.1);                        /* the noise level asked for */
    }
    /* axes are independent: correlation of gyro x and y near 0 */
    double mx, sx, my, sy, c = 0;
    mean_std(samples[0], NS, &mx, &sx);
    mean_std(samples[1], NS, &my, &sy);
    for (int k = 0; k < NS; k++) c += (samples[0][k] - mx) * (samples[1][k] - my);
    assert_true(fabs(c / (NS - 1) / (sx * sy)) < 0.05);

    /* without noise and bias the sensor reads exactly the ideal values */
    sim_imu_params clean = sim_imu_default_params();
    clean.gyro_noise = clean.accel_noise = 0;
    clean.gyro_bias = clean.accel_bias = warp_v3(0, 0, 0);
    sim_imu_sample s;
    sim_imu_sample_at(&tr, &clean, 123, &s);
    assert_true(fabs(s.t - 0.123) < 1e-15);
    assert_true(warp_v3_norm(s.gyro) == 0.0);
    assert_true(fabs(s.accel.x) < 1e-6 && fabs(s.accel.y - 9.81) < 1e-6 && fabs(s.accel.z) < 1e-6);
}

static void test_imu_accel_in_motion(void **state)
{
    (void)state;
    sim_imu_params p = sim_imu_default_params();
    p.gyro_noise = p.accel_noise = 0;
    p.gyro_bias = p.accel_bias = warp_v3(0, 0, 0);
    sim_trace tr = make("translate", 0);
    for (uint64_t k = 100; k < 3000; k += 137) {
        sim_imu_sample s;
        sim_imu_sample_at(&tr, &p, k, &s);
        double t = s.t, h = 2e-3;
        /* independent five-point second derivative of the eye-midpoint position, gravity, head frame */
        warp_vec3 a = warp_v3(0, 0, 0);
        const double c[5] = {-1.0 / 12, 16.0 / 12, -30.0 / 12, 16.0 / 12, -1.0 / 12};
        for (int i = 0; i < 5; i++) a = warp_v3_add(a, warp_v3_scale(sim_trace_head_pose(&tr, t + (i - 2) * h).p, c[i] / (h * h)));
        a.y += 9.81;
        warp_vec3 f = warp_quat_rotate(warp_quat_conj(sim_trace_orientation(&tr, t)), a);
        assert_true(warp_v3_norm(warp_v3_sub(f, s.accel)) < 1e-4);
        assert_true(warp_v3_norm(warp_v3_sub(s.gyro, sim_trace_angular_velocity(&tr, t))) == 0.0);
    }
    /* pitched down by the nod, gravity shows up along the head's -Z/+Z: the sensor is really in the head frame */
    sim_trace slow = make("slow", 0);
    sim_imu_sample s;
    sim_imu_sample_at(&slow, &p, 17500, &s); /* t = 17.5 s: pitched up ~10 deg */
    double pitch = asin(warp_quat_rotate(sim_trace_orientation(&slow, s.t), warp_v3(0, 0, -1)).y);
    assert_true(fabs(s.accel.z - (-9.81 * sin(pitch))) < 0.05 && pitch > 0.1);
}

static void test_imu_deterministic(void **state)
{
    (void)state;
    sim_trace tr = make("fast", 4);
    sim_imu_params p = sim_imu_default_params();
    sim_imu_sample a, b, c;
    sim_imu_sample_at(&tr, &p, 777, &a);
    for (uint64_t k = 0; k < 50; k++) sim_imu_sample_at(&tr, &p, k * 31, &c); /* other samples in between */
    sim_imu_sample_at(&tr, &p, 777, &b);
    assert_memory_equal(&a, &b, sizeof a);
    /* another seed gives other noise, the same truth */
    p.seed = 99;
    sim_imu_sample_at(&tr, &p, 777, &c);
    assert_true(c.t == a.t && c.gyro.x != a.gyro.x && fabs(c.gyro.x - a.gyro.x) < 0.1);
    /* consecutive samples are not the same noise */
    sim_imu_sample_at(&tr, &p, 778, &b);
    assert_true(b.accel.z != c.accel.z);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_start_from_rest),
        cmocka_unit_test(test_names),
        cmocka_unit_test(test_omega_matches_orientation),
        cmocka_unit_test(test_speeds),
        cmocka_unit_test(test_gyro_integrates_to_orientation),
        cmocka_unit_test(test_imu_at_rest),
        cmocka_unit_test(test_imu_accel_in_motion),
        cmocka_unit_test(test_imu_deterministic),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

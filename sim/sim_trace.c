/* SPDX-License-Identifier: MIT */
/* sim_trace: head-motion traces as closed-form smooth functions of time (yaw/pitch/roll and their rates), and the
 * stateless IMU model sampled along them (gyro and accelerometer with bias and counter-based Gaussian noise). */
#include "sim/sim_trace.h"

#include <math.h>
#include <string.h>

#include "warp/warp_rand.h"

static const char *const trace_names[] = {"still", "slow", "fast", "translate", "jitter", NULL};

#define DEG (WARP_PI / 180.0)
#define GRAVITY 9.81

bool sim_trace_init(sim_trace *tr, const char *name, uint64_t seed)
{
    memset(tr, 0, sizeof *tr);
    tr->head = warp_head_default();
    tr->seed = seed;
    if (!name) return false;
    for (int i = 0; trace_names[i]; i++) {
        if (strcmp(trace_names[i], name) == 0) {
            tr->kind = (sim_trace_kind)i;
            return true;
        }
    }
    return false;
}

const char *const *sim_trace_names(void) { return trace_names; }

const char *sim_trace_name(const sim_trace *tr)
{
    unsigned k = (unsigned)tr->kind;
    return k < sizeof trace_names / sizeof trace_names[0] - 1 ? trace_names[k] : "unknown";
}

/* ---- counter-based randomness: any value from (seed, counter) alone, so evaluation order never matters ---- */

static uint64_t key3(uint64_t seed, uint64_t a, uint64_t b)
{
    return warp_splitmix64(warp_splitmix64(warp_splitmix64(seed) ^ a) ^ (b * 0xD6E8FEB86659FD93ull));
}

static double unit_open(uint64_t k) /* (0, 1] */ { return ((double)(k >> 11) + 1.0) * (1.0 / 9007199254740992.0); }

/* ---- yaw / pitch / roll and their rates ---- */

typedef struct { double a[3], r[3]; } ypr; /* angles (yaw, pitch, roll) and their time derivatives, rad, rad/s */

static void add_sine(ypr *s, int axis, double amp, double freq, double phase, double t)
{
    double w = 2 * WARP_PI * freq;
    s->a[axis] += amp * sin(w * t + phase);
    s->r[axis] += amp * w * cos(w * t + phase);
}

/* "fast": raised-cosine velocity bumps 0.3 s long peaking at 300 deg/s, each sweeping 45 deg. Bursts come every
 * 1.2 s (+-0.1 s seeded jitter) from t = 0.5 s in the cycle yaw+, yaw-, pitch+, pitch-, so every pair returns to
 * rest and only the current few bursts need evaluating. The angle is C2 (velocity C1), as the IMU model needs. */
enum { FAST_CYCLE = 4 };
static const double fast_first = 0.5, fast_every = 1.2, fast_len = 0.3, fast_jitter = 0.1;
static const double fast_peak = 300.0 * DEG;

static void fast_bursts(const sim_trace *tr, double t, ypr *s)
{
    double cyc = floor((t - fast_first) / (fast_every * FAST_CYCLE));
    long c = cyc < 0 ? 0 : (long)cyc;
    long k0 = (c - 1) * FAST_CYCLE, k1 = (c + 2) * FAST_CYCLE;
    if (k0 < 0) k0 = 0;
    const double sweep = fast_peak * fast_len / 2; /* integral of the bump */
    for (long k = k0; k < k1; k++) {
        double jit = fast_jitter * (2 * unit_open(key3(tr->seed, 0xFA57, (uint64_t)k)) - 1);
        double start = fast_first + fast_every * (double)k + jit;
        double x = (t - start) / fast_len;
        int axis = (k / 2) % 2 == 0 ? 0 : 1;
        double sgn = k % 2 == 0 ? 1.0 : -1.0;
        if (x <= 0) continue;
        if (x >= 1) {
            s->a[axis] += sgn * sweep;
            continue;
        }
        s->a[axis] += sgn * sweep * (x - sin(2 * WARP_PI * x) / (2 * WARP_PI));
        s->r[axis] += sgn * fast_peak * 0.5 * (1 - cos(2 * WARP_PI * x));
    }
}

#define EASE_IN 0.5 /* seconds */

static void trace_ypr(const sim_trace *tr, double t, ypr *s)
{
    memset(s, 0, sizeof *s);
    if (t < 0) {
        /* Before the trace starts the head rests at its starting orientation (a headset lying still at boot). */
        trace_ypr(tr, 0, s);
        memset(s->r, 0, sizeof s->r);
        return;
    }
    switch (tr->kind) {
    case SIM_TRACE_STILL: break;
    case SIM_TRACE_SLOW: /* peak 19 deg/s yaw, 4.4 deg/s pitch */
        add_sine(s, 0, 30 * DEG, 0.1, 0, t);
        add_sine(s, 1, 10 * DEG, 0.07, 0, t);
        break;
    case SIM_TRACE_FAST: fast_bursts(tr, t, s); break;
    case SIM_TRACE_TRANSLATE: /* the neck pivot is 8 cm behind / 7.5 cm below the eyes: nods move them ~3 cm */
        add_sine(s, 1, 20 * DEG, 0.7, 0, t);
        add_sine(s, 0, 35 * DEG, 0.3, 0, t);
        break;
    case SIM_TRACE_JITTER: {
        /* physiological tremor (8-12 Hz, ~0.1-0.2 deg) on a slow drift (~1.5 deg), seeded phases and frequencies */
        for (int axis = 0; axis < 3; axis++) {
            double scale = axis == 2 ? 0.5 : 1.0; /* less roll */
            for (int i = 0; i < 2; i++) {
                uint64_t k = key3(tr->seed, 0xD21F7, (uint64_t)(axis * 8 + i));
                double f = (i == 0 ? 0.07 : 0.23) * (0.8 + 0.4 * unit_open(k));
                add_sine(s, axis, scale * (i == 0 ? 1.0 : 0.5) * DEG, f, 2 * WARP_PI * unit_open(warp_splitmix64(k)),
                         t);
            }
            for (int i = 0; i < 3; i++) {
                uint64_t k = key3(tr->seed, 0x77E40, (uint64_t)(axis * 8 + i));
                double f = 8.0 + 4.0 * unit_open(k);
                add_sine(s, axis, scale * 0.07 * DEG, f, 2 * WARP_PI * unit_open(warp_splitmix64(k)), t);
            }
        }
        break;
    }
    }
    /* The sine traces would start at full speed from the rest before t = 0, a velocity jump an accelerometer
     * reads as tens of g. A quintic ease-in (C2) over the first half second makes the start physical. */
    if (tr->kind != SIM_TRACE_FAST && t < EASE_IN) {
        double u = t / EASE_IN;
        double e = u * u * u * (10 - 15 * u + 6 * u * u), de = 30 * u * u * (1 - u) * (1 - u) / EASE_IN;
        for (int k = 0; k < 3; k++) {
            s->r[k] = e * s->r[k] + de * s->a[k];
            s->a[k] *= e;
        }
    }
}

warp_quat sim_trace_orientation(const sim_trace *tr, double t)
{
    ypr s;
    trace_ypr(tr, t, &s);
    return warp_quat_from_ypr(s.a[0], s.a[1], s.a[2]);
}

warp_pose sim_trace_head_pose(const sim_trace *tr, double t)
{
    return warp_head_pose_from_orientation(&tr->head, sim_trace_orientation(tr, t));
}

warp_vec3 sim_trace_angular_velocity(const sim_trace *tr, double t)
{
    /* q = Ry(yaw) Rx(pitch) Rz(roll): omega_body = Rz^T Rx^T (yaw' y) + Rz^T (pitch' x) + roll' z (exact). */
    ypr s;
    trace_ypr(tr, t, &s);
    warp_quat rx = warp_quat_from_axis_angle(warp_v3(1, 0, 0), s.a[1]);
    warp_quat rz = warp_quat_from_axis_angle(warp_v3(0, 0, 1), s.a[2]);
    warp_vec3 w = warp_quat_rotate(warp_quat_conj(rx), warp_v3(0, s.r[0], 0));
    w = warp_v3_add(w, warp_v3(s.r[1], 0, 0));
    w = warp_quat_rotate(warp_quat_conj(rz), w);
    return warp_v3_add(w, warp_v3(0, 0, s.r[2]));
}

double sim_trace_peak_speed(const sim_trace *tr, double duration)
{
    double peak = 0;
    long n = (long)floor(duration * 1000.0);
    for (long i = 0; i <= n; i++) peak = fmax(peak, warp_v3_norm(sim_trace_angular_velocity(tr, i * 1e-3)));
    return peak;
}

/* ---- IMU ---- */

sim_imu_params sim_imu_default_params(void)
{
    sim_imu_params p;
    memset(&p, 0, sizeof p);
    p.rate_hz = 1000.0;
    p.gyro_noise = 0.005;
    p.gyro_bias = warp_v3(0.01, -0.007, 0.004);
    p.accel_noise = 0.05;
    p.accel_bias = warp_v3(0, 0, 0);
    p.seed = 1;
    return p;
}

/* Standard normal from (seed, index, axis): Box-Muller on two hashed uniforms. */
static double gauss(uint64_t seed, uint64_t index, int axis)
{
    uint64_t k = key3(seed, index, (uint64_t)axis + 1);
    double u1 = unit_open(k), u2 = unit_open(warp_splitmix64(k ^ 0x5851F42D4C957F2Dull));
    return sqrt(-2.0 * log(u1)) * cos(2 * WARP_PI * u2);
}

void sim_imu_sample_at(const sim_trace *tr, const sim_imu_params *p, uint64_t index, sim_imu_sample *out)
{
    double t = p->t_start + (double)index / p->rate_hz;
    out->t = t;
    warp_vec3 w = sim_trace_angular_velocity(tr, t);
    out->gyro = warp_v3(w.x + p->gyro_bias.x + p->gyro_noise * gauss(p->seed, index, 0),
                        w.y + p->gyro_bias.y + p->gyro_noise * gauss(p->seed, index, 1),
                        w.z + p->gyro_bias.z + p->gyro_noise * gauss(p->seed, index, 2));
    /* Specific force at the head origin: second central difference of the neck-model position (h = 0.5 ms:
     * truncation ~1e-3 m/s^2 at the fastest bursts, rounding ~1e-9), plus gravity's reaction, in the head frame. */
    const double h = 5e-4;
    warp_vec3 pm = sim_trace_head_pose(tr, t - h).p, p0 = sim_trace_head_pose(tr, t).p,
              pp = sim_trace_head_pose(tr, t + h).p;
    warp_vec3 a = warp_v3_scale(warp_v3_add(warp_v3_sub(pp, warp_v3_scale(p0, 2.0)), pm), 1.0 / (h * h));
    a.y += GRAVITY;
    warp_vec3 f = warp_quat_rotate(warp_quat_conj(sim_trace_orientation(tr, t)), a);
    out->accel = warp_v3(f.x + p->accel_bias.x + p->accel_noise * gauss(p->seed, index, 3),
                         f.y + p->accel_bias.y + p->accel_noise * gauss(p->seed, index, 4),
                         f.z + p->accel_bias.z + p->accel_noise * gauss(p->seed, index, 5));
}

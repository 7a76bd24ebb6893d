/* SPDX-License-Identifier: MIT */
/* hil_common: what the hardware-in-the-loop feeder programs share: option parsing with errors naming the option,
 * stopping on SIGINT/SIGTERM, absolute sleeps, status files for scenarios, and IMU samples along a sim trace. */
#ifndef HIL_COMMON_H
#define HIL_COMMON_H

#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <signal.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "platform/plat_clock.h"
#include "sim/sim_trace.h"

/* Exit codes: 0 done, 1 a device or run-time failure, 2 bad command line. */
#define HIL_EXIT_FAIL 1
#define HIL_EXIT_USAGE 2

static const char *hil_prog = "hil";
static volatile sig_atomic_t hil_stop_sig;

/* One line on stderr, "PROG: message". */
static inline void hil_vmsg(const char *fmt, va_list ap) __attribute__((format(printf, 1, 0)));
static inline void hil_vmsg(const char *fmt, va_list ap)
{
    fprintf(stderr, "%s: ", hil_prog);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
}

static inline void hil_msg(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static inline void hil_msg(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    hil_vmsg(fmt, ap);
    va_end(ap);
}

static inline void hil_die(int code, const char *fmt, ...) __attribute__((format(printf, 2, 3), noreturn));
static inline void hil_die(int code, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    hil_vmsg(fmt, ap);
    va_end(ap);
    exit(code);
}

/* Program start: names the program for messages; stdout line-buffered so a scenario reading a pipe or a file sees
 * the "ready" line at once. */
static inline void hil_init(const char *prog)
{
    hil_prog = prog;
    setvbuf(stdout, NULL, _IOLBF, 0);
}

static inline void hil_on_signal(int sig) { hil_stop_sig = sig; }

/* SIGINT/SIGTERM set the stop flag; without SA_RESTART, so a sleep or a blocking call returns early. SIGPIPE is
 * ignored: a closed stdout must not kill a feeder that holds a device. */
static inline void hil_signals_install(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = hil_on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    signal(SIGPIPE, SIG_IGN);
}

static inline bool hil_stopped(void) { return hil_stop_sig != 0; }

static inline int64_t hil_now_ns(void) { return plat_now_ns(); }

/* Sleeps until the absolute CLOCK_MONOTONIC time t_ns; false when a signal cut it short (the caller checks
 * hil_stopped()). */
static inline bool hil_sleep_until_ns(int64_t t_ns)
{
    if (t_ns <= 0) return true;
    struct timespec ts = {(time_t)(t_ns / PLAT_NS_PER_S), (long)(t_ns % PLAT_NS_PER_S)};
    int rc;
    while ((rc = clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL)) == EINTR)
        if (hil_stopped()) return false;
    return rc == 0;
}

/* ---- option values ---- */

/* Every HIL program's command line: its own long options, then HIL_LONGOPTS_END (-v, -h and the terminator);
 * hil_getopt reads it with getopt's errors left to hil_opt_other (optstring ":hv"). */
#define HIL_LONGOPTS_END {"verbose", no_argument, NULL, 'v'}, {"help", no_argument, NULL, 'h'}, {NULL, 0, NULL, 0}

static inline int hil_getopt(int argc, char **argv, const struct option *lo)
{
    opterr = 0;
    return getopt_long(argc, argv, ":hv", lo, NULL);
}

/* The end of every HIL program's getopt switch: -h prints usage and exits 0, a missing value or an unknown option
 * is a usage error naming it. */
static inline __attribute__((noreturn)) void hil_opt_other(int c, char **argv, void (*usage)(FILE *f))
{
    if (c == 'h') {
        usage(stdout);
        exit(0);
    }
    if (c == ':') hil_die(HIL_EXIT_USAGE, "%s needs a value (see --help)", argv[optind - 1]);
    hil_die(HIL_EXIT_USAGE, "unknown option '%s' (see --help)", argv[optind - 1]);
}

/* After the getopt loop: the HIL programs take no operands. */
static inline void hil_opt_no_operands(int argc, char **argv)
{
    if (optind < argc) hil_die(HIL_EXIT_USAGE, "unexpected argument '%s' (see --help)", argv[optind]);
}

static inline double hil_parse_double(const char *opt, const char *arg, double lo, double hi)
{
    char *end;
    errno = 0;
    double v = strtod(arg, &end);
    if (end == arg || *end || errno || !isfinite(v) || v < lo || v > hi)
        hil_die(HIL_EXIT_USAGE, "%s '%s': expected a number from %g to %g", opt, arg, lo, hi);
    return v;
}

/* Integers in decimal or 0x hex. */
static inline long long hil_parse_int(const char *opt, const char *arg, long long lo, long long hi)
{
    char *end;
    errno = 0;
    long long v = strtoll(arg, &end, 0);
    if (end == arg || *end || errno || v < lo || v > hi)
        hil_die(HIL_EXIT_USAGE, "%s '%s': expected a whole number from %lld to %lld", opt, arg, lo, hi);
    return v;
}

/* Hex without prefix (USB ids: "1209"), 0..0xffff. */
static inline unsigned hil_parse_hex16(const char *opt, const char *arg)
{
    char *end;
    errno = 0;
    unsigned long v = strtoul(arg, &end, 16);
    if (end == arg || *end || errno || v > 0xffff || arg[0] == '-')
        hil_die(HIL_EXIT_USAGE, "%s '%s': expected a hex number 0000..ffff", opt, arg);
    return (unsigned)v;
}

/* "x,y,z" (commas or spaces). */
static inline void hil_parse_vec3(const char *opt, const char *arg, double lo, double hi, double out[3])
{
    const char *p = arg;
    for (int i = 0; i < 3; i++) {
        while (*p == ' ' || *p == ',') p++;
        char *end;
        errno = 0;
        double v = strtod(p, &end);
        if (end == p || errno || !isfinite(v) || v < lo || v > hi)
            hil_die(HIL_EXIT_USAGE, "%s '%s': expected three numbers x,y,z from %g to %g", opt, arg, lo, hi);
        out[i] = v;
        p = end;
    }
    while (*p == ' ') p++;
    if (*p) hil_die(HIL_EXIT_USAGE, "%s '%s': expected three numbers x,y,z from %g to %g", opt, arg, lo, hi);
}

/* ---- status file ---- */

/* Replaces `path` atomically (write a temporary file, rename) with key=value lines, so a scenario polling it never
 * reads half a file. A NULL or empty path does nothing. Failures are reported, not fatal. */
static inline void hil_status_write(const char *path, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static inline void hil_status_write(const char *path, const char *fmt, ...)
{
    if (!path || !path[0]) return;
    char tmp[4096];
    if (snprintf(tmp, sizeof tmp, "%s.tmp", path) >= (int)sizeof tmp) return;
    FILE *f = fopen(tmp, "w");
    if (!f) {
        hil_msg("--ready-file %s: cannot write: %s", path, strerror(errno));
        return;
    }
    fprintf(f, "pid=%ld\n", (long)getpid());
    va_list ap;
    va_start(ap, fmt);
    vfprintf(f, fmt, ap);
    va_end(ap);
    bool ok = fclose(f) == 0;
    if (!ok || rename(tmp, path) != 0) {
        hil_msg("--ready-file %s: cannot write: %s", path, strerror(errno));
        unlink(tmp);
    }
}

/* ---- IMU samples along a sim trace (the [sim] knobs of board.ini) ---- */

typedef struct {
    const char *trace;
    uint64_t seed;
    double rest_s; /* the head rests this long before the trace's motion starts (cf. [sim] imu_rest_s) */
    double gyro_noise, accel_noise;
    double gyro_bias[3], accel_bias[3];
} hil_trace_cfg;

/* Defaults as board/sim/board.ini, except the trace ("slow": moderate rates that every range covers). */
static inline hil_trace_cfg hil_trace_defaults(void)
{
    sim_imu_params d = sim_imu_default_params();
    hil_trace_cfg c;
    memset(&c, 0, sizeof c);
    c.trace = "slow";
    c.seed = 1;
    c.rest_s = 1.0;
    c.gyro_noise = d.gyro_noise;
    c.accel_noise = d.accel_noise;
    c.gyro_bias[0] = d.gyro_bias.x;
    c.gyro_bias[1] = d.gyro_bias.y;
    c.gyro_bias[2] = d.gyro_bias.z;
    return c;
}

enum {
    HIL_OPT_TRACE = 1000,
    HIL_OPT_SEED,
    HIL_OPT_REST,
    HIL_OPT_GYRO_NOISE,
    HIL_OPT_GYRO_BIAS,
    HIL_OPT_ACCEL_NOISE,
    HIL_OPT_ACCEL_BIAS,
    HIL_OPT_FIRST_FREE /* programs number their own long-only options from here */
};

#define HIL_TRACE_LONGOPTS                                                                                          \
    {"trace", required_argument, NULL, HIL_OPT_TRACE}, {"seed", required_argument, NULL, HIL_OPT_SEED},             \
        {"rest", required_argument, NULL, HIL_OPT_REST},                                                            \
        {"gyro-noise", required_argument, NULL, HIL_OPT_GYRO_NOISE},                                                \
        {"gyro-bias", required_argument, NULL, HIL_OPT_GYRO_BIAS},                                                  \
        {"accel-noise", required_argument, NULL, HIL_OPT_ACCEL_NOISE},                                              \
        {"accel-bias", required_argument, NULL, HIL_OPT_ACCEL_BIAS}

static inline void hil_trace_help(FILE *f)
{
    fprintf(f, "Motion (the IMU samples of a sim trace, as [sim] in board.ini):\n"
               "  --trace NAME        head-motion trace (default slow):");
    for (const char *const *n = sim_trace_names(); *n; n++) fprintf(f, " %s", *n);
    fprintf(f, "\n"
               "  --seed N            seed for noise and trace variations (default 1)\n"
               "  --rest S            seconds the head rests before the motion starts (default 1.0)\n"
               "  --gyro-noise R      gyro white noise, rad/s rms per sample (default 0.005)\n"
               "  --gyro-bias X,Y,Z   gyro bias, rad/s (default 0.01,-0.007,0.004)\n"
               "  --accel-noise A     accelerometer white noise, m/s^2 rms per sample (default 0.05)\n"
               "  --accel-bias X,Y,Z  accelerometer bias, m/s^2 (default 0,0,0)\n");
}

/* true when `opt` was one of HIL_TRACE_LONGOPTS (handled), false otherwise. Exits on a bad value. */
static inline bool hil_trace_option(int opt, const char *arg, hil_trace_cfg *c)
{
    switch (opt) {
    case HIL_OPT_TRACE: c->trace = arg; return true;
    case HIL_OPT_SEED: c->seed = (uint64_t)hil_parse_int("--seed", arg, 0, INT64_MAX); return true;
    case HIL_OPT_REST: c->rest_s = hil_parse_double("--rest", arg, 0, 3600); return true;
    case HIL_OPT_GYRO_NOISE: c->gyro_noise = hil_parse_double("--gyro-noise", arg, 0, 10); return true;
    case HIL_OPT_GYRO_BIAS: hil_parse_vec3("--gyro-bias", arg, -10, 10, c->gyro_bias); return true;
    case HIL_OPT_ACCEL_NOISE: c->accel_noise = hil_parse_double("--accel-noise", arg, 0, 100); return true;
    case HIL_OPT_ACCEL_BIAS: hil_parse_vec3("--accel-bias", arg, -100, 100, c->accel_bias); return true;
    default: return false;
    }
}

/* Sample i is measured at trace time i / rate_hz - rest_s. */
typedef struct {
    sim_trace tr;
    sim_imu_params p;
} hil_imu_gen;

/* Exits with a message listing the traces when the name is unknown. */
static inline void hil_imu_gen_init(hil_imu_gen *g, const hil_trace_cfg *c, double rate_hz)
{
    if (!sim_trace_init(&g->tr, c->trace, c->seed)) {
        char names[256] = "";
        for (const char *const *n = sim_trace_names(); *n; n++)
            snprintf(names + strlen(names), sizeof names - strlen(names), " %s", *n);
        hil_die(HIL_EXIT_USAGE, "--trace '%s': unknown trace (one of:%s)", c->trace, names);
    }
    g->p = sim_imu_default_params();
    g->p.rate_hz = rate_hz;
    g->p.seed = c->seed;
    g->p.t_start = -c->rest_s;
    g->p.gyro_noise = c->gyro_noise;
    g->p.accel_noise = c->accel_noise;
    g->p.gyro_bias = warp_v3(c->gyro_bias[0], c->gyro_bias[1], c->gyro_bias[2]);
    g->p.accel_bias = warp_v3(c->accel_bias[0], c->accel_bias[1], c->accel_bias[2]);
}

/* Head-frame gyro (rad/s) and specific force (m/s^2) of sample i. */
static inline void hil_imu_gen_sample(const hil_imu_gen *g, uint64_t i, double gyro[3], double accel[3])
{
    sim_imu_sample s;
    sim_imu_sample_at(&g->tr, &g->p, i, &s);
    gyro[0] = s.gyro.x;
    gyro[1] = s.gyro.y;
    gyro[2] = s.gyro.z;
    accel[0] = s.accel.x;
    accel[1] = s.accel.y;
    accel[2] = s.accel.z;
}

#endif

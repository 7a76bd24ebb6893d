/* SPDX-License-Identifier: MIT */
/* hil_te: plays a display panel's TE (tearing effect) signal on a gpio-sim line: pulses at the panel rate written
 * through the simulated line's sysfs `pull` attribute, so libgpiod in hmdwarpd sees real edge interrupts; with
 * jitter, a TE dropout and a phase jump on request, as drivers/drv_te_schedule plans them. A pulse it cannot start
 * on time is dropped, not written late: a panel's TE edge comes on time or not at all. */
#include <dirent.h>
#include <fcntl.h>

#include "drivers/drv_te_schedule.h"
#include "tests/hil/src/hil_common.h"

#define LATE_US 500 /* default --late-us: an edge written this late after its time counts as late */

typedef struct {
    const char *pull;
    char pull_buf[512];
    double rate_hz, high_us, jitter_us;
    double duration_s, stop_at_s, stop_for_s;
    double jump_at_s, jump_us;
    double late_us;
    bool active_low;
    uint64_t seed;
    const char *ready_file;
    int dry_run;
    bool verbose;
} opts;

/* ---- the pulse schedule: drivers/drv_te_schedule (the GPIO mock's too); high_ns is the pulse width ---- */

typedef struct {
    drv_te_schedule te;
    int64_t high_ns;
} sched;

/* Start of pulse k relative to pulse 0 (negative for pulse 0 jittered early); false when the TE is stopped then.
 * The jitter is uniform in [-jitter, +jitter], deterministic per (seed, k). */
static bool pulse_at(const sched *s, uint64_t k, int64_t *at) { return drv_te_schedule_pulse(&s->te, (int64_t)k, at); }

/* ---- the line ---- */

typedef struct {
    int fd;
    const char *path;
    bool active_low, level; /* level: the line is active (pulse) now */
    uint64_t rising, falling, write_errors;
} te_line;

static int line_set(te_line *l, bool active)
{
    bool high = active != l->active_low;
    const char *v = high ? "pull-up" : "pull-down";
    ssize_t n = pwrite(l->fd, v, strlen(v), 0);
    if (n != (ssize_t)strlen(v)) {
        int e = n < 0 ? errno : EIO;
        l->write_errors++;
        if (l->write_errors == 1 || l->write_errors % 1000 == 0)
            hil_msg("%s: writing \"%s\" failed (%llu so far): %s", l->path, v, (unsigned long long)l->write_errors,
                    strerror(e));
        return -e;
    }
    if (active != l->level) {
        if (high)
            l->rising++;
        else
            l->falling++;
    }
    l->level = active;
    return 0;
}

/* --chip NAME --line N: the gpio-sim line's attribute directory is the chip's device directory, reachable from
 * the gpio bus (/sys/bus/gpio/devices/gpiochipN) or under the gpio-sim platform device. */
static bool find_pull(const char *chip, int line, char *out, size_t len)
{
    snprintf(out, len, "/sys/bus/gpio/devices/%s/sim_gpio%d/pull", chip, line);
    if (access(out, F_OK) == 0) return true;
    DIR *d = opendir("/sys/devices/platform");
    struct dirent *e;
    bool found = false;
    while (d && !found && (e = readdir(d))) {
        if (strncmp(e->d_name, "gpio-sim.", 9) != 0 || strlen(e->d_name) > 64) continue;
        snprintf(out, len, "/sys/devices/platform/%.64s/%.64s/sim_gpio%d/pull", e->d_name, chip, line);
        found = access(out, F_OK) == 0;
    }
    if (d) closedir(d);
    return found;
}

static void line_open(te_line *l, const opts *o)
{
    memset(l, 0, sizeof *l);
    l->path = o->pull;
    l->active_low = o->active_low;
    l->fd = open(o->pull, O_WRONLY | O_CLOEXEC);
    if (l->fd >= 0) return;
    int e = errno;
    if (e == ENOENT)
        hil_die(HIL_EXIT_FAIL,
                "%s: no such file (gpio-sim loaded, the chip configured in /sys/kernel/config/gpio-sim and live, "
                "the line inside num_lines? see tests/hil/FEEDERS.md)",
                o->pull);
    if (e == EACCES || e == EPERM) hil_die(HIL_EXIT_FAIL, "%s: permission denied (run as root)", o->pull);
    hil_die(HIL_EXIT_FAIL, "%s: cannot open for writing: %s", o->pull, strerror(e));
}

/* ---- --dry-run ---- */

static int dry_run(const opts *o, const sched *s)
{
    printf("%s: dry run: %d pulses at %g Hz, %.0f us wide, jitter +-%.0f us, %s\n", hil_prog, o->dry_run, o->rate_hz,
           o->high_us, o->jitter_us, o->active_low ? "active low (idle pull-up)" : "active high (idle pull-down)");
    int bad = 0;
    int64_t prev_end = INT64_MIN;
    for (uint64_t k = 0; k < (uint64_t)o->dry_run; k++) {
        int64_t t;
        if (!pulse_at(s, k, &t)) {
            printf("  pulse %3llu: stopped (no edges)\n", (unsigned long long)k);
            continue;
        }
        int64_t nominal = drv_te_schedule_slot(&s->te, (int64_t)k);
        bool ok = t > prev_end && (double)llabs(t - nominal) <= s->te.jitter_ns;
        bad += !ok;
        prev_end = t + s->high_ns;
        printf("  pulse %3llu: t=%10.3f us write %-9s  t=%10.3f us write %-9s%s\n", (unsigned long long)k,
               (double)t * 1e-3, o->active_low ? "pull-down" : "pull-up", (double)(t + s->high_ns) * 1e-3,
               o->active_low ? "pull-up" : "pull-down", ok ? "" : "  <-- FAIL (overlaps or off its slot)");
    }
    printf("%s: dry run %s\n", hil_prog, bad ? "FAIL" : "PASS");
    return bad ? HIL_EXIT_FAIL : 0;
}

/* ---- command line ---- */

static void usage(FILE *f)
{
    fprintf(f,
            "usage: %s --pull PATH | --chip NAME --line N [options]\n"
            "Plays a panel TE signal on a gpio-sim line: every 1/rate seconds a pulse of --high-us, written as\n"
            "\"pull-up\" / \"pull-down\" to the simulated line's sysfs pull attribute, so the kernel's gpio-sim raises\n"
            "real edge interrupts for the consumer (hmdwarpd's libgpiod TE source). Sleeps with clock_nanosleep\n"
            "(TIMER_ABSTIME, CLOCK_MONOTONIC). Prints \"%s: ready PATH\" once the line is idle, and a key=value\n"
            "summary (edges written, lateness) at exit. The line is left idle.\n"
            "\n"
            "Line:\n"
            "  --pull PATH         the line's pull attribute, e.g.\n"
            "                      /sys/devices/platform/gpio-sim.0/gpiochip1/sim_gpio0/pull\n"
            "  --chip NAME         instead of --pull: the gpio-sim chip (gpiochipN, its bank's chip_name) ...\n"
            "  --line N            ... and the line offset (default 0)\n"
            "  --active-low        idle high, pulses low (for [vsync] edge = falling)\n"
            "  --ready-file PATH   also write state=ready|running|done, pull=, pid= lines to PATH (atomic), and\n"
            "                      once a second pulses= and dropped_late= (the share it could play on time)\n"
            "Signal:\n"
            "  --rate HZ           pulses per second (default 90)\n"
            "  --high-us US        pulse width (default 1000)\n"
            "  --jitter-us US      uniform random offset of each pulse, +-US (default 0; below half the gap\n"
            "                      between pulses)\n"
            "  --seed N            seed of the jitter (default 1)\n"
            "Run:\n"
            "  --duration S        stop after S seconds (default 60; 0: until SIGINT/SIGTERM)\n"
            "  --stop-at S         S seconds after start, no more pulses (TE dropout: hmdwarpd should fall back to\n"
            "                      its timer) ...\n"
            "  --stop-for S        ... for S seconds (default 1), then pulses resume on the same phase (relock)\n"
            "  --phase-jump-at S   S seconds after start, shift every later pulse by --phase-jump-us (a panel mode\n"
            "  --phase-jump-us US  change: hmdwarpd should relock on the new phase; default 3000)\n"
            "  --late-us US        a pulse whose start would be written more than US late is dropped, a missed\n"
            "                      edge (default %d; 0: write every pulse however late, in a burst after a stall)\n"
            "  --dry-run[=N]       no device: print the first N pulses (default 10) and the writes; PASS or FAIL\n"
            "  -v, --verbose       report every late edge\n"
            "  -h, --help          this text\n"
            "Exit status: 0 done, 1 device failure, 2 bad command line.\n",
            hil_prog, hil_prog, LATE_US);
}

enum {
    OPT_PULL = 1000,
    OPT_CHIP,
    OPT_LINE,
    OPT_ACTIVE_LOW,
    OPT_READY_FILE,
    OPT_RATE,
    OPT_HIGH_US,
    OPT_JITTER_US,
    OPT_SEED,
    OPT_DURATION,
    OPT_STOP_AT,
    OPT_STOP_FOR,
    OPT_JUMP_AT,
    OPT_JUMP_US,
    OPT_LATE_US,
    OPT_DRY_RUN,
};

static void parse_args(int argc, char **argv, opts *o)
{
    static const struct option lo[] = {
        {"pull", required_argument, NULL, OPT_PULL},
        {"chip", required_argument, NULL, OPT_CHIP},
        {"line", required_argument, NULL, OPT_LINE},
        {"active-low", no_argument, NULL, OPT_ACTIVE_LOW},
        {"ready-file", required_argument, NULL, OPT_READY_FILE},
        {"rate", required_argument, NULL, OPT_RATE},
        {"high-us", required_argument, NULL, OPT_HIGH_US},
        {"jitter-us", required_argument, NULL, OPT_JITTER_US},
        {"seed", required_argument, NULL, OPT_SEED},
        {"duration", required_argument, NULL, OPT_DURATION},
        {"stop-at", required_argument, NULL, OPT_STOP_AT},
        {"stop-for", required_argument, NULL, OPT_STOP_FOR},
        {"phase-jump-at", required_argument, NULL, OPT_JUMP_AT},
        {"phase-jump-us", required_argument, NULL, OPT_JUMP_US},
        {"late-us", required_argument, NULL, OPT_LATE_US},
        {"dry-run", optional_argument, NULL, OPT_DRY_RUN},
        HIL_LONGOPTS_END,
    };
    memset(o, 0, sizeof *o);
    o->rate_hz = 90;
    o->high_us = 1000;
    o->duration_s = 60;
    o->stop_for_s = 1;
    o->jump_us = 3000;
    o->late_us = LATE_US;
    o->seed = 1;
    const char *chip = NULL;
    int line = 0;
    int c;
    while ((c = hil_getopt(argc, argv, lo)) != -1) {
        switch (c) {
        case OPT_PULL: o->pull = optarg; break;
        case OPT_CHIP: chip = optarg; break;
        case OPT_LINE: line = (int)hil_parse_int("--line", optarg, 0, 1023); break;
        case OPT_ACTIVE_LOW: o->active_low = true; break;
        case OPT_READY_FILE: o->ready_file = optarg; break;
        case OPT_RATE: o->rate_hz = hil_parse_double("--rate", optarg, 1, 1000); break;
        case OPT_HIGH_US: o->high_us = hil_parse_double("--high-us", optarg, 1, 1e6); break;
        case OPT_JITTER_US: o->jitter_us = hil_parse_double("--jitter-us", optarg, 0, 1e6); break;
        case OPT_SEED: o->seed = (uint64_t)hil_parse_int("--seed", optarg, 0, INT64_MAX); break;
        case OPT_DURATION: o->duration_s = hil_parse_double("--duration", optarg, 0, 1e6); break;
        case OPT_STOP_AT: o->stop_at_s = hil_parse_double("--stop-at", optarg, 0, 1e6); break;
        case OPT_STOP_FOR: o->stop_for_s = hil_parse_double("--stop-for", optarg, 0.001, 1e6); break;
        case OPT_JUMP_AT: o->jump_at_s = hil_parse_double("--phase-jump-at", optarg, 0, 1e6); break;
        case OPT_JUMP_US: o->jump_us = hil_parse_double("--phase-jump-us", optarg, -1e6, 1e6); break;
        case OPT_LATE_US: o->late_us = hil_parse_double("--late-us", optarg, 0, 1e6); break;
        case OPT_DRY_RUN: o->dry_run = optarg ? (int)hil_parse_int("--dry-run", optarg, 1, 100000) : 10; break;
        case 'v': o->verbose = true; break;
        default: hil_opt_other(c, argv, usage);
        }
    }
    hil_opt_no_operands(argc, argv);
    double period_us = 1e6 / o->rate_hz;
    if (o->high_us >= period_us)
        hil_die(HIL_EXIT_USAGE, "--high-us %g: a pulse must be shorter than the period (%.1f us at %g Hz)",
                o->high_us, period_us, o->rate_hz);
    if (o->jitter_us > 0 && 2 * o->jitter_us >= period_us - o->high_us)
        hil_die(HIL_EXIT_USAGE, "--jitter-us %g: pulses could overlap; keep it below %.1f us (half the gap between "
                "pulses)", o->jitter_us, (period_us - o->high_us) / 2);
    if (o->pull && chip) hil_die(HIL_EXIT_USAGE, "give either --pull or --chip/--line, not both");
    if (chip && !o->dry_run) {
        if (!find_pull(chip, line, o->pull_buf, sizeof o->pull_buf))
            hil_die(HIL_EXIT_FAIL,
                    "--chip %s --line %d: no gpio-sim line attribute /sys/bus/gpio/devices/%s/sim_gpio%d/pull (nor "
                    "under /sys/devices/platform/gpio-sim.*; gpio-sim loaded and the chip live?)",
                    chip, line, chip, line);
        o->pull = o->pull_buf;
    }
    if (!o->pull && !o->dry_run) hil_die(HIL_EXIT_USAGE, "--pull PATH or --chip NAME --line N is required");
}

int main(int argc, char **argv)
{
    hil_init("hil_te");
    opts o;
    parse_args(argc, argv, &o);
    sched s = {drv_te_schedule_clean((double)llround(1e9 / o.rate_hz), o.seed), (int64_t)llround(o.high_us * 1e3)};
    s.te.jitter_ns = (double)llround(o.jitter_us * 1e3);
    if (o.stop_at_s > 0) {
        s.te.stop_at_ns = (int64_t)llround(o.stop_at_s * 1e9);
        s.te.stop_to_ns = (int64_t)llround((o.stop_at_s + o.stop_for_s) * 1e9);
    }
    if (o.jump_at_s > 0) s.te.jump_at_ns = (int64_t)llround(o.jump_at_s * 1e9);
    s.te.jump_ns = (int64_t)llround(o.jump_us * 1e3);
    if (o.dry_run) return dry_run(&o, &s);

    hil_signals_install();
    te_line l;
    line_open(&l, &o);
    l.level = true; /* unknown: force the idle write */
    if (line_set(&l, false) < 0) hil_die(HIL_EXIT_FAIL, "%s: cannot set the line idle", o.pull);
    l.rising = l.falling = 0;
    printf("%s: ready %s (%g Hz, %.0f us pulses, jitter +-%.0f us, %s)\n", hil_prog, o.pull, o.rate_hz, o.high_us,
           o.jitter_us, o.active_low ? "active low" : "active high");
    hil_status_write(o.ready_file, "state=ready\npull=%s\n", o.pull);

    /* the first pulse a little ahead, so it is not late by construction */
    const int64_t t0 = hil_now_ns() + 10 * PLAT_NS_PER_MS;
    const int64_t t_end = o.duration_s > 0 ? t0 + (int64_t)(o.duration_s * 1e9) : INT64_MAX;
    /* A stalled player that wrote every pulse it owed would send them in a burst at its own pace (under TCG on a
     * busy host it fell a minute behind, 76 edges a second for 90 Hz), which is no panel's TE signal: gpio-sim
     * stamps an edge when it is written, so a late write is an edge at the wrong time. */
    const int64_t drop_ns = o.late_us > 0 ? (int64_t)llround(o.late_us * 1e3) : INT64_MAX;
    const int64_t late_ns = (int64_t)llround((o.late_us > 0 ? o.late_us : LATE_US) * 1e3);
    uint64_t pulses = 0, stopped = 0, dropped = 0, late = 0, n_late = 0;
    /* how late each pulse's start was when the player woke for it (before the write): the VM's scheduling, which
     * decides how many pulses a given --late-us drops */
    static const int64_t wake_le_us[] = {100, 250, 500, 1000, 2000, 5000};
    enum { N_WAKE = sizeof wake_le_us / sizeof wake_le_us[0] + 1 };
    uint64_t wake_hist[N_WAKE] = {0};
    int64_t late_max = 0;
    double late_sum = 0;
    for (uint64_t k = 0; !hil_stopped(); k++) {
        int64_t rel;
        bool on = pulse_at(&s, k, &rel);
        int64_t nominal = t0 + llround((double)k * s.te.period_ns);
        if (nominal >= t_end) break;
        if (k > 0 && k % (uint64_t)ceil(o.rate_hz) == 0) /* about once a second */
            hil_status_write(o.ready_file, "state=running\npull=%s\npulses=%llu\ndropped_late=%llu\n", o.pull,
                             (unsigned long long)pulses, (unsigned long long)dropped);
        if (!on) {
            stopped++;
            hil_sleep_until_ns(nominal); /* keep the loop paced (and signals noticed) while the TE is off */
            continue;
        }
        int64_t edges[2] = {t0 + rel, t0 + rel + s.high_ns};
        for (int e = 0; e < 2 && !hil_stopped(); e++) {
            if (!hil_sleep_until_ns(edges[e])) break;
            if (e == 0) {
                int64_t woke_us = (hil_now_ns() - edges[0]) / 1000;
                int b = 0;
                while (b < N_WAKE - 1 && woke_us > wake_le_us[b]) b++;
                wake_hist[b]++;
            }
            if (e == 0 && hil_now_ns() - edges[0] > drop_ns) {
                dropped++;
                if (o.verbose) hil_msg("pulse %llu dropped: %.0f us late", (unsigned long long)k,
                                       (double)(hil_now_ns() - edges[0]) * 1e-3);
                break;
            }
            line_set(&l, e == 0);
            pulses += e == 0;
            int64_t lat = hil_now_ns() - edges[e];
            late_sum += (double)lat;
            n_late++;
            if (lat > late_max) late_max = lat;
            if (lat > late_ns) {
                late++;
                if (o.verbose) hil_msg("edge %llu.%d written %.0f us late", (unsigned long long)k, e, lat * 1e-3);
            }
        }
    }
    if (l.level) line_set(&l, false); /* stopped mid-pulse: leave the line idle */
    close(l.fd);
    char hist[200];
    int hn = 0;
    for (int b = 0; b < N_WAKE; b++)
        hn += snprintf(hist + hn, sizeof hist - (size_t)hn, "%s%llu", b ? "," : "", (unsigned long long)wake_hist[b]);
    printf("%s: summary run_s=%.3f pulses=%llu rising=%llu falling=%llu stopped_pulses=%llu dropped_late=%llu "
           "write_errors=%llu late_mean_us=%.1f late_max_us=%.1f late_over_%.0fus=%llu "
           "woke_late_us_le_100_250_500_1000_2000_5000_more=%s stop=%s\n",
           hil_prog, (double)(hil_now_ns() - t0) * 1e-9, (unsigned long long)pulses, (unsigned long long)l.rising,
           (unsigned long long)l.falling, (unsigned long long)stopped, (unsigned long long)dropped,
           (unsigned long long)l.write_errors, n_late ? late_sum / (double)n_late * 1e-3 : 0.0,
           (double)late_max * 1e-3, (double)late_ns * 1e-3, (unsigned long long)late, hist,
           hil_stopped() ? "signal" : "duration");
    hil_status_write(o.ready_file, "state=done\npull=%s\npulses=%llu\ndropped_late=%llu\n", o.pull,
                     (unsigned long long)pulses, (unsigned long long)dropped);
    return l.write_errors ? HIL_EXIT_FAIL : 0;
}

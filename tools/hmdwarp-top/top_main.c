/* SPDX-License-Identifier: MIT */
/* hmdwarp-top: a terminal view of a running hmdwarpd, like top: reads the key=value file the daemon rewrites each
 * second ([telemetry] live_stats) and shows rates, misses and why, latency, the host link, the IMU and the warps. */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <signal.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "platform/plat_version.h"
#include "warp/warp_err.h"

/* Where hmdwarpd writes it under systemd (RuntimeDirectory=hmdwarp), and under `make run`. */
#define DEFAULT_FILE "/run/hmdwarp/stats"
#define MAKE_RUN_FILE "build/run/stats"
/* The file is rewritten each second: older than this while it says running=1, the daemon is stuck or gone. */
#define STALE_S 3.0
#define MAX_KEYS 512

typedef struct {
    int n;
    char key[MAX_KEYS][64];
    char val[MAX_KEYS][256];
    double mtime; /* seconds, CLOCK_REALTIME, of the file read */
} kv_set;

static void usage(FILE *f)
{
    fprintf(f, "Usage: hmdwarp-top [options]\n"
               "Shows a running hmdwarpd from the statistics it rewrites each second ([telemetry] live_stats),\n"
               "refreshing like top: vsyncs per second, misses and why, motion-to-photon, frame age, the host link,\n"
               "the IMU and the warp methods. Rates are over the last refresh (the first screen: the run's average).\n"
               "  --file PATH        the statistics file (default " DEFAULT_FILE ", else " MAKE_RUN_FILE
               ",\n"
               "                     which `make run` writes)\n"
               "  --once             print one screen without terminal escapes and exit (scripts, tests)\n"
               "  --interval S       seconds between refreshes (default 1)\n"
               "  -h, --help         this text\n"
               "  --version          print the version and exit\n"
               "Exit status: 0, or 1 when the file cannot be read or holds no hmdwarpd statistics.\n");
}

/* Reads key=value lines; a line without '=' or with an over-long key is skipped, an over-long value cut. */
static bool kv_read(const char *path, kv_set *s, char *err, size_t errlen)
{
    s->n = 0;
    FILE *f = fopen(path, "r");
    if (!f) {
        return warp_err(err, (int)errlen, "%s: %s", path, strerror(errno));
    }
    struct stat st;
    s->mtime = fstat(fileno(f), &st) == 0 ? (double)st.st_mtim.tv_sec + st.st_mtim.tv_nsec * 1e-9 : 0;
    char line[512];
    while (fgets(line, sizeof line, f) && s->n < MAX_KEYS) {
        size_t len = strlen(line);
        bool whole = len && line[len - 1] == '\n';
        if (whole) line[--len] = 0;
        char *eq = strchr(line, '=');
        if (eq && eq > line && (size_t)(eq - line) < sizeof s->key[0]) {
            snprintf(s->key[s->n], sizeof s->key[0], "%.*s", (int)(eq - line), line);
            snprintf(s->val[s->n], sizeof s->val[0], "%s", eq + 1);
            s->n++;
        }
        /* the rest of a line longer than the buffer is not a line of its own */
        while (!whole) {
            int c = fgetc(f);
            if (c == EOF || c == '\n') break;
        }
    }
    fclose(f);
    /* every hmdwarpd statistics file starts with version= */
    if (!s->n || strcmp(s->key[0], "version") != 0) {
        return warp_err(err, (int)errlen, "%s: no hmdwarpd statistics in it (expected key=value lines from version=)",
                        path);
    }
    return true;
}

static const char *kv_str(const kv_set *s, const char *key)
{
    for (int i = 0; i < s->n; i++)
        if (strcmp(s->key[i], key) == 0) return s->val[i];
    return NULL;
}

static double kv_num(const kv_set *s, const char *key)
{
    const char *v = kv_str(s, key);
    char *end;
    double d = v && *v ? strtod(v, &end) : NAN;
    return v && *v && *end == 0 ? d : NAN;
}

/* A rate over the last refresh when there was one, else over the run. */
static double rate(const kv_set *cur, const kv_set *prev, const char *key)
{
    double now = kv_num(cur, key), t = kv_num(cur, "run_s");
    if (prev) {
        double dt = t - kv_num(prev, "run_s");
        if (dt > 0.05) return (now - kv_num(prev, key)) / dt;
    }
    return t >= 0.05 ? now / t : NAN;
}

/* a rate with `prec` decimals, "-" before there is one (the first second) */
static const char *fmt_rate(double r, int prec, char *buf, size_t len)
{
    if (!isfinite(r)) return "-";
    snprintf(buf, len, "%.*f", prec, r);
    return buf;
}

/* "12" or "-" for a missing key: a file from an older hmdwarpd lacks some */
static const char *num(const kv_set *s, const char *key, char *buf, size_t len)
{
    double d = kv_num(s, key);
    if (isnan(d)) return "-";
    if (d == floor(d) && fabs(d) < 1e15)
        snprintf(buf, len, "%.0f", d);
    else
        snprintf(buf, len, "%.2f", d);
    return buf;
}

static void screen(FILE *out, const char *path, const kv_set *s, const kv_set *prev)
{
    char b[8][64];
    const char *avg = prev ? "" : " (run average)";
    double age = (double)time(NULL) - s->mtime;
    bool running = kv_num(s, "running") == 1;
    fprintf(out, "hmdwarp-top — %s: board %s, hmdwarpd %s, %s %.1f s%s\n", path, kv_str(s, "board") ?: "?",
            kv_str(s, "version"), running ? "running" : "finished after", kv_num(s, "run_s"),
            running && age > STALE_S ? "; NOT UPDATED for over 3 s: hmdwarpd stopped or hung" : "");
    double v = kv_num(s, "vsyncs"), m = kv_num(s, "missed");
    fprintf(out, "display    %6s vsyncs/s%s   vsyncs %s   missed %s (%.2f %%)\n",
            fmt_rate(rate(s, prev, "vsyncs"), 1, b[7], 64), avg, num(s, "vsyncs", b[0], 64), num(s, "missed", b[1], 64), v > 0 ? 100.0 * m / v : 0.0);
    fprintf(out, "  missed   own %s, woken late %s, descheduled %s, no free image %s; no frame yet %s\n",
            num(s, "missed_own", b[0], 64), num(s, "missed_late_wake", b[1], 64),
            num(s, "missed_descheduled", b[2], 64), num(s, "missed_no_buffer", b[3], 64), num(s, "no_frame", b[4], 64));
    fprintf(out, "latency    motion-to-photon p50 %s ms, p99 %s ms; frame age p50 %s ms, max %s ms\n",
            num(s, "m2p_ms_p50", b[0], 64), num(s, "m2p_ms_p99", b[1], 64), num(s, "frame_age_ms_p50", b[2], 64),
            num(s, "frame_age_ms_max", b[3], 64));
    fprintf(out, "           warp p50 %s ms, p99 %s ms; outside the source p50 %s %%, p99 %s %% of the visible pixels\n",
            num(s, "warp_ms_p50", b[0], 64), num(s, "warp_ms_p99", b[1], 64), num(s, "outside_source_pct_p50", b[2], 64),
            num(s, "outside_source_pct_p99", b[3], 64));
    fprintf(out, "host link  %s: %s MB/s, %s frames/s%s; received %s, shown %s, dropped unseen %s, rejected %s\n",
            kv_str(s, "frames_backend") ?: "?", fmt_rate(rate(s, prev, "frames_bytes") / (1024 * 1024), 1, b[6], 64),
            fmt_rate(rate(s, prev, "frames_received"), 1, b[7], 64), avg, num(s, "frames_received", b[0], 64), num(s, "frames_shown", b[1], 64),
            num(s, "frames_dropped", b[2], 64), num(s, "frames_rejected", b[3], 64));
    /* the reasons, only those that occurred */
    bool any = false;
    for (int i = 0; i < s->n; i++)
        if (strncmp(s->key[i], "frames_rejected_", 16) == 0 && strcmp(s->val[i], "0") != 0) {
            fprintf(out, "%s%s %s", any ? ", " : "  rejected ", s->key[i] + 16, s->val[i]);
            any = true;
        }
    if (any) fputc('\n', out);
    fprintf(out, "IMU        %s: %s samples/s%s, read errors %s, lost %s, held orientation %s vsyncs",
            kv_str(s, "imu_backend") ?: "?", fmt_rate(rate(s, prev, "imu_samples"), 0, b[7], 64), avg, num(s, "imu_read_errors", b[0], 64), num(s, "imu_lost", b[1], 64),
            num(s, "imu_stale_vsyncs", b[2], 64));
    if (kv_str(s, "imu_connected"))
        fprintf(out, "; %s, reconnects %s", kv_num(s, "imu_connected") == 1 ? "connected" : "NOT connected",
                num(s, "imu_reconnects", b[0], 64));
    fputc('\n', out);
    fprintf(out, "vsync      %s", kv_str(s, "vsync_backend") ?: "?");
    if (kv_str(s, "vsync_edges"))
        fprintf(out, ": edges %s, spurious %s, timer fallbacks %s%s, jitter %s us", num(s, "vsync_edges", b[0], 64),
                num(s, "vsync_spurious", b[1], 64), num(s, "vsync_fallbacks", b[2], 64),
                kv_num(s, "vsync_on_timer") == 1 ? " (on timer now)" : "", num(s, "vsync_jitter_us", b[3], 64));
    fputc('\n', out);
    fprintf(out, "renderer   %s%s%s, output %s\n", kv_str(s, "renderer") ?: "?",
            kv_str(s, "gl_renderer") && *kv_str(s, "gl_renderer") ? " " : "", kv_str(s, "gl_renderer") ?: "",
            kv_str(s, "display_output") ?: "?");
    fprintf(out, "warps     ");
    for (int i = 0; i < s->n; i++)
        if (strncmp(s->key[i], "method_", 7) == 0 && strcmp(s->key[i], "method_switches") != 0)
            fprintf(out, " %s %s", s->key[i] + 7, s->val[i]);
    fprintf(out, "; switches %s\n", num(s, "method_switches", b[0], 64));
}

static volatile sig_atomic_t quit;
static void on_int(int sig)
{
    (void)sig;
    quit = 1;
}

int main(int argc, char **argv)
{
    const char *file = NULL;
    bool once = false;
    double interval = 1.0;
    static const struct option opts[] = {{"file", 1, 0, 'f'}, {"once", 0, 0, 'o'}, {"interval", 1, 0, 'i'},
                                         {"help", 0, 0, 'h'}, {"version", 0, 0, 'V'}, {0, 0, 0, 0}};
    int o;
    while ((o = getopt_long(argc, argv, "h", opts, NULL)) != -1) {
        switch (o) {
        case 'f': file = optarg; break;
        case 'o': once = true; break;
        case 'i': {
            char *end;
            interval = strtod(optarg, &end);
            if (*end || !(interval >= 0.1 && interval <= 3600)) {
                fprintf(stderr, "hmdwarp-top: --interval '%s': expected seconds from 0.1 to 3600\n", optarg);
                return 2;
            }
            break;
        }
        case 'h': usage(stdout); return 0;
        case 'V': printf("hmdwarp-top %s\n", plat_version()); return 0;
        default: usage(stderr); return 2;
        }
    }
    if (optind < argc) {
        fprintf(stderr, "hmdwarp-top: unexpected argument '%s' (see --help)\n", argv[optind]);
        return 2;
    }
    if (!file) file = access(DEFAULT_FILE, F_OK) != 0 && access(MAKE_RUN_FILE, F_OK) == 0 ? MAKE_RUN_FILE : DEFAULT_FILE;
    static kv_set cur, last, before;
    char err[400];
    if (once) {
        if (!kv_read(file, &cur, err, sizeof err)) {
            fprintf(stderr, "hmdwarp-top: %s\n", err);
            return 1;
        }
        screen(stdout, file, &cur, NULL);
        return 0;
    }
    struct sigaction sa = {.sa_handler = on_int};
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    int have = 0; /* distinct samples held: last, and the one before it (the rates' baseline) */
    while (!quit) {
        /* home and clear, then the screen: plain ANSI, any terminal */
        fputs("\033[H\033[2J", stdout);
        if (kv_read(file, &cur, err, sizeof err)) {
            /* a refresh faster than the daemon's second reads the same sample again: the rates keep their base */
            if (!have || kv_num(&cur, "run_s") != kv_num(&last, "run_s")) {
                if (have) before = last;
                last = cur;
                have = have < 2 ? have + 1 : 2;
            }
            screen(stdout, file, &last, have == 2 ? &before : NULL);
        } else {
            printf("hmdwarp-top: %s\n(waiting for hmdwarpd; Ctrl-C quits)\n", err);
            have = 0;
        }
        printf("\n(every %.1f s; Ctrl-C quits)\n", interval);
        fflush(stdout);
        struct timespec ts = {(time_t)interval, (long)((interval - floor(interval)) * 1e9)};
        nanosleep(&ts, NULL);
    }
    return 0;
}

/* SPDX-License-Identifier: MIT */
/* Live telemetry of a running hmdwarpd: the STATUS= line a stand-in systemd reads, the stats file rewritten each
 * second and hmdwarp-top's view of it, the summary on SIGTERM and SIGABRT, the CSV's rotation, log priorities. */
#include <fcntl.h>
#include <libgen.h>
#include <math.h>
#include <setjmp.h>
#include <signal.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "platform/plat_log.h"
#include "runtime/rt_telemetry.h"
#include "tests/support/test_notify.h"
#include "tests/support/test_util.h"

static char build[256], tmp[300];
/* The simulated board, small and quick to start; no accuracy evaluation (it would hold the exit back). */
#define RUN_ARGS "--config board/sim/board.ini --set sim.imu_rest_s=0.2 --set sim.eval_every_ms=0 " \
                 "--set render.rt_priority=0"

static int sh(const char *cmd, char *out, size_t cap)
{
    FILE *p = popen(cmd, "r");
    if (!p) return -1;
    size_t n = 0;
    if (out && cap) {
        n = fread(out, 1, cap - 1, p);
        out[n] = 0;
    } else {
        char sink[512];
        while (fread(sink, 1, sizeof sink, p) > 0) {
        }
    }
    int st = pclose(p);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

/* Starts hmdwarpd (exec'd by sh, so the pid is hmdwarpd's) with stdout and stderr into out_path. */
static pid_t spawn(const char *args, const char *out_path)
{
    char cmd[4096]; /* runner, build, args and out_path at their largest */
    snprintf(cmd, sizeof cmd, "exec %s%s/hmdwarpd " RUN_ARGS " %s >%s 2>&1 </dev/null", test_runner(), build, args,
             out_path);
    pid_t pid = fork();
    if (pid == 0) {
        struct rlimit no_core = {0, 0};
        setrlimit(RLIMIT_CORE, &no_core); /* the SIGABRT test leaves no core file behind */
        execl("/bin/sh", "sh", "-c", cmd, (char *)NULL);
        _exit(127);
    }
    return pid;
}

/* Waits until the live file says the display runs and has shown at least `shown` host frames: counts, not a
 * wall-clock sleep, so a slow start (the simulated host's first frames take seconds under qemu-user, where the
 * daemon runs in real time) only takes longer. The cap, 5 minutes, is there against a hung start only; reaching
 * it fails the test. */
#define LIVE_CAP_S 300
static bool wait_live(const char *path, char *text, size_t cap, double shown)
{
    for (int i = 0; i < LIVE_CAP_S * 100; i++) {
        if (test_slurp(path, text, cap) && test_kv(text, "vsyncs") > 0 && test_kv(text, "running") == 1 &&
            test_kv(text, "frames_shown") >= shown)
            return true;
        usleep(10000);
    }
    return false;
}

typedef struct {
    int ready, status, stopping, order_ok, content_ok;
    char last_status[1024];
    pid_t pid;        /* the daemon, stopped with SIGTERM once its live file says it has shown a host frame */
    const char *live;
    bool stopped;
} status_counts;

static bool count_status(const char *msg, void *ctx)
{
    status_counts *c = ctx;
    if (strstr(msg, "READY=1")) c->ready++;
    if (strncmp(msg, "STATUS=", 7) == 0) {
        c->status++;
        char text[16384];
        if (!c->stopped && test_slurp(c->live, text, sizeof text) && test_kv(text, "frames_shown") >= 1) {
            kill(c->pid, SIGTERM);
            c->stopped = true;
        }
        if (!c->ready) c->order_ok = 0;
        /* vsyncs, missed and why, m2p p99, frame age, link */
        const char *need[] = {"vsyncs/s", "missed", "own", "woken late", "descheduled", "m2p p99", "frame age",
                              "MB/s", "frames/s"};
        for (size_t i = 0; i < sizeof need / sizeof need[0]; i++)
            if (!strstr(msg, need[i])) c->content_ok = 0;
        snprintf(c->last_status, sizeof c->last_status, "%s", msg);
    }
    if (strstr(msg, "STOPPING=1")) c->stopping++;
    return c->stopping != 0;
}

/* hmdwarpd running until stopped with a live file (TMP/NAME.live, its output in TMP/NAME.out), and whether that
 * file came to say it runs and has shown `shown` host frames (up; r->text holds what it said). extra_args: more
 * hmdwarpd arguments. */
typedef struct {
    char live[400], out[400], text[16384];
    pid_t pid;
    bool up;
} live_run;

static void live_start(live_run *r, const char *name, const char *extra_args, double shown)
{
    snprintf(r->live, sizeof r->live, "%s/%s.live", tmp, name);
    snprintf(r->out, sizeof r->out, "%s/%s.out", tmp, name);
    unlink(r->live);
    char args[1200];
    snprintf(args, sizeof args, "--duration 0 --set telemetry.live_stats=%s %s", r->live, extra_args);
    r->pid = spawn(args, r->out);
    assert_true(r->pid > 0);
    r->up = wait_live(r->live, r->text, sizeof r->text, shown);
}

/* Sends sig and reaps the daemon; returns its wait status. */
static int live_stop(live_run *r, int sig)
{
    kill(r->pid, sig);
    int st = 0;
    assert_int_equal(waitpid(r->pid, &st, 0), r->pid);
    return st;
}

static void test_status_line_and_live_file(void **state)
{
    (void)state;
    /* hmdwarpd under a stand-in for systemd: STATUS= once a second, after READY=1, naming what `systemctl
     * status hmdwarpd` should show; stopped (SIGTERM) once it has shown a host frame, or it would exit 1: counts,
     * so a slow start only takes longer; the live file ends as the --stats file does */
    test_notify ns;
    assert_true(test_notify_open(&ns, "live"));
    char live[400], stats[400], args[1000], daemon_out[400], cmd[2000];
    snprintf(live, sizeof live, "%s/status.live", tmp);
    snprintf(stats, sizeof stats, "%s/status.stats", tmp);
    snprintf(daemon_out, sizeof daemon_out, "%s/status.out", tmp);
    unlink(live);
    snprintf(args, sizeof args, "--duration 0 --set telemetry.live_stats=%s --stats %s", live, stats);
    setenv("NOTIFY_SOCKET", ns.path, 1); /* for the daemon alone */
    status_counts sc = {0, 0, 0, 1, 1, "", spawn(args, daemon_out), live, false};
    unsetenv("NOTIFY_SOCKET");
    assert_true(sc.pid > 0);
    test_notify_read(&ns, LIVE_CAP_S * 1000, count_status, &sc);
    if (!sc.stopped) kill(sc.pid, SIGTERM); /* the cap: a hung start */
    int st = 0;
    assert_int_equal(waitpid(sc.pid, &st, 0), sc.pid);
    test_notify_close(&ns);
    assert_true(sc.stopped);
    assert_true(WIFEXITED(st) && WEXITSTATUS(st) == 0);
    const char *last_status = sc.last_status;
    print_message("notify: READY %d, STATUS %d, STOPPING %d; last: %s\n", sc.ready, sc.status, sc.stopping,
                  last_status);
    assert_int_equal(sc.ready, 1);
    assert_int_equal(sc.stopping, 1);
    assert_true(sc.status >= 1);
    assert_true(sc.order_ok);
    assert_true(sc.content_ok);
    /* the status says how many vsyncs: a number, not a placeholder */
    unsigned long long v = 0;
    const char *p = strstr(last_status, "vsyncs/s, ");
    assert_non_null(p);
    assert_int_equal(sscanf(p, "vsyncs/s, %llu vsyncs", &v), 1);
    assert_true(v > 0);

    /* at the end the live file is the --stats file: same keys, same counts (run_s aside: written a moment apart) */
    char a[16384], b[16384];
    assert_true(test_slurp(live, a, sizeof a) > 0);
    assert_true(test_slurp(stats, b, sizeof b) > 0);
    snprintf(cmd, sizeof cmd, "diff <(grep -v '^run_s=' %s) <(grep -v '^run_s=' %s)", live, stats);
    char c2[2100];
    snprintf(c2, sizeof c2, "bash -c \"%s\"", cmd);
    char out[2000];
    int rc = sh(c2, out, sizeof out);
    if (rc != 0) fail_msg("live file differs from --stats:\n%s", out);
    assert_true(test_kv(a, "running") == 0);
    assert_true(test_kv(a, "vsyncs") > 0);
    /* nothing left behind by the atomic rewrite */
    snprintf(cmd, sizeof cmd, "%s.tmp", live);
    assert_int_equal(access(cmd, F_OK), -1);
}

/* The host frames the daemon has shown when hmdwarp-top looks. */
#define TOP_FRAMES 3
static void test_top_shows_running_daemon_and_sigterm_summary(void **state)
{
    (void)state;
    /* a run until stopped: hmdwarp-top --once shows it while it runs; SIGTERM stops it with the summary, exit 0
     * (a run that showed no host frame exits 1: the top is taken once the daemon has shown some) */
    static live_run r;
    live_start(&r, "term", "", TOP_FRAMES);
    char cmd[1200], top[8192];
    snprintf(cmd, sizeof cmd, "%s%s/hmdwarp-top --once --file %s 2>&1", test_runner(), build, r.live);
    int top_rc = r.up ? sh(cmd, top, sizeof top) : -1;
    int st = live_stop(&r, SIGTERM);
    assert_true(r.up);
    print_message("hmdwarp-top --once:\n%s", top);
    assert_int_equal(top_rc, 0);
    const char *need[] = {"board sim", ", running ", "vsyncs/s", "missed   own", "motion-to-photon p50",
                          "frame age p50", "host link  sim:", "MB/s", "IMU        sim:", "renderer   cpu",
                          "warps      none 0 rotation "};
    for (size_t i = 0; i < sizeof need / sizeof need[0]; i++)
        if (!strstr(top, need[i])) fail_msg("hmdwarp-top lacks '%s'", need[i]);
    /* the counts it shows are the file's */
    unsigned long long v = 0;
    const char *p = strstr(top, "   vsyncs ");
    assert_non_null(p);
    assert_int_equal(sscanf(p, "   vsyncs %llu", &v), 1);
    assert_true(v > 0);
    unsigned long long shown = 0;
    p = strstr(top, ", shown ");
    assert_non_null(p);
    assert_int_equal(sscanf(p, ", shown %llu", &shown), 1);
    assert_true(shown >= TOP_FRAMES);

    char o[65536];
    test_slurp(r.out, o, sizeof o);
    if (!WIFEXITED(st) || WEXITSTATUS(st) != 0) fail_msg("SIGTERM: status %d; output:\n%s", st, o);
    assert_non_null(strstr(o, "summary —"));
    assert_non_null(strstr(o, "  vsyncs  "));
    test_slurp(r.live, r.text, sizeof r.text);
    assert_true(test_kv(r.text, "running") == 0); /* the final word, as --stats */
}

static void test_sigabrt_prints_last_stats(void **state)
{
    (void)state;
    /* systemd's watchdog sends SIGABRT: the process still dies of it, but says first what it saw */
    static live_run r;
    live_start(&r, "abrt", "", 0); /* what it saw, frames or none */
    /* the handler prints the live file's snapshot: abort once that has a motion-to-photon value (on a busy machine
     * the first second's vsyncs can all come before the first IMU sample: m2p_ms_p99 absent, make test-busy) */
    for (int i = 0; i < 6000 && r.up && !(test_kv(r.text, "m2p_ms_p99") > 0); i++) {
        usleep(10000);
        test_slurp(r.live, r.text, sizeof r.text);
    }
    int st = live_stop(&r, SIGABRT);
    assert_true(r.up);
    char o[65536];
    test_slurp(r.out, o, sizeof o);
    if (!WIFSIGNALED(st) || WTERMSIG(st) != SIGABRT) fail_msg("SIGABRT: status %d; output:\n%s", st, o);
    const char *s = strstr(o, "hmdwarpd: aborted (SIGABRT");
    if (!s) fail_msg("no abort report; output:\n%s", o);
    s = strchr(s, '\n');
    assert_non_null(s);
    s++;
    assert_int_equal(strncmp(s, "version=", 8), 0);
    assert_true(test_kv(s, "running") == 1);
    assert_true(test_kv(s, "vsyncs") > 0);
    assert_true(test_kv(s, "m2p_ms_p99") > 0);
}

/* bytes in path, 0 when it is not there */
static long file_size(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 ? (long)st.st_size : 0;
}

static void test_csv_rotates_by_size(void **state)
{
    (void)state;
    char csv[400], old[420], extra[600], a[65536], b[65536];
    snprintf(csv, sizeof csv, "%s/rot.csv", tmp);
    snprintf(old, sizeof old, "%s.1", csv);
    /* 2 KB: about 30 rows. The daemon runs until it has shown a host frame (or it would exit 1) and the CSV has
     * rotated with rows after it: counts, so a busy machine or an emulator only takes longer. */
    const double max_mb = 2048.0 / (1024 * 1024);
    snprintf(extra, sizeof extra, "--csv %s --set telemetry.csv_max_mb=%.9f", csv, max_mb);
    const char *header = "vsync,vsync_ns,frame_seq,method,warp_ms,missed,m2p_ms,frame_age_ms\n";
    size_t na = 0, nb = 0;
    /* a run that ended right after a rotation leaves the new file with its header alone, and nothing to check
     * the continuation on (make test-busy once did): run again, three times at most */
    for (int run = 0; run < 3 && nb <= strlen(header); run++) {
        unlink(csv);
        unlink(old);
        static live_run r;
        live_start(&r, "rot", extra, 1);
        /* rotated (FILE.1 is there), then more vsyncs, each a row: the live file's count goes up (the current
         * file's rows wait in stdio's buffer until it is closed, so its size says nothing yet) */
        double rotated_at = -1;
        for (int i = 0; r.up && i < LIVE_CAP_S * 100; i++) {
            bool read = test_slurp(r.live, r.text, sizeof r.text) > 0;
            if (rotated_at < 0 && read && file_size(old) > 0) rotated_at = test_kv(r.text, "vsyncs");
            if (rotated_at >= 0 && read && test_kv(r.text, "vsyncs") > rotated_at) break;
            usleep(10000);
        }
        int st = live_stop(&r, SIGTERM);
        assert_true(r.up);
        assert_true(WIFEXITED(st) && WEXITSTATUS(st) == 0);
        na = test_slurp(old, a, sizeof a);
        nb = test_slurp(csv, b, sizeof b);
        print_message("rot.csv.1 %zu bytes, rot.csv %zu bytes\n", na, nb);
    }
    assert_true(na > 0 && nb > 0);
    assert_int_equal(strncmp(a, header, strlen(header)), 0);
    assert_int_equal(strncmp(b, header, strlen(header)), 0);
    /* a file reaches the limit by at most one row (the row that crossed it) */
    assert_true(na >= 2048 && na < 2048 + 120);
    assert_true(nb > strlen(header) && nb < 2048 + 120);
    /* the current file continues where the rotated one ended: vsync numbers go on rising */
    const char *last = a + na - 1;
    while (last > a && last[-1] != '\n') last--;
    unsigned long long last_old = strtoull(last, NULL, 10), first_new = strtoull(b + strlen(header), NULL, 10);
    assert_true(first_new > last_old);
}

static void test_bad_live_path_is_an_error(void **state)
{
    (void)state;
    char cmd[1200], out[4096];
    snprintf(cmd, sizeof cmd, "%s%s/hmdwarpd " RUN_ARGS " --duration 1 --set telemetry.live_stats=%s/no-such-dir/stats "
             "2>&1 </dev/null", test_runner(), build, tmp);
    int rc = sh(cmd, out, sizeof out);
    print_message("%s", out);
    assert_int_equal(rc, 1);
    assert_non_null(strstr(out, "[telemetry] live_stats = "));
    assert_non_null(strstr(out, "no-such-dir/stats: No such file or directory"));
}

static void test_top_refuses_what_is_not_stats(void **state)
{
    (void)state;
    char cmd[1200], out[2048];
    snprintf(cmd, sizeof cmd, "%s%s/hmdwarp-top --once --file %s/nonexistent 2>&1", test_runner(), build, tmp);
    assert_int_equal(sh(cmd, out, sizeof out), 1);
    assert_non_null(strstr(out, "nonexistent: No such file or directory"));
    snprintf(cmd, sizeof cmd, "%s%s/hmdwarp-top --once --file board/sim/board.ini 2>&1", test_runner(), build);
    assert_int_equal(sh(cmd, out, sizeof out), 1);
    assert_non_null(strstr(out, "no hmdwarpd statistics"));
}

static void test_log_priorities(void **state)
{
    (void)state;
    /* stderr into a file; JOURNAL_STREAM naming that file makes it "the journal" */
    char path[400], text[1024];
    snprintf(path, sizeof path, "%s/log.txt", tmp);
    int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    assert_true(fd >= 0);
    fflush(stderr);
    int saved = dup(STDERR_FILENO);
    dup2(fd, STDERR_FILENO);
    struct stat st;
    fstat(fd, &st);
    char js[64];
    snprintf(js, sizeof js, "%llu:%llu", (unsigned long long)st.st_dev, (unsigned long long)st.st_ino);
    setenv("JOURNAL_STREAM", js, 1);
    plat_log_reset();
    plat_log(PLAT_LOG_WARNING, "IMU %s lost", "hid");
    plat_log(PLAT_LOG_ERR, "%d errors", 2);
    plat_log(PLAT_LOG_NOTICE, "back");
    /* a JOURNAL_STREAM inherited by a process whose stderr went elsewhere is not the journal */
    setenv("JOURNAL_STREAM", "1:2", 1);
    plat_log_reset();
    plat_log(PLAT_LOG_WARNING, "plain");
    unsetenv("JOURNAL_STREAM");
    plat_log_reset();
    plat_log(PLAT_LOG_INFO, "plain too");
    dup2(saved, STDERR_FILENO);
    close(saved);
    close(fd);
    test_slurp(path, text, sizeof text);
    assert_string_equal(text, "<4>IMU hid lost\n<3>2 errors\n<5>back\ntest_live: plain\ntest_live: plain too\n");
}

static void test_hist_last_second(void **state)
{
    (void)state;
    /* percentiles over what came since the mark, the mark moving on: STATUS's "last second" */
    rt_telemetry *t = rt_telemetry_create();
    rt_hist_mark *m = calloc(1, sizeof *m);
    assert_non_null(t);
    assert_non_null(m);
    assert_true(isnan(rt_hist_pct_since(&t->m2p_ms, m, 99)));
    for (int i = 1; i <= 100; i++) rt_hist_add(&t->m2p_ms, 100.0 + i); /* 101..200 ms */
    assert_true(fabs(rt_hist_pct_since(&t->m2p_ms, m, 99) - 199.0) < 0.02);
    for (int i = 0; i < 50; i++) rt_hist_add(&t->m2p_ms, 5.0);
    assert_true(fabs(rt_hist_pct_since(&t->m2p_ms, m, 99) - 5.005) < 0.001); /* the old samples are gone */
    assert_true(fabs(rt_hist_pct(&t->m2p_ms, 50) - 125.0) < 0.02);          /* the whole run still has them */
    assert_true(isnan(rt_hist_pct_since(&t->m2p_ms, m, 50)));               /* nothing new */
    rt_hist_add(&t->m2p_ms, 1000.0);                                        /* the overflow bin */
    assert_true(rt_hist_pct_since(&t->m2p_ms, m, 50) >= 250.0);
    free(m);
    rt_telemetry_destroy(t);
}

int main(int argc, char **argv)
{
    (void)argc;
    if (!test_build_dirs(argv[0], build, sizeof build, tmp, sizeof tmp, "live")) return 1;
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_hist_last_second),
        cmocka_unit_test(test_log_priorities),
        cmocka_unit_test(test_status_line_and_live_file),
        cmocka_unit_test(test_top_shows_running_daemon_and_sigterm_summary),
        cmocka_unit_test(test_sigabrt_prints_last_stats),
        cmocka_unit_test(test_csv_rotates_by_size),
        cmocka_unit_test(test_bad_live_path_is_an_error),
        cmocka_unit_test(test_top_refuses_what_is_not_stats),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

/* SPDX-License-Identifier: MIT */
/* hmdwarpd as a program with configurations that cannot work: a path that is no board.ini fails at once (exit 2),
 * --check-config refuses limits that cannot hold the configured frames, and a run that shows no host frame exits 1
 * with a summary line saying why, while a run with damaged frames among good ones shows them and exits 0. */
#include <libgen.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <cmocka.h>

#include "tests/support/test_util.h"

static char build[256], tmp[300];

/* Runs a shell command with a time limit (a hang is the failure being tested), stdout and stderr into out. */
static int sh(const char *cmd, char *out, size_t cap)
{
    char full[4096];
    snprintf(full, sizeof full, "timeout 60 %s 2>&1", cmd);
    FILE *p = popen(full, "r");
    assert_non_null(p);
    size_t n = fread(out, 1, cap - 1, p);
    out[n] = 0;
    char sink[4096];
    while (fread(sink, 1, sizeof sink, p) > 0) {
    }
    int st = pclose(p);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

static int hmdwarpd(const char *args, char *out, size_t cap)
{
    char cmd[2048];
    snprintf(cmd, sizeof cmd, "%s%s/hmdwarpd %s", test_runner(), build, args);
    return sh(cmd, out, cap);
}

static void expect(const char *args, int rc_want, const char *needle)
{
    static char out[65536];
    int rc = hmdwarpd(args, out, sizeof out);
    if (rc != rc_want || !strstr(out, needle))
        fail_msg("hmdwarpd %s: exit %d (want %d), output lacks '%s':\n%s", args, rc, rc_want, needle, out);
}

static void test_no_board_ini_fails_fast(void **state)
{
    (void)state;
    /* /dev/zero used to hang reading, a directory ran on the defaults and exited 0 */
    expect("--check-config --config /dev/zero", 2, "/dev/zero: not a regular file");
    expect("--config /dev/urandom --duration 1", 2, "/dev/urandom: not a regular file");
    expect("--config /tmp --duration 1", 2, "/tmp: a directory");
    char fifo[400], args[600];
    snprintf(fifo, sizeof fifo, "%s/fifo", tmp);
    remove(fifo);
    assert_int_equal(mkfifo(fifo, 0600), 0);
    snprintf(args, sizeof args, "--check-config --config %s", fifo);
    expect(args, 2, "not a regular file");
}

static void test_check_config_refuses_what_cannot_show(void **state)
{
    (void)state;
    /* every frame would be rejected as too large */
    expect("--check-config --set frames.backend=usb --set frames.device=mock --set frames.max_frame_mb=1", 2,
           "[frames] max_frame_mb = 1: a host frame of two");
    /* gigabytes locked for a board that shows nothing */
    expect("--check-config --set frames.backend=usb --set frames.device=mock --set frames.max_frame_mb=4096", 2,
           "[render] max_memory_mb = 2048: this configuration allocates about");
    expect("--check-config --set eye.width=8192 --set eye.height=8192", 2, "[eye] width (command line, override 1)");
    /* and a configuration that fits says how much it allocates */
    expect("--check-config", 0, "; allocates about");
}

/* Small eyes and 2 s, so that a host frame or two arrives even on a machine busy with other work (a run that shows
 * nothing is what the last test must not be). */
#define RUN                                                                                                       \
    "--config tests/hil/boards/sim-v4l2-sim.ini --duration 2 --set sim.imu_rest_s=0.2 --set render.rt_priority=0 " \
    "--set render.kernel=auto "

static void test_run_that_shows_nothing_fails(void **state)
{
    (void)state;
    /* every host frame damaged: the board warps nothing but black; that is a failure, not exit 0 */
    expect(RUN "--set frames.backend=usb --set frames.device=mock --set mock.corrupt_every=1", 1,
           "result                       FAILED, nothing shown: every host frame was rejected");
    expect(RUN "--set frames.backend=v4l2 --set frames.device=mock --set mock.corrupt_every=1", 1,
           "nothing shown: every host frame was rejected");
}

/* The V4L2 mock honours [mock] corrupt_every: the damaged frames are rejected by reason, counted in --stats, and
 * the good ones between them are shown (exit 0). */
static void test_v4l2_mock_corrupt_every(void **state)
{
    (void)state;
    char stats[400], args[1024], out[65536];
    snprintf(stats, sizeof stats, "%s/v4l2.stats", tmp);
    snprintf(args, sizeof args,
             RUN "--set frames.backend=v4l2 --set frames.device=mock --set mock.corrupt_every=3 --stats %s", stats);
    int rc = hmdwarpd(args, out, sizeof out);
    if (rc != 0) fail_msg("exit %d:\n%s", rc, out);
    FILE *f = fopen(stats, "r");
    assert_non_null(f);
    char line[256];
    long crc = -1, magic = -1, shown = -1;
    while (fgets(line, sizeof line, f)) {
        sscanf(line, "frames_rejected_bad_crc=%ld", &crc);
        sscanf(line, "frames_rejected_bad_magic=%ld", &magic);
        sscanf(line, "frames_shown=%ld", &shown);
    }
    fclose(f);
    if (!(crc > 0 && magic > 0 && shown > 0))
        fail_msg("rejected as bad CRC %ld, as bad magic %ld, shown %ld; want all > 0:\n%s", crc, magic, shown, out);
}

/* The link budget and [frames] link_mbps: --check-config states what the eyes need on the link, warning when nothing
 * fits; a mock link too slow for one frame in the run carries none (exit 1), the same link at 1000 MB/s shows
 * frames. */
static void test_link_budget_and_limit(void **state)
{
    (void)state;
    expect("--check-config --config board/rpi5/board.ini --set frames.backend=socket --set frames.link_mbps=40", 0,
           "; link: socket limited to 40 MB/s ([frames] link_mbps); colour+depth 1440x1600x2 @45 Hz: raw needs "
           "1.66 GB/s, does not fit; coded (");
    expect("--check-config --config board/rpi5/board.ini --set frames.backend=socket --set frames.link_mbps=1", 0,
           "; warning: link: socket limited to 1.0 MB/s");
    char stats[400], args[1024], text[16384];
    static char out[65536];
    snprintf(stats, sizeof stats, "%s/link.stats", tmp);
    /* 320x360 eyes: ~1.8 MB a frame; 0.01 MB/s moves one 16 kB burst and 10 kB a second */
    const double rates[2] = {0.01, 1000};
    for (int i = 0; i < 2; i++) {
        remove(stats);
        /* raw frames (codecs = raw): a limited mock link announces codecs, and a compressed frame would fit */
        snprintf(args, sizeof args, RUN "--set frames.backend=usb --set frames.device=mock --set frames.link_mbps=%g "
                 "--set frames.codecs=raw --stats %s", rates[i], stats);
        int rc = hmdwarpd(args, out, sizeof out);
        assert_true(test_slurp(stats, text, sizeof text) > 0);
        double received = test_kv(text, "frames_received");
        if (i == 0 && (rc != 1 || received != 0))
            fail_msg("0.01 MB/s: exit %d, %g frames received:\n%s", rc, received, out);
        if (i == 1 && (rc != 0 || !(received >= 1))) fail_msg("1000 MB/s: exit %d, %g frames:\n%s", rc, received, out);
    }
}

/* Virtual time (HMDWARP_TIME_SLOWDOWN, plat_clock.h) is for the simulated board: a device that stamps its events in
 * real time is refused by name, and a value that is no slow-down is said to be one and ignored. */
static void test_time_slowdown_refused_for_real_devices(void **state)
{
    (void)state;
    const char *was = getenv("HMDWARP_TIME_SLOWDOWN");
    char keep[32];
    snprintf(keep, sizeof keep, "%s", was ? was : "");
    setenv("HMDWARP_TIME_SLOWDOWN", "5", 1);
    expect("--config tests/hil/boards/sim-v4l2-sim.ini --duration 1 --set imu.backend=hid "
           "--set imu.device=/dev/hidraw-missing-test",
           1, "HMDWARP_TIME_SLOWDOWN=5: virtual time is for simulated and mock devices, but [imu] is a real one");
    setenv("HMDWARP_TIME_SLOWDOWN", "fast", 1);
    expect("--check-config", 0, "HMDWARP_TIME_SLOWDOWN=fast: not a whole number from 1 to 1000; running in real time");
    if (was)
        setenv("HMDWARP_TIME_SLOWDOWN", keep, 1);
    else
        unsetenv("HMDWARP_TIME_SLOWDOWN");
}

int main(int argc, char **argv)
{
    test_paced_by_sim(TEST_EMULATOR_SLOWDOWN);
    (void)argc;
    if (!test_build_dirs(argv[0], build, sizeof build, tmp, sizeof tmp, "config_cli")) return 1;
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_no_board_ini_fails_fast),
        cmocka_unit_test(test_check_config_refuses_what_cannot_show),
        cmocka_unit_test(test_run_that_shows_nothing_fails),
        cmocka_unit_test(test_v4l2_mock_corrupt_every),
        cmocka_unit_test(test_time_slowdown_refused_for_real_devices),
        cmocka_unit_test(test_link_budget_and_limit),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

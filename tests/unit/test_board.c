/* SPDX-License-Identifier: MIT */
/* The board definitions and the install tree: every board/NAME/board.ini loads and validates; `make install` for a
 * USB-gadget board gives a tree board/flash.sh --dry-run accepts (unit, drop-in, udev rules, sysusers, config);
 * the unit passes systemd-analyze verify where it exists; the udev rules parse; a broken tree is refused. */
#include <libgen.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "tests/support/test_notify.h"
#include "tests/support/test_util.h"
#include <unistd.h>

static char build[256], tmp[300];

static int sh(const char *cmd, char *out, size_t cap)
{
    char full[4096];
    snprintf(full, sizeof full, "%s 2>&1", cmd);
    FILE *p = popen(full, "r");
    assert_non_null(p);
    size_t n = out ? fread(out, 1, cap - 1, p) : 0;
    if (out) out[n] = 0;
    char sink[4096];
    while (fread(sink, 1, sizeof sink, p) > 0) {
    }
    int st = pclose(p);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

static void test_every_board_validates(void **state)
{
    (void)state;
    char cmd[1024], out[8192];
    snprintf(cmd, sizeof cmd, "ls board/*/board.ini");
    assert_int_equal(sh(cmd, out, sizeof out), 0);
    int boards = 0;
    for (char *line = strtok(out, "\n"); line; line = strtok(NULL, "\n")) {
        char o2[4096];
        snprintf(cmd, sizeof cmd, "%s%s/hmdwarpd --check-config --config %s", test_runner(), build, line);
        int rc = sh(cmd, o2, sizeof o2);
        if (rc != 0) fail_msg("%s does not validate:\n%s", line, o2);
        boards++;
    }
    assert_true(boards >= 3); /* sim, rpi5, generic-aarch64 */
}

static void test_install_tree_flashes(void **state)
{
    (void)state;
    char cmd[2048], out[16384];
    /* a cross build's tree (build/TRIPLET, make check-cross) is installed with its own compiler: make with the
     * host's would relink whatever is out of date there with the host's linker, fail, and delete the program */
    const char *leaf = strrchr(build, '/');
    leaf = leaf ? leaf + 1 : build;
    char cross[300] = "";
    if (strstr(leaf, "-linux-")) snprintf(cross, sizeof cross, " CROSS_COMPILE=%s-", leaf);
    snprintf(cmd, sizeof cmd, "rm -rf %s/root && make -s install BUILD=%s DESTDIR=%s/root PREFIX=/usr BOARD=rpi5%s",
             tmp, build, tmp, cross);
    if (sh(cmd, out, sizeof out) != 0) fail_msg("make install: %s", out);
    const char *files[] = {"usr/bin/hmdwarpd", "usr/bin/hmdwarp-feed", "usr/bin/hmdwarp-gadget",
                           "etc/hmdwarp/board.ini", "usr/lib/systemd/system/hmdwarpd.service",
                           "etc/systemd/system/hmdwarpd.service.d/usb-gadget.conf",
                           "usr/lib/udev/rules.d/99-hmdwarp.rules",
                           "usr/lib/sysusers.d/hmdwarp.conf", "usr/share/hmdwarp/boards/rpi5/hmdwarp-rpi5.dts"};
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        snprintf(cmd, sizeof cmd, "test -e %s/root/%s", tmp, files[i]);
        if (sh(cmd, NULL, 0) != 0) fail_msg("missing in the install tree: %s", files[i]);
    }
    /* the layout is what this test checks; the architecture check (rpi5 is aarch64, this build may not be) is
     * tests/flash/test_flash.sh's */
    snprintf(cmd, sizeof cmd, "sed -i 's/^arch = .*/arch = any/' %s/root/etc/hmdwarp/board.ini && "
             "board/flash.sh --tree %s/root --board rpi5 --dry-run", tmp, tmp);
    int rc = sh(cmd, out, sizeof out);
    /* (not echoed: its "ok" lines would read as TAP results) */
    if (rc != 0) fail_msg("flash.sh --dry-run refused the tree:\n%s", out);
    assert_non_null(strstr(out, "board.ini validates"));
    assert_non_null(strstr(out, "would run: tar -C"));
    /* the wrong board, and a tree without its unit, are refused */
    snprintf(cmd, sizeof cmd, "board/flash.sh --tree %s/root --board sim --dry-run", tmp);
    assert_int_not_equal(sh(cmd, out, sizeof out), 0);
    assert_non_null(strstr(out, "is for board 'rpi5'"));
    snprintf(cmd, sizeof cmd, "mv %s/root/usr/lib/systemd/system/hmdwarpd.service %s/unit && board/flash.sh --tree "
                              "%s/root --dry-run; rc=$?; mv %s/unit %s/root/usr/lib/systemd/system/hmdwarpd.service; "
                              "exit $rc",
             tmp, tmp, tmp, tmp, tmp);
    assert_int_not_equal(sh(cmd, out, sizeof out), 0);
    assert_non_null(strstr(out, "MISSING /usr/lib/systemd/system/hmdwarpd.service"));
    /* the unit starts the binary in the tree, with the tree's config */
    snprintf(cmd, sizeof cmd, "grep -q '^ExecStart=/usr/bin/hmdwarpd --config /etc/hmdwarp/board.ini' "
                              "%s/root/usr/lib/systemd/system/hmdwarpd.service", tmp);
    assert_int_equal(sh(cmd, NULL, 0), 0);
}

static void test_unit_and_rules_verify(void **state)
{
    (void)state;
    char cmd[2048], out[16384];
    /* systemd-analyze verify, where the tool exists (it checks keys, values and the ExecStart binary) */
    if (sh("command -v systemd-analyze", NULL, 0) == 0) {
        snprintf(cmd, sizeof cmd,
                 "d=%s/unit-check && rm -rf $d && mkdir -p $d && cp board/systemd/hmdwarpd.service $d/ && "
                 "sed -i 's|/usr/bin/hmdwarpd|%s/hmdwarpd|' $d/hmdwarpd.service && "
                 "SYSTEMD_LOG_LEVEL=warning systemd-analyze verify --man=no $d/hmdwarpd.service",
                 tmp, build);
        int rc = sh(cmd, out, sizeof out);
        /* users and groups of the board do not exist here; everything else must be clean */
        char *p = out, filtered[16384] = "";
        for (char *line = strtok(p, "\n"); line; line = strtok(NULL, "\n"))
            if (!strstr(line, "Failed to resolve") && !strstr(line, "user") && !strstr(line, "group") &&
                !strstr(line, "Cannot add dependency") && !strstr(line, "No such file or directory") &&
                !strstr(line, "Failed to put bus name") && !strstr(line, "Failed to create"))
                snprintf(filtered + strlen(filtered), sizeof filtered - strlen(filtered), "%s\n", line);
        if (filtered[0]) fail_msg("systemd-analyze verify (rc %d):\n%s", rc, filtered);
    } else {
        print_message("systemd-analyze not installed: unit syntax checked by the grep below only\n");
    }
    /* the unit's essentials */
    const char *keys[] = {"^Type=notify", "^WatchdogSec=", "^Restart=on-failure", "^LimitRTPRIO=",
                          "^CPUAffinity=", "^AmbientCapabilities=CAP_SYS_NICE CAP_IPC_LOCK", "^User=hmdwarp",
                          "^RuntimeDirectory=hmdwarp$"};
    for (size_t i = 0; i < sizeof keys / sizeof keys[0]; i++) {
        snprintf(cmd, sizeof cmd, "grep -q '%s' board/systemd/hmdwarpd.service", keys[i]);
        if (sh(cmd, NULL, 0) != 0) fail_msg("hmdwarpd.service lacks %s", keys[i]);
    }
    /* udev rules: every rule is comma-separated KEY[{attr}] OP "value" pairs with udev's operators */
    snprintf(cmd, sizeof cmd,
             "grep -v '^#' board/udev/99-hmdwarp.rules | grep -v '^$' | tr ',' '\\n' | sed 's/^ *//' | "
             "grep -vE '^[A-Z]+(\\{[A-Za-z0-9_]+\\})?(==|!=|\\+=|-=|:=|=)\"[^\"]*\"$'");
    int rc = sh(cmd, out, sizeof out);
    if (rc == 0) fail_msg("udev rules: malformed tokens:\n%s", out);
    /* device-tree overlay, where dtc exists */
    if (sh("command -v dtc", NULL, 0) == 0) {
        snprintf(cmd, sizeof cmd, "dtc -@ -q -I dts -O dtb -o %s/o.dtbo board/rpi5/hmdwarp-rpi5.dts", tmp);
        if (sh(cmd, out, sizeof out) != 0) fail_msg("dtc: %s", out);
    }
}

typedef struct {
    int ready, pings, stopping, order_ok;
} notify_counts;

static bool count_notify(const char *msg, void *ctx)
{
    notify_counts *c = ctx;
    if (strstr(msg, "READY=1")) c->ready++;
    if (strstr(msg, "WATCHDOG=1")) {
        c->pings++;
        if (!c->ready) c->order_ok = 0;
    }
    if (strstr(msg, "STOPPING=1")) c->stopping++;
    return c->stopping != 0;
}

static void test_systemd_notify_and_watchdog(void **state)
{
    (void)state;
    /* hmdwarpd under a stand-in for systemd: READY=1 once started, WATCHDOG=1 while the vsync loop runs (every
     * half WatchdogSec), STOPPING=1 at the end */
    test_notify ns;
    assert_true(test_notify_open(&ns, "notify"));
    char cmd[1200];
    snprintf(cmd, sizeof cmd, "NOTIFY_SOCKET=%s WATCHDOG_USEC=200000 %s%s/hmdwarpd --duration 1.5 --set sim.imu_rest_s=0.2 "
             "--set sim.eval_every_ms=0 --set render.rt_priority=0 >/dev/null 2>&1 </dev/null", ns.path, test_runner(),
             build);
    /* read while it runs, as systemd does (a datagram queue that nobody reads blocks the sender) */
    FILE *child = popen(cmd, "r");
    assert_non_null(child);
    notify_counts nc = {0, 0, 0, 1};
    /* 20 s of real time, more on virtual time (test_paced_by_sim: the run lasts that much longer) */
    test_notify_read(&ns, 20000.0 * plat_clock_slowdown(), count_notify, &nc);
    assert_int_equal(pclose(child), 0);
    test_notify_close(&ns);
    print_message("notify: READY %d, WATCHDOG %d, STOPPING %d\n", nc.ready, nc.pings, nc.stopping);
    assert_int_equal(nc.ready, 1);
    assert_int_equal(nc.stopping, 1);
    assert_true(nc.order_ok);
    assert_true(nc.pings >= 5 && nc.pings <= 20); /* ~1.5 s / 0.1 s while presenting */
}

int main(int argc, char **argv)
{
    test_paced_by_sim(TEST_EMULATOR_SLOWDOWN); /* the notify run is paced by the simulated board */
    (void)argc;
    if (!test_build_dirs(argv[0], build, sizeof build, tmp, sizeof tmp, "board")) return 1;
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_board_validates),
        cmocka_unit_test(test_install_tree_flashes),
        cmocka_unit_test(test_unit_and_rules_verify),
        cmocka_unit_test(test_systemd_notify_and_watchdog),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

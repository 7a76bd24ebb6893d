/* SPDX-License-Identifier: MIT */
/* hmdwarpd: the display runtime of an HMD controller board: command line, configuration, signals, and the run
 * summary. Everything else lives in rt_app and below. */
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <systemd/sd-daemon.h>

#include "platform/plat_log.h"
#include "platform/plat_version.h"
#include "runtime/rt_app.h"
#include "runtime/rt_calib.h"
#include "runtime/rt_link_budget.h"
#include "runtime/rt_config.h"
#include "sim/sim_scene.h"
#include "sim/sim_trace.h"

static rt_app app;

static volatile sig_atomic_t stopped_by_signal;

static void on_signal(int sig)
{
    (void)sig;
    stopped_by_signal = 1;
    rt_app_request_stop(&app); /* an atomic store: async-signal-safe */
}

/* systemd's watchdog ends a hung run with SIGABRT, which stops nothing cleanly: say what the run saw (the helper
 * thread's last key=value set, at most a second old) with write(2) alone, then die of the signal as before. */
static void on_abort(int sig)
{
    static const char head[] = "\nhmdwarpd: aborted (SIGABRT: systemd's watchdog or a failed check); the last "
                               "statistics, at most a second old:\n";
    if (write(STDOUT_FILENO, head, sizeof head - 1) > 0) rt_app_write_last_stats(&app, STDOUT_FILENO);
    raise(sig); /* SA_RESETHAND: the default action now */
}

static void usage(FILE *out)
{
    fprintf(out,
            "Usage: hmdwarpd [options]\n"
            "Warps the newest host frame to the predicted head pose at every vsync, corrects the lens, and shows it.\n"
            "\n"
            "options:\n"
            "  --config FILE       board configuration (default: board/sim/board.ini if present)\n"
            "  --calibration FILE  the calibration file read after the configuration (shorthand for --set\n"
            "                      board.calibration=FILE; default " RT_CONFIG_CALIBRATION_DEFAULT ")\n"
            "  --calibrate-imu     measure the IMU at rest (gyro bias, gravity, tilt), write [imu] gyro_bias and\n"
            "                      gravity into the calibration file, and exit (refused if the headset moved)\n"
            "  --seconds S         how long --calibrate-imu measures (default 5)\n"
            "  --set SEC.KEY=VAL   override one configuration key (repeatable), e.g. --set warp.method=raytrace\n"
            "  --duration S        shorthand for --set sim.duration_s=S (0 = run until Ctrl-C)\n"
            "  --scene NAME        shorthand for --set sim.scene=NAME\n"
            "  --trace NAME        shorthand for --set sim.trace=NAME\n"
            "  --method NAME       shorthand for --set warp.method=NAME (none, rotation, raytrace)\n"
            "  --csv FILE          shorthand for --set telemetry.csv=FILE (one row per vsync)\n"
            "  --stats FILE        shorthand for --set telemetry.stats=FILE (summary as key=value lines)\n"
            "  --check-config      load and validate the configuration, print it, and exit (0 = valid)\n"
            "  --list              list simulated scenes and head-motion traces\n"
            "  --help              this text\n"
            "  --help-config       only the configuration keys below (the source of hmdwarp-board.ini(5))\n"
            "  --version           print the version and exit\n"
            "\n"
            "exit status: 0 the run showed host frames; 1 it could not start, or showed none (no vsync, no host\n"
            "frame, or every one rejected: the summary's result line says which; stopped by a signal while waiting\n"
            "for a host that sent nothing: 0); 2 configuration or option error\n"
            "\n"
            "configuration keys (board.ini sections):\n");
    rt_config_print_keys(out);
}

static void list(void)
{
    printf("scenes:\n");
    for (const char *const *n = sim_scene_names(); *n; n++) {
        const sim_scene *s = sim_scene_find(*n);
        char fx[160];
        printf("  %-10s %s [%s]\n", *n, sim_scene_description(s), sim_effects_str(sim_scene_effects(s), fx, sizeof fx));
    }
    printf("head-motion traces:\n");
    for (const char *const *n = sim_trace_names(); *n; n++) printf("  %s\n", *n);
}

/* The options that stand for one --set KEY=VALUE (usage() lists them). */
static const struct {
    const char *opt, *key;
} shorthands[] = {
    {"--calibration", "board.calibration"}, {"--duration", "sim.duration_s"}, {"--scene", "sim.scene"},
    {"--trace", "sim.trace"},               {"--method", "warp.method"},      {"--csv", "telemetry.csv"},
    {"--stats", "telemetry.stats"},
};

/* opt as --set KEY=val when it is a shorthand; false when it is not one. */
static bool shorthand(rt_config *c, const char *opt, const char *val, rt_config_errors *err)
{
    for (size_t i = 0; i < sizeof shorthands / sizeof *shorthands; i++)
        if (strcmp(opt, shorthands[i].opt) == 0) {
            char buf[512];
            snprintf(buf, sizeof buf, "%s=%s", shorthands[i].key, val);
            rt_config_set(c, buf, err);
            return true;
        }
    return false;
}

int main(int argc, char **argv)
{
    rt_config cfg;
    rt_config_defaults(&cfg);
    rt_config_errors err = {0};
    const char *config = NULL;
    bool check = false, calibrate = false;
    double calib_seconds = 5;

    /* Load the config file first so that command-line overrides apply on top of it, whatever their order. */
    for (int i = 1; i < argc; i++)
        if (strcmp(argv[i], "--config") == 0 && i + 1 < argc) config = argv[++i];
    if (!config) {
        FILE *f = fopen("board/sim/board.ini", "r");
        if (f) {
            fclose(f);
            config = "board/sim/board.ini";
        }
    }
    if (config) rt_config_load(&cfg, config, &err);
    /* The calibration file comes after board.ini (it wins) and before the command line's --set (which wins over
     * both), so which file it is must be known before the overrides are applied: the last one named. */
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--calibrate-imu") == 0)
            calibrate = true; /* it creates the file: a named one need not exist yet */
        else if (i + 1 == argc)
            break;
        else if (strcmp(argv[i], "--calibration") == 0)
            snprintf(cfg.calibration, sizeof cfg.calibration, "%s", argv[++i]);
        else if (strcmp(argv[i], "--set") == 0 && strncmp(argv[++i], "board.calibration=", 18) == 0)
            snprintf(cfg.calibration, sizeof cfg.calibration, "%s", argv[i] + 18);
    }
    char calib_what[400] = "";
    if (!err.count) rt_calib_load(&cfg, calibrate, &err, calib_what, sizeof calib_what);

    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            usage(stdout);
            return 0;
        } else if (strcmp(a, "--help-config") == 0) {
            rt_config_print_keys(stdout);
            return 0;
        } else if (strcmp(a, "--version") == 0) {
            printf("hmdwarpd %s\n", plat_version());
            return 0;
        } else if (strcmp(a, "--list") == 0) {
            list();
            return 0;
        } else if (strcmp(a, "--check-config") == 0) {
            check = true;
        } else if (strcmp(a, "--config") == 0 && v) {
            i++;
        } else if (strcmp(a, "--calibrate-imu") == 0) {
            calibrate = true;
        } else if (strcmp(a, "--seconds") == 0 && v) {
            char *end;
            calib_seconds = strtod(v, &end);
            if (end == v || *end || !(calib_seconds >= 0.5 && calib_seconds <= 600)) {
                plat_log(PLAT_LOG_ERR, "--seconds '%s': expected a number of seconds from 0.5 to 600", v);
                return 2;
            }
            i++;
        } else if (strcmp(a, "--set") == 0 && v) {
            rt_config_set(&cfg, v, &err);
            i++;
        } else if (v && shorthand(&cfg, a, v, &err)) {
            i++;
        } else {
            plat_log(PLAT_LOG_ERR, "unknown or incomplete option '%s' (see --help)", a);
            return 2;
        }
    }
    if (!err.count) rt_config_validate(&cfg, &err);
    if (err.count) {
        for (int i = 0; i < err.count && i < 16; i++) plat_log(PLAT_LOG_ERR, "config error: %s", err.msg[i]);
        if (err.count > 16) plat_log(PLAT_LOG_ERR, "... and %d more", err.count - 16);
        return 2;
    }
    rt_config_errors warn = {0};
    rt_config_warnings(&cfg, &warn);
    for (int i = 0; i < warn.count && i < 16; i++) plat_log(PLAT_LOG_WARNING, "warning: %s", warn.msg[i]);
    if (calibrate) return rt_calib_imu_run(&cfg, calib_seconds, stdout);
    if (check) {
        printf("; %s: valid\n", config ? config : "built-in defaults");
        printf("; calibration: %s\n", calib_what);
        printf("; allocates about %.0f MiB at start ([render] max_memory_mb = %g)\n",
               (double)rt_config_memory_bytes(&cfg) / (1024.0 * 1024.0), cfg.max_memory_mb);
        char link[600];
        bool fits = rt_link_budget_line(&cfg, link, sizeof link);
        if (link[0]) printf("; %s%s\n", fits ? "" : "warning: ", link);
        char fov[400];
        rt_config_fov_line(&cfg, fov, sizeof fov);
        printf("; %s\n", fov);
        rt_config_print(&cfg, stdout);
        return 0;
    }

    char msg[512];
    if (!rt_app_init(&app, &cfg, msg, sizeof msg)) {
        plat_log(PLAT_LOG_ERR, "%s", msg);
        rt_app_free(&app);
        return 1;
    }
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    sa.sa_handler = on_abort;
    sa.sa_flags = SA_RESETHAND;
    sigaction(SIGABRT, &sa, NULL);
    printf("hmdwarpd: board '%s', scene '%s', trace '%s', method %s, %s\n", cfg.board_name, cfg.scene, cfg.trace,
           rt_method_name(cfg.method),
           cfg.duration_s > 0 ? "running" : "running until Ctrl-C");
    char fov[400];
    rt_config_fov_line(&cfg, fov, sizeof fov);
    printf("hmdwarpd: %s\n", fov);
    printf("hmdwarpd: calibration %s\n", calib_what);
    if (strcmp(cfg.calibration, RT_CONFIG_CALIBRATION_DEFAULT) == 0) {
        /* a board's first start: leave a file to find where calibration goes (nothing in it changes a key) */
        char cerr[300];
        int made = rt_calib_create_empty(cfg.calibration, cerr, sizeof cerr);
        if (made > 0) printf("hmdwarpd: created %s for this unit's calibration (empty)\n", cfg.calibration);
        if (made < 0) plat_log(PLAT_LOG_WARNING, "%s", cerr);
    }
    char link[600]; /* after the devices opened: a USB gadget's UDC is known */
    if (!rt_link_budget_line(&cfg, link, sizeof link)) plat_log(PLAT_LOG_WARNING, "%s", link);
    else if (link[0]) printf("hmdwarpd: %s\n", link);
    fflush(stdout);
    /* Devices are open and everything is allocated (for the USB gadget: the descriptors are written, so the UDC
     * can be bound now). No-op outside systemd. */
    sd_notify(0, "READY=1");
    rt_app_run(&app);
    sd_notify(0, "STOPPING=1");
    signal(SIGABRT, SIG_DFL); /* the stats buffers go with rt_app_free */
    rt_app_summary(&app, stdout);
    int rc = 0;
    char why[256];
    if (!rt_app_showed_frames(&app, why, sizeof why)) {
        /* A board that showed nothing has failed: systemd and scripts must see it. Except a board stopped (systemctl
         * stop, Ctrl-C) while it waited for a host that never sent anything: nothing was wrong with it, and a unit
         * marked failed for that would send the user looking for a fault. */
        bool waiting = stopped_by_signal && rt_telemetry_waiting_for_host(app.tel);
        printf("result                       %s, nothing shown: %s\n", waiting ? "stopped" : "FAILED", why);
        fflush(stdout);
        plat_log(waiting ? PLAT_LOG_NOTICE : PLAT_LOG_ERR, "nothing shown: %s%s", why,
                 waiting ? " (stopped while waiting for a host)" : "");
        rc = waiting ? 0 : 1;
    }
    if (cfg.stats[0]) {
        FILE *f = fopen(cfg.stats, "w");
        if (f) {
            rt_app_stats_kv(&app, f);
            fclose(f);
        } else {
            plat_log(PLAT_LOG_ERR, "[telemetry] stats = %s: cannot write", cfg.stats);
            rc = 1;
        }
    }
    rt_app_free(&app);
    return rc;
}

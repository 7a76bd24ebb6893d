/* SPDX-License-Identifier: MIT */
/* rt_calib: the calibration file beside board.ini (it overrides board.ini, --set overrides it, bad lines name it),
 * the IMU mounting's three forms, a mounting that turns the fused orientation on the mock IMU, hmdwarpd
 * --calibrate-imu on the simulated board, and the atomic update of the file. */
#include <dirent.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include <cmocka.h>

#include "platform/plat_clock.h"
#include "runtime/rt_calib.h"
#include "runtime/rt_devices.h"
#include "runtime/rt_fusion.h"
#include "sim/sim_trace.h"
#include "tests/support/test_util.h"

static char build[256], tmp[300];

/* --calibrate-imu's stated tolerance for the simulated gyro bias: noise 0.005 rad/s rms over 1000 samples (1 s)
 * leaves the mean 0.00016 rad/s rms off, a sixth of it; what remains the tracker's stillness learning takes out. */
#define BIAS_TOLERANCE 0.001

static void write_file(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

static int hmdwarpd(const char *args, char *out, size_t cap)
{
    char cmd[2048];
    int st = -1;
    snprintf(cmd, sizeof cmd, "timeout 120 %s%s/hmdwarpd %s 2>&1", test_runner(), build, args);
    assert_true(test_capture(cmd, out, cap, &st));
    return st;
}

static void expect(const char *args, int rc_want, const char *needle)
{
    static char out[65536];
    int rc = hmdwarpd(args, out, sizeof out);
    if (rc != rc_want || !strstr(out, needle))
        fail_msg("hmdwarpd %s: exit %d (want %d), output lacks '%s':\n%s", args, rc, rc_want, needle, out);
}

static void mat_equal(double a[3][3], double b[3][3], const char *what)
{
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            if (!(a[i][j] > b[i][j] - 1e-6 && a[i][j] < b[i][j] + 1e-6))
                fail_msg("%s: element %d %d is %g, want %g", what, i, j, a[i][j], b[i][j]);
}

/* Equivalent mountings in the three forms give one rotation; bad ones say what was wrong. */
static void test_mount_forms_agree(void **state)
{
    (void)state;
    const char *same[][3] = {
        /* turned 90 deg about the view axis: head x = IMU -y */
        {"-y +x +z", "quat 0.70710678 0 0 0.70710678", "rpy 90 0 0"},
        /* turned 90 deg about up: head x = IMU z, head z = IMU -x */
        {"+z +y -x", "quat 0.70710678, 0, 0.70710678, 0", "rpy 0 0 90"},
        /* upside down about the view axis */
        {"-x -y +z", "quat 0 0 0 1", "rpy 180 0 0"},
    };
    char err[200];
    for (size_t i = 0; i < sizeof same / sizeof same[0]; i++) {
        double m[3][3][3];
        for (int f = 0; f < 3; f++)
            if (!rt_calib_parse_mount(same[i][f], m[f], err, sizeof err)) fail_msg("'%s': %s", same[i][f], err);
        mat_equal(m[1], m[0], same[i][1]);
        mat_equal(m[2], m[0], same[i][2]);
    }
    /* the documented order: yaw, then pitch about the turned x, then roll about the turned z */
    double m[3][3], want[3][3] = {{1, 0, 0}, {0, 0, -1}, {0, 1, 0}}; /* = Rx(90): yaw and roll cancel */
    assert_true(rt_calib_parse_mount("rpy 90 90 90", m, err, sizeof err));
    mat_equal(m, want, "rpy 90 90 90");
    assert_false(rt_calib_parse_mount("quat 1 1 0 0", m, err, sizeof err));
    assert_non_null(strstr(err, "not a unit quaternion"));
    assert_false(rt_calib_parse_mount("rpy 1 2", m, err, sizeof err));
    assert_non_null(strstr(err, "ROLL PITCH YAW"));
    assert_false(rt_calib_parse_mount("quat 1 0 0 0 0", m, err, sizeof err));
    assert_false(rt_calib_parse_mount("-y +y +z", m, err, sizeof err));
    assert_non_null(strstr(err, "signed axes"));
    /* and validation names the key */
    rt_config c;
    rt_config_defaults(&c);
    rt_config_errors e = {0};
    assert_true(rt_config_set(&c, "imu.mount=rpy 1 2", &e));
    assert_false(rt_config_validate(&c, &e));
    assert_non_null(strstr(e.msg[0], "[imu] mount (command line, override 1) = 'rpy 1 2'"));
}

/* Biases off, gravity scaled, then turned: in that order, on every sample. */
static void test_apply_order(void **state)
{
    (void)state;
    rt_config c;
    rt_config_defaults(&c);
    rt_config_errors e = {0};
    assert_true(rt_config_set(&c, "imu.mount=-y +x +z", &e));
    assert_true(rt_config_set(&c, "imu.gyro_bias=0.1 0.2 0.3", &e));
    assert_true(rt_config_set(&c, "imu.accel_bias=0 0.5 0", &e));
    assert_true(rt_config_set(&c, "imu.gravity=9.5", &e));
    rt_calib_imu k;
    char err[200];
    assert_true(rt_calib_imu_from_config(&c, true, &k, err, sizeof err));
    assert_false(k.identity);
    drv_imu_sample s = {0, {1.1, 0.2, 0.3}, {9.5, 0.5, 0}};
    rt_calib_imu_apply(&k, &s);
    /* IMU x reads +1 rad/s and gravity: head y = IMU x */
    assert_true(fabs(s.gyro[0]) < 1e-12 && fabs(s.gyro[1] - 1) < 1e-12 && fabs(s.gyro[2]) < 1e-12);
    assert_true(fabs(s.accel[0]) < 1e-12 && fabs(s.accel[1] - RT_CALIB_G) < 1e-12 && fabs(s.accel[2]) < 1e-12);
    /* the simulated IMU's samples are the head's: biases apply, the mounting does not */
    assert_true(rt_calib_imu_from_config(&c, false, &k, err, sizeof err));
    assert_true(k.m[0][0] == 1 && k.m[0][1] == 0 && k.m[1][1] == 1);
    rt_config_defaults(&c);
    assert_true(rt_calib_imu_from_config(&c, true, &k, err, sizeof err));
    assert_true(k.identity);
}

static double quat_angle_deg(warp_quat q, double *axis_x)
{
    double s = sqrt(q.x * q.x + q.y * q.y + q.z * q.z);
    *axis_x = s > 0 ? fabs(q.x) / s : 0;
    return 2 * atan2(s, fabs(q.w)) * 180 / WARP_PI;
}

/* On the mock HID IMU with the still trace: an IMU pitched 30 deg on the visor, given as [imu] mount = rpy 0 30 0,
 * fuses to the upright head; the same samples taken as head-frame ones (the mounting applied to an IMU that sits
 * straight) fuse to a head pitched by 30 deg. The path is the daemon's: rt_devices_mount, rt_devices_remap. */
static void test_rpy_mount_turns_fusion_on_mock_imu(void **state)
{
    (void)state;
    rt_config c;
    rt_config_defaults(&c);
    rt_config_errors e = {0};
    const char *set[] = {"imu.backend=hid", "imu.device=mock", "sim.trace=still", "sim.imu_rest_s=0",
                         "imu.mount=rpy 0 30 0"};
    for (size_t i = 0; i < sizeof set / sizeof *set; i++) assert_true(rt_config_set(&c, set[i], &e));
    assert_true(rt_config_validate(&c, &e));
    sim_trace tr;
    assert_true(sim_trace_init(&tr, "still", 1));
    rt_devices d;
    memset(&d, 0, sizeof d);
    char err[300];
    if (!rt_devices_open_imu(&d, &c, &tr, plat_now_ns(), err, sizeof err)) fail_msg("%s", err);
    assert_true(rt_devices_mount(&d, &c, err, sizeof err));
    assert_true(d.imu_remap);

    static rt_fusion mounted, straight;
    rt_fusion_params fp = rt_fusion_default_params();
    rt_fusion_init(&mounted, &fp);
    rt_fusion_init(&straight, &fp);
    drv_imu_sample buf[64];
    int got = 0;
    for (int tries = 0; got < 300 && tries < 400; tries++) {
        int n = drv_imu_read(d.imu, buf, 64, 50);
        for (int i = 0; i < n; i++) {
            /* what an IMU pitched by the mounting reads: the head's vector in its turned axes (m^T) */
            drv_imu_sample raw = buf[i], as_head = buf[i];
            for (int r = 0; r < 3; r++) {
                raw.gyro[r] = raw.accel[r] = 0;
                for (int j = 0; j < 3; j++) {
                    raw.gyro[r] += d.imu_cal.m[j][r] * buf[i].gyro[j];
                    raw.accel[r] += d.imu_cal.m[j][r] * buf[i].accel[j];
                }
            }
            rt_devices_remap(&d, &raw);
            rt_devices_remap(&d, &as_head);
            rt_fusion_update(&mounted, &raw);
            rt_fusion_update(&straight, &as_head);
        }
        if (n > 0) got += n;
    }
    rt_devices_close(&d);
    assert_true(got >= 300);
    rt_fusion_state a, b;
    assert_true(rt_fusion_latest(&mounted, &a));
    assert_true(rt_fusion_latest(&straight, &b));
    double ax, bx;
    double ta = quat_angle_deg(a.q, &ax), tb = quat_angle_deg(b.q, &bx);
    if (ta > 0.5) fail_msg("the mounted IMU fused to a head tilted %.2f deg (want upright)", ta);
    if (fabs(tb - 30) > 0.5 || bx < 0.99)
        fail_msg("the straight IMU with mount = rpy 0 30 0 fused to %.2f deg about an axis %.3f along x (want 30, x)",
                 tb, bx);
}

/* The calibration file: overrides board.ini, --set overrides it, bad lines and keys that are not calibration name
 * the file and line; a named file that is missing is an error, the default one that is missing is not. */
static void test_file_overrides_and_errors(void **state)
{
    (void)state;
    char ini[400], cal[400], bad[400], args[2000];
    snprintf(ini, sizeof ini, "%s/board.ini", tmp);
    snprintf(cal, sizeof cal, "%s/calibration.ini", tmp);
    snprintf(bad, sizeof bad, "%s/bad-calibration.ini", tmp);
    write_file(ini, "[board]\nname = calibtest\n[lens]\nscale = 700\n[imu]\naxes = +x +y +z\ngyro_bias = 0 0 0\n");
    write_file(cal, "; this unit\n[lens]\nscale = 731.25 ; measured\n[imu]\nmount = rpy 0 10 0\n"
                    "gyro_bias = 0.01 0 0\n");
    snprintf(args, sizeof args, "--check-config --config %s --set board.calibration=", ini);
    expect(args, 0, "scale = 700\n");
    expect(args, 0, "; calibration: none ([board] calibration is empty)");
    snprintf(args, sizeof args, "--check-config --config %s --calibration %s", ini, cal);
    expect(args, 0, "scale = 731.25\n");
    expect(args, 0, "mount = rpy 0 10 0\n");
    expect(args, 0, "gyro_bias = 0.01 0 0\n");
    char want[500];
    snprintf(want, sizeof want, "; calibration: %s\n", cal);
    expect(args, 0, want);
    snprintf(args, sizeof args, "--check-config --config %s --set lens.scale=740 --calibration %s", ini, cal);
    expect(args, 0, "scale = 740\n");
    /* the same through [board] calibration given in board.ini */
    char ini2[400];
    snprintf(ini2, sizeof ini2, "%s/board2.ini", tmp);
    char text[1000];
    snprintf(text, sizeof text, "[board]\ncalibration = %s\n[lens]\nscale = 700\n", cal);
    write_file(ini2, text);
    snprintf(args, sizeof args, "--check-config --config %s", ini2);
    expect(args, 0, "scale = 731.25\n");

    write_file(bad, "[imu]\nmount = +x +y +z\n[frames]\nbackend = usb\n[lens]\nscale = many\n");
    snprintf(args, sizeof args, "--check-config --config %s --calibration %s", ini, bad);
    snprintf(want, sizeof want, "%s:4: [frames] backend: not a calibration key", bad);
    expect(args, 2, want);
    snprintf(want, sizeof want, "%s:6: [lens] scale = 'many'", bad);
    expect(args, 2, want);
    write_file(bad, "[imu]\ngyro_bias = 0.01 0\n");
    snprintf(want, sizeof want, "%s:2: [imu] gyro_bias = '0.01 0': expected 3 numbers", bad);
    expect(args, 2, want);
    /* a cross-key error names the calibration file's line */
    write_file(bad, "[imu]\n\nmount = rpy 0 0\n");
    snprintf(want, sizeof want, "[imu] mount (%s:3) = 'rpy 0 0'", bad);
    expect(args, 2, want);
    snprintf(args, sizeof args, "--check-config --config %s --calibration %s/missing.ini", ini, tmp);
    expect(args, 2, "missing.ini: cannot open config file: No such file or directory");

    /* the default path, absent: board.ini stands, said once */
    struct stat st;
    if (stat(RT_CONFIG_CALIBRATION_DEFAULT, &st) == 0) return; /* a board: its own calibration is there */
    rt_config c;
    rt_config_defaults(&c);
    rt_config_errors e = {0};
    char what[400];
    assert_true(rt_calib_load(&c, false, &e, what, sizeof what));
    assert_int_equal(e.count, 0);
    assert_non_null(strstr(what, "does not exist"));
}

/* Updating keeps every other line and comment; keys replaced in place, missing ones added to their section. */
static void test_update_text(void **state)
{
    (void)state;
    const char *keys[] = {"gyro_bias", "gravity"}, *vals[] = {"0.1 0.2 0.3", "9.8"};
    char *t = rt_calib_update_text("; top\n[lens]\nscale = 731 ; measured\n\n[imu]\n; bias from last week\n"
                                   "gyro_bias = 0 0 0\nmount = rpy 0 10 0\n\n[other]\nx = 1\n",
                                   "imu", keys, vals, 2);
    assert_string_equal(t, "; top\n[lens]\nscale = 731 ; measured\n\n[imu]\n; bias from last week\n"
                           "gyro_bias = 0.1 0.2 0.3\nmount = rpy 0 10 0\ngravity = 9.8\n\n[other]\nx = 1\n");
    free(t);
    t = rt_calib_update_text("[lens]\nscale = 731", "imu", keys, vals, 2);
    assert_string_equal(t, "[lens]\nscale = 731\n\n[imu]\ngyro_bias = 0.1 0.2 0.3\ngravity = 9.8\n");
    free(t);
    t = rt_calib_update_text("[imu]\ngravity=1\n", "imu", keys, vals, 2);
    assert_string_equal(t, "[imu]\ngravity = 9.8\ngyro_bias = 0.1 0.2 0.3\n");
    free(t);
    t = rt_calib_update_text(NULL, "imu", keys, vals, 2);
    assert_non_null(strstr(t, "; hmdwarp calibration"));
    assert_non_null(strstr(t, "\n[imu]\ngyro_bias = 0.1 0.2 0.3\ngravity = 9.8\n"));
    /* what it writes loads as a calibration file */
    char path[400];
    snprintf(path, sizeof path, "%s/new.ini", tmp);
    write_file(path, t);
    free(t);
    rt_config c;
    rt_config_defaults(&c);
    rt_config_errors e = {0};
    assert_true(rt_config_load_calibration(&c, path, &e));
    assert_true(c.imu_gyro_bias[2] == 0.3 && c.imu_gravity == 9.8);
}

/* Temp files beside PATH named as rt_calib_write_prepare names them (PATH's name + ".tmp." + 6 characters). */
static int count_temps(const char *dir, const char *name)
{
    DIR *d = opendir(dir);
    assert_non_null(d);
    int n = 0;
    char pre[300];
    snprintf(pre, sizeof pre, "%s.tmp.", name);
    for (struct dirent *de; (de = readdir(d));)
        if (strncmp(de->d_name, pre, strlen(pre)) == 0 && strlen(de->d_name) == strlen(pre) + 6) n++;
    closedir(d);
    return n;
}

/* A writer that dies between writing the temp file and the rename leaves the calibration as it was (the temp file
 * is what it leaves); one that finishes replaces it whole and leaves no temp file. */
static void test_write_is_atomic(void **state)
{
    (void)state;
    char dir[400], path[500];
    snprintf(dir, sizeof dir, "%s/atomic", tmp);
    char cmd[1000];
    snprintf(cmd, sizeof cmd, "rm -rf '%s' && mkdir -p '%s'", dir, dir);
    assert_int_equal(system(cmd), 0);
    snprintf(path, sizeof path, "%s/calibration.ini", dir);
    const char *before = "; kept\n[lens]\nscale = 731\n[imu]\ngyro_bias = 0 0 0\n";
    write_file(path, before);
    chmod(path, 0640);
    const char *keys[] = {"gyro_bias"}, *vals[] = {"0.5 0.5 0.5"};
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        char t[600], err[300];
        bool ok = rt_calib_write_prepare(path, "imu", keys, vals, 1, t, sizeof t, err, sizeof err);
        _exit(ok ? 0 : 1); /* dies before the rename */
    }
    int st;
    assert_int_equal(waitpid(pid, &st, 0), pid);
    assert_true(WIFEXITED(st) && WEXITSTATUS(st) == 0);
    char now[4096];
    test_slurp(path, now, sizeof now);
    assert_string_equal(now, before);
    assert_int_equal(count_temps(dir, "calibration.ini"), 1);

    snprintf(cmd, sizeof cmd, "rm -f '%s'/calibration.ini.tmp.*", dir);
    assert_int_equal(system(cmd), 0);
    char t[600], err[300];
    assert_true(rt_calib_write_prepare(path, "imu", keys, vals, 1, t, sizeof t, err, sizeof err));
    assert_true(rt_calib_write_commit(t, path, err, sizeof err));
    test_slurp(path, now, sizeof now);
    assert_string_equal(now, "; kept\n[lens]\nscale = 731\n[imu]\ngyro_bias = 0.5 0.5 0.5\n");
    assert_int_equal(count_temps(dir, "calibration.ini"), 0);
    struct stat sb;
    assert_int_equal(stat(path, &sb), 0);
    assert_int_equal(sb.st_mode & 0777, 0640); /* the file keeps its mode */
    /* a board's first start leaves a file saying what it is for, that changes no key; once */
    snprintf(path, sizeof path, "%s/first.ini", dir);
    assert_int_equal(rt_calib_create_empty(path, err, sizeof err), 1);
    assert_int_equal(rt_calib_create_empty(path, err, sizeof err), 0);
    test_slurp(path, now, sizeof now);
    assert_non_null(strstr(now, "; hmdwarp calibration"));
    rt_config c0, c1;
    rt_config_defaults(&c0);
    rt_config_defaults(&c1);
    rt_config_errors e = {0};
    assert_true(rt_config_load_calibration(&c1, path, &e));
    memset(c1.calib_file, 0, sizeof c1.calib_file);
    assert_memory_equal(&c0, &c1, sizeof c0);
    snprintf(path, sizeof path, "%s/no-such-dir/first.ini", dir);
    assert_int_equal(rt_calib_create_empty(path, err, sizeof err), 0);
    /* a directory that is not there: said, nothing written */
    snprintf(path, sizeof path, "%s/no-such-dir/calibration.ini", dir);
    assert_false(rt_calib_write_prepare(path, "imu", keys, vals, 1, t, sizeof t, err, sizeof err));
    assert_non_null(strstr(err, "does not exist"));
}

/* hmdwarpd --calibrate-imu on the simulated board: recovers [sim] gyro_bias within BIAS_TOLERANCE, keeps the
 * file's other sections and comments, and refuses (writing nothing) while the head moves. */
static void test_calibrate_imu_on_sim(void **state)
{
    (void)state;
    char cal[400], args[1500], out[16384];
    snprintf(cal, sizeof cal, "%s/measured.ini", tmp);
    remove(cal);
    const char *first = "; this unit's lens, by hand\n[lens]\nscale = 731.25\n\n[imu]\nmount = rpy 0 0 0\n";
    write_file(cal, first);
    snprintf(args, sizeof args,
             "--config board/sim/board.ini --calibrate-imu --seconds 1 --calibration %s --trace still "
             "--set sim.gyro_bias=0.02,-0.013,0.006", cal);
    int rc = hmdwarpd(args, out, sizeof out);
    if (rc != 0) fail_msg("hmdwarpd %s: exit %d\n%s", args, rc, out);
    assert_non_null(strstr(out, "tilt"));
    rt_config c;
    rt_config_defaults(&c);
    rt_config_errors e = {0};
    if (!rt_config_load_calibration(&c, cal, &e)) fail_msg("%s", e.msg[0]);
    const double want[3] = {0.02, -0.013, 0.006};
    for (int i = 0; i < 3; i++)
        if (fabs(c.imu_gyro_bias[i] - want[i]) > BIAS_TOLERANCE)
            fail_msg("gyro_bias[%d] = %.5f, simulated %.5f (tolerance %g)\n%s", i, c.imu_gyro_bias[i], want[i],
                     BIAS_TOLERANCE, out);
    assert_true(fabs(c.imu_gravity - RT_CALIB_G) < 0.02);
    assert_true(c.lens_scale == 731.25 && strcmp(c.imu_mount, "rpy 0 0 0") == 0);
    char text[4096];
    test_slurp(cal, text, sizeof text);
    assert_non_null(strstr(text, "; this unit's lens, by hand\n[lens]\nscale = 731.25\n"));

    /* the head turning: refused, said why, the file as it was */
    char before[4096];
    test_slurp(cal, before, sizeof before);
    snprintf(args, sizeof args,
             "--config board/sim/board.ini --calibrate-imu --seconds 1 --calibration %s --trace fast "
             "--set sim.imu_rest_s=0", cal);
    rc = hmdwarpd(args, out, sizeof out);
    if (rc != 1 || !strstr(out, "not at rest") || !strstr(out, "nothing written"))
        fail_msg("hmdwarpd %s: exit %d (want 1, 'not at rest', 'nothing written')\n%s", args, rc, out);
    test_slurp(cal, text, sizeof text);
    assert_string_equal(text, before);
    /* nowhere to write: said */
    expect("--config board/sim/board.ini --calibrate-imu --seconds 1", 1, "[board] calibration is empty");
    expect("--calibrate-imu --seconds 0", 2, "--seconds '0'");
}

int main(int argc, char **argv)
{
    test_paced_by_sim(TEST_EMULATOR_SLOWDOWN);
    (void)argc;
    if (!test_build_dirs(argv[0], build, sizeof build, tmp, sizeof tmp, "calib")) return 1;
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mount_forms_agree),
        cmocka_unit_test(test_apply_order),
        cmocka_unit_test(test_rpy_mount_turns_fusion_on_mock_imu),
        cmocka_unit_test(test_file_overrides_and_errors),
        cmocka_unit_test(test_update_text),
        cmocka_unit_test(test_write_is_atomic),
        cmocka_unit_test(test_calibrate_imu_on_sim),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

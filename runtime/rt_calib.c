/* SPDX-License-Identifier: MIT */
/* rt_calib: the calibration file apart from board.ini (read after it, written only by --calibrate-imu or by hand,
 * never by packaging), the IMU's mounting as any rotation with its biases, and the at-rest IMU measurement. */
#include "runtime/rt_calib.h"

#include <errno.h>
#include <fcntl.h>
#include <libgen.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "platform/plat_clock.h"
#include "platform/plat_log.h"
#include "runtime/rt_devices.h"
#include "sim/sim_trace.h"
#include "warp/warp_err.h"
#include "warp/warp_math.h"

/* ---- the mounting ---- */

static void mat_mul(const double a[3][3], const double b[3][3], double out[3][3])
{
    double r[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) r[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
    memcpy(out, r, sizeof r);
}

/* "quat 1 0 0 0" / "rpy 0 0 90": n numbers after the word, separated by blanks or commas; false unless exactly n. */
static bool numbers_after(const char *s, double *v, int n)
{
    int got = 0;
    char *end;
    while (*s) {
        while (*s == ' ' || *s == '\t' || *s == ',') s++;
        if (!*s) break;
        if (got == n) return false;
        v[got] = strtod(s, &end);
        if (end == s || !isfinite(v[got])) return false;
        got++;
        s = end;
    }
    return got == n;
}

bool rt_calib_parse_mount(const char *s, double m[3][3], char *err, int errlen)
{
    while (*s == ' ' || *s == '\t') s++;
    memset(m, 0, sizeof(double) * 9);
    if (strncmp(s, "quat", 4) == 0 && (s[4] == ' ' || s[4] == '\t')) {
        double q[4];
        if (!numbers_after(s + 4, q, 4)) return warp_err(err, errlen, "expected 'quat W X Y Z' (four numbers)");
        double norm = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
        /* a typed-in quaternion off by more than rounding is a typo, not a rotation to normalise */
        if (fabs(norm - 1) > 1e-3) return warp_err(err, errlen, "not a unit quaternion (norm %.6g)", norm);
        const double w = q[0] / norm, x = q[1] / norm, y = q[2] / norm, z = q[3] / norm;
        const double r[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
                                {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
                                {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}};
        memcpy(m, r, sizeof r);
        return true;
    }
    if (strncmp(s, "rpy", 3) == 0 && (s[3] == ' ' || s[3] == '\t')) {
        double a[3];
        if (!numbers_after(s + 3, a, 3))
            return warp_err(err, errlen, "expected 'rpy ROLL PITCH YAW' (three numbers, degrees)");
        const double r = a[0] * WARP_PI / 180, p = a[1] * WARP_PI / 180, y = a[2] * WARP_PI / 180;
        /* head axes: +x right, +y up, +z back; yaw turns about up, pitch about right, roll about the view axis */
        const double ry[3][3] = {{cos(y), 0, sin(y)}, {0, 1, 0}, {-sin(y), 0, cos(y)}};
        const double rx[3][3] = {{1, 0, 0}, {0, cos(p), -sin(p)}, {0, sin(p), cos(p)}};
        const double rz[3][3] = {{cos(r), -sin(r), 0}, {sin(r), cos(r), 0}, {0, 0, 1}};
        double t[3][3];
        mat_mul(ry, rx, t);
        mat_mul(t, rz, m);
        return true;
    }
    int map[3], sign[3];
    if (!rt_config_parse_axes(s, map, sign))
        return warp_err(err, errlen, "expected signed axes ('-y +x +z'), 'quat W X Y Z' or 'rpy ROLL PITCH YAW'");
    for (int i = 0; i < 3; i++) m[i][map[i]] = sign[i];
    return true;
}

bool rt_calib_imu_from_config(const rt_config *c, bool use_mount, rt_calib_imu *out, char *err, int errlen)
{
    memset(out, 0, sizeof *out);
    const char *mount = c->imu_mount[0] ? c->imu_mount : c->imu_axes;
    char why[200];
    if (!rt_calib_parse_mount(mount, out->m, why, sizeof why))
        return warp_err(err, errlen, "[imu] %s = '%s': %s", c->imu_mount[0] ? "mount" : "axes", mount, why);
    if (!use_mount) {
        memset(out->m, 0, sizeof out->m);
        for (int i = 0; i < 3; i++) out->m[i][i] = 1;
    }
    memcpy(out->gyro_bias, c->imu_gyro_bias, sizeof out->gyro_bias);
    memcpy(out->accel_bias, c->imu_accel_bias, sizeof out->accel_bias);
    out->accel_scale = c->imu_gravity > 0 ? RT_CALIB_G / c->imu_gravity : 1;
    out->identity = out->accel_scale == 1;
    for (int i = 0; i < 3; i++) {
        out->identity = out->identity && out->gyro_bias[i] == 0 && out->accel_bias[i] == 0;
        for (int j = 0; j < 3; j++) out->identity = out->identity && out->m[i][j] == (i == j);
    }
    return true;
}

void rt_calib_imu_apply(const rt_calib_imu *k, drv_imu_sample *s)
{
    double g[3], a[3];
    for (int j = 0; j < 3; j++) {
        g[j] = s->gyro[j] - k->gyro_bias[j];
        a[j] = (s->accel[j] - k->accel_bias[j]) * k->accel_scale;
    }
    for (int i = 0; i < 3; i++) {
        s->gyro[i] = k->m[i][0] * g[0] + k->m[i][1] * g[1] + k->m[i][2] * g[2];
        s->accel[i] = k->m[i][0] * a[0] + k->m[i][1] * a[1] + k->m[i][2] * a[2];
    }
}

/* ---- the file ---- */

bool rt_calib_load(rt_config *c, bool may_be_missing, rt_config_errors *err, char *what, int whatlen)
{
    const char *path = c->calibration;
    if (!path[0]) {
        snprintf(what, (size_t)whatlen, "none ([board] calibration is empty)");
        return true;
    }
    struct stat st;
    const bool is_default = strcmp(path, RT_CONFIG_CALIBRATION_DEFAULT) == 0;
    if (stat(path, &st) != 0 && errno == ENOENT && (may_be_missing || is_default)) {
        /* a board that was never calibrated: board.ini's lens and mounting stand */
        snprintf(what, (size_t)whatlen, "none (%s does not exist: board.ini's [lens] and [imu] stand)", path);
        return true;
    }
    if (!rt_config_load_calibration(c, path, err)) {
        /* the loader's own messages name the file, and the line where there is one */
        snprintf(what, (size_t)whatlen, "%s (with errors)", path);
        return false;
    }
    snprintf(what, (size_t)whatlen, "%s", path);
    return true;
}

/* ---- the measurement ---- */

void rt_calib_measure(const drv_imu_sample *s, int n, const rt_calib_imu *k, rt_calib_rest *out)
{
    memset(out, 0, sizeof *out);
    out->n = n;
    if (n < RT_CALIB_MIN_SAMPLES) {
        snprintf(out->why, sizeof out->why, "%d samples, fewer than %d: measure longer", n, RT_CALIB_MIN_SAMPLES);
        return;
    }
    out->seconds = (double)(s[n - 1].t_ns - s[0].t_ns) * 1e-9;
    /* two passes: the means, then the spread about them (one-pass variance loses digits at 9.81 +- 0.05) */
    for (int i = 0; i < n; i++)
        for (int j = 0; j < 3; j++) {
            out->gyro_mean[j] += s[i].gyro[j] / n;
            out->accel_mean[j] += s[i].accel[j] / n;
        }
    for (int i = 0; i < n; i++)
        for (int j = 0; j < 3; j++) {
            const double dg = s[i].gyro[j] - out->gyro_mean[j], da = s[i].accel[j] - out->accel_mean[j];
            out->gyro_sd[j] += dg * dg / n;
            out->accel_sd[j] += da * da / n;
        }
    double gmax = 0, amax = 0;
    int gax = 0, aax = 0;
    for (int j = 0; j < 3; j++) {
        out->gyro_sd[j] = sqrt(out->gyro_sd[j]);
        out->accel_sd[j] = sqrt(out->accel_sd[j]);
        if (out->gyro_sd[j] > gmax) gmax = out->gyro_sd[j], gax = j;
        if (out->accel_sd[j] > amax) amax = out->accel_sd[j], aax = j;
    }
    double a[3], h[3];
    for (int j = 0; j < 3; j++) a[j] = out->accel_mean[j] - k->accel_bias[j];
    out->gravity = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    for (int i = 0; i < 3; i++) h[i] = k->m[i][0] * a[0] + k->m[i][1] * a[1] + k->m[i][2] * a[2];
    /* at rest the accelerometer reads +g along head +y when upright */
    out->tilt_deg = out->gravity > 0 ? acos(fmax(-1, fmin(1, h[1] / out->gravity))) * 180 / WARP_PI : 0;
    const char axis[] = "xyz";
    if (gmax > RT_CALIB_REST_GYRO_SD)
        snprintf(out->why, sizeof out->why,
                 "not at rest: the gyro's %c spread is %.4f rad/s, over the %.2f rad/s a still headset stays within",
                 axis[gax], gmax, RT_CALIB_REST_GYRO_SD);
    else if (amax > RT_CALIB_REST_ACCEL_SD)
        snprintf(out->why, sizeof out->why,
                 "not at rest: the accelerometer's %c spread is %.3f m/s^2, over the %.1f m/s^2 a still headset stays "
                 "within", axis[aax], amax, RT_CALIB_REST_ACCEL_SD);
    else if (fmax(fabs(out->gyro_mean[0]), fmax(fabs(out->gyro_mean[1]), fabs(out->gyro_mean[2]))) > 0.5)
        snprintf(out->why, sizeof out->why,
                 "the gyro reads %.3f %.3f %.3f rad/s: a bias this large is a steady turn or a broken gyro",
                 out->gyro_mean[0], out->gyro_mean[1], out->gyro_mean[2]);
    else if (out->gravity < 5 || out->gravity > 15)
        snprintf(out->why, sizeof out->why,
                 "the accelerometer reads %.3f m/s^2 at rest, not gravity: check [imu] accel_g and the device",
                 out->gravity);
    else
        out->at_rest = true;
}

/* ---- writing ---- */

typedef struct {
    char *p;
    size_t n, cap;
    bool oom;
} sbuf;

static void put(sbuf *b, const char *s, size_t n)
{
    if (b->oom) return;
    if (b->n + n + 1 > b->cap) {
        size_t cap = (b->n + n + 1) * 2;
        char *p = realloc(b->p, cap);
        if (!p) {
            b->oom = true;
            return;
        }
        b->p = p;
        b->cap = cap;
    }
    memcpy(b->p + b->n, s, n);
    b->n += n;
    b->p[b->n] = 0;
}
static void puts_(sbuf *b, const char *s) { put(b, s, strlen(s)); }

static void put_key(sbuf *b, const char *key, const char *value)
{
    puts_(b, key);
    puts_(b, " = ");
    puts_(b, value);
    puts_(b, "\n");
}

/* The section a "[name]" line opens (inih's reading: blanks trimmed), into name; false for any other line. */
static bool section_of(const char *line, size_t len, char *name, size_t cap)
{
    size_t i = 0;
    while (i < len && (line[i] == ' ' || line[i] == '\t')) i++;
    if (i == len || line[i] != '[') return false;
    const char *close = memchr(line + i, ']', len - i);
    if (!close) return false;
    const char *s = line + i + 1;
    while (s < close && (*s == ' ' || *s == '\t')) s++;
    const char *e = close;
    while (e > s && (e[-1] == ' ' || e[-1] == '\t')) e--;
    snprintf(name, cap, "%.*s", (int)(e - s), s);
    return true;
}

/* Index of the key a "key = value" line sets among keys[0..n), or -1. */
static int key_of(const char *line, size_t len, const char *const *keys, int n)
{
    size_t i = 0;
    while (i < len && (line[i] == ' ' || line[i] == '\t')) i++;
    if (i == len || line[i] == ';' || line[i] == '#') return -1;
    size_t e = i;
    while (e < len && line[e] != '=' && line[e] != ':') e++;
    if (e == len) return -1;
    size_t k = e;
    while (k > i && (line[k - 1] == ' ' || line[k - 1] == '\t')) k--;
    for (int j = 0; j < n; j++)
        if (strlen(keys[j]) == k - i && strncmp(keys[j], line + i, k - i) == 0) return j;
    return -1;
}

char *rt_calib_update_text(const char *old, const char *section, const char *const *keys, const char *const *values,
                           int n)
{
    sbuf b = {0};
    bool done[16] = {false};
    if (n > 16) return NULL;
    if (!old) {
        puts_(&b, "; hmdwarp calibration: this unit's lens and IMU, kept apart from board.ini and read after\n"
                  "; it (its keys win over board.ini's, --set wins over both). hmdwarpd --calibrate-imu updates\n"
                  "; [imu]; upgrades and board/flash.sh never touch this file.\n");
        old = "";
    }
    bool in = false, seen = false;
    size_t pending = 0; /* where the section's content ends (blank lines after it stay after the inserted keys) */
    const char *p = old;
    while (*p) {
        const char *nl = strchr(p, '\n');
        size_t len = nl ? (size_t)(nl - p) : strlen(p);
        char name[64];
        if (section_of(p, len, name, sizeof name)) {
            if (in) { /* leaving the section: the keys it lacked go after its last line, before the blank ones */
                sbuf tail = {0};
                put(&tail, b.p + pending, b.n - pending);
                b.n = pending;
                for (int j = 0; j < n; j++)
                    if (!done[j]) put_key(&b, keys[j], values[j]), done[j] = true;
                if (tail.n) put(&b, tail.p, tail.n);
                free(tail.p);
            }
            in = strcmp(name, section) == 0;
            seen = seen || in;
        }
        int j = in ? key_of(p, len, keys, n) : -1;
        if (j >= 0) {
            put_key(&b, keys[j], values[j]);
            done[j] = true;
        } else {
            put(&b, p, len);
            puts_(&b, "\n");
        }
        size_t k = 0;
        while (k < len && (p[k] == ' ' || p[k] == '\t' || p[k] == '\r')) k++;
        if (k < len) pending = b.n;
        p = nl ? nl + 1 : p + len;
    }
    if (in) {
        b.n = pending;
        if (b.p) b.p[b.n] = 0;
    }
    bool any = false;
    for (int j = 0; j < n; j++) any = any || !done[j];
    if (any && !seen) {
        if (b.n && b.p[b.n - 1] != '\n') puts_(&b, "\n");
        puts_(&b, b.n ? "\n[" : "[");
        puts_(&b, section);
        puts_(&b, "]\n");
    }
    for (int j = 0; j < n; j++)
        if (!done[j]) put_key(&b, keys[j], values[j]);
    if (!b.p) puts_(&b, "");
    if (b.oom) {
        free(b.p);
        return NULL;
    }
    return b.p;
}

static char *read_all(const char *path, bool *missing, char *err, int errlen)
{
    *missing = false;
    FILE *f = fopen(path, "r");
    if (!f) {
        if (errno == ENOENT) {
            *missing = true;
            return NULL;
        }
        warp_err(err, errlen, "%s: cannot read: %s", path, strerror(errno));
        return NULL;
    }
    sbuf b = {0};
    char chunk[4096];
    size_t r;
    while ((r = fread(chunk, 1, sizeof chunk, f)) > 0 && b.n <= (size_t)RT_CONFIG_MAX_FILE_KB * 1024) put(&b, chunk, r);
    bool bad = ferror(f) || b.oom || b.n > (size_t)RT_CONFIG_MAX_FILE_KB * 1024;
    fclose(f);
    if (bad) {
        warp_err(err, errlen, "%s: cannot read (or larger than %d KB)", path, RT_CONFIG_MAX_FILE_KB);
        free(b.p);
        return NULL;
    }
    if (!b.p) puts_(&b, "");
    return b.p;
}

bool rt_calib_write_prepare(const char *path, const char *section, const char *const *keys,
                            const char *const *values, int n, char *tmp, int tmplen, char *err, int errlen)
{
    bool missing;
    char *old = read_all(path, &missing, err, errlen);
    if (!old && !missing) return false;
    struct stat st_old, st_dir;
    bool have_old = !missing && stat(path, &st_old) == 0;
    char dirbuf[512];
    snprintf(dirbuf, sizeof dirbuf, "%s", path);
    const char *dir = dirname(dirbuf);
    if (stat(dir, &st_dir) != 0 || !S_ISDIR(st_dir.st_mode)) {
        free(old);
        return warp_err(err, errlen, "%s: its directory %s does not exist (on a board systemd makes "
                                     "/var/lib/hmdwarp for the service: StateDirectory=hmdwarp)", path, dir);
    }
    char *text = rt_calib_update_text(old, section, keys, values, n);
    free(old);
    if (!text) return warp_err(err, errlen, "%s: out of memory", path);
    if (snprintf(tmp, (size_t)tmplen, "%s.tmp.XXXXXX", path) >= tmplen) {
        free(text);
        return warp_err(err, errlen, "%s: path too long", path);
    }
    int fd = mkstemp(tmp);
    if (fd < 0) {
        free(text);
        return warp_err(err, errlen, "%s: cannot create %s: %s", path, tmp, strerror(errno));
    }
    /* the file keeps its mode and owner; a new one belongs to whoever owns the state directory (the service user,
     * when root ran --calibrate-imu), readable by all: it holds no secret */
    bool ok = fchmod(fd, have_old ? st_old.st_mode & 07777 : 0644) == 0;
    if (ok && geteuid() == 0) {
        uid_t u = have_old ? st_old.st_uid : st_dir.st_uid;
        gid_t g = have_old ? st_old.st_gid : st_dir.st_gid;
        ok = fchown(fd, u, g) == 0;
    }
    size_t len = strlen(text), off = 0;
    while (ok && off < len) {
        ssize_t w = write(fd, text + off, len - off);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) ok = false;
        else off += (size_t)w;
    }
    ok = ok && fsync(fd) == 0;
    int e = errno;
    ok = close(fd) == 0 && ok;
    free(text);
    if (!ok) {
        unlink(tmp);
        return warp_err(err, errlen, "%s: cannot write %s: %s", path, tmp, strerror(e));
    }
    return true;
}

bool rt_calib_write_commit(const char *tmp, const char *path, char *err, int errlen)
{
    if (rename(tmp, path) != 0) {
        int e = errno;
        unlink(tmp);
        return warp_err(err, errlen, "%s: cannot replace it with %s: %s", path, tmp, strerror(e));
    }
    /* the rename itself reaches the disk only with the directory */
    char dirbuf[512];
    snprintf(dirbuf, sizeof dirbuf, "%s", path);
    int dfd = open(dirname(dirbuf), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dfd >= 0) {
        fsync(dfd);
        close(dfd);
    }
    return true;
}

int rt_calib_create_empty(const char *path, char *err, int errlen)
{
    struct stat st;
    char dirbuf[512];
    snprintf(dirbuf, sizeof dirbuf, "%s", path);
    if (lstat(path, &st) == 0 || errno != ENOENT) return 0;
    if (stat(dirname(dirbuf), &st) != 0 || !S_ISDIR(st.st_mode)) return 0;
    char tmp[600];
    if (!rt_calib_write_prepare(path, "imu", NULL, NULL, 0, tmp, sizeof tmp, err, errlen)) return -1;
    return rt_calib_write_commit(tmp, path, err, errlen) ? 1 : -1;
}

/* ---- hmdwarpd --calibrate-imu ---- */

int rt_calib_imu_run(const rt_config *c, double seconds, FILE *out)
{
    if (!c->calibration[0]) {
        plat_log(PLAT_LOG_ERR, "--calibrate-imu: no calibration file to write ([board] calibration is empty): "
                               "give --calibration PATH");
        return 1;
    }
    /* before the measurement: a file that cannot be written would waste the user's stillness */
    char dirbuf[512];
    snprintf(dirbuf, sizeof dirbuf, "%s", c->calibration);
    struct stat st;
    if (stat(dirname(dirbuf), &st) != 0 || !S_ISDIR(st.st_mode)) {
        snprintf(dirbuf, sizeof dirbuf, "%s", c->calibration);
        plat_log(PLAT_LOG_ERR, "--calibrate-imu: %s: its directory %s does not exist (on a board systemd makes "
                               "/var/lib/hmdwarp for the service: StateDirectory=hmdwarp)", c->calibration,
                 dirname(dirbuf));
        return 1;
    }
    const bool sim = strcmp(c->imu_backend, "sim") == 0;
    rt_calib_imu k;
    char e[300];
    if (!rt_calib_imu_from_config(c, !sim, &k, e, sizeof e)) {
        plat_log(PLAT_LOG_ERR, "--calibrate-imu: %s", e);
        return 1;
    }
    sim_trace trace;
    if (!sim_trace_init(&trace, c->trace, c->seed)) sim_trace_init(&trace, "still", c->seed);
    trace.head.ipd = c->ipd;
    rt_devices d;
    memset(&d, 0, sizeof d);
    /* a simulated IMU starts its trace's time at -imu_rest_s, now: the rest before the motion is measured */
    int64_t t0 = plat_now_ns() + (int64_t)(c->imu_rest_s * 1e9);
    if (!rt_devices_open_imu(&d, c, &trace, t0, e, sizeof e)) {
        plat_log(PLAT_LOG_ERR, "--calibrate-imu: %s", e);
        return 1;
    }
    const int cap = (int)(seconds * fmax(c->imu_rate_hz, 100) * 1.5) + 1024;
    drv_imu_sample *s = malloc(sizeof *s * (size_t)cap);
    if (!s) {
        rt_devices_close(&d);
        plat_log(PLAT_LOG_ERR, "--calibrate-imu: out of memory");
        return 1;
    }
    fprintf(out, "hmdwarpd: measuring the IMU (%s) for %.1f s: keep the headset still\n", d.imu->name, seconds);
    fflush(out);
    int n = 0, errors = 0;
    const int64_t end = plat_now_ns() + (int64_t)(seconds * 1e9);
    while (plat_now_ns() < end && n < cap) {
        int r = drv_imu_read(d.imu, s + n, cap - n, 50);
        if (r < 0 && ++errors > 20) break;
        if (r > 0) n += r;
    }
    rt_devices_close(&d);
    rt_calib_rest m;
    rt_calib_measure(s, n, &k, &m);
    free(s);
    fprintf(out, "samples       %d over %.2f s\n", m.n, m.seconds);
    fprintf(out, "gyro mean     %+.5f %+.5f %+.5f rad/s (spread %.4f %.4f %.4f)\n", m.gyro_mean[0], m.gyro_mean[1],
            m.gyro_mean[2], m.gyro_sd[0], m.gyro_sd[1], m.gyro_sd[2]);
    fprintf(out, "accel mean    %+.4f %+.4f %+.4f m/s^2 (spread %.3f %.3f %.3f)\n", m.accel_mean[0], m.accel_mean[1],
            m.accel_mean[2], m.accel_sd[0], m.accel_sd[1], m.accel_sd[2]);
    fprintf(out, "gravity       %.4f m/s^2\n", m.gravity);
    fprintf(out, "tilt          %.2f deg from upright (as mounted)\n", m.tilt_deg);
    if (errors > 20) {
        plat_log(PLAT_LOG_ERR, "--calibrate-imu: the IMU kept failing to read: nothing written");
        return 1;
    }
    if (!m.at_rest) {
        plat_log(PLAT_LOG_ERR, "--calibrate-imu: %s; nothing written (hold the headset still, or lay it down)",
                 m.why);
        return 1;
    }
    char bias[120], grav[40];
    snprintf(bias, sizeof bias, "%.6f %.6f %.6f", m.gyro_mean[0], m.gyro_mean[1], m.gyro_mean[2]);
    snprintf(grav, sizeof grav, "%.4f", m.gravity);
    const char *keys[] = {"gyro_bias", "gravity"}, *values[] = {bias, grav};
    char tmp[600];
    if (!rt_calib_write_prepare(c->calibration, "imu", keys, values, 2, tmp, sizeof tmp, e, sizeof e) ||
        !rt_calib_write_commit(tmp, c->calibration, e, sizeof e)) {
        plat_log(PLAT_LOG_ERR, "--calibrate-imu: %s", e);
        return 1;
    }
    fprintf(out, "hmdwarpd: wrote [imu] gyro_bias = %s, gravity = %s to %s\n", bias, grav, c->calibration);
    return 0;
}

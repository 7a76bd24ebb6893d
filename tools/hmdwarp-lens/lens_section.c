/* SPDX-License-Identifier: MIT */
/* hmdwarp-lens: the [lens] section import and fit write, checked with hmdwarpd's own configuration rules before
 * it is written, so a section that folds over the panel never reaches a board. */
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "runtime/rt_calib.h"
#include "tools/hmdwarp-lens/lens_cli.h"

void lens_section_add(lens_section *s, const char *fmt, ...)
{
    if (s->n >= LENS_SECTION_MAX) return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(s->line[s->n++], sizeof s->line[0], fmt, ap);
    va_end(ap);
}

int lens_load_config(rt_config *c, const char *path)
{
    rt_config_defaults(c);
    const char *p = path ? path : "board/sim/board.ini";
    FILE *probe = fopen(p, "r");
    if (!probe) {
        if (!path) return 0; /* no sim board here: the defaults */
        fprintf(stderr, "hmdwarp-lens: %s: cannot open\n", p);
        return 2;
    }
    fclose(probe);
    rt_config_errors err = {0};
    if (!rt_config_load(c, p, &err)) {
        for (int i = 0; i < err.count && i < 16; i++) fprintf(stderr, "hmdwarp-lens: %s\n", err.msg[i]);
        return 2;
    }
    return 0;
}

/* --out names a calibration file (a board's /var/lib/hmdwarp/calibration.ini, or a new one): its [lens] keys are
 * set in place and everything else it holds (the IMU's mounting and biases, comments) is kept, replaced atomically
 * as hmdwarpd --calibrate-imu does (rt_calib). The section's own comment lines go to stdout instead. */
static int write_calibration(const lens_section *s, const char *path)
{
    static char keys[LENS_SECTION_MAX][64], vals[LENS_SECTION_MAX][300];
    const char *kp[LENS_SECTION_MAX], *vp[LENS_SECTION_MAX];
    int n = 0;
    for (int i = 0; i < s->n; i++) {
        const char *eq = strchr(s->line[i], '=');
        if (s->line[i][0] == ';' || !eq) {
            printf("%s\n", s->line[i]);
            continue;
        }
        int kl = (int)(eq - s->line[i]);
        while (kl > 0 && s->line[i][kl - 1] == ' ') kl--;
        const char *val = eq + 1;
        while (*val == ' ') val++;
        snprintf(keys[n], sizeof keys[n], "%.*s", kl, s->line[i]);
        snprintf(vals[n], sizeof vals[n], "%s", val);
        kp[n] = keys[n];
        vp[n] = vals[n];
        n++;
    }
    char tmp[4200], err[300];
    if (!rt_calib_write_prepare(path, "lens", kp, vp, n, tmp, sizeof tmp, err, sizeof err) ||
        !rt_calib_write_commit(tmp, path, err, sizeof err)) {
        fprintf(stderr, "hmdwarp-lens: %s: %s\n", path, err);
        return 1;
    }
    fflush(stdout);
    fprintf(stderr, "hmdwarp-lens: wrote [lens] (%d keys) into %s, its other sections kept\n", n, path);
    return 0;
}

int lens_section_finish(const lens_section *s, rt_config *c, const char *out_path)
{
    rt_config_errors err = {0};
    for (int i = 0; i < s->n; i++) {
        if (s->line[i][0] == ';') continue;
        char assign[360], key[64];
        const char *eq = strchr(s->line[i], '=');
        if (!eq) continue;
        int kl = (int)(eq - s->line[i]);
        while (kl > 0 && s->line[i][kl - 1] == ' ') kl--;
        snprintf(key, sizeof key, "%.*s", kl, s->line[i]);
        const char *val = eq + 1;
        while (*val == ' ') val++;
        snprintf(assign, sizeof assign, "lens.%s=%s", key, val);
        rt_config_set(c, assign, &err);
    }
    if (!err.count) rt_config_validate(c, &err);
    if (err.count) {
        for (int i = 0; i < err.count && i < 16; i++) fprintf(stderr, "hmdwarp-lens: %s\n", err.msg[i]);
        return 1;
    }
    if (out_path) return write_calibration(s, out_path);
    printf("[lens]\n");
    for (int i = 0; i < s->n; i++) printf("%s\n", s->line[i]);
    fflush(stdout);
    return 0;
}

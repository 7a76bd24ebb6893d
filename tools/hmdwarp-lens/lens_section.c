/* SPDX-License-Identifier: MIT */
/* hmdwarp-lens: the [lens] section import and fit write, checked with hmdwarpd's own configuration rules before
 * it is written, so a section that folds over the panel never reaches a board. */
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

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
    FILE *f = out_path ? fopen(out_path, "w") : stdout;
    if (!f) {
        fprintf(stderr, "hmdwarp-lens: %s: cannot create\n", out_path);
        return 1;
    }
    fprintf(f, "[lens]\n");
    for (int i = 0; i < s->n; i++) fprintf(f, "%s\n", s->line[i]);
    if (out_path && fclose(f) != 0) {
        fprintf(stderr, "hmdwarp-lens: %s: write failed\n", out_path);
        return 1;
    }
    if (!out_path) fflush(stdout);
    return 0;
}

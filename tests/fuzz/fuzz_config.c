/* SPDX-License-Identifier: MIT */
/* Fuzzes board.ini parsing through runtime/rt_config.c's public functions only: byte 0 picks INI text
 * (rt_config_load_string), command-line overrides one per line (rt_config_set, as --set), or a file
 * (rt_config_load); then the cross-key validation, warnings and printing run on whatever was accepted. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "runtime/rt_config.h"
#include "tests/fuzz/fuzz.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static FILE *null;
    if (!null) null = fopen("/dev/null", "w");
    if (size < 1 || size > 65536) return 0;
    int mode = data[0] % 3;
    char *text = malloc(size);
    memcpy(text, data + 1, size - 1);
    text[size - 1] = 0;
    rt_config *c = malloc(sizeof *c);
    rt_config_defaults(c);
    rt_config_errors *err = calloc(1, sizeof *err);
    if (mode == 0) {
        rt_config_load_string(c, text, "fuzz.ini", err);
    } else if (mode == 1) {
        for (char *line = text, *next; line; line = next) {
            next = strchr(line, '\n');
            if (next) *next++ = 0;
            rt_config_set(c, line, err);
        }
    } else {
        rt_config_load(c, fuzz_file(data + 1, size - 1), err);
    }
    if (err->count < 0) abort();
    rt_config_errors *verr = calloc(1, sizeof *verr);
    if (rt_config_validate(c, verr)) {
        rt_config_errors *warn = calloc(1, sizeof *warn);
        rt_config_warnings(c, warn);
        free(warn);
        rt_config_print(c, null);
    }
    free(verr);
    free(err);
    free(c);
    free(text);
    return 0;
}

void fuzz_write_seeds(void)
{
    static const char *boards[] = {"sim", "rpi5", "generic-aarch64"};
    for (int i = 0; i < 3; i++) {
        char path[128], buf[16384];
        snprintf(path, sizeof path, "board/%s/board.ini", boards[i]);
        FILE *f = fopen(path, "r");
        if (!f) continue; /* run from the repository root */
        size_t n = fread(buf, 1, sizeof buf, f);
        fclose(f);
        char name[64];
        snprintf(name, sizeof name, "board-%s", boards[i]);
        fuzz_seed_tagged(name, 0, buf, n);
        snprintf(name, sizeof name, "file-%s", boards[i]);
        fuzz_seed_tagged(name, 2, buf, n);
    }
    static const char sets[] = "sim.scene=cubes\nwarp.method=raytrace\nimu.backend=hid\nimu.device=mock\n"
                               "frames.backend=usb\nframes.device=mock\nvsync.backend=gpio\nsim.duration_s=0.5\n"
                               "display.width=1920\neye.width=960\nlens.k1=0.2\ntelemetry.csv=/tmp/x.csv\n";
    fuzz_seed_tagged("set", 1, sets, sizeof sets - 1);
}

/* SPDX-License-Identifier: MIT */
/* hmdwarp-lens's subcommands beyond the calibration pattern: import (published lens parameters to a [lens] section)
 * and fit (measured correspondences to one), with the section writer they share. */
#ifndef HMDWARP_LENS_CLI_H
#define HMDWARP_LENS_CLI_H

#include <stdio.h>

#include "runtime/rt_config.h"

#define LENS_SECTION_MAX 32

/* A [lens] section being written: "key = value" lines in order, and comment lines. */
typedef struct {
    char line[LENS_SECTION_MAX][320];
    int n;
} lens_section;

void lens_section_add(lens_section *s, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* Applies the section's keys to c (over --config's board.ini) and checks the result as hmdwarpd would; prints
 * each error with the tool's name and returns 1 on any, else writes the section to out_path (or stdout) and
 * returns 0. */
int lens_section_finish(const lens_section *s, rt_config *c, const char *out_path);

/* Loads --config (default board/sim/board.ini when present); 2 with a message when it cannot. */
int lens_load_config(rt_config *c, const char *path);

int lens_import_main(int argc, char **argv);
int lens_fit_main(int argc, char **argv);

#endif

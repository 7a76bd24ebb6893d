/* SPDX-License-Identifier: MIT */
/* The results table of docs/warp-results.md: every warp of the catalogue on every scene's test case, scored
 * against the simulator's ground truth. `make results` regenerates it. */
#ifndef HMDWARP_WARP_TABLE_H
#define HMDWARP_WARP_TABLE_H

#include <stdbool.h>

/* Writes the Markdown table to path ("-" = stdout). quick: small images (smoke runs). False on I/O errors. */
bool warp_table_write(const char *path, bool quick);

#endif

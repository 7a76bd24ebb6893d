/* SPDX-License-Identifier: MIT */
/* bench_link: hmdwarp-bench's link section: every framelink v2 codec and quality step through the real frame
 * encoder and decoder (drv_framelink_enc/dec) on simulator frames: bytes, MB/s, times, PSNR, the raytrace after decode. */
#ifndef BENCH_LINK_H
#define BENCH_LINK_H

#include <stdbool.h>

#include "warp/warp_camera.h"

typedef struct {
    bool quick;              /* fewer scenes and frames (the eye size comes with cam) */
    bool reference;          /* the reference panel (not --quick, no --eye): only such a run may feed the README */
    warp_camera cam[2];      /* the eye cameras frames are rendered with (the bench's panel configuration) */
    int decode_threads;      /* the board's [frames] decode_threads: 2 */
    const char *out;         /* link.csv and link.md go here */
} bench_link_opts;

/* Runs the section and writes OUT/link.csv and OUT/link.md. A codec this build cannot run makes its rows
 * "n/a (reason)", not a failure. False (reason on stderr) only when the section itself cannot run (memory, files). */
bool bench_link_run(const bench_link_opts *o);

#endif

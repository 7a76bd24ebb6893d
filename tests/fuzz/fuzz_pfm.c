/* SPDX-License-Identifier: MIT */
/* Fuzzes hmdwarp-warp's PFM reader (tools/common/warp_files.c): header parsing and the check that the file
 * holds what its header declares before anything is allocated. */
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#include "tests/fuzz/fuzz.h"
#include "tools/common/warp_files.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    int w, h, ch;
    char err[512];
    float *px = warpfile_read_pfm(fuzz_file(data, size), &w, &h, &ch, err, sizeof err);
    if (!px) return 0;
    if (w < 1 || h < 1 || (ch != 1 && ch != 3) || (size_t)w * (size_t)h * (size_t)ch * 4 > size) abort();
    free(px);
    return 0;
}

void fuzz_write_seeds(void)
{
    float px[6 * 4 * 3];
    for (int i = 0; i < 6 * 4 * 3; i++) px[i] = 0.5f * (float)i;
    char path[256];
    for (int ch = 1; ch <= 3; ch += 2) {
        snprintf(path, sizeof path, "%s/seed-%s", fuzz_seed_dir, ch == 1 ? "grey" : "rgb");
        if (!warpfile_write_pfm(path, px, 6, 4, ch)) abort();
    }
    /* big-endian (positive scale) */
    static const char be[] = "Pf\n2 1\n1.0\n\x3f\x80\x00\x00\x40\x00\x00\x00";
    fuzz_seed("big-endian", be, sizeof be - 1);
}

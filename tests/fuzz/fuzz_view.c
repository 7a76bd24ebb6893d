/* SPDX-License-Identifier: MIT */
/* Fuzzes hmdwarp-warp's view file reader (tools/common/warp_files.c): an accepted view has a camera
 * warp_camera_check() takes and finite unit poses. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "tests/fuzz/fuzz.h"
#include "tools/common/warp_files.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    warpfile_view v;
    char err[512];
    if (!warpfile_load_view(fuzz_file(data, size), &v, err, sizeof err)) return 0;
    if (warp_camera_check(&v.cam) || !warp_pose_isfinite(v.src) || !warp_pose_isfinite(v.dst) ||
        fabs(warp_quat_norm(v.src.q) - 1) > 1e-6 || fabs(warp_quat_norm(v.dst.q) - 1) > 1e-6)
        abort();
    return 0;
}

void fuzz_write_seeds(void)
{
    static const char a[] = "# a view\nsize 64 48\ntan 1 1 0.75 0.75\nnear 0.05\nfar inf\n"
                            "source 1 0 0 0  0 1.6 0\ntarget 0.99 0 0.14 0  0.02 1.6 0\n";
    static const char b[] = "size 640 480\nintrinsics 500 500 320 240\nsource 1 0 0 0 0 0 0\n"
                            "target 1 0 0 0 0.1 0 0\nfar 100\n";
    fuzz_seed("tan", a, sizeof a - 1);
    fuzz_seed("intrinsics", b, sizeof b - 1);
}

/* SPDX-License-Identifier: MIT */
/* Fuzzes the sequence manifest reader (tools/common/seq_manifest.c): what it accepts has cameras warp_camera_check()
 * takes, finite unit poses, increasing finite times and a file per view for every plane it declares. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "tests/fuzz/fuzz.h"
#include "tools/common/seq_manifest.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    seq_manifest m;
    char err[512];
    if (!seq_open(fuzz_file(data, size), &m, err, sizeof err)) return 0;
    if (m.n < 1 || warp_camera_check(&m.cam[0]) || warp_camera_check(&m.cam[1]) || !(m.planes & DRV_PLANE_COLOR))
        abort();
    for (int i = 0; i < m.n; i++) {
        const seq_frame *fr = &m.frames[i];
        if (!isfinite(fr->time) || (i > 0 && !(fr->time > fr[-1].time))) abort();
        for (int e = 0; e < 2; e++) {
            if (!warp_pose_isfinite(fr->pose[e]) || fabs(warp_quat_norm(fr->pose[e].q) - 1) > 1e-6) abort();
            for (int k = 0; k < SEQ_KINDS && e < m.eyes; k++) /* one view: its files are eye 0's */
                if (((m.planes >> k) & 1) != (fr->file[e][k] != NULL)) abort();
        }
        if (m.objects != (fr->objects != NULL)) abort();
    }
    seq_close(&m);
    return 0;
}

void fuzz_write_seeds(void)
{
    /* Files by absolute path (/dev/null is readable everywhere): the reader checks they exist, not what they hold. */
    static const char mono[] = "# one view\nhmdwarp-sequence 1\neyes 1\nsize 8 6\nintrinsics 4 4 4 3\nnear 0.05\n"
                               "far inf\ndepth-encoding reversed\nframes\nindex,time,qw,qx,qy,qz,x,y,z,color,depth\n"
                               "0,0,1,0,0,0,0,1.6,0,/dev/null,/dev/null\n"
                               "1,0.011,0.99998,0,0.00611,0,0,1.6,0,/dev/null,/dev/null\n";
    static const char stereo[] =
        "hmdwarp-sequence 1\nsize 8 6\ntan 1.2 1 1 1\ntan-right 1 1.2 1 1\ndepth-kind ray\ndepth-scale 0.001\n"
        "max-layers 4\nframes\nindex,time,left_qw,left_qx,left_qy,left_qz,left_x,left_y,left_z,right_qw,right_qx,"
        "right_qy,right_qz,right_x,right_y,right_z,left_color,right_color,left_ids,right_ids,left_motion,"
        "right_motion,left_layers,right_layers,objects\n"
        "0,5,1,0,0,0,-0.032,1.6,0,1,0,0,0,0.032,1.6,0,/dev/null,/dev/null,/dev/null,/dev/null,/dev/null,/dev/null,"
        "/dev/null,/dev/null,/dev/null\n";
    fuzz_seed("mono", mono, sizeof mono - 1);
    fuzz_seed("stereo", stereo, sizeof stereo - 1);
}

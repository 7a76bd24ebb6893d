/* SPDX-License-Identifier: MIT */
/* Fuzzes the framelink pose message decoder (board -> host; hmdwarp-feed decodes it): as received, then with its
 * CRC repaired; an accepted message re-encodes and decodes to the same values. */
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "drivers/drv_framelink.h"
#include "tests/fuzz/fuzz.h"

static void run(const uint8_t *data, size_t size)
{
    drv_framelink_pose p, q;
    if (drv_framelink_pose_decode(data, size, &p) != DRV_FRAME_OK) return;
    if (p.board_t_ns < 0 || p.target_t_ns < 0) abort();
    uint8_t buf[DRV_FRAMELINK_POSE_BYTES];
    if (drv_framelink_pose_encode(&p, buf, sizeof buf) != sizeof buf) abort();
    if (drv_framelink_pose_decode(buf, sizeof buf, &q) != DRV_FRAME_OK || memcmp(&p.head, &q.head, sizeof p.head) ||
        p.seq != q.seq || p.board_t_ns != q.board_t_ns || p.target_t_ns != q.target_t_ns)
        abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    run(data, size);
    if (size >= DRV_FRAMELINK_POSE_BYTES) {
        uint8_t copy[DRV_FRAMELINK_POSE_BYTES];
        memcpy(copy, data, sizeof copy);
        uint32_t c = (uint32_t)crc32_z(0, copy, 200);
        for (int i = 0; i < 4; i++) copy[200 + i] = (uint8_t)(c >> (8 * i));
        run(copy, sizeof copy);
    }
    return 0;
}

void fuzz_write_seeds(void)
{
    drv_framelink_pose p = {7, 5000000000LL, 5020000000LL, {{1, 0, 0, 0}, {0, 1.6, 0}},
                            {{{1, 0, 0, 0}, {-0.032, 1.6, 0}}, {{1, 0, 0, 0}, {0.032, 1.6, 0}}}};
    uint8_t buf[DRV_FRAMELINK_POSE_BYTES];
    drv_framelink_pose_encode(&p, buf, sizeof buf);
    fuzz_seed("pose", buf, sizeof buf);
    p.head.q = (warp_quat){0.5, 0.5, 0.5, 0.5};
    drv_framelink_pose_encode(&p, buf, sizeof buf);
    fuzz_seed("pose-turned", buf, sizeof buf);
}

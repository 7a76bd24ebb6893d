/* SPDX-License-Identifier: MIT */
/* hmdwarp-feed, the host program, end to end in its file mode: the stream it writes decodes with the board's
 * codec into valid frames of the scene, with the planes the scene needs and the poses it was driven with. */
#include <libgen.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "tests/support/test_host_link.h"
#include "tests/support/test_util.h"

#include "drivers/drv_framelink.h"

static char feed_path[512];

static uint8_t *run_feed(const char *args, size_t *len)
{
    char cmd[1024];
    snprintf(cmd, sizeof cmd, "%s%s --stdout --synth-poses %s 2>/dev/null", test_runner(), feed_path, args);
    FILE *p = popen(cmd, "r");
    assert_non_null(p);
    size_t cap = 1 << 20, n = 0;
    uint8_t *buf = malloc(cap);
    for (size_t r; (r = fread(buf + n, 1, cap - n, p)) > 0;) {
        n += r;
        if (n == cap) buf = realloc(buf, cap *= 2);
    }
    assert_int_equal(pclose(p), 0);
    *len = n;
    return buf;
}

static void test_feed_stream_decodes(void **state)
{
    (void)state;
    size_t len;
    uint8_t *buf = run_feed("--scene near --eye 96x64 --frames 3 --rate 200", &len);
    drv_frame f;
    assert_true(drv_frame_alloc(&f, 96, 64, DRV_PLANE_COLOR | DRV_PLANE_DEPTH, 1));
    size_t at = 0;
    int frames = 0;
    int64_t last_pose_t = 0;
    while (at < len) {
        test_stream_next(buf, len, &at, 64u << 20, &f);
        /* the translation scene needs depth, and depth is what arrives */
        assert_true(f.planes & DRV_PLANE_DEPTH);
        assert_true(f.pose_t_ns > last_pose_t);
        last_pose_t = f.pose_t_ns;
        assert_int_equal(f.seq, (uint64_t)frames + 1);
        frames++;
    }
    assert_int_equal(frames, 3);
    drv_frame_free(&f);
    free(buf);
}

static void test_feed_rotation_scene_sends_no_depth(void **state)
{
    (void)state;
    size_t len;
    uint8_t *buf = run_feed("--scene room --eye 64x64 --frames 2 --rate 200", &len);
    drv_frame f;
    assert_true(drv_frame_alloc(&f, 64, 64, DRV_PLANE_COLOR | DRV_PLANE_DEPTH, 1));
    size_t total;
    assert_int_equal(drv_framelink_peek(buf, len, 64u << 20, &total), DRV_FRAME_OK);
    assert_int_equal(drv_framelink_decode(buf, total, 64u << 20, &f), DRV_FRAME_OK);
    assert_int_equal(f.planes, DRV_PLANE_COLOR); /* a rotation-only scene never pays for depth */
    drv_frame_free(&f);
    free(buf);
}

/* --damage-every 3: frames 3, 6, 9 damaged in turn (payload byte, cut in half, version). A receiver resyncing on
 * the next magic after a bad frame (as the USB backend does) loses exactly those three, each for its reason. */
static void test_feed_damage_every(void **state)
{
    (void)state;
    size_t len;
    uint8_t *buf = run_feed("--scene room --eye 64x64 --frames 9 --rate 200 --damage-every 3", &len);
    drv_frame f;
    assert_true(drv_frame_alloc(&f, 64, 64, DRV_PLANE_COLOR | DRV_PLANE_DEPTH, 1));
    size_t at = 0;
    uint64_t good = 0, seqs = 0;
    int crc = 0, version = 0, other = 0;
    while (at < len) {
        size_t total = 0;
        drv_frame_err e = drv_framelink_peek(buf + at, len - at, 64u << 20, &total);
        if (e == DRV_FRAME_OK && total <= len - at) e = drv_framelink_decode(buf + at, total, 64u << 20, &f);
        else if (e == DRV_FRAME_OK) e = DRV_FRAME_ERR_TRUNCATED;
        if (e == DRV_FRAME_OK) {
            good++;
            seqs |= 1ull << f.seq;
            at += total;
            continue;
        }
        crc += e == DRV_FRAME_ERR_CRC;
        version += e == DRV_FRAME_ERR_BAD_VERSION;
        other += e != DRV_FRAME_ERR_CRC && e != DRV_FRAME_ERR_BAD_VERSION && e != DRV_FRAME_ERR_TRUNCATED;
        size_t skip = drv_framelink_find_magic(buf + at + 1, len - at - 1);
        at += 1 + skip;
    }
    assert_int_equal(good, 6);
    assert_int_equal(seqs, (1u << 1) | (1u << 2) | (1u << 4) | (1u << 5) | (1u << 7) | (1u << 8));
    /* the flipped payload byte and the cut frame (whose bytes run into the next one) fail their CRCs */
    assert_int_equal(crc, 2);
    assert_int_equal(version, 1);
    assert_int_equal(other, 0);
    drv_frame_free(&f);
    free(buf);
}

int main(int argc, char **argv)
{
    (void)argc;
    /* BUILD/tests/unit/test_feed -> BUILD/hmdwarp-feed */
    char tmp[512];
    snprintf(tmp, sizeof tmp, "%s", argv[0]);
    snprintf(feed_path, sizeof feed_path, "%s/hmdwarp-feed", dirname(dirname(dirname(tmp))));
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_feed_stream_decodes),
        cmocka_unit_test(test_feed_rotation_scene_sends_no_depth),
        cmocka_unit_test(test_feed_damage_every),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

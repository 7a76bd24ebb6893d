/* SPDX-License-Identifier: MIT */
/* hil_kms_crc, the HIL program that predicts vkms's CRC of a panel image: checked against an independent
 * bytewise CRC-32 (the kernel's crc32_le: reflected 0xEDB88320, no inversion) over vkms's 16-bit ARGB rows. */
#include <libgen.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <cmocka.h>

#include "tests/support/test_util.h"

static char prog[512];

/* Linux's crc32_le(crc, p, len), one bit at a time (lib/crc32.c's CRC_LE_BITS == 1 variant). */
static uint32_t crc32_le_bitwise(uint32_t crc, const uint8_t *p, size_t len)
{
    while (len--) {
        crc ^= *p++;
        for (int i = 0; i < 8; i++) crc = (crc >> 1) ^ ((crc & 1) ? 0xEDB88320u : 0);
    }
    return crc;
}

/* What vkms_composer.c computes for an opaque XRGB8888 plane covering the CRTC: per row, struct pixel_argb_u16
 * {a = 0xffff, r, g, b} with each channel * 257, crc chained from 0. */
static uint32_t vkms_reference(const uint8_t *rgba, int w, int h)
{
    uint32_t crc = 0;
    uint8_t *row = malloc((size_t)w * 8);
    for (int y = 0; y < h; y++) {
        for (int x = 0; x < w; x++) {
            const uint8_t *s = rgba + ((size_t)y * w + x) * 4;
            uint16_t v[4] = {0xffff, (uint16_t)(s[0] << 8 | s[0]), (uint16_t)(s[1] << 8 | s[1]),
                             (uint16_t)(s[2] << 8 | s[2])};
            memcpy(row + (size_t)x * 8, v, 8); /* the host is little-endian, as the VM */
        }
        crc = crc32_le_bitwise(crc, row, (size_t)w * 8);
    }
    free(row);
    return crc;
}

static void write_file(const char *path, const uint8_t *buf, size_t n)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(buf, 1, n, f), n);
    fclose(f);
}

/* Runs hil_kms_crc with args; its stdout lines parsed as hex into out (up to max); returns the exit status. */
static int run(const char *args, uint32_t *out, int max, int *n_out)
{
    char cmd[1024];
    snprintf(cmd, sizeof cmd, "%s%s %s 2>/dev/null", test_runner(), prog, args);
    FILE *p = popen(cmd, "r");
    assert_non_null(p);
    char line[64];
    int n = 0;
    while (fgets(line, sizeof line, p))
        if (n < max) out[n++] = (uint32_t)strtoul(line, NULL, 16);
    *n_out = n;
    int st = pclose(p);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

static void fill_random(uint8_t *buf, size_t n, unsigned seed)
{
    for (size_t i = 0; i < n; i++) {
        seed = seed * 1103515245u + 12345u;
        buf[i] = (uint8_t)(seed >> 16);
    }
}

static void test_reference_is_crc32(void **state)
{
    (void)state;
    /* the CRC-32 check value: with zlib's inversions around the kernel's plain crc32_le */
    assert_int_equal(crc32_le_bitwise(0xffffffffu, (const uint8_t *)"123456789", 9) ^ 0xffffffffu, 0xCBF43926u);
    /* one black pixel: the row is ff ff 00 00 00 00 00 00 (alpha 0xffff, then r, g, b = 0) */
    static const uint8_t black[8] = {0xff, 0xff};
    uint8_t px[4] = {0, 0, 0, 255};
    assert_int_equal(vkms_reference(px, 1, 1), crc32_le_bitwise(0, black, 8));
}

static void test_crc_matches_reference(void **state)
{
    (void)state;
    char path[] = "/tmp/test_hil_kms_crc_XXXXXX";
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    close(fd);
    /* odd sizes, random alpha (vkms ignores it on XRGB8888), three images in one stream */
    const int w = 37, h = 11;
    size_t isz = (size_t)w * h * 4;
    uint8_t *img = malloc(3 * isz);
    fill_random(img, 3 * isz, 7);
    write_file(path, img, 3 * isz);
    char args[600];
    uint32_t got[8];
    int n;
    snprintf(args, sizeof args, "crc %s %d %d --all", path, w, h);
    assert_int_equal(run(args, got, 8, &n), 0);
    assert_int_equal(n, 3);
    for (int i = 0; i < 3; i++) assert_int_equal(got[i], vkms_reference(img + i * isz, w, h));
    assert_int_not_equal(got[0], got[1]);
    /* without --all: the last image only */
    snprintf(args, sizeof args, "crc %s %d %d", path, w, h);
    assert_int_equal(run(args, got, 8, &n), 0);
    assert_int_equal(n, 1);
    assert_int_equal(got[0], vkms_reference(img + 2 * isz, w, h));
    /* a red/blue swap in one pixel (what a wrong scanout format would show) changes it */
    uint8_t t = img[2 * isz + 4 * 100];
    img[2 * isz + 4 * 100] = img[2 * isz + 4 * 100 + 2];
    img[2 * isz + 4 * 100 + 2] = t;
    assert_int_not_equal(vkms_reference(img + 2 * isz, w, h), got[0]);
    unlink(path);
    free(img);
}

static void test_pattern_is_the_crc_input(void **state)
{
    (void)state;
    char path[] = "/tmp/test_hil_kms_crc_XXXXXX";
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    close(fd);
    char args[600];
    uint32_t got[2];
    int n;
    snprintf(args, sizeof args, "pattern 640 480 >%s", path);
    assert_int_equal(run(args, got, 2, &n), 0);
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    size_t isz = 640 * 480 * 4;
    uint8_t *img = malloc(isz + 1);
    assert_int_equal(fread(img, 1, isz + 1, f), isz);
    fclose(f);
    /* every channel varies and the channels differ: an R/B swap or channel shift cannot keep the CRC */
    int rb_differ = 0;
    for (size_t i = 0; i < isz; i += 4) rb_differ += img[i] != img[i + 2];
    assert_true(rb_differ > 1000);
    snprintf(args, sizeof args, "crc %s 640 480", path);
    assert_int_equal(run(args, got, 2, &n), 0);
    assert_int_equal(n, 1);
    assert_int_equal(got[0], vkms_reference(img, 640, 480));
    unlink(path);
    free(img);
}

static void test_bad_input_is_refused(void **state)
{
    (void)state;
    char path[] = "/tmp/test_hil_kms_crc_XXXXXX";
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    close(fd);
    uint8_t small[16] = {0};
    write_file(path, small, sizeof small);
    char args[600];
    uint32_t got[2];
    int n;
    snprintf(args, sizeof args, "crc %s 0 4", path);
    assert_int_equal(run(args, got, 2, &n), 2);
    snprintf(args, sizeof args, "crc %s 4x 4", path);
    assert_int_equal(run(args, got, 2, &n), 2);
    snprintf(args, sizeof args, "crc %s 8 8", path); /* 16 bytes: no whole 8x8 image */
    assert_int_equal(run(args, got, 2, &n), 1);
    assert_int_equal(n, 0);
    assert_int_equal(run("crc /nonexistent/file 2 2", got, 2, &n), 1);
    assert_int_equal(run("frobnicate", got, 2, &n), 2);
    unlink(path);
}

int main(int argc, char **argv)
{
    (void)argc;
    /* BUILD/tests/unit/test_hil_kms_crc -> BUILD/hil/hil_kms_crc */
    char tmp[512];
    snprintf(tmp, sizeof tmp, "%s", argv[0]);
    snprintf(prog, sizeof prog, "%s/hil/hil_kms_crc", dirname(dirname(dirname(tmp))));
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_reference_is_crc32),
        cmocka_unit_test(test_crc_matches_reference),
        cmocka_unit_test(test_pattern_is_the_crc_input),
        cmocka_unit_test(test_bad_input_is_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

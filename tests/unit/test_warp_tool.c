/* SPDX-License-Identifier: MIT */
/* hmdwarp-warp end to end: the inputs it writes from the simulator (PNG colour, PFM depth, 16-bit ids, view file)
 * read back through its file loaders give the same warp and the same score; ray-distance depth and 16-bit
 * reversed-Z depth convert to the same result; bad inputs are refused with a message naming them, and declared sizes
 * are checked against the file before anything is allocated. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>
#include <cmocka.h>

#include "tests/support/test_util.h"

static char tool[256], dir[256];

/* Runs the tool; returns its exit status and its stdout in out. */
static int run(const char *args, char *out, size_t cap) { return test_run_program(tool, args, out, cap); }

static double psnr_of(const char *out)
{
    const char *p = strstr(out, "PSNR ");
    assert_non_null(p);
    return atof(p + 5);
}

/* Writes the view file every test starts from (DIR/v.txt) and returns its path. */
static const char *write_view(void)
{
    static char path[600];
    snprintf(path, sizeof path, "%s/v.txt", dir);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fprintf(f, "size 160 120\nintrinsics 80 75 80 60\nnear 0.05\nfar inf\n"
               "source 1 0 0 0  0 1.6 0\ntarget 0.99905 0 0.04362 0  0.04 1.6 0\n");
    fclose(f);
    return path;
}

/* Runs warp on the simulator's scene from the view file, writing its inputs into DIR/sub; returns the PSNR the
 * warp scored against the truth, for the same warp from those files to match. */
static double sim_inputs(const char *scene, const char *warp, const char *sub)
{
    char out[4096], args[8192];
    snprintf(args, sizeof args, "--sim %s --view %s --warp %s --write-inputs %s/%s", scene, write_view(), warp, dir,
             sub);
    assert_int_equal(run(args, out, sizeof out), 0);
    return psnr_of(out);
}

/* The arguments that warp, with `warp`, what --write-inputs wrote into DIR/sub and score it against that truth:
 * colour, depth, each file of `planes` (space-separated: ids.png as --ids DIR/sub/ids.png), the view, then `more`. */
static const char *files_args(const char *sub, const char *planes, const char *warp, const char *more)
{
    static char a[8192];
    size_t n = (size_t)snprintf(a, sizeof a, "--color %s/%s/color.png --depth %s/%s/depth.pfm", dir, sub, dir, sub);
    char list[256];
    snprintf(list, sizeof list, "%s", planes);
    for (char *save = NULL, *f = strtok_r(list, " ", &save); f; f = strtok_r(NULL, " ", &save))
        n += (size_t)snprintf(a + n, sizeof a - n, " --%.*s %s/%s/%s", (int)strcspn(f, "."), f, dir, sub, f);
    snprintf(a + n, sizeof a - n, " --view %s/%s/view.txt --warp %s --ref %s/%s/truth.png %s", dir, sub, warp, dir,
             sub, more);
    return a;
}

static void test_files_match_simulator(void **state)
{
    (void)state;
    char out[4096], args[8192], more[600];
    double sim_psnr = sim_inputs("near", "raytrace", "in");
    snprintf(more, sizeof more, "--out %s/o.png --mask %s/m.png", dir, dir);
    assert_int_equal(run(files_args("in", "ids.png", "raytrace", more), out, sizeof out), 0);
    print_message("%s", out);
    /* colour through 8-bit PNG is exact, depth through PFM is float-exact: the same result */
    assert_true(fabs(psnr_of(out) - sim_psnr) < 1e-6);
    /* and raytrace beats rotation on this translation case, through the files too */
    snprintf(args, sizeof args, "--color %s/in/color.png --view %s/in/view.txt --warp rotation --ref %s/in/truth.png",
             dir, dir, dir);
    assert_int_equal(run(args, out, sizeof out), 0);
    assert_true(psnr_of(out) < sim_psnr - 3);
}

static void test_layers_file_round_trip(void **state)
{
    (void)state;
    /* the A-buffer through its file format warps exactly as from the simulator */
    char out[4096], args[8192];
    double sim_psnr = sim_inputs("glass", "transparency", "glass");
    assert_int_equal(run(files_args("glass", "layers.bin", "transparency", ""), out, sizeof out), 0);
    assert_true(fabs(psnr_of(out) - sim_psnr) < 1e-6);
    /* a truncated layers file is refused with its name */
    snprintf(args, sizeof args, "head -c 100 %s/glass/layers.bin > %s/short.bin", dir, dir);
    assert_int_equal(system(args), 0);
    snprintf(args, sizeof args,
             "--color %s/glass/color.png --depth %s/glass/depth.pfm --layers %s/short.bin --view %s/glass/view.txt "
             "--warp transparency", dir, dir, dir, dir);
    assert_int_equal(run(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "short.bin"));
}

/* Object poses from a file (--objects, written by --write-inputs at the source and target times): the per-object
 * warp scores exactly what it scores on the simulator's poses (colour, depth, ids and motion through exact file
 * formats, poses printed with 17 digits); without them the objects stay where the source saw them, and score less. */
static void test_objects_file_matches_simulator(void **state)
{
    (void)state;
    char out[4096], args[8192];
    snprintf(args, sizeof args,
             "--sim movers --view %s --warp objects --time 0 --target-time 0.05 --write-inputs %s/mov", write_view(),
             dir);
    assert_int_equal(run(args, out, sizeof out), 0);
    double sim_psnr = psnr_of(out);
    assert_non_null(strstr(out, "moved"));
    snprintf(args, sizeof args, "%s",
             files_args("mov", "ids.png motion.pfm", "objects", "--time 0 --target-time 0.05"));
    char with[8800];
    snprintf(with, sizeof with, "%s --objects %s/mov/objects.txt", args, dir);
    assert_int_equal(run(with, out, sizeof out), 0);
    print_message("%s", out);
    assert_true(fabs(psnr_of(out) - sim_psnr) < 1e-6);
    assert_int_equal(run(args, out, sizeof out), 0);
    assert_true(psnr_of(out) < sim_psnr - 0.3);
    /* a broken object file is refused naming the line and object */
    snprintf(with, sizeof with, "%s/mov/objects.txt", dir);
    FILE *f = fopen(with, "a");
    fprintf(f, "object 12  1 0 0 0  0 nan 0\n");
    fclose(f);
    snprintf(with, sizeof with, "%s --objects %s/mov/objects.txt", args, dir);
    assert_int_equal(run(with, out, sizeof out), 1);
    assert_non_null(strstr(out, "objects.txt:13: object 12: source pose")); /* 2 comment lines, 10 objects */
}

static void put_be32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++) p[i] = (uint8_t)(v >> (24 - 8 * i));
}

/* A PNG of just signature, IHDR (w x h, 8-bit RGBA), an empty IDAT and IEND: what a few bytes can declare. */
static void write_png_header(const char *path, uint32_t w, uint32_t h)
{
    uint8_t b[8 + 25 + 12 + 12] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    uint8_t *c = b + 8;
    put_be32(c, 13);
    memcpy(c + 4, "IHDR", 4);
    put_be32(c + 8, w);
    put_be32(c + 12, h);
    c[16] = 8, c[17] = 6;
    put_be32(c + 21, (uint32_t)crc32(0, c + 4, 17));
    c += 25;
    memcpy(c + 4, "IDAT", 4);
    put_be32(c + 8, (uint32_t)crc32(0, c + 4, 4));
    c += 12;
    memcpy(c + 4, "IEND", 4);
    put_be32(c + 8, (uint32_t)crc32(0, c + 4, 4));
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    fwrite(b, 1, sizeof b, f);
    fclose(f);
}

/* Sizes a file declares are checked against what it holds before anything is allocated (issue #16: a 68-byte PNG
 * made it allocate 4.3 GB, a PFM header 6.4 GB); a NaN pose or an overlong line in the view file is refused. */
static void test_declared_sizes_bounded(void **state)
{
    (void)state;
    char out[4096], args[8192], path[600];
    const char *view = write_view();
    snprintf(path, sizeof path, "%s/huge.png", dir);
    write_png_header(path, 32768, 32768);
    snprintf(args, sizeof args, "--color %s --view %s", path, view);
    assert_int_equal(run(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "32768x32768 pixels is larger than this reader takes"));
    write_png_header(path, 16000, 16000);
    assert_int_equal(run(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "more than a file of 57 bytes can hold"));
    snprintf(path, sizeof path, "%s/huge.pfm", dir);
    FILE *f = fopen(path, "w");
    fprintf(f, "PF\n16384 16384\n-1.0\n");
    fclose(f);
    snprintf(args, sizeof args, "--color %s/in/color.png --view %s --warp raytrace --motion %s --depth %s/in/depth.pfm",
             dir, view, path, dir);
    assert_int_equal(run(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "declares 16384x16384x3 floats (3221225472 bytes) but holds 0"));
    f = fopen(view, "w");
    fprintf(f, "size 160 120\nintrinsics 80 75 80 60\nsource 1 0 0 0  nan 1.6 0\ntarget 1 0 0 0 0 0 0\n");
    fclose(f);
    snprintf(args, sizeof args, "--color %s/in/color.png --view %s", dir, view);
    assert_int_equal(run(args, out, sizeof out), 1);
    assert_non_null(strstr(out, ":3: 'source': x is not finite"));
    /* each bad field is named (issue #21), the zero quaternion apart from an unreadable line */
    const struct {
        const char *text, *want;
    } bad[] = {
        {"size 160 120\nintrinsics 80 75 80 60\nsource 1 0 0 0 0 0 0\ntarget 1 0 0 0 0 -inf 0\n",
         ":4: 'target': y is not finite"},
        {"size 160 120\nintrinsics 80 75 80 60\nsource 0 0 0 0 0 1.6 0\ntarget 1 0 0 0 0 0 0\n",
         ":3: 'source': orientation quaternion qw qx qy qz is zero"},
        {"size 160 120\nintrinsics 80 75 80 60\nsource 1 nan 0 0 0 1.6 0\ntarget 1 0 0 0 0 0 0\n",
         ":3: 'source': qx is not finite"},
        {"size 160 120\nintrinsics 80 75 nan 60\nsource 1 0 0 0 0 0 0\ntarget 1 0 0 0 0 0 0\n",
         ":2: 'intrinsics': fx fy cx cy must be finite numbers"},
        {"size 160 120\ntan 1 inf 0.75 0.75\nsource 1 0 0 0 0 0 0\ntarget 1 0 0 0 0 0 0\n",
         ":2: 'tan': the tangents must be finite numbers"},
        {"size 160 120\nnear nan\ntan 1 1 0.75 0.75\nsource 1 0 0 0 0 0 0\ntarget 1 0 0 0 0 0 0\n",
         ":2: 'near': near must be a finite number"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        f = fopen(view, "w");
        fputs(bad[i].text, f);
        fclose(f);
        assert_int_equal(run(args, out, sizeof out), 1);
        if (!strstr(out, bad[i].want)) fail_msg("case %zu: want '%s', got '%s'", i, bad[i].want, out);
    }
    /* a comment line longer than the reader's buffer: named, not read in pieces with shifted line numbers */
    f = fopen(view, "w");
    fprintf(f, "size 160 120\n# %0600d\nintrinsics 80 75 80 60\nsource 1 0 0 0 0 0 0\ntarget 1 0 0 0 0 0 0\n", 0);
    fclose(f);
    assert_int_equal(run(args, out, sizeof out), 1);
    assert_non_null(strstr(out, ":2: line longer than 510 characters"));
}

static void test_bad_inputs_named(void **state)
{
    (void)state;
    char out[4096], args[8192];
    const char *view = write_view();
    snprintf(args, sizeof args, "--color %s/nope.png --view %s", dir, view);
    assert_int_equal(run(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "nope.png"));
    snprintf(args, sizeof args, "--color %s/in/color.png --view %s --warp raytrace", dir, view);
    assert_int_equal(run(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "needs --depth"));
    snprintf(args, sizeof args, "--color %s/in/color.png --view %s --warp raytrace --depth %s/in/color.png", dir,
             view, dir);
    assert_int_equal(run(args, out, sizeof out), 1);
    assert_non_null(strstr(out, "16-bit"));
    FILE *f = fopen(view, "w");
    fprintf(f, "size 160 120\nbogus 1\n");
    fclose(f);
    snprintf(args, sizeof args, "--color %s/in/color.png --view %s", dir, view);
    assert_int_equal(run(args, out, sizeof out), 1);
    assert_non_null(strstr(out, ":2: unknown key 'bogus'"));
    assert_int_equal(run("--warp nosuchwarp", out, sizeof out), 2);
}

int main(int argc, char **argv)
{
    (void)argc;
    char build[200];
    if (!test_build_dirs(argv[0], build, sizeof build, dir, sizeof dir, "warp-tool")) return 1;
    snprintf(tool, sizeof tool, "%s/hmdwarp-warp", build);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_files_match_simulator),
        cmocka_unit_test(test_layers_file_round_trip),
        cmocka_unit_test(test_objects_file_matches_simulator),
        cmocka_unit_test(test_bad_inputs_named),
        cmocka_unit_test(test_declared_sizes_bounded),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

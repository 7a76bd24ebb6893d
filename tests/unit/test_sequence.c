/* SPDX-License-Identifier: MIT */
/* Recorded sequences (docs/sequences.md): the manifest reader takes a good manifest and refuses broken ones naming
 * the line and field; hmdwarp-feed --sequence plays what hmdwarp-warp writes (--write-inputs, --write-sequence) into
 * a file whose frames decode to the manifest's images, layers, poses and planes, at its own rate or the board's. */
#include <math.h>
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
#include "platform/plat_png.h"
#include "tools/common/seq_manifest.h"
#include "tools/common/warp_files.h"

static char build[400], dir[480];

/* ---- the reader ---- */

/* DIR/NAME/manifest.txt with the given text, beside a 4x2 colour c.png and a 4x2 depth d.pfm. Returns the folder. */
static const char *manifest(const char *name, const char *text)
{
    static char d[800];
    char p[900], err[300];
    snprintf(d, sizeof d, "%s/%s", dir, name);
    snprintf(p, sizeof p, "mkdir -p '%s'", d);
    assert_int_equal(system(p), 0);
    warp_image_rgba8 img;
    assert_true(warp_image_rgba8_alloc(&img, 4, 2));
    for (int y = 0; y < 2; y++)
        for (int x = 0; x < 4; x++) WARP_AT(&img, x, y) = (warp_rgba8){(uint8_t)(10 * x), (uint8_t)(100 + y), 7, 255};
    snprintf(p, sizeof p, "%s/c.png", d);
    assert_true(plat_png_write(p, &img, false, err, sizeof err));
    warp_image_free(&img);
    const float depth[8] = {1, 2, 3, 4, 5, 6, 7, 8};
    snprintf(p, sizeof p, "%s/d.pfm", d);
    assert_true(warpfile_write_pfm(p, depth, 4, 2, 1));
    snprintf(p, sizeof p, "%s/%s", d, SEQ_MANIFEST_NAME);
    FILE *f = fopen(p, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
    return d;
}

#define HEAD "hmdwarp-sequence 1\neyes 1\nsize 4 2\nintrinsics 2 2 2 1\nframes\n"
#define COLS "index,time,qw,qx,qy,qz,x,y,z,color,depth\n"

static void test_reader_good_manifest(void **state)
{
    (void)state;
    char err[400];
    seq_manifest m;
    const char *d = manifest("good", "# a comment\n" HEAD COLS
                                     "0, 0.5, 1,0,0,0, 0,1.6,0, c.png, d.pfm\n"
                                     "# comments between frames\n"
                                     "1,0.6,0.7071068,0,0.7071068,0,1,1.6,-2,c.png,d.pfm\r\n");
    assert_true(seq_open(d, &m, err, sizeof err));
    assert_int_equal(m.n, 2);
    assert_int_equal(m.eyes, 1);
    assert_int_equal(m.planes, DRV_PLANE_COLOR | DRV_PLANE_DEPTH);
    /* intrinsics fx fy cx cy in pixels, y down -> tangents; the one view serves both eyes */
    assert_true(fabs(m.cam[0].tan_left - 1) < 1e-12 && fabs(m.cam[0].tan_right - 1) < 1e-12);
    assert_true(fabs(m.cam[1].tan_up - 0.5) < 1e-12 && fabs(m.cam[1].tan_down - 0.5) < 1e-12);
    assert_true(fabs(m.frames[1].time - 0.6) < 1e-15);
    assert_int_equal(m.frames[1].line, 10);
    drv_frame f;
    assert_true(drv_frame_alloc(&f, 4, 2, m.planes, m.max_layers));
    assert_true(seq_load_frame(&m, 1, ~0u, &f, err, sizeof err));
    assert_int_equal(f.planes, DRV_PLANE_COLOR | DRV_PLANE_DEPTH);
    for (int e = 0; e < 2; e++) {
        assert_int_equal(WARP_AT(&f.color[e], 3, 1).r, 30);
        assert_int_equal(WARP_AT(&f.color[e], 3, 1).g, 101);
        assert_true(WARP_AT(&f.depth[e], 1, 1) == 6.0f);
        /* normalised on reading: within the tolerance, not exactly unit */
        assert_true(fabs(f.eye_pose[e].q.w - sqrt(0.5)) < 1e-6 && f.eye_pose[e].p.z == -2);
    }
    assert_int_equal(drv_frame_validate(&f), DRV_FRAME_OK);
    /* planes not asked for are not loaded */
    assert_true(seq_load_frame(&m, 0, DRV_PLANE_COLOR, &f, err, sizeof err));
    assert_int_equal(f.planes, DRV_PLANE_COLOR);
    assert_false(seq_load_frame(&m, 2, ~0u, &f, err, sizeof err));
    drv_frame_free(&f);
    seq_close(&m);
}

/* Window depth from 16-bit PNG (value / 65535) in the manifest's encoding, ray distance in millimetres to planar
 * metres, and a right eye with its own intrinsics. */
static void test_reader_depth_encodings(void **state)
{
    (void)state;
    char err[400], p[900];
    const char *d = manifest("enc", "hmdwarp-sequence 1\nsize 4 2\nintrinsics 2 2 2 1\nintrinsics-right 2 2 1 1\n"
                                    "depth-encoding reversed\nnear 0.1\nframes\n"
                                    "index,time,left_qw,left_qx,left_qy,left_qz,left_x,left_y,left_z,right_qw,right_qx,"
                                    "right_qy,right_qz,right_x,right_y,right_z,left_color,right_color,left_depth,"
                                    "right_depth\n0,0,1,0,0,0,0,0,0,1,0,0,0,0.064,0,0,c.png,c.png,d16.png,d16.png\n");
    const uint16_t u[8] = {0, 1, 65535, 32768, 100, 200, 300, 400};
    snprintf(p, sizeof p, "%s/d16.png", d);
    assert_true(plat_png_write_u16(p, u, 4, 2, err, sizeof err));
    seq_manifest m;
    assert_true(seq_open(d, &m, err, sizeof err));
    assert_int_equal(m.eyes, 2);
    assert_true(m.cam[1].tan_left == 0.5 && m.cam[1].tan_right == 1.5 && m.cam[0].tan_left == 1);
    drv_frame f;
    assert_true(drv_frame_alloc(&f, 4, 2, m.planes, m.max_layers));
    assert_true(seq_load_frame(&m, 0, ~0u, &f, err, sizeof err));
    assert_int_equal(f.depth_encoding, WARP_DEPTH_REVERSED);
    assert_true(WARP_AT(&f.depth[1], 2, 0) == 1.0f && WARP_AT(&f.depth[0], 3, 0) == (float)(32768 / 65535.0));
    assert_true(f.eye_pose[1].p.x == 0.064);
    seq_close(&m);
    /* ray distance in millimetres (raw float32): planar z = distance / |ray at z = 1| in metres */
    d = manifest("ray", "hmdwarp-sequence 1\neyes 1\nsize 4 2\ntan 1 1 0.5 0.5\ndepth-kind ray\ndepth-scale 0.001\n"
                        "frames\nindex,time,qw,qx,qy,qz,x,y,z,color,depth\n0,0,1,0,0,0,0,0,0,c.png,d.f32\n");
    const float mm[8] = {3000, 3000, 3000, 3000, 3000, 3000, 3000, 3000};
    snprintf(p, sizeof p, "%s/d.f32", d);
    FILE *o = fopen(p, "wb");
    fwrite(mm, sizeof mm, 1, o);
    fclose(o);
    assert_true(seq_open(d, &m, err, sizeof err));
    assert_true(seq_load_frame(&m, 0, ~0u, &f, err, sizeof err));
    /* pixel (0, 0): centre at tangents (-0.75, 0.25) */
    assert_true(fabs(WARP_AT(&f.depth[0], 0, 0) - 3.0 / sqrt(0.75 * 0.75 + 0.25 * 0.25 + 1)) < 1e-6);
    seq_close(&m);
    drv_frame_free(&f);
}

/* Every broken manifest is refused with a message naming the line and field, nothing allocated stays (ASan). */
static void test_reader_broken_manifests(void **state)
{
    (void)state;
    static const struct {
        const char *text, *expect;
    } cases[] = {
        {"", "empty"},
        {"hmdwarp-sequence 2\n", ":1: expected 'hmdwarp-sequence 1' first"},
        {"hmdwarp-sequence 1\nsize 4 2\nbogus 1\n", ":3: unknown key 'bogus'"},
        {"hmdwarp-sequence 1\neyes 3\n", ":2: cannot read the value of 'eyes'"},
        {"hmdwarp-sequence 1\nsize 4 2\nintrinsics 0 2 2 1\n", ":3: cannot read the value of 'intrinsics'"},
        {"hmdwarp-sequence 1\nsize 4 2\nframes\n", "needs size and tan or intrinsics"},
        {"hmdwarp-sequence 1\nsize 4 2\ntan 1 1 1 1\ndepth-encoding log\n",
         ":4: cannot read the value of 'depth-encoding'"},
        {"hmdwarp-sequence 1\nsize 4 2\ntan 1 1 1 1\ndepth-kind ray\ndepth-encoding reversed\nframes\n",
         "depth-kind ray needs depth-encoding linear"},
        {"hmdwarp-sequence 1\nsize 4 2\ntan -1 -1 1 1\nframes\n", "left camera"},
        {HEAD, "no column line after 'frames'"},
        {HEAD COLS, "no frames"},
        {HEAD "index,time,qw,qx,qy,qz,x,y,z,colour\n", ":6: column 'colour': unknown"},
        {HEAD "index,time,qw,qx,qy,qz,x,y,z,color,time\n", ":6: column 'time': named twice"},
        {HEAD "index,time,,qw,qx,qy,qz,x,y,z,color\n", ":6: column 3 has no name"},
        {HEAD "index,time,qw,qx,qy,qz,x,y,color\n", ":6: no column 'z'"},
        {HEAD "index,time,qw,qx,qy,qz,x,y,z\n", ":6: no column 'color'"},
        {"hmdwarp-sequence 1\nsize 4 2\ntan 1 1 1 1\nframes\nindex,time,left_qw,left_qx,left_qy,left_qz,left_x,left_y,"
         "left_z,left_color,left_depth,right_qw,right_qx,right_qy,right_qz,right_x,right_y,right_z,right_color\n",
         ":5: no column 'right_depth'"},
        {HEAD COLS "0,0,1,0,0,0,0,1.6,0,c.png\n", ":7: 10 fields, the column line names 11"},
        {HEAD COLS "0,0,1,0,0,0,0,1.6,0,c.png,d.pfm,x\n", ":7: 12 fields, the column line names 11"},
        {HEAD COLS "0,0,1,0,0,0,nan,1.6,0,c.png,d.pfm\n", ":7: field 'x': 'nan' is not a finite number"},
        {HEAD COLS "0,0,1,0,0,0,0,1.6m,0,c.png,d.pfm\n", ":7: field 'y': '1.6m' is not a finite number"},
        {HEAD COLS "0,0,1,0,0,0.1,0,1.6,0,c.png,d.pfm\n", ":7: fields 'qw'..'qz': quaternion length 1.00499"},
        {HEAD COLS "0,0,0,0,0,1,1,0,0,0,c.png,d.pfm\n", ":7: 12 fields"},
        {HEAD COLS "1,0,1,0,0,0,0,1.6,0,c.png,d.pfm\n", ":7: field 'index': 1, expected 0"},
        {HEAD COLS "0,1,1,0,0,0,0,1.6,0,c.png,d.pfm\n1,1,1,0,0,0,0,1.6,0,c.png,d.pfm\n",
         ":8: field 'time': 1 is not after the previous frame's 1"},
        {HEAD COLS "0,0,1,0,0,0,0,1.6,0,c.png,\n", ":7: field 'depth': empty"},
        {HEAD COLS "0,0,1,0,0,0,0,1.6,0,nope.png,d.pfm\n", ":7: field 'color': "},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char err[400] = "", name[32];
        snprintf(name, sizeof name, "bad%zu", i);
        seq_manifest m;
        bool ok = seq_open(manifest(name, cases[i].text), &m, err, sizeof err);
        print_message("case %zu: %s\n", i, err);
        assert_false(ok);
        assert_non_null(strstr(err, SEQ_MANIFEST_NAME));
        assert_non_null(strstr(err, cases[i].expect));
    }
    /* the missing file is named with the error */
    char err[400];
    seq_manifest m;
    assert_false(seq_open(manifest("bad_file", HEAD COLS "0,0,1,0,0,0,0,1.6,0,nope.png,d.pfm\n"), &m, err, sizeof err));
    assert_non_null(strstr(err, "nope.png: No such file or directory"));
    assert_false(seq_open("/nonexistent/dir", &m, err, sizeof err));
    assert_non_null(strstr(err, "/nonexistent/dir"));
}

/* A file of the wrong size is refused when the frame loads, naming it and the manifest's line. */
static void test_reader_wrong_size_file(void **state)
{
    (void)state;
    char err[400], p[900];
    const char *d = manifest("size", "hmdwarp-sequence 1\neyes 1\nsize 4 3\ntan 1 1 1 1\nframes\n" COLS
                                     "0,0,1,0,0,0,0,1.6,0,c.png,d.pfm\n");
    seq_manifest m;
    assert_true(seq_open(d, &m, err, sizeof err));
    drv_frame f;
    assert_true(drv_frame_alloc(&f, 4, 3, m.planes, m.max_layers));
    assert_false(seq_load_frame(&m, 0, ~0u, &f, err, sizeof err));
    print_message("%s\n", err);
    assert_non_null(strstr(err, "manifest.txt:7 (frame 0): "));
    assert_non_null(strstr(err, "c.png"));
    seq_close(&m);
    /* an objects file with a bad line: named with its line and the object */
    d = manifest("objs", HEAD "index,time,qw,qx,qy,qz,x,y,z,color,objects\n0,0,1,0,0,0,0,1.6,0,c.png,o.txt\n");
    snprintf(p, sizeof p, "%s/o.txt", d);
    FILE *o = fopen(p, "w");
    fputs("# objects\nobject 1  1 0 0 0  0 0 0\nobject 2  2 0 0 0  0 0 0\n", o);
    fclose(o);
    assert_true(seq_open(d, &m, err, sizeof err));
    assert_false(seq_load_frame(&m, 0, ~0u, &f, err, sizeof err));
    print_message("%s\n", err);
    assert_non_null(strstr(err, "o.txt:3: object 2: source pose"));
    seq_close(&m);
    drv_frame_free(&f);
}

static void test_objects_file(void **state)
{
    (void)state;
    char p[700], err[400];
    snprintf(p, sizeof p, "%s/objects.txt", dir);
    static const struct {
        const char *text, *expect;
    } bad[] = {
        {"object 0 1 0 0 0 0 0 0\n", ":1: id 0: outside 1..64"},
        {"object 3 1 0 0 0 0 0 0\nobject 3 1 0 0 0 0 0 0\n", ":2: id 3: listed twice"},
        {"thing 1\n", ":1: expected 'object ID'"},
        {"object 1 1 0 0 0 0 0 inf\n", ":1: object 1: source pose"},
        {"object 1 1 0 0 0 0 0 0 1 0 0\n", ":1: object 1: target pose"},
        {"object 1 1 0 0 0 0 0 0 1 0 0 0 0 0 0 5\n", ":1: object 1: more than 14 numbers"},
    };
    warpfile_objects o;
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        FILE *f = fopen(p, "w");
        fputs(bad[i].text, f);
        fclose(f);
        assert_false(warpfile_load_objects(p, &o, err, sizeof err));
        assert_non_null(strstr(err, bad[i].expect));
    }
    warp_pose src[3] = {warp_pose_identity(), {{0.6, 0.8, 0, 0}, {1, 2, 3}}, warp_pose_identity()};
    warp_pose dst[3] = {warp_pose_identity(), {{0.8, 0.6, 0, 0}, {1, 2, 4}}, warp_pose_identity()};
    assert_true(warpfile_write_objects(p, 3, src, dst));
    assert_true(warpfile_load_objects(p, &o, err, sizeof err));
    assert_int_equal(o.n, 3);
    assert_true(o.has_target);
    assert_true(o.src[1].q.x == 0.8 && o.dst[1].p.z == 4 && o.dst[1].q.w == 0.8);
}

/* ---- the tools ---- */

static int run(const char *cmd_args, char *out, size_t cap)
{
    char cmd[4000];
    snprintf(cmd, sizeof cmd, "%s%s 2>&1", test_runner(), cmd_args);
    int st = -1;
    assert_true(test_capture(cmd, out, cap, &st));
    return st;
}

/* hmdwarp-feed ARGS --file DIR/NAME; returns the stream read back (free it) and its length. */
static uint8_t *feed(const char *args, const char *name, size_t *len)
{
    char cmd[3000], out[8192], path[900];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    snprintf(cmd, sizeof cmd, "%s/hmdwarp-feed %s --file %s", build, args, path);
    int rc = run(cmd, out, sizeof out);
    print_message("%s", out);
    assert_int_equal(rc, 0);
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    uint8_t *buf = malloc((size_t)n + 1);
    assert_int_equal(fread(buf, 1, (size_t)n, f), (size_t)n);
    fclose(f);
    *len = (size_t)n;
    return buf;
}

static void write_view(const char *path)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fprintf(f, "size 96 64\nintrinsics 48 48 48 32\nnear 0.05\nfar inf\n"
               "source 1 0 0 0  0 1.6 0\ntarget 0.99905 0 0.04362 0  0.04 1.6 0\n");
    fclose(f);
}

static bool same_pose(warp_pose a, warp_pose b)
{
    return a.q.w == b.q.w && a.q.x == b.q.x && a.q.y == b.q.y && a.q.z == b.q.z && a.p.x == b.p.x &&
           a.p.y == b.p.y && a.p.z == b.p.z;
}

/* Each frame of the stream against the manifest's frame (index i % m->n): the same planes, pixels, poses and
 * objects; returns the frames decoded. */
static int check_stream(const uint8_t *buf, size_t len, const seq_manifest *m, unsigned planes)
{
    drv_frame got, want;
    int w = m->cam[0].width, h = m->cam[0].height;
    assert_true(drv_frame_alloc(&got, w, h, planes, m->max_layers));
    assert_true(drv_frame_alloc(&want, w, h, planes, m->max_layers));
    char err[400];
    size_t at = 0;
    int n = 0;
    while (at < len) {
        test_stream_next(buf, len, &at, 256u << 20, &got);
        assert_true(seq_load_frame(m, n % m->n, planes, &want, err, sizeof err));
        assert_int_equal(got.seq, (uint64_t)n + 1);
        assert_int_equal(got.planes, want.planes);
        assert_int_equal(got.n_objects, want.n_objects);
        for (int k = 0; k < want.n_objects; k++) assert_true(same_pose(got.object_pose[k], want.object_pose[k]));
        for (int e = 0; e < 2; e++) {
            assert_true(same_pose(got.eye_pose[e], want.eye_pose[e]));
            assert_true(got.cam[e].tan_left == want.cam[e].tan_left && got.cam[e].tan_down == want.cam[e].tan_down);
            for (int y = 0; y < h; y++) {
                assert_memory_equal(&WARP_AT(&got.color[e], 0, y), &WARP_AT(&want.color[e], 0, y), 4 * (size_t)w);
                if (planes & DRV_PLANE_DEPTH)
                    assert_memory_equal(&WARP_AT(&got.depth[e], 0, y), &WARP_AT(&want.depth[e], 0, y), 4 * (size_t)w);
                if (planes & DRV_PLANE_IDS)
                    assert_memory_equal(&WARP_AT(&got.ids[e], 0, y), &WARP_AT(&want.ids[e], 0, y), 2 * (size_t)w);
                if (planes & DRV_PLANE_MOTION)
                    assert_memory_equal(&WARP_AT(&got.motion[e], 0, y), &WARP_AT(&want.motion[e], 0, y), 8 * (size_t)w);
            }
            for (int i = 0; (planes & DRV_PLANE_LAYERS) && i < w * h; i++) {
                assert_int_equal(got.layers[e].count[i], want.layers[e].count[i]);
                for (int k = 0; k < want.layers[e].count[i]; k++) {
                    const warp_fragment *a = &got.layers[e].frag[(size_t)i * got.layers[e].max_layers + k];
                    const warp_fragment *b = &want.layers[e].frag[(size_t)i * want.layers[e].max_layers + k];
                    assert_true(a->z == b->z && a->id == b->id && !memcmp(&a->rgba, &b->rgba, 4));
                }
            }
        }
        n++;
    }
    drv_frame_free(&got);
    drv_frame_free(&want);
    return n;
}

/* The Done-when point: what hmdwarp-warp --write-inputs writes is a one-frame sequence hmdwarp-feed plays. */
static void test_feed_plays_write_inputs(void **state)
{
    (void)state;
    char cmd[3000], out[8192], err[400];
    snprintf(cmd, sizeof cmd, "%s/v.txt", dir);
    write_view(cmd);
    snprintf(cmd, sizeof cmd, "%s/hmdwarp-warp --sim movers --view %s/v.txt --write-inputs %s/inputs", build, dir, dir);
    assert_int_equal(run(cmd, out, sizeof out), 0);
    char in[700];
    snprintf(in, sizeof in, "%s/inputs", dir);
    seq_manifest m;
    assert_true(seq_open(in, &m, err, sizeof err));
    assert_int_equal(m.n, 1);
    unsigned planes = DRV_PLANE_COLOR | DRV_PLANE_DEPTH | DRV_PLANE_IDS | DRV_PLANE_MOTION;
    assert_int_equal(m.planes & planes, planes);
    size_t len;
    snprintf(cmd, sizeof cmd, "--sequence %s --planes color,depth,ids,motion", in);
    uint8_t *buf = feed(cmd, "inputs.bin", &len);
    assert_int_equal(check_stream(buf, len, &m, planes), 1);
    /* and the colour on the wire is the PNG hmdwarp-warp wrote, the depth its PFM, the pose the view's source */
    warp_image_rgba8 png;
    snprintf(cmd, sizeof cmd, "%s/color.png", in);
    assert_true(plat_png_read(cmd, &png, err, sizeof err));
    drv_frame f;
    assert_true(drv_frame_alloc(&f, 96, 64, planes, 8));
    assert_int_equal(drv_framelink_decode(buf, len, 0, &f), DRV_FRAME_OK);
    assert_memory_equal(f.color[1].px, png.px, 96 * 64 * 4);
    assert_true(f.eye_pose[0].p.y == 1.6 && f.eye_pose[1].q.w == 1);
    assert_true(f.n_objects > 4);
    warp_image_free(&png);
    drv_frame_free(&f);
    free(buf);
    seq_close(&m);
}

/* hmdwarp-warp --sim SIM ARGS writes a sequence at dir/NAME (its path into sq), opened into m. */
static void sim_sequence(const char *sim, const char *args, const char *name, char *sq, size_t sqcap, seq_manifest *m)
{
    char cmd[3000], out[8192], err[400];
    snprintf(cmd, sizeof cmd, "%s/v.txt", dir);
    write_view(cmd);
    snprintf(sq, sqcap, "%s/%s", dir, name);
    snprintf(cmd, sizeof cmd, "%s/hmdwarp-warp --sim %s --view %s/v.txt --write-sequence %s %s", build, sim, dir, sq,
             args);
    assert_int_equal(run(cmd, out, sizeof out), 0);
    assert_true(seq_open(sq, m, err, sizeof err));
}

/* A stereo sequence from the simulator, played once at its own rate, then at the board's, looping. */
static void test_feed_plays_simulator_sequence(void **state)
{
    (void)state;
    char cmd[3000], sq[700];
    seq_manifest m;
    sim_sequence("movers", "--frames 4 --rate 200", "seq", sq, sizeof sq, &m);
    assert_int_equal(m.n, 4);
    assert_int_equal(m.eyes, 2);
    assert_true(m.objects);
    /* the eyes IPD apart, the head moving: no two frames' poses alike */
    assert_true(fabs(m.frames[0].pose[1].p.x - m.frames[0].pose[0].p.x - 0.064) < 1e-9);
    assert_false(same_pose(m.frames[0].pose[0], m.frames[3].pose[0]));
    size_t len;
    snprintf(cmd, sizeof cmd, "--sequence %s --planes color,depth,ids,motion", sq);
    uint8_t *buf = feed(cmd, "own.bin", &len);
    assert_int_equal(check_stream(buf, len, &m, DRV_PLANE_COLOR | DRV_PLANE_DEPTH | DRV_PLANE_IDS | DRV_PLANE_MOTION),
                     4);
    free(buf);
    /* one frame per pose message, around again from frame 0 after frame 3; the default planes: colour and depth */
    snprintf(cmd, sizeof cmd, "--sequence %s --sequence-rate board --loop --frames 6", sq);
    buf = feed(cmd, "board.bin", &len);
    assert_int_equal(check_stream(buf, len, &m, DRV_PLANE_COLOR | DRV_PLANE_DEPTH), 6);
    free(buf);
    seq_close(&m);
}

/* Transparency: the layers files of a scene with glass reach the stream fragment for fragment. */
static void test_feed_plays_layers(void **state)
{
    (void)state;
    char cmd[3000], err[400], sq[700];
    seq_manifest m;
    sim_sequence("glass", "--frames 2", "glass", sq, sizeof sq, &m);
    assert_true(m.planes & DRV_PLANE_LAYERS);
    size_t len;
    snprintf(cmd, sizeof cmd, "--sequence %s --planes color,depth,layers", sq);
    uint8_t *buf = feed(cmd, "glass.bin", &len);
    assert_int_equal(check_stream(buf, len, &m, DRV_PLANE_COLOR | DRV_PLANE_DEPTH | DRV_PLANE_LAYERS), 2);
    /* the glass is there: some pixel carries fragments */
    drv_frame f;
    assert_true(drv_frame_alloc(&f, 96, 64, m.planes, m.max_layers));
    assert_true(seq_load_frame(&m, 0, ~0u, &f, err, sizeof err));
    long frags = 0;
    for (int i = 0; i < 96 * 64; i++) frags += f.layers[0].count[i];
    assert_true(frags > 100);
    drv_frame_free(&f);
    free(buf);
    seq_close(&m);
}

/* Bad input on the command line: the manifest's problem named, exit 2, nothing written as a frame. */
/* The Done-when point on a board: hmdwarpd's socket backend (the simulated board's IMU and vsync, offscreen) receives
 * every frame hmdwarp-feed --sequence plays to it once its display runs, at the sequence's own 30 Hz and looping,
 * rejects none and shows more than one. */
static void test_feed_plays_to_board(void **state)
{
    (void)state;
    char sq[600], sock[108], stats[600], cmd[6000], out[16384];
    seq_manifest m;
    sim_sequence("movers", "--frames 4 --rate 30", "board", sq, sizeof sq, &m);
    snprintf(sock, sizeof sock, "/tmp/hmdwarp-seq-%d.sock", (int)getpid()); /* sun_path holds 108 bytes */
    snprintf(stats, sizeof stats, "%s/board.stats", dir);
    const char *r = test_runner();
    snprintf(cmd, sizeof cmd,
             "unset HMDWARP_TIME_SLOWDOWN; rm -f %s; %s%s/hmdwarpd --config board/sim/board.ini --set sim.eval_every_ms=0 "
             "--set render.rt_priority=0 --set frames.backend=socket --set frames.device=%s --set eye.width=96 "
             "--set eye.height=64 --set sim.imu_rest_s=0.2 --duration 0 --set telemetry.live_stats=%s.live "
             "--stats %s >%s/board.log 2>&1 </dev/null & b=$!; "
             /* frames once the display runs (it starts after the IMU's rest); 5 minutes only against a hang */
             "for i in $(seq 3000); do grep -qs '^vsyncs=[1-9]' %s.live && break; sleep 0.1; done; "
             "%s%s/hmdwarp-feed --sequence %s --sequence-rate own --loop --frames 16 --socket %s; rc=$?; "
             "kill -TERM $b; wait $b; echo \"board exit $?\"; cat %s/board.log; rm -f %s; exit $rc",
             sock, r, build, sock, stats, stats, dir, stats, r, build, sq, sock, dir, sock);
    int st = -1;
    assert_true(test_capture(cmd, out, sizeof out, &st));
    if (st != 0 || !strstr(out, "board exit 0")) fail_msg("feed or board failed (%d):\n%s", st, out);
    char text[16384];
    if (!test_slurp(stats, text, sizeof text)) fail_msg("no --stats file:\n%s", out);
    print_message("frames_received=%g frames_shown=%g frames_rejected=%g\n", test_kv(text, "frames_received"),
                  test_kv(text, "frames_shown"), test_kv(text, "frames_rejected"));
    assert_true(test_kv(text, "frames_received") >= 16);
    assert_true(test_kv(text, "frames_rejected") == 0);
    assert_true(test_kv(text, "frames_shown") >= 2);
    seq_close(&m);
}

static void test_feed_refuses_bad_sequence(void **state)
{
    (void)state;
    char cmd[3000], out[8192];
    const char *d =
        manifest("feedbad", HEAD COLS "0,0,1,0,0,0,0,1.6,0,c.png,d.pfm\n1,0.1,1,0,0,0,0,inf,0,c.png,d.pfm\n");
    snprintf(cmd, sizeof cmd, "%s/hmdwarp-feed --sequence %s --file %s/never.bin", build, d, dir);
    assert_int_equal(run(cmd, out, sizeof out), 2);
    assert_non_null(strstr(out, "manifest.txt:8: field 'y': 'inf' is not a finite number"));
    snprintf(cmd, sizeof cmd, "%s/hmdwarp-feed --sequence %s --sequence-rate fast --file %s/never.bin", build, d, dir);
    assert_int_equal(run(cmd, out, sizeof out), 2);
    assert_non_null(strstr(out, "--sequence-rate fast: own or board"));
}

int main(int argc, char **argv)
{
    (void)argc;
    if (!test_build_dirs(argv[0], build, sizeof build, dir, sizeof dir, "sequence")) return 1;
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_reader_good_manifest),
        cmocka_unit_test(test_reader_depth_encodings),
        cmocka_unit_test(test_reader_broken_manifests),
        cmocka_unit_test(test_reader_wrong_size_file),
        cmocka_unit_test(test_objects_file),
        cmocka_unit_test(test_feed_plays_write_inputs),
        cmocka_unit_test(test_feed_plays_simulator_sequence),
        cmocka_unit_test(test_feed_plays_layers),
        cmocka_unit_test(test_feed_refuses_bad_sequence),
        cmocka_unit_test(test_feed_plays_to_board),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

/* SPDX-License-Identifier: MIT */
/* Fuzzes hmdwarp-lens's file readers (tools/hmdwarp-lens/lens_read.c): byte 0 picks a Monado/SteamVR config JSON
 * (json-c), an OpenCV calibration YAML (libyaml) or a fit correspondence CSV, the rest is the file. Whatever is
 * accepted holds what lens_read.h promises (finite numbers, positive or non-zero focal lengths, counts within the
 * bound); whatever is refused says why. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "tests/fuzz/fuzz.h"
#include "tools/hmdwarp-lens/lens_read.h"

/* The test board's eye viewport (tests/unit/test_lens_tool.c): OpenCV calibrations are scaled to it. */
#define FUZZ_LENS_VW 1080
#define FUZZ_LENS_VH 1200

static bool finite_all(const double *v, int n)
{
    for (int i = 0; i < n; i++)
        if (!isfinite(v[i])) return false;
    return true;
}

static void check_vive(const warp_lens_vive_params *p, const bool missing[3])
{
    if (missing[1]) abort(); /* green is required */
    for (int c = 0; c < 3; c++) {
        if (!finite_all(p->k[c], 4) || !finite_all(p->center[c], 2)) abort();
        if (missing[c] && (memcmp(p->k[c], p->k[1], sizeof p->k[c]) || memcmp(p->center[c], p->center[1],
                                                                                sizeof p->center[c])))
            abort();
    }
    if (!isfinite(p->aspect_x_over_y) || !(p->aspect_x_over_y > 0)) abort();
    if (!finite_all(p->intrinsics, 4) || p->intrinsics[0] == 0 || p->intrinsics[2] == 0) abort();
    if (!isfinite(p->r2_cutoff) || !(p->r2_cutoff >= 0)) abort();
}

static void check_opencv(const warp_lens_opencv_params *p)
{
    const double v[9] = {p->fx, p->fy, p->cx, p->cy, p->k1, p->k2, p->p1, p->p2, p->k3};
    if (!finite_all(v, 9) || !(p->fx > 0) || !(p->fy > 0)) abort();
}

static void check_csv(warp_lensfit_point *const pts[3], const int n[3])
{
    long total = 0;
    for (int c = 0; c < 3; c++) {
        if (n[c] < 0 || (n[c] > 0) != (pts[c] != NULL)) abort();
        total += n[c];
        for (int i = 0; i < n[c]; i++) {
            const double v[4] = {pts[c][i].x, pts[c][i].y, pts[c][i].u, pts[c][i].v};
            if (!finite_all(v, 4)) abort();
        }
    }
    if (total > LENS_READ_MAX_POINTS) abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1) return 0;
    const char *path = fuzz_file(data + 1, size - 1);
    char err[1200] = "";
    int rc;
    switch (data[0] % 3) {
    case 0: {
        warp_lens_vive_params p;
        bool missing[3];
        rc = lens_read_vive(path, &p, missing, err, sizeof err);
        if (!rc) check_vive(&p, missing);
        break;
    }
    case 1: {
        warp_lens_opencv_params p;
        bool scaled;
        rc = lens_read_opencv(path, FUZZ_LENS_VW, FUZZ_LENS_VH, &p, &scaled, err, sizeof err);
        if (!rc) check_opencv(&p);
        break;
    }
    default: {
        warp_lensfit_point *pts[3] = {NULL, NULL, NULL};
        int n[3] = {0, 0, 0};
        rc = lens_read_csv(path, pts, n, err, sizeof err);
        if (!rc) check_csv(pts, n);
        for (int c = 0; c < 3; c++) free(pts[c]);
        break;
    }
    }
    /* refused: the tool's exit status, with a message */
    if (rc && ((rc != 1 && rc != 2) || !err[0] || !memchr(err, 0, sizeof err))) abort();
    return 0;
}

static void seed_file(const char *name, int format, const char *text)
{
    fuzz_seed_tagged(name, (uint8_t)format, text, strlen(text));
}

void fuzz_write_seeds(void)
{
    /* tests/unit/test_lens_tool.c's examples: a Vive's config (docs/lens.md), an OpenCV calibration, a fit CSV,
     * and the malformed ones it refuses */
    seed_file("vive", 0,
              "{\"device\": {\"physical_aspect_x_over_y\": 0.9},\n"
              " \"tracking_to_eye_transform\": [{\n"
              "  \"distortion\": {\"center_x\": 0.0894, \"center_y\": -0.009, \"coeffs\": [-0.188, -0.221, -0.254]},\n"
              "  \"distortion_red\": {\"center_x\": 0.0890, \"center_y\": -0.009, \"coeffs\": [-0.022, -0.049, "
              "-0.079]},\n"
              "  \"distortion_blue\": {\"center_x\": 0.0898, \"center_y\": -0.009, \"coeffs\": [-0.073, -0.023, "
              "0.025, 0.001]},\n"
              "  \"grow_for_undistort\": 0.6, \"undistort_r2_cutoff\": 1.116,\n"
              "  \"intrinsics\": [[0.92, 0.0, -0.06], [0.0, 1.02, 0.01], [0.0, 0.0, -1.0]]\n"
              " }, {}]}\n");
    seed_file("vive-green", 0,
              "{\"tracking_to_eye_transform\": [{\"distortion\": {\"center_x\": 0, \"center_y\": 0, "
              "\"coeffs\": [0, 0, 0]}, \"intrinsics\": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}]}");
    seed_file("vive-trunc", 0, "{\"tracking_to_eye_transform\": [{\"distortion\": {\"coeffs\": [0.1, ");
    seed_file("opencv", 1,
              "%YAML:1.0\n---\nimage_width: 540\nimage_height: 600\n"
              "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
              "   data: [ 350., 0., 272.5, 0., 345., 299., 0., 0., 1. ]\n"
              "distortion_coefficients: !!opencv-matrix\n   rows: 5\n   cols: 1\n   dt: d\n"
              "   data: [ -0.21, 0.045, 0.0012, -0.0008, -0.004 ]\n");
    seed_file("opencv-rational", 1,
              "camera_matrix:\n  data: [700, 0, 540, 0, 700, 600, 0, 0, 1]\n"
              "distortion_coefficients:\n  data: [0, 0, 0, 0, 0, 0.5, 0, 0]\n");
    /* numbers near the ends of double's range, for the mutator to push past them (crash-opencv-scale-inf) */
    seed_file("opencv-extreme", 1,
              "image_width: 1e-300\nimage_height: 4.9e-324\n"
              "camera_matrix:\n  data: [1e300, 0, -1.7e308, 0, 2.2e-308, 1e308, 0, 0, 1]\n"
              "distortion_coefficients:\n  data: [1e308, -1e308, 0, 0]\n");
    seed_file("vive-extreme", 0,
              "{\"device\": {\"physical_aspect_x_over_y\": 4.9e-324}, \"tracking_to_eye_transform\": [{"
              "\"distortion\": {\"center_x\": 1.7e308, \"center_y\": -1e308, \"coeffs\": [1e308, -9223372036854775808, "
              "18446744073709551615, 1e-320]}, \"intrinsics\": [[1e-320, 0, 0], [0, -1e308, 0], [0, 0, 1]], "
              "\"undistort_r2_cutoff\": 0}]}");
    seed_file("opencv-bad", 1, "%YAML:1.0\ncamera_matrix: !!opencv-matrix\n  data: [1, 2\n  rows: 3\n");
    seed_file("csv", 2,
              "channel,panel_x,panel_y,u,v\n# a comment\n"
              "red,0.5,0.5,-1.0371,1.1523\ngreen,0.5,0.5,-1.0412,1.1569\nblue,0.5,0.5,-1.0455,1.1617\n"
              "r,540.5,600.5,0,0\ng,540.5,600.5,0,0\nb,540.5,600.5,0,0\n\n"
              "0 ,60.5, 60.5 ,-0.81,0.89\r\n1,60.5,60.5,-0.82,0.9\n2,60.5,60.5,-0.83,0.91\n");
    seed_file("csv-extreme", 2, "green,1e308,-1.7e308,4.9e-324,1e-320\nred            junk,1,2,0.1,0.2\n");
    seed_file("csv-bad", 2, "channel,panel_x,panel_y,u,v\nred,1,2,0.1,0.2\ngreen,1,2,zero,0.2\n");
}

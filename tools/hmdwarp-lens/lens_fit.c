/* SPDX-License-Identifier: MIT */
/* hmdwarp-lens fit: measured correspondences (panel pixel -> view tangent, per colour) to a [lens] section, each
 * channel fitted by least squares (warp_lensfit), with the residual in panel pixels. */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "tools/hmdwarp-lens/lens_cli.h"
#include "tools/hmdwarp-lens/lens_read.h"
#include "warp/warp_lensfit.h"

static void usage(FILE *f)
{
    fprintf(f, "Usage: hmdwarp-lens fit CORR.csv [--model poly|panotools] [--fit-center] [--config FILE] [--out FILE]\n"
               "Fits the lens model per colour channel to measured correspondences and writes a [lens] section.\n"
               "CORR.csv rows: channel,panel_x,panel_y,u,v\n"
               "  channel          red, green or blue (or r, g, b, 0, 1, 2)\n"
               "  panel_x,panel_y  the pixel in the left eye's half of the panel (pixel centres at +0.5)\n"
               "  u,v              the tangent of the direction it is seen at (right and up), e.g. from a camera\n"
               "                   at the eye photographing a pattern through the lens\n"
               "  A header line, blank lines and lines starting with # are skipped.\n"
               "The lens centre and scale are [lens] center and scale of --config (default board/sim/board.ini);\n"
               "--fit-center fits the centre too, starting there (the scale only normalises: any value near the\n"
               "viewport's half-width fits the same lens).\n"
               "Prints each channel's RMS and largest residual in panel pixels (also as comments in the section).\n");
}

int lens_fit_main(int argc, char **argv)
{
    const char *config = NULL, *out = NULL, *model_name = "poly";
    static const struct option lo[] = {{"config", 1, 0, 'c'}, {"out", 1, 0, 'o'},        {"model", 1, 0, 'm'},
                                       {"help", 0, 0, 'h'},   {"fit-center", 0, 0, 'C'}, {0, 0, 0, 0}};
    bool fit_center = false;
    int o;
    optind = 1;
    while ((o = getopt_long(argc, argv, "h", lo, NULL)) != -1) {
        switch (o) {
        case 'c': config = optarg; break;
        case 'o': out = optarg; break;
        case 'm': model_name = optarg; break;
        case 'C': fit_center = true; break;
        case 'h': usage(stdout); return 0;
        default: usage(stderr); return 2;
        }
    }
    if (optind != argc - 1) return usage(stderr), 2;
    warp_lens_model model = strcmp(model_name, "poly") == 0        ? WARP_LENS_POLY
                            : strcmp(model_name, "panotools") == 0 ? WARP_LENS_PANOTOOLS
                                                                   : WARP_LENS_MODELS;
    if (model == WARP_LENS_MODELS) {
        fprintf(stderr, "hmdwarp-lens fit: --model %s: poly or panotools (the models linear in their "
                        "coefficients)\n",
                model_name);
        return 2;
    }
    rt_config c;
    int rc = lens_load_config(&c, config);
    if (rc) return rc;
    warp_lensfit_point *pts[3] = {NULL, NULL, NULL};
    int n[3] = {0, 0, 0};
    const char *csv = argv[optind];
    char csv_err[1200];
    rc = lens_read_csv(csv, pts, n, csv_err, sizeof csv_err);
    if (rc) fprintf(stderr, "hmdwarp-lens fit: %s\n", csv_err);
    const char *const key[3] = {"red", "green", "blue"};
    warp_lensfit_result r[3];
    for (int ch = 0; !rc && ch < 3; ch++)
        if (!n[ch]) {
            fprintf(stderr, "hmdwarp-lens fit: %s: no rows for %s\n", csv, key[ch]);
            rc = 2;
        }
    double cx = c.lens_center[0], cy = c.lens_center[1];
    if (!rc && fit_center) {
        char err[200];
        const warp_lensfit_point *const cp[3] = {pts[0], pts[1], pts[2]};
        if (!warp_lensfit_center(model, cp, n, &cx, &cy, c.lens_scale, r, err, sizeof err)) {
            fprintf(stderr, "hmdwarp-lens fit: %s: %s\n", csv, err);
            rc = 2;
        }
    }
    for (int ch = 0; !rc && !fit_center && ch < 3; ch++) {
        char err[200];
        if (!warp_lensfit_radial(model, pts[ch], n[ch], c.lens_center[0], c.lens_center[1], c.lens_scale,
                                        &r[ch], err, sizeof err)) {
            fprintf(stderr, "hmdwarp-lens fit: %s: %s channel: %s\n", csv, key[ch], err);
            rc = 2;
        }
    }
    for (int ch = 0; ch < 3; ch++) free(pts[ch]);
    if (rc) return rc;
    lens_section s = {.n = 0};
    lens_section_add(&s, "; fitted by hmdwarp-lens fit from %s (%s model, %s)", csv, model_name,
                     fit_center ? "centre fitted, scale held" : "centre and scale held");
    for (int ch = 0; ch < 3; ch++) {
        char msg[200];
        snprintf(msg, sizeof msg, "%s: %d points, residual RMS %.3f px, max %.3f px%s", key[ch], r[ch].n,
                 r[ch].rms_px, r[ch].max_px, r[ch].unmapped ? " (some beyond the fitted lens's fold)" : "");
        lens_section_add(&s, "; %s", msg);
        fprintf(out ? stdout : stderr, "%s\n", msg);
    }
    lens_section_add(&s, "model = %s", model_name);
    for (int ch = 0; ch < 3; ch++)
        lens_section_add(&s, "%s%s = %.10g %.10g %.10g %.10g", model == WARP_LENS_POLY ? "k_" : "pano_", key[ch],
                         r[ch].k[0], r[ch].k[1], r[ch].k[2], r[ch].k[3]);
    if (model == WARP_LENS_PANOTOOLS) {
        lens_section_add(&s, "aberration = 1 1 1");
        lens_section_add(&s, "pano_tan_scale = 1");
    }
    lens_section_add(&s, "scale = %.10g", c.lens_scale);
    lens_section_add(&s, "center = %.10g %.10g", cx, cy);
    return lens_section_finish(&s, &c, out);
}

/* SPDX-License-Identifier: MIT */
/* hmdwarp-lens import: published lens parameters (OpenHMD's Panotools constants, a Monado/SteamVR config JSON,
 * a Cardboard viewer profile, an OpenCV calibration YAML) to a [lens] section in board.ini syntax, units converted. */
#include <getopt.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "tools/hmdwarp-lens/lens_cli.h"
#include "tools/hmdwarp-lens/lens_read.h"
#include "warp/warp_lens_models.h"

static void usage(FILE *f)
{
    fprintf(f,
            "Usage: hmdwarp-lens import SOURCE [options]\n"
            "Writes a [lens] section (board.ini syntax) from published lens parameters, for the panel of --config.\n"
            "SOURCE is one of:\n"
            "  --openhmd A,B,C,D       OpenHMD universal_distortion_k (Panotools a b c d); with --screen W,H\n"
            "                          (whole panel, metres), --lens-sep M, --eye-to-screen M, optionally\n"
            "                          --lens-vpos M (lens centre above the bottom edge; default H/2) and\n"
            "                          --aberration R,G,B (universal_aberration_k; default 1,1,1)\n"
            "  --vive FILE.json        Monado/SteamVR HMD config: tracking_to_eye_transform[0] (left eye; the\n"
            "                          right eye is its mirror image), device.physical_aspect_x_over_y\n"
            "  --cardboard K1,K2       Cardboard viewer profile distortion_coefficients; with --screen W,H,\n"
            "                          --screen-to-lens M, --inter-lens M, --tray-to-lens M and\n"
            "                          --alignment bottom|center|top (default bottom)\n"
            "  --opencv FILE.yaml      OpenCV calibration: camera_matrix and distortion_coefficients (k1 k2 p1 p2\n"
            "                          k3), scaled from image_width x image_height to the eye's viewport\n"
            "Options:\n"
            "  --config FILE           board.ini with the panel's display.width and height (default\n"
            "                          board/sim/board.ini)\n"
            "  --out FILE              write the section there (default: stdout)\n"
            "The section is checked as hmdwarpd would (a lens that folds over the viewport is refused).\n");
}

static int fail(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static int fail(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fputs("hmdwarp-lens import: ", stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    return 2;
}

/* "a,b,c" with exactly n finite numbers. */
static bool parse_list(const char *s, double *v, int n)
{
    const char *p = s;
    for (int i = 0; i < n; i++) {
        char *end;
        v[i] = strtod(p, &end);
        if (end == p || !isfinite(v[i])) return false;
        p = end;
        while (*p == ' ') p++;
        if (i < n - 1) {
            if (*p != ',') return false;
            p++;
        }
    }
    return *p == 0;
}

/* ---- Monado / SteamVR JSON, OpenCV YAML (read by lens_read.c) ---- */

static int import_vive(const char *path, lens_section *s)
{
    warp_lens_vive_params p;
    bool missing[3];
    char err[1200];
    int rc = lens_read_vive(path, &p, missing, err, sizeof err);
    if (rc) return fail("%s", err);
    const char *const names[3] = {"distortion_red", "distortion", "distortion_blue"};
    for (int c = 0; c < 3; c++)
        if (missing[c])
            lens_section_add(s, "; %s missing: the green channel's model (no chromatic aberration)", names[c]);
    lens_section_add(s, "; from %s (Monado's u_vive model; left eye, the right one mirrored)", path);
    lens_section_add(s, "model = vive");
    const char *const key[3] = {"red", "green", "blue"};
    for (int c = 0; c < 3; c++)
        lens_section_add(s, "vive_%s = %.17g %.17g %.17g %.17g", key[c], p.k[c][0], p.k[c][1], p.k[c][2], p.k[c][3]);
    for (int c = 0; c < 3; c++)
        lens_section_add(s, "vive_center_%s = %.17g %.17g", key[c], p.center[c][0], p.center[c][1]);
    lens_section_add(s, "vive_aspect = %.17g", p.aspect_x_over_y);
    lens_section_add(s, "vive_intrinsics = %.17g %.17g %.17g %.17g", p.intrinsics[0], p.intrinsics[1],
                     p.intrinsics[2], p.intrinsics[3]);
    lens_section_add(s, "vive_r2_cutoff = %.17g", p.r2_cutoff);
    return 0;
}

static int import_opencv(const char *path, const rt_config *cfg, lens_section *s)
{
    warp_lens_opencv_params p;
    bool scaled;
    char err[1200];
    int rc = lens_read_opencv(path, cfg->panel_w / 2.0, cfg->panel_h, &p, &scaled, err, sizeof err);
    if (rc) return fail("%s", err);
    lens_section_add(s, "; from %s (OpenCV's camera model%s)", path,
                     scaled ? ", camera matrix scaled from the calibration image to the viewport" : "");
    lens_section_add(s, "model = opencv");
    lens_section_add(s, "opencv_camera = %.17g %.17g %.17g %.17g", p.fx, p.fy, p.cx, p.cy);
    lens_section_add(s, "opencv_dist = %.17g %.17g %.17g %.17g %.17g", p.k1, p.k2, p.p1, p.p2, p.k3);
    return 0;
}

int lens_import_main(int argc, char **argv)
{
    const char *config = NULL, *out = NULL, *vive = NULL, *opencv = NULL, *openhmd = NULL, *cardboard = NULL;
    const char *aberr = "1,1,1", *screen = NULL, *alignment = "bottom";
    double lens_sep = NAN, lens_vpos = NAN, eye_to_screen = NAN, s2l = NAN, inter = NAN, tray = NAN;
    static const struct option lo[] = {
        {"config", 1, 0, 'c'},        {"out", 1, 0, 'o'},          {"vive", 1, 0, 'v'},
        {"opencv", 1, 0, 'O'},        {"openhmd", 1, 0, 'H'},      {"cardboard", 1, 0, 'C'},
        {"aberration", 1, 0, 'a'},    {"screen", 1, 0, 's'},       {"lens-sep", 1, 0, 'l'},
        {"lens-vpos", 1, 0, 'p'},     {"eye-to-screen", 1, 0, 'e'}, {"screen-to-lens", 1, 0, 'S'},
        {"inter-lens", 1, 0, 'i'},    {"tray-to-lens", 1, 0, 't'}, {"alignment", 1, 0, 'A'},
        {"help", 0, 0, 'h'},          {0, 0, 0, 0}};
    int o;
    optind = 1;
    while ((o = getopt_long(argc, argv, "h", lo, NULL)) != -1) {
        double *num = NULL;
        switch (o) {
        case 'c': config = optarg; break;
        case 'o': out = optarg; break;
        case 'v': vive = optarg; break;
        case 'O': opencv = optarg; break;
        case 'H': openhmd = optarg; break;
        case 'C': cardboard = optarg; break;
        case 'a': aberr = optarg; break;
        case 's': screen = optarg; break;
        case 'A': alignment = optarg; break;
        case 'l': num = &lens_sep; break;
        case 'p': num = &lens_vpos; break;
        case 'e': num = &eye_to_screen; break;
        case 'S': num = &s2l; break;
        case 'i': num = &inter; break;
        case 't': num = &tray; break;
        case 'h': usage(stdout); return 0;
        default: usage(stderr); return 2;
        }
        if (num && (!parse_list(optarg, num, 1) || !(*num > 0))) {
            const char *name = "?";
            for (const struct option *q = lo; q->name; q++)
                if (q->val == o) name = q->name;
            return fail("--%s %s: expected a positive distance in metres", name, optarg);
        }
    }
    if (optind < argc) return fail("%s: unexpected argument (see --help)", argv[optind]);
    int sources = !!vive + !!opencv + !!openhmd + !!cardboard;
    if (sources != 1) return fail("give exactly one of --openhmd, --vive, --cardboard, --opencv (see --help)");
    rt_config c;
    int rc = lens_load_config(&c, config);
    if (rc) return rc;
    lens_section s = {.n = 0};
    double scr[2] = {NAN, NAN};
    if ((openhmd || cardboard) && (!screen || !parse_list(screen, scr, 2) || !(scr[0] > 0) || !(scr[1] > 0)))
        return fail("--screen W,H: the whole panel's width and height in metres are needed");
    if (vive) {
        rc = import_vive(vive, &s);
    } else if (opencv) {
        rc = import_opencv(opencv, &c, &s);
    } else if (openhmd) {
        warp_lens_openhmd_device d = {.hsize = scr[0], .vsize = scr[1], .hres = c.panel_w, .vres = c.panel_h,
                                      .lens_sep = lens_sep, .lens_vpos = isnan(lens_vpos) ? scr[1] / 2 : lens_vpos,
                                      .eye_to_screen = eye_to_screen};
        if (!parse_list(openhmd, d.k, 4)) return fail("--openhmd %s: expected four numbers a,b,c,d", openhmd);
        if (!parse_list(aberr, d.aberration, 3)) return fail("--aberration %s: expected three numbers r,g,b", aberr);
        if (isnan(lens_sep) || isnan(eye_to_screen)) return fail("--openhmd needs --lens-sep and --eye-to-screen");
        warp_lens_panotools_params p;
        char err[200];
        if (!warp_lens_openhmd_params(&d, &p, err, sizeof err)) return fail("%s", err);
        lens_section_add(&s, "; from OpenHMD's universal distortion %s, aberration %s, screen %s m, lens separation "
                             "%g m, eye to screen %g m",
                         openhmd, aberr, screen, lens_sep, eye_to_screen);
        lens_section_add(&s, "model = panotools");
        const char *const key[3] = {"red", "green", "blue"};
        for (int ch = 0; ch < 3; ch++)
            lens_section_add(&s, "pano_%s = %.17g %.17g %.17g %.17g", key[ch], p.abcd[ch][0], p.abcd[ch][1],
                             p.abcd[ch][2], p.abcd[ch][3]);
        lens_section_add(&s, "aberration = %.17g %.17g %.17g", p.aberration[0], p.aberration[1], p.aberration[2]);
        lens_section_add(&s, "pano_tan_scale = %.17g", p.tan_scale);
        lens_section_add(&s, "scale = %.17g", p.scale);
        lens_section_add(&s, "center = %.17g %.17g", p.center_x, p.center_y);
    } else {
        double k[2];
        int align = strcmp(alignment, "bottom") == 0 ? 0 : strcmp(alignment, "center") == 0 ? 1
                                                        : strcmp(alignment, "top") == 0      ? 2
                                                                                             : -1;
        if (!parse_list(cardboard, k, 2)) return fail("--cardboard %s: expected two numbers k1,k2", cardboard);
        if (align < 0) return fail("--alignment %s: bottom, center or top", alignment);
        if (isnan(s2l) || isnan(inter) || isnan(tray))
            return fail("--cardboard needs --screen-to-lens, --inter-lens and --tray-to-lens (metres)");
        lens_section_add(&s, "; from a Cardboard viewer profile (Cardboard SDK's PolynomialRadialDistortion)");
        lens_section_add(&s, "model = cardboard");
        lens_section_add(&s, "cardboard_k = %.17g %.17g", k[0], k[1]);
        lens_section_add(&s, "cardboard_distances = %.17g %.17g %.17g", s2l, inter, tray);
        lens_section_add(&s, "cardboard_alignment = %s", alignment);
        lens_section_add(&s, "cardboard_screen = %.17g %.17g", scr[0], scr[1]);
    }
    if (rc) return rc;
    return lens_section_finish(&s, &c, out);
}

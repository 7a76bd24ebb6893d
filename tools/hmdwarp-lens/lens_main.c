/* SPDX-License-Identifier: MIT */
/* hmdwarp-lens: lens calibration aid. Renders a test pattern (grid, circles, a colour cross) in the eye buffers
 * and sends it through the board's distortion mesh exactly as hmdwarpd does, so the panel image shows what the
 * wearer will see through the lenses with the configured [lens] coefficients; tune them until lines are straight
 * and the red, green and blue edges coincide. */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "platform/plat_png.h"
#include "platform/plat_version.h"
#include "runtime/rt_config.h"
#include "warp/warp_fov.h"
#include "tools/hmdwarp-lens/lens_cli.h"
#include "warp/warp_lens.h"
#include "warp/warp_mesh.h"
#include "warp/warp_resample.h"

static void usage(FILE *f)
{
    fprintf(f, "Usage: hmdwarp-lens [options]\n"
               "  or:  hmdwarp-lens import SOURCE [options]\n"
               "  or:  hmdwarp-lens fit CORR.csv [options]\n"
               "Renders a calibration pattern through the configured lens distortion and chromatic aberration;\n"
               "import writes a [lens] section from published lens parameters (OpenHMD, Monado/SteamVR JSON,\n"
               "Cardboard, OpenCV YAML), fit one from measured correspondences (hmdwarp-lens import --help,\n"
               "hmdwarp-lens fit --help; docs/lens.md).\n"
               "  --config FILE      board.ini (default board/sim/board.ini)\n"
               "  --set SEC.KEY=VAL  override a key, e.g. --set lens.k_green=\"1 0.25 0.2 0\" (repeatable)\n"
               "  --out FILE.png     the panel image (default lens-pattern.png)\n"
               "  --source FILE.png  also write the undistorted pattern of the left eye buffer\n"
               "  --pattern P        grid (default), checker or dots\n"
               "  --spacing PX       pattern pitch in eye-buffer pixels (default 64)\n"
               "  -h, --help         this text\n"
               "  --version          print the version and exit\n"
               "Show the image on the panel (e.g. as hmdwarpd's output with [warp] method = none and a host frame of\n"
               "the pattern, or any image viewer on the display) and look through the lenses: barrel or pincushion\n"
               "curvature of the lines means k1/k2 are off, coloured fringes at the edge mean the per-channel k0\n"
               "differ from the lens's lateral aberration, an off-centre pattern means [lens] center is off.\n");
}

static warp_rgba8 pattern_at(const char *kind, int x, int y, int w, int h, int sp)
{
    const warp_rgba8 black = {0, 0, 0, 255}, white = {255, 255, 255, 255};
    int cx = w / 2, cy = h / 2;
    /* a red/green/blue cross through the centre: lateral CA shows as colour separation along it */
    if (abs(x - cx) <= 1) return (warp_rgba8){255, 0, 0, 255};
    if (abs(y - cy) <= 1) return (warp_rgba8){0, 0, 255, 255};
    if (abs(x - cx) == 3 || abs(y - cy) == 3) return (warp_rgba8){0, 255, 0, 255};
    double r = hypot(x - cx + 0.5, y - cy + 0.5);
    if (fmod(r, 2.0 * sp) < 1.5) return (warp_rgba8){255, 255, 0, 255}; /* circles every two pitches */
    int gx = ((x - cx) % sp + sp) % sp, gy = ((y - cy) % sp + sp) % sp;
    if (strcmp(kind, "checker") == 0) return ((x - cx + 100 * sp) / sp + (y - cy + 100 * sp) / sp) % 2 ? white : black;
    if (strcmp(kind, "dots") == 0) return hypot(gx - sp / 2.0, gy - sp / 2.0) < sp / 8.0 ? white : black;
    return gx < 2 || gy < 2 ? white : black;
}

int main(int argc, char **argv)
{
    if (argc > 1 && strcmp(argv[1], "import") == 0) return lens_import_main(argc - 1, argv + 1);
    if (argc > 1 && strcmp(argv[1], "fit") == 0) return lens_fit_main(argc - 1, argv + 1);
    const char *config = "board/sim/board.ini", *out = "lens-pattern.png", *source = NULL, *kind = "grid";
    int spacing = 64;
    rt_config c;
    rt_config_defaults(&c);
    rt_config_errors err = {0};
    for (int i = 1; i < argc; i++)
        if (strcmp(argv[i], "--config") == 0 && i + 1 < argc) config = argv[++i];
    FILE *probe = fopen(config, "r");
    if (probe) {
        fclose(probe);
        rt_config_load(&c, config, &err);
    } else if (strcmp(config, "board/sim/board.ini") != 0) {
        fprintf(stderr, "hmdwarp-lens: %s: cannot open\n", config);
        return 2;
    }
    static const struct option lo[] = {{"config", 1, 0, 'c'}, {"set", 1, 0, 's'},     {"out", 1, 0, 'o'},
                                       {"source", 1, 0, 'S'}, {"pattern", 1, 0, 'p'}, {"spacing", 1, 0, 'g'},
                                       {"help", 0, 0, 'h'},   {"version", 0, 0, 'V'}, {0, 0, 0, 0}};
    int o;
    while ((o = getopt_long(argc, argv, "h", lo, NULL)) != -1) {
        switch (o) {
        case 'c': break;
        case 's': rt_config_set(&c, optarg, &err); break;
        case 'o': out = optarg; break;
        case 'S': source = optarg; break;
        case 'p': kind = optarg; break;
        case 'g': spacing = atoi(optarg); break;
        case 'h': usage(stdout); return 0;
        case 'V': printf("hmdwarp-lens %s\n", plat_version()); return 0;
        default: usage(stderr); return 2;
        }
    }
    if (strcmp(kind, "grid") && strcmp(kind, "checker") && strcmp(kind, "dots")) {
        fprintf(stderr, "hmdwarp-lens: --pattern %s: grid, checker or dots\n", kind);
        return 2;
    }
    if (spacing < 4) spacing = 4;
    if (!err.count) rt_config_validate(&c, &err);
    if (err.count) {
        for (int i = 0; i < err.count && i < 16; i++) fprintf(stderr, "hmdwarp-lens: %s\n", err.msg[i]);
        return 2;
    }
    warp_image_rgba8 panel;
    if (!warp_image_rgba8_alloc(&panel, c.panel_w, c.panel_h)) return fprintf(stderr, "out of memory\n"), 1;
    int vw = c.panel_w / 2;
    for (int e = 0; e < 2; e++) {
        warp_camera cam = rt_config_eye_camera(&c, e);
        warp_lens lens = rt_config_lens(&c, e);
        warp_image_rgba8 src;
        warp_planar3 planar;
        warp_mesh mesh;
        if (!warp_image_rgba8_alloc(&src, c.eye_w, c.eye_h) || !warp_planar3_alloc(&planar, c.eye_w, c.eye_h) ||
            !warp_mesh_alloc(&mesh, c.mesh_n, &lens, e * vw, 0, vw, c.panel_h))
            return fprintf(stderr, "out of memory\n"), 1;
        for (int y = 0; y < c.eye_h; y++)
            for (int x = 0; x < c.eye_w; x++) WARP_AT(&src, x, y) = pattern_at(kind, x, y, c.eye_w, c.eye_h, spacing);
        if (e == 0 && source) {
            char m[300];
            if (!plat_png_write(source, &src, true, m, sizeof m)) return fprintf(stderr, "hmdwarp-lens: %s\n", m), 1;
        }
        /* the hidden-area mask as hmdwarpd applies it: black outside the lens's visible disc */
        int32_t *span = malloc(sizeof *span * 2 * (size_t)c.panel_h);
        if (!span) return fprintf(stderr, "out of memory\n"), 1;
        const double vr = rt_config_visible_radius(&c, e);
        const int64_t visible = vr > 0 ? warp_fov_spans(&lens, vr, vw, c.panel_h, span) : 0;
        if (vr > 0) mesh.visible = span;
        warp_planar3_from_rgba_rows(&planar, &src, 0, c.eye_h);
        warp_mesh_update(&mesh, &cam, warp_quat_identity());
        warp_mesh_resample(&mesh, &planar, &panel, 0, 0, vw, c.panel_h);
        /* what the calibration tells: the lens's reach and its colour spread at the viewport's corner */
        double u[3], v[3];
        for (int ch = 0; ch < 3; ch++) warp_lens_distort(&lens, ch, 0.5, 0.5, &u[ch], &v[ch]);
        double spread = hypot(u[0] - u[2], v[0] - v[2]) * warp_camera_pixels_per_tan_x(&cam);
        printf("%s eye: corner sees tangent (%.3f, %.3f); red-blue separation there %.1f eye-buffer px; "
               "monotonic to r = %.3f (green)\n",
               e ? "right" : "left", u[1], v[1], spread, warp_lens_monotonic_radius(&lens, 1));
        /* what the eye buffer covers and what of the visible disc samples outside it (0 with fov = auto) */
        const double d = 180 / WARP_PI;
        printf("  visible disc radius %.3f: %.1f %% of the eye's panel pixels; eye camera %.1f %.1f %.1f %.1f deg "
               "(left right up down, %s); visible pixels sampling outside it: %lld\n",
               vr, 100.0 * (double)visible / ((double)vw * c.panel_h), atan(cam.tan_left) * d, atan(cam.tan_right) * d,
               atan(cam.tan_up) * d, atan(cam.tan_down) * d, rt_config_fov_auto(&c) ? "fov = auto" : "[eye] fov",
               (long long)warp_fov_outside_exact(&mesh, cam.width, cam.height));
        free(span);
        warp_mesh_free(&mesh);
        warp_planar3_free(&planar);
        warp_image_free(&src);
    }
    char m[300];
    if (!plat_png_write(out, &panel, true, m, sizeof m)) return fprintf(stderr, "hmdwarp-lens: %s\n", m), 1;
    printf("wrote %s (%dx%d)\n", out, c.panel_w, c.panel_h);
    warp_image_free(&panel);
    return 0;
}

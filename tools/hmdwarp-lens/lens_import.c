/* SPDX-License-Identifier: MIT */
/* hmdwarp-lens import: published lens parameters (OpenHMD's Panotools constants, a Monado/SteamVR config JSON,
 * a Cardboard viewer profile, an OpenCV calibration YAML) to a [lens] section in board.ini syntax, units converted. */
#include <getopt.h>
#include <json-c/json.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <yaml.h>

#include "tools/hmdwarp-lens/lens_cli.h"
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

/* A file read whole (at most 16 MiB: configs and calibrations are a few kB). */
static char *slurp(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    size_t cap = 1 << 16, n = 0;
    char *b = malloc(cap + 1);
    while (b) {
        size_t r = fread(b + n, 1, cap - n, f);
        n += r;
        if (n < cap) break;
        if (cap >= (16u << 20)) {
            free(b);
            b = NULL;
            break;
        }
        char *nb = realloc(b, cap * 2 + 1);
        if (!nb) {
            free(b);
            b = NULL;
            break;
        }
        b = nb;
        cap *= 2;
    }
    fclose(f);
    if (b) b[n] = 0, *len = n;
    return b;
}

/* ---- Monado / SteamVR JSON ---- */

static json_object *jget(json_object *o, const char *key)
{
    json_object *v = NULL;
    return o && json_object_is_type(o, json_type_object) && json_object_object_get_ex(o, key, &v) ? v : NULL;
}

static bool jnum(json_object *o, double *v)
{
    if (!o || !(json_object_is_type(o, json_type_double) || json_object_is_type(o, json_type_int))) return false;
    *v = json_object_get_double(o);
    return isfinite(*v);
}

static int import_vive(const char *path, lens_section *s)
{
    size_t len;
    char *text = slurp(path, &len);
    if (!text) return fail("%s: cannot read", path);
    json_tokener *tok = json_tokener_new();
    if (!tok) {
        free(text);
        return fail("%s: out of memory", path);
    }
    json_object *root = json_tokener_parse_ex(tok, text, (int)len + 1);
    enum json_tokener_error je = json_tokener_get_error(tok);
    size_t at = json_tokener_get_parse_end(tok);
    json_tokener_free(tok);
    free(text);
    if (!root || je != json_tokener_success) {
        if (root) json_object_put(root);
        return fail("%s: not JSON: %s near byte %zu", path, json_tokener_error_desc(je), at);
    }
    int rc = 0;
    warp_lens_vive_params p = {.aspect_x_over_y = 0.9};
    const char *const names[3] = {"distortion_red", "distortion", "distortion_blue"};
    json_object *eyes = jget(root, "tracking_to_eye_transform"), *eye = NULL;
    if (!eyes || !json_object_is_type(eyes, json_type_array) || json_object_array_length(eyes) < 1) {
        rc = fail("%s: tracking_to_eye_transform: missing or not an array of eyes (is this an HMD's config JSON?)",
                  path);
        goto out;
    }
    eye = json_object_array_get_idx(eyes, 0);
    json_object *aspect = jget(jget(root, "device"), "physical_aspect_x_over_y");
    if (aspect && (!jnum(aspect, &p.aspect_x_over_y) || !(p.aspect_x_over_y > 0))) {
        rc = fail("%s: device.physical_aspect_x_over_y: expected a positive number", path);
        goto out;
    }
    bool have[3] = {false, false, false};
    for (int c = 0; c < 3; c++) {
        json_object *d = jget(eye, names[c]);
        if (!d) continue;
        json_object *co = jget(d, "coeffs");
        size_t n = co && json_object_is_type(co, json_type_array) ? json_object_array_length(co) : 0;
        if (n < 3 || n > 4) {
            rc = fail("%s: tracking_to_eye_transform[0].%s.coeffs: expected an array of 3 or 4 numbers", path,
                      names[c]);
            goto out;
        }
        for (size_t i = 0; i < n; i++)
            if (!jnum(json_object_array_get_idx(co, i), &p.k[c][i])) {
                rc = fail("%s: tracking_to_eye_transform[0].%s.coeffs[%zu]: not a number", path, names[c], i);
                goto out;
            }
        if (!jnum(jget(d, "center_x"), &p.center[c][0]) || !jnum(jget(d, "center_y"), &p.center[c][1])) {
            rc = fail("%s: tracking_to_eye_transform[0].%s: center_x and center_y must be numbers", path, names[c]);
            goto out;
        }
        have[c] = true;
    }
    if (!have[1]) {
        rc = fail("%s: tracking_to_eye_transform[0].distortion: missing (the green channel's model)", path);
        goto out;
    }
    for (int c = 0; c < 3; c += 2)
        if (!have[c]) {
            memcpy(p.k[c], p.k[1], sizeof p.k[c]);
            memcpy(p.center[c], p.center[1], sizeof p.center[c]);
            lens_section_add(s, "; %s missing: the green channel's model (no chromatic aberration)", names[c]);
        }
    json_object *in = jget(eye, "intrinsics");
    double m[3][3];
    bool ok = in && json_object_is_type(in, json_type_array) && json_object_array_length(in) == 3;
    for (int r = 0; ok && r < 3; r++) {
        json_object *row = json_object_array_get_idx(in, r);
        ok = row && json_object_is_type(row, json_type_array) && json_object_array_length(row) == 3;
        for (int c = 0; ok && c < 3; c++) ok = jnum(json_object_array_get_idx(row, c), &m[r][c]);
    }
    if (!ok || m[0][0] == 0 || m[1][1] == 0) {
        rc = fail("%s: tracking_to_eye_transform[0].intrinsics: expected a 3 x 3 array of numbers with non-zero "
                  "fx, fy",
                  path);
        goto out;
    }
    json_object *cut = jget(eye, "undistort_r2_cutoff");
    if (cut && (!jnum(cut, &p.r2_cutoff) || p.r2_cutoff < 0)) {
        rc = fail("%s: tracking_to_eye_transform[0].undistort_r2_cutoff: expected a number >= 0", path);
        goto out;
    }
    lens_section_add(s, "; from %s (Monado's u_vive model; left eye, the right one mirrored)", path);
    lens_section_add(s, "model = vive");
    const char *const key[3] = {"red", "green", "blue"};
    for (int c = 0; c < 3; c++)
        lens_section_add(s, "vive_%s = %.17g %.17g %.17g %.17g", key[c], p.k[c][0], p.k[c][1], p.k[c][2], p.k[c][3]);
    for (int c = 0; c < 3; c++)
        lens_section_add(s, "vive_center_%s = %.17g %.17g", key[c], p.center[c][0], p.center[c][1]);
    lens_section_add(s, "vive_aspect = %.17g", p.aspect_x_over_y);
    lens_section_add(s, "vive_intrinsics = %.17g %.17g %.17g %.17g", m[0][0], m[0][2], m[1][1], m[1][2]);
    lens_section_add(s, "vive_r2_cutoff = %.17g", p.r2_cutoff);
out:
    json_object_put(root);
    return rc;
}

/* ---- OpenCV YAML ---- */

static yaml_node_t *ymap_get(yaml_document_t *d, yaml_node_t *map, const char *key)
{
    if (!map || map->type != YAML_MAPPING_NODE) return NULL;
    for (yaml_node_pair_t *p = map->data.mapping.pairs.start; p < map->data.mapping.pairs.top; p++) {
        yaml_node_t *k = yaml_document_get_node(d, p->key);
        if (k && k->type == YAML_SCALAR_NODE && strlen(key) == k->data.scalar.length &&
            memcmp(k->data.scalar.value, key, k->data.scalar.length) == 0)
            return yaml_document_get_node(d, p->value);
    }
    return NULL;
}

static bool ynum(yaml_node_t *n, double *v)
{
    if (!n || n->type != YAML_SCALAR_NODE || n->data.scalar.length == 0 || n->data.scalar.length > 60) return false;
    char buf[64], *end;
    snprintf(buf, sizeof buf, "%.*s", (int)n->data.scalar.length, (const char *)n->data.scalar.value);
    *v = strtod(buf, &end);
    return end != buf && *end == 0 && isfinite(*v);
}

/* An opencv-matrix's data as up to max numbers; -1 (message printed) when malformed. */
static int ymatrix(yaml_document_t *d, yaml_node_t *root, const char *path, const char *name, double *v, int max)
{
    yaml_node_t *m = ymap_get(d, root, name);
    if (!m) return fail("%s: %s: missing", path, name), -1;
    yaml_node_t *data = ymap_get(d, m, "data");
    if (!data || data->type != YAML_SEQUENCE_NODE)
        return fail("%s:%zu: %s.data: expected a sequence of numbers (an opencv-matrix)", path,
                    (size_t)m->start_mark.line + 1, name),
               -1;
    int n = 0;
    for (yaml_node_item_t *it = data->data.sequence.items.start; it < data->data.sequence.items.top; it++, n++) {
        yaml_node_t *e = yaml_document_get_node(d, *it);
        double x;
        if (!ynum(e, &x))
            return fail("%s:%zu: %s.data[%d]: not a number", path, (size_t)(e ? e->start_mark.line : 0) + 1, name, n),
                   -1;
        if (n < max) v[n] = x;
    }
    return n;
}

static int import_opencv(const char *path, const rt_config *cfg, lens_section *s)
{
    size_t len;
    char *text = slurp(path, &len);
    if (!text) return fail("%s: cannot read", path);
    /* OpenCV writes "%YAML:1.0", which YAML itself does not accept: blank that directive, keeping line numbers */
    if (strncmp(text, "%YAML:", 6) == 0)
        for (char *p = text; *p && *p != '\n'; p++) *p = ' ';
    yaml_parser_t parser;
    yaml_document_t doc;
    if (!yaml_parser_initialize(&parser)) {
        free(text);
        return fail("%s: out of memory", path);
    }
    yaml_parser_set_input_string(&parser, (const unsigned char *)text, len);
    if (!yaml_parser_load(&parser, &doc)) {
        int rc = fail("%s:%zu:%zu: not YAML: %s%s%s", path, (size_t)parser.problem_mark.line + 1,
                      (size_t)parser.problem_mark.column + 1, parser.problem ? parser.problem : "parse error",
                      parser.context ? " " : "", parser.context ? parser.context : "");
        yaml_parser_delete(&parser);
        free(text);
        return rc;
    }
    yaml_parser_delete(&parser);
    free(text);
    int rc = 0;
    yaml_node_t *root = yaml_document_get_root_node(&doc);
    double k[9], dist[14] = {0};
    int nk, nd;
    if (!root || root->type != YAML_MAPPING_NODE) {
        rc = fail("%s: expected a mapping with camera_matrix and distortion_coefficients", path);
        goto out;
    }
    if ((nk = ymatrix(&doc, root, path, "camera_matrix", k, 9)) < 0 ||
        (nd = ymatrix(&doc, root, path, "distortion_coefficients", dist, 14)) < 0) {
        rc = 2;
        goto out;
    }
    if (nk != 9 || !(k[0] > 0) || !(k[4] > 0)) {
        rc = fail("%s: camera_matrix: expected 9 numbers (3 x 3) with positive fx, fy, got %d", path, nk);
        goto out;
    }
    if (nd != 4 && nd != 5 && nd != 8 && nd != 12 && nd != 14) {
        rc = fail("%s: distortion_coefficients: expected 4, 5, 8, 12 or 14 numbers, got %d", path, nd);
        goto out;
    }
    for (int i = 5; i < nd; i++)
        if (dist[i] != 0) {
            rc = fail("%s: distortion_coefficients[%d] = %g: only k1 k2 p1 p2 k3 are supported (not the rational, "
                      "thin-prism or tilt terms)",
                      path, i, dist[i]);
            goto out;
        }
    /* the calibration's image may be another size than the eye's viewport: scale the camera matrix to it */
    double vw = cfg->panel_w / 2.0, vh = cfg->panel_h, iw = 0, ih = 0, sx = 1, sy = 1;
    yaml_node_t *wn = ymap_get(&doc, root, "image_width"), *hn = ymap_get(&doc, root, "image_height");
    if (wn || hn) {
        if (!ynum(wn, &iw) || !ynum(hn, &ih) || !(iw > 0) || !(ih > 0)) {
            rc = fail("%s: image_width and image_height must both be positive numbers", path);
            goto out;
        }
        sx = vw / iw;
        sy = vh / ih;
    }
    lens_section_add(s, "; from %s (OpenCV's camera model%s)", path,
                     wn ? ", camera matrix scaled from the calibration image to the viewport" : "");
    lens_section_add(s, "model = opencv");
    lens_section_add(s, "opencv_camera = %.17g %.17g %.17g %.17g", k[0] * sx, k[4] * sy, k[2] * sx, k[5] * sy);
    lens_section_add(s, "opencv_dist = %.17g %.17g %.17g %.17g %.17g", dist[0], dist[1], dist[2], dist[3],
                     nd >= 5 ? dist[4] : 0.0);
out:
    yaml_document_delete(&doc);
    return rc;
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

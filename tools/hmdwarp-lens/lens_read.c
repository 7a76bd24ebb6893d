/* SPDX-License-Identifier: MIT */
/* hmdwarp-lens's file readers (lens_read.h): JSON through json-c, YAML through libyaml, the CSV by hand; every
 * number they return is checked finite here, so import and fit only format and convert. */
#include <errno.h>
#include <json-c/json.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <yaml.h>

#include "tools/hmdwarp-lens/lens_read.h"

static int say(char *err, size_t errlen, int rc, const char *fmt, ...) __attribute__((format(printf, 4, 5)));
static int say(char *err, size_t errlen, int rc, const char *fmt, ...)
{
    if (err && errlen) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, errlen, fmt, ap);
        va_end(ap);
    }
    return rc;
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

int lens_read_vive(const char *path, warp_lens_vive_params *p, bool missing[3], char *err, size_t errlen)
{
    size_t len;
    char *text = slurp(path, &len);
    if (!text) return say(err, errlen, 2, "%s: cannot read", path);
    json_tokener *tok = json_tokener_new();
    if (!tok) {
        free(text);
        return say(err, errlen, 2, "%s: out of memory", path);
    }
    json_object *root = json_tokener_parse_ex(tok, text, (int)len + 1);
    enum json_tokener_error je = json_tokener_get_error(tok);
    size_t at = json_tokener_get_parse_end(tok);
    json_tokener_free(tok);
    free(text);
    if (!root || je != json_tokener_success) {
        if (root) json_object_put(root);
        return say(err, errlen, 2, "%s: not JSON: %s near byte %zu", path, json_tokener_error_desc(je), at);
    }
    int rc = 0;
    *p = (warp_lens_vive_params){.aspect_x_over_y = 0.9};
    const char *const names[3] = {"distortion_red", "distortion", "distortion_blue"};
    json_object *eyes = jget(root, "tracking_to_eye_transform"), *eye = NULL;
    if (!eyes || !json_object_is_type(eyes, json_type_array) || json_object_array_length(eyes) < 1) {
        rc = say(err, errlen, 2,
                 "%s: tracking_to_eye_transform: missing or not an array of eyes (is this an HMD's config JSON?)",
                 path);
        goto out;
    }
    eye = json_object_array_get_idx(eyes, 0);
    json_object *aspect = jget(jget(root, "device"), "physical_aspect_x_over_y");
    if (aspect && (!jnum(aspect, &p->aspect_x_over_y) || !(p->aspect_x_over_y > 0))) {
        rc = say(err, errlen, 2, "%s: device.physical_aspect_x_over_y: expected a positive number", path);
        goto out;
    }
    bool have[3] = {false, false, false};
    for (int c = 0; c < 3; c++) {
        json_object *d = jget(eye, names[c]);
        if (!d) continue;
        json_object *co = jget(d, "coeffs");
        size_t n = co && json_object_is_type(co, json_type_array) ? json_object_array_length(co) : 0;
        if (n < 3 || n > 4) {
            rc = say(err, errlen, 2, "%s: tracking_to_eye_transform[0].%s.coeffs: expected an array of 3 or 4 numbers",
                     path, names[c]);
            goto out;
        }
        for (size_t i = 0; i < n; i++)
            if (!jnum(json_object_array_get_idx(co, i), &p->k[c][i])) {
                rc = say(err, errlen, 2, "%s: tracking_to_eye_transform[0].%s.coeffs[%zu]: not a number", path,
                         names[c], i);
                goto out;
            }
        if (!jnum(jget(d, "center_x"), &p->center[c][0]) || !jnum(jget(d, "center_y"), &p->center[c][1])) {
            rc = say(err, errlen, 2, "%s: tracking_to_eye_transform[0].%s: center_x and center_y must be numbers",
                     path, names[c]);
            goto out;
        }
        have[c] = true;
    }
    if (!have[1]) {
        rc = say(err, errlen, 2, "%s: tracking_to_eye_transform[0].distortion: missing (the green channel's model)",
                 path);
        goto out;
    }
    for (int c = 0; c < 3; c++) {
        missing[c] = !have[c];
        if (missing[c]) {
            memcpy(p->k[c], p->k[1], sizeof p->k[c]);
            memcpy(p->center[c], p->center[1], sizeof p->center[c]);
        }
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
        rc = say(err, errlen, 2,
                 "%s: tracking_to_eye_transform[0].intrinsics: expected a 3 x 3 array of numbers with non-zero fx, fy",
                 path);
        goto out;
    }
    p->intrinsics[0] = m[0][0];
    p->intrinsics[1] = m[0][2];
    p->intrinsics[2] = m[1][1];
    p->intrinsics[3] = m[1][2];
    json_object *cut = jget(eye, "undistort_r2_cutoff");
    if (cut && (!jnum(cut, &p->r2_cutoff) || p->r2_cutoff < 0)) {
        rc = say(err, errlen, 2, "%s: tracking_to_eye_transform[0].undistort_r2_cutoff: expected a number >= 0", path);
        goto out;
    }
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

/* A scalar as a number, written at any length (a generator may print 17 digits and more of zeros): strtod
 * needs its text NUL-terminated, which libyaml's scalar is not promised to be. */
static bool ynum(yaml_node_t *n, double *v)
{
    if (!n || n->type != YAML_SCALAR_NODE || n->data.scalar.length == 0) return false;
    char *buf = strndup((const char *)n->data.scalar.value, n->data.scalar.length), *end;
    if (!buf) return false;
    *v = strtod(buf, &end);
    const bool ok = end != buf && *end == 0 && isfinite(*v);
    free(buf);
    return ok;
}

/* An opencv-matrix's data as up to max numbers; -1 (err set) when malformed. */
static int ymatrix(yaml_document_t *d, yaml_node_t *root, const char *path, const char *name, double *v, int max,
                   char *err, size_t errlen)
{
    yaml_node_t *m = ymap_get(d, root, name);
    if (!m) return say(err, errlen, -1, "%s: %s: missing", path, name);
    yaml_node_t *data = ymap_get(d, m, "data");
    if (!data || data->type != YAML_SEQUENCE_NODE)
        return say(err, errlen, -1, "%s:%zu: %s.data: expected a sequence of numbers (an opencv-matrix)", path,
                   (size_t)m->start_mark.line + 1, name);
    int n = 0;
    for (yaml_node_item_t *it = data->data.sequence.items.start; it < data->data.sequence.items.top; it++, n++) {
        yaml_node_t *e = yaml_document_get_node(d, *it);
        double x;
        if (!ynum(e, &x))
            return say(err, errlen, -1, "%s:%zu: %s.data[%d]: not a number", path,
                       (size_t)(e ? e->start_mark.line : 0) + 1, name, n);
        if (n < max) v[n] = x;
    }
    return n;
}

int lens_read_opencv(const char *path, double vw, double vh, warp_lens_opencv_params *p, bool *scaled, char *err,
                     size_t errlen)
{
    size_t len;
    char *text = slurp(path, &len);
    if (!text) return say(err, errlen, 2, "%s: cannot read", path);
    /* OpenCV writes "%YAML:1.0", which YAML itself does not accept: blank that directive, keeping line numbers */
    if (strncmp(text, "%YAML:", 6) == 0)
        for (char *q = text; *q && *q != '\n'; q++) *q = ' ';
    yaml_parser_t parser;
    yaml_document_t doc;
    if (!yaml_parser_initialize(&parser)) {
        free(text);
        return say(err, errlen, 2, "%s: out of memory", path);
    }
    yaml_parser_set_input_string(&parser, (const unsigned char *)text, len);
    if (!yaml_parser_load(&parser, &doc)) {
        int rc = say(err, errlen, 2, "%s:%zu:%zu: not YAML: %s%s%s", path, (size_t)parser.problem_mark.line + 1,
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
        rc = say(err, errlen, 2, "%s: expected a mapping with camera_matrix and distortion_coefficients", path);
        goto out;
    }
    if ((nk = ymatrix(&doc, root, path, "camera_matrix", k, 9, err, errlen)) < 0 ||
        (nd = ymatrix(&doc, root, path, "distortion_coefficients", dist, 14, err, errlen)) < 0) {
        rc = 2;
        goto out;
    }
    if (nk != 9 || !(k[0] > 0) || !(k[4] > 0)) {
        rc = say(err, errlen, 2, "%s: camera_matrix: expected 9 numbers (3 x 3) with positive fx, fy, got %d", path,
                 nk);
        goto out;
    }
    if (nd != 4 && nd != 5 && nd != 8 && nd != 12 && nd != 14) {
        rc = say(err, errlen, 2, "%s: distortion_coefficients: expected 4, 5, 8, 12 or 14 numbers, got %d", path, nd);
        goto out;
    }
    for (int i = 5; i < nd; i++)
        if (dist[i] != 0) {
            rc = say(err, errlen, 2,
                     "%s: distortion_coefficients[%d] = %g: only k1 k2 p1 p2 k3 are supported (not the rational, "
                     "thin-prism or tilt terms)",
                     path, i, dist[i]);
            goto out;
        }
    /* the calibration's image may be another size than the eye's viewport: scale the camera matrix to it */
    double iw = 0, ih = 0, sx = 1, sy = 1;
    yaml_node_t *wn = ymap_get(&doc, root, "image_width"), *hn = ymap_get(&doc, root, "image_height");
    if (wn || hn) {
        if (!ynum(wn, &iw) || !ynum(hn, &ih) || !(iw > 0) || !(ih > 0)) {
            rc = say(err, errlen, 2, "%s: image_width and image_height must both be positive numbers", path);
            goto out;
        }
        sx = vw / iw;
        sy = vh / ih;
    }
    *scaled = wn != NULL;
    *p = (warp_lens_opencv_params){.fx = k[0] * sx, .fy = k[4] * sy, .cx = k[2] * sx, .cy = k[5] * sy,
                                   .k1 = dist[0], .k2 = dist[1], .p1 = dist[2], .p2 = dist[3],
                                   .k3 = nd >= 5 ? dist[4] : 0.0};
    /* finite factors can still overflow (image_width 1e-306, or fx near DBL_MAX): say so here, naming the file,
     * rather than as an 'inf' the [lens] section's range check blames on the command line */
    if (!isfinite(p->fx) || !isfinite(p->fy) || !isfinite(p->cx) || !isfinite(p->cy)) {
        rc = say(err, errlen, 2,
                 "%s: camera_matrix scaled from image_width x image_height %g x %g to the %g x %g viewport is not "
                 "finite",
                 path, iw, ih, vw, vh);
        goto out;
    }
out:
    yaml_document_delete(&doc);
    return rc;
}

/* ---- correspondence CSV ---- */

static int channel_of(const char *s)
{
    const char *const names[3][3] = {{"red", "r", "0"}, {"green", "g", "1"}, {"blue", "b", "2"}};
    for (int c = 0; c < 3; c++)
        for (int i = 0; i < 3; i++)
            if (strcmp(s, names[c][i]) == 0) return c;
    return -1;
}

int lens_read_csv(const char *path, warp_lensfit_point *pts[3], int n[3], char *err, size_t errlen)
{
    FILE *f = fopen(path, "r");
    if (!f) return say(err, errlen, 2, "%s: cannot open: %s", path, strerror(errno));
    char line[512];
    int ln = 0, total = 0, rc = 0;
    while (fgets(line, sizeof line, f)) {
        ln++;
        size_t len = strlen(line);
        if (len == sizeof line - 1 && line[len - 1] != '\n') {
            rc = say(err, errlen, 2, "%s:%d: line longer than %zu characters", path, ln, sizeof line - 2);
            break;
        }
        line[strcspn(line, "\r\n")] = 0;
        char *p = line;
        while (*p == ' ' || *p == '\t') p++;
        if (!*p || *p == '#') continue;
        if (strncmp(p, "channel", 7) == 0) continue; /* the header */
        char *field[6];
        int nf = 0;
        for (char *tok = p; nf < 6;) {
            field[nf++] = tok;
            char *comma = strchr(tok, ',');
            if (!comma) break;
            *comma = 0;
            tok = comma + 1;
        }
        double v[4];
        bool ok = nf == 5;
        for (int i = 0; ok && i < 4; i++) {
            char *end;
            v[i] = strtod(field[i + 1], &end);
            while (*end == ' ') end++;
            ok = end != field[i + 1] && *end == 0 && isfinite(v[i]);
        }
        /* a name that does not fit is no channel: cut short, "red" and 12 spaces then "junk" would read as red */
        char ch[16];
        ok = ok && strlen(field[0]) < sizeof ch;
        snprintf(ch, sizeof ch, "%s", ok ? field[0] : "");
        char *e = ch + strlen(ch);
        while (e > ch && e[-1] == ' ') *--e = 0;
        int c = ok ? channel_of(ch) : -1;
        if (!ok || c < 0) {
            rc = say(err, errlen, 2,
                     "%s:%d: expected channel,panel_x,panel_y,u,v with channel red, green or blue and four finite "
                     "numbers",
                     path, ln);
            break;
        }
        if (++total > LENS_READ_MAX_POINTS) {
            rc = say(err, errlen, 2, "%s:%d: more than %d points", path, ln, LENS_READ_MAX_POINTS);
            break;
        }
        warp_lensfit_point *np = realloc(pts[c], sizeof *np * (size_t)(n[c] + 1));
        if (!np) {
            rc = say(err, errlen, 1, "out of memory");
            break;
        }
        pts[c] = np;
        pts[c][n[c]++] = (warp_lensfit_point){v[0], v[1], v[2], v[3]};
    }
    fclose(f);
    return rc;
}

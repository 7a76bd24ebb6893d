/* SPDX-License-Identifier: MIT */
/* seq_manifest: recorded frame sequences (docs/sequences.md): a directory of per-frame, per-eye colour and optional
 * depth, ids, motion and layers files with their poses and times in a manifest; parsed, validated, written, loaded. */
#include "tools/common/seq_manifest.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "platform/plat_png.h"
#include "tools/common/warp_files.h"
#include "warp/warp_err.h"

static const char *const kind_names[SEQ_KINDS] = {"color", "depth", "ids", "motion", "layers"};
static const char *const pose_names[7] = {"qw", "qx", "qy", "qz", "x", "y", "z"};
static const char *const eye_prefix[2][2] = {{"", ""}, {"left_", "right_"}}; /* [eyes - 1][eye] */

/* ---- the header ---- */

typedef struct {
    bool size, proj[2], is_intr[2];
    double v[2][4]; /* per eye: tan left right up down, or intrinsics fx fy cx cy */
} header_seen;

/* One "key values" line of the header; false with the message. */
static bool header_line(seq_manifest *m, header_seen *hs, const char *path, int ln, char *s, char *err, int errlen)
{
    char key[32];
    int used = 0;
    if (sscanf(s, "%31s %n", key, &used) != 1) return true;
    const char *rest = s + used;
    bool ok = true;
    int eye = strstr(key, "-right") ? 1 : 0;
    if (strcmp(key, "eyes") == 0) {
        ok = sscanf(rest, "%d", &m->eyes) == 1 && (m->eyes == 1 || m->eyes == 2);
    } else if (strcmp(key, "size") == 0) {
        ok = hs->size = sscanf(rest, "%6d %6d", &m->cam[0].width, &m->cam[0].height) == 2; /* no int overflow */
    } else if (strcmp(key, "tan") == 0 || strcmp(key, "tan-right") == 0) {
        double *v = hs->v[eye];
        ok = hs->proj[eye] = sscanf(rest, "%lf %lf %lf %lf", &v[0], &v[1], &v[2], &v[3]) == 4;
        hs->is_intr[eye] = false;
    } else if (strcmp(key, "intrinsics") == 0 || strcmp(key, "intrinsics-right") == 0) {
        double *v = hs->v[eye];
        ok = hs->proj[eye] = hs->is_intr[eye] =
            sscanf(rest, "%lf %lf %lf %lf", &v[0], &v[1], &v[2], &v[3]) == 4 && v[0] > 0 && v[1] > 0;
    } else if (strcmp(key, "near") == 0) {
        ok = sscanf(rest, "%lf", &m->cam[0].near_z) == 1;
    } else if (strcmp(key, "far") == 0) {
        ok = sscanf(rest, "%lf", &m->cam[0].far_z) == 1; /* "inf" parses as infinity */
    } else if (strcmp(key, "depth-encoding") == 0 || strcmp(key, "depth-kind") == 0) {
        char word[32];
        ok = sscanf(rest, "%31s", word) == 1 &&
             (strcmp(key, "depth-kind") == 0 ? warpfile_depth_kind(word, &m->depth_ray)
                                             : warpfile_depth_encoding(word, &m->depth_encoding));
    } else if (strcmp(key, "depth-scale") == 0) {
        ok = sscanf(rest, "%lf", &m->depth_scale) == 1 && isfinite(m->depth_scale) && m->depth_scale > 0;
    } else if (strcmp(key, "max-layers") == 0) {
        ok = sscanf(rest, "%d", &m->max_layers) == 1 && m->max_layers >= 1 && m->max_layers <= 64;
    } else {
        return warp_err(err, errlen, "%s:%d: unknown key '%s' (eyes, size, tan, intrinsics, tan-right, "
                        "intrinsics-right, near, far, depth-encoding, depth-kind, depth-scale, max-layers, frames)",
                        path, ln, key);
    }
    if (!ok) return warp_err(err, errlen, "%s:%d: cannot read the value of '%s'", path, ln, key);
    return true;
}

/* The cameras once the header is read: the right eye takes the left's projection unless it has its own. */
static bool header_done(seq_manifest *m, header_seen *hs, const char *path, char *err, int errlen)
{
    if (!hs->size || !hs->proj[0])
        return warp_err(err, errlen, "%s: the header needs size and tan or intrinsics before 'frames'", path);
    if (m->depth_ray && m->depth_encoding != WARP_DEPTH_LINEAR)
        return warp_err(err, errlen, "%s: depth-kind ray needs depth-encoding linear", path);
    if (m->eyes == 1 && hs->proj[1])
        return warp_err(err, errlen, "%s: tan-right/intrinsics-right with eyes 1", path);
    m->cam[1] = m->cam[0];
    for (int e = 0; e < 2; e++) {
        warp_camera *c = &m->cam[e];
        int src = hs->proj[e] ? e : 0;
        const double *v = hs->v[src];
        if (hs->is_intr[src]) {
            /* Pixel-space intrinsics (y down, principal point from the top-left corner) to frustum tangents. */
            c->tan_left = v[2] / v[0];
            c->tan_right = (c->width - v[2]) / v[0];
            c->tan_up = v[3] / v[1];
            c->tan_down = (c->height - v[3]) / v[1];
        } else {
            c->tan_left = v[0], c->tan_right = v[1], c->tan_up = v[2], c->tan_down = v[3];
        }
        const char *why = warp_camera_check(c);
        if (why) return warp_err(err, errlen, "%s: %s camera: %s", path, e ? "right" : "left", why);
    }
    return true;
}

/* ---- the table ---- */

enum { COL_INDEX, COL_TIME, COL_POSE, COL_FILE, COL_OBJECTS };
typedef struct {
    int what, eye, k; /* k: pose component or file kind */
    char name[24];
} column;

static bool parse_columns(seq_manifest *m, char *s, column **cols, int *ncols, const char *path, int ln, char *err,
                          int errlen)
{
    int cap = 8, n = 0;
    column *c = malloc(sizeof *c * (size_t)cap);
    if (!c) return warp_err(err, errlen, "out of memory");
    bool have_pose[2][7] = {{false}}, have_file[2][SEQ_KINDS] = {{false}}, have_index = false, have_time = false;
    s[strcspn(s, "\r\n")] = 0;
    for (char *next = s, *tok; (tok = strsep(&next, ",")) != NULL;) {
        tok += strspn(tok, " \t");
        tok[strcspn(tok, " \t")] = 0;
        if (!*tok) {
            free(c);
            return warp_err(err, errlen, "%s:%d: column %d has no name", path, ln, n + 1);
        }
        if (n == cap) {
            column *nc = realloc(c, sizeof *c * (size_t)(cap *= 2));
            if (!nc) return free(c), warp_err(err, errlen, "out of memory");
            c = nc;
        }
        column *col = &c[n];
        snprintf(col->name, sizeof col->name, "%s", tok);
        col->what = -1;
        if (strcmp(tok, "index") == 0) col->what = COL_INDEX, have_index = true;
        else if (strcmp(tok, "time") == 0) col->what = COL_TIME, have_time = true;
        else if (strcmp(tok, "objects") == 0) col->what = COL_OBJECTS, m->objects = true;
        for (int e = 0; e < m->eyes && col->what < 0; e++) {
            size_t pl = strlen(eye_prefix[m->eyes - 1][e]);
            if (strncmp(tok, eye_prefix[m->eyes - 1][e], pl) != 0) continue;
            for (int k = 0; k < 7; k++)
                if (strcmp(tok + pl, pose_names[k]) == 0) col->what = COL_POSE, col->eye = e, col->k = k;
            for (int k = 0; k < SEQ_KINDS; k++)
                if (strcmp(tok + pl, kind_names[k]) == 0) col->what = COL_FILE, col->eye = e, col->k = k;
        }
        bool dup = false;
        for (int i = 0; i < n; i++) dup |= strcmp(c[i].name, col->name) == 0;
        if (col->what < 0 || dup) {
            free(c);
            return warp_err(err, errlen, "%s:%d: column '%s': %s", path, ln, tok,
                            dup ? "named twice" : m->eyes == 2 ? "unknown (index, time, objects, left_/right_ + qw qx "
                            "qy qz x y z color depth ids motion layers)" : "unknown (index, time, objects, qw qx qy qz "
                            "x y z color depth ids motion layers; eyes 1 has no left_/right_ prefix)");
        }
        if (col->what == COL_POSE) have_pose[col->eye][col->k] = true;
        if (col->what == COL_FILE) have_file[col->eye][col->k] = true;
        n++;
    }
    const char *missing = !have_index ? "index" : !have_time ? "time" : NULL;
    char buf[32];
    for (int e = 0; e < m->eyes && !missing; e++) {
        for (int k = 0; k < 7 && !missing; k++)
            if (!have_pose[e][k])
                snprintf(buf, sizeof buf, "%s%s", eye_prefix[m->eyes - 1][e], pose_names[k]), missing = buf;
        if (!missing && !have_file[e][SEQ_COLOR])
            snprintf(buf, sizeof buf, "%scolor", eye_prefix[m->eyes - 1][e]), missing = buf;
        for (int k = 1; k < SEQ_KINDS && !missing; k++)
            if (have_file[e][k] != have_file[0][k])
                snprintf(buf, sizeof buf, "%s%s", eye_prefix[m->eyes - 1][e], kind_names[k]), missing = buf;
    }
    if (missing) {
        free(c);
        return warp_err(err, errlen, "%s:%d: no column '%s'", path, ln, missing);
    }
    m->planes = 0;
    for (int k = 0; k < SEQ_KINDS; k++)
        if (have_file[0][k]) m->planes |= 1u << k;
    *cols = c;
    *ncols = n;
    return true;
}

/* A number filling the whole cell. */
static bool cell_number(const char *s, double *v)
{
    char *end;
    errno = 0;
    *v = strtod(s, &end);
    return end != s && !*end && errno != ERANGE;
}

static char *join_path(const char *dir, const char *name)
{
    size_t n = strlen(dir) + strlen(name) + 2;
    char *p = malloc(n);
    if (p) snprintf(p, n, "%s%s%s", name[0] == '/' ? "" : dir, name[0] == '/' ? "" : "/", name);
    return p;
}

static void frame_free(seq_frame *fr)
{
    for (int e = 0; e < 2; e++)
        for (int k = 0; k < SEQ_KINDS; k++) free(fr->file[e][k]);
    free(fr->objects);
}

/* One row into fr (zeroed by the caller; fr->file freed by the caller on failure too). */
static bool parse_row(const seq_manifest *m, const column *cols, int ncols, char *s, const char *dir, int row,
                      seq_frame *fr, const char *path, int ln, char *err, int errlen)
{
    double pose[2][7];
    int i = 0, fields = 1;
    fr->line = ln;
    for (const char *c = s; *c; c++) fields += *c == ',';
    /* Counted first: a shifted row would otherwise be reported as a bad number or a missing file. */
    if (fields != ncols)
        return warp_err(err, errlen, "%s:%d: %d fields, the column line names %d", path, ln, fields, ncols);
    char *cell = s;
    for (;; i++) {
        char *end = cell + strcspn(cell, ",");
        bool last = *end != ',';
        *end = 0;
        cell += strspn(cell, " \t");
        cell[strcspn(cell, "\r\n")] = 0;
        for (size_t l = strlen(cell); l > 0 && (cell[l - 1] == ' ' || cell[l - 1] == '\t'); l--) cell[l - 1] = 0;
        const column *c = &cols[i];
        double v = 0;
        if (c->what == COL_INDEX || c->what == COL_TIME || c->what == COL_POSE) {
            if (!cell_number(cell, &v) || !isfinite(v))
                return warp_err(err, errlen, "%s:%d: field '%s': '%s' is not a finite number", path, ln, c->name, cell);
        }
        if (c->what == COL_INDEX && v != row)
            return warp_err(err, errlen, "%s:%d: field 'index': %s, expected %d (frames in order from 0)", path, ln,
                            cell, row);
        if (c->what == COL_TIME) {
            if (row > 0 && !(v > fr[-1].time))
                return warp_err(err, errlen, "%s:%d: field 'time': %s is not after the previous frame's %.9g", path,
                                ln, cell, fr[-1].time);
            fr->time = v;
        }
        if (c->what == COL_POSE) pose[c->eye][c->k] = v;
        if (c->what == COL_FILE || c->what == COL_OBJECTS) {
            if (!*cell) return warp_err(err, errlen, "%s:%d: field '%s': empty", path, ln, c->name);
            char *p = join_path(dir, cell);
            if (!p) return warp_err(err, errlen, "out of memory");
            if (c->what == COL_FILE)
                fr->file[c->eye][c->k] = p;
            else
                fr->objects = p;
            if (access(p, R_OK) != 0)
                return warp_err(err, errlen, "%s:%d: field '%s': %s: %s", path, ln, c->name, p, strerror(errno));
        }
        if (last) break;
        cell = end + 1;
    }
    for (int e = 0; e < m->eyes; e++) {
        warp_quat q = {pose[e][0], pose[e][1], pose[e][2], pose[e][3]};
        double len = sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
        if (fabs(len - 1) > SEQ_UNIT_TOL || !warp_quat_normalize(q, &fr->pose[e].q))
            return warp_err(err, errlen, "%s:%d: fields '%sqw'..'%sqz': quaternion length %.6g, not 1 (within %g)",
                            path, ln, eye_prefix[m->eyes - 1][e], eye_prefix[m->eyes - 1][e], len, SEQ_UNIT_TOL);
        fr->pose[e].p = warp_v3(pose[e][4], pose[e][5], pose[e][6]);
    }
    if (m->eyes == 1) fr->pose[1] = fr->pose[0];
    return true;
}

bool seq_open(const char *path, seq_manifest *m, char *err, int errlen)
{
    memset(m, 0, sizeof *m);
    struct stat st;
    char *dir, *mpath;
    if (stat(path, &st) == 0 && S_ISDIR(st.st_mode)) {
        dir = strdup(path);
        mpath = join_path(path, SEQ_MANIFEST_NAME);
    } else {
        mpath = strdup(path);
        dir = strdup(path);
        if (dir) {
            char *slash = strrchr(dir, '/');
            if (slash) *slash = 0;
            else strcpy(dir, ".");
        }
    }
    if (!dir || !mpath) return free(dir), free(mpath), warp_err(err, errlen, "out of memory");
    m->path = mpath;
    FILE *f = fopen(mpath, "r");
    if (!f) {
        warp_err(err, errlen, "%s: %s", mpath, strerror(errno));
        free(dir);
        seq_close(m);
        return false;
    }
    m->eyes = 2;
    m->cam[0].near_z = 0.05;
    m->cam[0].far_z = INFINITY;
    m->depth_encoding = WARP_DEPTH_LINEAR;
    m->depth_scale = 1;
    m->max_layers = 8;
    header_seen hs = {0};
    enum { MAGIC, HEADER, COLUMNS, ROWS } stage = MAGIC;
    column *cols = NULL;
    int ncols = 0, cap = 0, ln = 0;
    char *line = NULL;
    size_t linecap = 0;
    bool ok = true;
    while (ok && getline(&line, &linecap, f) > 0) {
        ln++;
        char *s = line + strspn(line, " \t\r");
        if (*s == '#' || *s == '\n' || !*s) continue;
        if (stage == MAGIC) {
            int v = 0;
            ok = sscanf(s, "hmdwarp-sequence %d", &v) == 1 && v == SEQ_VERSION;
            if (!ok) warp_err(err, errlen, "%s:%d: expected 'hmdwarp-sequence %d' first", mpath, ln, SEQ_VERSION);
            stage = HEADER;
        } else if (stage == HEADER) {
            if (strncmp(s, "frames", 6) == 0 && strspn(s + 6, " \t\r\n") == strlen(s + 6)) {
                ok = header_done(m, &hs, mpath, err, errlen);
                stage = COLUMNS;
            } else {
                ok = header_line(m, &hs, mpath, ln, s, err, errlen);
            }
        } else if (stage == COLUMNS) {
            ok = parse_columns(m, s, &cols, &ncols, mpath, ln, err, errlen);
            stage = ROWS;
        } else {
            if (m->n == cap) {
                int ncap = cap ? cap * 2 : 64;
                seq_frame *nf = realloc(m->frames, sizeof *nf * (size_t)ncap);
                if (!nf) {
                    ok = warp_err(err, errlen, "out of memory");
                    break;
                }
                m->frames = nf;
                cap = ncap;
            }
            seq_frame *fr = &m->frames[m->n];
            memset(fr, 0, sizeof *fr);
            m->n++; /* counted before parsing: seq_close frees what a failed row holds */
            ok = parse_row(m, cols, ncols, s, dir, m->n - 1, fr, mpath, ln, err, errlen);
        }
    }
    free(line);
    free(cols);
    free(dir);
    fclose(f);
    if (ok && stage != ROWS)
        ok = warp_err(err, errlen, "%s: %s", mpath,
                      stage == MAGIC ? "empty (expected 'hmdwarp-sequence 1', the header, 'frames', the column line)"
                      : stage == HEADER ? "no 'frames' line ending the header" : "no column line after 'frames'");
    if (ok && m->n == 0) ok = warp_err(err, errlen, "%s: no frames", mpath);
    if (!ok) seq_close(m);
    return ok;
}

void seq_close(seq_manifest *m)
{
    for (int i = 0; i < m->n; i++) frame_free(&m->frames[i]);
    free(m->frames);
    free(m->path);
    memset(m, 0, sizeof *m);
}

/* ---- loading a frame ---- */

static bool load_eye(const seq_manifest *m, const seq_frame *fr, int e, unsigned planes, drv_frame *f, char *err,
                     int errlen)
{
    const warp_camera *cam = &m->cam[e];
    int src = m->eyes == 1 ? 0 : e;
    bool ok = true;
    warp_image_rgba8 color = {0};
    warp_image_f32 depth = {0};
    warp_image_u16 ids = {0};
    warp_image_vec2f motion = {0};
    warp_image_layers layers = {0};
    /* The manifest's camera says the size: a PNG declaring more is refused before it is decoded. */
    size_t max_px = (size_t)cam->width * (size_t)cam->height;
    ok = plat_png_read_max(fr->file[src][SEQ_COLOR], &color, max_px, err, errlen);
    if (ok && (color.w != cam->width || color.h != cam->height))
        ok = warp_err(err, errlen, "%s: %dx%d, the manifest says %dx%d", fr->file[src][SEQ_COLOR], color.w, color.h,
                      cam->width, cam->height);
    if (ok) warp_image_rgba8_copy(&f->color[e], &color);
    if (ok && (planes & DRV_PLANE_DEPTH)) {
        ok = warpfile_load_depth(fr->file[src][SEQ_DEPTH], cam, m->depth_encoding, m->depth_ray, m->depth_scale,
                                 &depth, err, errlen);
        for (int y = 0; ok && y < cam->height; y++)
            memcpy(&WARP_AT(&f->depth[e], 0, y), &WARP_AT(&depth, 0, y), sizeof(float) * (size_t)cam->width);
    }
    if (ok && (planes & DRV_PLANE_IDS)) {
        ok = warpfile_load_ids(fr->file[src][SEQ_IDS], cam, &ids, err, errlen);
        for (int y = 0; ok && y < cam->height; y++)
            memcpy(&WARP_AT(&f->ids[e], 0, y), &WARP_AT(&ids, 0, y), sizeof(uint16_t) * (size_t)cam->width);
    }
    if (ok && (planes & DRV_PLANE_MOTION)) {
        ok = warpfile_load_motion(fr->file[src][SEQ_MOTION], cam, &motion, err, errlen);
        for (int y = 0; ok && y < cam->height; y++)
            memcpy(&WARP_AT(&f->motion[e], 0, y), &WARP_AT(&motion, 0, y), sizeof(warp_vec2f) * (size_t)cam->width);
    }
    if (ok && (planes & DRV_PLANE_LAYERS)) {
        ok = warpfile_read_layers(fr->file[src][SEQ_LAYERS], cam, &layers, err, errlen);
        warp_image_layers *d = &f->layers[e];
        for (int i = 0; ok && i < layers.w * layers.h; i++) {
            int n = layers.count[i];
            if (n > d->max_layers) {
                ok = warp_err(err, errlen, "%s: pixel %d has %d fragments, more than max-layers %d",
                              fr->file[src][SEQ_LAYERS], i, n, d->max_layers);
                break;
            }
            d->count[i] = (uint8_t)n;
            memcpy(&d->frag[(size_t)i * d->max_layers], &layers.frag[(size_t)i * layers.max_layers],
                   sizeof(warp_fragment) * (size_t)n);
        }
    }
    warp_image_free(&color);
    warp_image_free(&depth);
    warp_image_free(&ids);
    warp_image_free(&motion);
    warp_image_layers_free(&layers);
    return ok;
}

bool seq_load_frame(const seq_manifest *m, int i, unsigned planes, drv_frame *f, char *err, int errlen)
{
    planes = (planes & m->planes) | DRV_PLANE_COLOR;
    if (i < 0 || i >= m->n) return warp_err(err, errlen, "%s: no frame %d (%d frames)", m->path, i, m->n);
    const seq_frame *fr = &m->frames[i];
    char why[400];
    for (int e = 0; e < 2; e++)
        if (!load_eye(m, fr, e, planes, f, why, sizeof why))
            return warp_err(err, errlen, "%s:%d (frame %d): %s", m->path, fr->line, i, why);
    f->n_objects = 0;
    if (fr->objects) {
        warpfile_objects o;
        if (!warpfile_load_objects(fr->objects, &o, why, sizeof why))
            return warp_err(err, errlen, "%s:%d (frame %d): %s", m->path, fr->line, i, why);
        f->n_objects = o.n;
        memcpy(f->object_pose, o.src, sizeof(warp_pose) * (size_t)o.n);
    }
    f->planes = planes;
    f->depth_encoding = m->depth_encoding;
    for (int e = 0; e < 2; e++) {
        f->cam[e] = m->cam[e];
        f->eye_pose[e] = fr->pose[e];
    }
    f->scene_time = fr->time;
    return true;
}

/* ---- writing ---- */

static void pose_fields(FILE *f, warp_pose p)
{
    fprintf(f, ",%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g", p.q.w, p.q.x, p.q.y, p.q.z, p.p.x, p.p.y, p.p.z);
}

bool seq_writer_open(seq_writer *w, const char *dir, int eyes, const warp_camera cam[2], warp_depth_encoding enc,
                     unsigned planes, bool objects, char *err, int errlen)
{
    static const char *const enc_names[] = {[WARP_DEPTH_LINEAR] = "linear", [WARP_DEPTH_STANDARD] = "standard",
                                            [WARP_DEPTH_REVERSED] = "reversed"};
    memset(w, 0, sizeof *w);
    mkdir(dir, 0755);
    char *p = join_path(dir, SEQ_MANIFEST_NAME);
    if (!p) return warp_err(err, errlen, "out of memory");
    w->f = fopen(p, "w");
    if (!w->f) {
        warp_err(err, errlen, "%s: %s", p, strerror(errno));
        free(p);
        return false;
    }
    free(p);
    w->eyes = eyes;
    w->planes = planes | DRV_PLANE_COLOR;
    w->objects = objects;
    FILE *f = w->f;
    fprintf(f, "# hmdwarp sequence (docs/sequences.md): right-handed, the camera looks down -Z, +Y up, +X right;\n"
               "# poses are world_from_eye: unit quaternion qw qx qy qz, position x y z in metres; time in seconds\n"
               "hmdwarp-sequence %d\neyes %d\nsize %d %d\n", SEQ_VERSION, eyes, cam[0].width, cam[0].height);
    for (int e = 0; e < eyes; e++)
        fprintf(f, "tan%s %.17g %.17g %.17g %.17g\n", e ? "-right" : "", cam[e].tan_left, cam[e].tan_right,
                cam[e].tan_up, cam[e].tan_down);
    fprintf(f, "near %.17g\nfar %.17g\ndepth-encoding %s\ndepth-kind planar\nframes\nindex,time", cam[0].near_z,
            cam[0].far_z, enc_names[enc]);
    for (int e = 0; e < eyes; e++)
        for (int k = 0; k < 7; k++) fprintf(f, ",%s%s", eye_prefix[eyes - 1][e], pose_names[k]);
    for (int e = 0; e < eyes; e++)
        for (int k = 0; k < SEQ_KINDS; k++)
            if (w->planes & (1u << k)) fprintf(f, ",%s%s", eye_prefix[eyes - 1][e], kind_names[k]);
    fprintf(f, "%s\n", objects ? ",objects" : "");
    return true;
}

bool seq_writer_frame(seq_writer *w, double time, const warp_pose pose[2], const char *const files[2][SEQ_KINDS],
                      const char *objects)
{
    fprintf(w->f, "%d,%.17g", w->n++, time);
    for (int e = 0; e < w->eyes; e++) pose_fields(w->f, pose[e]);
    for (int e = 0; e < w->eyes; e++)
        for (int k = 0; k < SEQ_KINDS; k++)
            if (w->planes & (1u << k)) fprintf(w->f, ",%s", files[e][k] ? files[e][k] : "");
    if (w->objects) fprintf(w->f, ",%s", objects ? objects : "");
    return fputc('\n', w->f) != EOF;
}

bool seq_writer_close(seq_writer *w)
{
    bool ok = w->f && fclose(w->f) == 0;
    w->f = NULL;
    return ok;
}

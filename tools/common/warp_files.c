/* SPDX-License-Identifier: MIT */
/* warp_files: the tools' frame files (hmdwarp-warp's inputs, hmdwarp-feed's sequences): the view file, depth, ids,
 * motion, PFM, layers and object-pose files, each checked against what the file holds before anything is allocated. */
#include "tools/common/warp_files.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "platform/plat_png.h"
#include "warp/warp_err.h"

/* Bytes left in f after its current position (-1 when unknown: not a regular file). */
static long long bytes_left(FILE *f)
{
    struct stat st;
    long pos = ftell(f);
    if (pos < 0 || fstat(fileno(f), &st) != 0 || !S_ISREG(st.st_mode)) return -1;
    return (long long)st.st_size - pos;
}

/* ---- the view file ---- */

const char *warpfile_parse_pose(const char *s, double tol, warp_pose *p, int *used)
{
    /* sscanf reads "nan" and "inf" as numbers: each is named, as the warps would reject the pose without the field */
    static const char *const not_finite[7] = {"qw is not finite", "qx is not finite", "qy is not finite",
                                              "qz is not finite", "x is not finite",  "y is not finite",
                                              "z is not finite"};
    double v[7];
    int n = 0;
    if (sscanf(s, "%lf %lf %lf %lf %lf %lf %lf%n", &v[0], &v[1], &v[2], &v[3], &v[4], &v[5], &v[6], &n) != 7)
        return "expected 7 numbers: qw qx qy qz x y z";
    for (int i = 0; i < 7; i++)
        if (!isfinite(v[i])) return not_finite[i];
    warp_quat q = {v[0], v[1], v[2], v[3]};
    if (q.w == 0 && q.x == 0 && q.y == 0 && q.z == 0) return "orientation quaternion qw qx qy qz is zero";
    double len = sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
    if (tol >= 0 && fabs(len - 1) > tol) return "orientation quaternion qw qx qy qz is not of unit length";
    if (!warp_quat_normalize(q, &p->q)) return "orientation quaternion qw qx qy qz is too short to normalise";
    p->p = warp_v3(v[4], v[5], v[6]);
    if (used) *used = n;
    return NULL;
}

/* Every number of the camera keys must be finite; far alone may be "inf" (no far plane). */
static bool all_finite(const double *v, int n)
{
    for (int i = 0; i < n; i++)
        if (!isfinite(v[i])) return false;
    return true;
}

bool warpfile_load_view(const char *path, warpfile_view *vf, char *err, int errlen)
{
    FILE *f = fopen(path, "r");
    if (!f) return warp_err(err, errlen, "%s: %s", path, strerror(errno));
    memset(vf, 0, sizeof *vf);
    vf->cam.near_z = 0.05;
    vf->cam.far_z = INFINITY;
    bool have_src = false, have_dst = false, have_size = false, have_proj = false;
    double fx = 0, fy = 0, cx = 0, cy = 0;
    bool intr = false;
    char line[512];
    int n = 0;
    while (fgets(line, sizeof line, f)) {
        n++;
        /* A longer line would come back in pieces, the rest read as lines of their own with shifted numbers. */
        if (!strchr(line, '\n') && !feof(f)) {
            fclose(f);
            return warp_err(err, errlen, "%s:%d: line longer than %zu characters", path, n, sizeof line - 2);
        }
        char *s = line + strspn(line, " \t");
        if (*s == '#' || *s == '\n' || !*s) continue;
        char key[32];
        int used = 0;
        if (sscanf(s, "%31s %n", key, &used) != 1) continue;
        const char *rest = s + used;
        bool ok = true;
        const char *why = NULL; /* what is wrong with the values, when more than "cannot read" can be said */
        int used2;
        if (strcmp(key, "size") == 0) {
            ok = sscanf(rest, "%6d %6d", &vf->cam.width, &vf->cam.height) == 2; /* 6 digits: no int overflow */
            have_size = ok;
        } else if (strcmp(key, "tan") == 0) {
            double t[4];
            ok = sscanf(rest, "%lf %lf %lf %lf", &t[0], &t[1], &t[2], &t[3]) == 4;
            if (ok && !all_finite(t, 4)) why = "the tangents must be finite numbers";
            vf->cam.tan_left = t[0], vf->cam.tan_right = t[1], vf->cam.tan_up = t[2], vf->cam.tan_down = t[3];
            have_proj = ok;
        } else if (strcmp(key, "intrinsics") == 0) {
            double k[4];
            ok = sscanf(rest, "%lf %lf %lf %lf", &k[0], &k[1], &k[2], &k[3]) == 4;
            if (ok && !all_finite(k, 4)) why = "fx fy cx cy must be finite numbers";
            else if (ok && !(k[0] > 0 && k[1] > 0)) why = "fx and fy must be positive";
            fx = k[0], fy = k[1], cx = k[2], cy = k[3];
            have_proj = intr = ok;
        } else if (strcmp(key, "near") == 0) {
            ok = sscanf(rest, "%lf", &vf->cam.near_z) == 1;
            if (ok && !isfinite(vf->cam.near_z)) why = "near must be a finite number";
        } else if (strcmp(key, "far") == 0) {
            ok = sscanf(rest, "%lf", &vf->cam.far_z) == 1; /* "inf" parses as infinity */
            if (ok && isnan(vf->cam.far_z)) why = "far must be a number (inf: no far plane)";
        } else if (strcmp(key, "source") == 0) {
            why = warpfile_parse_pose(rest, -1, &vf->src, &used2);
            have_src = !why;
        } else if (strcmp(key, "target") == 0) {
            why = warpfile_parse_pose(rest, -1, &vf->dst, &used2);
            have_dst = !why;
        } else {
            fclose(f);
            return warp_err(err, errlen, "%s:%d: unknown key '%s' (size, tan, intrinsics, near, far, source, "
                            "target)", path, n, key);
        }
        if (!ok || why) {
            fclose(f);
            if (why) return warp_err(err, errlen, "%s:%d: '%s': %s", path, n, key, why);
            return warp_err(err, errlen, "%s:%d: cannot read the values of '%s'", path, n, key);
        }
    }
    fclose(f);
    if (!have_size || !have_proj || !have_src || !have_dst)
        return warp_err(err, errlen, "%s: needs size, tan or intrinsics, source and target", path);
    if (intr) {
        /* Pixel-space intrinsics (y down) to the frustum tangents the warps use. */
        vf->cam.tan_left = cx / fx;
        vf->cam.tan_right = (vf->cam.width - cx) / fx;
        vf->cam.tan_up = cy / fy;
        vf->cam.tan_down = (vf->cam.height - cy) / fy;
    }
    const char *why = warp_camera_check(&vf->cam);
    if (why) return warp_err(err, errlen, "%s: camera: %s", path, why);
    return true;
}

void warpfile_pose_line(FILE *f, const char *key, warp_pose p)
{
    fprintf(f, "%s %.17g %.17g %.17g %.17g  %.17g %.17g %.17g\n", key, p.q.w, p.q.x, p.q.y, p.q.z, p.p.x, p.p.y,
            p.p.z);
}

/* ---- float images ---- */

/* PFM: "Pf" (grey) or "PF" (RGB), width height, scale (negative = little endian), rows bottom to top. */
float *warpfile_read_pfm(const char *path, int *w, int *h, int *channels, char *err, int errlen)
{
    FILE *f = fopen(path, "rb");
    if (!f) return warp_err(err, errlen, "%s: %s", path, strerror(errno)), NULL;
    char magic[3] = {0};
    double scale;
    if (fscanf(f, "%2s %6d %6d %lf", magic, w, h, &scale) != 4 || (strcmp(magic, "Pf") && strcmp(magic, "PF")) ||
        *w <= 0 || *h <= 0 || *w > WARP_MAX_SIDE || *h > WARP_MAX_SIDE || fgetc(f) == EOF) {
        fclose(f);
        return warp_err(err, errlen, "%s: not a PFM file (expected Pf/PF, width, height, scale)", path), NULL;
    }
    *channels = magic[1] == 'F' ? 3 : 1;
    size_t n = (size_t)*w * (size_t)*h * (size_t)*channels;
    long long left = bytes_left(f);
    if (left >= 0 && (unsigned long long)left < n * sizeof(float)) {
        fclose(f);
        return warp_err(err, errlen, "%s: declares %dx%dx%d floats (%zu bytes) but holds %lld", path, *w, *h,
                        *channels, n * sizeof(float), left), NULL;
    }
    float *px = malloc(n * sizeof *px), *rows = malloc(n * sizeof *px);
    if (!px || !rows || fread(rows, sizeof(float), n, f) != n) {
        free(px);
        free(rows);
        fclose(f);
        return warp_err(err, errlen, "%s: truncated PFM data", path), NULL;
    }
    fclose(f);
    bool big = scale > 0;
    size_t row = (size_t)*w * (size_t)*channels;
    for (int y = 0; y < *h; y++)
        for (size_t i = 0; i < row; i++) {
            float v = rows[(size_t)(*h - 1 - y) * row + i];
            if (big) {
                uint32_t u;
                memcpy(&u, &v, 4);
                u = __builtin_bswap32(u);
                memcpy(&v, &u, 4);
            }
            px[(size_t)y * row + i] = v;
        }
    free(rows);
    return px;
}

bool warpfile_write_pfm(const char *path, const float *px, int w, int h, int channels)
{
    FILE *f = fopen(path, "wb");
    if (!f) return false;
    fprintf(f, "%s\n%d %d\n-1.0\n", channels == 3 ? "PF" : "Pf", w, h);
    size_t row = (size_t)w * (size_t)channels;
    for (int y = h - 1; y >= 0; y--) fwrite(px + (size_t)y * row, sizeof(float), row, f);
    return fclose(f) == 0;
}

/* ---- transparency layers: "HWLAYER1", u32 w, h, max_layers, then per pixel (row-major) a u8 count and count
 * fragments of f32 z (linear view depth, metres), u8 r g b a (straight alpha), u16 object id; little endian ---- */

bool warpfile_write_layers(const char *path, const warp_image_layers *l)
{
    FILE *f = fopen(path, "wb");
    if (!f) return false;
    uint32_t hdr[3] = {(uint32_t)l->w, (uint32_t)l->h, (uint32_t)l->max_layers};
    fwrite("HWLAYER1", 1, 8, f);
    fwrite(hdr, 4, 3, f);
    for (int i = 0; i < l->w * l->h; i++) {
        uint8_t n = l->count[i];
        fwrite(&n, 1, 1, f);
        for (int k = 0; k < n; k++) {
            const warp_fragment *fr = &l->frag[(size_t)i * l->max_layers + k];
            fwrite(&fr->z, 4, 1, f);
            fwrite(&fr->rgba, 1, 4, f);
            fwrite(&fr->id, 2, 1, f);
        }
    }
    return fclose(f) == 0;
}

bool warpfile_read_layers(const char *path, const warp_camera *cam, warp_image_layers *l, char *err, int errlen)
{
    FILE *f = fopen(path, "rb");
    if (!f) return warp_err(err, errlen, "%s: %s", path, strerror(errno));
    char magic[8];
    uint32_t hdr[3];
    if (fread(magic, 1, 8, f) != 8 || memcmp(magic, "HWLAYER1", 8) || fread(hdr, 4, 3, f) != 3) {
        fclose(f);
        return warp_err(err, errlen, "%s: not a layers file (expected HWLAYER1)", path);
    }
    if ((int)hdr[0] != cam->width || (int)hdr[1] != cam->height || hdr[2] < 1 || hdr[2] > 64) {
        fclose(f);
        return warp_err(err, errlen, "%s: %ux%u with %u layers; expected %dx%d and 1..64 layers", path, hdr[0],
                        hdr[1], hdr[2], cam->width, cam->height);
    }
    /* Every pixel has at least its count byte: a file shorter than that is refused before the allocation (up to
     * 64 fragments a pixel of the declared size). */
    long long left = bytes_left(f);
    if (left >= 0 && (unsigned long long)left < (unsigned long long)hdr[0] * hdr[1]) {
        fclose(f);
        return warp_err(err, errlen, "%s: %ux%u pixels but only %lld bytes of data", path, hdr[0], hdr[1], left);
    }
    if (!warp_image_layers_alloc(l, (int)hdr[0], (int)hdr[1], (int)hdr[2])) {
        fclose(f);
        return warp_err(err, errlen, "out of memory");
    }
    for (int i = 0; i < l->w * l->h; i++) {
        uint8_t n;
        if (fread(&n, 1, 1, f) != 1 || n > l->max_layers) {
            fclose(f);
            warp_image_layers_free(l);
            return warp_err(err, errlen, "%s: pixel %d: truncated or more than %d fragments", path, i, l->max_layers);
        }
        l->count[i] = n;
        for (int k = 0; k < n; k++) {
            warp_fragment *fr = &l->frag[(size_t)i * l->max_layers + k];
            if (fread(&fr->z, 4, 1, f) != 1 || fread(&fr->rgba, 1, 4, f) != 4 || fread(&fr->id, 2, 1, f) != 1) {
                fclose(f);
                warp_image_layers_free(l);
                return warp_err(err, errlen, "%s: truncated at pixel %d", path, i);
            }
        }
    }
    fclose(f);
    return true;
}


/* ---- depth, ids, motion ---- */

bool warpfile_depth_encoding(const char *name, warp_depth_encoding *enc)
{
    static const struct { const char *name; warp_depth_encoding e; } t[] = {
        {"linear", WARP_DEPTH_LINEAR}, {"standard", WARP_DEPTH_STANDARD}, {"reversed", WARP_DEPTH_REVERSED}};
    for (size_t i = 0; i < sizeof t / sizeof t[0]; i++)
        if (strcmp(name, t[i].name) == 0) return *enc = t[i].e, true;
    return false;
}

bool warpfile_depth_kind(const char *name, bool *ray)
{
    if (strcmp(name, "planar") && strcmp(name, "ray")) return false;
    *ray = strcmp(name, "ray") == 0;
    return true;
}

bool warpfile_load_depth(const char *path, const warp_camera *cam, warp_depth_encoding enc, bool ray, double scale,
                         warp_image_f32 *depth, char *err, int errlen)
{
    if (ray && enc != WARP_DEPTH_LINEAR) return warp_err(err, errlen, "ray-distance depth needs linear encoding");
    int w = cam->width, h = cam->height, ch = 1;
    float *px = NULL;
    const char *ext = strrchr(path, '.');
    bool png16 = ext && strcmp(ext, ".png") == 0;
    if (ext && strcmp(ext, ".pfm") == 0) {
        px = warpfile_read_pfm(path, &w, &h, &ch, err, errlen);
        if (!px) return false;
    } else if (png16) {
        uint16_t *u = NULL;
        if (!plat_png_read_u16(path, &u, &w, &h, err, errlen)) return false;
        px = malloc(sizeof(float) * (size_t)w * (size_t)h);
        if (px)
            for (size_t i = 0; i < (size_t)w * (size_t)h; i++) px[i] = (float)u[i];
        free(u);
    } else {
        FILE *f = fopen(path, "rb");
        if (!f) return warp_err(err, errlen, "%s: %s", path, strerror(errno));
        px = malloc(sizeof(float) * (size_t)w * (size_t)h);
        size_t got = px ? fread(px, sizeof(float), (size_t)w * (size_t)h, f) : 0;
        fclose(f);
        if (got != (size_t)w * (size_t)h) {
            free(px);
            return warp_err(err, errlen, "%s: expected %dx%d float32 values (the colour's size)", path, w, h);
        }
    }
    if (!px) return warp_err(err, errlen, "out of memory");
    if (w != cam->width || h != cam->height || ch != 1) {
        free(px);
        return warp_err(err, errlen, "%s: %dx%d, %d channels; expected %dx%d, 1 channel", path, w, h, ch,
                        cam->width, cam->height);
    }
    if (!warp_image_f32_alloc(depth, w, h)) return free(px), warp_err(err, errlen, "out of memory");
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double v = px[(size_t)y * w + x];
            if (enc == WARP_DEPTH_LINEAR) {
                v *= scale;
                if (ray) {
                    /* distance along the ray -> planar z: divide by the ray direction's length at z = 1 */
                    double u, t;
                    warp_camera_pixel_to_tan(cam, x + 0.5, y + 0.5, &u, &t);
                    v /= sqrt(u * u + t * t + 1);
                }
            } else if (png16) {
                v /= 65535.0;
            }
            WARP_AT(depth, x, y) = (float)v;
        }
    free(px);
    return true;
}

bool warpfile_load_ids(const char *path, const warp_camera *cam, warp_image_u16 *ids, char *err, int errlen)
{
    uint16_t *u = NULL;
    int w, h;
    if (!plat_png_read_u16(path, &u, &w, &h, err, errlen)) return false;
    if (w != cam->width || h != cam->height) {
        free(u);
        return warp_err(err, errlen, "%s: %dx%d ids; expected %dx%d", path, w, h, cam->width, cam->height);
    }
    if (!warp_image_u16_alloc(ids, w, h)) return free(u), warp_err(err, errlen, "out of memory");
    for (int y = 0; y < h; y++) memcpy(&WARP_AT(ids, 0, y), u + (size_t)y * w, sizeof(uint16_t) * (size_t)w);
    free(u);
    return true;
}

bool warpfile_load_motion(const char *path, const warp_camera *cam, warp_image_vec2f *motion, char *err, int errlen)
{
    int w, h, ch;
    float *m = warpfile_read_pfm(path, &w, &h, &ch, err, errlen);
    if (!m) return false;
    if (w != cam->width || h != cam->height || ch != 3) {
        free(m);
        return warp_err(err, errlen, "%s: %dx%d, %d channels; expected a 3-channel PFM of %dx%d", path, w, h, ch,
                        cam->width, cam->height);
    }
    if (!warp_image_vec2f_alloc(motion, w, h)) return free(m), warp_err(err, errlen, "out of memory");
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            WARP_AT(motion, x, y) = (warp_vec2f){m[((size_t)y * w + x) * 3], m[((size_t)y * w + x) * 3 + 1]};
    free(m);
    return true;
}

bool warpfile_write_motion(const char *path, const warp_image_vec2f *motion)
{
    int w = motion->w, h = motion->h;
    float *m = malloc(sizeof(float) * 3 * (size_t)w * (size_t)h);
    if (!m) return false;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            warp_vec2f v = WARP_AT(motion, x, y);
            float *o = m + ((size_t)y * w + x) * 3;
            o[0] = v.x, o[1] = v.y, o[2] = 0;
        }
    bool ok = warpfile_write_pfm(path, m, w, h, 3);
    free(m);
    return ok;
}

/* ---- object poses: "object ID  qw qx qy qz x y z  [qw qx qy qz x y z]" per line, # comments ---- */

/* The tolerance on a unit quaternion's length: a renderer's float matrices give about 1e-7; more means the
 * columns are not a quaternion (w last, degrees, a typo) and normalising would hide it. */
#define UNIT_TOL 1e-3

bool warpfile_load_objects(const char *path, warpfile_objects *o, char *err, int errlen)
{
    FILE *f = fopen(path, "r");
    if (!f) return warp_err(err, errlen, "%s: %s", path, strerror(errno));
    memset(o, 0, sizeof *o);
    bool seen[WARPFILE_MAX_OBJECTS] = {false};
    for (int i = 0; i < WARPFILE_MAX_OBJECTS; i++) o->src[i] = o->dst[i] = warp_pose_identity();
    char line[512];
    int n = 0;
    bool ok = true;
    while (ok && fgets(line, sizeof line, f)) {
        n++;
        if (!strchr(line, '\n') && !feof(f)) {
            ok = warp_err(err, errlen, "%s:%d: line longer than %zu characters", path, n, sizeof line - 2);
            break;
        }
        char *s = line + strspn(line, " \t\r");
        if (*s == '#' || *s == '\n' || !*s) continue;
        int id, used = 0;
        if (strncmp(s, "object", 6) != 0 || sscanf(s + 6, "%d%n", &id, &used) != 1) {
            ok = warp_err(err, errlen, "%s:%d: expected 'object ID' then 7 or 14 numbers", path, n);
            break;
        }
        if (id < 1 || id > WARPFILE_MAX_OBJECTS || seen[id - 1]) {
            ok = warp_err(err, errlen, "%s:%d: id %d: %s", path, n, id,
                          id < 1 || id > WARPFILE_MAX_OBJECTS ? "outside 1..64" : "listed twice");
            break;
        }
        const char *rest = s + 6 + used;
        int u2 = 0;
        const char *why = warpfile_parse_pose(rest, UNIT_TOL, &o->src[id - 1], &u2);
        if (why) {
            ok = warp_err(err, errlen, "%s:%d: object %d: source pose: %s (expected qw qx qy qz x y z, a unit "
                          "quaternion)", path, n, id, why);
            break;
        }
        rest += u2;
        rest += strspn(rest, " \t\r");
        if (*rest && *rest != '\n' && *rest != '#') {
            if ((why = warpfile_parse_pose(rest, UNIT_TOL, &o->dst[id - 1], &u2))) {
                ok = warp_err(err, errlen, "%s:%d: object %d: target pose: %s (expected qw qx qy qz x y z, a unit "
                              "quaternion)", path, n, id, why);
                break;
            }
            rest += u2;
            rest += strspn(rest, " \t\r");
            if (*rest && *rest != '\n' && *rest != '#') {
                ok = warp_err(err, errlen, "%s:%d: object %d: more than 14 numbers", path, n, id);
                break;
            }
            o->has_target = true;
        } else {
            o->dst[id - 1] = o->src[id - 1];
        }
        seen[id - 1] = true;
        if (id > o->n) o->n = id;
    }
    fclose(f);
    return ok;
}

bool warpfile_write_objects(const char *path, int n, const warp_pose *src, const warp_pose *dst)
{
    FILE *f = fopen(path, "w");
    if (!f) return false;
    fprintf(f, "# hmdwarp objects (docs/hmdwarp-warp.md): world_from_object at the source time%s:\n"
               "# object ID  qw qx qy qz  x y z%s\n", dst ? " and at the target time" : "",
            dst ? "  qw qx qy qz  x y z" : "");
    for (int i = 0; i < n; i++) {
        fprintf(f, "object %d  %.17g %.17g %.17g %.17g  %.17g %.17g %.17g", i + 1, src[i].q.w, src[i].q.x,
                src[i].q.y, src[i].q.z, src[i].p.x, src[i].p.y, src[i].p.z);
        if (dst)
            fprintf(f, "  %.17g %.17g %.17g %.17g  %.17g %.17g %.17g", dst[i].q.w, dst[i].q.x, dst[i].q.y,
                    dst[i].q.z, dst[i].p.x, dst[i].p.y, dst[i].p.z);
        fputc('\n', f);
    }
    return fclose(f) == 0;
}

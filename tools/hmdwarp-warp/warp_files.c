/* SPDX-License-Identifier: MIT */
/* warp_files: hmdwarp-warp's input and output files other than PNG: the view file, PFM float images and the layers
 * (A-buffer) file, each checked against what the file holds before anything it declares is allocated. */
#include "warp_files.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

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

static bool read_pose(const char *rest, warp_pose *p)
{
    double v[7];
    if (sscanf(rest, "%lf %lf %lf %lf %lf %lf %lf", &v[0], &v[1], &v[2], &v[3], &v[4], &v[5], &v[6]) != 7) return false;
    /* A NaN or infinite position would reach the warps' ray arithmetic unchecked. */
    for (int i = 0; i < 7; i++)
        if (!isfinite(v[i])) return false;
    warp_quat q = {v[0], v[1], v[2], v[3]};
    if (!warp_quat_normalize(q, &p->q)) return false;
    p->p = warp_v3(v[4], v[5], v[6]);
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
        if (strcmp(key, "size") == 0) {
            ok = sscanf(rest, "%6d %6d", &vf->cam.width, &vf->cam.height) == 2; /* 6 digits: no int overflow */
            have_size = ok;
        } else if (strcmp(key, "tan") == 0) {
            ok = sscanf(rest, "%lf %lf %lf %lf", &vf->cam.tan_left, &vf->cam.tan_right, &vf->cam.tan_up,
                        &vf->cam.tan_down) == 4;
            have_proj = ok;
        } else if (strcmp(key, "intrinsics") == 0) {
            ok = sscanf(rest, "%lf %lf %lf %lf", &fx, &fy, &cx, &cy) == 4 && fx > 0 && fy > 0;
            have_proj = intr = ok;
        } else if (strcmp(key, "near") == 0) {
            ok = sscanf(rest, "%lf", &vf->cam.near_z) == 1;
        } else if (strcmp(key, "far") == 0) {
            ok = sscanf(rest, "%lf", &vf->cam.far_z) == 1; /* "inf" parses as infinity */
        } else if (strcmp(key, "source") == 0) {
            ok = have_src = read_pose(rest, &vf->src);
        } else if (strcmp(key, "target") == 0) {
            ok = have_dst = read_pose(rest, &vf->dst);
        } else {
            fclose(f);
            return warp_err(err, errlen, "%s:%d: unknown key '%s' (size, tan, intrinsics, near, far, source, "
                            "target)", path, n, key);
        }
        if (!ok) {
            fclose(f);
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


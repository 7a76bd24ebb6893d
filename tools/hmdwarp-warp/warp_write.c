/* SPDX-License-Identifier: MIT */
/* warp_write: hmdwarp-warp's files written from the simulator: one frame's inputs (--write-inputs, also a one-frame
 * sequence) and a multi-frame sequence (--write-sequence) that hmdwarp-feed --sequence plays. */
#include "warp_write.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "platform/plat_png.h"
#include "tools/common/seq_manifest.h"
#include "warp/warp_err.h"
#include "warp/warp_head.h"

/* Depth as PFM: the simulator's sky is +inf, which PFM readers choke on; 1e30 reads back as just as far. */
static bool write_depth(const char *path, const warp_image_f32 *depth)
{
    int w = depth->w, h = depth->h;
    float *d = malloc(sizeof(float) * (size_t)w * (size_t)h);
    if (!d) return false;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            float z = WARP_AT(depth, x, y);
            d[(size_t)y * w + x] = isfinite(z) ? z : 1e30f;
        }
    bool ok = warpfile_write_pfm(path, d, w, h, 1);
    free(d);
    return ok;
}

static bool write_ids(const char *path, const warp_image_u16 *ids, char *err, int errlen)
{
    int w = ids->w, h = ids->h;
    uint16_t *u = malloc(sizeof(uint16_t) * (size_t)w * (size_t)h);
    if (!u) return warp_err(err, errlen, "out of memory");
    for (int y = 0; y < h; y++) memcpy(u + (size_t)y * w, &WARP_AT(ids, 0, y), sizeof(uint16_t) * (size_t)w);
    bool ok = plat_png_write_u16(path, u, w, h, err, errlen);
    free(u);
    return ok;
}

/* The planes of one eye of one frame as DIR/PREFIXcolor.png, PREFIXdepth.pfm, ...; names[k] gets the file names
 * (relative to DIR) of the planes written. */
static bool write_planes(const char *dir, const char *prefix, const sim_buffers *b, unsigned planes,
                         char names[SEQ_KINDS][64], char *err, int errlen)
{
    static const char *const suffix[SEQ_KINDS] = {"color.png", "depth.pfm", "ids.png", "motion.pfm", "layers.bin"};
    for (int k = 0; k < SEQ_KINDS; k++) {
        if (!(planes & (1u << k))) continue;
        char p[1024];
        snprintf(names[k], 64, "%s%s", prefix, suffix[k]);
        snprintf(p, sizeof p, "%s/%s", dir, names[k]);
        bool ok = k == SEQ_COLOR    ? plat_png_write(p, &b->color, true, err, errlen)
                  : k == SEQ_DEPTH  ? write_depth(p, &b->depth)
                  : k == SEQ_IDS    ? write_ids(p, &b->ids, err, errlen)
                  : k == SEQ_MOTION ? warpfile_write_motion(p, &b->motion)
                                    : warpfile_write_layers(p, &b->layers);
        if (!ok) return k == SEQ_COLOR || k == SEQ_IDS ? false : warp_err(err, errlen, "cannot write %s", p);
    }
    return true;
}

bool warp_write_inputs(const char *dir, const warpfile_view *vf, const sim_buffers *sb, const sim_buffers *tb,
                       double t, int n_objects, const warp_pose *obj_src, const warp_pose *obj_dst, char *err,
                       int errlen)
{
    mkdir(dir, 0755);
    char p[1024], names[SEQ_KINDS][64];
    unsigned planes = DRV_PLANE_COLOR | DRV_PLANE_DEPTH | DRV_PLANE_IDS | DRV_PLANE_MOTION | DRV_PLANE_LAYERS;
    if (!write_planes(dir, "", sb, planes, names, err, errlen)) return false;
    snprintf(p, sizeof p, "%s/truth.png", dir);
    if (!plat_png_write(p, &tb->color, true, err, errlen)) return false;
    snprintf(p, sizeof p, "%s/objects.txt", dir);
    if (!warpfile_write_objects(p, n_objects, obj_src, obj_dst)) return warp_err(err, errlen, "cannot write %s", p);
    snprintf(p, sizeof p, "%s/view.txt", dir);
    FILE *f = fopen(p, "w");
    if (!f) return warp_err(err, errlen, "%s: %s", p, strerror(errno));
    fprintf(f, "# hmdwarp-warp view: right-handed, the camera looks down -Z, +Y up, +X right; poses are\n"
               "# world_from_eye: qw qx qy qz (unit quaternion) then position x y z in metres\n");
    fprintf(f, "size %d %d\ntan %.17g %.17g %.17g %.17g\nnear %.17g\nfar inf\n", vf->cam.width, vf->cam.height,
            vf->cam.tan_left, vf->cam.tan_right, vf->cam.tan_up, vf->cam.tan_down, vf->cam.near_z);
    warpfile_pose_line(f, "source", vf->src);
    warpfile_pose_line(f, "target", vf->dst);
    if (fclose(f) != 0) return warp_err(err, errlen, "cannot write %s", p);
    /* The same files as a one-frame sequence of one view (hmdwarp-feed --sequence sends it to both eyes). */
    seq_writer w;
    const warp_camera cams[2] = {vf->cam, vf->cam};
    const warp_pose poses[2] = {vf->src, vf->src};
    const char *files[2][SEQ_KINDS];
    for (int k = 0; k < SEQ_KINDS; k++) files[0][k] = files[1][k] = names[k];
    if (!seq_writer_open(&w, dir, 1, cams, WARP_DEPTH_LINEAR, planes, true, err, errlen)) return false;
    bool ok = seq_writer_frame(&w, t, poses, files, "objects.txt");
    if (!seq_writer_close(&w) || !ok) return warp_err(err, errlen, "cannot write %s/%s", dir, SEQ_MANIFEST_NAME);
    return true;
}

bool warp_write_sequence(const char *dir, const sim_scene *sc, const warpfile_view *vf, int n, double rate_hz,
                         double t0, char *err, int errlen)
{
    unsigned planes = SIM_PLANE_COLOR | SIM_PLANE_DEPTH | SIM_PLANE_IDS | SIM_PLANE_MOTION |
                      (sim_planes_for_effects(sim_scene_effects(sc)) & SIM_PLANE_LAYERS);
    sim_buffers b;
    memset(&b, 0, sizeof b);
    if (!sim_buffers_alloc(&b, vf->cam.width, vf->cam.height, planes, 8)) return warp_err(err, errlen, "out of memory");
    int n_obj = sim_scene_object_count(sc) < WARPFILE_MAX_OBJECTS ? sim_scene_object_count(sc) : WARPFILE_MAX_OBJECTS;
    warp_head head = warp_head_default();
    const warp_camera cams[2] = {vf->cam, vf->cam};
    seq_writer w;
    if (!seq_writer_open(&w, dir, 2, cams, WARP_DEPTH_LINEAR, planes, n_obj > 0, err, errlen)) {
        sim_buffers_free(&b);
        return false;
    }
    bool ok = true;
    for (int i = 0; i < n && ok; i++) {
        double a = n > 1 ? (double)i / (n - 1) : 0, t = t0 + i / rate_hz;
        warp_pose hp = {.q = warp_quat_slerp(vf->src.q, vf->dst.q, a),
                        .p = warp_v3(vf->src.p.x + a * (vf->dst.p.x - vf->src.p.x),
                                     vf->src.p.y + a * (vf->dst.p.y - vf->src.p.y),
                                     vf->src.p.z + a * (vf->dst.p.z - vf->src.p.z))};
        warp_pose eye[2];
        char names[2][SEQ_KINDS][64], obj[64];
        const char *files[2][SEQ_KINDS];
        for (int e = 0; e < 2 && ok; e++) {
            eye[e] = warp_head_eye_pose(&head, hp, e);
            sim_render(sc, t, eye[e], &vf->cam, planes, &b);
            char prefix[32];
            snprintf(prefix, sizeof prefix, "%04d-%s-", i, e ? "right" : "left");
            ok = write_planes(dir, prefix, &b, planes, names[e], err, errlen);
            for (int k = 0; k < SEQ_KINDS; k++) files[e][k] = names[e][k];
        }
        if (ok && n_obj > 0) {
            warp_pose op[WARPFILE_MAX_OBJECTS];
            for (int k = 0; k < n_obj; k++) op[k] = sim_scene_object_pose(sc, k + 1, t);
            char p[1024];
            snprintf(obj, sizeof obj, "%04d-objects.txt", i);
            snprintf(p, sizeof p, "%s/%s", dir, obj);
            ok = warpfile_write_objects(p, n_obj, op, NULL) || warp_err(err, errlen, "cannot write %s", p);
        }
        ok = ok && seq_writer_frame(&w, t, eye, files, n_obj > 0 ? obj : NULL);
    }
    if (!seq_writer_close(&w) && ok) ok = warp_err(err, errlen, "cannot write %s/%s", dir, SEQ_MANIFEST_NAME);
    sim_buffers_free(&b);
    return ok;
}

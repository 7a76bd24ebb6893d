/* SPDX-License-Identifier: MIT */
/* seq_manifest: recorded frame sequences (docs/sequences.md): a directory of per-frame, per-eye colour and optional
 * depth, ids, motion and layers files with their poses and times in a manifest; parsed, validated, written, loaded. */
#ifndef TOOLS_SEQ_MANIFEST_H
#define TOOLS_SEQ_MANIFEST_H

#include <stdbool.h>
#include <stdio.h>

#include "drivers/drv_frames.h"
#include "warp/warp_camera.h"
#include "warp/warp_math.h"

#define SEQ_MANIFEST_NAME "manifest.txt"
#define SEQ_VERSION 1
/* Tolerance on a unit quaternion's length: float matrices give about 1e-7; more means the columns are wrong
 * (w last, a typo) and normalising would hide it. */
#define SEQ_UNIT_TOL 1e-3

/* The per-eye files of a frame, in the order of the DRV_PLANE_* bits. */
enum { SEQ_COLOR, SEQ_DEPTH, SEQ_IDS, SEQ_MOTION, SEQ_LAYERS, SEQ_KINDS };

typedef struct {
    int line;                      /* of the manifest, for messages */
    double time;                   /* seconds: the display time the frame was rendered for */
    warp_pose pose[2];             /* world_from_eye per eye (one eye: both the same) */
    char *file[2][SEQ_KINDS];      /* paths (the manifest's directory prepended), NULL where the column is absent */
    char *objects;                 /* object-pose file (warp_files.h), or NULL */
} seq_frame;

typedef struct {
    char *path;                    /* of the manifest */
    int eyes;                      /* 1: one view, sent to both eyes; 2: stereo */
    warp_camera cam[2];
    warp_depth_encoding depth_encoding;
    bool depth_ray;                /* depth files hold distance along the ray (converted to planar z on loading) */
    double depth_scale;            /* linear depth * scale = metres */
    int max_layers;
    unsigned planes;               /* DRV_PLANE_* every frame carries */
    bool objects;
    int n;
    seq_frame *frames;
} seq_manifest;

/* Reads and checks DIR/manifest.txt (or a manifest file given directly): every field, every pose finite with a unit
 * quaternion, times increasing, every file present. False with a message naming the file, line and field; nothing
 * stays allocated then. */
bool seq_open(const char *path, seq_manifest *m, char *err, int errlen);
void seq_close(seq_manifest *m);

/* Loads frame i into f, allocated by drv_frame_alloc(f, cam width, height, planes, m->max_layers): the planes of
 * m->planes & planes (colour always), cameras, poses, depth encoding, object poses (source time), scene_time = the
 * frame's time. False with a message naming the file (and the manifest's line) when a file is unreadable or the
 * wrong size. */
bool seq_load_frame(const seq_manifest *m, int i, unsigned planes, drv_frame *f, char *err, int errlen);

/* Writes a manifest: the header from the arguments, then one line per seq_writer_frame. files[e][kind] are names
 * relative to the manifest's directory; the kinds in planes (DRV_PLANE_*) must be given for every frame. */
typedef struct {
    FILE *f;
    int eyes, n;
    unsigned planes;
    bool objects;
} seq_writer;
bool seq_writer_open(seq_writer *w, const char *dir, int eyes, const warp_camera cam[2], warp_depth_encoding enc,
                     unsigned planes, bool objects, char *err, int errlen);
bool seq_writer_frame(seq_writer *w, double time, const warp_pose pose[2], const char *const files[2][SEQ_KINDS],
                      const char *objects);
bool seq_writer_close(seq_writer *w);

#endif

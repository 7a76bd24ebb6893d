/* SPDX-License-Identifier: MIT */
/* feed_sequence: hmdwarp-feed's recorded-sequence content source (--sequence DIR, docs/sequences.md): the frames of
 * a manifest with the poses they were rendered at, at the manifest's pace or one per board pose, once or looping. */
#ifndef FEED_SEQUENCE_H
#define FEED_SEQUENCE_H

#include <stdbool.h>

#include "drivers/drv_frames.h"

typedef struct feed_sequence feed_sequence;

/* rate: "own" (each frame at its manifest time after the first frame's send) or "board" (one frame per pose message
 * the caller takes; no waiting here). NULL with the message (naming the manifest's line and field) when the
 * manifest is bad or rate is neither. */
feed_sequence *feed_sequence_open(const char *dir, const char *rate, bool loop, char *err, int errlen);
/* What to allocate the frame with: the manifest's eye size, its planes among want (colour always) and its layer
 * limit (drv_frame_alloc(f, *w, *h, *planes, *max_layers)). */
void feed_sequence_shape(feed_sequence *s, unsigned want, int *w, int *h, unsigned *planes, int *max_layers);
/* Loads the first frame into f (a bad file fails before the link starts) and sets f->n_objects to the most a frame
 * may carry, so the encoder's buffer sized from f holds every frame. False with the message. */
bool feed_sequence_prepare(feed_sequence *s, drv_frame *f, char *err, int errlen);
/* The next frame into f: its planes, cameras, eye poses and object poses (f->seq and f->pose_t_ns stay the caller's).
 * At the sequence's own rate it first sleeps until the frame is due. 1: a frame; 0: the sequence ended (not
 * looping); -1: a file could not be loaded (err). */
int feed_sequence_next(feed_sequence *s, drv_frame *f, char *err, int errlen);
void feed_sequence_close(feed_sequence *s);

#endif

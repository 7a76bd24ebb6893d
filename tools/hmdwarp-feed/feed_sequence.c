/* SPDX-License-Identifier: MIT */
/* feed_sequence: hmdwarp-feed's recorded-sequence content source (--sequence DIR, docs/sequences.md): the frames of
 * a manifest with the poses they were rendered at, at the manifest's pace or one per board pose, once or looping. */
#include "feed_sequence.h"

#include <stdlib.h>
#include <string.h>

#include "platform/plat_clock.h"
#include "tools/common/seq_manifest.h"
#include "warp/warp_err.h"

struct feed_sequence {
    seq_manifest m;
    bool own_rate, loop;
    unsigned planes;
    int next;              /* frame to send next */
    long laps;             /* times the sequence wrapped */
    double lap_s;          /* a lap's length at its own rate: first to last frame plus one mean frame interval */
    int64_t start_ns;      /* own rate: when frame 0 of lap 0 was due (0: not started) */
};

feed_sequence *feed_sequence_open(const char *dir, const char *rate, bool loop, char *err, int errlen)
{
    bool own = strcmp(rate, "own") == 0;
    if (!own && strcmp(rate, "board") != 0)
        return warp_err(err, errlen, "--sequence-rate %s: own or board", rate), NULL;
    feed_sequence *s = calloc(1, sizeof *s);
    if (!s) return warp_err(err, errlen, "out of memory"), NULL;
    if (!seq_open(dir, &s->m, err, errlen)) return free(s), NULL;
    const seq_manifest *m = &s->m;
    /* One frame has no pace of its own: it goes out at the board's. */
    s->own_rate = own && m->n > 1;
    s->loop = loop;
    s->planes = m->planes;
    if (m->n > 1) {
        double span = m->frames[m->n - 1].time - m->frames[0].time;
        s->lap_s = span + span / (m->n - 1);
    }
    return s;
}

void feed_sequence_shape(feed_sequence *s, unsigned want, int *w, int *h, unsigned *planes, int *max_layers)
{
    s->planes = (s->m.planes & want) | DRV_PLANE_COLOR;
    *w = s->m.cam[0].width;
    *h = s->m.cam[0].height;
    *planes = s->planes;
    *max_layers = s->m.max_layers;
}

bool feed_sequence_prepare(feed_sequence *s, drv_frame *f, char *err, int errlen)
{
    if (!seq_load_frame(&s->m, 0, s->planes, f, err, errlen)) return false;
    if (s->m.objects) f->n_objects = DRV_MAX_OBJECTS;
    return true;
}

int feed_sequence_next(feed_sequence *s, drv_frame *f, char *err, int errlen)
{
    const seq_manifest *m = &s->m;
    if (s->next == m->n) {
        if (!s->loop) return 0;
        s->next = 0;
        s->laps++;
    }
    int i = s->next++;
    if (!seq_load_frame(m, i, s->planes, f, err, errlen)) return -1;
    /* Loaded first, then held until due: the decode does not delay the frame. */
    if (s->own_rate) {
        double due = (m->frames[i].time - m->frames[0].time) + (double)s->laps * s->lap_s;
        if (!s->start_ns)
            s->start_ns = plat_now_ns();
        else
            plat_sleep_until_ns(s->start_ns + (int64_t)(due * 1e9));
    }
    return 1;
}

void feed_sequence_close(feed_sequence *s)
{
    if (!s) return;
    seq_close(&s->m);
    free(s);
}

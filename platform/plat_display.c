/* SPDX-License-Identifier: MIT */
/* plat_display: where composited panel images go: a swapchain of panel-sized buffers and display sinks (null,
 * PNG snapshots, raw stream; KMS on a board). Presenting never blocks and never does I/O on the vsync path. */
#include "platform/plat_display.h"

#include <errno.h>
#include <pthread.h>
#include <semaphore.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#include "platform/plat_png.h"
#include "warp/warp_err.h"

bool plat_swapchain_alloc(plat_swapchain *sc, int count, int w, int h)
{
    memset(sc, 0, sizeof *sc);
    if (count < 2 || count > PLAT_SWAPCHAIN_MAX) return false;
    for (int i = 0; i < count; i++) {
        if (!warp_image_rgba8_alloc(&sc->img[i], w, h)) {
            plat_swapchain_free(sc);
            return false;
        }
        warp_image_rgba8_fill(&sc->img[i], (warp_rgba8){0, 0, 0, 255});
        sc->count = i + 1;
    }
    sc->on_screen = sc->prev = -1;
    sc->prev_until_ns = 0;
    return true;
}

int plat_swapchain_next(plat_swapchain *sc, int64_t now_ns)
{
    for (int k = 1; k <= sc->count; k++) {
        int i = (sc->on_screen + k + sc->count) % sc->count;
        if (i != sc->on_screen && !(i == sc->prev && now_ns < sc->prev_until_ns) &&
            !atomic_load_explicit(&sc->held[i], memory_order_acquire))
            return i;
    }
    return -1;
}

void plat_swapchain_presented(plat_swapchain *sc, int index, int64_t vsync_ns)
{
    sc->prev = sc->on_screen;
    sc->prev_until_ns = vsync_ns;
    sc->on_screen = index;
}

void plat_swapchain_free(plat_swapchain *sc)
{
    for (int i = 0; i < PLAT_SWAPCHAIN_MAX; i++) warp_image_free(&sc->img[i]);
    sc->count = 0;
}

/* ---- null ---- */

static void null_present(plat_display *d, plat_swapchain *sc, int index, int64_t vsync_ns, uint64_t vsync_no)
{
    (void)d;
    (void)sc;
    (void)index;
    (void)vsync_ns;
    (void)vsync_no;
}
static void null_describe(plat_display *d, char *buf, int len)
{
    (void)d;
    snprintf(buf, (size_t)len, "null display (frames discarded)");
}
static void null_destroy(plat_display *d) { free(d); }

plat_display *plat_display_null_create(void)
{
    plat_display *d = calloc(1, sizeof *d);
    if (!d) return NULL;
    d->name = "null";
    d->present = null_present;
    d->describe = null_describe;
    d->destroy = null_destroy;
    return d;
}

/* ---- files (png snapshots / raw stream) ---- */

typedef struct {
    plat_display base;
    bool raw;
    char dir[512];
    int every;
    sem_t go;
    pthread_t th;
    _Atomic int busy;
    _Atomic int quit;
    /* job handed from present() to the writer; valid while busy */
    plat_swapchain *sc;
    int index;
    uint64_t vsync_no;
    /* results, read after the writer has stopped (or racily for the summary) */
    _Atomic long written, skipped, failed;
    char last_error[256];
    FILE *raw_file;
    int w, h;
} files_display;

static void *files_writer(void *arg)
{
    files_display *f = arg;
    for (;;) {
        while (sem_wait(&f->go) != 0 && errno == EINTR) {
        }
        if (atomic_load(&f->quit) && !atomic_load(&f->busy)) return NULL;
        const warp_image_rgba8 *img = &f->sc->img[f->index];
        char err[256] = "";
        bool ok;
        if (f->raw) {
            ok = true;
            for (int y = 0; y < img->h && ok; y++)
                ok = fwrite(&WARP_AT(img, 0, y), sizeof(warp_rgba8), (size_t)img->w, f->raw_file) == (size_t)img->w;
            if (!ok) snprintf(err, sizeof err, "write to frames.rgba failed: %s", strerror(errno));
            f->w = img->w;
            f->h = img->h;
        } else {
            char path[600];
            snprintf(path, sizeof path, "%s/frame_%06llu.png", f->dir, (unsigned long long)f->vsync_no);
            ok = plat_png_write(path, img, true, err, sizeof err);
        }
        atomic_store_explicit(&f->sc->held[f->index], 0, memory_order_release);
        if (ok) {
            atomic_fetch_add(&f->written, 1);
        } else {
            atomic_fetch_add(&f->failed, 1);
            memcpy(f->last_error, err, sizeof err);
        }
        atomic_store_explicit(&f->busy, 0, memory_order_release);
        if (atomic_load(&f->quit)) return NULL;
    }
}

static void files_present(plat_display *d, plat_swapchain *sc, int index, int64_t vsync_ns, uint64_t vsync_no)
{
    files_display *f = (files_display *)d;
    (void)vsync_ns;
    if (vsync_no % (uint64_t)f->every != 0) return;
    if (atomic_load_explicit(&f->busy, memory_order_acquire)) {
        atomic_fetch_add(&f->skipped, 1);
        return;
    }
    atomic_store_explicit(&sc->held[index], 1, memory_order_release);
    f->sc = sc;
    f->index = index;
    f->vsync_no = vsync_no;
    atomic_store_explicit(&f->busy, 1, memory_order_release);
    sem_post(&f->go); /* never blocks */
}

static void files_flush(plat_display *d)
{
    files_display *f = (files_display *)d;
    while (atomic_load_explicit(&f->busy, memory_order_acquire)) {
        struct timespec ts = {0, 1000000};
        nanosleep(&ts, NULL);
    }
}

static void files_describe(plat_display *d, char *buf, int len)
{
    files_display *f = (files_display *)d;
    int n;
    if (f->raw)
        n = snprintf(buf, (size_t)len, "raw stream %s/frames.rgba: %ld frames of %dx%d RGBA8 (every %d vsyncs)", f->dir,
                     atomic_load(&f->written), f->w, f->h, f->every);
    else
        n = snprintf(buf, (size_t)len, "PNG snapshots in %s: %ld written (every %d vsyncs)", f->dir,
                     atomic_load(&f->written), f->every);
    if (n > 0 && n < len && (atomic_load(&f->skipped) || atomic_load(&f->failed)))
        snprintf(buf + n, (size_t)(len - n), ", %ld skipped (writer busy), %ld failed%s%s", atomic_load(&f->skipped),
                 atomic_load(&f->failed), f->last_error[0] ? ": " : "", f->last_error);
}

static void files_destroy(plat_display *d)
{
    files_display *f = (files_display *)d;
    atomic_store(&f->quit, 1);
    sem_post(&f->go);
    pthread_join(f->th, NULL);
    sem_destroy(&f->go);
    if (f->raw_file) fclose(f->raw_file);
    free(f);
}

plat_display *plat_display_files_create(const char *kind, const char *dir, int every, char *err, int errlen)
{
    bool raw = strcmp(kind, "raw") == 0;
    if (!raw && strcmp(kind, "png") != 0) {
        warp_err(err, errlen, "unknown file sink '%s' (expected png or raw)", kind);
        return NULL;
    }
    if (every < 1) {
        warp_err(err, errlen, "sink_every must be at least 1 (got %d)", every);
        return NULL;
    }
    if (mkdir(dir, 0755) != 0 && errno != EEXIST) {
        warp_err(err, errlen, "cannot create sink directory %s: %s", dir, strerror(errno));
        return NULL;
    }
    files_display *f = calloc(1, sizeof *f);
    if (!f) {
        warp_err(err, errlen, "out of memory");
        return NULL;
    }
    f->raw = raw;
    snprintf(f->dir, sizeof f->dir, "%s", dir);
    f->every = every;
    if (raw) {
        char path[600];
        snprintf(path, sizeof path, "%s/frames.rgba", dir);
        f->raw_file = fopen(path, "wb");
        if (!f->raw_file) {
            warp_err(err, errlen, "cannot create %s: %s", path, strerror(errno));
            free(f);
            return NULL;
        }
    }
    sem_init(&f->go, 0, 0);
    if (pthread_create(&f->th, NULL, files_writer, f) != 0) {
        warp_err(err, errlen, "cannot start the sink writer thread");
        sem_destroy(&f->go);
        if (f->raw_file) fclose(f->raw_file);
        free(f);
        return NULL;
    }
    f->base.name = raw ? "raw" : "png";
    f->base.present = files_present;
    f->base.flush = files_flush;
    f->base.describe = files_describe;
    f->base.destroy = files_destroy;
    return &f->base;
}

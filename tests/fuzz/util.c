/* SPDX-License-Identifier: MIT */
/* Helpers shared by the fuzz harnesses: inputs as files (memfd), bounded little-endian reads, the example frame the
 * seeds are encoded from, and writing a seed. */
#include "tests/fuzz/fuzz.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

const char *fuzz_file(const uint8_t *data, size_t size)
{
    static int fd = -1;
    static char path[64];
    if (fd < 0) {
        fd = memfd_create("hmdwarp-fuzz", MFD_CLOEXEC);
        if (fd < 0) {
            perror("fuzz: memfd_create");
            abort();
        }
        snprintf(path, sizeof path, "/proc/self/fd/%d", fd);
    }
    if (ftruncate(fd, 0) != 0 || (size && pwrite(fd, data, size, 0) != (ssize_t)size)) {
        perror("fuzz: memfd write");
        abort();
    }
    return path;
}

uint8_t fuzz_u8(fuzz_in *in)
{
    if (!in->n) return 0;
    in->n--;
    return *in->p++;
}
uint32_t fuzz_u32(fuzz_in *in)
{
    uint32_t v = 0;
    for (int i = 0; i < 4; i++) v |= (uint32_t)fuzz_u8(in) << (8 * i);
    return v;
}
uint64_t fuzz_u64(fuzz_in *in)
{
    uint64_t lo = fuzz_u32(in);
    return lo | (uint64_t)fuzz_u32(in) << 32;
}
double fuzz_f64(fuzz_in *in)
{
    uint64_t v = fuzz_u64(in);
    double d;
    memcpy(&d, &v, sizeof d);
    return d;
}

void fuzz_example_frame(drv_frame *f, unsigned planes, int seed)
{
    if (!drv_frame_alloc(f, FUZZ_EYE_W, FUZZ_EYE_H, planes, FUZZ_MAX_LAYERS)) abort();
    f->planes = planes;
    f->seq = 1000 + (uint64_t)seed;
    f->pose_t_ns = 5000000000LL + seed;
    f->render_start_ns = 4990000000LL;
    f->depth_encoding = (warp_depth_encoding)(seed % 3);
    f->scene_time = 0.25 * seed;
    f->n_objects = seed % 3;
    for (int e = 0; e < 2; e++) {
        f->cam[e] = (warp_camera){FUZZ_EYE_W, FUZZ_EYE_H, 1.0, 1.0, 0.8, 0.8, 0.05, 100.0};
        f->eye_pose[e] = (warp_pose){{1, 0, 0, 0}, {e ? 0.032 : -0.032, 1.6, 0}};
    }
    for (int i = 0; i < f->n_objects; i++) f->object_pose[i] = (warp_pose){{0, 1, 0, 0}, {i, 0, -2}};
    for (int e = 0; e < 2; e++)
        for (int y = 0; y < FUZZ_EYE_H; y++)
            for (int x = 0; x < FUZZ_EYE_W; x++) {
                int v = x * 31 + y * 17 + e * 7 + seed;
                if (planes & DRV_PLANE_COLOR)
                    WARP_AT(&f->color[e], x, y) = (warp_rgba8){(uint8_t)v, (uint8_t)(v * 3), (uint8_t)(v * 5), 255};
                /* window depth in (0, 1] for the standard/reversed encodings, metres for linear */
                if (planes & DRV_PLANE_DEPTH)
                    WARP_AT(&f->depth[e], x, y) = f->depth_encoding ? 0.5f + 0.01f * (float)x : 1.0f + (float)y;
                if (planes & DRV_PLANE_IDS) WARP_AT(&f->ids[e], x, y) = (uint16_t)((x + y) % 3);
                if (planes & DRV_PLANE_MOTION) WARP_AT(&f->motion[e], x, y) = (warp_vec2f){(float)x, -(float)y};
                if (planes & DRV_PLANE_LAYERS) {
                    warp_image_layers *l = &f->layers[e];
                    size_t i = (size_t)y * FUZZ_EYE_W + x;
                    l->count[i] = (uint8_t)((x + y + seed) % (FUZZ_MAX_LAYERS + 1));
                    for (int k = 0; k < l->count[i]; k++)
                        l->frag[i * FUZZ_MAX_LAYERS + k] =
                            (warp_fragment){.z = 1.0f + (float)k, .rgba = {(uint8_t)v, 0, 0, 128}, .id = (uint16_t)k};
                }
            }
}

const char *fuzz_seed_dir = ".";

void fuzz_seed(const char *name, const void *data, size_t size)
{
    char path[512];
    snprintf(path, sizeof path, "%s/seed-%s", fuzz_seed_dir, name);
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(data, 1, size, f) != size || fclose(f) != 0) {
        fprintf(stderr, "fuzz seeds: cannot write %s: %s\n", path, strerror(errno));
        exit(1);
    }
}

void fuzz_seed_tagged(const char *name, uint8_t tag, const void *data, size_t size)
{
    uint8_t *b = malloc(size + 1);
    if (!b) abort();
    b[0] = tag;
    memcpy(b + 1, data, size);
    fuzz_seed(name, b, size + 1);
    free(b);
}

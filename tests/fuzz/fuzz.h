/* SPDX-License-Identifier: MIT */
/* Fuzz harnesses of every decoder of outside bytes: each fuzz_NAME.c defines LLVMFuzzerTestOneInput (libFuzzer with
 * clang in `make fuzz`; standalone.c replays the checked-in corpus with it in `make test`) and a seed writer. */
#ifndef HMDWARP_FUZZ_H
#define HMDWARP_FUZZ_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "drivers/drv_frames.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* The harness's seeds, made by the project's own encoders (seeds_main.c: `seeds_NAME DIR`): fuzz_seed() for each. */
void fuzz_write_seeds(void);
/* Saves one seed as fuzz_seed_dir/seed-NAME. */
extern const char *fuzz_seed_dir;
void fuzz_seed(const char *name, const void *data, size_t size);
/* Saves one seed as a leading tag byte (the harness's mode or format selector) and then the data. */
void fuzz_seed_tagged(const char *name, uint8_t tag, const void *data, size_t size);

/* The bytes as a file the readers can open by name (a memfd: no disk I/O); valid until the next call. */
const char *fuzz_file(const uint8_t *data, size_t size);

/* The eye size and planes the frame harnesses allocate (and the seeds are encoded at). */
#define FUZZ_EYE_W 8
#define FUZZ_EYE_H 6
#define FUZZ_MAX_LAYERS 4
#define FUZZ_PLANES (DRV_PLANE_COLOR | DRV_PLANE_DEPTH | DRV_PLANE_IDS | DRV_PLANE_MOTION | DRV_PLANE_LAYERS)
/* A small valid frame of that size with every plane filled from seed (for the encoders writing seeds). */
void fuzz_example_frame(drv_frame *f, unsigned planes, int seed);

/* Little-endian reads that never run past the input (missing bytes read as zero). */
typedef struct {
    const uint8_t *p;
    size_t n;
} fuzz_in;
uint8_t fuzz_u8(fuzz_in *in);
uint32_t fuzz_u32(fuzz_in *in);
uint64_t fuzz_u64(fuzz_in *in);
double fuzz_f64(fuzz_in *in);

#endif

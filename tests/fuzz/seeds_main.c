/* SPDX-License-Identifier: MIT */
/* Writes one fuzz harness's seed inputs (made by the project's own encoders) into a directory: `seeds_NAME DIR`.
 * `make fuzz` seeds each harness's working corpus with them. */
#include <stdio.h>
#include <sys/stat.h>

#include "tests/fuzz/fuzz.h"

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: %s DIR\n", argv[0]);
        return 2;
    }
    fuzz_seed_dir = argv[1];
    mkdir(fuzz_seed_dir, 0777);
    fuzz_write_seeds();
    return 0;
}

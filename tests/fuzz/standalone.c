/* SPDX-License-Identifier: MIT */
/* Replays a fuzz harness's checked-in corpus without libFuzzer (gcc, `make test`, `make asan`): every file of
 * tests/fuzz/corpus/NAME (NAME from the program's name, fuzz_NAME), or the files and directories given, through
 * LLVMFuzzerTestOneInput. One TAP test per harness; a crash loses it, and the log names the input that ran last. */
#include <dirent.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "tests/fuzz/fuzz.h"

#ifndef FUZZ_CORPUS
#define FUZZ_CORPUS "tests/fuzz/corpus"
#endif

static int run_file(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        printf("# %s: %s\n", path, strerror(errno));
        return -1;
    }
    size_t cap = 1 << 16, n = 0;
    uint8_t *buf = malloc(cap);
    size_t got;
    while (buf && (got = fread(buf + n, 1, cap - n, f)) > 0) {
        n += got;
        if (n == cap) buf = realloc(buf, cap *= 2);
    }
    fclose(f);
    if (!buf) return -1;
    printf("# input %s (%zu bytes)\n", path, n);
    fflush(stdout); /* a crash in the harness leaves this as the last line of the log */
    /* An exact-size copy, so the sanitizers see a read past the input as one. */
    uint8_t *exact = malloc(n ? n : 1);
    memcpy(exact, buf, n);
    free(buf);
    LLVMFuzzerTestOneInput(exact, n);
    free(exact);
    return 0;
}

static int cmp(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

/* Runs every regular file of dir (sorted, so logs compare); the count, or -1. */
static int run_dir(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d) {
        printf("# %s: %s\n", dir, strerror(errno));
        return -1;
    }
    char **names = NULL;
    int n = 0, cap = 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (e->d_name[0] == '.') continue;
        if (n == cap) names = realloc(names, sizeof *names * (size_t)(cap = cap ? 2 * cap : 64));
        names[n++] = strdup(e->d_name);
    }
    closedir(d);
    qsort(names, (size_t)n, sizeof *names, cmp);
    int ran = 0;
    for (int i = 0; i < n; i++) {
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", dir, names[i]);
        struct stat st;
        if (stat(path, &st) == 0 && S_ISREG(st.st_mode) && run_file(path) == 0) ran++;
        free(names[i]);
    }
    free(names);
    return ran;
}

int main(int argc, char **argv)
{
    const char *base = strrchr(argv[0], '/');
    base = base ? base + 1 : argv[0];
    const char *name = strncmp(base, "fuzz_", 5) == 0 ? base + 5 : base;
    printf("1..1\n");
    int ran = 0;
    bool bad = false;
    if (argc > 1) {
        for (int i = 1; i < argc; i++) {
            struct stat st;
            int r = stat(argv[i], &st) == 0 && S_ISDIR(st.st_mode) ? run_dir(argv[i]) : run_file(argv[i]) == 0;
            if (r < 0) bad = true; else ran += r;
        }
    } else {
        char dir[1024];
        snprintf(dir, sizeof dir, "%s/%s", FUZZ_CORPUS, name);
        ran = run_dir(dir);
        bad = ran <= 0; /* a harness without its corpus tests nothing: that is a failure, not a pass */
    }
    printf("%s 1 - %s: %d inputs replayed without a crash or sanitizer report\n", bad ? "not ok" : "ok", name,
           ran > 0 ? ran : 0);
    return bad ? 1 : 0;
}

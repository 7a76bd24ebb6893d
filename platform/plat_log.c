/* SPDX-License-Identifier: MIT */
/* plat_log: the daemon's log lines with journal priorities: "<N>" prefixes (sd-daemon.h) when stderr is the
 * journal, plain "program: message" text otherwise. For helper threads and setup; never for the vsync path. */
#include "platform/plat_log.h"

#include <errno.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* -1: not decided yet. The environment is read once: getenv is not safe beside a thread calling setenv. */
static atomic_int journal = -1;

int plat_log_to_journal(void)
{
    int j = atomic_load(&journal);
    if (j >= 0) return j;
    /* systemd sets JOURNAL_STREAM=DEV:INODE for a unit whose stderr is the journal; a child whose stderr was
     * redirected inherits the variable, so it counts only while stderr is still that stream (systemd.exec(5)) */
    j = 0;
    const char *e = getenv("JOURNAL_STREAM");
    unsigned long long dev, ino;
    struct stat st;
    if (e && sscanf(e, "%llu:%llu", &dev, &ino) == 2 && fstat(STDERR_FILENO, &st) == 0 &&
        (unsigned long long)st.st_dev == dev && (unsigned long long)st.st_ino == ino)
        j = 1;
    atomic_store(&journal, j);
    return j;
}

void plat_log_reset(void) { atomic_store(&journal, -1); }

void plat_log(plat_log_level level, const char *fmt, ...)
{
    int saved = errno; /* callers format strerror(errno) after logging something else */
    char line[1024];
    int n = 0;
    if (level < PLAT_LOG_ERR) level = PLAT_LOG_ERR;
    if (level > PLAT_LOG_DEBUG) level = PLAT_LOG_DEBUG;
    /* the journal takes the priority from "<N>" and shows the rest; a terminal gets the program's name */
    if (plat_log_to_journal())
        n = snprintf(line, sizeof line, "<%d>", (int)level);
    else
        n = snprintf(line, sizeof line, "%s: ", program_invocation_short_name);
    va_list ap;
    va_start(ap, fmt);
    int m = vsnprintf(line + n, sizeof line - (size_t)n - 1, fmt, ap);
    va_end(ap);
    if (m < 0) m = 0;
    n += m;
    if (n > (int)sizeof line - 2) n = (int)sizeof line - 2;
    line[n++] = '\n';
    for (int off = 0; off < n;) {
        ssize_t w = write(STDERR_FILENO, line + off, (size_t)(n - off));
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) break;
        off += (int)w;
    }
    errno = saved;
}

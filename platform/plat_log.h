/* SPDX-License-Identifier: MIT */
/* plat_log: the daemon's log lines with journal priorities: "<N>" prefixes (sd-daemon.h) when stderr is the
 * journal, plain "program: message" text otherwise. For helper threads and setup; never for the vsync path. */
#ifndef PLAT_LOG_H
#define PLAT_LOG_H

/* syslog(3) priorities, as the journal reads them */
typedef enum {
    PLAT_LOG_ERR = 3,     /* the run cannot do what was asked */
    PLAT_LOG_WARNING = 4, /* something is wrong and was worked around (a device lost, input rejected) */
    PLAT_LOG_NOTICE = 5,  /* normal but worth seeing (a device back) */
    PLAT_LOG_INFO = 6,
    PLAT_LOG_DEBUG = 7,
} plat_log_level;

/* One line to stderr, "<program>: " first, the newline added; written with a single write(2) so lines from
 * several threads never interleave. Lines over 1 KB are cut. */
void plat_log(plat_log_level level, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* Whether stderr is the journal (JOURNAL_STREAM names stderr's device and inode), as plat_log decides it. Read
 * once, on the first line logged; plat_log_reset() forgets the answer (tests that move stderr). */
int plat_log_to_journal(void);
void plat_log_reset(void);

#endif

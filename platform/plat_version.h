/* SPDX-License-Identifier: MIT */
/* plat_version: hmdwarp's version string (VERSION, git describe, or the Debian package version; see
 * scripts/version.sh), for --version, the run summary and the stats file. */
#ifndef PLAT_VERSION_H
#define PLAT_VERSION_H

/* A static string such as "0.1.0" or "0.1.0+git.4409396.dirty". */
const char *plat_version(void);

#endif

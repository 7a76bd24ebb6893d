/* SPDX-License-Identifier: MIT */
/* plat_version: the only object that holds the version string, so a new commit recompiles this file and relinks
 * rather than rebuilding everything. The Makefile generates hmdwarp_version.h under $(BUILD)/gen. */
#include "platform/plat_version.h"

#include "hmdwarp_version.h"

const char *plat_version(void)
{
    return HMDWARP_VERSION;
}

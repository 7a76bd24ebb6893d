#!/bin/sh
# SPDX-License-Identifier: MIT
# Prints hmdwarp's version: $HMDWARP_VERSION when set (a Debian build passes the package version), else
# `git describe` when a v* tag exists, else VERSION + "+git.<short sha>[.dirty]", else VERSION alone (a tarball).
# usage: scripts/version.sh [SOURCE_DIR]
set -eu
src=${1:-$(dirname "$0")/..}
if [ -n "${HMDWARP_VERSION:-}" ]; then
    # It becomes a C string and a file name part: only what Debian allows in a version.
    case $HMDWARP_VERSION in
    *[!A-Za-z0-9.+~:-]*)
        echo "version.sh: HMDWARP_VERSION '$HMDWARP_VERSION': only A-Z a-z 0-9 . + ~ : - allowed" >&2
        exit 1
        ;;
    esac
    echo "$HMDWARP_VERSION"
    exit 0
fi
base=$(cat "$src/VERSION")
# Only the checkout's own repository counts: a source copy unpacked inside another git tree (a build directory
# under this checkout, a distribution's packaging repository) must not take that tree's commit.
top=$(git -C "$src" rev-parse --show-toplevel 2>/dev/null || true)
if [ -n "$top" ] && [ "$(cd "$top" && pwd -P)" = "$(cd "$src" && pwd -P)" ]; then
    if v=$(git -C "$src" describe --tags --dirty --match 'v[0-9]*' 2>/dev/null); then
        echo "${v#v}"
        exit 0
    fi
    sha=$(git -C "$src" rev-parse --short HEAD 2>/dev/null || true)
    if [ -n "$sha" ]; then
        git -C "$src" update-index -q --refresh >/dev/null 2>&1 || true
        dirty=""
        git -C "$src" diff-index --quiet HEAD -- 2>/dev/null || dirty=.dirty
        echo "$base+git.$sha$dirty"
        exit 0
    fi
fi
echo "$base"

#!/bin/sh
# SPDX-License-Identifier: MIT
# Installs what `make deb` needs on Debian 12 beyond board/deps.sh: debhelper, dpkg-dev, fakeroot, lintian (and
# help2man, also in deps.sh); with ARCH=arm64 (a cross build), crossbuild-essential-arm64 and board/deps-cross.sh's
# cross compilers and arm64 -dev packages. As root it runs apt-get; otherwise it prints the command and fails.
set -eu
PKGS="debhelper dpkg-dev fakeroot lintian help2man"
native=$(dpkg --print-architecture)
if [ -n "${ARCH:-}" ] && [ "$ARCH" != "$native" ]; then
    PKGS="$PKGS crossbuild-essential-$ARCH"
    "$(dirname "$0")/deps-cross.sh"
fi
missing=""
for p in $PKGS; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing="$missing $p"
done
[ -z "$missing" ] && exit 0
if [ "$(id -u)" -eq 0 ]; then
    echo "deps-deb: installing$missing"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    # shellcheck disable=SC2086
    apt-get install -y -qq --no-install-recommends $missing >/dev/null
    echo "deps-deb: done"
else
    echo "deps-deb: missing Debian packages:$missing" >&2
    echo "deps-deb: run:  sudo apt-get install -y --no-install-recommends$missing" >&2
    exit 1
fi

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
. "$(dirname "$0")/deps-lib.sh"
deps_install deps-deb $PKGS

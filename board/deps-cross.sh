#!/bin/sh
# SPDX-License-Identifier: MIT
# Installs what the aarch64 board build needs on a Debian 12 host: the cross compilers, qemu-user to run the
# cross-built tests, and the arm64 (multiarch) -dev packages of every library hmdwarp links.
# As root it runs apt-get (adding the arm64 architecture once); otherwise it prints the exact commands and fails.
set -eu
ARCH=${ARCH:-arm64}
TRIPLET=${TRIPLET:-aarch64-linux-gnu}

HOST_PKGS="gcc-$TRIPLET g++-$TRIPLET qemu-user-static pkg-config"
# Keep in step with board/deps.sh (the native list).
LIBS="libc6-dev libinih-dev libpng-dev zlib1g-dev libhidapi-dev libusb-1.0-0-dev libgpiod-dev libi2c-dev
libcmocka-dev libopencv-imgproc-dev libegl-dev libgles-dev libgbm-dev libdrm-dev libsystemd-dev"

missing=""
for p in $HOST_PKGS; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing="$missing $p"
done
for p in $LIBS; do
    dpkg-query -W -f='${Status}' "$p:$ARCH" 2>/dev/null | grep -q 'install ok installed' || missing="$missing $p:$ARCH"
done
[ -z "$missing" ] && exit 0

have_arch=$(dpkg --print-foreign-architectures | grep -qx "$ARCH" && echo yes || echo no)
if [ "$(id -u)" -eq 0 ]; then
    echo "deps-cross: installing$missing"
    export DEBIAN_FRONTEND=noninteractive
    [ "$have_arch" = yes ] || dpkg --add-architecture "$ARCH"
    apt-get update -qq
    # shellcheck disable=SC2086
    apt-get install -y -qq --no-install-recommends $missing >/dev/null
    echo "deps-cross: done"
else
    echo "deps-cross: missing:$missing" >&2
    [ "$have_arch" = yes ] || echo "deps-cross: run:  sudo dpkg --add-architecture $ARCH && sudo apt-get update" >&2
    echo "deps-cross: run:  sudo apt-get install -y --no-install-recommends$missing" >&2
    exit 1
fi

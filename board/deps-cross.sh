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
libcmocka-dev libopencv-imgproc-dev libegl-dev libgles-dev libgbm-dev libdrm-dev libsystemd-dev
libturbojpeg0-dev libzstd-dev libavcodec-dev libavutil-dev libswscale-dev libjson-c-dev libyaml-dev"

. "$(dirname "$0")/deps-lib.sh"
arch_libs=""
for p in $LIBS; do arch_libs="$arch_libs $p:$ARCH"; done
if ! dpkg --print-foreign-architectures | grep -qx "$ARCH"; then
    DEPS_BEFORE_UPDATE="dpkg --add-architecture $ARCH"
    DEPS_HINT="sudo dpkg --add-architecture $ARCH && sudo apt-get update"
fi
# shellcheck disable=SC2086
deps_install deps-cross $HOST_PKGS $arch_libs

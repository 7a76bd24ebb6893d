#!/bin/sh
# SPDX-License-Identifier: MIT
# Installs the Debian 12 packages hmdwarp needs to build, run and test.
# As root it runs apt-get; otherwise it prints the exact command and fails, so `make run`/`make test` stop early.
set -eu

# Keep in step with the README's dependency list. help2man writes the manual pages (`make man`). g++,
# libopencv-imgproc-dev and gnuplot-nox are for `make bench` (OpenCV's cv::remap is the peer it measures against;
# gnuplot draws the plots). python3-numpy and python3-opengl: the Python binding of libhmdwarp-host and its GLES
# example (host/python, host/examples; make test runs them). libturbojpeg0-dev, libzstd-dev and FFmpeg's
# libavcodec-dev, libavutil-dev, libswscale-dev: framelink v2's compressed planes (docs/framelink.md).
# libjson-c-dev and libyaml-dev: hmdwarp-lens import reads Monado/SteamVR config JSON and OpenCV calibration YAML.
# opencv-doc: its examples hold the Aloe stereo pair with ground-truth disparity (tests/accuracy/test_real_stereo).
PKGS="gcc libc6-dev make pkg-config
libinih-dev libpng-dev zlib1g-dev
libhidapi-dev libusb-1.0-0-dev libgpiod-dev libi2c-dev linux-libc-dev
libcmocka-dev
libegl-dev libgles-dev libgbm-dev libdrm-dev libegl-mesa0 libgl1-mesa-dri
libsystemd-dev
libturbojpeg0-dev libzstd-dev libavcodec-dev libavutil-dev libswscale-dev
libjson-c-dev libyaml-dev
help2man
g++ libopencv-imgproc-dev gnuplot-nox
python3-numpy python3-opengl
opencv-doc"

. "$(dirname "$0")/deps-lib.sh"
deps_install deps $PKGS

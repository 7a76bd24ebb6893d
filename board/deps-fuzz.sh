#!/bin/sh
# SPDX-License-Identifier: MIT
# Installs what `make fuzz` needs beyond board/deps.sh: clang and libFuzzer with its sanitizer runtimes (Debian 12
# ships libFuzzer for its clang in libclang-rt-14-dev). As root it runs apt-get; otherwise it prints the command.
set -eu

# Keep in step with the README's dependency list.
PKGS="clang libclang-rt-14-dev"

. "$(dirname "$0")/deps-lib.sh"
deps_install deps-fuzz $PKGS

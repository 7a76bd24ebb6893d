#!/bin/sh
# SPDX-License-Identifier: MIT
# Installs what `make fuzz` needs beyond board/deps.sh: clang and libFuzzer with its sanitizer runtimes (Debian 12
# ships libFuzzer for its clang in libclang-rt-14-dev). As root it runs apt-get; otherwise it prints the command.
set -eu

# Keep in step with the README's dependency list.
PKGS="clang libclang-rt-14-dev"

missing=""
for p in $PKGS; do
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed'; then
        missing="$missing $p"
    fi
done
[ -z "$missing" ] && exit 0

if [ "$(id -u)" -eq 0 ]; then
    echo "deps-fuzz: installing$missing"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    # shellcheck disable=SC2086
    apt-get install -y -qq --no-install-recommends $missing >/dev/null
    echo "deps-fuzz: done"
else
    echo "deps-fuzz: missing Debian packages:$missing" >&2
    echo "deps-fuzz: run:  sudo apt-get install -y --no-install-recommends$missing" >&2
    exit 1
fi

#!/bin/sh
# SPDX-License-Identifier: MIT
# Every header in runtime/ compiles on its own and includes only what it uses: for each of its project includes,
# the header is compiled again with that include's guard predefined (so it contributes nothing); if it still
# compiles, nothing of it was used. TAP output for tests/run.sh; run from the repository root.
# usage: tests/build/test_headers.sh [HEADER...]   (default: runtime/*.h)
set -u
CC=${CC:-cc}
FLAGS="-std=gnu11 -I. -D_GNU_SOURCE -Wall -Wextra -Werror -Wshadow -Wstrict-prototypes -Wmissing-prototypes -Wvla"
# the include paths of the libraries the build uses (libdrm's headers live under /usr/include/libdrm)
FLAGS="$FLAGS $(pkg-config --cflags $(sed -n 's/^PKGS *[:+]= *//p' Makefile) 2>/dev/null)"
[ $# -gt 0 ] || set -- runtime/*.h
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "1..$#"
n=0
compiles() { # compiles HEADER [EXTRA FLAGS...]
    h=$1; shift
    printf '#include "%s"\n' "$h" | $CC $FLAGS "$@" -fsyntax-only -x c - >"$tmp/err" 2>&1
}
for h in "$@"; do
    n=$((n + 1))
    why=""
    if ! compiles "$h"; then
        why="does not compile on its own: $(grep -m1 -E 'error' "$tmp/err")"
    else
        for inc in $(sed -n 's/^#include "\([^"]*\)".*/\1/p' "$h"); do
            guard=$(sed -n 's/^#ifndef \([A-Za-z0-9_]*\).*/\1/p' "$inc" | head -n 1)
            [ -n "$guard" ] || { why="$why $inc has no include guard;"; continue; }
            if compiles "$h" "-D$guard"; then why="$why includes $inc but uses nothing of it;"; fi
        done
    fi
    if [ -z "$why" ]; then echo "ok $n - $h: self-contained, every include used"; else echo "not ok $n - $h:$why"; fi
done

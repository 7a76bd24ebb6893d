#!/bin/sh
# SPDX-License-Identifier: MIT
# libhmdwarp-host as a user gets it: `make install DESTDIR=...`, then a small C program (host_api_smoke.c) built
# with the installed header and `pkg-config --cflags --libs hmdwarp-host` only, run against a board on a Unix
# socket (host_fake_board: the codec's own decoder); the colour the board received must be what the program
# rendered, byte for byte. TAP output; run from the repository root after `make all` (BUILD=build).
# usage: tests/packaging/test_host_install.sh
set -u
BUILD=${BUILD:-build}
CC=${CC:-cc}
# shellcheck source=tests/support/tap.sh
. "$(dirname "$0")/../support/tap.sh"
tmp=$(mktemp -d)
trap 'kill "$board" 2>/dev/null; rm -rf "$tmp"' EXIT
board=""
echo "1..6"

if make --no-print-directory BUILD="$BUILD" install DESTDIR="$tmp/root" PREFIX=/usr >"$tmp/install.log" 2>&1; then
    ok "make install DESTDIR=$tmp/root PREFIX=/usr"
else
    not_ok "make install" "$(tail -n 3 "$tmp/install.log")"
fi
lib=$tmp/root/usr/lib
if [ -f "$lib/libhmdwarp-host.so.0" ] && [ "$(readlink "$lib/libhmdwarp-host.so")" = libhmdwarp-host.so.0 ] &&
   [ -f "$tmp/root/usr/include/hmdwarp-host.h" ] &&
   objdump -p "$lib/libhmdwarp-host.so.0" | grep -q 'SONAME *libhmdwarp-host.so.0' &&
   ! nm -D --defined-only "$lib/libhmdwarp-host.so.0" | awk '$2 == "T" {print $3}' | grep -v '^hmdwarp_host_' | grep -q .; then
    ok "the library (soname libhmdwarp-host.so.0, only hmdwarp_host_* exported), the dev symlink and the header"
else
    not_ok "library, symlink, header" "$(ls -l "$lib" "$tmp/root/usr/include" 2>&1 | head -n 5)"
fi
flags=$(PKG_CONFIG_PATH= PKG_CONFIG_LIBDIR="$lib/pkgconfig" PKG_CONFIG_SYSROOT_DIR="$tmp/root" \
        pkg-config --cflags --libs hmdwarp-host 2>"$tmp/pc.err")
case $flags in
*"-I$tmp/root/usr/include"*"-L$lib"*"-lhmdwarp-host"*) ok "pkg-config --cflags --libs hmdwarp-host: $flags" ;;
*) not_ok "pkg-config --cflags --libs hmdwarp-host" "got '$flags' $(cat "$tmp/pc.err")" ;;
esac
# shellcheck disable=SC2086 # the flags are words
if $CC -std=c11 -Wall -Wextra -Werror -o "$tmp/smoke" tests/packaging/host_api_smoke.c $flags 2>"$tmp/cc.err"; then
    ok "host_api_smoke.c builds against the installed header and library alone"
else
    not_ok "host_api_smoke.c builds" "$(head -n 3 "$tmp/cc.err")"
fi

# The board: listening before the program starts.
"$BUILD/tests/packaging/host_fake_board" "$tmp/frames.sock" 64 48 5 "$tmp/board.rgba" >"$tmp/board.log" 2>&1 &
board=$!
for _ in $(seq 100); do grep -q listening "$tmp/board.log" 2>/dev/null && break; sleep 0.05; done
if LD_LIBRARY_PATH="$lib" timeout 60 "$tmp/smoke" "socket:$tmp/frames.sock" 5 "$tmp/host.rgba" >"$tmp/smoke.log" 2>&1 &&
   wait "$board" && grep -q '^received 5 frames, 64x48, planes 0x3' "$tmp/board.log"; then
    ok "5 frames from the program decoded by the board: $(tail -n 1 "$tmp/board.log")"
else
    not_ok "the program's frames reach the board" "$(tail -n 2 "$tmp/smoke.log")" "$(tail -n 2 "$tmp/board.log")"
fi
board=""
if [ -s "$tmp/host.rgba" ] && cmp -s "$tmp/host.rgba" "$tmp/board.rgba"; then
    ok "the colour the board received is what the program rendered (BGRA converted), byte for byte"
else
    not_ok "rendered == received" "$(cmp "$tmp/host.rgba" "$tmp/board.rgba" 2>&1)"
fi
[ "$fails" -eq 0 ]

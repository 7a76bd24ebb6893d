#!/bin/sh
# SPDX-License-Identifier: MIT
# libhmdwarp-host as a user gets it: `make install DESTDIR=...`, then a small C program (host_api_smoke.c) built
# with the installed header and `pkg-config --cflags --libs hmdwarp-host` only, run against a board on a Unix
# socket (tests/examples/fake_board: the codec's own decoder); the colour the board received must be what the program
# rendered, byte for byte; then hmdwarpd's socket backend with the program as host, its panel image compared with
# what the program rendered. TAP output; run from the repository root after `make all` (BUILD=build).
# usage: tests/packaging/test_host_install.sh
set -u
BUILD=${BUILD:-build}
CC=${CC:-cc}
# shellcheck source=tests/support/tap.sh
. "$(dirname "$0")/../support/tap.sh"
tmp=$(mktemp -d)
trap 'kill "$board" 2>/dev/null; rm -rf "$tmp"' EXIT
board=""
echo "1..9"

if make --no-print-directory BUILD="$BUILD" install DESTDIR="$tmp/root" PREFIX=/usr >"$tmp/install.log" 2>&1; then
    ok "make install DESTDIR=$tmp/root PREFIX=/usr"
else
    not_ok "make install" "$(tail -n 3 "$tmp/install.log")"
fi
lib=$tmp/root/usr/lib
if [ -f "$lib/libhmdwarp-host.so.0" ] && [ "$(readlink "$lib/libhmdwarp-host.so")" = libhmdwarp-host.so.0 ] &&
   [ -f "$tmp/root/usr/include/hmdwarp-host.h" ] &&
   objdump -p "$lib/libhmdwarp-host.so.0" | grep -q 'SONAME *libhmdwarp-host.so.0' &&
   ! nm -D --defined-only "$lib/libhmdwarp-host.so.0" | awk '$2 == "T" {print $3}' | grep -v '^hmdwarp_host_' |
     grep -q .; then
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

# The board: tests/examples/fake_board (the codec's own decoder; a line per frame with each plane's CRC), listening
# before the program starts.
crc_of() { /usr/bin/python3 -c 'import sys, zlib; print("%08x" % zlib.crc32(open(sys.argv[1], "rb").read()))' "$1"; }
start_board() { # SOCKET FRAMES LOG
    "$BUILD/tests/examples/fake_board" "$1" 64x48 "$2" >"$3" 2>&1 &
    board=$!
    for _ in $(seq 100); do grep -q listening "$3" 2>/dev/null && break; sleep 0.05; done
}
start_board "$tmp/frames.sock" 5 "$tmp/board.log"
if LD_LIBRARY_PATH="$lib" timeout 60 "$tmp/smoke" "socket:$tmp/frames.sock" 5 "$tmp/host.rgba" >"$tmp/smoke.log" 2>&1 &&
   wait "$board" && [ "$(grep -c '^frame seq=.* planes=3 .*eye0 64x48 ' "$tmp/board.log")" -eq 5 ]; then
    ok "5 frames from the program decoded by the board (colour and depth)"
else
    not_ok "the program's frames reach the board" "$(tail -n 2 "$tmp/smoke.log")" "$(tail -n 2 "$tmp/board.log")"
fi
board=""
got=$(tail -n 1 "$tmp/board.log" | sed -n 's/.*| eye0 [^|]* color=\([0-9a-f]*\).*/\1/p')
if [ -s "$tmp/host.rgba" ] && [ "$got" = "$(crc_of "$tmp/host.rgba")" ]; then
    ok "the colour the board received is what the program rendered (BGRA converted), byte for byte (CRC $got)"
else
    not_ok "rendered == received" "board's colour CRC '$got', rendered $(crc_of "$tmp/host.rgba")"
fi
# hmdwarp-feed on the same library: --socket to the same kind of board.
start_board "$tmp/feed.sock" 3 "$tmp/board2.log"
if timeout 60 "$BUILD/hmdwarp-feed" --socket "$tmp/feed.sock" --eye 64x48 --fov 45,45,45,45 --scene near \
       --frames 3 --rate 100 >"$tmp/feed.log" 2>&1 && wait "$board" &&
   [ "$(grep -c '^frame seq=.* planes=3 .*eye0 64x48 ' "$tmp/board2.log")" -eq 3 ]; then
    ok "hmdwarp-feed --socket: 3 frames, colour and depth, decoded by the board"
else
    not_ok "hmdwarp-feed --socket" "$(tail -n 2 "$tmp/feed.log")" "$(tail -n 2 "$tmp/board2.log")"
fi
board=""

# hmdwarpd's own socket backend ([frames] backend = socket, #18 point 3) with the installed program as its host:
# frames received and shown in --stats, and the panel image compared with what the program rendered. The board is
# set up so that showing a frame as rendered is the identity: a still head, a lens without distortion whose scale
# maps panel pixel centres onto eye pixel centres (64x48 eyes at tan 1 x 0.75, lens scale 32 px), both eyes side by
# side on a 128x48 panel. The raw sink writes every 10th vsync; the last image is taken after the program's last frame.
set -- --set frames.backend=socket --set "frames.device=$tmp/hmd.sock" --set sim.trace=still --set sim.imu_rest_s=0.2 \
    --set sim.eval_every_ms=0 --set render.rt_priority=0 --set eye.width=64 --set eye.height=48 \
    --set "eye.fov=45 45 36.869898 36.869898" --set display.width=128 --set display.height=48 \
    --set "lens.k_red=1 0 0 0" --set "lens.k_green=1 0 0 0" --set "lens.k_blue=1 0 0 0" --set lens.scale=32 \
    --set "lens.center=32 24" --set lens.visible_radius=100 --set display.sink=raw --set display.sink_every=10 \
    --set "display.sink_path=$tmp/panel"
mkdir -p "$tmp/panel"
if ! "$BUILD/hmdwarpd" --config board/sim/board.ini --check-config "$@" >"$tmp/check.log" 2>&1; then
    not_ok "hmdwarpd with the socket backend" "--check-config: $(tail -n 1 "$tmp/check.log")"
    not_ok "the panel shows what the program rendered" "hmdwarpd did not start"
else
    "$BUILD/hmdwarpd" --config board/sim/board.ini "$@" --duration 0 --stats "$tmp/stats.txt" >"$tmp/hmd.log" 2>&1 &
    board=$!
    for _ in $(seq 300); do [ -S "$tmp/hmd.sock" ] && break; sleep 0.1; done
    LD_LIBRARY_PATH="$lib" timeout 120 "$tmp/smoke" "socket:$tmp/hmd.sock" 20 "$tmp/hmd.rgba" >"$tmp/smoke2.log" 2>&1
    rc=$?
    # One more panel image after the last frame (the board keeps showing it).
    sz=$(stat -c %s "$tmp/panel/frames.rgba" 2>/dev/null || echo 0)
    for _ in $(seq 300); do [ "$(stat -c %s "$tmp/panel/frames.rgba" 2>/dev/null || echo 0)" -gt "$sz" ] && break
                            sleep 0.1; done
    sleep 0.5
    kill -INT "$board" 2>/dev/null; wait "$board"
    board=""
    received=$(sed -n 's/^frames_received=//p' "$tmp/stats.txt" 2>/dev/null)
    shown=$(sed -n 's/^frames_shown=//p' "$tmp/stats.txt" 2>/dev/null)
    if [ "$rc" -eq 0 ] && [ "${received:-0}" -ge 20 ] && [ "${shown:-0}" -ge 1 ]; then
        ok "hmdwarpd --set frames.backend=socket: the program's 20 frames received, $shown shown"
    else
        not_ok "hmdwarpd with the socket backend" "program: $(tail -n 1 "$tmp/smoke2.log")" \
            "frames_received=${received:-none} frames_shown=${shown:-none}; $(tail -n 2 "$tmp/hmd.log")"
    fi
    # The last whole panel image against the last frame rendered, in both halves: colour channels, per pixel.
    if cmp_out=$(/usr/bin/python3 - "$tmp/panel/frames.rgba" "$tmp/hmd.rgba" <<'PY'
import sys
W, H = 64, 48
panel, host = open(sys.argv[1], "rb").read(), open(sys.argv[2], "rb").read()
size = 2 * W * H * 4
if len(panel) < size or len(host) != W * H * 4:
    print("panel %d bytes, rendered %d bytes" % (len(panel), len(host)))
    sys.exit(1)
last = panel[(len(panel) // size - 1) * size:][:size]
worst, off = 0, 0
for y in range(H):
    for x in range(2 * W):
        p, q = 4 * (y * 2 * W + x), 4 * (y * W + x % W)
        d = max(abs(last[p + c] - host[q + c]) for c in range(3))
        worst, off = max(worst, d), off + (d > 2)
print("largest difference %d, pixels off by more than 2: %d of %d" % (worst, off, 2 * W * H))
sys.exit(0 if off <= 2 * W * H // 100 else 1)
PY
    ); then
        ok "the panel shows what the program rendered, both eyes: $cmp_out"
    else
        not_ok "the panel shows what the program rendered" "$cmp_out"
    fi
fi
echo "$((n - fails)) passed, $fails failed"
exit $((fails > 0))

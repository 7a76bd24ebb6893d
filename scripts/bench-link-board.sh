#!/bin/sh
# SPDX-License-Identifier: MIT
# What the codec buys on a slow link, on the simulated board itself (not a model): hmdwarpd with its devices
# behind the real backends (make run DEVICES=mock), the mock USB link limited to USB 2.0's ~35 MB/s, once with the
# board announcing raw alone and once on auto (the mock host then sends what libhmdwarp-host's auto sends). Writes
# a Markdown table of frames, frame age and each warp's accuracy against ground truth. `make bench` runs it.
# usage: scripts/bench-link-board.sh HMDWARPD OUT.md [SECONDS]
set -eu
[ $# -ge 2 ] || { echo "usage: $0 HMDWARPD OUT.md [SECONDS]" >&2; exit 2; }
hmd=$1 out=$2 secs=${3:-15}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for c in raw auto; do
    "$hmd" --config board/sim/board.ini --set imu.backend=hid --set imu.device=mock --set frames.backend=usb \
        --set frames.device=mock --set vsync.backend=gpio --set vsync.chip=mock --set frames.link_mbps=35 \
        --set "frames.codecs=$c" --set "sim.duration_s=$secs" --stats "$tmp/$c.txt" >"$tmp/$c.log" 2>&1 ||
        { tail -n 5 "$tmp/$c.log" >&2; echo "bench-link-board: hmdwarpd with codecs=$c failed" >&2; exit 1; }
done
kv() { sed -n "s/^$2=//p" "$tmp/$1.txt" | head -n 1; }
{
    echo "# On the simulated board: the mock USB link at 35 MB/s, raw frames against auto"
    echo
    echo "\`scripts/bench-link-board.sh\` (run by \`make bench\`): \`board/sim/board.ini\` (its eyes, colour +"\
         "depth, the host at its \`[sim] host_rate_hz\`), devices behind the real backends"\
         "(\`make run DEVICES=mock LINK_MBPS=35\`), ${secs} s each; \`[frames] codecs = raw\` against \`auto\` (JPEG"\
         "q$(sed -n 's/^#define DRV_FRAMELINK_AUTO_JPEG_QUALITY //p' drivers/drv_framelink_codec.h) colour, zstd INV16"\
         "depth). Accuracy is the board's own evaluation against the simulator's ground truth (mean PSNR over the run)."\
         "Load average at the start: $(cut -d' ' -f1 /proc/loadavg)."
    echo
    echo "| announced | frames received | compressed | MB/s on the wire | frame age p50 ms | decode p50 ms | raytrace dB | rotation dB | none dB |"
    echo "|---|---:|---:|---:|---:|---:|---:|---:|---:|"
    for c in raw auto; do
        echo "| $c | $(kv $c frames_received) | $(kv $c frames_link_compressed_frames) | $(kv $c frames_link_wire_mb_s) |"\
             "$(kv $c frame_age_ms_p50) | $(kv $c frames_link_decode_ms_p50) | $(kv $c psnr_raytrace) |"\
             "$(kv $c psnr_rotation) | $(kv $c psnr_none) |"
    done
} >"$out"
echo "bench-link-board: $out"

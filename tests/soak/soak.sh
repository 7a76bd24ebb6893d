#!/bin/bash
# SPDX-License-Identifier: MIT
# make soak: hmdwarpd on the simulated board behind the mocked devices (HID IMU, framelink over the USB backend, TE
# edges through the GPIO estimator) for SOAK_S seconds (default 600) with faults throughout: every Nth HID report
# and host frame garbled, frames cut short, jittered TE edges, and once each the IMU unplugged, the host stalled
# and the TE edges stopped. Samples RSS, open file descriptors and threads from /proc and the counters from the
# live stats file every SOAK_EVERY_S seconds; fails unless they are flat (RSS within SOAK_RSS_KB of the first
# sample after the warm-up, fds and threads equal), every fault was counted and recovered from, and hmdwarpd
# exited 0 (no crash). Not part of make test: it takes minutes by design.
set -u
BUILD=${BUILD:-build}
SOAK_S=${SOAK_S:-600}
SOAK_EVERY_S=${SOAK_EVERY_S:-10}
# Histogram bins and stdio buffers are touched as the run meets new values: allowed growth after the warm-up.
SOAK_RSS_KB=${SOAK_RSS_KB:-4096}
SOAK_ARGS=${SOAK_ARGS:-}
out=${SOAK_OUT:-$BUILD/soak}
mkdir -p "$out"
rm -f "$out"/live "$out"/stats "$out"/samples.txt
[ "$SOAK_S" -ge 60 ] 2>/dev/null || { echo "soak: SOAK_S=$SOAK_S: at least 60 seconds"; exit 2; }

# The one-off faults at a quarter, a half and three quarters of the run; the warm-up sample after a tenth.
unplug_at=$((SOAK_S / 4)) stall_at=$((SOAK_S / 2)) edges_at=$((SOAK_S * 3 / 4))
warm=$((SOAK_S / 10 < 20 ? 20 : SOAK_S / 10))
# rt_priority 0: on a shared machine a SCHED_FIFO soak would starve the rest (SOAK_ARGS may set it).
"$BUILD/hmdwarpd" --config board/sim/board.ini --duration "$SOAK_S" \
    --set imu.backend=hid --set imu.device=mock --set frames.backend=usb --set frames.device=mock \
    --set vsync.backend=gpio --set vsync.chip=mock --set render.rt_priority=0 --set sim.eval_every_ms=0 \
    --set mock.corrupt_every=97 --set mock.truncate_every=89 --set mock.vsync_jitter_us=300 \
    --set mock.imu_unplug_at_s=$unplug_at --set mock.imu_unplug_for_s=2 \
    --set mock.host_stall_at_s=$stall_at --set mock.host_stall_for_s=3 \
    --set mock.edges_stop_at_s=$edges_at --set mock.edges_stop_for_s=2 \
    --set telemetry.live_stats="$out/live" --stats "$out/stats" $SOAK_ARGS >"$out/hmdwarpd.log" 2>&1 &
pid=$!
echo "soak: hmdwarpd (pid $pid) for $SOAK_S s with mocked devices and faults; IMU unplugged at ${unplug_at} s," \
     "host stalled at ${stall_at} s, TE edges stopped at ${edges_at} s; log and samples in $out/"

kv() { sed -n "s/^$1=//p" "$2" 2>/dev/null | head -n 1; }
sample() { # t rss_kb fds threads vsyncs frames_received imu_samples
    local rss thr fds
    rss=$(sed -n 's/^VmRSS:[[:space:]]*\([0-9]*\) kB/\1/p' /proc/$pid/status 2>/dev/null)
    thr=$(sed -n 's/^Threads:[[:space:]]*//p' /proc/$pid/status 2>/dev/null)
    fds=$(ls /proc/$pid/fd 2>/dev/null | wc -l)
    [ -n "$rss" ] || return 1
    echo "$1 $rss $fds $thr $(kv vsyncs "$out/live") $(kv frames_received "$out/live") $(kv imu_samples "$out/live")"
}

t=0
first="" last=""
printf '%6s %9s %5s %7s %9s %9s %10s\n' t_s rss_kb fds threads vsyncs frames imu_samples | tee "$out/samples.txt"
while kill -0 $pid 2>/dev/null; do
    sleep "$SOAK_EVERY_S"
    t=$((t + SOAK_EVERY_S))
    s=$(sample $t) || break
    printf '%6s %9s %5s %7s %9s %9s %10s\n' $s | tee -a "$out/samples.txt"
    [ $t -ge $warm ] && [ -z "$first" ] && first=$s
    # the end's samples could catch threads being joined: compare only while the run surely goes on
    [ $t -le $((SOAK_S - 5)) ] && last=$s
done
wait $pid
rc=$?

fails=0
fail() { echo "soak: FAIL: $*"; fails=$((fails + 1)); }
pass() { echo "soak: ok: $*"; }
if [ $rc -eq 0 ]; then pass "hmdwarpd ran $SOAK_S s and exited 0 (no crash)"; else
    fail "hmdwarpd exited with status $rc$([ $rc -gt 128 ] && echo " (signal $((rc - 128)))"); tail of $out/hmdwarpd.log:"
    tail -n 15 "$out/hmdwarpd.log"
fi
if [ -z "$first" ] || [ -z "$last" ] || [ "$first" = "$last" ]; then
    fail "too few samples after the warm-up ($warm s) to compare"
else
    set -- $first; t0=$1 rss0=$2 fd0=$3 th0=$4
    set -- $last; t1=$1 rss1=$2 fd1=$3 th1=$4
    echo "soak: from ${t0} s to ${t1} s: RSS $rss0 -> $rss1 kB ($((rss1 - rss0)) kB), fds $fd0 -> $fd1," \
         "threads $th0 -> $th1"
    [ $((rss1 - rss0)) -le "$SOAK_RSS_KB" ] && pass "RSS flat (grew $((rss1 - rss0)) kB, bound $SOAK_RSS_KB kB)" ||
        fail "RSS grew $((rss1 - rss0)) kB, more than $SOAK_RSS_KB kB"
    [ "$fd0" = "$fd1" ] && pass "open file descriptors flat ($fd1)" || fail "open file descriptors $fd0 -> $fd1"
    [ "$th0" = "$th1" ] && pass "threads flat ($th1)" || fail "threads $th0 -> $th1"
fi
# Every fault counted, and recovered: the device back, the counts still rising at the end.
st="$out/stats"
n() { v=$(kv "$1" "$st"); echo "${v:-0}"; }
[ -s "$st" ] || fail "no stats file $st"
[ "$(n imu_lost)" -ge 1 ] && [ "$(n imu_reconnects)" -ge 1 ] && [ "$(n imu_connected)" = 1 ] &&
    pass "IMU unplug: lost $(n imu_lost), reconnected $(n imu_reconnects), connected at the end" ||
    fail "IMU unplug: lost $(n imu_lost), reconnects $(n imu_reconnects), connected $(n imu_connected)"
[ "$(n imu_bad_reports)" -ge 1 ] && pass "garbled HID reports rejected: $(n imu_bad_reports)" ||
    fail "no garbled HID report was counted"
[ "$(n frames_rejected)" -ge 1 ] && pass "garbled or cut frames rejected: $(n frames_rejected)" ||
    fail "no rejected frame was counted"
[ "$(n vsync_fallbacks)" -ge 1 ] && [ "$(n vsync_on_timer)" = 0 ] &&
    pass "TE edges stopped: $(n vsync_fallbacks) timer fallback(s), back on the edges at the end" ||
    fail "TE edges: fallbacks $(n vsync_fallbacks), on timer at the end $(n vsync_on_timer)"
# after the last one-off fault (three quarters in), frames, IMU samples and vsyncs still came
late=$(awk -v t=$((SOAK_S * 3 / 4 + 10)) 'NR > 1 && $1 + 0 >= t' "$out/samples.txt" | head -n 1)
if [ -n "$late" ] && [ -n "$last" ]; then
    set -- $late; v0=$5 f0=$6 i0=$7
    set -- $last; v1=$5 f1=$6 i1=$7
    [ "$v1" -gt "$v0" ] && [ "$f1" -gt "$f0" ] && [ "$i1" -gt "$i0" ] &&
        pass "still running after the faults: vsyncs +$((v1 - v0)), frames +$((f1 - f0)), IMU samples +$((i1 - i0))" ||
        fail "stalled after the faults: vsyncs $v0 -> $v1, frames $f0 -> $f1, IMU samples $i0 -> $i1"
else
    fail "no sample after the last fault to show recovery"
fi
grep -E '^(vsyncs|missed|m2p_ms_p99|frames_received|frames_rejected|imu_samples)=' "$st" | tr '\n' ' '; echo
[ $fails -eq 0 ] && echo "soak: PASS" || echo "soak: FAIL ($fails)"
[ $fails -eq 0 ]

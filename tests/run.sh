#!/bin/sh
# SPDX-License-Identifier: MIT
# Runs cmocka test binaries with TAP output and sums them into one closing line "N passed, N failed".
# A binary that crashes or reports fewer results than it planned counts its missing tests as failed.
# With --hil first, the hardware-in-the-loop scenarios (tests/hil, a qemu VM) run after the binaries and count one
# test each; they are skipped, saying why, when HIL=0 or their tools cannot be set up (board/deps-hil.sh), and a
# skip counts as a failure when HIL_REQUIRED=1 (CI: .ci/run), so CI can never pass without them.
# usage: tests/run.sh [--hil] LOGDIR BINARY...
set -u
hil=0
[ "${1:-}" = --hil ] && { hil=1; shift; }
logdir=$1; shift
mkdir -p "$logdir/logs"
passed=0; failed=0
for bin in "$@"; do
    name=$(basename "$bin")
    log="$logdir/logs/$name.log"
    # TEST_RUNNER: e.g. qemu-aarch64-static for cross-built tests (make check-cross)
    CMOCKA_MESSAGE_OUTPUT=TAP ${TEST_RUNNER:-} "$bin" >"$log" 2>&1
    rc=$?
    ok=$(grep -c '^ok ' "$log")
    bad=$(grep -c '^not ok ' "$log")
    plan=$(sed -n 's/^1\.\.\([0-9][0-9]*\).*/\1/p' "$log" | head -n 1)
    [ -n "$plan" ] || plan=$((ok + bad))
    missing=$((plan - ok - bad))
    [ "$missing" -lt 0 ] && missing=0
    if [ "$rc" -ne 0 ] && [ "$bad" -eq 0 ] && [ "$missing" -eq 0 ]; then missing=1; fi
    bad=$((bad + missing))
    passed=$((passed + ok)); failed=$((failed + bad))
    if [ "$bad" -eq 0 ]; then
        printf '  ok    %-34s %3d tests\n' "$name" "$ok"
    else
        printf '  FAIL  %-34s %3d passed, %d failed (exit %d) — log: %s\n' "$name" "$ok" "$bad" "$rc" "$log"
        grep -E '^not ok|\[  ERROR|Failure|ERROR|error:|runtime error|AddressSanitizer' "$log" | head -n 20 | sed 's/^/        /'
    fi
done
if [ "$hil" = 1 ]; then
    log="$logdir/logs/hil.log"
    skip=""
    if [ "${HIL:-1}" = 0 ]; then
        skip="HIL=0"
    elif ! board/deps-hil.sh >"$log" 2>&1; then
        skip="board/deps-hil.sh failed: $(tail -n 1 "$log")"
    fi
    if [ -n "$skip" ]; then
        if [ "${HIL_REQUIRED:-0}" = 1 ]; then
            printf '  FAIL  %-34s skipped (%s) but HIL_REQUIRED=1 — log: %s\n' "hil (make hil)" "$skip" "$log"
            failed=$((failed + 1))
        else
            printf '  SKIP  %-34s %s; run it with: make hil\n' "hil (make hil)" "$skip"
        fi
    else
        # the scenario lines as they come: the VM takes a few minutes
        BUILD=${BUILD:-build} tests/hil/run.sh >>"$log" 2>&1 &
        tail -n 0 -f "$log" --pid=$! 2>/dev/null | grep --line-buffered -E '^hil: [0-9][0-9]-' | sed 's/^hil: /  hil   /'
        wait $! 2>/dev/null
        # timing targets (rates, misses, latency) are reported, not counted: they depend on the machine's load
        grep -E '^hil: timing targets:' "$log" | tail -n 1 | sed 's/^hil: /  hil   /'
        sum=$(grep -E '^hil: [0-9]+ passed, [0-9]+ failed' "$log" | tail -n 1)
        if [ -n "$sum" ]; then
            set -- $sum
            passed=$((passed + $2)); failed=$((failed + $4))
            [ "$4" -eq 0 ] || echo "        hil: scenario logs and the VM console in $log and ${BUILD:-build}/hil/console.log.txt"
        else
            printf '  FAIL  %-34s the VM did not report — log: %s\n' "hil (make hil)" "$log"
            tail -n 8 "$log" | sed 's/^/        /'
            failed=$((failed + 1))
        fi
    fi
fi
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]

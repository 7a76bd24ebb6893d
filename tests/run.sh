#!/bin/sh
# Runs cmocka test binaries with TAP output and sums them into one closing line "N passed, N failed".
# A binary that crashes or reports fewer results than it planned counts its missing tests as failed.
# usage: tests/run.sh LOGDIR BINARY...
set -u
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
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]

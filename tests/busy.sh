#!/bin/sh
# SPDX-License-Identifier: MIT
# busy.sh COMMAND...: runs COMMAND beside a busy loop on every core (make test-busy: the tests must judge what
# holds on a loaded machine, issue #16), stops the loops by their pids however COMMAND ends, exits with its status.
# BUSY_LOOPS=N overrides the count (default: one per online CPU).
set -u
n=${BUSY_LOOPS:-$(getconf _NPROCESSORS_ONLN 2>/dev/null || echo 2)}
pids=""
stop() {
    [ -n "$pids" ] && kill $pids 2>/dev/null
    pids=""
}
trap stop EXIT
trap 'stop; exit 130' INT TERM
i=0
while [ "$i" -lt "$n" ]; do
    sh -c 'while :; do :; done' &
    pids="$pids $!"
    i=$((i + 1))
done
echo "test-busy: $n busy loops (one per core, pids$pids) beside: $*"
"$@"
rc=$?
stop
exit "$rc"

#!/bin/sh
# SPDX-License-Identifier: MIT
# Runs the libFuzzer harnesses built by `make fuzz-build` (make fuzz, make fuzz-merge).
#   run.sh run   FUZZ_BUILD SECONDS JOBS NAME...  each harness for SECONDS, JOBS at a time, from the checked-in corpus
#                plus fresh seeds; prints executions, coverage (cov = edges, ft = features) and crashes per harness
#                and a total line; exits 1 when anything crashed. Crashes: FUZZ_BUILD/crashes/NAME/, with the
#                commands that reproduce them in reproduce.sh there.
#   run.sh merge FUZZ_BUILD 0 1 NAME...         minimises seeds + checked-in + found inputs (-merge=1) into
#                tests/fuzz/corpus/NAME, keeping every crash-* reproducer there as it is.
set -u
mode=$1 build=$2 seconds=$3 jobs=$4
shift 4
bin=$build/fuzzers
# leaks inside Debian's libraries (x265) are not the harnesses' findings
LSAN_OPTIONS=suppressions=$(pwd)/tests/support/lsan.supp:print_suppressions=0${LSAN_OPTIONS:+:$LSAN_OPTIONS}
export LSAN_OPTIONS
mkdir -p "$build/logs"

prepare() { # NAME: the working corpus, seeded
    w=$build/corpus/$1
    mkdir -p "$w" "$build/seeds/$1" "$build/crashes/$1"
    "$bin/seeds_$1" "$build/seeds/$1" >/dev/null || { echo "fuzz: seeds_$1 failed" >&2; return 1; }
    cp -n "$build/seeds/$1"/* "$w"/ 2>/dev/null
    [ -d "tests/fuzz/corpus/$1" ] && cp -n "tests/fuzz/corpus/$1"/* "$w"/ 2>/dev/null
    return 0
}

if [ "$mode" = merge ]; then
    for n in "$@"; do
        prepare "$n" || exit 1
        dst=tests/fuzz/corpus/$n
        new=$build/merged/$n
        rm -rf "$new" && mkdir -p "$new" "$dst"
        "$bin/$n" -merge=1 -timeout=10 -rss_limit_mb=2048 "$new" "$build/corpus/$n" "$dst" \
            >"$build/logs/$n.merge.log" 2>&1 || { echo "fuzz-merge: $n failed: $build/logs/$n.merge.log"; exit 1; }
        find "$dst" -maxdepth 1 -type f ! -name 'crash-*' -delete
        cp "$new"/* "$dst"/ 2>/dev/null
        echo "fuzz-merge: $n: $(ls "$new" | wc -l) inputs, $(du -sk "$new" | cut -f1) KB ($(ls "$dst" | grep -c '^crash-') crash reproducers kept)"
    done
    exit 0
fi

run_one() { # NAME: one harness for $seconds, results into logs/NAME.result
    n=$1
    log=$build/logs/$n.log
    nice -n 10 "$bin/$n" -max_total_time="$seconds" -print_final_stats=1 -timeout=10 -rss_limit_mb=2048 \
        -artifact_prefix="$build/crashes/$n/" "$build/corpus/$n" >"$log" 2>&1
    rc=$?
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
    last=$(grep -E '^#[0-9]+' "$log" | tail -n 1)
    cov=$(echo "$last" | sed -n 's/.* cov: \([0-9]*\).*/\1/p')
    ft=$(echo "$last" | sed -n 's/.* ft: \([0-9]*\).*/\1/p')
    crashes=$(ls "$build/crashes/$n" 2>/dev/null | grep -vc '^reproduce\.sh$')
    echo "$n ${execs:-0} ${cov:-0} ${ft:-0} $crashes $rc" >"$build/logs/$n.result"
}

for n in "$@"; do rm -rf "$build/crashes/$n"; prepare "$n" || exit 1; done
echo "fuzz: $# harnesses, $seconds s each, $jobs at a time (logs: $build/logs/)"
# JOBS harnesses at a time: each slot takes the next name in turn.
slot=0
while [ "$slot" -lt "$jobs" ]; do
    (i=0; for n in "$@"; do [ $((i % jobs)) -eq "$slot" ] && run_one "$n"; i=$((i + 1)); done) &
    slot=$((slot + 1))
done
wait

total=0 crashed=0
printf '  %-16s %12s %8s %8s %8s\n' harness executions cov ft crashes
for n in "$@"; do
    set -- $(cat "$build/logs/$n.result" 2>/dev/null || echo "$n 0 0 0 0 1")
    printf '  %-16s %12s %8s %8s %8s\n' "$1" "$2" "$3" "$4" "$5"
    total=$((total + $2))
    if [ "$5" -gt 0 ] || { [ "$6" -ne 0 ] && [ "$5" -eq 0 ]; }; then
        crashed=$((crashed + ($5 > 0 ? $5 : 1)))
        [ "$6" -ne 0 ] && [ "$5" -eq 0 ] && echo "        $1 exited $6 without a crash file: $build/logs/$1.log"
        for c in "$build/crashes/$1"/*; do
            [ -e "$c" ] && [ "${c##*/}" != reproduce.sh ] || continue
            echo "        reproduce: $bin/$1 $c   (or, without clang: build/tests/fuzz/fuzz_$1 $c)"
            echo "$bin/$1 $c" >>"$build/crashes/$1/reproduce.sh"
        done
    fi
done
echo "fuzz: $total executions, $crashed crashes"
[ "$crashed" -eq 0 ]

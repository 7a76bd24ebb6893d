#!/bin/sh
# SPDX-License-Identifier: MIT
# hmdwarp-bench's link section on 64x64 eyes: every codec row is measured or says why not, the raw row is the
# lossless v1 baseline, and scripts/bench-link-readme.sh copies only a reference run's table into a README.
# TAP output for tests/run.sh; run from the repository root after `make all`.
set -u
BUILD=${BUILD:-build}
bench=$BUILD/hmdwarp-bench
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "1..9"
n=0
ok() { n=$((n + 1)); echo "ok $n - $1"; }
nok() { n=$((n + 1)); echo "not ok $n - $1"; }
check() { # check DESCRIPTION WHY-IF-FAILED (empty: passed)
    if [ -z "$2" ]; then ok "$1"; else nok "$1: $2"; fi
}
# readme LINK_MD README: scripts/bench-link-readme.sh on them, its output in $tmp/log2; why says how it failed (its exit
# status and output), empty when it succeeded
readme() {
    scripts/bench-link-readme.sh "$1" "$2" >"$tmp/log2" 2>&1
    rc=$?
    why=""
    [ "$rc" -eq 0 ] || why="exit $rc: $(cat "$tmp/log2")"
}
# unchanged README: adds to why when README differs from the original, README.orig
unchanged() { cmp -s "$1" "$tmp/README.orig" || why="$why the README changed"; }

out=$tmp/out
mkdir -p "$out"
"$bench" --link-only --eye 64x64 --out "$out" >"$tmp/log" 2>&1
rc=$?
why=""
[ "$rc" -eq 0 ] || why="exit $rc: $(tail -n 3 "$tmp/log")"
[ -s "$out/link.csv" ] && [ -s "$out/link.md" ] || why="$why link.csv or link.md missing"
check "hmdwarp-bench --link-only --eye 64x64 runs and writes link.csv and link.md" "$why"

# rows: the header, then one line per row; the row name is quoted (it may hold commas)
rows=$(tail -n +2 "$out/link.csv" 2>/dev/null | wc -l)
check "link.csv has the raw row, 8 JPEG, 4 video, 5 depth and 8 whole-frame rows" \
    "$([ "$rows" -eq 26 ] || echo "$rows rows")"

# every row: either numbers in every measured column, or n/a with a reason
bad=$(tail -n +2 "$out/link.csv" | awk -F'"' '{
    split($3, f, ",")   # f[1] is empty (the comma after the name): codecs at f[2], f[3], figures from f[4]
    if (NF != 3 || split($3, g, ",") != 23) { print $2 ": not 24 columns"; next }
    if ($3 ~ /,n\/a \(.+\)$/) next
    for (i = 4; i <= 18; i++) if (f[i] !~ /^-?[0-9]+(\.[0-9]+)?$/) { print $2 ": column " i + 1 " is \"" f[i] "\""; next }
}' | head -n 3)
check "every row is measured in full or n/a with its reason" "$bad"

# auto's decode split: the same frames' colour alone, timed by the bench (times on this machine: only their form and
# their sum are judged)
why=$(awk '/^Decode time of \*\*auto: / {
    found = 1
    if (!match($0, /\*\*, [0-9.]+ ms: /)) { print "no total: " $0; exit }
    all = substr($0, RSTART + 4, RLENGTH - 9)
    if (!match($0, /decode in [0-9.]+ ms/)) { print "no colour time: " $0; exit }
    col = substr($0, RSTART + 10, RLENGTH - 13)
    if (!match($0, /the other -?[0-9.]+ ms/)) { print "no depth time: " $0; exit }
    dep = substr($0, RSTART + 10, RLENGTH - 13)
    d = all - col - dep  # each printed to 0.01
    if (col <= 0 || d > 0.02 || d < -0.02) print "colour " col " + depth " dep " is not " all
} END { if (!found) print "no line on auto'"'"'s decode time" }' "$out/link.md")
check "link.md splits auto's decode time into its colour's and its depth's" "$why"

raw=$(grep '^raw,' "$out/link.csv")
# 64x64 eyes, colour RGBA8 + depth F32: 8 bytes per pixel per eye, plus the header (a few hundred bytes)
why=$(echo "$raw" | awk -F'"' '{ split($3, f, ",")
    if (f[4] < 2 * 64 * 64 * 8 || f[4] > 2 * 64 * 64 * 8 + 4096) print "raw bytes " f[4]
    if (f[9] != "999.000") print "raw colour PSNR " f[9] " (lossless is 999)"
    if (f[11] != "0.000") print "raw raytrace vs raw " f[11]
    if (f[12] != "0.000") print "raw depth share of the raytrace " f[12]
    if (f[22] < 8 || f[22] > 8.1) print "raw bytes per eye pixel " f[22] " (RGBA8 + F32: 8 and the header)"
    if (f[13] != 1) print "a 64x64 raw frame does not fit 30 MB/s at 45 Hz?" }')
[ -n "$raw" ] || why="no raw row"
check "the raw row is the lossless v1 frame, its raytrace the reference" "$why"

# the README copy: a --eye run is not a reference, so the README stays as it was
printf '# R\n\ntext\n<!-- link-table:begin -->\nold table\n<!-- link-table:end -->\nafter\n' >"$tmp/README.md"
cp "$tmp/README.md" "$tmp/README.orig"
readme "$out/link.md" "$tmp/README.md"
unchanged "$tmp/README.md"
check "a --eye run's table stays out of the README" "$why"

# a reference run's table replaces what stood between the markers, and nothing else
sed 's/^<!-- link-run: not reference -->$/<!-- link-run: reference -->/' "$out/link.md" >"$tmp/ref.md"
readme "$tmp/ref.md" "$tmp/README.md"
sed -n '/^<!-- link-table:begin -->$/,/^<!-- link-table:end -->$/p' "$tmp/ref.md" >"$tmp/want"
sed -n '/^<!-- link-table:begin -->$/,/^<!-- link-table:end -->$/p' "$tmp/README.md" >"$tmp/got"
cmp -s "$tmp/want" "$tmp/got" || why="$why the README's table is not link.md's"
grep -q '^| raw (v1 frame) |' "$tmp/got" || why="$why no raw row in the copied table"
[ "$(head -n 3 "$tmp/README.md")" = "$(head -n 3 "$tmp/README.orig")" ] && [ "$(tail -n 1 "$tmp/README.md")" = after ] ||
    why="$why text outside the markers changed"
check "a reference run's whole-frame table replaces the README's, nothing else" "$why"

printf '# R\nno markers\n' >"$tmp/README2.md"
readme "$tmp/ref.md" "$tmp/README2.md"
why=""
[ "$rc" -ne 0 ] || why="accepted a README without markers"
grep -q 'needs exactly one' "$tmp/log2" || why="$why no reason given: $(cat "$tmp/log2")"
check "a README without the markers is refused, naming them" "$why"

cp "$tmp/README.orig" "$tmp/README3.md"
readme "$tmp/none/link.md" "$tmp/README3.md"
unchanged "$tmp/README3.md"
check "no link.md (a bench run with --out elsewhere): the README is left alone and make bench goes on" "$why"

#!/bin/sh
# SPDX-License-Identifier: MIT
# Copies the link section's whole-frame table from hmdwarp-bench's link.md into the README (between the
# `<!-- link-table:begin -->` and `<!-- link-table:end -->` lines of both), so the README shows measured numbers,
# never typed ones. Only a reference run's table (the rpi5 eye size: not --quick, no --eye) goes in; any other run
# leaves the README alone and says so. `make bench` runs it.
# usage: scripts/bench-link-readme.sh LINK_MD README
set -eu
[ $# -eq 2 ] || { echo "usage: $0 LINK_MD README" >&2; exit 2; }
md=$1 readme=$2
begin='<!-- link-table:begin -->'
end='<!-- link-table:end -->'
# a bench run with --out elsewhere wrote no link.md here: nothing to copy, and make bench must not fail for it
[ -e "$md" ] || { echo "bench-link-readme: no $md (the bench wrote elsewhere): $readme left alone"; exit 0; }
for f in "$md" "$readme"; do
    if [ "$(grep -cxF "$begin" "$f")" != 1 ] || [ "$(grep -cxF "$end" "$f")" != 1 ]; then
        echo "bench-link-readme: $f: needs exactly one '$begin' line and one '$end' line" >&2
        exit 1
    fi
done
if ! grep -qxF '<!-- link-run: reference -->' "$md"; then
    echo "bench-link-readme: $md is not from a reference run (--quick or --eye): $readme left alone"
    exit 0
fi
tmp=$(mktemp "$readme.XXXXXX")
trap 'rm -f "$tmp"' EXIT
# the README up to its begin line, the table between link.md's markers, the README from its end line on
awk -v b="$begin" -v e="$end" -v md="$md" '
    $0 == b { print; while ((getline l < md) > 0) { if (l == b) on = 1; else if (l == e) on = 0; else if (on) print l }
              skip = 1; next }
    $0 == e { skip = 0 }
    !skip { print }' "$readme" >"$tmp"
cat "$tmp" >"$readme"
echo "bench-link-readme: $readme's link table from $md"

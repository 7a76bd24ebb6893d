#!/bin/sh
# SPDX-License-Identifier: MIT
# The version and the manual pages: every program's --version and --help (what help2man reads), hmdwarpd's
# summary and stats, scripts/version.sh in a tagged, an untagged, a modified and a git-less tree, and the pages
# `make man` generated. TAP output for tests/run.sh; run from the repository root after `make all man`.
set -u
BUILD=${BUILD:-build}
PROGS="hmdwarpd hmdwarp-feed hmdwarp-warp hmdwarp-lens hmdwarp-bench hmdwarp-top"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# shellcheck source=tests/support/tap.sh
. "$(dirname "$0")/../support/tap.sh"
check() { # check DESCRIPTION COMMAND...: ok when the command succeeds
    d=$1; shift
    if "$@" >"$tmp/out" 2>&1; then ok "$d"; else not_ok "$d" "$(head -n 5 "$tmp/out")"; fi
}
echo "1..31"

# The version the build generated (scripts/version.sh at build time; a file edited since would make it differ).
version=$(sed -n 's/^#define HMDWARP_VERSION "\(.*\)"$/\1/p' "$BUILD/gen/hmdwarp_version.h" 2>/dev/null)
[ -n "$version" ] || version="(no $BUILD/gen/hmdwarp_version.h: run make all)"
for p in $PROGS; do
    out=$("$BUILD/$p" --version 2>"$tmp/err"); rc=$?
    if [ $rc -eq 0 ] && [ "$out" = "$p $version" ] && [ ! -s "$tmp/err" ]; then
        ok "$p --version prints '$p $version'"
    else
        not_ok "$p --version prints '$p $version'" "exit $rc, stdout '$out'" "stderr $(head -c 200 "$tmp/err")"
    fi
    "$BUILD/$p" --help >"$tmp/help" 2>"$tmp/err"; rc=$?
    if [ $rc -eq 0 ] && head -n 1 "$tmp/help" | grep -q "^Usage: $p " && [ ! -s "$tmp/err" ]; then
        ok "$p --help exits 0 with 'Usage: $p' on stdout"
    else
        not_ok "$p --help exits 0 with 'Usage: $p' on stdout" "exit $rc, first line '$(head -n 1 "$tmp/help")'"
    fi
done

# --help-config is exactly the key table --help ends with (the man page's source).
"$BUILD/hmdwarpd" --help | sed -n '/^configuration keys (board.ini sections):$/,$p' | tail -n +2 >"$tmp/keys_help"
"$BUILD/hmdwarpd" --help-config >"$tmp/keys"; rc=$?
if [ $rc -eq 0 ] && [ -s "$tmp/keys" ] && cmp -s "$tmp/keys" "$tmp/keys_help"; then
    ok "hmdwarpd --help-config is --help's key table"
else
    not_ok "hmdwarpd --help-config is --help's key table" "exit $rc; $(diff "$tmp/keys" "$tmp/keys_help" | head -n 3)"
fi

# A short run on the simulated board: the summary's first line and the stats file name the version.
"$BUILD/hmdwarpd" --config board/sim/board.ini --duration 0.2 --stats "$tmp/stats.kv" >"$tmp/run" 2>&1; rc=$?
first=$(grep -m 1 'summary —' "$tmp/run")
case $first in
"hmdwarpd $version summary — board 'sim',"*) ok "the run summary's first line names the version" ;;
*) not_ok "the run summary's first line names the version" "exit $rc, line '$first'" ;;
esac
check "--stats has version=$version" grep -qx "version=$version" "$tmp/stats.kv"

# scripts/version.sh on small trees of its own.
mkdir -p "$tmp/src/scripts"
cp scripts/version.sh "$tmp/src/scripts/"
echo 2.3.4 >"$tmp/src/VERSION"
check "no git: VERSION alone" sh -c "[ \"\$('$tmp/src/scripts/version.sh')\" = 2.3.4 ]"
check "HMDWARP_VERSION (a Debian build) wins" sh -c "[ \"\$(HMDWARP_VERSION=2.3.4-1 '$tmp/src/scripts/version.sh')\" = 2.3.4-1 ]"
check "HMDWARP_VERSION with a quote is refused, naming it" \
    sh -c "out=\$(HMDWARP_VERSION='1\"x' '$tmp/src/scripts/version.sh' 2>&1); [ \$? -ne 0 ] && echo \"\$out\" | grep -q 'HMDWARP_VERSION .1\"x.'"
g() { git -C "$tmp/src" -c user.name=t -c user.email=t@t -c init.defaultBranch=main "$@" >/dev/null 2>&1; }
if g init && g add . && g commit -qm one; then
    sha=$(git -C "$tmp/src" rev-parse --short HEAD)
    check "untagged git: VERSION+git.SHA" sh -c "[ \"\$('$tmp/src/scripts/version.sh')\" = 2.3.4+git.$sha ]"
    echo 2.3.5 >"$tmp/src/VERSION"
    check "modified tree: VERSION+git.SHA.dirty" sh -c "[ \"\$('$tmp/src/scripts/version.sh')\" = 2.3.5+git.$sha.dirty ]"
    g checkout VERSION
    g tag -a v2.4.0 -m v2.4.0
    check "tagged commit: git describe without the v" sh -c "[ \"\$('$tmp/src/scripts/version.sh')\" = 2.4.0 ]"
    echo x >>"$tmp/src/VERSION"
    check "tagged, modified: describe's -dirty" sh -c "[ \"\$('$tmp/src/scripts/version.sh')\" = 2.4.0-dirty ]"
    # A source copy inside another git tree (a build directory, a packaging repository) ignores that tree.
    mkdir -p "$tmp/src/sub/scripts"
    cp scripts/version.sh "$tmp/src/sub/scripts/"
    echo 9.9.9 >"$tmp/src/sub/VERSION"
    check "a copy inside another repository: its own VERSION" sh -c "[ \"\$('$tmp/src/sub/scripts/version.sh')\" = 9.9.9 ]"
else
    for d in untagged modified tagged tagged-modified nested; do not_ok "version.sh in a git tree ($d): git init failed"; done
fi

# The manual pages `make man` generated: one per program with its version, and board.ini's with every key.
for p in $PROGS; do
    f=$BUILD/man/$p.1
    th=$(grep -m 1 '^\.TH' "$f" 2>/dev/null)
    case $th in
    ".TH $(echo "$p" | tr a-z A-Z) \"1\" "*"\"$p $version\""*) good=1 ;;
    *) good=0 ;;
    esac
    if [ $good = 1 ]; then
        ok "$f: section 1, version $version"
    else
        not_ok "$f: section 1, version $version" "$th"
    fi
done
f=$BUILD/man/hmdwarp-board.ini.5
keys=$(grep -c '^    [a-z]' "$tmp/keys")
tps=$(grep -c '^\.TP$' "$f" 2>/dev/null)
# The FILES section adds two .TP entries of its own.
if [ -s "$f" ] && [ "$keys" -gt 0 ] && [ "$tps" -eq $((keys + 2)) ] && grep -qx '\.B method' "$f"; then
    ok "$f lists all $keys keys of hmdwarpd's table"
else
    not_ok "$f lists all $keys keys of hmdwarpd's table" "found $tps .TP entries (keys + 2 expected)"
fi
check "hmdwarp-board.ini.5 renders without warnings" sh -c "LC_ALL=C.UTF-8 MANWIDTH=100 man --warnings -l '$f' 2>&1 >/dev/null | grep . && exit 1 || exit 0"
exit $((fails > 0))

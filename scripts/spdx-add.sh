#!/bin/sh
# SPDX-License-Identifier: MIT
# Puts the licence line `SPDX-License-Identifier: MIT` into source files that lack it: `/* ... */` on the first line
# of C and C++ files, `# ...` after the shebang of scripts (or first in makefiles). --list prints the files the
# rule covers (tests/packaging/test_spdx.sh checks the same list).
# usage: scripts/spdx-add.sh FILE...   |   scripts/spdx-add.sh --all   |   scripts/spdx-add.sh --list
set -eu
TAG='SPDX-License-Identifier: MIT'
# Lines at the top of a file that may hold the tag (a shebang, then the tag).
HEAD_LINES=3

cd "$(dirname "$0")/.."

# Source files: C, C++, shell, Python and makefiles by name, and any other file that starts with a shebang;
# documentation and data (Markdown, images, .ini, .dts, benchmark results) are not. Git's view when there is one
# (tracked and new files, not ignored ones), else every file but build/.
candidates() {
    if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
        git ls-files --cached --others --exclude-standard
    else
        find . -path ./build -prune -o -path ./.git -prune -o -type f -print | sed 's|^\./||'
    fi
}
is_source() {
    case $1 in
    *.c | *.h | *.cpp | *.sh | *.py | Makefile | */Makefile | *.mk | Kbuild | */Kbuild | debian/rules) return 0 ;;
    esac
    [ -f "$1" ] && [ "$(head -c 2 "$1")" = '#!' ]
}
list() {
    candidates | sort -u | while IFS= read -r f; do
        [ -f "$f" ] && is_source "$f" && echo "$f"
    done
    return 0
}

add() {
    f=$1
    if head -n "$HEAD_LINES" "$f" | grep -q "$TAG"; then return 0; fi
    if head -n "$HEAD_LINES" "$f" | grep -q 'SPDX-License-Identifier:'; then
        echo "spdx-add: $f: has another SPDX-License-Identifier; left alone" >&2
        return 1
    fi
    case $f in
    *.c | *.h | *.cpp) line="/* $TAG */" ;;
    *) line="# $TAG" ;;
    esac
    if [ ! -s "$f" ]; then
        echo "$line" >"$f"
    elif [ "$(head -c 2 "$f")" = '#!' ]; then
        sed -i "1a\\
$line" "$f"
    else
        sed -i "1i\\
$line" "$f"
    fi
    echo "spdx-add: $f"
}

[ $# -gt 0 ] || { sed -n 's/^# usage: //p' "$0" >&2; exit 2; }
case $1 in
--list) list; exit 0 ;;
--all) set -- $(list) ;;
esac
rc=0
for f in "$@"; do
    if [ ! -f "$f" ]; then
        echo "spdx-add: $f: no such file" >&2; rc=1
    elif ! is_source "$f"; then
        echo "spdx-add: $f: not a source file by the rule (C, C++, shell, Python, makefile, shebang); left alone" >&2
        rc=1
    else
        add "$f" || rc=1
    fi
done
exit $rc

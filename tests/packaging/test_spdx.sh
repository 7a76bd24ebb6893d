#!/bin/sh
# SPDX-License-Identifier: MIT
# Licence lines: every source file (scripts/spdx-add.sh --list: C, C++, shell, Python, makefiles, shebang
# scripts) carries `SPDX-License-Identifier: MIT` in its first 3 lines, and scripts/spdx-add.sh puts it where
# it belongs in a scratch tree. TAP output for tests/run.sh; run from the repository root.
set -u
TAG='SPDX-License-Identifier: MIT'
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# shellcheck source=tests/support/tap.sh
. "$(dirname "$0")/../support/tap.sh"
expect() { # expect DESCRIPTION FILE EXPECTED-CONTENT
    if [ "$(cat "$2")" = "$3" ]; then ok "$1"; else not_ok "$1" "got: $(head -n 3 "$2" | tr '\n' '|')"; fi
}
echo "1..10"

scripts/spdx-add.sh --list >"$tmp/list"
# The rule must keep seeing the tree's sources (a broken rule that lists nothing would pass the next check).
if grep -qx Makefile "$tmp/list" && grep -qx runtime/hmdwarpd_main.c "$tmp/list" && grep -qx tests/run.sh "$tmp/list" \
    && grep -qx .ci/run "$tmp/list" && ! grep -q '\.md$\|\.ini$\|\.png$' "$tmp/list"; then
    ok "the source list has C, make, shell and shebang files, no docs or data ($(wc -l <"$tmp/list") files)"
else
    not_ok "the source list has C, make, shell and shebang files, no docs or data"
fi
while IFS= read -r f; do
    head -n 3 "$f" | grep -q "$TAG" || echo "$f"
done <"$tmp/list" >"$tmp/missing"
if [ ! -s "$tmp/missing" ]; then
    ok "every source file has '$TAG' in its first 3 lines"
else
    not_ok "every source file has '$TAG' in its first 3 lines" \
        "$(wc -l <"$tmp/missing") without it (scripts/spdx-add.sh --all adds it), e.g.:" $(head -n 8 "$tmp/missing")
fi

# scripts/spdx-add.sh in a scratch tree (no git there: it lists by find).
mkdir -p "$tmp/t/scripts" "$tmp/t/docs"
cp scripts/spdx-add.sh "$tmp/t/scripts/"
printf '/* a.c: a module */\nint a;\n' >"$tmp/t/a.c"
printf '#!/bin/sh\n# does things\ntrue\n' >"$tmp/t/run"
printf 'all:\n\ttrue\n' >"$tmp/t/Makefile"
printf '/* SPDX-License-Identifier: GPL-2.0 */\nint b;\n' >"$tmp/t/b.c"
printf '# notes\n' >"$tmp/t/docs/notes.md"
chmod +x "$tmp/t/run"
(cd "$tmp/t" && scripts/spdx-add.sh a.c run Makefile) >"$tmp/out" 2>&1
expect "C: /* ... */ on the first line" "$tmp/t/a.c" "$(printf '/* %s */\n/* a.c: a module */\nint a;' "$TAG")"
expect "script: after the shebang" "$tmp/t/run" "$(printf '#!/bin/sh\n# %s\n# does things\ntrue' "$TAG")"
if [ -x "$tmp/t/run" ]; then ok "the script stays executable"; else not_ok "the script stays executable"; fi
expect "Makefile: # on the first line" "$tmp/t/Makefile" "$(printf '# %s\nall:\n\ttrue' "$TAG")"
cp "$tmp/t/a.c" "$tmp/a.c.1"
(cd "$tmp/t" && scripts/spdx-add.sh a.c) >/dev/null 2>&1
if cmp -s "$tmp/a.c.1" "$tmp/t/a.c"; then ok "a second run changes nothing"; else not_ok "a second run changes nothing"; fi
(cd "$tmp/t" && scripts/spdx-add.sh b.c) >"$tmp/out" 2>&1; rc=$?
if [ $rc -ne 0 ] && grep -q 'b.c: has another SPDX' "$tmp/out" && [ "$(head -n 1 "$tmp/t/b.c")" = '/* SPDX-License-Identifier: GPL-2.0 */' ]
then ok "another licence's tag: an error naming the file, file untouched"
else not_ok "another licence's tag: an error naming the file, file untouched" "exit $rc: $(cat "$tmp/out")"; fi
(cd "$tmp/t" && scripts/spdx-add.sh docs/notes.md) >"$tmp/out" 2>&1; rc=$?
if [ $rc -ne 0 ] && grep -q 'notes.md: not a source file' "$tmp/out" && [ "$(cat "$tmp/t/docs/notes.md")" = '# notes' ]
then ok "a document: refused, naming it, untouched"
else not_ok "a document: refused, naming it, untouched" "exit $rc: $(cat "$tmp/out")"; fi
(cd "$tmp/t" && scripts/spdx-add.sh --list) >"$tmp/out" 2>&1
if [ "$(sort "$tmp/out" | tr '\n' ' ')" = "Makefile a.c b.c run scripts/spdx-add.sh " ]; then ok "--list without git: sources only"
else not_ok "--list without git: sources only" "$(tr '\n' ' ' <"$tmp/out")"; fi
exit $((fails > 0))

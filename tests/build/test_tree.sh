#!/bin/sh
# SPDX-License-Identifier: MIT
# The source tree as committed: no merge conflict markers left in any text file (a README once kept a pair for a
# session). TAP output for tests/run.sh; run from the repository root.
# usage: tests/build/test_tree.sh
set -u
# shellcheck source=tests/support/tap.sh
. "$(dirname "$0")/../support/tap.sh"
echo "1..1"
# text files only (-I), outside build output, git's own files and the fuzz corpus (raw bytes)
hits=$(grep -rInE '^(<<<<<<<|>>>>>>>) ' --exclude-dir=.git --exclude-dir='build*' --exclude-dir=corpus . | head -n 5)
if [ -z "$hits" ]; then
    ok "no merge conflict markers in the tree"
else
    IFS='
'   # one comment line per hit
    # shellcheck disable=SC2086
    not_ok "merge conflict markers in the tree" $hits
fi
echo "$((n - fails)) passed, $fails failed"
exit $((fails > 0))

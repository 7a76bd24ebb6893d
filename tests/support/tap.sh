# SPDX-License-Identifier: MIT
# tap.sh: the TAP result helpers the shell tests share (sourced, POSIX sh): ok and not_ok number the results in n
# and count failures in fails; not_ok's further arguments become comment lines under the result.
# shellcheck shell=sh
n=0
fails=0
ok() { n=$((n + 1)); echo "ok $n - $1"; }
not_ok() { n=$((n + 1)); fails=$((fails + 1)); echo "not ok $n - $1"; shift; for l in "$@"; do echo "#   $l"; done; }

# SPDX-License-Identifier: MIT
# deps-lib.sh: the one "install what is missing" step the board/deps*.sh scripts share (sourced, not run).
# deps_install NAME PKG...: as root apt-get installs the packages not installed yet; otherwise prints the command.

# deps_missing PKG...: the packages (pkg or pkg:arch) dpkg does not have installed, space-separated.
deps_missing() {
    _m=""
    for _p in "$@"; do
        dpkg-query -W -f='${Status}' "$_p" 2>/dev/null | grep -q 'install ok installed' || _m="$_m $_p"
    done
    echo "$_m"
}

# deps_install NAME PKG...: returns 0 when all are installed (or were installed now), 1 with the command to run
# when not root. DEPS_BEFORE_UPDATE (a command, root only) runs before apt-get update, DEPS_HINT (a line) is
# printed before the command for non-root users.
deps_install() {
    _name=$1; shift
    _missing=$(deps_missing "$@")
    [ -z "$_missing" ] && return 0
    if [ "$(id -u)" -eq 0 ]; then
        echo "$_name: installing$_missing"
        export DEBIAN_FRONTEND=noninteractive
        [ -z "${DEPS_BEFORE_UPDATE:-}" ] || eval "$DEPS_BEFORE_UPDATE"
        # An index older than the mirror makes installs fail with 404s; refresh once before installing.
        apt-get update -qq
        # Quiet unless it fails; then again with apt's messages, so the log says which package and why.
        # shellcheck disable=SC2086
        apt-get install -y -qq --no-install-recommends $_missing >/dev/null 2>&1 ||
            apt-get install -y -q --no-install-recommends $_missing
        echo "$_name: done"
    else
        echo "$_name: missing Debian packages:$_missing" >&2
        [ -z "${DEPS_HINT:-}" ] || echo "$_name: run:  $DEPS_HINT" >&2
        echo "$_name: run:  sudo apt-get install -y --no-install-recommends$_missing" >&2
        return 1
    fi
}

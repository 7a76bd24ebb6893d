#!/bin/sh
# flash.sh: puts a `make install DESTDIR=...` tree onto a board: into a mounted SD-card root filesystem, or over
# ssh onto a running board; enables the service. --dry-run checks the tree and prints what it would do.
set -eu

TREE=
ROOT=
SSH=
BOARD=
DRY=0

usage() {
    cat <<'USAGE'
usage: board/flash.sh --tree DIR (--root DIR | --ssh USER@HOST | --dry-run) [options]

  --tree DIR     the staged install: make install PREFIX=/usr DESTDIR=DIR [BOARD=name] [CROSS_COMPILE=...]
  --root DIR     the board's root filesystem, mounted (e.g. an SD card's second partition)
  --ssh TARGET   a running board reachable over ssh (user with sudo rights)
  --board NAME   expect this board's configuration in the tree (board/NAME/board.ini)
  --dry-run      check the tree and print every action without doing it (the exit code says if it is usable)
  -h, --help     this text

The tree must hold hmdwarpd, its systemd unit, udev rules, sysusers entry and /etc/hmdwarp/board.ini; the
service is enabled (multi-user.target) and, over ssh, reloaded and started.
USAGE
}

die() { echo "flash.sh: $*" >&2; exit 1; }
run() {
    if [ "$DRY" -eq 1 ]; then echo "would run: $*"; else "$@"; fi
}

while [ $# -gt 0 ]; do
    case "$1" in
        --tree) TREE=$2; shift 2 ;;
        --root) ROOT=$2; shift 2 ;;
        --ssh) SSH=$2; shift 2 ;;
        --board) BOARD=$2; shift 2 ;;
        --dry-run) DRY=1; shift ;;
        -h|--help) usage; exit 0 ;;
        *) usage >&2; die "unknown argument '$1'" ;;
    esac
done
[ -n "$TREE" ] || { usage >&2; die "--tree DIR is required"; }
[ -d "$TREE" ] || die "--tree $TREE: not a directory"
[ -n "$ROOT$SSH" ] || [ "$DRY" -eq 1 ] || die "say where to: --root DIR, --ssh USER@HOST, or --dry-run"
[ -z "$ROOT" ] || [ -z "$SSH" ] || die "--root and --ssh exclude each other"

# tree_file REL...: the first of these paths that the tree has (the unit and udev rules may be under usr/lib or,
# from an older or overridden install, lib); nothing when none.
tree_file() {
    for tf in "$@"; do
        if [ -e "$TREE/$tf" ]; then echo "$tf"; return 0; fi
    done
}

# ---- check the tree ----
problems=0
need() {
    if [ -n "$1" ]; then echo "ok      /$1"; else echo "MISSING /$2 ($3)"; problems=$((problems + 1)); fi
}
bin=$(find "$TREE" -path '*/bin/hmdwarpd' -type f | head -n 1)
[ -n "$bin" ] || { echo "MISSING bin/hmdwarpd (make install)"; problems=$((problems + 1)); }
[ -z "$bin" ] || echo "ok      ${bin#"$TREE"}"
need "$(tree_file etc/hmdwarp/board.ini)" etc/hmdwarp/board.ini "make install BOARD=name"
unit=$(tree_file usr/lib/systemd/system/hmdwarpd.service lib/systemd/system/hmdwarpd.service)
need "$unit" usr/lib/systemd/system/hmdwarpd.service "the systemd unit"
need "$(tree_file usr/lib/udev/rules.d/99-hmdwarp.rules lib/udev/rules.d/99-hmdwarp.rules)" \
    usr/lib/udev/rules.d/99-hmdwarp.rules "device access for the service user"
need "$(tree_file usr/lib/sysusers.d/hmdwarp.conf)" usr/lib/sysusers.d/hmdwarp.conf "the service user"
if [ -n "$bin" ]; then
    # The unit must start the binary that is in the tree.
    exec_path=$(sed -n 's/^ExecStart=\([^ ]*\).*/\1/p' "$TREE/$unit" 2>/dev/null || true)
    if [ -n "$exec_path" ] && [ ! -e "$TREE$exec_path" ]; then
        echo "WRONG   hmdwarpd.service starts $exec_path, which is not in the tree (PREFIX mismatch?)"
        problems=$((problems + 1))
    fi
    machine=$(od -An -tx1 -j18 -N2 "$bin" | tr -d ' \n')
    case "$machine" in
        b700) arch=aarch64 ;;
        3e00) arch=x86_64 ;;
        2800) arch=arm ;;
        *) arch="unknown ($machine)" ;;
    esac
    echo "info    hmdwarpd is built for $arch"
fi
if [ -n "$BOARD" ] && [ -e "$TREE/etc/hmdwarp/board.ini" ]; then
    name=$(sed -n 's/^name *= *\([^ ;]*\).*/\1/p' "$TREE/etc/hmdwarp/board.ini" | head -n 1)
    if [ "$name" != "$BOARD" ]; then
        echo "WRONG   /etc/hmdwarp/board.ini is for board '$name', not '$BOARD'"
        problems=$((problems + 1))
    fi
fi
# The configuration must load: check it with a hmdwarpd that runs here (the tree's own, or this checkout's).
checker=
if [ -n "$bin" ] && "$bin" --help >/dev/null 2>&1; then checker=$bin
elif [ -x build/hmdwarpd ]; then checker=build/hmdwarpd
fi
if [ -n "$checker" ] && [ -e "$TREE/etc/hmdwarp/board.ini" ]; then
    if "$checker" --check-config --config "$TREE/etc/hmdwarp/board.ini" >/dev/null 2>"${TMPDIR:-/tmp}/flash-check.$$"; then
        echo "ok      board.ini validates"
    else
        echo "INVALID board.ini:"; sed 's/^/          /' "${TMPDIR:-/tmp}/flash-check.$$"
        problems=$((problems + 1))
    fi
    rm -f "${TMPDIR:-/tmp}/flash-check.$$"
fi
[ "$problems" -eq 0 ] || die "$problems problem(s) in $TREE: not installing"

# ---- install ----
if [ -n "$ROOT" ] || [ "$DRY" -eq 1 ] && [ -z "$SSH" ]; then
    dest=${ROOT:-/ROOT}
    [ "$DRY" -eq 1 ] || [ -d "$dest/etc" ] || die "--root $dest does not look like a root filesystem (no etc/)"
    run cp -a "$TREE/." "$dest/"
    run mkdir -p "$dest/etc/systemd/system/multi-user.target.wants"
    run ln -sf "/$unit" "$dest/etc/systemd/system/multi-user.target.wants/hmdwarpd.service"
    if [ "$DRY" -eq 1 ]; then
        echo "flash.sh: the tree is usable (dry run: nothing was written)"
    else
        echo "flash.sh: installed into $dest: the service starts at the next boot (systemd-sysusers creates its"
        echo "          user and groups then)"
    fi
elif [ -n "$SSH" ]; then
    if [ "$DRY" -eq 1 ]; then
        echo "would run: tar -C $TREE -cz . | ssh $SSH sudo tar -C / -xz"
    else
        tar -C "$TREE" -cz . | ssh "$SSH" sudo tar -C / -xz
    fi
    run ssh "$SSH" "sudo systemd-sysusers && sudo udevadm control --reload && sudo udevadm trigger && sudo systemctl daemon-reload && sudo systemctl enable --now hmdwarpd && systemctl --no-pager status hmdwarpd"
fi

#!/bin/sh
# SPDX-License-Identifier: MIT
# flash.sh: puts a `make install DESTDIR=...` tree onto a board: into a mounted SD-card root filesystem, or over
# ssh onto a running board; enables the service. --dry-run checks the tree and prints what it would do.
set -eu

TREE=
ROOT=
SSH=
BOARD=
DRY=0
HERE=$(cd "$(dirname "$0")" && pwd)
CONF=etc/hmdwarp/board.ini
# The unit's calibration (hmdwarpd --calibrate-imu, lens fits): state, not configuration; never written or deleted.
CALIB=var/lib/hmdwarp/calibration.ini

usage() {
    cat <<'USAGE'
usage: board/flash.sh --tree DIR (--root DIR | --ssh USER@HOST | --dry-run) [options]

  --tree DIR     the staged install: make install PREFIX=/usr DESTDIR=DIR [BOARD=name] [CROSS_COMPILE=...]
  --root DIR     the board's root filesystem, mounted (e.g. an SD card's second partition)
  --ssh TARGET   a running board reachable over ssh (user with sudo rights)
  --board NAME   expect this board's configuration in the tree (board/NAME/board.ini)
  --dry-run      check the tree and print every action without doing it (the exit code says if it is usable)
  -h, --help     this text

The tree must hold hmdwarpd, its systemd unit, udev rules, sysusers entry and /etc/hmdwarp/board.ini, and its
programs must be built for the board (the root's own programs, `uname -m` over ssh, or board.ini's [board] arch
say which architecture that is). Everything is unpacked with GNU tar keeping the board's directory symlinks
(merged /usr: /lib -> usr/lib); a board.ini already on the board is kept and the tree's one goes beside it as
board.ini.dist. The board's calibration (/var/lib/hmdwarp/calibration.ini) is never written or deleted, even if
the tree holds one. The service is enabled (multi-user.target) and, over ssh, reloaded and started.
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
[ -z "$ROOT" ] || [ -d "$ROOT" ] || die "--root $ROOT: not a directory"

# ---- helpers ----
# ini_get FILE SECTION KEY: the key's value (inih's rules: ';' after a blank starts a comment); empty when absent.
ini_get() {
    awk -v s="$2" -v k="$3" '
        /^[ \t]*[;#]/ { next }
        /^[ \t]*\[/ { sec = $0; sub(/^[ \t]*\[/, "", sec); sub(/\].*/, "", sec); next }
        sec == s {
            line = $0; sub(/[ \t];.*/, "", line)
            if (match(line, "^[ \t]*" k "[ \t]*=")) {
                v = substr(line, RLENGTH + 1); gsub(/^[ \t]+|[ \t]+$/, "", v); print v; exit
            }
        }' "$1"
}

# elf_arch FILE: the architecture (uname -m's name) an ELF file is built for, from its header's EI_CLASS, EI_DATA
# and e_machine; nothing when FILE is not ELF.
elf_arch() {
    # shellcheck disable=SC2046
    set -- $(od -An -tu1 -N20 "$1" 2>/dev/null)
    [ $# -eq 20 ] && [ "$1 $2 $3 $4" = "127 69 76 70" ] || return 0
    if [ "$6" = 2 ]; then ea_m=$((${19} * 256 + ${20})); else ea_m=$((${20} * 256 + ${19})); fi
    case "$5:$ea_m" in
        2:183) echo aarch64 ;;
        2:62) echo x86_64 ;;
        1:40) echo arm ;;
        1:3) echo i386 ;;
        2:243) echo riscv64 ;;
        *) echo "ELF machine $ea_m ($((32 * $5))-bit)" ;;
    esac
}

# arch_of NAME: uname -m's spellings folded into the names [board] arch uses.
arch_of() {
    case "$1" in
        aarch64|arm64) echo aarch64 ;;
        armv*|arm) echo arm ;;
        i?86) echo i386 ;;
        x86_64|amd64) echo x86_64 ;;
        *) echo "$1" ;;
    esac
}

# in_root PATH: the board's PATH as a path here under $ROOT, following every symlink on the way inside the root
# (an absolute link target names the board's /, not this machine's). Fails on a symlink loop.
in_root() {
    ir_rest=${1#/}; ir_done=; ir_hops=0
    while [ -n "$ir_rest" ]; do
        ir_part=${ir_rest%%/*}
        case "$ir_rest" in */*) ir_rest=${ir_rest#*/} ;; *) ir_rest= ;; esac
        case "$ir_part" in
            ''|.) continue ;;
            ..) ir_done=${ir_done%/*}; continue ;;
        esac
        if [ -L "$ROOT$ir_done/$ir_part" ]; then
            ir_hops=$((ir_hops + 1))
            [ "$ir_hops" -le 40 ] || return 1
            ir_link=$(readlink "$ROOT$ir_done/$ir_part")
            case "$ir_link" in /*) ir_done= ;; esac
            ir_rest=${ir_link#/}${ir_rest:+/$ir_rest}
        else
            ir_done=$ir_done/$ir_part
        fi
    done
    echo "$ROOT$ir_done"
}

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
need "$(tree_file "$CONF")" "$CONF" "make install BOARD=name"
unit=$(tree_file usr/lib/systemd/system/hmdwarpd.service lib/systemd/system/hmdwarpd.service)
need "$unit" usr/lib/systemd/system/hmdwarpd.service "the systemd unit"
need "$(tree_file usr/lib/udev/rules.d/99-hmdwarp.rules lib/udev/rules.d/99-hmdwarp.rules)" \
    usr/lib/udev/rules.d/99-hmdwarp.rules "device access for the service user"
need "$(tree_file usr/lib/sysusers.d/hmdwarp.conf)" usr/lib/sysusers.d/hmdwarp.conf "the service user"
tree_arch=
if [ -n "$bin" ]; then
    # The unit must start the binary that is in the tree.
    exec_path=$(sed -n 's/^ExecStart=\([^ ]*\).*/\1/p' "$TREE/$unit" 2>/dev/null || true)
    if [ -n "$exec_path" ] && [ ! -e "$TREE$exec_path" ]; then
        echo "WRONG   hmdwarpd.service starts $exec_path, which is not in the tree (PREFIX mismatch?)"
        problems=$((problems + 1))
    fi
    tree_arch=$(elf_arch "$bin")
    echo "info    hmdwarpd is built for ${tree_arch:-no known architecture (not an ELF file)}"
fi
board_name=$BOARD
if [ -e "$TREE/$CONF" ]; then
    name=$(ini_get "$TREE/$CONF" board name)
    if [ -n "$BOARD" ] && [ "$name" != "$BOARD" ]; then
        echo "WRONG   /$CONF is for board '$name', not '$BOARD'"
        problems=$((problems + 1))
    fi
    board_name=${board_name:-$name}
fi
# The configuration must load: check it with a hmdwarpd that runs here: the tree's own (natively, or under
# Debian's qemu-user-static when it was built for another machine, as a cross build's is), else this checkout's.
checker='' runner=''
if [ -n "$bin" ] && "$bin" --help >/dev/null 2>&1; then checker=$bin
elif [ -n "$bin" ] && [ -n "${tree_arch:-}" ] && command -v "qemu-$tree_arch-static" >/dev/null 2>&1 \
        && "qemu-$tree_arch-static" "$bin" --help >/dev/null 2>&1; then
    checker=$bin runner=qemu-$tree_arch-static
    echo "info    board.ini checked by the tree's hmdwarpd under qemu-$tree_arch-static"
elif [ -x build/hmdwarpd ]; then checker=build/hmdwarpd
fi
if [ -z "$checker" ] && [ -e "$TREE/$CONF" ]; then
    echo "info    board.ini not checked: no hmdwarpd runs here (the tree's is for ${tree_arch:-another machine}; install qemu-user-static, or make)"
fi
if [ -n "$checker" ] && [ -e "$TREE/$CONF" ]; then
    # shellcheck disable=SC2086
    if $runner "$checker" --check-config --config "$TREE/$CONF" >/dev/null 2>"${TMPDIR:-/tmp}/flash-check.$$"; then
        echo "ok      board.ini validates"
    else
        echo "INVALID board.ini:"; sed 's/^/          /' "${TMPDIR:-/tmp}/flash-check.$$"
        problems=$((problems + 1))
    fi
    rm -f "${TMPDIR:-/tmp}/flash-check.$$"
fi

# ---- the target's architecture: the root's own programs, else uname -m over ssh, else [board] arch ----
target_arch=
target_what=
if [ -n "$ROOT" ]; then
    for p in /usr/bin/env /bin/sh /sbin/init /usr/lib/systemd/systemd; do
        f=$(in_root "$p") || continue
        [ -f "$f" ] || continue
        target_arch=$(elf_arch "$f")
        if [ -n "$target_arch" ]; then target_what="the root $ROOT (its $p)"; break; fi
    done
elif [ -n "$SSH" ]; then
    if m=$(ssh "$SSH" uname -m); then
        target_arch=$(arch_of "$m"); target_what="$SSH (uname -m)"
    elif [ "$DRY" -eq 0 ]; then
        die "cannot reach $SSH over ssh (uname -m failed)"
    else
        echo "info    $SSH not reachable: its architecture from board.ini"
    fi
fi
if [ -z "$target_arch" ]; then
    # The tree's board.ini, or when it does not say, the board's definition (in the tree, else this checkout).
    def=
    [ ! -e "$TREE/$CONF" ] || def="$TREE/$CONF"
    if [ -z "$def" ] || [ -z "$(ini_get "$def" board arch)" ]; then
        def=$(find "$TREE" -path "*/share/hmdwarp/boards/$board_name/board.ini" 2>/dev/null | head -n 1)
        [ -n "$def" ] || [ ! -e "$HERE/$board_name/board.ini" ] || def="$HERE/$board_name/board.ini"
    fi
    a=
    [ -z "$def" ] || a=$(ini_get "$def" board arch)
    if [ -n "$a" ] && [ "$a" != any ]; then target_arch=$a; target_what="the board $board_name"; fi
fi
if [ -z "$target_arch" ]; then
    echo "info    the board${board_name:+ $board_name} runs any architecture ([board] arch = any): not checked"
elif [ -n "$bin" ]; then
    # Every program in the tree, hmdwarpd first: one built for another machine would not start on the board.
    wrong=$({ echo "$bin"; find "$TREE" -path '*/bin/*' -type f | sort; } | while IFS= read -r f; do
        a=$(elf_arch "$f")
        if [ -n "$a" ] && [ "$a" != "$target_arch" ]; then echo "the tree's ${f##*/} is $a"; break; fi
    done)
    if [ -n "$wrong" ]; then
        case "$target_arch" in
            "$(arch_of "$(uname -m)")") hint="rebuild without CROSS_COMPILE" ;;
            aarch64) hint="rebuild with CROSS_COMPILE=aarch64-linux-gnu-" ;;
            arm) hint="rebuild with CROSS_COMPILE=arm-linux-gnueabihf-" ;;
            x86_64) hint="rebuild with CROSS_COMPILE=x86_64-linux-gnu-" ;;
            *) hint="rebuild for it" ;;
        esac
        more=
        [ "$problems" -eq 0 ] || more=" (and $problems problem(s) above)"
        die "$wrong but $target_what is $target_arch: $hint$more"
    fi
    echo "ok      the tree's programs are $target_arch, as $target_what"
fi
[ "$problems" -eq 0 ] || die "$problems problem(s) in $TREE: not installing"

# ---- install ----
# GNU tar, not cp -a: --keep-directory-symlink follows the board's directory symlinks (merged /usr) instead of
# replacing them, --no-overwrite-dir leaves existing directories' owners and modes alone, and the files become
# root's, not the build user's. A board.ini already there is kept; the tree's is renamed board.ini.dist on the way.
TAR_X="--keep-directory-symlink --no-overwrite-dir --exclude=./$CALIB"
TO_DIST="--transform=s,^[.]/etc/hmdwarp/board[.]ini\$,./$CONF.dist,"
KEPT="kept the board's /$CONF; the tree's one is beside it as /$CONF.dist"
KEPT_CALIB="kept the board's calibration /$CALIB (flashing never writes it)"
[ ! -e "$TREE/$CALIB" ] || echo "info    the tree holds /$CALIB: not installed (a unit's calibration is its own)"
wants=etc/systemd/system/multi-user.target.wants
if [ -z "$SSH" ]; then
    dest=${ROOT:-/ROOT}
    [ "$DRY" -eq 1 ] || [ -d "$dest/etc" ] || die "--root $dest does not look like a root filesystem (no etc/)"
    if [ -n "$ROOT" ]; then
        # tar follows a symlink with an absolute target on this machine, not inside the root: refuse rather than
        # write into this machine's directories.
        abs=$(cd "$TREE" && find . -mindepth 1 -type d | while IFS= read -r d; do
            d=${d#./}
            if [ -L "$ROOT/$d" ]; then
                case "$(readlink "$ROOT/$d")" in /*) echo "/$d -> $(readlink "$ROOT/$d")"; break ;; esac
            fi
        done)
        [ -z "$abs" ] || die "the root's $abs is a symlink to an absolute path, which tar would follow on this" \
            "machine, not in the root: make it relative (ln -sfn with a path inside the root)"
    fi
    xform=
    if [ -e "$dest/$CONF" ] || [ -L "$dest/$CONF" ]; then xform=$TO_DIST; fi
    if [ "$DRY" -eq 1 ]; then
        echo "would run: tar -C $TREE --owner=0 --group=0 -cf - . | tar -C $dest $TAR_X -xf -${xform:+ $xform}"
    else
        # shellcheck disable=SC2086
        tar -C "$TREE" --owner=0 --group=0 --numeric-owner -cf - . | tar -C "$dest" $TAR_X -xf - ${xform:+"$xform"}
    fi
    if [ -n "$xform" ]; then
        if [ "$DRY" -eq 1 ]; then echo "would keep $dest/$CONF (the tree's one beside it as board.ini.dist)"
        else echo "flash.sh: $KEPT"; fi
    fi
    if [ -e "$dest/$CALIB" ]; then
        if [ "$DRY" -eq 1 ]; then echo "would keep $dest/$CALIB"; else echo "flash.sh: $KEPT_CALIB"; fi
    fi
    run mkdir -p "$dest/$wants"
    run ln -sf "/$unit" "$dest/$wants/hmdwarpd.service"
    if [ "$DRY" -eq 1 ]; then
        echo "flash.sh: the tree is usable (dry run: nothing was written)"
    else
        echo "flash.sh: installed into $dest: the service starts at the next boot (systemd-sysusers creates its"
        echo "          user and groups then)"
    fi
else
    # One remote command decides about board.ini on the board itself (reading /etc/hmdwarp needs no root).
    remote="if [ -e /$CONF ]; then sudo tar -C / $TAR_X '$TO_DIST' -xzf - && echo \"flash.sh: $KEPT\";"
    remote="$remote else sudo tar -C / $TAR_X -xzf -; fi &&"
    remote="$remote { [ ! -e /$CALIB ] || echo \"flash.sh: $KEPT_CALIB\"; }"   # (tar's failure still fails it)
    if [ "$DRY" -eq 1 ]; then
        echo "would run: tar -C $TREE --owner=0 --group=0 -cz . | ssh $SSH \"$remote\""
    else
        tar -C "$TREE" --owner=0 --group=0 --numeric-owner -cz . | ssh "$SSH" "$remote"
    fi
    run ssh "$SSH" "sudo systemd-sysusers && sudo udevadm control --reload && sudo udevadm trigger && sudo systemctl daemon-reload && sudo systemctl enable --now hmdwarpd && systemctl --no-pager status hmdwarpd"
    [ "$DRY" -eq 0 ] || echo "flash.sh: the tree is usable (dry run: nothing was written)"
fi

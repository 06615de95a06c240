#!/usr/bin/env bash
# Runs the OpenTMCL firmware on an emulated Cortex-M3 (QEMU's lm3s6965evb) with the module's UART on a pty
# whose symlink is LINK: host software opens LINK as a serial port, exactly as with `tmcl serve --pty LINK`.
#
# Usage: scripts/qemu-serve.sh LINK [--module pd28-1021|tmcm-1310|pd-113|tmcm-1140|tmcm-3110|tmcm-6110] [--monitor SOCKET] [--icount]
#   Builds the image (firmware/, release) when it is missing or older than its sources, starts QEMU and
#   prints `serving PD28-1021 at address 1 on LINK` (the ready line of `tmcl serve`) once LINK works.
#   --monitor SOCKET  QEMU's human monitor on a Unix socket (for memory dumps: scripts/qemu-budgets.sh)
#   --icount          deterministic time: one instruction = one nanosecond of virtual time
#   Stops QEMU and removes LINK on SIGINT or SIGTERM (exit code 0). QEMU_IMAGE=ELF runs that image instead;
#   QEMU_SYSTEM_ARM names the emulator (default qemu-system-arm). Works with or without a controlling
#   terminal (from a shell, under setsid, as a service, from Popen(..., start_new_session=True)).
# Needs qemu-system-arm (Debian: apt-get install qemu-system-arm) and, to build, the thumbv7m-none-eabi
# target (rustup target add thumbv7m-none-eabi).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"

usage() { sed -n '2,15p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//' >&2; exit 2; }
[[ $# -ge 1 && "$1" != -* ]] || usage
link="$1"
shift
model=pd28-1021
monitor=""
icount=()
while [[ $# -gt 0 ]]; do
    case "$1" in
        --module) model="${2:?--module needs a model}"; shift 2 ;;
        --monitor) monitor="${2:?--monitor needs a socket path}"; shift 2 ;;
        --icount) icount=(-icount shift=0,sleep=off); shift ;;
        *) usage ;;
    esac
done
# The model's index in tmcl_core::model::MODELS, written as the board configuration word
# (crates/tmcl-mcu/src/strap.rs: "TMC" and the index; the address is shim::STRAP_ADDRESS).
case "$model" in
    pd28-1021) index=0; name=PD28-1021 ;;
    tmcm-1310) index=1; name=TMCM-1310 ;;
    pd-113) index=2; name=PDx-113 ;;
    tmcm-1140) index=3; name=TMCM-1140 ;;
    tmcm-3110) index=4; name=TMCM-3110 ;;
    tmcm-6110) index=5; name=TMCM-6110 ;;
    *) echo "qemu-serve: unknown module \`$model\`; known: pd28-1021, tmcm-1310, pd-113, tmcm-1140, tmcm-3110, tmcm-6110" >&2; exit 2 ;;
esac
strap=$(printf '0x544d43%02x' "$index")

qemu="${QEMU_SYSTEM_ARM:-qemu-system-arm}"
command -v "$qemu" >/dev/null || { echo "qemu-serve: $qemu not found (apt-get install qemu-system-arm)" >&2; exit 3; }

image="${QEMU_IMAGE:-}"
if [[ -z "$image" ]]; then
    target_dir="${CARGO_TARGET_DIR:-$root/target}"
    [[ "$target_dir" = /* ]] || target_dir="$root/$target_dir"
    image="$target_dir/thumbv7m-none-eabi/release/tmcl-lm3s6965"
    newest=$(find "$root/firmware" "$root/crates/tmcl-core" "$root/crates/tmcl-wire" "$root/crates/tmcl-model" \
        "$root/crates/tmcl-mcu" -newer "$image" -type f \( -name '*.rs' -o -name '*.toml' -o -name '*.x' \) \
        -print -quit 2>/dev/null || true)
    if [[ ! -f "$image" || -n "$newest" ]]; then
        echo "qemu-serve: building the firmware image" >&2
        (cd "$root/firmware" && CARGO_TARGET_DIR="$target_dir" cargo build --release --quiet --bin tmcl-lm3s6965) >&2
    fi
fi
[[ -f "$image" ]] || { echo "qemu-serve: no image at $image" >&2; exit 3; }

if [[ -e "$link" && ! -L "$link" ]]; then
    echo "qemu-serve: $link exists and is not a symlink; not replacing it" >&2
    exit 2
fi

work=$(mktemp -d)
qemu_pid=""
holder_pid=""
pts=""
cleanup() {
    if [[ -n "$holder_pid" ]]; then
        kill -TERM "$holder_pid" 2>/dev/null || true
        wait "$holder_pid" 2>/dev/null || true
    fi
    if [[ -n "$qemu_pid" ]] && kill -0 "$qemu_pid" 2>/dev/null; then
        kill -TERM "$qemu_pid" 2>/dev/null || true
        wait "$qemu_pid" 2>/dev/null || true
    fi
    exec 4>&- 2>/dev/null || true
    if [[ -n "$pts" && -L "$link" && "$(readlink "$link")" == "$pts" ]]; then
        rm -f "$link"
        if [[ -n "$holder_pid" && "$(cat "$link.lock" 2>/dev/null)" == "$holder_pid" ]]; then
            rm -f "$link.lock"
        fi
    fi
    rm -rf "$work"
}
stop() { cleanup; exit 0; }
trap stop INT TERM
trap cleanup EXIT

# A monitor of our own on two fifos ($work/ctl.in, $work/ctl.out; QEMU opens them read-write, so neither
# side blocks), and on request one on a Unix socket.
mkfifo "$work/ctl.in" "$work/ctl.out"
# The output files exist before QEMU starts: the loop below reads them at once, and the background job
# may not have opened its redirections yet (a loaded machine made that race visible).
: >"$work/out"
: >"$work/err"
monitor_args=(-chardev "pipe,id=ctl,path=$work/ctl" -mon chardev=ctl,mode=readline)
[[ -n "$monitor" ]] && monitor_args+=(-monitor "unix:$monitor,server=on,wait=off")
"$qemu" -machine lm3s6965evb -display none "${monitor_args[@]}" -serial pty -kernel "$image" \
    -device "loader,addr=0x2000ff00,data=$strap,data-len=4" "${icount[@]}" \
    >"$work/out" 2>"$work/err" </dev/null &
qemu_pid=$!

# QEMU names the pty on its start: "char device redirected to /dev/pts/N (label serial0)".
for _ in $(seq 1 200); do
    pts=$(sed -n 's/^char device redirected to \(\/dev\/[^ ]*\) (label serial0).*/\1/p' "$work/out" "$work/err" | head -1)
    [[ -n "$pts" ]] && break
    kill -0 "$qemu_pid" 2>/dev/null || break
    sleep 0.05
done
if [[ -z "$pts" ]]; then
    echo "qemu-serve: QEMU did not start: $(cat "$work/err")" >&2
    exit 1
fi
# The board's navigation switches (the digital inputs) have pull-ups, which QEMU's GPIO model does not
# apply: a switch reads pressed until it has been released once. Press and release all five, as the
# pull-ups would have them, before the module is announced.
exec 4<>"$work/ctl.out"
echo "sendkey up-down-left-right-ctrl 10" >"$work/ctl.in"
sleep 0.2
# Hold the pty open for the whole run: QEMU stops reading a pty that no one has open and looks again only
# once a second, so a host that opens LINK would wait for its first reply; held open, it never does.
#
# No terminal is opened by this shell itself: started without a controlling terminal as a session leader
# (setsid, a service, Python's Popen(start_new_session=True)), a shell that opens a tty makes it its
# controlling terminal, and then the `timeout dd` reads below, which run in a process group of their own,
# are stopped by SIGTTIN. A child that is no session leader never acquires one: a holder process keeps the
# pty open, and every read and write opens it in a child (a redirection of an external command or a
# subshell).
sleep infinity 3<>"$pts" &
holder_pid=$!
# QEMU reads a pty only once it has noticed that someone opened it, which it checks once a second; until
# then a host's bytes pile up and reach the UART together, as one burst without the gaps that end a
# partial frame. So ask the module something through our own descriptor (136 type 1, the version, which
# changes nothing) and announce LINK only once the answer is back. Bytes that reach the UART before the
# firmware has set it up are lost (as on a module that is still booting), so the question is repeated;
# answers to earlier copies are read away before LINK appears.
version_reply=02016488
answers=""
for _ in $(seq 1 12); do
    (printf '\x01\x88\x01\x00\x00\x00\x00\x00\x8a' >"$pts")
    answers+=$(timeout 2.5 dd bs=64 count=1 status=none <"$pts" 2>/dev/null | od -An -tx1 | tr -d ' \n' || true)
    [[ "$answers" == *"$version_reply"* ]] && break
    kill -0 "$qemu_pid" 2>/dev/null || break
done
if [[ "$answers" != *"$version_reply"* ]]; then
    echo "qemu-serve: the firmware did not answer on $pts (got '$answers'): $(cat "$work/err")" >&2
    exit 1
fi
while [[ -n "$(timeout 0.3 dd bs=64 count=1 status=none <"$pts" 2>/dev/null | od -An -tx1 || true)" ]]; do :; done
ln -sfn "$pts" "$link.tmp.$$"
mv -Tf "$link.tmp.$$" "$link"
# As `tmcl serve` does: LINK.lock names the process that holds the pty for the link, so that hosts do not
# count it as another host (`tmcl --port LINK`), and know when it is gone.
echo "$holder_pid" >"$link.lock"
echo "serving $name at address 1 on $link"
set +e
wait "$qemu_pid"
rc=$?
qemu_pid=""
echo "qemu-serve: QEMU exited with $rc: $(cat "$work/err")" >&2
exit 1

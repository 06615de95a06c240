#!/usr/bin/env bash
# The pty path: round trips and system calls per request of `tmcl serve` and the Rust client
# (tmcl-host's SerialTransport) next to the floor, a minimal C echo over a pty (scripts/pty-echo.c, built
# here with cc).
#
# Usage: scripts/pty-bench.sh [ROUNDS] [REQUESTS]      (default 5 rounds of 20 000 requests)
#   BEFORE_BENCH=PATH: also the `throughput` bench of another build (its client, `--only pty`: 20 000
#   requests to a `tmcl serve` it starts itself, this checkout's), in the same rounds, and its system calls
#   per request against this checkout's `tmcl serve`.
#   Each round runs, one after the other: the C echo (blocking read/write), the C echo waiting in poll()
#   before each read (as a server with deadlines must), and `tmcl serve --pty` with the Rust client
#   (`throughput --only pty`, GAP 1); each prints its median, p90, p99 round trip. Then once each under
#   `strace -c` (server attached with -p, client run under it): the system calls per request on both sides
#   (calls / requests, for the calls made at least once per two requests).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
rounds=${1:-5}
n=${2:-20000}
cargo build --quiet --release -p tmcl-cli --bench throughput --bin tmcl
bench=$(ls -t target/release/deps/throughput-* | grep -v '\.d$' | head -1)
tmcl=target/release/tmcl
tmp=$(mktemp -d)
server=
cleanup() {
    [[ -n "$server" ]] && kill "$server" 2>/dev/null && wait "$server" 2>/dev/null
    rm -rf "$tmp"
}
trap cleanup EXIT
cc -O2 -o "$tmp/pty-echo" scripts/pty-echo.c -lutil

wait_link() { for _ in $(seq 500); do [[ -L "$1" ]] && return; sleep 0.01; done; echo "no link $1" >&2; exit 1; }
start() { # start NAME: a server on $tmp/NAME, its PID in $server
    case "$1" in
        c) "$tmp/pty-echo" serve "$tmp/c" & ;;
        cpoll) "$tmp/pty-echo" serve "$tmp/cpoll" poll & ;;
        rust | before) "$tmcl" serve --pty "$tmp/$1" >/dev/null & ;;
    esac
    server=$!
    wait_link "$tmp/$1"
}
stop() { kill "$server"; wait "$server" 2>/dev/null || true; server=; }
client() { # client NAME: N round trips on $tmp/NAME
    case "$1" in
        c | cpoll) "$tmp/pty-echo" client "$tmp/$1" "$n" ;;
        rust) PTY_LINK="$tmp/rust" PTY_N="$n" "$bench" --only pty | sed 's/^pty round trip (GAP 1, Rust client) *//' ;;
    esac
}
label() { case "$1" in c) echo "C echo      " ;; cpoll) echo "C echo, poll" ;; rust) echo "tmcl serve  " ;; before) echo "tmcl serve, client before" ;; esac; }

for r in $(seq "$rounds"); do
    for s in c cpoll rust; do
        start "$s"
        echo "round $r $(label "$s") $(client "$s")"
        stop
    done
    if [[ -n "${BEFORE_BENCH:-}" ]]; then
        echo "round $r before       $("$BEFORE_BENCH" --only pty | sed 's/^pty round trip (GAP 1, Rust client) *//')"
    fi
done

per_request() { # the strace -c table in $1: calls per request
    awk -v n="$n" '$0 ~ /^ *[0-9.]+ +[0-9.]+ +[0-9]+ +[0-9]+/ {
        calls = $4; name = $NF; if (name != "total" && calls >= n / 2) printf " %s %.2f", name, calls / n }' "$1"
}
traced="c cpoll rust"
[[ -n "${BEFORE_BENCH:-}" ]] && traced="$traced before"
for s in $traced; do
    start "$s"
    strace -c -f -o "$tmp/server.txt" -p "$server" 2>/dev/null &
    tracer=$!
    sleep 0.5
    case "$s" in
        c | cpoll) strace -c -f -o "$tmp/client.txt" "$tmp/pty-echo" client "$tmp/$s" "$n" >/dev/null ;;
        rust) PTY_LINK="$tmp/rust" PTY_N="$n" strace -c -f -o "$tmp/client.txt" "$bench" --only pty >/dev/null ;;
        before) PTY_LINK="$tmp/before" PTY_N="$n" strace -c -f -o "$tmp/client.txt" "$BEFORE_BENCH" --only pty >/dev/null ;;
    esac
    kill -INT "$tracer"
    wait "$tracer" 2>/dev/null || true
    stop
    echo "syscalls per request, $(label "$s"): server$(per_request "$tmp/server.txt"); client$(per_request "$tmp/client.txt")"
done

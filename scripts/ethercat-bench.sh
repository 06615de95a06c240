#!/usr/bin/env bash
# The EtherCAT figures of docs/benchmarks.md, each run in a network namespace of its own (`unshare -n`,
# a veth pair; needs root):
#   - round trips of single-datagram frames (a BRD of AL status) from a raw socket on the master's end of
#     the veth pair through `tmcl serve --ethercat` and back;
#   - for each cycle time, pysoem cycling the process data (LRW, velocity mode) for SECONDS: lost working
#     counters, the slave's state at the end, the master's worst lateness.
#
# Usage: scripts/ethercat-bench.sh [SECONDS [CYCLE_US...]]    (default: 60 s; 2000 1000 500 250 125 µs)
#   RT=1 runs master and server with SCHED_FIFO priority 20 (chrt), as EtherCAT masters usually run.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

seconds="${1:-60}"
shift || true
cycles=("$@")
[[ ${#cycles[@]} -gt 0 ]] || cycles=(2000 1000 500 250 125)

cargo build --quiet --release -p tmcl-cli
tmcl="${CARGO_TARGET_DIR:-$root/target}/release/tmcl"
[[ -x .venv/bin/python ]] || python3 -m venv .venv
.venv/bin/python -m pip install --quiet --disable-pip-version-check -r tests/python/requirements.txt
rt=()
[[ "${RT:-0}" == 1 ]] && rt=(chrt -f 20)

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
run() {
    rm -rf "$work"/*
    unshare -n "${rt[@]}" .venv/bin/python tests/python/ethercat_master.py "$@" --tmcl "$tmcl" --dir "$work"
}
echo "# $(date -u +%FT%TZ), load $(cut -d' ' -f1-3 /proc/loadavg), RT=${RT:-0}"
run roundtrip --frames 20000
for c in "${cycles[@]}"; do
    run cycle --cycle-us "$c" --seconds "$seconds"
done

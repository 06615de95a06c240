#!/usr/bin/env bash
# A fleet of virtual modules on one machine, idle of host traffic: CPU and memory of `tmcl serve --fleet`.
#
# Usage: scripts/fleet-bench.sh [--quick] [BEFORE_TMCL]
#   Builds this checkout's `throughput` bench and `tmcl` (release) and runs `--only fleet`: 100 modules on
#   37 lines (34 TMCM-1310s, each alone on its pty as on its USB port; 33 PD28-1021s and 33 PDx-113s on
#   three RS485 buses of 22), set going by a host (each TMCM-1310's encoder initialised and its loop
#   closed, every third module turning), then left without host traffic for 30 s (10 s with --quick)
#   while the CPU time (user + system, /proc/PID/stat) of the serving process(es) is measured; two
#   rounds. Variants: loop closed; loop closed and nothing turning; loop open; loop open and nothing
#   turning (the serve loops' own cost).
#   Memory: the resident set (VmRSS) of `tmcl serve` with one module, and of the fleet after one request to
#   every module; the difference over 99 is what a module costs beyond the process.
#   BEFORE_TMCL: a `tmcl` binary from before `--fleet`, served as one `tmcl serve` per line (what a
#   fleet took before), measured in the same run. FLEET_COMPARE=PATH (environment): another build's `tmcl`,
#   served with --fleet and its loops closed, alternating with this build's.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
args=(--only fleet)
if [[ "${1:-}" == "--quick" ]]; then
    args+=(--quick)
    shift
fi
if [[ -n "${1:-}" ]]; then
    FLEET_BEFORE="$(realpath "$1")"
    export FLEET_BEFORE
fi
cargo bench -p tmcl-cli --bench throughput -- "${args[@]}"

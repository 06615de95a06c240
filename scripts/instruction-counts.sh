#!/usr/bin/env bash
# Machine instructions per unit of work on the hot paths, counted by valgrind's callgrind: the same count
# whatever else the machine is doing, so two builds compare exactly (run this once with both).
#
# Usage: scripts/instruction-counts.sh [BENCH_BINARY...]
#   With no argument it builds this checkout's `throughput` bench (cargo bench -p tmcl-cli --bench
#   throughput) and measures it; give the paths of other builds of that bench (an older checkout's
#   target/release/deps/throughput-*) to compare them in the same run.
#
# Figures, per binary:
#   GAP / SAP / MVP  instructions per frame through Module::receive (parse, execute, reply), 1 M frames
#                    each with time advancing 1 µs per frame (`--quick --only core`, one callgrind dump
#                    per frame kind), module start-up included (one per million frames);
#   VM               instructions per TMCL instruction of the CALC/COMP/JC loop, 1 M instructions
#                    (`--quick --only vm`);
#   motion tick      instructions per 1 ms motion tick of the §2.4 program over one hour of module time,
#                    3.6 M ticks, program machine and simulated free axis included (`--only motion`: tick
#                    by tick, the reference);
#   hour (events)    instructions of the same hour event-driven, in millions (`--only events`; builds
#                    from before event-driven time have no such part and print the process alone).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
bins=("$@")
if [ ${#bins[@]} -eq 0 ]; then
    cargo build --release -p tmcl-cli --bench throughput >&2
    bins=("$(ls -t target/release/deps/throughput-* | grep -v '\.d$' | head -1)")
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
summary() { grep -E '^summary:' "$1" | awk '{print $2}'; }
printf '%-70s %8s %8s %8s %8s %12s %14s\n' binary GAP SAP MVP VM "motion tick" "hour (events)"
for bin in "${bins[@]}"; do
    valgrind --tool=callgrind --dump-after='*core_rate*' --callgrind-out-file="$tmp/core" "$bin" --quick --only core \
        >/dev/null 2>&1
    valgrind --tool=callgrind --callgrind-out-file="$tmp/vm" "$bin" --quick --only vm >/dev/null 2>&1
    valgrind --tool=callgrind --callgrind-out-file="$tmp/motion" "$bin" --only motion >/dev/null 2>&1
    valgrind --tool=callgrind --callgrind-out-file="$tmp/events" "$bin" --only events >/dev/null 2>&1
    printf '%-70s %8.0f %8.0f %8.0f %8.1f %12.0f %14.2f\n' "$bin" \
        "$(echo "$(summary "$tmp/core.1") / 1000000" | bc -l)" \
        "$(echo "$(summary "$tmp/core.2") / 1000000" | bc -l)" \
        "$(echo "$(summary "$tmp/core.3") / 1000000" | bc -l)" \
        "$(echo "$(summary "$tmp/vm") / 1000000" | bc -l)" \
        "$(echo "$(summary "$tmp/motion") / 3600000" | bc -l)" \
        "$(echo "$(summary "$tmp/events") / 1000000" | bc -l)"
    rm -f "$tmp"/*
done

#!/usr/bin/env bash
# A fuzzing campaign: every cargo-fuzz target for RUNS executions (default 10 million) from an empty
# corpus, JOBS targets at a time (default 2). Needs a nightly toolchain and cargo-fuzz.
#
# Usage: scripts/fuzz-campaign.sh [RUNS] [JOBS]      (TARGETS="a b" to run only those targets)
#
# The targets are built with optimisations and without a sanitizer (`-O -s none`): the code under test
# has no `unsafe`, so AddressSanitizer finds nothing a Rust panic would not, and costs a factor of 3-5 in
# executions. Inputs are at most 512 bytes. Each target's log, with libFuzzer's final "Done N runs in S
# second(s)", is in target/fuzz-campaign/TARGET.log; a crash stops that target with its input saved
# under fuzz/artifacts/TARGET/ and this script exits non-zero.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
runs="${1:-10000000}"
jobs="${2:-2}"
out=target/fuzz-campaign
mkdir -p "$out"
(cd fuzz && cargo +nightly fuzz build -O -s none)
targets=${TARGETS:-$(cd fuzz && cargo +nightly fuzz list)}
run_one() {
    local t=$1
    local corpus="$out/corpus-$t"
    rm -rf "$corpus" && mkdir -p "$corpus"
    if (cd fuzz && cargo +nightly fuzz run "$t" -O -s none "../$corpus" -- -runs="$runs" -max_len=512 \
        -rss_limit_mb=2048 -print_final_stats=1) > "$out/$t.log" 2>&1; then
        echo "$t: $(grep -E '^Done [0-9]+ runs' "$out/$t.log" | tail -1), no crash"
    else
        echo "$t: FAILED, see $out/$t.log"
        return 1
    fi
}
export -f run_one
export out runs
status=0
printf '%s\n' $targets | xargs -P "$jobs" -I{} bash -c 'run_one {}' || status=1
exit $status

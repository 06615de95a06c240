#!/usr/bin/env bash
# A fuzzing campaign: every cargo-fuzz target for RUNS executions (default 10 million) from an empty
# corpus, JOBS fuzzer processes at a time (default 2). Needs a nightly toolchain and cargo-fuzz.
#
# Usage: scripts/fuzz-campaign.sh [RUNS] [JOBS]
#   TARGETS="a b"       only those targets (default: all, `cargo fuzz list`)
#   CHUNK=N             run in chunks of N runs (default: RUNS, one go); see "Resuming" below
#   TRACE_COMPARES=0    build without libFuzzer's comparison tracing (see below)
#
# The targets are built with optimisations and without a sanitizer (`-O -s none`): the code under test
# has no `unsafe`, so AddressSanitizer finds nothing a Rust panic would not, and costs a factor of 3-5 in
# executions. Inputs are at most 512 bytes.
#
# Comparison tracing (`-sanitizer-coverage-trace-compares`, cargo-fuzz's default) reports every integer
# comparison to libFuzzer so that it can find magic values. The simulating targets (`closed_loop`,
# `event_driven`) compare in every motion tick: there the hooks took about 60 % of the time, and without
# them a run costs a third (docs/benchmarks.md, "Fuzzing campaign"). Their inputs are small numbers in
# fixed places, which plain edge coverage and mutation find.
#
# Resuming: with CHUNK set, each target's runs are recorded chunk by chunk in
# target/fuzz-campaign/TARGET.ledger (`CODE RUNS SECONDS`, one line per chunk, CODE being the git trees of
# the code under test) and its corpus is kept in target/fuzz-campaign/corpus-TARGET, so an interrupted
# campaign goes on where it stopped. A ledger of other code (a commit that changed crates/, fuzz/ or the
# lock file) is moved aside with its corpus and the target starts from an empty corpus. The code must be
# committed: a working tree that differs from HEAD there is refused. With JOBS above the number of targets
# left, several processes fuzz one target, sharing its corpus from chunk to chunk (each loads the
# other's finds when its next chunk starts; a target may end up to a chunk per extra job past RUNS).
#
# Each chunk's log, with libFuzzer's final "Done N runs in S second(s)", is in
# target/fuzz-campaign/TARGET.log (TARGET.JOB.log for the jobs after the first); a crash stops that job
# with its input saved under fuzz/artifacts/TARGET/ and this script exits non-zero.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
runs="${1:-10000000}"
jobs="${2:-2}"
chunk="${CHUNK:-$runs}"
out=target/fuzz-campaign
mkdir -p "$out"
flags=(-O -s none)
if [ "${TRACE_COMPARES:-1}" = 0 ]; then flags+=(--no-trace-compares); fi
if [ -n "${CHUNK:-}" ] && ! git diff --quiet HEAD -- crates fuzz Cargo.lock Cargo.toml; then
    echo "fuzz-campaign: crates/, fuzz/ or the lock file differ from HEAD; commit first (CHUNK resumes by commit)" >&2
    exit 2
fi
code=$(git rev-parse HEAD:crates HEAD:fuzz HEAD:Cargo.lock | cut -c1-12 | paste -sd+)
(cd fuzz && cargo +nightly fuzz build "${flags[@]}")
targets=${TARGETS:-$(cd fuzz && cargo +nightly fuzz list)}

# The runs recorded for TARGET on this code.
done_runs() {
    awk -v code="$code" '$1 == code { n += $2 } END { print n + 0 }' "$out/$1.ledger" 2>/dev/null || echo 0
}

for t in $targets; do
    corpus="$out/corpus-$t"
    if [ -z "${CHUNK:-}" ]; then
        rm -rf "$corpus" "$out/$t.ledger"
    elif [ -f "$out/$t.ledger" ] && grep -qv "^$code " "$out/$t.ledger"; then
        stamp=$(date +%Y%m%d-%H%M%S)
        echo "$t: the ledger holds runs of other code; moved aside as $t.ledger.$stamp"
        mv "$out/$t.ledger" "$out/$t.ledger.$stamp"
        rm -rf "$corpus.$stamp" && mv "$corpus" "$corpus.$stamp" 2>/dev/null || true
    fi
    mkdir -p "$corpus"
done

# One job: the targets in turn, starting at the JOB-th, each chunk by chunk until its runs are done
# (in one go, only its own targets).
run_job() {
    local job=$1 t corpus left n log secs
    local -a list=($targets)
    for ((i = 0; i < ${#list[@]}; i++)); do
        t=${list[$(((i + job) % ${#list[@]}))]}
        # In one go, a target is one job's: job J takes the targets J, J + JOBS, ...
        if [ "$chunk" = "$runs" ] && [ $(((i + job) % ${#list[@]} % jobs)) != "$job" ]; then continue; fi
        corpus="$out/corpus-$t"
        log="$out/$t.log"
        [ "$job" = 0 ] || log="$out/$t.$job.log"
        while left=$((runs - $(done_runs "$t"))); [ "$left" -gt 0 ]; do
            n=$((left < chunk ? left : chunk))
            if ! (cd fuzz && cargo +nightly fuzz run "$t" "${flags[@]}" "../$corpus" -- -runs="$n" \
                -max_len=512 -rss_limit_mb=2048 -print_final_stats=1) > "$log" 2>&1; then
                echo "$t: FAILED, see $log"
                return 1
            fi
            secs=$(sed -nE 's/^Done ([0-9]+) runs in ([0-9]+) second.*/\1 \2/p' "$log" | tail -1)
            (flock 9; echo "$code $secs" >> "$out/$t.ledger") 9>> "$out/$t.ledger.lock"
            echo "$t (job $job): $(awk '{print $1" runs in "$2" s"}' <<< "$secs"); $(done_runs "$t") of $runs on this code"
        done
    done
}
export -f run_job done_runs
export out runs chunk code targets jobs
export flags_text="${flags[*]}"
status=0
seq 0 $((jobs - 1)) | xargs -P "$jobs" -I{} bash -c 'flags=($flags_text); run_job {}' || status=1
for t in $targets; do echo "$t: $(done_runs "$t") runs on code $code, $(awk -v c="$code" '$1 == c { s += $3 } END { print s + 0 }' "$out/$t.ledger" 2>/dev/null) s"; done
exit $status

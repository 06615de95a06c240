#!/usr/bin/env bash
# Runs every test of OpenTMCL: formatting, lints, the no_std build of the firmware crates, the Rust unit,
# property and integration tests (ethercrab drives the EtherCAT slave in memory), the Python
# host-compatibility suite (pytrinamic over a pty and TCP; pysoem against the EtherCAT slave in network
# namespaces of its own, skipped with a message without root), and a short fuzzing run of every fuzz
# target when cargo-fuzz and a nightly toolchain are installed.
#
# Usage: scripts/test.sh            (FUZZ_SECONDS=N to fuzz each target N seconds; 0 skips fuzzing)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

step() { printf '\n== %s\n' "$*"; }

step "cargo fmt --check"
cargo fmt --all -- --check

step "cargo clippy (all targets, warnings are errors)"
cargo clippy --workspace --all-targets --quiet -- -D warnings

step "documentation (broken links are errors)"
RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps --quiet

step "no_std, heap-free firmware crates"
cargo build --quiet -p tmcl-wire -p tmcl-model -p tmcl-core -p tmcl-ethercat --no-default-features

step "Rust tests"
cargo test --workspace --quiet 2>&1 | tee "${CARGO_TARGET_DIR:-target}/rust-tests.log" | grep -E "^(test result|error|failures:|---- )" || true
if grep -qE "^test result: FAILED|^error" "${CARGO_TARGET_DIR:-target}/rust-tests.log"; then
    echo "Rust tests failed (full log: target/rust-tests.log)" >&2
    exit 1
fi
passed=$(grep -oE "^test result: ok\. [0-9]+ passed" "${CARGO_TARGET_DIR:-target}/rust-tests.log" | awk '{s+=$4} END {print s+0}')
echo "rust: ${passed} passed, 0 failed"

step "Python host-compatibility suite (pytrinamic, pyserial, tmcl CLI against tmcl serve)"
scripts/python-tests.sh

fuzz_seconds="${FUZZ_SECONDS:-20}"
if [[ "$fuzz_seconds" != 0 ]] && command -v cargo-fuzz >/dev/null && rustup toolchain list 2>/dev/null | grep -q nightly; then
    step "fuzzing each target for ${fuzz_seconds}s"
    for target in $(cd fuzz && cargo +nightly fuzz list); do
        (cd fuzz && cargo +nightly fuzz run "$target" -- -max_total_time="$fuzz_seconds" -rss_limit_mb=2048) \
            > "target/fuzz-$target.log" 2>&1 || { tail -40 "target/fuzz-$target.log"; exit 1; }
        grep -E "^Done|#[0-9]+.*DONE" "target/fuzz-$target.log" | tail -1 || true
        echo "fuzz $target: no crash in ${fuzz_seconds}s"
    done
else
    step "fuzzing skipped (needs cargo-fuzz and a nightly toolchain; the harnesses also run as property tests above)"
fi

step "all tests passed"

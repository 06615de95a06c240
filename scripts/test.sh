#!/usr/bin/env bash
# Runs every test of OpenTMCL: formatting, lints, the no_std build of the firmware crates, the firmware
# image for the emulated Cortex-M3 (firmware/, its own workspace), the Rust unit, property and integration
# tests (ethercrab drives the EtherCAT slave in memory), the Python host-compatibility suite (pytrinamic
# over a pty and TCP; pysoem against the EtherCAT slave in network namespaces of its own, skipped with a
# message without root) against `tmcl serve` and against the image under QEMU, and a short fuzzing run of
# every fuzz target when cargo-fuzz and a nightly toolchain are installed. The QEMU steps are skipped, with a
# message, where qemu-system-arm or the thumbv7m-none-eabi target is missing (.ci/run installs both where
# it can).
#
# Usage: scripts/test.sh            (FUZZ_SECONDS=N to fuzz each target N seconds; 0 skips fuzzing)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

step() { printf '\n== %s\n' "$*"; }
logs="${CARGO_TARGET_DIR:-target}"
mkdir -p "$logs"
thumb=thumbv7m-none-eabi

step "cargo fmt --check"
cargo fmt --all -- --check

step "cargo clippy (all targets, warnings are errors)"
cargo clippy --workspace --all-targets --quiet -- -D warnings

step "documentation (broken links are errors)"
RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps --quiet

step "no_std, heap-free firmware crates"
cargo build --quiet -p tmcl-wire -p tmcl-model -p tmcl-core -p tmcl-ethercat --no-default-features

step "firmware image for the Cortex-M3 (firmware/: fmt, clippy, release build for $thumb)"
image_ok=0
if rustc --print target-libdir --target "$thumb" >/dev/null 2>&1 && [[ -d "$(rustc --print target-libdir --target "$thumb")" ]]; then
    (cd firmware && cargo fmt -- --check && cargo clippy --all-targets --quiet -- -D warnings \
        && cargo build --release --quiet)
    image_ok=1
    echo "firmware image built"
else
    echo "SKIPPED: the $thumb target is not installed (rustup target add $thumb); no firmware image"
fi

step "Rust tests"
cargo test --workspace --quiet 2>&1 | tee "$logs/rust-tests.log" | grep -E "^(test result|error|failures:|---- )" || true
if grep -qE "^test result: FAILED|^error" "$logs/rust-tests.log"; then
    echo "Rust tests failed (full log: $logs/rust-tests.log)" >&2
    exit 1
fi
passed=$(grep -oE "^test result: ok\. [0-9]+ passed" "$logs/rust-tests.log" | awk '{s+=$4} END {print s+0}')
echo "rust: ${passed} passed, 0 failed"

step "Python host-compatibility suite (pytrinamic, pyserial, tmcl CLI against tmcl serve; test_qemu.py against the image)"
scripts/python-tests.sh

step "the opentmcl Python package (wheel built, installed in a fresh venv, its own pytest suite)"
scripts/python-package-tests.sh

step "library crates packaged (cargo package: metadata, READMEs, versioned path dependencies)"
# --no-verify: every crate is built and tested above; a verifying run rebuilds each from its .crate
# (about 10 minutes on 2 cores; run it by hand before a release).
cargo package --workspace --exclude opentmcl-python --no-verify --allow-dirty --quiet
ls "${CARGO_TARGET_DIR:-target}"/package/*.crate | sed 's|.*/|packaged |'

step "the crates' examples (built by cargo test above), run"
for example in "tmcl-wire frames" "tmcl-model parameters" "tmcl-core own_board" "tmcl-sim simulated_module" \
    "tmcl-host read_parameter" "tmcl-asm assemble" "tmcl-mcu uart_and_ring" "tmcl-run manual_program" "tmcl-ethercat al_states" \
    "tmcl-serve serve_and_read" "tmcl-ui workbench"; do
    set -- $example
    cargo run --quiet -p "$1" --example "$2" > "$logs/example-$2.log" || { cat "$logs/example-$2.log"; exit 1; }
    echo "example $1/$2 ran"
done

step "the same suite against the firmware image under QEMU (scripts/qemu-serve.sh)"
if [[ "$image_ok" == 1 ]] && command -v qemu-system-arm >/dev/null; then
    scripts/python-tests.sh --target qemu --ignore=tests/python/test_qemu.py
else
    echo "SKIPPED: needs qemu-system-arm (apt-get install qemu-system-arm) and the $thumb target"
fi

fuzz_seconds="${FUZZ_SECONDS:-20}"
if [[ "$fuzz_seconds" != 0 ]] && command -v cargo-fuzz >/dev/null && rustup toolchain list 2>/dev/null | grep -q nightly; then
    step "fuzzing each target for ${fuzz_seconds}s"
    for target in $(cd fuzz && cargo +nightly fuzz list); do
        (cd fuzz && cargo +nightly fuzz run "$target" -- -max_total_time="$fuzz_seconds" -rss_limit_mb=2048) \
            > "$logs/fuzz-$target.log" 2>&1 || { tail -40 "$logs/fuzz-$target.log"; exit 1; }
        grep -E "^Done|#[0-9]+.*DONE" "$logs/fuzz-$target.log" | tail -1 || true
        echo "fuzz $target: no crash in ${fuzz_seconds}s"
    done
else
    step "fuzzing skipped (needs cargo-fuzz and a nightly toolchain; the harnesses also run as property tests above)"
fi

step "all tests passed"

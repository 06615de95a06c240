#!/usr/bin/env bash
# Builds the opentmcl wheel (python/, PyO3 + maturin, abi3), installs it into a fresh venv with no
# checkout on sys.path, and runs the package's own pytest suite (python/tests) and the example test file
# (python/examples, pytrinamic's TMCM1021 and TMCM1311 against the plugin's fixture) from a copy outside
# the checkout. Needs `tmcl` for the test that compares opentmcl.run with `tmcl run` (TMCL_BIN, else the
# release build is made).
#
# Usage: scripts/python-package-tests.sh [pytest args...]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
target_dir="${CARGO_TARGET_DIR:-$root/target}"
work="$target_dir/opentmcl-package"
rm -rf "$work"
mkdir -p "$work"

# maturin, pinned, in a build venv of its own.
build_venv="$target_dir/opentmcl-build-venv"
if [[ ! -x "$build_venv/bin/maturin" ]]; then
    python3 -m venv "$build_venv"
    "$build_venv/bin/python" -m pip install --disable-pip-version-check --quiet "maturin==1.9.6"
fi
"$build_venv/bin/maturin" build --release --quiet -m python/Cargo.toml -o "$work/wheels"
wheel="$(ls "$work"/wheels/opentmcl-*.whl)"
echo "python-package-tests: built $(basename "$wheel") ($(du -k "$wheel" | cut -f1) KiB)" >&2

if [[ -z "${TMCL_BIN:-}" ]]; then
    cargo build --quiet --release -p tmcl-cli
    TMCL_BIN="$target_dir/release/tmcl"
fi
export TMCL_BIN

# A fresh venv: the wheel and the test tools only (pytrinamic and pyserial at the suite's pins).
python3 -m venv "$work/venv"
"$work/venv/bin/python" -m pip install --disable-pip-version-check --quiet "$wheel" \
    "$(grep -E '^pytest==' tests/python/requirements.txt)" \
    "$(grep -E '^pytrinamic==' tests/python/requirements.txt)" \
    "$(grep -E '^pyserial==' tests/python/requirements.txt)"
# The suite and the example test file run from a copy outside the checkout, so that only the installed
# package can be imported.
cp -r python/tests "$work/tests"
cp -r python/examples "$work/examples"
cd "$work"
exec "$work/venv/bin/python" -m pytest -q -p no:cacheprovider tests examples "$@"

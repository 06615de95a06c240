#!/usr/bin/env bash
# Runs the Python host-compatibility suite (tests/python) against `tmcl serve`:
# pytrinamic, pyserial and the `tmcl` host CLI talk to a virtual PD28-1021 over a pty and TCP.
#
# Usage: scripts/python-tests.sh [--debug] [pytest args...]
#   Creates .venv in the repository root if it is missing, installs the pinned packages of
#   tests/python/requirements.txt, builds `tmcl` (release; --debug for a debug build) unless
#   TMCL_BIN is already set, then runs pytest. Exits non-zero when anything fails.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

profile=release
if [[ "${1:-}" == "--debug" ]]; then
    profile=debug
    shift
fi

venv="$root/.venv"
requirements="tests/python/requirements.txt"
if [[ ! -x "$venv/bin/python" ]]; then
    echo "python-tests: creating $venv" >&2
    python3 -m venv "$venv"
fi
# Reinstall only when the pins changed since the last successful install.
stamp="$venv/.tmcl-python-tests-requirements"
if ! cmp -s "$requirements" "$stamp" 2>/dev/null; then
    echo "python-tests: installing $requirements" >&2
    "$venv/bin/python" -m pip install --disable-pip-version-check --quiet -r "$requirements"
    cp "$requirements" "$stamp"
fi

if [[ -z "${TMCL_BIN:-}" ]]; then
    target_dir="${CARGO_TARGET_DIR:-$root/target}"
    if [[ "$profile" == release ]]; then
        cargo build --quiet -p tmcl-cli --release
    else
        cargo build --quiet -p tmcl-cli
    fi
    TMCL_BIN="$target_dir/$profile/tmcl"
fi
export TMCL_BIN
echo "python-tests: using $TMCL_BIN" >&2

exec "$venv/bin/python" -m pytest tests/python -q "$@"

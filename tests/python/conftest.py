"""Fixtures: a `tmcl serve` virtual PD28-1021 (or another model: `tmcm1310_server`, `model_server`) on a
pty or TCP port, started per test in a temporary directory, stopped with SIGTERM at teardown (exit code 0
and the pty link removed are checked).

The binary is $TMCL_BIN when set, else target/debug/tmcl built once per session with
`cargo build -p tmcl-cli`.
"""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

from tmcltest import BUS_MODULES, REPO_ROOT, Server, ServerFactory


def _target_dir() -> Path:
    target = os.environ.get("CARGO_TARGET_DIR")
    if target:
        path = Path(target)
        return path if path.is_absolute() else REPO_ROOT / path
    return REPO_ROOT / "target"


@pytest.fixture(scope="session")
def tmcl_bin() -> Path:
    """Path of the `tmcl` binary (TMCL_BIN, or a debug build made once per session)."""
    env = os.environ.get("TMCL_BIN")
    if env:
        path = Path(env)
        if not path.is_absolute():
            path = Path.cwd() / path
        assert path.is_file(), f"TMCL_BIN={env} does not exist"
        return path
    subprocess.run(["cargo", "build", "--quiet", "-p", "tmcl-cli"], cwd=REPO_ROOT, check=True, timeout=900)
    path = _target_dir() / "debug" / "tmcl"
    assert path.is_file(), f"cargo build did not produce {path}"
    return path


@pytest.fixture
def serve(tmcl_bin, tmp_path):
    """Factory: `serve(kind="pty"|"tcp", eeprom=None, extra=None)` → a started Server."""
    factory = ServerFactory(tmcl_bin, tmp_path)
    try:
        yield factory
    finally:
        problems = factory.cleanup()
    assert not problems, "; ".join(problems)


@pytest.fixture
def pty_server(serve) -> Server:
    """A server on a pty, state in memory."""
    return serve("pty")


@pytest.fixture
def tcp_server(serve) -> Server:
    """A server on an ephemeral TCP port of 127.0.0.1, state in memory."""
    return serve("tcp")


@pytest.fixture
def eeprom_server(serve, tmp_path) -> Server:
    """A pty server on a file-backed EEPROM; `.restart()` brings it back on the same file."""
    return serve("pty", eeprom=tmp_path / "eeprom.bin")


@pytest.fixture
def bus_server(serve) -> Server:
    """Three PD28-1021 at addresses 1, 2 and 3 on one pty, state in memory."""
    return serve("pty", modules=BUS_MODULES)


@pytest.fixture
def tmcm1310_server(serve) -> Server:
    """A TMCM-1310 on a pty (its USB interface), state in memory."""
    return serve("pty", modules=["tmcm-1310"])


@pytest.fixture(params=["pd28-1021", "tmcm-1310"])
def model_server(request, serve) -> Server:
    """A pty server of each model in turn, state in memory (for what the models share);
    `model_server.modules[0]` names the model."""
    return serve("pty", modules=[request.param])

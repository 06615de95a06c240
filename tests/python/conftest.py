"""Fixtures: a `tmcl serve` virtual PD28-1021 (or another model: `tmcm1310_server`, `model_server`) on a
pty or TCP port, started per test in a temporary directory, stopped with SIGTERM at teardown (exit code 0
and the pty link removed are checked).

The binary is $TMCL_BIN when set, else target/debug/tmcl built once per session with
`cargo build -p tmcl-cli`.

`--target qemu` runs the same tests against the firmware image on an emulated Cortex-M3
(scripts/qemu-serve.sh): every single-module pty server is then the image under QEMU, and the tests that
need what only `tmcl serve` has (TCP, an EEPROM file, a bus, a simulated world, its options) are skipped.
`qemu_server` is the image whatever the target. Where qemu-system-arm or the thumbv7m-none-eabi target is
missing, the tests that need the image are skipped with the reason.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

from tmcltest import BUS_MODULES, REPO_ROOT, QemuServer, Server, ServerFactory

THUMB = "thumbv7m-none-eabi"
# Test files about `tmcl serve` itself rather than about the module it serves: not run with `--target qemu`.
SERVE_ONLY = {
    "test_line_safety.py": "tests how `tmcl serve` guards its line (LINK.lock, clearing a killed host's "
                           "exclusive mode); scripts/qemu-serve.sh does not",
    "test_ethercat.py": "tests the EtherCAT slave of `tmcl serve --ethercat`; the image has no EtherCAT",
}

# Single tests about `tmcl serve` and its links rather than about the module: not run with `--target qemu`.
SERVE_ONLY_TESTS = {
    "test_a_stale_link_is_refused_without_a_byte_written": "kills `tmcl serve` and reads the LINK.lock it left",
    "test_the_server_warns_about_two_hosts_on_one_link": "checks the warning `tmcl serve` logs",
    "test_a_restarted_server_is_reconnected_and_the_trace_restarts": "stops and restarts `tmcl serve` on the "
                                                                     "same link",
    "test_a_frame_in_slow_pieces_is_answered": "the image is a module on a serial line: its 5 ms inter-byte "
                                               "timeout drops a frame whose pieces come 20 ms apart, as the "
                                               "real module does (docs/decisions.md, \"No frame lost\")",
    "test_two_modules_at_one_address_are_refused": "about `tmcl serve --module`, which the image does not take",
    "test_replies_to_another_host_turn_the_indicator_to_a_warning": "a second host on the same `tmcl serve` "
                                                                    "pty; the image's pty is held by "
                                                                    "scripts/qemu-serve.sh's own processes",
}

# Tests that measure the module's timing in wall-clock milliseconds. QEMU's emulated clock falls behind the
# host's whenever the host is busy (the emulated SysTick is late), so under QEMU they measure the host's
# load, not the firmware. They run against `tmcl serve` (the same core); the port's clock arithmetic is
# unit-tested in crates/tmcl-mcu (clock.rs).
WALL_CLOCK_TIMING = {
    "test_telegram_pause_in_ascii",
    "test_tick_timer_runs_in_milliseconds",
}


def pytest_addoption(parser):
    parser.addoption("--target", choices=["serve", "qemu"], default="serve",
                     help="what the pty server fixtures start: `tmcl serve` (default) or the firmware image "
                          "under QEMU (scripts/qemu-serve.sh)")


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


def pytest_collection_modifyitems(config, items):
    if config.getoption("--target") != "qemu":
        return
    for item in items:
        reason = SERVE_ONLY.get(item.path.name) or SERVE_ONLY_TESTS.get(item.originalname)
        if reason:
            item.add_marker(pytest.mark.skip(reason=f"needs tmcl serve: {reason}"))
        elif item.name in WALL_CLOCK_TIMING:
            item.add_marker(pytest.mark.skip(reason="measures wall-clock timing, which QEMU's emulated clock "
                                                    "follows only on an idle host; checked against tmcl serve"))


@pytest.fixture(scope="session")
def qemu_image() -> Path:
    """The firmware image (ELF), built once per session (release); skips where QEMU or the target is missing.
    $QEMU_IMAGE names a prebuilt one."""
    if shutil.which(os.environ.get("QEMU_SYSTEM_ARM", "qemu-system-arm")) is None:
        pytest.skip("QEMU tests skipped: qemu-system-arm is not installed (Debian: apt-get install qemu-system-arm)")
    env = os.environ.get("QEMU_IMAGE")
    if env:
        path = Path(env)
        assert path.is_file(), f"QEMU_IMAGE={env} does not exist"
        return path
    if shutil.which("rustup"):
        installed = subprocess.run(["rustup", "target", "list", "--installed"], capture_output=True, text=True)
        if installed.returncode == 0 and THUMB not in installed.stdout.split():
            pytest.skip(f"QEMU tests skipped: the {THUMB} target is not installed (rustup target add {THUMB})")
    build = subprocess.run(["cargo", "build", "--release", "--quiet", "--bin", "tmcl-lm3s6965"],
                           cwd=REPO_ROOT / "firmware", capture_output=True, text=True, timeout=1200)
    if build.returncode != 0 and "target may not be installed" in build.stderr:
        pytest.skip(f"QEMU tests skipped: the {THUMB} target is not installed (rustup target add {THUMB})")
    assert build.returncode == 0, f"building the firmware image failed:\n{build.stderr[-4000:]}"
    path = _target_dir() / THUMB / "release" / "tmcl-lm3s6965"
    assert path.is_file(), f"cargo build did not produce {path}"
    return path


@pytest.fixture
def serve(tmcl_bin, tmp_path, request):
    """Factory: `serve(kind="pty"|"tcp", eeprom=None, extra=None)` → a started Server (under
    `--target qemu`, the image under QEMU where the request allows it, see the module docs)."""
    image = request.getfixturevalue("qemu_image") if request.config.getoption("--target") == "qemu" else None
    # A test file that sets QEMU_ICOUNT = True runs the image with deterministic time (see QemuServer).
    factory = ServerFactory(tmcl_bin, tmp_path, qemu_image=image,
                            qemu_icount=getattr(request.module, "QEMU_ICOUNT", False))
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


@pytest.fixture
def qemu_server(qemu_image, tmp_path, request) -> QemuServer:
    """The firmware image under QEMU: a PD28-1021 on a pty, with QEMU's monitor (with deterministic time in
    a test file that sets QEMU_ICOUNT = True)."""
    factory = ServerFactory(Path("tmcl"), tmp_path, qemu_image=qemu_image,
                            qemu_icount=getattr(request.module, "QEMU_ICOUNT", False))
    try:
        yield factory.qemu("qemu-link")
    finally:
        problems = factory.cleanup()
    assert not problems, "; ".join(problems)

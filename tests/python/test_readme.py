"""The README's tour, run as written: every `$T ...` command of its shell blocks, in order.

Servers (`$T serve ...`, `$T share ...`, and `scripts/qemu-serve.sh ...` for the firmware under QEMU) are
started in the background and stopped at the end, the last one first (a share before the server behind
it); `/tmp/` paths are moved into the test's temporary directory; a command whose comment says `exit code
N` must exit with N, every other command with 0. A newcomer who pastes the tour gets what the README
promises. Where QEMU or the Cortex-M3 target is missing, the QEMU server and the
commands to its link are left out.
"""

import os
import re
import signal
import subprocess
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def tour_commands() -> list[tuple[str, int]]:
    """(command, expected exit code) for each `$T` line of the README's tour, continuation lines joined."""
    text = (ROOT / "README.md").read_text()
    tour = text[text.index("## A tour"):text.index("## What is there")]
    commands = []
    for block in re.findall(r"```sh\n(.*?)```", tour, re.S):
        lines = block.replace("\\\n", " ").splitlines()
        for number, line in enumerate(lines):
            qemu = line.startswith("scripts/qemu-serve.sh ")
            if ("$T" not in line and not qemu) or line.lstrip().startswith(("#", "T=")):
                continue
            command, _, comment = line.partition("  #")
            # A comment may go on in the next lines' comments (`#   1..2147483647; exit code 1`).
            for following in lines[number + 1:]:
                if not following.lstrip().startswith("#"):
                    break
                comment += " " + following
            found = re.search(r"exit code (\d+)", comment)
            commands.append((command.strip(), int(found.group(1)) if found else 0))
    return commands


def test_the_tour_has_the_commands_it_should():
    commands = [c for c, _ in tour_commands()]
    assert any(c.startswith("$T serve --pty /tmp/tmcl0") for c in commands)
    assert any("get ap MaxPositioningSpeed" in c for c in commands)
    assert any(" run " in f" {c} " for c in commands)
    assert len(commands) >= 30


def test_the_readme_tour(tmcl_bin, tmp_path, request):
    env = dict(os.environ, T=str(tmcl_bin))
    try:
        env["QEMU_IMAGE"] = str(request.getfixturevalue("qemu_image"))
        qemu = True
    except pytest.skip.Exception:
        qemu = False
    servers = []
    skipped_links = []
    try:
        for command, expected in tour_commands():
            command = command.replace("/tmp/", f"{tmp_path}/")
            if command.startswith("scripts/qemu-serve.sh ") and not qemu:
                skipped_links.append(command.split()[1])
                continue
            if any(link in command.split() for link in skipped_links):
                continue
            if any(f" {server} " in f"{command} " for server in ("serve", "share")) \
                    or command.startswith("scripts/qemu-serve.sh "):
                proc = subprocess.Popen(["bash", "-c", f"exec {command}"], cwd=ROOT, env=env, stdout=subprocess.PIPE,
                                        stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL, text=True)
                ready = proc.stdout.readline()
                assert ready.startswith(("serving ", "sharing ")), (command, ready)
                servers.append(proc)
                continue
            started = time.monotonic()
            r = subprocess.run(["bash", "-c", command], cwd=ROOT, env=env, capture_output=True, text=True,
                               timeout=120, stdin=subprocess.DEVNULL)
            assert r.returncode == expected, (command, r.returncode, r.stdout[-2000:], r.stderr[-2000:])
            assert "panicked" not in r.stderr, (command, r.stderr)
            assert time.monotonic() - started < 60, command
    finally:
        for proc in reversed(servers):
            proc.send_signal(signal.SIGTERM)
            assert proc.wait(timeout=20) == 0

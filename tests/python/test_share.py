"""`tmcl share` (issue 20): one module, several hosts, each on a link of its own, with a `tmcl serve` (or the
firmware image under QEMU) standing in for the real module on its serial port. pytrinamic, pyserial, the
`tmcl` host commands and the workbench use it at once; every transaction is in the share's log with its host,
and no host ever gets a value that answers another's request.

The share is started as tools and services start it: in a session of its own, without a controlling
terminal (`start_new_session=True`)."""

from __future__ import annotations

import json
import os
import queue
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import serial
from pytrinamic.connections import ConnectionManager

from tmcltest import RawReply, frame, wait_until

# The firmware image under QEMU as the module: with deterministic time (`--icount`), so that a host too
# busy to run QEMU for 5 ms in the middle of a frame does not make the image's inter-byte timeout drop it
# (docs/decisions.md, "No frame lost").
QEMU_ICOUNT = True

READY_RE = re.compile(r"^sharing (\S+) on (.+?)(?: \(tmcl monitor --socket (\S+)\))?$")
MAX_CURRENT, MAX_SPEED = 6, 4


class Share:
    """One `tmcl share` process; `start()` waits for its ready line."""

    def __init__(self, tmcl: Path, workdir: Path, device: Path, links: list[str], extra: list[str] | None = None):
        self.tmcl, self.workdir, self.device = tmcl, workdir, device
        self.links_args = links
        self.extra = list(extra or [])
        self.proc: subprocess.Popen | None = None
        self.links: list[str] = []
        self.monitor: str | None = None
        self.stderr_path = workdir / f"share-{id(self)}.stderr"

    def start(self) -> "Share":
        args = [str(self.tmcl), "share", "--port", str(self.device), *self.links_args, *self.extra]
        with open(self.stderr_path, "wb") as err:
            self.proc = subprocess.Popen(args, cwd=self.workdir, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                         stderr=err, start_new_session=True)
        lines: queue.Queue = queue.Queue()

        def pump():
            for raw in self.proc.stdout:
                lines.put(raw.decode("utf-8", "replace").rstrip("\n"))
            lines.put(None)

        threading.Thread(target=pump, daemon=True).start()
        try:
            line = lines.get(timeout=20)
        except queue.Empty:
            line = None
        if line is None:
            self.kill()
            raise AssertionError(f"tmcl share printed no ready line; stderr: {self.stderr()}")
        m = READY_RE.match(line)
        assert m, line
        assert m.group(1) == str(self.device), line
        self.links = m.group(2).split(" and ")
        self.monitor = m.group(3)
        return self

    def stop(self, sig=signal.SIGTERM) -> int:
        assert self.proc is not None
        proc, self.proc = self.proc, None
        if proc.poll() is None:
            proc.send_signal(sig)
        return proc.wait(timeout=15)

    def kill(self) -> None:
        if self.proc is not None:
            self.proc.kill()
            self.proc.wait(timeout=5)
            self.proc = None

    def stderr(self) -> str:
        return self.stderr_path.read_text("utf-8", "replace")[-4000:] if self.stderr_path.exists() else ""


@pytest.fixture
def share(tmcl_bin, tmp_path):
    """Factory: `share(device, links, extra)` → a started Share, stopped (SIGTERM, exit 0) at teardown."""
    started: list[Share] = []

    def make(device, links, extra=None) -> Share:
        s = Share(tmcl_bin, tmp_path, device, links, extra).start()
        started.append(s)
        return s

    yield make
    problems = []
    for s in started:
        if s.proc is not None:
            rc = s.stop()
            if rc != 0:
                problems.append(f"tmcl share exited with {rc}: {s.stderr()}")
    assert not problems, problems


def tmcl(tmcl_bin, *args, timeout=30):
    return subprocess.run([str(tmcl_bin), *map(str, args)], capture_output=True, text=True, timeout=timeout)


def read_log(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def test_pytrinamic_tmcl_and_the_workbench_through_share_never_mix(pty_server, share, tmcl_bin, tmp_path):
    """pytrinamic polls AP 6 on one link while `tmcl get`/`watch` read AP 4 on a second and the workbench
    (`tmcl ui --port`) polls on a third: 10 000 transactions and more, no wrong value anywhere, and the log
    names for each transaction the host that asked it, with the value its request asks for."""
    a, b, c = tmp_path / "a", tmp_path / "b", tmp_path / "c"
    log = tmp_path / "share.jsonl"
    s = share(pty_server.link, ["--pty", a, "--pty", b, "--pty", c, "--tcp", "127.0.0.1:0"],
              ["--log", log, "--module", "pd28-1021"])
    # The log is text (JSON lines with `tmcl --json share`); the values are checked in the monitor's JSON.
    assert s.links[:3] == [str(a), str(b), str(c)] and s.monitor == f"{a}.monitor"
    assert tmcl(tmcl_bin, "set", "--port", b, "ap", MAX_CURRENT, 128).returncode == 0
    assert tmcl(tmcl_bin, "set", "--port", b, "ap", MAX_SPEED, 1234).returncode == 0

    monitor = subprocess.Popen([str(tmcl_bin), "--json", "monitor", a], stdout=subprocess.PIPE,
                               stderr=subprocess.DEVNULL, start_new_session=True)
    records: list[dict] = []
    threading.Thread(target=lambda: [records.append(json.loads(l)) for l in monitor.stdout], daemon=True).start()

    from uitest import Ui
    workbench = Ui(tmcl_bin, tmp_path, ["--port", str(c)]).start()
    polls, wrong, errors = 8_000, [], []

    def poll():
        conn = ConnectionManager(f"--interface serial_tmcl --port {a} --data-rate 115200").connect()
        try:
            for _ in range(polls):
                value = conn.get_axis_parameter(MAX_CURRENT, 0)
                if value != 128:
                    wrong.append(value)
        except Exception as e:  # noqa: BLE001 - reported below
            errors.append(repr(e))
        finally:
            conn.close()

    script = threading.Thread(target=poll)
    script.start()
    cli = 0
    try:
        while script.is_alive() or polls + cli < 10_000:
            r = tmcl(tmcl_bin, "get", "--port", b, "--timeout", "3", "ap", MAX_SPEED)
            assert (r.returncode, r.stdout.strip()) == (0, f"ap {MAX_SPEED} = 1234"), r
            cli += 1
            if cli % 25 == 0:
                r = tmcl(tmcl_bin, "--json", "watch", "--port", b, "ap", MAX_SPEED, "--every", "0.001",
                         "--count", 50)
                assert r.returncode == 0, r
                assert all("1234" in line for line in r.stdout.splitlines()), r.stdout[:400]
                cli += 50
    finally:
        script.join(180)
        assert workbench.stop() == 0
    assert not errors, errors
    assert not wrong, f"{len(wrong)} wrong values on pytrinamic's link: {wrong[:5]}"
    # A SIGTERM flushes the log; the monitor saw the same transactions live.
    wait_until(lambda: len(records) >= polls + cli, 30, what="the monitor's records")
    monitor.terminate()
    text = log.read_text()
    assert text.count(f" {a}  ") >= polls, "every transaction of pytrinamic is in the log"
    by_host: dict[str, int] = {}
    for t in records:
        if t["outcome"] != "answered":
            assert t["outcome"] not in ("late", "foreign", "damaged", "partial"), t
            continue
        host = t["host"]
        by_host[host] = by_host.get(host, 0) + 1
        request, reply = t["request"]["text"], t["reply"]["text"]
        if host == str(a):
            assert request.startswith("to 1: GAP 6, "), t
        # Whoever asked for AP 4 or AP 6 got the module's value of that parameter, and nothing else.
        if request.startswith("to 1: GAP 6, "):
            assert re.search(r": 128( |$)", reply), t
        elif request.startswith("to 1: GAP 4, "):
            assert reply.endswith(": 1234 pps"), t
    assert by_host.get(str(c), 0) > 0, "the workbench's requests went through the share"
    assert sum(by_host.values()) >= 10_000, by_host


def test_the_workbench_through_share_stays_answering(pty_server, share, tmcl_bin, tmp_path):
    """The workbench (headless Chromium) on one link of the share, pyserial hammering another: the line
    indicator stays "answering" (no reply it gets answers another host's request) and shows the module's
    values."""
    from uitest import Ui, new_browser, screenshot_dir
    from uitest import wait_until as ui_wait_until

    browser = new_browser()
    a, b = tmp_path / "a", tmp_path / "b"
    share(pty_server.link, ["--pty", a, "--pty", b])
    u = Ui(tmcl_bin, tmp_path, ["--port", str(a)]).start()
    stop = threading.Event()

    def other_host():
        with serial.Serial(str(b), 115200, timeout=2) as port:
            while not stop.is_set():
                port.write(frame(1, 10, 66, 0, 0))  # GGP 66: a command the page also sends
                assert RawReply(port.read(9)).value == 1

    try:
        browser.get(f"{u.url}#motion")
        ui_wait_until(lambda: browser.execute_script("return window.workbench && window.workbench.hello"),
                      what="the module's hello")
        ui_wait_until(lambda: browser.execute_script("return window.workbench.line.state") == "answering",
                      what="the line answering")
        thread = threading.Thread(target=other_host, daemon=True)
        thread.start()
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline:
            assert browser.execute_script("return window.workbench.line.state") == "answering"
            assert browser.execute_script("return window.workbench.line.mismatched || 0") == 0
            time.sleep(0.2)
        browser.save_screenshot(str(screenshot_dir() / "share-workbench-beside-another-host.png"))
        stop.set()
        thread.join(5)
        assert not thread.is_alive()
    finally:
        stop.set()
        browser.quit()
        assert u.stop() == 0


def test_a_killed_host_and_a_killed_share_leave_no_reply_astray(pty_server, share, tmcl_bin, tmp_path):
    """A host killed with -9 in the middle of its transactions: the other host's replies stay its own.
    Then the share itself killed with -9 mid-transaction: its links are refused as stale (nothing written),
    and a new share on the same links works."""
    a, b = tmp_path / "a", tmp_path / "b"
    s = share(pty_server.link, ["--pty", a, "--pty", b])
    assert tmcl(tmcl_bin, "set", "--port", b, "ap", MAX_SPEED, 777).returncode == 0
    script = (
        "import serial, sys\n"
        "from tmcltest import frame\n"
        f"p = serial.Serial({str(a)!r}, 115200)\n"
        "while True:\n"
        "    p.write(frame(1, 6, 6, 0, 0) * 50)\n"
        "    p.read(9 * 25)\n"
    )
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).parent))
    host = subprocess.Popen([sys.executable, "-c", script], env=env, start_new_session=True)
    try:
        for _ in range(20):
            r = tmcl(tmcl_bin, "get", "--port", b, "ap", MAX_SPEED)
            assert (r.returncode, r.stdout.strip()) == (0, f"ap {MAX_SPEED} = 777"), r
        host.send_signal(signal.SIGKILL)
        host.wait(5)
        for _ in range(20):
            r = tmcl(tmcl_bin, "get", "--port", b, "ap", MAX_SPEED)
            assert (r.returncode, r.stdout.strip()) == (0, f"ap {MAX_SPEED} = 777"), r
    finally:
        if host.poll() is None:
            host.kill()
    # The share killed in the middle of a backlog.
    with serial.Serial(str(b), 115200, timeout=0.2) as port:
        port.write(frame(1, 6, 4, 0, 0) * 200)
        s.stop(signal.SIGKILL)
    r = tmcl(tmcl_bin, "get", "--port", a, "ap", MAX_SPEED)
    assert r.returncode == 3 and "has exited" in r.stderr, r
    again = share(pty_server.link, ["--pty", a, "--pty", b])
    assert again.links[:2] == [str(a), str(b)]
    r = tmcl(tmcl_bin, "get", "--port", a, "ap", MAX_SPEED)
    assert (r.returncode, r.stdout.strip()) == (0, f"ap {MAX_SPEED} = 777"), r


def test_refusals_and_silence_through_share(pty_server, share, tmcl_bin, tmp_path):
    """`send 137`/`send 255` without the key are refused by the module: the refusal reaches the asker (exit
    1). `set gp 255 1` switches replies off, and `set gp 255 0` back on, through the share."""
    a = tmp_path / "a"
    share(pty_server.link, ["--pty", a])
    for opcode in (137, 255):
        r = tmcl(tmcl_bin, "send", "--port", a, "--timeout", "1", opcode, 0, 0, 0)
        assert r.returncode == 1 and "status 4" in r.stderr, r
    r = tmcl(tmcl_bin, "set", "--port", a, "--timeout", "1", "gp", 255, 1)
    assert r.returncode == 0 and "replies are now off" in r.stdout, r
    r = tmcl(tmcl_bin, "get", "--port", a, "--timeout", "1", "ap", MAX_SPEED)
    assert r.returncode == 0, r  # GAP is always answered
    r = tmcl(tmcl_bin, "set", "--port", a, "--timeout", "1", "gp", 255, 0)
    assert r.returncode == 0, r
    r = tmcl(tmcl_bin, "set", "--port", a, "ap", MAX_SPEED, 1000)
    assert r.returncode == 0, r


def test_a_backlog_through_share_gets_every_reply_in_order(pty_server, share, tmp_path):
    a = tmp_path / "a"
    share(pty_server.link, ["--pty", a])
    with serial.Serial(str(a), 115200, timeout=10) as port:
        port.write(b"".join(frame(1, 5, 4, 0, k + 1) for k in range(1000)))
        got = port.read(9000)
    assert len(got) == 9000
    values = [RawReply(got[k:k + 9]).value for k in range(0, 9000, 9)]
    assert values == list(range(1, 1001))


def test_ascii_through_share(pty_server, share, tmp_path):
    """A host that enters ASCII mode (139) talks text through the share while the module stays binary for
    the others (docs/decisions.md)."""
    a, b = tmp_path / "a", tmp_path / "b"
    share(pty_server.link, ["--pty", a, "--pty", b])
    with serial.Serial(str(a), 115200, timeout=5) as term, serial.Serial(str(b), 115200, timeout=5) as bin_host:
        term.write(frame(1, 139, 0, 0, 0))
        assert RawReply(term.read(9)).status == 100
        term.write(b"ASAP 4, 0, 4321\r")
        assert term.read_until(b"\r") == b"BA 100 4321\r"
        bin_host.write(frame(1, 6, 4, 0, 0))
        assert RawReply(bin_host.read(9)).value == 4321
        term.write(b"ABIN\r")
        assert term.read_until(b"\r") == b"BA 100 0\r"


def test_share_over_tcp_and_the_monitor(pty_server, share, tmcl_bin, tmp_path):
    """A TCP host link beside a pty; `tmcl monitor` shows the TCP host's transaction by its address."""
    a = tmp_path / "a"
    s = share(pty_server.link, ["--pty", a, "--tcp", "127.0.0.1:0"])
    tcp = s.links[1]
    mon = subprocess.Popen([str(tmcl_bin), "monitor", a, "--count", "1"], stdout=subprocess.PIPE, text=True)
    time.sleep(0.3)  # the share takes the monitor client in its next turn
    host, port = tcp.rsplit(":", 1)
    with socket.create_connection((host, int(port)), timeout=5) as sock:
        sock.sendall(frame(1, 6, 4, 0, 0))
        got = b""
        while len(got) < 9:
            got += sock.recv(9 - len(got))
    out, _ = mon.communicate(timeout=10)
    assert tcp in out and "GAP 4, 0" in out and "-> 100 (ok)" in out, out


def test_share_in_front_of_the_firmware_image_under_qemu(qemu_server, share, tmcl_bin, tmp_path):
    """The firmware image under QEMU as the real module on a serial line: pytrinamic on one link of the
    share and `tmcl` on another, 1 000 transactions, each value its asker's."""
    a, b = tmp_path / "a", tmp_path / "b"
    share(qemu_server.link, ["--pty", a, "--pty", b], ["--module", "pd28-1021"])
    assert tmcl(tmcl_bin, "set", "--port", b, "ap", MAX_SPEED, 4321).returncode == 0
    assert tmcl(tmcl_bin, "set", "--port", b, "ap", MAX_CURRENT, 100).returncode == 0
    wrong, errors = [], []

    def poll():
        conn = ConnectionManager(f"--interface serial_tmcl --port {a} --data-rate 115200").connect()
        try:
            for _ in range(900):
                if conn.get_axis_parameter(MAX_CURRENT, 0) != 100:
                    wrong.append(1)
        except Exception as e:  # noqa: BLE001 - reported below
            errors.append(repr(e))
        finally:
            conn.close()

    script = threading.Thread(target=poll)
    script.start()
    try:
        for _ in range(10):
            r = tmcl(tmcl_bin, "--json", "watch", "--port", b, "ap", MAX_SPEED, "--every", "0.001", "--count", 10)
            assert r.returncode == 0 and all("4321" in line for line in r.stdout.splitlines()), r
    finally:
        script.join(120)
    assert not errors and not wrong, (errors, len(wrong))


def test_the_module_going_away_ends_the_share_and_its_links(serve, share, tmcl_bin, tmp_path):
    """`tmcl serve` standing in for the module is killed with -9 while hosts use the share: the share says
    so and ends (exit code 3), removing its links, so that hosts see a port gone, not a module that is
    silent."""
    module = serve("pty")
    a = tmp_path / "a"
    s = share(module.link, ["--pty", a])
    with serial.Serial(str(a), 115200, timeout=2) as port:
        port.write(frame(1, 6, 4, 0, 0))
        assert RawReply(port.read(9)).status == 100
        port.write(frame(1, 6, 4, 0, 0) * 100)
        module.kill()
        wait_until(lambda: s.proc.poll() is not None, 10, what="the share's end")
    assert s.proc.returncode == 3, s.stderr()
    assert "the share stops" in s.stderr(), s.stderr()
    assert not os.path.lexists(a) and not os.path.lexists(f"{a}.lock"), "its links are removed"
    s.proc = None


def test_tmcl_serve_log_and_monitor(serve, tmcl_bin, tmp_path):
    """`tmcl serve --log FILE` and `tmcl monitor LINK` on a virtual module: each transaction once, with the
    parameter's name and unit, and a refusal explained with the range."""
    log = tmp_path / "serve.log"
    server = serve("pty", extra=["--log", str(log)])
    mon = subprocess.Popen([str(tmcl_bin), "monitor", str(server.link), "--count", "2"], stdout=subprocess.PIPE,
                           text=True)
    time.sleep(0.3)  # the server takes the monitor client in its next turn
    assert tmcl(tmcl_bin, "get", "--port", server.link, "ap", MAX_SPEED).returncode == 0
    assert tmcl(tmcl_bin, "set", "--port", server.link, "ap", MAX_SPEED, 0).returncode == 1
    out, _ = mon.communicate(timeout=10)
    lines = out.splitlines()
    assert len(lines) == 2, out
    assert "GAP 4, 0 (Maximum positioning speed)" in lines[0] and "-> 100 (ok): 51200 pps" in lines[0], out
    assert "SAP 4, 0" in lines[1] and "refused: Maximum positioning speed takes 1..2147483647" in lines[1], out
    wait_until(lambda: len(log.read_text().splitlines()) >= 2, 5, what="the log")
    assert [line.split(" ", 1)[1] for line in log.read_text().splitlines()[:2]] == \
        [line.split(" ", 1)[1] for line in lines]

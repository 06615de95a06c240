"""Shared helpers of the Python host-compatibility suite: the `tmcl serve` process wrapper, pytrinamic
connections, bounded polling and raw TMCL frames."""

from __future__ import annotations

import contextlib
import itertools
import os
import queue
import re
import select
import signal
import socket
import struct
import subprocess
import threading
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[2]
READY_TIMEOUT_S = 20.0
STOP_TIMEOUT_S = 10.0
READY_RE = re.compile(r"^serving (\S+) at address (\d+) on (.+)$")
# The ready line of one or more modules: `serving PD28-1021 at address 1, PD28-1021 at address 2 on LINK`.
BUS_READY_RE = re.compile(r"^serving (.+?) on (.+)$")
BUS_MODULE_RE = re.compile(r"^(\S+) at address (\d+)$")
# `--module` names whose product name is not the name in upper case.
PRODUCT_NAMES = {"pd-113": "PDx-113-57/60-SE"}

# Factory defaults of the PD28-1021: AP 140 (manual §6.1), AP 214 (Table 22), GP 66 and 76 (the reply
# examples of §3.2); AP 4 and 5 are OpenTMCL's choice (docs/decisions.md).
DEFAULT_AP = {4: 51200, 5: 51200, 140: 8, 214: 200}
DEFAULT_GP = {66: 1, 76: 2}
# The `--module` arguments of the three-module bus (`bus_server` fixture).
BUS_MODULES = ["pd28-1021@1", "pd28-1021@2", "pd28-1021@3"]


class Server:
    """One `tmcl serve` process. `start()` waits for its ready line; `stop()` sends SIGTERM."""

    def __init__(self, tmcl: Path, workdir: Path, kind: str, eeprom: Path | None = None,
                 extra: list[str] | None = None, link_name: str = "tmcl-link",
                 modules: list[str] | None = None, listen: str = "127.0.0.1:0"):
        self.tmcl = tmcl
        # `--module` arguments (e.g. ["pd28-1021@1", "pd28-1021@2"]); None: the single default module.
        self.modules = list(modules) if modules else None
        self.workdir = workdir
        self.kind = kind
        self.eeprom = eeprom
        self.extra = list(extra or [])
        self.link = workdir / link_name if kind == "pty" else None
        self.listen = listen  # --tcp HOST:PORT of a TCP server (the ready line must show 127.0.0.1)
        self.proc: subprocess.Popen | None = None
        self.ready_line = ""
        self.address = ""  # the LINK path or 127.0.0.1:PORT
        self.host = ""
        self.port = 0
        self.starts = 0
        self.module_address = 0
        self.expect_address: int | None = 1  # checked against the ready line; None = any
        # Every module's address from the ready line, in command-line order (one entry for one module).
        self.addresses: list[int] = []
        # With `modules`: the addresses the ready line must show (default: those of MODEL@ADDR); None = any.
        self.expect_addresses: list[int] | None = None
        if self.modules:
            self.expect_addresses = [int(m.partition("@")[2] or n + 1) for n, m in enumerate(self.modules)]
        self._lines: queue.Queue = queue.Queue()
        self._stderr_path: Path | None = None
        # The environment of the process (None: this one's).
        self.env: dict[str, str] | None = None
        # Start it in a session of its own, without a controlling terminal (as services and tools do).
        self.new_session = False
        self.ready_timeout_s = READY_TIMEOUT_S

    # -- lifecycle ---------------------------------------------------------------------------------
    def models(self) -> list[str]:
        """The product names the ready line must show, in command-line order (`tmcm-1310@2` → TMCM-1310)."""
        return [PRODUCT_NAMES.get(m.partition("@")[0], m.partition("@")[0].upper())
                for m in self.modules or ["pd28-1021"]]

    def args(self) -> list[str]:
        args = [str(self.tmcl), "serve"]
        for module in self.modules or ["pd28-1021"]:
            args += ["--module", module]
        if self.kind == "pty":
            args += ["--pty", str(self.link)]
        else:
            args += ["--tcp", self.listen]
        if self.eeprom is not None:
            args += ["--eeprom", str(self.eeprom)]
        return args + self.extra

    def start(self) -> "Server":
        assert self.proc is None, "server already running"
        self.starts += 1
        self._stderr_path = self.workdir / f"serve-{self.kind}-{self.starts}.stderr"
        stderr = open(self._stderr_path, "wb")
        try:
            self.proc = subprocess.Popen(self.args(), cwd=self.workdir, stdin=subprocess.DEVNULL,
                                         stdout=subprocess.PIPE, stderr=stderr, env=self.env,
                                         start_new_session=self.new_session)
        finally:
            stderr.close()
        self._lines = queue.Queue()
        threading.Thread(target=self._pump, args=(self.proc, self._lines), daemon=True).start()
        deadline = time.monotonic() + self.ready_timeout_s
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                self.kill()
                raise AssertionError(f"no ready line within {self.ready_timeout_s} s; stderr: {self.stderr()}")
            try:
                line = self._lines.get(timeout=min(left, 0.5))
            except queue.Empty:
                if self.proc.poll() is not None:
                    rc = self.proc.returncode
                    self.proc = None
                    raise AssertionError(f"tmcl serve exited with {rc} before it was ready; "
                                         f"stderr: {self.stderr()}")
                continue
            if line is None:
                continue
            m = BUS_READY_RE.match(line)
            if m:
                break
        self.ready_line = line
        self.addresses = []
        parts = m.group(1).split(", ")
        models = self.models()
        assert len(parts) == len(models), line
        for part, model in zip(parts, models):
            module = BUS_MODULE_RE.match(part)
            assert module, line
            assert module.group(1) == model, line
            self.addresses.append(int(module.group(2)))
        self.module_address = self.addresses[0]
        if self.modules is None:
            assert len(self.addresses) == 1, line
            if self.expect_address is not None:
                assert self.module_address == self.expect_address, line
        elif self.expect_addresses is not None:
            assert self.addresses == self.expect_addresses, line
        # Several links (`--pty A --pty B --tcp ADDR`) are listed "A and B and ADDR": the first is this one.
        self.links = m.group(2).split(" and ")
        self.address = self.links[0]
        if self.kind == "pty":
            assert self.address == str(self.link), line
            assert self.link.is_symlink(), f"{self.link} is not a symlink"
        else:
            host, _, port = self.address.rpartition(":")
            assert host == "127.0.0.1", line
            self.host, self.port = host, int(port)
            assert self.port > 0, line
        return self

    @staticmethod
    def _pump(proc: subprocess.Popen, lines: queue.Queue) -> None:
        # Keep reading stdout so the server never blocks on a full pipe.
        assert proc.stdout is not None
        for raw in proc.stdout:
            lines.put(raw.decode("utf-8", "replace").rstrip("\r\n"))
        lines.put(None)

    @property
    def running(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def stop(self, sig: int = signal.SIGTERM) -> int:
        """Sends `sig`, waits for the exit and returns the exit code."""
        assert self.proc is not None, "server not running"
        proc, self.proc = self.proc, None
        if proc.poll() is None:
            proc.send_signal(sig)
        try:
            return proc.wait(timeout=STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=STOP_TIMEOUT_S)
            raise AssertionError(f"tmcl serve did not exit within {STOP_TIMEOUT_S} s after signal {sig}")

    def terminate_checked(self) -> None:
        """SIGTERM; the exit code must be 0 and the pty link must be gone."""
        rc = self.stop(signal.SIGTERM)
        assert rc == 0, f"tmcl serve exited with {rc} after SIGTERM; stderr: {self.stderr()}"
        if self.link is not None:
            assert not os.path.lexists(self.link), f"{self.link} still exists after SIGTERM"
            lock = f"{self.link}.lock"
            assert not os.path.lexists(lock), f"{lock} still exists after SIGTERM"

    def kill(self) -> None:
        """SIGKILL (a crash): the link stays behind, the EEPROM journal is whatever was written."""
        if self.proc is None:
            return
        proc, self.proc = self.proc, None
        if proc.poll() is None:
            proc.kill()
        proc.wait(timeout=STOP_TIMEOUT_S)

    def restart(self) -> "Server":
        """SIGTERM (checked), then start again with the same arguments (same EEPROM file, same link)."""
        self.terminate_checked()
        return self.start()

    def stderr(self) -> str:
        if self._stderr_path and self._stderr_path.exists():
            return self._stderr_path.read_text("utf-8", "replace")[-4000:]
        return ""

    # -- host-side helpers -------------------------------------------------------------------------
    @property
    def pytrinamic_args(self) -> str:
        return self.pytrinamic_args_for(self.module_address)

    def pytrinamic_args_for(self, module_id: int) -> str:
        """ConnectionManager arguments for the module at `module_id` (pytrinamic's `--module-id`)."""
        module = f" --module-id {module_id}" if module_id not in (0, 1) else ""
        if self.kind == "pty":
            return f"--interface serial_tmcl --port {self.link} --data-rate 115200{module}"
        return f"--interface socket_serial_tmcl --port 127.0.0.1:{self.port}{module}"


_MONITORS = itertools.count()


class QemuServer(Server):
    """The firmware image on an emulated Cortex-M3 (`scripts/qemu-serve.sh LINK`): one module on a pty,
    its EEPROM in the microcontroller's RAM (lost when QEMU stops), QEMU's monitor on a Unix socket."""

    def __init__(self, image: Path, workdir: Path, link_name: str = "tmcl-link", model: str = "pd28-1021"):
        super().__init__(image, workdir, "pty", link_name=link_name, modules=[model])
        self.image = image
        self.model = model
        # Deterministic time (`--icount`): the emulated clock runs with the instructions, so a host too busy
        # to run QEMU for a while makes no gap in the byte stream the firmware sees.
        self.icount = False
        # A Unix socket's path must stay under 108 bytes; a test's temporary directory may not.
        self.monitor_path = Path(f"/tmp/tmcl-qemu-{os.getpid()}-{next(_MONITORS)}.monitor")
        self.env = dict(os.environ, QEMU_IMAGE=str(image))
        # QEMU boots and the script waits until the firmware answers on the pty: slower on a loaded machine.
        self.ready_timeout_s = 60.0

    def args(self) -> list[str]:
        return ["bash", str(REPO_ROOT / "scripts" / "qemu-serve.sh"), str(self.link), "--module", self.model,
                "--monitor", str(self.monitor_path)] + (["--icount"] if self.icount else [])

    def monitor(self, *commands: str, timeout_s: float = 10.0) -> list[str]:
        """Runs QEMU human-monitor commands; returns what each printed."""
        with socket.socket(socket.AF_UNIX) as sock:
            sock.connect(str(self.monitor_path))
            sock.settimeout(timeout_s)

            def prompt() -> str:
                buf = b""
                while not buf.endswith(b"(qemu) "):
                    data = sock.recv(65536)
                    if not data:
                        break
                    buf += data
                return re.sub(r"\x1b\[[0-9;]*[A-Za-z]|\r", "", buf.decode("utf-8", "replace"))

            prompt()
            out = []
            for command in commands:
                sock.sendall(command.encode() + b"\n")
                text = prompt()
                # The monitor echoes the command line first and ends with the next prompt.
                lines = text.split("\n")[1:]
                out.append("\n".join(line for line in lines if not line.startswith("(qemu)")).strip())
            return out

    def stop(self, sig: int = signal.SIGTERM) -> int:
        try:
            return super().stop(sig)
        finally:
            with contextlib.suppress(FileNotFoundError):
                self.monitor_path.unlink()

    def read_words(self, address: int, count: int = 1) -> list[int]:
        """`count` 32-bit words of the emulated memory (RAM or a peripheral register) from `address`."""
        text = self.monitor(f"xp /{count}xw {address:#x}")[0]
        return [int(word, 16) for line in text.splitlines() for word in line.split(":", 1)[1].split()]

    def dump(self, address: int, length: int, path: Path) -> bytes:
        """`length` bytes of the emulated memory from `address`, through a file."""
        self.monitor(f'pmemsave {address:#x} {length} "{path}"')
        return path.read_bytes()


def elf_symbols(path: Path) -> dict[str, int]:
    """Symbol name (demangled to its path without the hash, e.g. `tmcl_lm3s6965::steps::STEPS`) -> address,
    from the .symtab of a 32-bit little-endian ELF."""
    data = path.read_bytes()
    assert data[:4] == b"\x7fELF" and data[4] == 1 and data[5] == 1, f"{path} is no ELF32 LE file"
    shoff, = struct.unpack_from("<I", data, 0x20)
    shentsize, shnum = struct.unpack_from("<HH", data, 0x2E)
    sections = [struct.unpack_from("<IIIIIIIIII", data, shoff + i * shentsize) for i in range(shnum)]
    symbols = {}
    for _name, kind, _flags, _addr, offset, size, link, _info, _align, entsize in sections:
        if kind != 2:  # SHT_SYMTAB
            continue
        strtab = sections[link]
        for at in range(offset, offset + size, entsize):
            name_at, value = struct.unpack_from("<II", data, at)
            start = strtab[4] + name_at
            name = data[start:data.index(b"\0", start)].decode("ascii", "replace")
            symbols[demangle(name)] = value
    return symbols


def demangle(name: str) -> str:
    """`_ZN13tmcl_lm3s69655steps5STEPS17h…E` -> `tmcl_lm3s6965::steps::STEPS` (legacy Rust mangling, the
    hash dropped); other names unchanged."""
    if not name.startswith("_ZN"):
        return name
    parts, at = [], 3
    while at < len(name) and name[at].isdigit():
        end = at
        while name[end].isdigit():
            end += 1
        length = int(name[at:end])
        parts.append(name[end:end + length])
        at = end + length
    if parts and re.fullmatch(r"h[0-9a-f]{16}", parts[-1]):
        parts.pop()
    return "::".join(parts)


class ServerFactory:
    """Starts servers in one test's temporary directory and cleans all of them up. With `qemu_image`, a
    single-module pty server is the firmware image under QEMU (the `--target qemu` run of the suite); a
    test that asks for more (TCP, an EEPROM file, options of `tmcl serve`, several modules) is skipped."""

    def __init__(self, tmcl: Path, workdir: Path, qemu_image: Path | None = None, qemu_icount: bool = False):
        self.tmcl = tmcl
        self.workdir = workdir
        self.qemu_image = qemu_image
        self.qemu_icount = qemu_icount
        self.servers: list[Server] = []

    def __call__(self, kind: str = "pty", eeprom: Path | None = None, extra: list[str] | None = None,
                 link_name: str | None = None, expect_address: int | None = 1,
                 modules: list[str] | None = None, listen: str = "127.0.0.1:0") -> Server:
        name = link_name or f"tmcl-link-{len(self.servers)}"
        if self.qemu_image is not None:
            return self.qemu(name, kind=kind, eeprom=eeprom, extra=extra, modules=modules)
        server = Server(self.tmcl, self.workdir, kind, eeprom=eeprom, extra=extra, link_name=name,
                        modules=modules, listen=listen)
        server.expect_address = expect_address
        self.servers.append(server)
        return server.start()

    def qemu(self, name: str, kind: str = "pty", eeprom: Path | None = None, extra: list[str] | None = None,
             modules: list[str] | None = None) -> QemuServer:
        import pytest

        needs = [what for what, asked in [
            ("a TCP port", kind != "pty"), ("an EEPROM file", eeprom is not None),
            (f"the options {extra}", bool(extra)),
            ("several modules or a start address", bool(modules) and (len(modules) > 1 or "@" in modules[0])),
            ("a TMCM-1310 (its encoder and closed loop need the simulated world)",
             bool(modules) and modules[0] != "pd28-1021"),
        ] if asked]
        if needs:
            pytest.skip(f"needs tmcl serve: {', '.join(needs)}; the QEMU image is one PD28-1021 on a pty")
        assert self.qemu_image is not None
        server = QemuServer(self.qemu_image, self.workdir, link_name=name)
        server.icount = self.qemu_icount
        self.servers.append(server)
        return server.start()

    def cleanup(self) -> list[str]:
        problems = []
        for server in self.servers:
            if not server.running:
                if server.proc is not None:  # exited by itself
                    problems.append(f"server exited early with {server.proc.returncode}: {server.stderr()}")
                    server.proc = None
                continue
            try:
                server.terminate_checked()
            except AssertionError as exc:
                problems.append(str(exc))
            finally:
                server.kill()
        return problems


# -- pytrinamic helpers ----------------------------------------------------------------------------

@contextlib.contextmanager
def pytrinamic_connection(server: Server, tcp_timeout_s: float = 10.0, module_id: int | None = None):
    """A pytrinamic ConnectionManager connection to `server`, closed afterwards; `module_id` selects a
    module on a bus (pytrinamic's `--module-id`; default: the server's first module).

    pytrinamic's socket interface has no receive timeout; a socket timeout is set on its socket so a
    missing reply fails the test instead of hanging it.
    """
    from pytrinamic.connections import ConnectionManager

    args = server.pytrinamic_args if module_id is None else server.pytrinamic_args_for(module_id)
    conn = ConnectionManager(args).connect()
    try:
        sock = getattr(conn, "_socket", None)
        if sock is not None:
            sock.settimeout(tcp_timeout_s)
        yield conn
    finally:
        conn.close()


def wait_until(predicate, timeout_s: float, interval_s: float = 0.02, what: str = "condition"):
    """Polls `predicate()` until it returns a truthy value; fails after `timeout_s`."""
    deadline = time.monotonic() + timeout_s
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() >= deadline:
            raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")
        time.sleep(interval_s)


# The silence after which `tmcl serve` (without --wire-timing) drops a partial frame, with a margin: the
# serial line's 5 ms are meaningless on a pty or a TCP socket (docs/decisions.md, "No frame lost").
RESYNC_S = 0.07


# -- raw frames ------------------------------------------------------------------------------------

def checksum(data: bytes) -> int:
    return sum(data) & 0xFF


def frame(address: int, opcode: int, kind: int, motor: int, value: int) -> bytes:
    body = bytes([address & 0xFF, opcode & 0xFF, kind & 0xFF, motor & 0xFF]) + (value & 0xFFFFFFFF).to_bytes(4, "big")
    return body + bytes([checksum(body)])


class RawReply:
    def __init__(self, data: bytes):
        assert len(data) == 9, f"short reply: {data.hex(' ')}"
        self.data = data
        self.host, self.module, self.status, self.opcode = data[0], data[1], data[2], data[3]
        self.value = int.from_bytes(data[4:8], "big", signed=True)
        self.checksum_ok = checksum(data[:8]) == data[8]

    def __repr__(self):
        return (f"RawReply(host={self.host}, module={self.module}, status={self.status}, opcode={self.opcode}, "
                f"value={self.value}, bytes={self.data.hex(' ')})")


# -- a raw line with timestamps (bus and ASCII tests) ----------------------------------------------

class LinePort:
    """A host on the line with raw pyserial: writes whole frames or text, reads with bounded waits and
    with the monotonic time at which the bytes arrived (`select` on the pty, then `os.read`)."""

    def __init__(self, link, baud: int = 115200):
        import serial

        self.ser = serial.Serial(str(link), baud, timeout=0)
        self.fd = self.ser.fileno()
        self.pending = b""  # bytes read but not yet consumed

    def close(self):
        self.ser.close()

    def __enter__(self) -> "LinePort":
        return self

    def __exit__(self, *exc):
        self.close()

    def write(self, data: bytes) -> float:
        """Writes `data`; returns the time right before the write (nothing can answer earlier, so delays
        measured from it are never too short, even if this process is descheduled after the write)."""
        t = time.monotonic()
        self.ser.write(data)
        self.ser.flush()
        return t

    def _fill(self, deadline: float) -> float | None:
        """Reads whatever arrives before `deadline`; returns its arrival time (None: nothing came)."""
        left = deadline - time.monotonic()
        readable, _, _ = select.select([self.fd], [], [], max(left, 0))
        if not readable:
            return None
        t = time.monotonic()
        data = os.read(self.fd, 4096)
        self.pending += data
        return t

    def read_timed(self, n: int, timeout: float = 5.0) -> tuple[bytes, float | None, float | None]:
        """Up to `n` bytes within `timeout`, with the arrival times of the first and the last of them."""
        deadline = time.monotonic() + timeout
        first = last = time.monotonic() if self.pending else None
        while len(self.pending) < n:
            t = self._fill(deadline)
            if t is None:
                break
            first = first or t
            last = t
        data, self.pending = self.pending[:n], self.pending[n:]
        return data, first, last

    def read_exact(self, n: int, timeout: float = 5.0) -> bytes:
        data, _, _ = self.read_timed(n, timeout)
        assert len(data) == n, f"expected {n} bytes within {timeout} s, got {data.hex(' ') or 'nothing'}"
        return data

    def read_until(self, end: bytes = b"\r", timeout: float = 5.0) -> bytes:
        """Bytes up to and including `end` (an ASCII reply line)."""
        deadline = time.monotonic() + timeout
        while end not in self.pending:
            if self._fill(deadline) is None:
                raise AssertionError(f"no {end!r} within {timeout} s; got {self.pending!r}")
        i = self.pending.index(end) + len(end)
        data, self.pending = self.pending[:i], self.pending[i:]
        return data

    def read_quiet(self, quiet_s: float = 0.2, timeout: float = 5.0) -> bytes:
        """Everything that arrives until the line has been quiet for `quiet_s`."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self._fill(min(deadline, time.monotonic() + quiet_s)) is None:
                break
        data, self.pending = self.pending, b""
        return data

    def reply(self, timeout: float = 5.0) -> RawReply:
        return RawReply(self.read_exact(9, timeout))

    def request(self, address: int, opcode: int, kind: int, motor: int, value: int,
                timeout: float = 5.0) -> RawReply:
        self.write(frame(address, opcode, kind, motor, value))
        return self.reply(timeout)

    def ok(self, address: int, opcode: int, kind: int, motor: int, value: int, host: int = 2) -> RawReply:
        """A request answered with status 100 by the module at `address`."""
        reply = self.request(address, opcode, kind, motor, value)
        assert reply.checksum_ok, reply
        assert (reply.host, reply.module, reply.status, reply.opcode) == (host, address, 100, opcode), reply
        return reply

    def silence(self, seconds: float = 0.3):
        """Nothing arrives within `seconds`."""
        data, _, _ = self.read_timed(1, seconds)
        assert data == b"", f"expected no bytes within {seconds} s, got {(data + self.pending).hex(' ')}"

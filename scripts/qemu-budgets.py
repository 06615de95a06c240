#!/usr/bin/env python3
"""The budgets of the firmware image for the emulated Cortex-M3 (docs/benchmarks.md, "The firmware on a
Cortex-M3"), measured on the image itself.

Usage: scripts/qemu-budgets.py            (needs qemu-system-arm and the thumbv7m-none-eabi target)

- flash and static RAM: the sizes of the release image's sections (.vector_table + .text + .rodata +
  .data are flash; .data + .bss + .uninit are static RAM);
- stack high-water mark: the image runs under QEMU (scripts/qemu-serve.sh) and a host session drives it
  over the pty through everything that goes deep (parameters, STAP/RSAP and STGP, moves, a reference
  search, a program downloaded and run with subroutines, ASCII mode, restarts with 255 and factory
  defaults with 137); then QEMU's monitor dumps the stack, which cortex-m-rt painted with 0xCCCCCCCC at
  start-up (`paint-stack`), and the deepest word that lost its paint is the high-water mark;
- instructions: the `tmcl-lm3s6965-bench` image under `-icount shift=0` (one instruction = one virtual
  nanosecond; see firmware/src/bin/bench.rs for what each figure covers).

Only the standard library: the session writes raw frames to the pty.
"""

from __future__ import annotations

import os
import re
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import termios
import time
import tty
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TARGET = "thumbv7m-none-eabi"
PAINT = 0xCCCC_CCCC


def target_dir() -> Path:
    t = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    return t if t.is_absolute() else ROOT / t


def sections(path: Path) -> dict[str, tuple[int, int, int]]:
    """name -> (address, size, flags) of a 32-bit little-endian ELF."""
    data = path.read_bytes()
    shoff, = struct.unpack_from("<I", data, 0x20)
    shentsize, shnum, shstrndx = struct.unpack_from("<HHH", data, 0x2E)
    heads = [struct.unpack_from("<IIIIIIIIII", data, shoff + i * shentsize) for i in range(shnum)]
    names = heads[shstrndx][4]
    out = {}
    for name, _kind, flags, addr, _off, size, *_ in heads:
        text = data[names + name:data.index(b"\0", names + name)].decode()
        out[text] = (addr, size, flags)
    return out


def symbols(path: Path) -> dict[str, int]:
    sys.path.insert(0, str(ROOT / "tests" / "python"))
    from tmcltest import elf_symbols  # noqa: E402 (the suite's ELF reader)

    return elf_symbols(path)


def frame(address: int, opcode: int, kind: int, motor: int, value: int) -> bytes:
    body = bytes([address, opcode, kind, motor]) + (value & 0xFFFFFFFF).to_bytes(4, "big")
    return body + bytes([sum(body) & 0xFF])


class Line:
    def __init__(self, path: Path):
        self.fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
        tty.setraw(self.fd)
        termios.tcflush(self.fd, termios.TCIOFLUSH)

    def read(self, n: int, timeout: float = 5.0) -> bytes:
        import select

        out = b""
        deadline = time.monotonic() + timeout
        while len(out) < n:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([self.fd], [], [], left)[0]:
                break
            out += os.read(self.fd, n - len(out))
        return out

    def request(self, opcode: int, kind: int = 0, motor: int = 0, value: int = 0) -> tuple[int, int]:
        os.write(self.fd, frame(1, opcode, kind, motor, value))
        reply = self.read(9)
        assert len(reply) == 9, f"no reply to {opcode}/{kind}: {reply.hex(' ')}"
        return reply[2], int.from_bytes(reply[4:8], "big", signed=True)

    def text(self, line: bytes) -> bytes:
        os.write(self.fd, line + b"\r")
        out = b""
        while not out.endswith(b"\r"):
            chunk = self.read(1, 2.0)
            if not chunk:
                break
            out += chunk
        return out


def monitor(path: str, command: str) -> str:
    with socket.socket(socket.AF_UNIX) as s:
        s.connect(path)
        s.settimeout(10)
        buf = b""
        for _ in range(2):
            while not buf.endswith(b"(qemu) "):
                buf += s.recv(65536)
            if _ == 0:
                buf = b""
                s.sendall(command.encode() + b"\n")
        return buf.decode("utf-8", "replace")


def session(line: Line) -> None:
    """Everything deep, through the pty."""
    SAP, GAP, STAP, RSAP, SGP, GGP, STGP, RSGP, MVP, RFS = 5, 6, 7, 8, 9, 10, 11, 12, 4, 13
    for number in (4, 5, 6, 140, 193, 194, 195):
        assert line.request(GAP, number)[0] == 100
    assert line.request(SAP, 4, 0, 204800)[0] == 100
    assert line.request(SAP, 5, 0, 409600)[0] == 100
    assert line.request(STAP, 4)[0] == 100
    assert line.request(RSAP, 4)[0] == 100
    assert line.request(SGP, 3, 2, 42)[0] == 100
    assert line.request(STGP, 3, 2)[0] == 100
    assert line.request(RSGP, 3, 2)[0] == 100
    assert line.request(SGP, 84, 0, 1)[0] == 100  # coordinates stored in the EEPROM
    assert line.request(30, 1, 0, 1000)[0] == 100  # SCO 1
    assert line.request(MVP, 0, 0, 25600)[0] == 100
    for _ in range(200):
        if line.request(GAP, 8)[1] == 1:
            break
        time.sleep(0.02)
    assert line.request(RFS, 0)[0] == 100  # reference search (mode of AP 193)
    time.sleep(0.2)
    assert line.request(RFS, 1)[0] == 100  # stop it
    # A program: subroutines, CALC, COMP/JC, a timer interrupt.
    program = [(19, 9, 0, 0), (21, 0, 0, 5), (20, 2, 0, 8), (23, 0, 0, 8), (22, 0, 0, 1),
               (28, 0, 0, 0), (28, 0, 0, 0), (28, 0, 0, 0),
               (19, 0, 0, 1), (35, 7, 2, 0), (24, 0, 0, 0)]
    assert line.request(132, 0, 0, 0)[0] == 100
    for op, kind, motor, value in program:
        assert line.request(op, kind, motor, value)[0] == 101
    assert line.request(133)[0] == 100
    assert line.request(129, 1)[0] == 100
    time.sleep(0.3)
    assert line.request(128)[0] == 100
    for address in range(len(program)):
        line.request(134, 0, 0, address)
    assert line.request(SGP, 67, 0, 0x20)[0] == 100  # ASCII without echo
    os.write(line.fd, frame(1, 139, 0, 0, 0))
    assert len(line.read(9)) == 9
    for text in (b"AGAP 4, 0", b"ASAP 4, 0, 51200", b"AMVP ABS, 0, 100", b"AGGP 66, 0", b"ASIO 0, 2, 1"):
        assert line.text(text).startswith(b"BA 100"), text
    line.text(b"ABIN")
    time.sleep(0.1)
    assert line.request(255, 0, 0, 1234)[0] == 100  # restart
    time.sleep(0.2)
    os.write(line.fd, frame(1, 137, 0, 0, 1234))  # factory defaults, no reply
    time.sleep(0.5)
    assert line.request(136, 1)[0] == 100


def stack_high_water(image: Path) -> tuple[int, int]:
    """(used, size) of the stack after the session."""
    syms = symbols(image)
    bottom, top = syms["_stack_end"], syms["_stack_start"]
    with tempfile.TemporaryDirectory() as tmp:
        link, mon, dump = Path(tmp) / "link", f"{tmp}/mon", Path(tmp) / "stack.bin"
        env = dict(os.environ, QEMU_IMAGE=str(image))
        serve = subprocess.Popen(["bash", str(ROOT / "scripts" / "qemu-serve.sh"), str(link), "--monitor", mon],
                                 stdout=subprocess.PIPE, env=env, text=True)
        try:
            ready = serve.stdout.readline()
            assert ready.startswith("serving"), ready
            line = Line(link)
            session(line)
            monitor(mon, f'pmemsave {bottom:#x} {top - bottom} "{dump}"')
            time.sleep(0.2)
            data = dump.read_bytes()
        finally:
            serve.send_signal(signal.SIGTERM)
            serve.wait(20)
    words = struct.unpack(f"<{len(data) // 4}I", data)
    untouched = next(i for i, w in enumerate(words) if w != PAINT) * 4
    return top - bottom - untouched, top - bottom


def instructions(bench: Path) -> dict[str, float]:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "uart.txt"
        subprocess.run(["qemu-system-arm", "-machine", "lm3s6965evb", "-display", "none", "-monitor", "none",
                        "-serial", f"file:{out}", "-no-reboot", "-icount", "shift=0,sleep=off",
                        "-kernel", str(bench)], check=True, timeout=600, stderr=subprocess.DEVNULL)
        text = out.read_bytes().decode("latin-1")
    figures = {}
    for name, runs, micros in re.findall(r"([a-z][a-z_]*) runs=(\d+) micros=(\d+)", text):
        figures[name] = int(micros) * 1000 / int(runs)
    assert "done" in text, text[-500:]
    return figures


def main() -> int:
    subprocess.run(["cargo", "build", "--release", "--quiet"], cwd=ROOT / "firmware", check=True)
    release = target_dir() / TARGET / "release"
    image = release / "tmcl-lm3s6965"
    s = sections(image)
    size = lambda name: s.get(name, (0, 0, 0))[1]  # noqa: E731
    flash = size(".vector_table") + size(".text") + size(".rodata") + size(".data")
    print(f"flash: {flash} bytes (.vector_table {size('.vector_table')}, .text {size('.text')}, "
          f".rodata {size('.rodata')}, .data {size('.data')}) of 262144")
    ram = size(".data") + size(".bss") + size(".uninit")
    print(f"static RAM: {ram} bytes (.data {size('.data')}, .bss {size('.bss')}, "
          f".uninit {size('.uninit')}: the EEPROM) of 65280 (64 KiB less the 256 configuration bytes)")
    used, stack = stack_high_water(image)
    print(f"stack: high-water mark {used} bytes of the {stack} between the statics and the top of RAM "
          f"({stack - used} never touched)")
    for name, value in instructions(release / "tmcl-lm3s6965-bench").items():
        print(f"instructions per {name}: {value:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

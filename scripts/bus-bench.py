#!/usr/bin/env python3
"""Request throughput on a three-module RS485 bus served by `tmcl serve`, with and without --wire-timing,
compared with the physical wire time at each GP 65 baud rate.

Usage (from the repository root, after `scripts/python-tests.sh` made .venv and the release binary):

    .venv/bin/python scripts/bus-bench.py [--tmcl target/release/tmcl] [--seconds 1.5] [--bauds 0-8]

One host, one request in flight (as TMCL requires): GAP 4 to addresses 1, 2, 3 in turn, each reply read
whole before the next request. Two clients: raw pyserial (write 9 bytes, select + read 9 bytes) and
pytrinamic's SerialTmclInterface (`get_axis_parameter(4, 0, module_id=N)`). For --wire-timing, GP 65 of
all three modules is set and each module restarted with command 255 (a new baud rate is in force after a
restart, manual §5.1). Physical wire time of one request: 9 bytes in + 9 bytes out, 10 bits each (8N1),
no telegram pause (GP 75 = 0), no turnaround: 180 bits / baud; that is the ceiling of a real line.
Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import os
import platform
import re
import select
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import serial

ROOT = Path(__file__).resolve().parents[1]
BAUD_RATES = [9600, 14400, 19200, 28800, 38400, 57600, 76800, 115200, 230400]  # GP 65 = 0 … 8
ADDRESSES = (1, 2, 3)
GAP, SGP, RESET = 6, 9, 255


def frame(address: int, opcode: int, kind: int, motor: int, value: int) -> bytes:
    body = bytes([address, opcode, kind, motor]) + (value & 0xFFFFFFFF).to_bytes(4, "big")
    return body + bytes([sum(body) & 0xFF])


class Server:
    def __init__(self, tmcl: Path, workdir: Path, wire_timing: bool):
        self.link = workdir / ("link-wire" if wire_timing else "link")
        args = [str(tmcl), "serve", "--pty", str(self.link)]
        for a in ADDRESSES:
            args += ["--module", f"pd28-1021@{a}"]
        if wire_timing:
            args.append("--wire-timing")
        self.proc = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                     stderr=subprocess.DEVNULL, text=True)
        assert self.proc.stdout is not None
        ready, _, _ = select.select([self.proc.stdout], [], [], 20)
        line = self.proc.stdout.readline() if ready else ""
        if not re.match(r"^serving .* on ", line):
            self.stop()
            raise SystemExit(f"tmcl serve did not start: {line!r}")

    def stop(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
        self.proc.wait(timeout=10)


class Raw:
    def __init__(self, link: Path):
        self.ser = serial.Serial(str(link), 115200, timeout=0)
        self.fd = self.ser.fileno()

    def close(self):
        self.ser.close()

    def request(self, data: bytes, timeout: float = 2.0) -> bytes:
        self.ser.write(data)
        got = b""
        deadline = time.monotonic() + timeout
        while len(got) < 9:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([self.fd], [], [], left)[0]:
                raise RuntimeError(f"no reply to {data.hex(' ')} (got {got.hex(' ')})")
            got += os.read(self.fd, 9 - len(got))
        return got

    def drain(self, quiet: float = 0.1):
        while select.select([self.fd], [], [], quiet)[0]:
            os.read(self.fd, 4096)


def set_baud(link: Path, index: int):
    """GP 65 = index on every module, then command 255 (restart) so that it is in force."""
    raw = Raw(link)
    try:
        for a in ADDRESSES:
            reply = raw.request(frame(a, SGP, 65, 0, index))
            assert reply[2] == 100, reply.hex(" ")
            raw.request(frame(a, RESET, 0, 0, 1234))
        raw.drain()
    finally:
        raw.close()


def measure_raw(link: Path, seconds: float) -> list[float]:
    raw = Raw(link)
    times = []
    try:
        frames = [frame(a, GAP, 4, 0, 0) for a in ADDRESSES]
        end = time.monotonic() + seconds
        i = 0
        while time.monotonic() < end or len(times) < 30:
            t0 = time.perf_counter()
            reply = raw.request(frames[i % 3])
            times.append(time.perf_counter() - t0)
            assert reply[1] == ADDRESSES[i % 3] and reply[2] == 100, reply.hex(" ")
            i += 1
    finally:
        raw.close()
    return times


def measure_pytrinamic(link: Path, seconds: float) -> list[float]:
    from pytrinamic.connections import SerialTmclInterface

    conn = SerialTmclInterface(str(link), timeout_s=2)
    times = []
    try:
        end = time.monotonic() + seconds
        i = 0
        while time.monotonic() < end or len(times) < 30:
            t0 = time.perf_counter()
            value = conn.get_axis_parameter(4, 0, module_id=ADDRESSES[i % 3])
            times.append(time.perf_counter() - t0)
            assert value == 51200, value
            i += 1
    finally:
        conn.close()
    return times


def row(label: str, baud: int | None, client: str, times: list[float]) -> str:
    median = statistics.median(times)
    p99 = sorted(times)[int(len(times) * 0.99) - 1]
    rate = len(times) / sum(times)
    if baud is None:
        wire = ceiling = ratio = "–"
    else:
        wire_s = 180 / baud
        wire = f"{wire_s * 1e3:.2f}"
        ceiling = f"{baud / 180:.0f}"
        ratio = f"{median / wire_s:.2f}"
    return (f"| {label} | {client} | {len(times)} | {rate:.0f} | {median * 1e3:.2f} | {p99 * 1e3:.2f} | "
            f"{wire} | {ceiling} | {ratio} |")


def parse_bauds(text: str) -> list[int]:
    out = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        out += list(range(int(lo), int(hi or lo) + 1))
    assert all(0 <= i <= 8 for i in out), text
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tmcl", type=Path, default=ROOT / "target" / "release" / "tmcl")
    parser.add_argument("--seconds", type=float, default=1.5, help="measuring time per row")
    parser.add_argument("--bauds", default="0-8", help="GP 65 indices for --wire-timing, e.g. 0-8 or 0,7,8")
    args = parser.parse_args()
    if not args.tmcl.is_file():
        raise SystemExit(f"{args.tmcl} not found: build it with `cargo build --release -p tmcl-cli`")

    print(f"`{' '.join(['scripts/bus-bench.py'] + sys.argv[1:])}` on {platform.system()} {platform.release()}, "
          f"{platform.machine()}, {os.cpu_count()} CPUs, Python {platform.python_version()}\n")
    print("| line | client | requests | requests/s | median RTT ms | p99 RTT ms | wire time ms (180 bits) "
          "| wire ceiling req/s | median RTT / wire time |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory(prefix="bus-bench-") as tmp:
        server = Server(args.tmcl, Path(tmp), wire_timing=False)
        try:
            for client, measure in (("pyserial", measure_raw), ("pytrinamic", measure_pytrinamic)):
                print(row("pty, no --wire-timing", None, client, measure(server.link, args.seconds)), flush=True)
        finally:
            server.stop()
        server = Server(args.tmcl, Path(tmp), wire_timing=True)
        try:
            for index in parse_bauds(args.bauds):
                baud = BAUD_RATES[index]
                set_baud(server.link, index)
                for client, measure in (("pyserial", measure_raw), ("pytrinamic", measure_pytrinamic)):
                    label = f"--wire-timing, GP 65 = {index} ({baud} baud)"
                    print(row(label, baud, client, measure(server.link, args.seconds)), flush=True)
        finally:
            server.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""The round trip `tmcl share` adds: one module, reached directly and through a share, in the same run.

Usage (from the repository root, after `scripts/python-tests.sh` made .venv and the release binary):

    .venv/bin/python scripts/share-bench.py [--tmcl target/release/tmcl] [--rounds 10] [--batch 1000]

`tmcl serve --pty DIRECT --pty DEVICE` serves one PD28-1021 on two links; `tmcl share --port DEVICE --pty
SHARED` shares the second. One host (raw pyserial: write 9 bytes, read 9 bytes) sends GAP 4 and times each
transaction from the write to the last byte of its reply, in batches of --batch transactions that
alternate between DIRECT and SHARED (--rounds batches each), so that the machine's load falls on both
alike. With --log, the share also writes every transaction to a log file (its cost is in the figure).
Prints a Markdown table: median, p99 and mean per path, and the difference (what the share adds).
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


def frame(address: int, opcode: int, kind: int, motor: int, value: int) -> bytes:
    body = bytes([address, opcode, kind, motor]) + (value & 0xFFFFFFFF).to_bytes(4, "big")
    return body + bytes([sum(body) & 0xFF])


def start(args: list[str], ready: str) -> subprocess.Popen:
    proc = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                            text=True, start_new_session=True)
    assert proc.stdout is not None
    ok, _, _ = select.select([proc.stdout], [], [], 20)
    line = proc.stdout.readline() if ok else ""
    if not re.match(ready, line):
        proc.kill()
        sys.exit(f"{args[1]} did not start: {line!r}")
    return proc


def batch(port: serial.Serial, n: int, request: bytes) -> list[float]:
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        port.write(request)
        got = b""
        while len(got) < 9:
            got += port.read(9 - len(got))
        times.append(time.perf_counter() - t0)
        assert got[2] == 100, got
    return times


def pct(values: list[float], p: float) -> float:
    s = sorted(values)
    return s[min(len(s) - 1, int(round(p / 100 * (len(s) - 1))))]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tmcl", default=str(ROOT / "target" / "release" / "tmcl"))
    ap.add_argument("--rounds", type=int, default=10)
    ap.add_argument("--batch", type=int, default=1000)
    ap.add_argument("--log", action="store_true", help="the share logs every transaction to a file")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        direct, device, shared = tmp / "direct", tmp / "device", tmp / "shared"
        serve = start([args.tmcl, "serve", "--pty", str(direct), "--pty", str(device)], r"^serving ")
        extra = ["--log", str(tmp / "share.log")] if args.log else []
        share = start([args.tmcl, "share", "--port", str(device), "--pty", str(shared), *extra], r"^sharing ")
        try:
            request = frame(1, 6, 4, 0, 0)
            results: dict[str, list[float]] = {"direct": [], "share": []}
            with serial.Serial(str(direct), 115200, timeout=5) as d, serial.Serial(str(shared), 115200, timeout=5) as s:
                batch(d, 100, request)  # warm-up
                batch(s, 100, request)
                for _ in range(args.rounds):
                    results["direct"] += batch(d, args.batch, request)
                    results["share"] += batch(s, args.batch, request)
        finally:
            for proc in (share, serve):
                proc.send_signal(signal.SIGTERM)
                proc.wait(10)
    ms = 1000.0
    print(f"{platform.machine()}, {os.cpu_count()} cores; {args.rounds} alternating batches of {args.batch} "
          f"GAP 4 per path{'; share with --log' if args.log else ''}\n")
    print("| path | median | p99 | mean |")
    print("|---|---|---|---|")
    for name, values in results.items():
        print(f"| {name} | {statistics.median(values) * ms:.3f} ms | {pct(values, 99) * ms:.3f} ms | "
              f"{statistics.fmean(values) * ms:.3f} ms |")
    d, s = results["direct"], results["share"]
    print(f"| added by the share | {(statistics.median(s) - statistics.median(d)) * ms:+.3f} ms | "
          f"{(pct(s, 99) - pct(d, 99)) * ms:+.3f} ms | {(statistics.fmean(s) - statistics.fmean(d)) * ms:+.3f} ms |")


if __name__ == "__main__":
    main()

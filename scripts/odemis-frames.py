#!/usr/bin/env python3
"""GAP frames per second through odemis' TMCMSimulator, the public peer simulator that issue 24 compares
the in-process frame path with (docs/benchmarks.md, "The frame path").

Usage: scripts/odemis-frames.py ODEMIS_CHECKOUT [FRAMES] [ROUNDS]

ODEMIS_CHECKOUT is a clone of delmic/odemis. The simulator class (src/odemis/driver/tmcm.py) and the
simulated axis it moves (src/odemis/util/mock.py) are taken out of the sources as they are and run with
numpy, without the rest of odemis (whose hardware layer the simulator does not use). Each frame is the
9-byte GAP 1 (actual position) of axis 0 written and its 9-byte reply read back, as odemis' driver does;
the figure is frames per second over FRAMES frames (default 200 000), printed for each of ROUNDS rounds
(default 3).
"""
import ast
import logging
import random
import struct
import sys
import time
import types
from typing import Optional, Tuple

import numpy


def class_source(path, name):
    tree = ast.parse(open(path, encoding="utf-8").read())
    for node in tree.body:
        if isinstance(node, ast.ClassDef) and node.name == name:
            return ast.get_source_segment(open(path, encoding="utf-8").read(), node)
    raise SystemExit(f"{name} not found in {path}")


def load(checkout):
    mock_ns = {"time": time, "logging": logging, "Optional": Optional, "Tuple": Tuple}
    exec(class_source(f"{checkout}/src/odemis/util/mock.py", "SimulatedAxis"), mock_ns)
    mock = types.SimpleNamespace(SimulatedAxis=mock_ns["SimulatedAxis"])
    ns = {"numpy": numpy, "struct": struct, "time": time, "logging": logging, "random": random, "mock": mock}
    exec(class_source(f"{checkout}/src/odemis/driver/tmcm.py", "TMCMSimulator"), ns)
    return ns["TMCMSimulator"]


def gap_frame(address=1, kind=1, motor=0, value=0):
    body = struct.pack(">BBBBi", address, 6, kind, motor, value)
    return body + bytes([sum(body) & 0xFF])


def main():
    if len(sys.argv) < 2:
        raise SystemExit(__doc__)
    checkout = sys.argv[1]
    frames = int(sys.argv[2]) if len(sys.argv) > 2 else 200_000
    rounds = int(sys.argv[3]) if len(sys.argv) > 3 else 3
    simulator = load(checkout)(timeout=0, naxes=3)
    frame = gap_frame()
    simulator.write(frame)
    assert len(simulator.read(9)) == 9, "the simulator answers GAP 1"
    for _ in range(rounds):
        start = time.perf_counter()
        for _ in range(frames):
            simulator.write(frame)
            simulator.read(9)
        secs = time.perf_counter() - start
        print(f"odemis TMCMSimulator GAP 1  {frames / secs / 1e3:8.1f} k frames/s  ({secs * 1e9 / frames:.0f} ns/frame, {frames} frames)")


if __name__ == "__main__":
    main()

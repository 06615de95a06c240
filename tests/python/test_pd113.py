"""A virtual PDx-113 (`tmcl serve --module pd-113`), the TMC428 generation, driven by host software as
for the real module: the manual's frames with pyserial (PDx-113-57/60-SE TMCL firmware manual V1.04,
§5.7), its ASCII interface (§5.6), SAC to the TMC428 (§5.4.3), pytrinamic's generic TMCL calls, and a
PD28-1021 beside it on one virtual RS485 bus.

pytrinamic has no PDx-113 class; its `TMCLInterface` (get/set axis and global parameters, rotate,
move_to, the version string) is what host software for the module uses, with the module's own units.
"""

from __future__ import annotations

import pathlib
import re

import pytest
from pytrinamic.connections import ConnectionManager

from tmcltest import LinePort, frame, wait_until

STATUS_OK = 100
STATUS_INVALID_COMMAND = 2
STATUS_WRONG_TYPE = 3
STATUS_INVALID_VALUE = 4
STATUS_NOT_AVAILABLE = 6
REPLY_RE = re.compile(rb"^([A-Z])([A-Z]) (\d+) (-?\d+)\r$")


@pytest.fixture
def pd113(serve):
    """A PDx-113 on a pty, state in memory."""
    return serve("pty", modules=["pd-113"])


@pytest.fixture
def bus(serve):
    """A PDx-113 at address 1 and a PD28-1021 at address 2 on one virtual RS485 line."""
    return serve("pty", modules=["pd-113@1", "pd28-1021@2"])


def test_the_manuals_frames_byte_for_byte(pd113):
    with LinePort(pd113.link) as line:
        # §5.7.1 ROR 0, 350 as printed (motor byte 02, checksum of motor 00): wrong checksum, status 1.
        line.write(bytes.fromhex("01 01 00 02 00 00 01 5E 61"))
        assert line.reply().data == bytes.fromhex("02 01 01 00 00 00 00 00 04")
        for request, status, op, value in [
            ("01 01 00 00 00 00 01 5E 61", 100, 1, 350),     # ROR 0, 350 (the erratum decided)
            ("01 02 00 00 00 00 04 B0 B7", 100, 2, 1200),    # ROL 0, 1200
            ("01 03 00 00 00 00 00 00 04", 100, 3, 0),       # MST 0
            ("01 04 00 00 00 00 23 28 50", 100, 4, 9000),    # MVP ABS, 0, 9000
            ("01 04 01 00 FF FF FC 18 18", 100, 4, -1000),   # MVP REL, 0, -1000
            ("01 04 02 00 00 00 00 08 0F", 100, 4, 8),       # MVP COORD, 0, 8
            ("01 05 06 00 00 00 00 B6 C2", 100, 5, 182),     # SAP 6, 0, 182
            ("01 07 04 00 00 00 00 00 0C", 100, 7, 0),       # STAP 4, 0
            ("01 08 06 00 00 00 00 00 0F", 100, 8, 0),       # RSAP 6, 0
            ("01 0B 42 00 00 00 00 00 4E", 100, 11, 0),      # STGP 66, 0
            ("01 0C 2A 02 00 00 00 00 39", 100, 12, 0),      # RSGP 42, 2
            ("01 0D 00 00 00 00 00 00 0E", 100, 13, 0),      # RFS START, 0
            ("01 0E 01 02 00 00 00 01 13", 100, 14, 1),      # SIO 1, 2, 1
            ("01 13 02 00 FF FF EC 78 78", 100, 19, -5000),  # CALC MUL, -5000
            ("01 14 00 00 00 00 03 E8 00", 6, 20, 1000),     # COMP 1000: program only
        ]:
            line.write(bytes.fromhex(request))
            r = line.reply()
            assert r.checksum_ok and (r.host, r.module, r.status, r.opcode, r.value) == (2, 1, status, op, value), \
                (request, r)
        line.ok(1, 13, 1, 0, 0)  # RFS STOP
        # §5.7.6 GAP 1, 0 (printed "GAP 0, 1") with the actual position 711.
        line.ok(1, 3, 0, 0, 0)
        wait_until(lambda: line.request(1, 6, 3, 0, 0).value == 0, 5, what="standstill")
        line.ok(1, 5, 1, 0, 711)
        line.write(bytes.fromhex("01 06 01 00 00 00 00 00 08"))
        assert line.reply().data == bytes.fromhex("02 01 64 06 00 00 02 C7 36")
        # §5.7.10 GGP 66, 0.
        line.write(bytes.fromhex("01 0A 42 00 00 00 00 00 4D"))
        assert line.reply().data == bytes.fromhex("02 01 64 0A 00 00 00 01 72")
        # §5.7.15 GIO 0, 1 (printed "GIO 1, 1"): an analog value 0..1023.
        line.write(bytes.fromhex("01 0F 00 01 00 00 00 00 11"))
        r = line.reply()
        assert (r.status, r.opcode) == (100, 15) and 0 <= r.value <= 1023, r


def test_commands_it_lacks_and_135(pd113):
    with LinePort(pd113.link) as line:
        for op in [25, 26, 37, 38, 39, 138, 242, 255]:  # EI DI VECT RETI ACO 138 242 255
            r = line.request(1, op, 0, 0, 1234)
            assert r.status == STATUS_INVALID_COMMAND, (op, r)
        # 135 without type variants (§5.5): the state, 0 = stopped, whatever the type.
        for t in [0, 1, 3, 200]:
            assert line.ok(1, 135, t, 0, 0).value == 0
        # Banks 0, 1, 2; no bank 3.
        assert line.request(1, 10, 0, 3, 0).status == STATUS_INVALID_VALUE
        assert line.request(1, 10, 0, 1, 0).status == STATUS_WRONG_TYPE
        # TMC428 ranges: velocity 0..2047, 24-bit positions.
        assert line.request(1, 1, 0, 0, 2048).status == STATUS_INVALID_VALUE
        assert line.request(1, 4, 0, 0, 1 << 23).status == STATUS_INVALID_VALUE


def test_ascii_negative_reply_and_sac(pd113):
    with LinePort(pd113.link) as line:
        line.ok(1, 5, 1, 0, -5000)
        line.ok(1, 139, 0, 0, 0)
        line.write(b"AGAP 1, 0\r")
        assert line.read_until(b"\r") == b"AGAP 1, 0\r"
        assert line.read_until(b"\r") == b"BA 100 -5000\r"
        # SAC in ASCII (§5.6.3): the TMC429's type and version, all motors at their targets.
        word = 0x73000000
        line.write(b"ASAC 0, 4, %d\r" % word)
        line.read_until(b"\r")
        assert line.read_until(b"\r") == b"BA 100 %d\r" % (0x15000000 | 0x429101)
        line.write(b"ABIN\r")
        line.read_until(b"\r")
        assert line.read_until(b"\r") == b"BA 100 0\r"
        # Binary again: SAC writes v_max (AP 4) and reads it back.
        line.ok(1, 29, 0, 4, (0x06 << 24) | 1234)
        assert line.ok(1, 6, 4, 0, 0).value == 1234
        assert line.ok(1, 29, 0, 4, 0x07 << 24).value & 0xFFFFFF == 1234
        assert line.request(1, 29, 1, 4, 0).status == STATUS_WRONG_TYPE


def test_pytrinamic_in_tmc428_units(pd113):
    c = ConnectionManager(f"--interface serial_tmcl --port {pd113.link}").connect()
    try:
        assert c.get_version_string(1) == "113V1.04"
        c.set_axis_parameter(154, 0, 3)  # pulse divisor 3: one unit is 30.5 microsteps/s
        c.set_axis_parameter(4, 0, 1000)
        assert c.get_axis_parameter(4, 0) == 1000
        c.rotate(0, 500)
        wait_until(lambda: c.get_axis_parameter(3, 0) == 500, 5, what="AP 3 at 500 TMC428 units")
        c.stop(0)
        wait_until(lambda: c.get_axis_parameter(3, 0) == 0, 5, what="stopped")
        c.move_to(0, 3200)
        wait_until(lambda: c.get_axis_parameter(8, 0) == 1, 10, what="target reached")
        assert c.get_axis_parameter(1, 0) == 3200
    finally:
        c.close()


def test_a_pdx_113_and_a_pd28_1021_share_a_bus(bus):
    with LinePort(bus.link) as line:
        # 136 type 1 from each: the module numbers 113 and 1021.
        assert line.ok(1, 136, 1, 0, 0).value == 0x010D0104
        assert line.ok(2, 136, 1, 0, 0).value == 0x0A15012A
        # The same SAP 4 means different things: TMC428 units (0..2047) and pps.
        assert line.request(1, 5, 4, 0, 51200).status == STATUS_INVALID_VALUE
        line.ok(2, 5, 4, 0, 51200)
        line.ok(1, 5, 4, 0, 1000)
        # SAC is the PDx-113's; the PD28-1021 does not know it.
        assert line.ok(1, 29, 0, 4, 0x73000000).value & 0xFFFFFF == 0x429101
        assert line.request(2, 29, 0, 4, 0x73000000).status == STATUS_INVALID_COMMAND
        # EI is the PD28-1021's only.
        assert line.request(1, 25, 255, 0, 0).status == STATUS_INVALID_COMMAND
        line.ok(2, 25, 255, 0, 0)
        # Both move; 24-bit positions on one, 32-bit on the other.
        line.ok(1, 4, 0, 0, 20000)
        line.ok(2, 4, 0, 0, 20000)
        wait_until(lambda: line.request(1, 6, 8, 0, 0).value == 1 and line.request(2, 6, 8, 0, 0).value == 1, 20,
                   what="both at their targets")
        assert line.ok(1, 6, 1, 0, 0).value == 20000
        assert line.ok(2, 6, 1, 0, 0).value == 20000
        assert line.request(1, 4, 0, 0, 10_000_000).status == STATUS_INVALID_VALUE
        line.ok(2, 4, 0, 0, 10_000_000)


def test_cli_status_and_parameters_in_its_units(tmcl_bin, pd113):
    """`tmcl status` shows the state 135 answers (PDx-113 manual §5.5: no PC, accumulator or X register to
    ask for), and `tmcl get` the model's own units."""
    import json
    import subprocess

    def tmcl(*args):
        proc = subprocess.run([str(tmcl_bin), "--json", *args, "--port", str(pd113.link)], capture_output=True,
                              text=True, timeout=30)
        assert proc.returncode == 0, proc.stderr
        return json.loads(proc.stdout.strip().splitlines()[-1])

    assert tmcl("status") == {"mode": 0, "mode_text": "stopped", "pc": 0}
    tmcl("download", str(pathlib.Path(__file__).parents[1] / "programs" / "pd113_first_program.tmc"))
    tmcl("start")
    assert tmcl("status")["mode_text"] == "running"
    tmcl("stop")
    stopped = tmcl("status")
    assert stopped["mode_text"] == "stopped" and 1 <= stopped["pc"] <= 7, stopped  # GP 130, in the program
    speed = tmcl("get", "ap", "MaxPositioningSpeed")
    assert (speed["type"], speed["value"], speed["unit"]) == (4, 1000, "TMC428 v units"), speed

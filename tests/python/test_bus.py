"""Several virtual PD28-1021 on one RS485 line (`tmcl serve --module pd28-1021@1 --module pd28-1021@2 ...`):
addressing (GP 66, 87), host address (GP 76), heartbeat (GP 68), telegram pause (GP 75), reply
suppression (GP 255), damaged frames, resynchronisation, 138 events from several modules, wire timing
(GP 65), and `tmcl scan`. All traffic is on the pty, with raw pyserial (LinePort) and pytrinamic.
"""

from __future__ import annotations

import contextlib
import statistics
import subprocess
import time

import pytest
from pytrinamic.connections import SerialTmclInterface
from pytrinamic.tmcl import TMCLCommand

from tmcltest import BUS_MODULES, RESYNC_S, LinePort, RawReply, frame, pytrinamic_connection, wait_until

HOST = 2
ROR, MST, MVP, SAP, GAP, SGP, GGP = 1, 3, 4, 5, 6, 9, 10
ADDRESSES = (1, 2, 3)
BYTE_9600 = 10 / 9600  # one byte (8N1) at 9600 baud
BYTE_115200 = 10 / 115200


@pytest.fixture
def line(bus_server):
    with LinePort(bus_server.link) as port:
        yield port


def set_distinct_values(line: LinePort) -> dict[int, int]:
    """AP 4 = 1111 on module 1, 2222 on 2, 3333 on 3: every reply tells which module sent it."""
    values = {a: 1111 * a for a in ADDRESSES}
    for a, v in values.items():
        line.ok(a, SAP, 4, 0, v)
    return values


def fast_ramp(line: LinePort, address: int):
    line.ok(address, SAP, 4, 0, 512000)
    line.ok(address, SAP, 5, 0, 2048000)


# -- addressing ------------------------------------------------------------------------------------

def test_ready_line_names_every_module(bus_server):
    assert bus_server.ready_line == (
        "serving PD28-1021 at address 1, PD28-1021 at address 2, PD28-1021 at address 3 "
        f"on {bus_server.link}")
    assert bus_server.addresses == [1, 2, 3]


def test_each_address_answers_only_for_itself(line):
    values = set_distinct_values(line)
    for a in ADDRESSES:
        line.write(frame(a, GAP, 4, 0, 0))
        reply = line.reply()
        assert reply.checksum_ok, reply
        assert (reply.host, reply.module, reply.status, reply.opcode, reply.value) == (HOST, a, 100, GAP,
                                                                                       values[a]), reply
        line.silence(0.15)  # exactly one reply per request
    # The modules are independent: a value set on one is not seen by the others.
    line.ok(2, SGP, 0, 2, -42)  # user variable 0
    assert line.ok(2, GGP, 0, 2, 0).value == -42
    assert line.ok(1, GGP, 0, 2, 0).value == 0
    assert line.ok(3, GGP, 0, 2, 0).value == 0


def test_frame_for_a_free_address_gets_no_reply(line):
    line.write(frame(9, GAP, 4, 0, 0))
    line.silence(0.4)
    bad = bytearray(frame(9, GAP, 4, 0, 0))
    bad[8] ^= 0x5A  # a damaged frame for nobody is not answered either
    line.write(bytes(bad))
    line.silence(0.4)
    for a in ADDRESSES:
        assert line.ok(a, GAP, 4, 0, 0).value == 51200


def test_host_address_gp76_per_module(line):
    line.write(frame(2, SGP, 76, 0, 5))
    reply = line.reply()
    assert reply.checksum_ok and reply.status == 100, reply
    assert reply.host in (2, 5), reply  # the SGP's own reply: old or new host address, either is fine
    assert line.ok(2, GAP, 4, 0, 0, host=5).value == 51200
    assert line.ok(1, GAP, 4, 0, 0, host=2).value == 51200
    assert line.ok(3, GAP, 4, 0, 0, host=2).value == 51200
    line.ok(2, SGP, 76, 0, 2, host=2)


def test_pytrinamic_one_connection_per_module_id(bus_server):
    """A ConnectionManager per module (`--module-id N`); all three are open on the same pty at once and
    used in turn, as a host with one object per drive would."""
    with contextlib.ExitStack() as stack:
        opened = {a: stack.enter_context(pytrinamic_connection(bus_server, module_id=a)) for a in ADDRESSES}
        for a, conn in opened.items():
            conn.set_axis_parameter(4, 0, 10000 + a)
            conn.set_global_parameter(0, 2, -a)
        for a, conn in opened.items():
            assert conn.get_axis_parameter(4, 0) == 10000 + a
            assert conn.get_global_parameter(0, 2, signed=True) == -a
            assert conn.get_global_parameter(66, 0) == a
            assert conn.get_version_string() == "1021V142"
            reply = conn.send(TMCLCommand.GAP, 4, 0, 0)
            assert (reply.module_address, reply.status, reply.value) == (a, 100, 10000 + a)
        # One connection, the module chosen per call with module_id=.
        conn = opened[1]
        for a in ADDRESSES:
            assert conn.get_axis_parameter(4, 0, module_id=a) == 10000 + a
            reply = conn.send(TMCLCommand.GGP, 66, 0, 0, module_id=a)
            assert (reply.module_address, reply.value) == (a, a)
            assert conn.get_version_string(module_id=a) == "1021V142"


def test_pytrinamic_motion_on_three_modules(bus_server):
    with pytrinamic_connection(bus_server) as conn:
        targets = {1: 10000, 2: -20000, 3: 30000}
        for a, target in targets.items():
            conn.set_axis_parameter(4, 0, 512000, module_id=a)
            conn.set_axis_parameter(5, 0, 2048000, module_id=a)
            conn.move_to(0, target, module_id=a)
        for a, target in targets.items():
            wait_until(lambda: conn.get_axis_parameter(8, 0, module_id=a) == 1, 10, what=f"module {a} arrives")
            assert conn.get_axis_parameter(1, 0, module_id=a, signed=True) == target


def test_secondary_address_both_answer(line, bus_server):
    """SGP 87 = 10 on modules 2 and 3: a frame for 10 is executed by both, and both reply, whole and one
    after the other (the bus.rs decision: a real RS485 line would garble two simultaneous replies). Each
    reply carries its module's primary address in byte 1."""
    values = set_distinct_values(line)
    line.ok(2, SGP, 87, 0, 10)
    line.ok(3, SGP, 87, 0, 10)
    assert line.ok(2, GGP, 87, 0, 0).value == 10
    line.write(frame(10, GAP, 4, 0, 0))
    first, second = line.reply(), line.reply()
    line.silence(0.2)
    assert first.checksum_ok and second.checksum_ok, (first, second)
    assert sorted((r.module, r.value) for r in (first, second)) == [(2, values[2]), (3, values[3])]
    assert {r.status for r in (first, second)} == {100}
    # A write to the secondary address reaches both.
    line.write(frame(10, SAP, 4, 0, 7777))
    assert sorted(line.reply().module for _ in range(2)) == [2, 3]
    assert [line.ok(a, GAP, 4, 0, 0).value for a in ADDRESSES] == [values[1], 7777, 7777]

    # What pytrinamic sees: it reads the first 9 bytes as the reply and leaves the second in the buffer,
    # where it is taken as the reply to the next request (pytrinamic checks no addresses).
    conn = SerialTmclInterface(line.ser)
    line.ser.timeout = 5
    reply = conn.send(TMCLCommand.GAP, 4, 0, 0, module_id=10)
    assert reply.module_address in (2, 3) and reply.value == 7777
    stale = conn.send(TMCLCommand.GAP, 4, 0, 0, module_id=1)
    assert stale.module_address in (2, 3) and stale.module_address != reply.module_address
    assert stale.value == 7777, "the other secondary reply, not module 1's"
    left = RawReply(line.ser.read(9))  # module 1's real reply is now the one left over
    assert (left.module, left.value) == (1, values[1]), left
    line.ser.timeout = 0
    # Only one module at the secondary address: one reply, byte 1 = its primary address.
    line.ok(3, SGP, 87, 0, 0)
    line.write(frame(10, GGP, 66, 0, 0))
    reply = line.reply()
    assert (reply.module, reply.value) == (2, 2), reply
    line.silence(0.2)


def test_address_change_takes_effect_at_once(line, bus_server, tmcl_bin):
    line.write(frame(3, SGP, 66, 0, 7))
    reply = line.reply()
    assert reply.checksum_ok and reply.status == 100, reply
    assert reply.module in (3, 7), reply  # the server answers from the new address (7)
    line.write(frame(3, GAP, 4, 0, 0))
    line.silence(0.3)
    assert line.ok(7, GGP, 66, 0, 0).value == 7
    for a in (1, 2):
        assert line.ok(a, GAP, 4, 0, 0).value == 51200
    # tmcl scan sees the new address.
    assert scan(tmcl_bin, bus_server, 1, 10) == [1, 2, 7]


def test_address_change_survives_a_restart(serve, tmp_path):
    """GP 66 is stored automatically (§5.1 access RWA): after a restart on the same EEPROM files the
    module is at its new address; the secondary address GP 87 (also RWA) is kept too."""
    server = serve("pty", modules=BUS_MODULES, extra=["--eeprom-dir", str(tmp_path / "eeprom")])
    with LinePort(server.link) as line:
        line.ok(2, SGP, 87, 0, 20)
        line.write(frame(3, SGP, 66, 0, 7))
        assert line.reply().status == 100
    server.expect_addresses = None
    server.restart()
    with LinePort(server.link) as line:
        line.write(frame(20, GGP, 87, 0, 0))
        reply = line.reply()
        assert (reply.module, reply.value) == (2, 20), "secondary address kept"
        line.write(frame(7, GGP, 66, 0, 0))
        reply = line.reply(timeout=1)
        assert (reply.module, reply.value) == (7, 7), reply
        line.write(frame(3, GAP, 4, 0, 0))
        line.silence(0.3)
    assert server.addresses == [1, 2, 7], server.ready_line


def test_secondary_address_survives_a_restart(serve, tmp_path):
    server = serve("pty", modules=BUS_MODULES, extra=["--eeprom-dir", str(tmp_path / "eeprom")])
    with LinePort(server.link) as line:
        line.ok(2, SGP, 87, 0, 20)
        line.ok(3, SAP, 4, 0, 3000)  # not stored: back to the default after the restart
    assert sorted(p.name for p in (tmp_path / "eeprom").glob("*.eeprom")) == [f"{m}.eeprom" for m in BUS_MODULES]
    server.restart()
    with LinePort(server.link) as line:
        line.write(frame(20, GGP, 87, 0, 0))
        reply = line.reply()
        assert (reply.module, reply.value) == (2, 20), reply
        line.silence(0.2)
        assert line.ok(3, GAP, 4, 0, 0).value == 51200


# -- heartbeat, telegram pause, reply suppression --------------------------------------------------

def test_heartbeat_stops_only_its_module(line):
    for a in (1, 2):
        fast_ramp(line, a)
    line.ok(2, SGP, 68, 0, 200)
    line.ok(1, ROR, 0, 0, 20000)
    line.ok(2, ROR, 0, 0, 20000)
    t_last_to_2 = time.monotonic()
    # Within the heartbeat time module 2 keeps turning (this GAP restarts its heartbeat).
    time.sleep(0.1)
    assert line.ok(2, GAP, 2, 0, 0).value == 20000
    t_last_to_2 = time.monotonic()
    # 400 ms of commands to module 1 only: they do not feed module 2's heartbeat.
    while time.monotonic() - t_last_to_2 < 0.4:
        assert line.ok(1, GAP, 3, 0, 0).value == 20000
        time.sleep(0.02)
    assert line.ok(2, GAP, 2, 0, 0).value == 0, "module 2's target speed"
    wait_until(lambda: line.ok(2, GAP, 3, 0, 0).value == 0, 2, what="module 2 at standstill")
    assert line.ok(1, GAP, 2, 0, 0).value == 20000
    assert line.ok(1, GAP, 3, 0, 0).value == 20000, "module 1's motor not affected"
    # Module 3 (no heartbeat) was never moved and answers as usual.
    assert line.ok(3, GAP, 3, 0, 0).value == 0
    line.ok(1, MST, 0, 0, 0)


def test_heartbeat_fed_by_commands_to_the_module(line):
    """Commands to module 2 every 50 ms keep its motor turning past many heartbeat times."""
    fast_ramp(line, 2)
    line.ok(2, SGP, 68, 0, 150)
    line.ok(2, ROR, 0, 0, 20000)
    t0 = time.monotonic()
    while time.monotonic() - t0 < 0.6:
        assert line.ok(2, GAP, 2, 0, 0).value == 20000
        time.sleep(0.05)
    line.ok(2, SGP, 68, 0, 0)
    line.ok(2, MST, 0, 0, 0)


def reply_delays(line: LinePort, address: int, count: int = 8) -> list[float]:
    """Time from the end of the write to the arrival of the reply's first byte, per request."""
    delays = []
    for _ in range(count):
        t0 = line.write(frame(address, GAP, 4, 0, 0))
        data, first, _ = line.read_timed(9, 2.0)
        assert len(data) == 9, data.hex(" ")
        assert RawReply(data).module == address
        delays.append(first - t0)
        time.sleep(0.01)
    return delays


def test_telegram_pause(line):
    line.ok(3, SGP, 75, 0, 20)
    paused = reply_delays(line, 3)
    prompt = reply_delays(line, 1)
    assert min(paused) >= 0.020, paused
    assert statistics.median(paused) < 0.020 + 0.010, paused
    assert max(paused) < 0.020 + 0.050, paused
    assert statistics.median(prompt) < 0.010, f"module 1 (no pause) {prompt}"
    line.ok(3, SGP, 75, 0, 0)
    assert statistics.median(reply_delays(line, 3)) < 0.010


def test_suppress_reply_on_one_module(line):
    conn = SerialTmclInterface(line.ser)
    line.ser.timeout = 5
    conn.send(TMCLCommand.SGP, 255, 0, 1, module_id=2, no_reply=True)
    line.silence(0.3)
    conn.send(TMCLCommand.SAP, 4, 0, 2222, module_id=2, no_reply=True)
    line.silence(0.3)
    assert conn.get_axis_parameter(4, 0, module_id=2) == 2222  # GAP is answered
    assert conn.get_global_parameter(255, 0, module_id=2) == 1  # GGP too
    assert conn.get_digital_input(0, module_id=2) in (0, 1)  # and GIO
    # The others answer everything.
    for a in (1, 3):
        assert conn.set_axis_parameter(4, 0, 1000 * a, module_id=a) == 1000 * a
        assert conn.get_axis_parameter(4, 0, module_id=a) == 1000 * a
        assert conn.get_global_parameter(255, 0, module_id=a) == 0
    conn.send(TMCLCommand.SGP, 255, 0, 0, module_id=2, no_reply=True)
    leftover = line.read_quiet(0.3)  # whether that SGP itself is answered is not specified
    assert leftover == b"" or RawReply(leftover).module == 2
    assert conn.set_axis_parameter(4, 0, 51200, module_id=2) == 51200
    line.ser.timeout = 0


# -- damaged frames and resynchronisation ----------------------------------------------------------

def test_wrong_checksum_to_one_module(line):
    values = set_distinct_values(line)
    bad = bytearray(frame(2, SAP, 4, 0, 9999))
    bad[8] = (bad[8] + 1) & 0xFF
    line.write(bytes(bad))
    reply = line.reply()
    assert reply.checksum_ok, reply
    assert (reply.host, reply.module, reply.status) == (HOST, 2, 1), reply
    line.silence(0.3)  # from module 2 only
    assert [line.ok(a, GAP, 4, 0, 0).value for a in ADDRESSES] == [values[1], values[2], values[3]]


def test_garbage_then_a_pause_resynchronises(line):
    values = set_distinct_values(line)
    # Partial frames for each module (the first bytes of a request), each followed by a pause longer than the resync time.
    for junk in (frame(1, GAP, 4, 0, 0)[:4], frame(2, SAP, 4, 0, 1)[:8], b"\x03", b"\xff\x00\x13\x37\x42"):
        line.write(junk)
        time.sleep(RESYNC_S)
        line.silence(0.05)
        for a in ADDRESSES:
            assert line.ok(a, GAP, 4, 0, 0).value == values[a]


def test_garbage_without_a_pause_shifts_the_frames(line):
    """Without the resync pause a stray byte joins the next frame, as on a real line: the frame is read
    from the stray byte on. Documented here; a host must pause after an error before it resends."""
    line.write(b"\x02" + frame(1, GAP, 4, 0, 0))  # 0x02 starts a 9-byte frame for address 2
    got = line.read_quiet(0.3)
    # Module 2 sees 02 01 06 04 00 00 00 00 00 (bad checksum): status 1 from module 2; the last byte of
    # the real frame is left over and dropped after the pause.
    assert len(got) == 9, got.hex(" ")
    reply = RawReply(got)
    assert (reply.module, reply.status) == (2, 1), reply
    time.sleep(RESYNC_S)
    assert line.ok(1, GAP, 4, 0, 0).value == 51200


# -- 138 events from several modules ---------------------------------------------------------------

@pytest.mark.parametrize("wire_timing", [False, True], ids=["pty", "wire-9600"])
def test_events_from_two_modules_whole_and_in_order(serve, wire_timing):
    server = serve("pty", modules=BUS_MODULES, extra=["--wire-timing"] if wire_timing else [])
    with LinePort(server.link) as line:
        events_in_order(line)


def events_in_order(line: LinePort):
    for a in (1, 3):
        fast_ramp(line, a)
        line.ok(a, 138, 1, 0, 1)
    line.ok(3, MVP, 0, 0, 150000)  # the longer move starts first and ends last
    line.ok(1, MVP, 0, 0, 20000)
    frames = []
    deadline = time.monotonic() + 10
    events = []
    # Meanwhile module 2 is polled: its replies and the events share the line back to the host.
    while len(events) < 2 and time.monotonic() < deadline:
        line.write(frame(2, GAP, 1, 0, 0))
        while True:
            f = RawReply(line.read_exact(9))
            frames.append(f)
            assert f.checksum_ok, f
            if f.status == 128:
                events.append(f)
                continue
            assert (f.module, f.status, f.opcode, f.value) == (2, 100, GAP, 0), f
            break
        time.sleep(0.01)
    assert [(e.host, e.module, e.opcode, e.value) for e in events] == [(HOST, 1, 138, 1), (HOST, 3, 138, 1)]
    assert line.ok(1, GAP, 1, 0, 0).value == 20000
    assert line.ok(3, GAP, 1, 0, 0).value == 150000
    line.silence(0.2)
    # Again with both moves ending together: two whole events, then nothing.
    line.ok(1, MVP, 0, 0, 0)
    line.ok(3, MVP, 0, 0, 130000)
    got = sorted(RawReply(line.read_exact(9)).module for _ in range(2))
    assert got == [1, 3]
    line.silence(0.2)


# -- wire timing (GP 65) ---------------------------------------------------------------------------

def round_trips(line: LinePort, address: int, count: int = 8) -> list[float]:
    times = []
    for _ in range(count):
        t0 = time.monotonic()
        line.write(frame(address, GAP, 4, 0, 0))
        reply = line.reply(2.0)
        times.append(time.monotonic() - t0)
        assert reply.module == address and reply.status == 100, reply
    return times


def test_wire_timing_9600(serve):
    server = serve("pty", modules=BUS_MODULES, extra=["--wire-timing"])
    with LinePort(server.link) as line:
        for a in ADDRESSES:
            times = round_trips(line, a)
            assert min(times) >= 18 * BYTE_9600 * 0.99, times  # 9 bytes in, 9 bytes out: 18.75 ms
            assert statistics.median(times) < 0.040, times


def test_wire_timing_follows_gp65_after_a_restart(serve):
    server = serve("pty", modules=BUS_MODULES, extra=["--wire-timing"])
    with LinePort(server.link) as line:
        line.ok(1, SGP, 65, 0, 7)  # 115200 baud: stored, but in force only after a restart (§5.1)
        assert line.ok(1, GGP, 65, 0, 0).value == 7
        assert min(round_trips(line, 1, 4)) >= 18 * BYTE_9600 * 0.99
        line.write(frame(1, 255, 0, 0, 1234))  # software reset
        reply = line.reply()
        assert (reply.module, reply.status, reply.opcode) == (1, 100, 255), reply
        line.silence(0.1)
        fast = round_trips(line, 1, 16)
        slow = round_trips(line, 2, 4)
        assert min(fast) >= 18 * BYTE_115200 * 0.99, fast  # 1.56 ms
        assert statistics.median(fast) < 0.008, fast
        assert min(slow) >= 18 * BYTE_9600 * 0.99, f"module 2 still at 9600: {slow}"
        assert statistics.median(fast) * 3 < statistics.median(slow), (fast, slow)
        line.ok(1, SGP, 65, 0, 0)


def test_wire_timing_two_replies_share_the_line(serve):
    """Two modules at one secondary address: their replies go out one after the other, whole, so the
    second ends 9 byte times after the first (27 byte times after the request was written)."""
    server = serve("pty", modules=BUS_MODULES, extra=["--wire-timing"])
    with LinePort(server.link) as line:
        line.ok(2, SGP, 87, 0, 10)
        line.ok(3, SGP, 87, 0, 10)
        t0 = line.write(frame(10, GAP, 4, 0, 0))
        first, _, t_first = line.read_timed(9, 2)
        second, _, t_second = line.read_timed(9, 2)
        assert sorted([RawReply(first).module, RawReply(second).module]) == [2, 3]
        assert RawReply(first).checksum_ok and RawReply(second).checksum_ok
        assert t_first - t0 >= 18 * BYTE_9600 * 0.99, t_first - t0
        assert t_second - t0 >= 27 * BYTE_9600 * 0.99, t_second - t0
        assert t_second - t0 < 27 * BYTE_9600 + 0.020, t_second - t0
        line.silence(0.1)


def test_without_wire_timing_the_line_is_fast(line):
    line.ok(1, SGP, 65, 0, 0)  # 9600 baud configured: no effect on the pty's speed
    assert statistics.median(round_trips(line, 1, 16)) < 0.010  # 9600 baud would be 18.75 ms


# -- tmcl host commands per address ----------------------------------------------------------------

def tmcl(tmcl_bin, *args, timeout=30):
    # --shared: these tests keep a raw line open beside `tmcl` on purpose.
    return subprocess.run([str(tmcl_bin), "--shared", *args], capture_output=True, text=True, timeout=timeout,
                          stdin=subprocess.DEVNULL)


def scan(tmcl_bin, server, first: int, last: int) -> list[int]:
    r = tmcl(tmcl_bin, "--port", str(server.link), "scan", "--first", str(first), "--last", str(last),
             "--wait", "40")
    assert r.returncode == 0, (r.stdout, r.stderr)
    lines = r.stdout.splitlines()
    found = []
    for text in lines[:-1]:
        address, version = text.split()
        assert version == "1021V142", text
        found.append(int(address))
    assert lines[-1] == f"{len(found)} module(s) found", r.stdout
    return found


def test_scan_lists_the_three_modules(bus_server, tmcl_bin):
    assert scan(tmcl_bin, bus_server, 1, 32) == [1, 2, 3]
    r = tmcl(tmcl_bin, "--port", str(bus_server.link), "scan", "--first", "1", "--last", "5")
    assert r.stdout.splitlines()[:3] == ["  1  1021V142", "  2  1021V142", "  3  1021V142"], r.stdout


def test_host_commands_per_address(bus_server, tmcl_bin):
    link = str(bus_server.link)
    for a in ADDRESSES:
        r = tmcl(tmcl_bin, "--port", link, "--address", str(a), "set", "ap", "4", str(1000 * a))
        assert r.returncode == 0, r.stderr
    for a in ADDRESSES:
        r = tmcl(tmcl_bin, "--port", link, "--address", str(a), "get", "ap", "4")
        assert (r.returncode, r.stdout.strip()) == (0, f"ap 4 = {1000 * a}"), r.stderr
        r = tmcl(tmcl_bin, "--port", link, "--address", str(a), "get", "gp", "66")
        assert r.stdout.strip() == f"gp 66 = {a}", r.stdout
    r = tmcl(tmcl_bin, "--port", link, "--address", "9", "--timeout", "0.3", "get", "ap", "4")
    assert r.returncode == 3, (r.stdout, r.stderr)

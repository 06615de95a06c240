"""Raw frames on the pty with pyserial: events, checksums, addressing, reply suppression, 137/255/242."""

import time

import pytest
import serial
from pytrinamic.connections import SerialTmclInterface
from pytrinamic.tmcl import TMCLCommand

from tmcltest import RawReply, frame

HOST, MODULE = 2, 1
GAP, SAP, SGP, GGP, STGP, STAP, MVP, GIO, SIO = 6, 5, 9, 10, 11, 7, 4, 15, 14


class RawPort:
    def __init__(self, link):
        self.ser = serial.Serial(str(link), 115200, timeout=5)

    def close(self):
        self.ser.close()

    def write(self, data: bytes):
        self.ser.write(data)
        self.ser.flush()

    def read_reply(self, timeout: float = 5.0) -> RawReply:
        self.ser.timeout = timeout
        data = self.ser.read(9)
        self.ser.timeout = 5
        assert len(data) == 9, f"expected a 9-byte reply within {timeout} s, got {data.hex(' ') or 'nothing'}"
        return RawReply(data)

    def request(self, opcode, kind, motor, value, address=MODULE) -> RawReply:
        self.write(frame(address, opcode, kind, motor, value))
        return self.read_reply()

    def ok(self, opcode, kind, motor, value) -> RawReply:
        reply = self.request(opcode, kind, motor, value)
        assert reply.checksum_ok, reply
        assert (reply.host, reply.module, reply.status, reply.opcode) == (HOST, MODULE, 100, opcode), reply
        return reply

    def expect_silence(self, seconds: float = 0.4):
        self.ser.timeout = seconds
        data = self.ser.read(9)
        self.ser.timeout = 5
        assert data == b"", f"expected no bytes within {seconds} s, got {data.hex(' ')}"


@pytest.fixture
def port(pty_server):
    p = RawPort(pty_server.link)
    try:
        yield p
    finally:
        p.close()


def fast_ramp(port):
    port.ok(SAP, 4, 0, 512000)
    port.ok(SAP, 5, 0, 2048000)


def assert_event(reply: RawReply):
    assert reply.checksum_ok, reply
    assert (reply.host, reply.module, reply.status, reply.opcode, reply.value) == (HOST, MODULE, 128, 138, 1), reply


def test_reply_layout(port):
    reply = port.ok(GAP, 4, 0, 0)
    assert reply.data == bytes([2, 1, 100, 6, 0, 0, 0xC8, 0x00, (2 + 1 + 100 + 6 + 0xC8) & 0xFF])


def test_target_reached_event_every_mvp(port):
    reply = port.ok(138, 1, 0, 1)
    assert reply.value == 1
    fast_ramp(port)
    port.ok(MVP, 0, 0, 100000)
    t0 = time.monotonic()
    assert_event(port.read_reply(timeout=5))
    assert time.monotonic() - t0 > 0.05  # the event comes when the motor arrives, not with the reply
    assert port.ok(GAP, 1, 0, 0).value == 100000
    assert port.ok(GAP, 8, 0, 0).value == 1
    # Type 1: again for the next MVP, and the one after.
    port.ok(MVP, 1, 0, -30000)
    assert_event(port.read_reply(timeout=5))
    assert port.ok(GAP, 1, 0, 0).value == 70000
    port.ok(MVP, 0, 0, 0)
    assert_event(port.read_reply(timeout=5))
    port.expect_silence(0.3)


def test_target_reached_event_next_mvp_only(port):
    port.ok(138, 0, 0, 1)
    fast_ramp(port)
    port.ok(MVP, 0, 0, 50000)
    assert_event(port.read_reply(timeout=5))
    # Type 0: the next MVP gets no event.
    port.ok(MVP, 0, 0, 0)
    deadline = time.monotonic() + 5
    while port.ok(GAP, 8, 0, 0).value != 1:
        assert time.monotonic() < deadline, "MVP did not finish"
        time.sleep(0.02)
    port.expect_silence(0.5)


def test_wrong_checksum_gets_status_1(port):
    bad = bytearray(frame(MODULE, GAP, 4, 0, 0))
    bad[8] = (bad[8] + 1) & 0xFF
    port.write(bytes(bad))
    reply = port.read_reply()
    assert reply.checksum_ok, reply
    assert (reply.host, reply.module, reply.status) == (HOST, MODULE, 1), reply
    # The stream stays aligned.
    assert port.ok(GAP, 4, 0, 0).value == 51200


def test_other_address_gets_no_reply(port):
    port.write(frame(5, GAP, 4, 0, 0))
    port.expect_silence(0.5)
    # Not even a bad-checksum frame for another address is answered.
    bad = bytearray(frame(5, GAP, 4, 0, 0))
    bad[8] ^= 0x55
    port.write(bytes(bad))
    port.expect_silence(0.5)
    assert port.ok(GAP, 4, 0, 0).value == 51200


def test_two_frames_in_one_write(port):
    port.write(frame(MODULE, SAP, 4, 0, 4321) + frame(MODULE, GAP, 4, 0, 0))
    first, second = port.read_reply(), port.read_reply()
    assert (first.status, first.opcode) == (100, SAP), first
    assert (second.status, second.opcode, second.value) == (100, GAP, 4321), second


def test_invalid_command_is_status_2(port):
    for opcode in (200, 157, 50):
        reply = port.request(opcode, 0, 0, 0)
        assert reply.checksum_ok, reply
        assert (reply.status, reply.opcode) == (2, opcode), reply


def test_version_binary(port):
    reply = port.ok(136, 1, 0, 0)
    assert reply.value & 0xFFFF == 0x012A  # major 1, minor 42
    port.write(frame(MODULE, 136, 0, 0, 0))
    raw = port.ser.read(9)
    assert raw == bytes([HOST]) + b"1021V142"


def test_suppress_reply_mode(port):
    conn = SerialTmclInterface(port.ser)  # pytrinamic on the already opened port
    conn.send(TMCLCommand.SGP, 255, 0, 1, no_reply=True)
    port.expect_silence()
    conn.send(TMCLCommand.SAP, 4, 0, 1234, no_reply=True)
    port.expect_silence()
    conn.send(TMCLCommand.SGP, 3, 2, -3, no_reply=True)
    port.expect_silence()
    conn.send(TMCLCommand.SIO, 0, 2, 1, no_reply=True)
    port.expect_silence()
    # GAP, GGP and GIO still answer.
    assert conn.get_axis_parameter(4, 0) == 1234
    assert conn.get_global_parameter(255, 0) == 1
    assert conn.get_global_parameter(3, 2, signed=True) == -3
    assert conn.get_digital_output(0) == 1
    conn.send(TMCLCommand.MVP, 1, 0, 500, no_reply=True)
    port.expect_silence()
    deadline = time.monotonic() + 5
    while conn.get_axis_parameter(8, 0) != 1:
        assert time.monotonic() < deadline
        time.sleep(0.02)
    assert conn.get_axis_parameter(1, 0) == 500
    # Errors are suppressed too (SAP out of range), the value is unchanged.
    conn.send(TMCLCommand.SAP, 140, 0, 99, no_reply=True)
    port.expect_silence()
    assert conn.get_axis_parameter(140, 0) == 8
    # Switching it off: whether that very SGP is answered is not specified; drain at most one reply.
    conn.send(TMCLCommand.SGP, 255, 0, 0, no_reply=True)
    port.ser.timeout = 0.5
    leftover = port.ser.read(9)
    port.ser.timeout = 5
    if leftover:
        reply = RawReply(leftover)
        assert (reply.status, reply.opcode) == (100, SGP), reply
    conn.set_axis_parameter(4, 0, 2000)  # answered again
    assert conn.get_axis_parameter(4, 0) == 2000


def test_factory_defaults_137(port):
    port.ok(SAP, 4, 0, 999)
    port.ok(STAP, 4, 0, 0)
    port.ok(SGP, 3, 2, 5)
    port.ok(STGP, 3, 2, 0)
    port.ok(SAP, 5, 0, 1000)
    # Without the key: refused, nothing happens.
    reply = port.request(137, 0, 0, 1)
    assert reply.checksum_ok and reply.status == 4 and reply.opcode == 137, reply
    assert port.ok(GAP, 4, 0, 0).value == 999
    # With the key: no reply, factory settings.
    port.write(frame(MODULE, 137, 0, 0, 1234))
    port.expect_silence(0.5)
    assert port.ok(GAP, 4, 0, 0).value == 51200
    assert port.ok(GAP, 5, 0, 0).value == 51200
    assert port.ok(GGP, 3, 2, 0).value == 0
    port.ok(8, 4, 0, 0)  # RSAP 4: the EEPROM holds the default too
    assert port.ok(GAP, 4, 0, 0).value == 51200


def test_software_reset_255(port):
    fast_ramp(port)
    port.ok(SAP, 4, 0, 256000)
    port.ok(STAP, 4, 0, 0)
    port.ok(SGP, 4, 2, 44)
    port.ok(STGP, 4, 2, 0)
    port.ok(SGP, 5, 2, 55)  # not stored
    port.ok(SIO, 1, 2, 1)
    port.ok(MVP, 0, 0, 20000)
    deadline = time.monotonic() + 5
    while port.ok(GAP, 8, 0, 0).value != 1:
        assert time.monotonic() < deadline
        time.sleep(0.02)
    assert port.ok(GAP, 1, 0, 0).value == 20000
    reply = port.request(255, 0, 0, 1234)
    assert reply.checksum_ok, reply
    assert (reply.status, reply.opcode) == (100, 255), reply
    # Restarted from the EEPROM: counters and unstored values back to defaults, stored values kept.
    assert port.ok(GAP, 1, 0, 0).value == 0
    assert port.ok(GAP, 5, 0, 0).value == 51200
    assert port.ok(GAP, 4, 0, 0).value == 256000
    assert port.ok(GGP, 4, 2, 0).value == 44
    assert port.ok(GGP, 5, 2, 0).value == 0
    assert port.ok(GIO, 1, 2, 0).value == 0
    assert port.ok(GGP, 255, 0, 0).value == 0


def test_boot_242_gets_no_reply(port):
    conn = SerialTmclInterface(port.ser)
    conn.send_boot()
    port.expect_silence(0.5)
    assert conn.get_axis_parameter(4, 0) == 51200

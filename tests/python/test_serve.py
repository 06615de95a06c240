"""`tmcl serve` itself: ready line, stale links, signals, hosts that vanish."""

import os
import signal
import time

import serial

from tmcltest import RawReply, Server, frame, pytrinamic_connection


def test_ready_line_pty(pty_server):
    assert pty_server.ready_line == f"serving PD28-1021 at address 1 on {pty_server.link}"
    target = os.readlink(pty_server.link)
    assert target.startswith("/dev/pts/"), target


def test_stale_link_is_replaced(serve, tmp_path):
    link = tmp_path / "stale-link"
    os.symlink(tmp_path / "no-such-pty", link)  # dangling, as left by a crash
    server = serve("pty", link_name=link.name)
    assert os.readlink(link).startswith("/dev/pts/")
    with pytrinamic_connection(server) as conn:
        assert conn.get_version_string() == "1021V142"


def test_sigint_exits_cleanly(tmcl_bin, tmp_path):
    server = Server(tmcl_bin, tmp_path, "pty").start()
    try:
        with pytrinamic_connection(server) as conn:
            conn.set_axis_parameter(4, 0, 1000)
        rc = server.stop(signal.SIGINT)
        assert rc == 0, server.stderr()
        assert not os.path.lexists(server.link)
    finally:
        server.kill()


def test_sigterm_while_moving_and_connected(tmcl_bin, tmp_path):
    server = Server(tmcl_bin, tmp_path, "pty", eeprom=tmp_path / "e.bin").start()
    try:
        with pytrinamic_connection(server) as conn:
            conn.rotate(0, 51200)
            server.terminate_checked()
    finally:
        server.kill()


def test_host_vanishing_mid_request(pty_server):
    """A host that sends a request and closes before the reply, or leaves half a frame, does not disturb
    the next host."""
    for _ in range(5):
        with serial.Serial(str(pty_server.link), 115200, timeout=2) as ser:
            ser.write(frame(1, 5, 4, 0, 4242))  # SAP 4; the reply is never read
        with serial.Serial(str(pty_server.link), 115200, timeout=2) as ser:
            ser.write(frame(1, 6, 4, 0, 0)[:4])  # half a frame, then gone
        # The module drops a partial frame after a 5 ms gap (RS485 inter-byte timeout); a pty does not tell it
        # when a host closes, so the next host must not start within those 5 ms.
        time.sleep(0.1)
    with pytrinamic_connection(pty_server) as conn:
        assert conn.get_axis_parameter(4, 0) == 4242
        assert conn.get_version_string() == "1021V142"


def test_module_address_change(pty_server):
    with serial.Serial(str(pty_server.link), 115200, timeout=2) as ser:
        ser.write(frame(1, 9, 66, 0, 5))  # SGP 66 = 5
        reply = RawReply(ser.read(9))
        assert reply.checksum_ok and reply.status == 100, reply
        ser.write(frame(1, 6, 4, 0, 0))
        ser.timeout = 0.4
        assert ser.read(9) == b"", "old address still answered"
        ser.timeout = 2
        ser.write(frame(5, 6, 4, 0, 0))
        reply = RawReply(ser.read(9))
        assert reply.checksum_ok and (reply.host, reply.module, reply.status, reply.value) == (2, 5, 100, 51200), reply
        ser.write(frame(5, 9, 66, 0, 1))
        reply = RawReply(ser.read(9))
        assert reply.checksum_ok and reply.status == 100, reply
    with pytrinamic_connection(pty_server) as conn:
        assert conn.get_global_parameter(66, 0) == 1


def test_serve_address_option(serve):
    server = serve("pty", extra=["--address", "7"], expect_address=7)
    assert server.ready_line == f"serving PD28-1021 at address 7 on {server.link}"
    with pytrinamic_connection(server) as conn:  # --module-id 7
        assert conn.get_global_parameter(66, 0) == 7
        assert conn.get_axis_parameter(4, 0) == 51200
    with serial.Serial(str(server.link), 115200, timeout=0.4) as ser:
        ser.write(frame(1, 6, 4, 0, 0))
        assert ser.read(9) == b"", "address 1 answered although the module is at 7"


def test_address_change_persists_with_eeprom(serve, tmp_path):
    """GP 66 is stored automatically (bank 0, 65..90): after a restart the module is at the new address."""
    server = serve("pty", eeprom=tmp_path / "e.bin")
    with pytrinamic_connection(server) as conn:
        conn.send(9, 66, 0, 3)  # SGP 66 = 3; answered (from the new or the old address, either is fine)
    server.expect_address = 3
    server.restart()
    with pytrinamic_connection(server) as conn:  # --module-id 3
        assert conn.get_global_parameter(66, 0) == 3
        conn.send(9, 66, 0, 1)
    server.expect_address = 1
    server.restart()
    with pytrinamic_connection(server) as conn:
        assert conn.get_global_parameter(66, 0) == 1


def test_event_while_no_host_is_lost(pty_server):
    """A target-reached event that fires while no host has the port open is not delivered to the next host
    (pyserial flushes on open); the next host's replies stay aligned."""
    with serial.Serial(str(pty_server.link), 115200, timeout=2) as ser:
        for f in (frame(1, 5, 4, 0, 512000), frame(1, 5, 5, 0, 2048000), frame(1, 138, 0, 0, 1),
                  frame(1, 4, 0, 0, 20000)):
            ser.write(f)
            reply = RawReply(ser.read(9))
            assert reply.status == 100, reply
    time.sleep(0.5)  # the move (about 0.2 s) ends while the port is closed
    with pytrinamic_connection(pty_server) as conn:
        assert conn.get_axis_parameter(1, 0) == 20000
        assert conn.get_axis_parameter(8, 0) == 1
        assert conn.get_version_string() == "1021V142"


def test_verbose_logs_requests_to_stderr(serve):
    server = serve("pty", extra=["-v"])
    with pytrinamic_connection(server) as conn:
        conn.set_axis_parameter(4, 0, 1234)
        assert conn.get_axis_parameter(4, 0) == 1234
    deadline = time.monotonic() + 5
    while not server.stderr().strip():
        assert time.monotonic() < deadline, "nothing logged with -v"
        time.sleep(0.05)
    # stdout carries only the ready line: the log must not go there.
    assert server._lines.empty()

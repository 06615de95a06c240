"""Modules served on a pty and on TCP from the Python process: pytrinamic and pyserial as hosts, a bus of
two models, EEPROM across a restart, links cleaned up."""

import os
import struct

import pytest

import opentmcl
from opentmcl.pytest_plugin import pytrinamic_args, pytrinamic_connection

serial = pytest.importorskip("serial")
pytest.importorskip("pytrinamic")


def frame(address, opcode, kind, motor, value):
    body = struct.pack(">BBBBi", address, opcode, kind, motor, value)
    return body + bytes([sum(body) & 0xFF])


def test_pty_link_with_pyserial_and_direct_access_together():
    with opentmcl.Module(link=True) as module:
        assert module.link and os.path.islink(module.link) and module.tcp_address is None
        with serial.Serial(str(module.link), 9600, timeout=5) as port:
            port.write(frame(1, 5, 4, 0, 1234))  # SAP 4, 0, 1234 over the link
            reply = port.read(9)
            assert reply[2] == 100 and reply[3] == 5
        # ... and read back directly, from the same module.
        assert module.get("MaxPositioningSpeed") == 1234
        link = module.link
    assert not os.path.lexists(link)  # removed on close


def test_tcp_with_pytrinamic():
    from pytrinamic.modules import TMCM1021

    with opentmcl.Module(tcp=True) as module:
        host, port = module.tcp_address.rsplit(":", 1)
        assert host == "127.0.0.1" and int(port) > 0
        assert "socket_serial_tmcl" in pytrinamic_args(module)
        connection = pytrinamic_connection(module)
        try:
            motor = TMCM1021(connection).motors[0]
            motor.set_axis_parameter(motor.AP.MaxVelocity, 2000)
            assert motor.get_axis_parameter(motor.AP.MaxVelocity) == 2000
        finally:
            connection.close()
        assert module.get("MaxPositioningSpeed") == 2000


def test_bus_of_two_models():
    first, second = opentmcl.Module.bus(["pd28-1021", {"model": "pd-113", "address": 2}])
    try:
        assert first.link == second.link
        assert (first.address, second.address) == (1, 2)
        with serial.Serial(str(first.link), 9600, timeout=5) as port:
            for address, model in ((1, "1021"), (2, "113")):
                port.write(frame(address, 136, 1, 0, 0))  # firmware version, binary (§3.7.38)
                reply = port.read(9)
                assert reply[1] == address and reply[2] == 100
            first.set("MaxPositioningSpeed", 999)
            port.write(frame(1, 6, 4, 0, 0))
            assert struct.unpack(">i", port.read(9)[4:8])[0] == 999
        # Closing one keeps the line up for the other; the last one stops it.
        first.close()
        assert os.path.islink(second.link)
        assert second.request("GAP", 4, 0).ok
    finally:
        first.close()
        second.close()
    assert not os.path.lexists(second.link)


def test_usb_modules_on_an_rs485_bus():
    """The TMCM-1140, -3110 and -6110 are USB first (a USB port answers every address, one module per
    link); `interface="rs485"` puts them on one RS485 line, each answering its own address, every axis."""
    with pytest.raises(RuntimeError, match="one module per link"):
        opentmcl.Module.bus(["tmcm-3110", "tmcm-6110"])
    with pytest.raises(ValueError, match="cannot be served on"):
        opentmcl.Module.bus(["pd28-1021"], interface="usb")
    modules = opentmcl.Module.bus(["tmcm-3110", "tmcm-6110", {"model": "tmcm-1140", "address": 7}],
                                  interface="rs485")
    try:
        with serial.Serial(str(modules[0].link), 9600, timeout=5) as port:
            for address, number in ((1, 3110), (2, 6110), (7, 1140)):
                port.write(frame(address, 136, 1, 0, 0))
                reply = port.read(9)
                assert reply[1] == address and struct.unpack(">i", reply[4:8])[0] >> 16 == number
            port.write(frame(2, 5, 4, 5, 321))  # SAP 4 of motor 5 of the TMCM-6110
            assert port.read(9)[2] == 100
            port.write(frame(5, 6, 4, 0, 0))  # nobody at 5
            assert port.read(9) == b""
        assert modules[1].get("MaxVelocity", motor=5) == 321
        assert modules[1].get("MaxVelocity", motor=4) == 1000
    finally:
        for module in modules:
            module.close()


def test_eeprom_across_a_restart_of_a_served_module(tmp_path):
    eeprom = tmp_path / "m.eeprom"
    with opentmcl.Module(eeprom=eeprom, link=True) as module:
        with serial.Serial(str(module.link), 9600, timeout=5) as port:
            port.write(frame(1, 5, 4, 0, 4321))  # SAP
            port.read(9)
            port.write(frame(1, 7, 4, 0, 0))  # STAP: into the EEPROM
            assert port.read(9)[2] == 100
    with opentmcl.Module(eeprom=eeprom, tcp=True) as module:
        assert module.get("MaxPositioningSpeed") == 4321


def test_a_pty_and_tcp_at_once_each_host_gets_its_own_replies():
    from pytrinamic.connections import ConnectionManager
    from pytrinamic.modules import TMCM1021

    with opentmcl.Module(link=True, tcp=True) as module:
        assert module.link and os.path.islink(module.link)
        host, port = module.tcp_address.rsplit(":", 1)
        assert host == "127.0.0.1" and int(port) > 0
        assert "serial_tmcl" in pytrinamic_args(module)  # the plugin's helper takes the pty
        module.set("MaxPositioningSpeed", 1234)
        module.set("MaxAcceleration", 777)
        connection = ConnectionManager(f"--interface socket_serial_tmcl --port {module.tcp_address}").connect()
        connection._socket.settimeout(10.0)
        try:
            motor = TMCM1021(connection).motors[0]
            with serial.Serial(str(module.link), 9600, timeout=5) as pty:
                for _ in range(20):
                    # A request on the pty, one on TCP before its reply is read: each reply goes back
                    # on the link its request came in on.
                    pty.write(frame(1, 6, 4, 0, 0))  # GAP 4 (maximum positioning speed)
                    assert motor.get_axis_parameter(motor.AP.MaxAcceleration) == 777
                    reply = pty.read(9)
                    assert reply[2:4] == bytes([100, 6]) and struct.unpack(">i", reply[4:8])[0] == 1234
                assert pty.in_waiting == 0, "no reply of the TCP host on the pty"
        finally:
            connection.close()


def test_a_bus_on_a_pty_and_tcp_at_once():
    import socket

    first, second = opentmcl.Module.bus(["pd28-1021", "pd28-1021"], link=True, tcp=True)
    with first, second:
        assert first.link == second.link and first.tcp_address == second.tcp_address
        second.set("MaxPositioningSpeed", 4321)
        host, port = first.tcp_address.rsplit(":", 1)
        with socket.create_connection((host, int(port)), timeout=10) as tcp, serial.Serial(
            str(first.link), 9600, timeout=5
        ) as pty:
            pty.write(frame(2, 6, 4, 0, 0))  # GAP 4 of module 2 on the pty
            tcp.sendall(frame(1, 6, 4, 0, 0))  # GAP 4 of module 1 over TCP
            reply = pty.read(9)
            assert reply[:4] == bytes([2, 2, 100, 6]) and struct.unpack(">i", reply[4:8])[0] == 4321
            reply = b""
            while len(reply) < 9:
                reply += tcp.recv(9 - len(reply))
            assert reply[:4] == bytes([2, 1, 100, 6]) and struct.unpack(">i", reply[4:8])[0] == 51200


def test_wire_timing_takes_one_link():
    with pytest.raises(ValueError, match="one link"):
        opentmcl.Module(link=True, tcp=True, wire_timing=True)

"""pytrinamic over TCP: `--interface socket_serial_tmcl --port 127.0.0.1:PORT`."""

import socket

import pytest
from pytrinamic.tmcl import TMCLReplyStatusError

from tmcltest import RawReply, frame, pytrinamic_connection, wait_until


def test_ready_line_names_the_real_port(tcp_server):
    assert tcp_server.ready_line == f"serving PD28-1021 at address 1 on 127.0.0.1:{tcp_server.port}"


def test_pytrinamic_calls(tcp_server):
    with pytrinamic_connection(tcp_server) as conn:
        assert conn.get_version_string() == "1021V142"
        assert conn.get_axis_parameter(4, 0) == 51200
        conn.set_axis_parameter(4, 0, 300000)
        conn.set_axis_parameter(5, 0, 1000000)
        assert conn.get_axis_parameter(4, 0) == 300000
        conn.set_global_parameter(10, 2, -10)
        assert conn.get_global_parameter(10, 2, signed=True) == -10
        with pytest.raises(TMCLReplyStatusError) as err:
            conn.set_axis_parameter(140, 0, 9)
        assert err.value.status_code == 4
        conn.move_to(0, 60000)
        wait_until(lambda: conn.get_axis_parameter(8, 0) == 1, 5, what="position reached")
        assert conn.get_axis_parameter(1, 0, signed=True) == 60000


def test_connections_one_after_another(tcp_server):
    with pytrinamic_connection(tcp_server) as conn:
        conn.set_axis_parameter(4, 0, 98765)
        conn.set_global_parameter(0, 2, 4711)
    # A new TCP connection talks to the same module: its state is kept.
    with pytrinamic_connection(tcp_server) as conn:
        assert conn.get_axis_parameter(4, 0) == 98765
        assert conn.get_global_parameter(0, 2) == 4711
        assert conn.get_version_string() == "1021V142"
    for i in range(5):
        with pytrinamic_connection(tcp_server) as conn:
            conn.set_global_parameter(1, 2, i)
            assert conn.get_global_parameter(1, 2) == i


def test_raw_socket_frames_split(tcp_server):
    """Frames may arrive in pieces (TCP has no message boundaries)."""
    with socket.create_connection(("127.0.0.1", tcp_server.port), timeout=5) as sock:
        request = frame(1, 6, 4, 0, 0)  # GAP 4
        for piece in (request[:3], request[3:7], request[7:]):
            sock.sendall(piece)
        reply = RawReply(recv_exact(sock, 9))
        assert reply.checksum_ok and reply.status == 100 and reply.value == 51200
        # Two frames in one segment: two replies.
        sock.sendall(frame(1, 5, 4, 0, 777) + frame(1, 6, 4, 0, 0))
        first, second = RawReply(recv_exact(sock, 9)), RawReply(recv_exact(sock, 9))
        assert (first.status, first.opcode) == (100, 5), first
        assert (second.status, second.opcode, second.value) == (100, 6, 777), second


def test_partial_frame_does_not_leak_into_next_connection(tcp_server):
    request = frame(1, 6, 140, 0, 0)  # GAP 140
    first = socket.create_connection(("127.0.0.1", tcp_server.port), timeout=5)
    first.sendall(request[:5])  # abandoned half frame
    first.close()
    # The next client's frame is read from its first byte, not as the rest of the abandoned one.
    with socket.create_connection(("127.0.0.1", tcp_server.port), timeout=5) as second:
        second.sendall(request)
        reply = RawReply(recv_exact(second, 9))
        assert reply.checksum_ok and (reply.status, reply.opcode, reply.value) == (100, 6, 8), reply


def recv_exact(sock, n):
    data = b""
    while len(data) < n:
        chunk = sock.recv(n - len(data))
        if not chunk:
            break
        data += chunk
    return data

"""No frame lost, bus set-up (issue 20 items 4 and 5), against `tmcl serve` (and the firmware image under
QEMU with `--target qemu`, where the tests about `tmcl serve` itself are skipped): a pty or a TCP socket is a
buffer, not a wire, so a backlog of complete frames in one write is answered in order, one reply per frame
(also with a telegram pause, and ASCII lines in ASCII mode); a frame written in slow pieces is answered;
two modules at one address are refused before anything is served."""

from __future__ import annotations

import select
import socket
import subprocess
import time

import serial

from tmcltest import RawReply, frame

SGP, GGP, ENTER_ASCII = 9, 10, 139

# Under `--target qemu`: the image's UART holds bytes in its FIFO while its receive ring is full, and QEMU
# then waits to deliver more, so a backlog is answered whole. The emulated clock runs with the instructions
# (`--icount`): on a loaded host QEMU may not run for longer than the 5 ms inter-byte timeout in the middle
# of a frame, which on a real line would be a sender that stopped mid-frame (docs/decisions.md).
QEMU_ICOUNT = True


def pairs(n: int) -> tuple[bytes, list[int]]:
    """`SGP k, 2, v` then `GGP k, 2` n times: the GGP replies carry v only when every reply answers its
    own request, in order."""
    data, values = b"", []
    for k in range(n):
        var, value = k % 50, 100_000 + k
        data += frame(1, SGP, var, 2, value) + frame(1, GGP, var, 2, 0)
        values += [value, value]
    return data, values


def read_exactly(read, count: int, timeout_s: float = 20.0) -> bytes:
    got = b""
    deadline = time.monotonic() + timeout_s
    while len(got) < count and time.monotonic() < deadline:
        got += read(count - len(got))
    return got


def check_replies(data: bytes, values: list[int]) -> None:
    replies = [RawReply(data[i:i + 9]) for i in range(0, len(data), 9)]
    assert len(replies) == len(values)
    assert all(r.checksum_ok and r.status == 100 for r in replies), [r for r in replies if r.status != 100][:3]
    assert [r.value for r in replies] == values


def pty_reader(port: serial.Serial):
    def read(n: int) -> bytes:
        select.select([port.fileno()], [], [], 0.5)
        return port.read(n)
    return read


def test_a_thousand_frames_in_one_write_on_a_pty(pty_server):
    data, values = pairs(500)
    with serial.Serial(str(pty_server.link), 115200, timeout=0) as port:
        port.write(data)  # 9 000 bytes, one write
        got = read_exactly(pty_reader(port), 9 * len(values))
        time.sleep(0.2)
        assert port.read(100) == b"", "nothing more than one reply per frame"
    check_replies(got, values)


def test_a_thousand_frames_in_one_write_on_tcp(tcp_server):
    data, values = pairs(600)
    with socket.create_connection((tcp_server.host, tcp_server.port), timeout=10) as sock:
        sock.sendall(data)
        got = read_exactly(lambda n: sock.recv(n), 9 * len(values))
    check_replies(got, values)


def test_a_backlog_with_a_telegram_pause_is_answered_in_turn(pty_server):
    with serial.Serial(str(pty_server.link), 115200, timeout=0) as port:
        port.write(frame(1, 9, 75, 0, 3))  # SGP 75: a 3 ms telegram pause (§5.1)
        assert RawReply(read_exactly(pty_reader(port), 9)).status == 100
        data, values = pairs(100)
        started = time.monotonic()
        port.write(data)
        got = read_exactly(pty_reader(port), 9 * len(values))
        took = time.monotonic() - started
    check_replies(got, values)
    # Under QEMU with --icount the pauses pass in emulated time, which runs ahead of the wall clock while
    # the firmware sleeps; there the replies, whole and in order, are what is checked.
    if not getattr(pty_server, "icount", False):
        assert took >= 200 * 0.003, "each reply waited for its pause"


def test_interleaved_ascii_lines_in_one_write(pty_server):
    with serial.Serial(str(pty_server.link), 115200, timeout=0) as port:
        port.write(frame(1, ENTER_ASCII, 0, 0, 0))
        assert RawReply(read_exactly(pty_reader(port), 9)).status == 100
        lines = [f"ASGP {k % 50}, 2, {k}\r" if k % 2 == 0 else f"AGGP {(k - 1) % 50}, 2\r" for k in range(400)]
        expected = "".join(f"{line}BA 100 {k - k % 2}\r" for k, line in enumerate(lines))
        port.write("".join(lines).encode())
        got = read_exactly(pty_reader(port), len(expected)).decode()
        port.write(b"ABIN\r")
    assert got == expected


def test_a_frame_in_slow_pieces_is_answered(pty_server):
    request = frame(1, 6, 4, 0, 0)
    with serial.Serial(str(pty_server.link), 115200, timeout=0) as port:
        for k in range(0, 9, 3):
            port.write(request[k:k + 3])
            time.sleep(0.02)  # 20 ms between pieces (a serial line drops after 5 ms): a buffer, not a wire
        reply = RawReply(read_exactly(pty_reader(port), 9))
    assert reply.status == 100 and reply.value == 51200


def test_two_modules_at_one_address_are_refused(tmcl_bin, tmp_path):
    for modules in (["pd28-1021@1", "pd28-1021@1"], ["pd28-1021@2", "pd28-1021"]):
        args = [str(tmcl_bin), "serve", "--pty", str(tmp_path / "l")]
        for m in modules:
            args += ["--module", m]
        r = subprocess.run(args, capture_output=True, text=True, timeout=20)
        assert r.returncode == 2, r
        assert "two modules at address" in r.stderr and "own address" in r.stderr, r.stderr
        assert not (tmp_path / "l").exists(), "nothing was served"

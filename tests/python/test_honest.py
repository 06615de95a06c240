"""Honest replies and links (issue 20 item 3), against `tmcl serve`: commands documented to get no reply
still show the reply that comes (a refusal exits 1); `set gp 255 1` says replies are off and how to turn
them on, and later silence is explained; a link whose server is gone is refused without a byte written;
an interrupted download says how much was stored."""

from __future__ import annotations

import os
import select
import socket
import subprocess
import threading



def tmcl(tmcl_bin, *args, timeout=30):
    return subprocess.run([str(tmcl_bin), *map(str, args)], capture_output=True, text=True, timeout=timeout)


def test_send_137_and_255_refusals_exit_1(pty_server, tmcl_bin):
    port = ["--port", pty_server.link, "--timeout", "0.5"]
    for op in ("137", "255"):
        r = tmcl(tmcl_bin, "send", *port, op, "0", "0", "0")  # no key: status 4
        assert r.returncode == 1, r
        assert "status 4" in r.stderr or "invalid value" in r.stderr, r.stderr
        assert "sent" not in r.stdout, r.stdout
    # With the key, 255 is answered (then the module restarts); 137 is carried out without a reply.
    r = tmcl(tmcl_bin, "send", *port, "255", "0", "0", "1234")
    assert r.returncode == 0 and r.stdout.startswith("status 100"), r
    r = tmcl(tmcl_bin, "send", *port, "137", "0", "0", "1234")
    assert r.returncode == 0, r
    assert r.stdout.startswith("sent; no reply within 0.5 s"), r.stdout


def test_replies_off_is_said_and_explained(pty_server, tmcl_bin):
    port = ["--port", pty_server.link, "--timeout", "0.5"]
    r = tmcl(tmcl_bin, "set", *port, "gp", "255", "1")
    assert r.returncode == 0, r
    assert "replies are now off" in r.stdout and "tmcl set gp 255 0" in r.stdout, r.stdout
    # GAP is still answered; a SAP is not, and the silence is explained, not blamed on the port.
    assert tmcl(tmcl_bin, "get", *port, "ap", "4").returncode == 0
    r = tmcl(tmcl_bin, "set", *port, "ap", "4", "1000")
    assert r.returncode == 3, r
    assert "replies are off" in r.stderr and "tmcl set gp 255 0" in r.stderr, r.stderr
    r = tmcl(tmcl_bin, "set", *port, "gp", "255", "0")
    assert (r.returncode, r.stdout) == (0, "ok\n"), r
    assert tmcl(tmcl_bin, "get", *port, "ap", "4").stdout.strip() == "ap 4 = 1000"


def test_a_stale_link_is_refused_without_a_byte_written(serve, tmcl_bin, tmp_path):
    server = serve("pty")
    link = server.link
    server.kill()  # kill -9: the link and its lock file stay
    assert os.path.islink(link) and os.path.exists(f"{link}.lock")
    # Another program has since opened a pseudo-terminal, and the stale link points at it.
    master, slave = os.openpty()
    try:
        os.remove(link)
        os.symlink(os.ttyname(slave), link)
        r = tmcl(tmcl_bin, "version", "--port", link, "--timeout", "0.5")
        assert r.returncode == 3, r
        assert "has exited" in r.stderr and "PID" in r.stderr, r.stderr
        readable, _, _ = select.select([master], [], [], 0.3)
        assert not readable, f"bytes were written: {os.read(master, 64)!r}"
    finally:
        os.close(master)
        os.close(slave)


def test_an_interrupted_download_says_how_much_was_stored(tmcl_bin, tmp_path):
    """A module (a stand-in on TCP) that hangs up after 5 of 12 instructions."""
    program = tmp_path / "p.tmc"
    program.write_text("".join(f"ROL 0, {100 + k}\n" for k in range(11)) + "STOP\n")
    listener = socket.create_server(("127.0.0.1", 0))
    port = listener.getsockname()[1]

    def module():
        conn, _ = listener.accept()
        with conn:
            for n in range(1 + 5):  # 132, then five instructions
                request = b""
                while len(request) < 9:
                    request += conn.recv(9 - len(request))
                status = 100 if n == 0 else 101
                body = bytes([2, 1, status, request[1]]) + request[4:8]
                conn.sendall(body + bytes([sum(body) & 0xFF]))
            conn.recv(9)  # the sixth instruction: hang up without an answer

    thread = threading.Thread(target=module, daemon=True)
    thread.start()
    r = tmcl(tmcl_bin, "download", "--tcp", f"127.0.0.1:{port}", "--timeout", "1", program)
    thread.join(5)
    listener.close()
    assert r.returncode != 0, r
    assert "download interrupted: 5 of 12 instructions stored (addresses 0..5)" in r.stderr, r.stderr


def test_a_non_locking_opener_is_detected_and_named(pty_server, tmcl_bin):
    """pyserial opens ports without a lock (and as root TIOCEXCL keeps nobody out): `tmcl` looks for other
    processes that have the tty open (/proc/*/fd) and refuses, naming them; --shared goes on anyway."""
    import serial

    link = str(pty_server.link)
    holder = serial.Serial(link, 115200)  # no exclusive=True: no flock, no TIOCEXCL
    try:
        r = tmcl(tmcl_bin, "get", "--port", link, "ap", "4")
        assert r.returncode == 3, r
        assert f"PID {os.getpid()} (" in r.stderr and "--shared" in r.stderr, r.stderr
        r = tmcl(tmcl_bin, "--shared", "get", "--port", link, "ap", "4")
        assert (r.returncode, r.stdout.strip()) == (0, "ap 4 = 51200"), r
    finally:
        holder.close()
    # The server itself, which keeps its pty open, is never counted.
    assert tmcl(tmcl_bin, "get", "--port", link, "ap", "4").returncode == 0


def test_the_server_warns_about_two_hosts_on_one_link(pty_server):
    """Two processes with the same link open (pyserial, no lock): the server names both on stderr."""
    import sys
    import time

    import serial

    from tmcltest import wait_until

    link = str(pty_server.link)
    other = subprocess.Popen([sys.executable, "-c",
                              f"import serial, time; s = serial.Serial({link!r}); time.sleep(30)"])
    try:
        with serial.Serial(link, 115200):
            wait_until(lambda: "warning" in pty_server.stderr(), 10, what="the server's warning")
        text = pty_server.stderr()
        assert f"PID {os.getpid()}" in text and f"PID {other.pid}" in text, text
        assert "--pty A --pty B" in text, text
    finally:
        other.kill()
        other.wait(10)

"""Several hosts, one module (issue 20 item 1), against `tmcl serve --pty A --pty B --tcp ADDR`: each link is
a host interface of its own, so a script (pytrinamic) polling on one link and `tmcl get`/`watch` on another
never see each other's replies: 10 000 transactions, zero wrong values."""

from __future__ import annotations

import json
import subprocess


from tmcltest import Poller, RawReply, frame

MAX_CURRENT, MAX_SPEED = 6, 4  # AP 6 = 128, AP 4 = 1234 below: a mixed-up reply shows as a wrong value


def tmcl(tmcl_bin, *args, timeout=30):
    return subprocess.run([str(tmcl_bin), *map(str, args)], capture_output=True, text=True, timeout=timeout)


def test_pytrinamic_and_tmcl_on_two_links_never_mix(serve, tmcl_bin, tmp_path):
    second = tmp_path / "link-b"
    server = serve("pty", extra=["--pty", str(second), "--tcp", "127.0.0.1:0"])
    ready = server.ready_line
    assert ready.endswith(f"on {server.link} and {second} and 127.0.0.1:" + ready.rpartition(":")[2]), ready
    assert tmcl(tmcl_bin, "set", "--port", second, "ap", MAX_CURRENT, 128).returncode == 0
    assert tmcl(tmcl_bin, "set", "--port", second, "ap", MAX_SPEED, 1234).returncode == 0

    polls = 9_000
    script = Poller(server.link, MAX_CURRENT, 128, polls)
    transactions = 0
    try:
        # Meanwhile on the second link: `tmcl get` one process at a time, and a `tmcl watch`.
        while script.is_alive() or polls + transactions < 10_000:
            r = tmcl(tmcl_bin, "get", "--port", second, "--timeout", "2", "ap", MAX_SPEED)
            assert (r.returncode, r.stdout.strip()) == (0, f"ap {MAX_SPEED} = 1234"), r
            transactions += 1
            if transactions % 25 == 0:
                r = tmcl(tmcl_bin, "--json", "watch", "--port", second, "ap", MAX_SPEED, "--every", "0.001",
                         "--count", 50)
                assert r.returncode == 0, r
                values = [json.loads(line) for line in r.stdout.splitlines()]
                assert len(values) == 50 and all(str(1234) in json.dumps(v) for v in values), r.stdout[:400]
                transactions += 50
    finally:
        script.join(120)
    assert not script.errors, script.errors
    assert not script.wrong, f"{len(script.wrong)} wrong values on the script's link: {script.wrong[:5]}"
    assert polls + transactions >= 10_000, transactions
    # The TCP link is a third interface of the same module.
    import socket
    with socket.create_connection(("127.0.0.1", int(server.links[-1].rpartition(":")[2])), timeout=5) as s:
        s.sendall(frame(1, 6, MAX_SPEED, 0, 0))
        got = b""
        while len(got) < 9:
            got += s.recv(9 - len(got))
    assert RawReply(got).value == 1234


def test_a_second_link_sees_no_event_of_the_first(serve, tmp_path):
    """138 (the target-reached event) goes to the link that asked, never to another."""
    import serial
    import time

    second = tmp_path / "link-b"
    server = serve("pty", extra=["--pty", str(second)])
    with serial.Serial(str(server.link), 115200, timeout=2) as a, serial.Serial(str(second), 115200, timeout=0.5) as b:
        a.write(frame(1, 138, 0, 0, 1))  # ask for the event of the next move (type 0, motor mask 1)
        assert RawReply(a.read(9)).status == 100
        a.write(frame(1, 4, 0, 0, 200))  # MVP ABS 200
        assert RawReply(a.read(9)).status == 100
        event = RawReply(a.read(9))
        assert (event.status, event.opcode) == (128, 138), event
        time.sleep(0.1)
        assert b.read(64) == b"", "the other link got nothing"

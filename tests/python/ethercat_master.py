"""pysoem (SOEM, a real EtherCAT master) against `tmcl serve --module tmcm-1310 --ethercat`, inside a
network namespace of its own.

Run it under `unshare -n` (test_ethercat.py does): it brings up `lo` and a veth pair (ecm0 for the
master, ecs0 for the slave), starts `tmcl serve` on ecs0 with its USB port on a pty, runs one
scenario, stops the server (exit code 0 checked) and prints its results as JSON lines on stdout. The
namespace, the veth pair and every frame vanish with the process.

    unshare -n python tests/python/ethercat_master.py SCENARIO --tmcl target/debug/tmcl --dir /tmp/x

Scenarios:
  pysoem     discovery and identity, config_map, SAFE-OP (outputs held), OP, velocity and position mode
             with the motor following, TMCL GAP/SAP through the mailbox (100), a wrong command (2), the
             USB port seeing the same module, a refused transition answered with an AL code
  foe        INIT -> BOOT, a file written with FoE lands beside the EEPROM
  roundtrip  N frames (a BRD of AL status) from a raw socket on ecm0: round-trip times
  cycle      pysoem cycles process data at CYCLE_US for SECONDS: lost working counters
  record     SOEM's bring-up to OP (no motion), a mailbox GAP and the way back to INIT, every frame
             in both directions written to --out (the replay test of tmcl-ethercat reads it)
  alias      SOEM writes a station alias into the SII (word 4 and the checksum, as eepromtool -walias);
             the server is killed with -9 and started again on the same --eeprom: the alias is there
  broadcast  raw BRD/BWR/BRW frames: each comes back with its position (ADP) incremented
  split      a TMCL request written into SM0 in two frames (two FPWR): answered as in one
  sigterm    SIGTERM while a master floods the slave with frames: exit times (ms)
  esi        `tmcl esi` against the SII the running slave serves, read word by word with SOEM
Exit code 77 (and a {"skip": ...} line) where the namespace cannot have veth links or raw sockets.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import socket
import struct
import subprocess
import sys
import time
from pathlib import Path

SKIP = 77
MASTER_IF, SLAVE_IF = "ecm0", "ecs0"
ETHERTYPE = 0x88A4


def emit(**fields) -> None:
    print(json.dumps(fields), flush=True)


def skip(reason: str) -> None:
    emit(skip=reason)
    sys.exit(SKIP)


def sh(*args: str) -> None:
    subprocess.run(args, check=True, capture_output=True, text=True)


def set_up_network() -> None:
    try:
        sh("ip", "link", "set", "lo", "up")
        sh("ip", "link", "add", MASTER_IF, "type", "veth", "peer", "name", SLAVE_IF)
        for name in (MASTER_IF, SLAVE_IF):
            # No IPv6 chatter on the link (router solicitations): only EtherCAT.
            with open(f"/proc/sys/net/ipv6/conf/{name}/disable_ipv6", "w") as f:
                f.write("1")
            sh("ip", "link", "set", name, "up")
    except (subprocess.CalledProcessError, FileNotFoundError, PermissionError, OSError) as e:
        detail = getattr(e, "stderr", "") or str(e)
        skip(f"cannot create a veth pair in this network namespace: {detail.strip()}")
    try:
        s = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(ETHERTYPE))
        s.close()
    except PermissionError as e:
        skip(f"raw packet sockets are not allowed: {e}")


class Serve:
    """`tmcl serve` on ecs0 with its USB port on a pty; stderr collected in a file."""

    def __init__(self, tmcl: str, workdir: Path, extra: list[str] | None = None):
        self.link = workdir / "usb"
        self.eeprom = workdir / "tmcm1310.eeprom"
        self.stderr_path = workdir / "serve.stderr"
        args = [tmcl, "serve", "--module", "tmcm-1310", "--ethercat", SLAVE_IF, "--pty", str(self.link),
                "--eeprom", str(self.eeprom), "-v"] + (extra or [])
        self.stderr = open(self.stderr_path, "w")
        self.proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=self.stderr, text=True)
        line = self.proc.stdout.readline().strip()
        if not line.startswith("serving TMCM-1310 at address 1 on ") or f"EtherCAT {SLAVE_IF}" not in line:
            self.proc.kill()
            raise AssertionError(f"ready line {line!r}; stderr: {self.stderr_path.read_text()}")

    def kill(self) -> None:
        """kill -9: no chance to clean up."""
        self.proc.kill()
        self.proc.wait(timeout=10)
        self.stderr.close()

    def stop(self) -> str:
        self.proc.send_signal(signal.SIGTERM)
        rc = self.proc.wait(timeout=10)
        self.stderr.close()
        text = self.stderr_path.read_text()
        assert rc == 0, f"tmcl serve exited {rc}: {text}"
        return text


class Usb:
    """The module's USB port: 9-byte TMCL frames on the pty."""

    def __init__(self, path: Path):
        import serial

        self.port = serial.Serial(str(path), timeout=2)

    def request(self, opcode: int, kind: int, value: int = 0, motor: int = 0) -> tuple[int, int]:
        frame = bytes([1, opcode, kind, motor]) + struct.pack(">i", value)
        self.port.write(frame + bytes([sum(frame) & 0xFF]))
        reply = self.port.read(9)
        assert len(reply) == 9 and sum(reply[:8]) & 0xFF == reply[8], f"USB reply {reply!r}"
        return reply[2], struct.unpack(">i", reply[4:8])[0]


SM0, SM0_LEN, SM1, SM1_LEN = 0x1000, 268, 0x110C, 40


def tmcl(slave, opcode: int, kind: int, value: int = 0, motor: int = 0) -> tuple[int, int, bytes]:
    """A TMCL request through the raw mailbox: 8 bytes at offset 0 of SM0 (the whole buffer written,
    as the SyncManager wants), SM1 polled until full, then read whole. (status, value, raw reply)."""
    request = bytes([1, opcode, kind, motor]) + struct.pack(">i", value)
    slave._fpwr(SM0, request + bytes(SM0_LEN - 8))
    deadline = time.monotonic() + 2
    while not slave._fprd(0x080D, 1)[0] & 0x08:
        assert time.monotonic() < deadline, "no reply in SM1"
    reply = slave._fprd(SM1, SM1_LEN)
    assert reply[8:] == bytes(SM1_LEN - 8), f"SM1 holds more than the reply: {reply!r}"
    return reply[2], struct.unpack(">i", reply[4:8])[0], reply[:8]


def fields(slave) -> list[int]:
    """The 12 input fields (manual §3.4), little-endian."""
    data = bytes(slave.input)
    assert len(data) == 48, len(data)
    return list(struct.unpack("<iiiiiiiIIiii", data))


def cycle(master, slave, outputs: bytes, n: int, period: float = 0.001) -> list[int]:
    """n process-data cycles at `period`; every working counter must be the expected one."""
    slave.output = outputs
    for _ in range(n):
        master.send_processdata()
        wkc = master.receive_processdata(10_000)
        assert wkc == master.expected_wkc, f"working counter {wkc}, expected {master.expected_wkc}"
        time.sleep(period)
    return fields(slave)


def open_master():
    import pysoem

    master = pysoem.Master()
    master.open(MASTER_IF)
    found = master.config_init()
    assert found == 1, f"config_init found {found} slaves"
    return pysoem, master, master.slaves[0]


def to_op(pysoem, master, slave, outputs: bytes) -> None:
    size = master.config_map()
    assert size == 56, f"process image of {size} bytes (8 out + 48 in)"
    assert master.state_check(pysoem.SAFEOP_STATE, 3_000_000) == pysoem.SAFEOP_STATE
    cycle(master, slave, outputs, 5)
    master.state = pysoem.OP_STATE
    master.write_state()
    for _ in range(1000):
        master.send_processdata()
        master.receive_processdata(10_000)
        if master.state_check(pysoem.OP_STATE, 1000) == pysoem.OP_STATE:
            return
    raise AssertionError(f"no OP: AL status code {slave.al_status:#06x}")


def scenario_pysoem(args) -> None:
    serve = Serve(args.tmcl, Path(args.dir))
    usb = Usb(serve.link)
    pysoem, master, slave = open_master()
    emit(slaves=1, vendor=slave.man, product=slave.id, revision=slave.rev, name=slave.name)
    assert (slave.man, slave.id, slave.rev) == (0x286, 1310, 0x0001000E)
    assert slave.name == "TMCM-1310"
    assert master.state_check(pysoem.PREOP_STATE, 3_000_000) == pysoem.PREOP_STATE
    # TMCL in PRE-OP: GAP 4, SAP 4 (status 100), a wrong command (status 2), a protected parameter (8).
    assert tmcl(slave, 6, 4)[:2] == (100, 51200)
    status, value, raw = tmcl(slave, 5, 4, 102400)
    assert (status, value) == (100, 102400) and raw[:2] == bytes([2, 1]), raw
    assert tmcl(slave, 200, 0)[0] == 2
    assert tmcl(slave, 5, 26, 1)[0] == 8
    # The USB port sees the same module.
    assert usb.request(6, 4) == (100, 102400)
    emit(mailbox="ok")

    velocity = struct.pack("<Ii", 2, 51200)
    size = master.config_map()
    assert size == 56, f"process image of {size} bytes"
    assert master.expected_wkc == 3, master.expected_wkc
    assert master.state_check(pysoem.SAFEOP_STATE, 3_000_000) == pysoem.SAFEOP_STATE
    # SAFE-OP: the outputs are held; the motor does not move.
    f = cycle(master, slave, velocity, 100)
    assert f[1] == 0 and f[5] == 0, f"moved in SAFE-OP: {f}"
    assert usb.request(6, 1) == (100, 0)
    master.state = pysoem.OP_STATE
    master.write_state()
    assert master.state_check(pysoem.OP_STATE, 3_000_000) == pysoem.OP_STATE
    emit(state="OP", expected_wkc=master.expected_wkc)

    # Velocity mode: 51200 pps (1 s to full speed at the default acceleration).
    t0 = time.monotonic()
    f = cycle(master, slave, velocity, 1)
    while f[5] != 51200:
        assert time.monotonic() - t0 < 10, f"no full speed: {f}"
        f = cycle(master, slave, velocity, 10)
    assert f[4] == 51200 and f[7] & (1 << 4), f"target velocity and velocity-mode bit: {f}"
    status, position = usb.request(6, 1)
    assert status == 100 and position >= f[1] > 0, (position, f)
    emit(velocity_mode=f[5], position=f[1], usb_position=position)

    # TMCL in OP, between cycles.
    assert tmcl(slave, 6, 2)[:2] == (100, 51200)
    # Position mode: back to 1000; the status word says when it is reached.
    target = struct.pack("<Ii", 1, 1000)
    t0 = time.monotonic()
    f = cycle(master, slave, target, 1)
    while not (f[1] == 1000 and f[7] & 1):
        assert time.monotonic() - t0 < 15, f"target not reached: {f}"
        f = cycle(master, slave, target, 10)
    assert f[0] == 1000 and usb.request(6, 1) == (100, 1000)
    emit(position_mode=f[1])

    # A refused transition answers with an AL code: OP -> BOOT skips INIT.
    slave.state = pysoem.BOOT_STATE
    slave.write_state()
    cycle(master, slave, target, 5)
    master.read_state()
    assert slave.state == pysoem.OP_STATE | pysoem.STATE_ERROR, f"{slave.state:#x}"
    assert slave.al_status == 0x0011, f"{slave.al_status:#06x}"
    emit(refused=slave.al_status)
    # Acknowledged, and down to INIT.
    slave.state = pysoem.SAFEOP_STATE | pysoem.STATE_ACK
    slave.write_state()
    assert slave.state_check(pysoem.SAFEOP_STATE, 3_000_000) == pysoem.SAFEOP_STATE
    master.state = pysoem.INIT_STATE
    master.write_state()
    assert master.state_check(pysoem.INIT_STATE, 3_000_000) == pysoem.INIT_STATE
    master.close()
    usb.port.close()
    log = serve.stop()
    assert "EtherCAT: OP with error, AL status code 0x0011" in log, log
    emit(done=True)


def scenario_foe(args) -> None:
    serve = Serve(args.tmcl, Path(args.dir))
    pysoem, master, slave = open_master()
    master.state = pysoem.INIT_STATE
    master.write_state()
    assert master.state_check(pysoem.INIT_STATE, 3_000_000) == pysoem.INIT_STATE
    slave.state = pysoem.BOOT_STATE
    slave.write_state()
    assert slave.state_check(pysoem.BOOT_STATE, 3_000_000) == pysoem.BOOT_STATE
    data = bytes((i * 7) & 0xFF for i in range(1000))
    result = slave.foe_write("TMCM-1310.hex", 0, data)
    assert result > 0, f"foe_write: {result}"
    # The server writes the file once no frame waits for an answer.
    foe = Path(str(serve.eeprom) + ".foe")
    deadline = time.monotonic() + 5
    while not foe.exists():
        assert time.monotonic() < deadline, f"{foe} not written"
        time.sleep(0.01)
    assert foe.read_bytes() == data
    slave.state = pysoem.INIT_STATE
    slave.write_state()
    assert slave.state_check(pysoem.INIT_STATE, 3_000_000) == pysoem.INIT_STATE
    master.close()
    log = serve.stop()
    assert "FoE: received 'TMCM-1310.hex', 1000 bytes" in log.replace('"', "'"), log
    emit(foe=len(data), file=foe.name)


def brd_frame() -> bytes:
    """A BRD of AL status (2 bytes): 14 bytes Ethernet, 2 EtherCAT header, 10 + 2 + 2 datagram."""
    datagram = struct.pack("<BBHHHH", 7, 0x42, 0, 0x0130, 2, 0) + bytes(2) + struct.pack("<H", 0)
    return b"\xff" * 6 + b"\x01" * 6 + struct.pack(">H", ETHERTYPE) + struct.pack("<H", len(datagram) | 0x1000) + datagram


def scenario_roundtrip(args) -> None:
    serve = Serve(args.tmcl, Path(args.dir), extra=[])
    s = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(ETHERTYPE))
    s.bind((MASTER_IF, ETHERTYPE))
    s.settimeout(1)
    frame = brd_frame()
    times = []
    for i in range(args.frames):
        t0 = time.perf_counter_ns()
        s.send(frame)
        reply = s.recv(2048)
        t1 = time.perf_counter_ns()
        assert reply[6] == 0x03 and len(reply) == len(frame), reply
        assert struct.unpack("<H", reply[-2:])[0] == 1, "working counter 1"
        if i >= 100:  # warm-up
            times.append((t1 - t0) / 1000)
    s.close()
    serve.stop()
    times.sort()
    q = lambda p: round(times[min(len(times) - 1, int(p * len(times)))], 1)
    emit(frames=len(times), median_us=q(0.5), p90_us=q(0.9), p99_us=q(0.99), max_us=round(times[-1], 1))


def scenario_cycle(args) -> None:
    serve = Serve(args.tmcl, Path(args.dir))
    pysoem, master, slave = open_master()
    velocity = struct.pack("<Ii", 2, 51200)
    to_op(pysoem, master, slave, velocity)
    period = args.cycle_us / 1e6
    cycles = lost = timeouts = 0
    late = 0.0
    start = next_at = time.perf_counter()
    end = start + args.seconds
    while next_at < end:
        master.send_processdata()
        wkc = master.receive_processdata(args.receive_timeout_us)
        cycles += 1
        if wkc != master.expected_wkc:
            lost += 1
            # SOEM's EC_NOFRAME (-1): no answer within the receive timeout, as opposed to an answer with
            # the wrong working counter.
            timeouts += wkc < 0
        next_at += period
        now = time.perf_counter()
        late = max(late, now - next_at)
        while time.perf_counter() < next_at:
            pass
    master.read_state()
    state = slave.state
    f = fields(slave)
    master.close()
    serve.stop()
    emit(cycle_us=args.cycle_us, seconds=args.seconds, cycles=cycles, lost=lost, timeouts=timeouts, state=state,
         worst_lateness_us=round(late * 1e6), velocity=f[5])


def scenario_record(args) -> None:
    import threading

    serve = Serve(args.tmcl, Path(args.dir))
    sniffer = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(0x0003))  # ETH_P_ALL
    sniffer.bind((MASTER_IF, 0))
    # pysoem holds the GIL through config_init and config_map: the kernel must queue every frame meanwhile.
    sniffer.setsockopt(socket.SOL_SOCKET, 33, 64 << 20)  # SO_RCVBUFFORCE (root)
    sniffer.settimeout(0.2)
    frames: list[tuple[int, str, bytes]] = []
    done = threading.Event()
    t0 = time.perf_counter_ns()

    def sniff() -> None:
        while not done.is_set():
            try:
                data, addr = sniffer.recvfrom(4096)
            except socket.timeout:
                continue
            if struct.unpack(">H", data[12:14])[0] == ETHERTYPE:
                # pkttype 4: sent by this host (the master); otherwise the slave's answer.
                frames.append(((time.perf_counter_ns() - t0) // 1000, ">" if addr[2] == 4 else "<", data))

    thread = threading.Thread(target=sniff)
    thread.start()
    pysoem, master, slave = open_master()
    to_op(pysoem, master, slave, struct.pack("<Ii", 0, 0))
    cycle(master, slave, struct.pack("<Ii", 0, 0), 20)
    assert tmcl(slave, 6, 4)[:2] == (100, 51200)
    master.state = pysoem.INIT_STATE
    master.write_state()
    assert master.state_check(pysoem.INIT_STATE, 3_000_000) == pysoem.INIT_STATE
    master.close()
    time.sleep(0.3)
    done.set()
    thread.join()
    serve.stop()
    with open(args.out, "w") as f:
        f.write("# SOEM (pysoem 1.1.13) and `tmcl serve --module tmcm-1310 --ethercat` over a veth pair, recorded\n")
        f.write("# by `ethercat_master.py record`: microseconds since the start, > from the master, < the answer.\n")
        for t, direction, data in frames:
            f.write(f"{t} {direction} {data.hex()}\n")
    emit(recorded=len(frames), out=args.out)


def sii_crc(data: bytes) -> int:
    """CRC-8 of the SII configuration area (x^8 + x^2 + x + 1, initial 0xFF), as eepromtool computes it."""
    crc = 0xFF
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = ((crc << 1) ^ 0x07) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc


def sii_words(slave, first: int, count: int) -> bytes:
    """SII words read with SOEM's EEPROM interface (each read gives 2 words)."""
    out = b""
    for w in range(first, first + count, 2):
        out += bytes(slave.eeprom_read(w, 20_000))
    return out[: 2 * count]


def scenario_alias(args) -> None:
    alias = 0x0BAD
    serve = Serve(args.tmcl, Path(args.dir))
    pysoem, master, slave = open_master()
    config = bytearray(sii_words(slave, 0, 8))
    assert config[8:10] == bytes(2), f"factory alias {config[8:10].hex()}"
    # eepromtool -walias: word 4, then the checksum over words 0..6 in word 7.
    config[8:10] = struct.pack("<H", alias)
    slave.eeprom_write(4, bytes(config[8:10]), 20_000)
    slave.eeprom_write(7, bytes([sii_crc(bytes(config[:14])), 0]), 20_000)
    assert sii_words(slave, 4, 4) == bytes(config[8:10]) + bytes(config[10:14]) + bytes([sii_crc(bytes(config[:14])), 0])
    before = struct.unpack("<H", bytes(slave._fprd(0x0012, 2)))[0]
    master.close()
    serve.kill()  # kill -9: the words must already be on disk
    serve = Serve(args.tmcl, Path(args.dir))
    pysoem, master, slave = open_master()
    after = struct.unpack("<H", bytes(slave._fprd(0x0012, 2)))[0]
    word4 = struct.unpack("<H", sii_words(slave, 4, 1))[0]
    crc_ok = sii_words(slave, 7, 1)[0] == sii_crc(sii_words(slave, 0, 7))
    # The rest of the identity is the model's, as before.
    assert (slave.man, slave.id, slave.name) == (0x286, 1310, "TMCM-1310")
    master.close()
    log = serve.stop()
    emit(alias_before_restart=before, alias_after_restart=after, sii_word4=word4, crc_ok=crc_ok,
         restored_logged="SII: 2 words a master wrote" in log)


def raw_socket() -> socket.socket:
    s = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(ETHERTYPE))
    s.bind((MASTER_IF, ETHERTYPE))
    s.settimeout(1)
    return s


def datagram(cmd: int, adp: int, ado: int, data: bytes, more: bool = False) -> bytes:
    return struct.pack("<BBHHHH", cmd, 0x42, adp, ado, len(data) | (0x8000 if more else 0), 0) + data + bytes(2)


def ecat_frame(*datagrams: bytes) -> bytes:
    body = b"".join(datagrams)
    return b"\xff" * 6 + b"\x01" * 6 + struct.pack(">H", ETHERTYPE) + struct.pack("<H", len(body) | 0x1000) + body


def packet_sockets() -> list[tuple[int, int]]:
    """(protocol, interface index) of every packet socket in this namespace (/proc/net/packet: 0 = not
    bound to an interface)."""
    rows = Path("/proc/net/packet").read_text().splitlines()[1:]
    return [(int(r.split()[3], 16), int(r.split()[4])) for r in rows]


def scenario_broadcast(args) -> None:
    serve = Serve(args.tmcl, Path(args.dir))
    # The server's socket is bound to its interface (ecs0), not open on all of them.
    ecs0 = socket.if_nametoindex(SLAVE_IF)
    sockets = packet_sockets()
    s = raw_socket()
    result = {"server_socket_bound_to": [iface for proto, iface in sockets if proto == ETHERTYPE], "ecs0": ecs0}
    for name, cmd, adp, ado, data in [("brd", 7, 0, 0x0000, bytes(4)), ("bwr", 8, 0xFFFE, 0x0F80, b"\x00"),
                                      ("brw", 9, 0x0005, 0x0F80, b"\x00")]:
        s.send(ecat_frame(datagram(cmd, adp, ado, data)))
        reply = s.recv(2048)
        back_adp, = struct.unpack("<H", reply[18:20])
        wkc, = struct.unpack("<H", reply[-2:])
        result[name] = {"sent": adp, "back": back_adp, "wkc": wkc}
        if name == "brd":
            result["esc"] = reply[26:30].hex()
    s.close()
    serve.stop()
    emit(**result)


def scenario_split(args) -> None:
    serve = Serve(args.tmcl, Path(args.dir))
    pysoem, master, slave = open_master()
    assert master.state_check(pysoem.PREOP_STATE, 3_000_000) == pysoem.PREOP_STATE
    request = bytes([1, 6, 4, 0, 0, 0, 0, 0]) + bytes(SM0_LEN - 8)
    slave._fpwr(SM0, request[:100])
    early = slave._fprd(0x080D, 1)[0] & 0x08
    slave._fpwr(SM0 + 100, request[100:])
    deadline = time.monotonic() + 2
    while not slave._fprd(0x080D, 1)[0] & 0x08:
        assert time.monotonic() < deadline, "no reply in SM1 after a split request"
    reply = bytes(slave._fprd(SM1, SM1_LEN))
    # And a whole request after it still works.
    whole = tmcl(slave, 6, 4)[:2]
    master.close()
    serve.stop()
    emit(reply_before_the_end=bool(early), status=reply[2], value=struct.unpack(">i", reply[4:8])[0],
         whole=list(whole))


def scenario_sigterm(args) -> None:
    import threading

    times = []
    for _ in range(args.rounds):
        serve = Serve(args.tmcl, Path(args.dir))
        stop = threading.Event()
        sent = [0]

        def flood() -> None:
            s = raw_socket()
            s.settimeout(0.01)
            frame = ecat_frame(datagram(7, 0, 0x0130, bytes(2)), datagram(4, 0x1001, 0x0010, bytes(64)))
            while not stop.is_set():
                try:
                    s.send(frame)
                    sent[0] += 1
                    s.recv(2048)
                except (socket.timeout, OSError):
                    pass
            s.close()

        threads = [threading.Thread(target=flood) for _ in range(2)]
        for t in threads:
            t.start()
        time.sleep(0.5)
        t0 = time.perf_counter()
        serve.proc.send_signal(signal.SIGTERM)
        rc = serve.proc.wait(timeout=10)
        elapsed = time.perf_counter() - t0
        stop.set()
        for t in threads:
            t.join()
        serve.stderr.close()
        assert rc == 0, f"exit {rc}: {serve.stderr_path.read_text()}"
        times.append(round(elapsed * 1000, 1))
    emit(exit_ms=times, worst_ms=max(times), frames=sent[0])


def scenario_esi(args) -> None:
    import xml.etree.ElementTree as ET

    esi_path = Path(args.dir) / "tmcm1310.xml"
    subprocess.run([args.tmcl, "esi", "--module", "tmcm-1310", "-o", str(esi_path)], check=True)
    root = ET.parse(esi_path).getroot()
    serve = Serve(args.tmcl, Path(args.dir))
    pysoem, master, slave = open_master()
    # The SII as the slave serves it: the fixed words, then the categories up to the end marker.
    head = sii_words(slave, 0, 0x40)
    word = lambda w: struct.unpack("<H", head[2 * w:2 * w + 2])[0]
    dword = lambda w: word(w) | word(w + 1) << 16
    cats = {}
    at = 0x40
    while True:
        kind, size = struct.unpack("<HH", sii_words(slave, at, 2))
        if kind == 0xFFFF:
            break
        cats[kind] = sii_words(slave, at + 2, size)
        at += 2 + size
    master.close()
    serve.stop()
    strings = [b""]
    data = cats[10]
    pos = 1
    for _ in range(data[0]):
        n = data[pos]
        strings.append(data[pos + 1:pos + 1 + n])
        pos += 1 + n
    s = lambda i: strings[i].decode()
    hexval = lambda t: int(t.strip().removeprefix("#x"), 16)
    device = root.find("Descriptions/Devices/Device")
    checks = {}
    checks["vendor"] = hexval(root.find("Vendor/Id").text) == dword(0x08)
    t = device.find("Type")
    checks["product"] = hexval(t.get("ProductCode")) == dword(0x0A)
    checks["revision"] = hexval(t.get("RevisionNo")) == dword(0x0C)
    general = cats[30]
    checks["name"] = device.find("Name").text == s(general[3])
    checks["group"] = device.find("GroupType").text == s(general[0])
    sms = device.findall("Sm")
    syncm = cats[41]
    checks["sync_managers"] = len(sms) == len(syncm) // 8 and all(
        hexval(sm.get("StartAddress")) == struct.unpack("<H", syncm[8 * i:8 * i + 2])[0]
        and int(sm.get("DefaultSize")) == struct.unpack("<H", syncm[8 * i + 2:8 * i + 4])[0]
        and hexval(sm.get("ControlByte")) == syncm[8 * i + 4]
        for i, sm in enumerate(sms))
    types = {"DINT": 4, "UDINT": 7}
    for element, kind in (("RxPdo", 51), ("TxPdo", 50)):
        pdo, raw = device.find(element), cats[kind]
        index, entries, sm, _, name = struct.unpack("<HBBBB", raw[:6])
        ok = hexval(pdo.find("Index").text) == index and int(pdo.get("Sm")) == sm and pdo.find("Name").text == s(name)
        xml_entries = pdo.findall("Entry")
        ok &= len(xml_entries) == entries
        for k, e in enumerate(xml_entries):
            e_index, sub, e_name, dtype, bits = struct.unpack("<HBBBB", raw[8 + 8 * k:8 + 8 * k + 6])
            ok &= (hexval(e.find("Index").text), int(e.find("SubIndex").text), e.find("Name").text,
                   types[e.find("DataType").text], int(e.find("BitLen").text)) == (e_index, sub, s(e_name), dtype, bits)
        checks[element] = bool(ok)
    protocols = {"AoE": 1, "EoE": 2, "CoE": 4, "FoE": 8, "SoE": 16, "VoE": 32}
    checks["mailbox"] = sum(protocols[c.tag] for c in device.find("Mailbox")) == word(0x1C)
    checks["config_data"] = bytes.fromhex(device.find("Eeprom/ConfigData").text) == head[:14]
    checks["bootstrap"] = bytes.fromhex(device.find("Eeprom/BootStrap").text) == head[0x28:0x30]
    emit(**checks)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("scenario", choices=["pysoem", "foe", "roundtrip", "cycle", "record", "alias", "broadcast", "split",
                                        "sigterm", "esi"])
    p.add_argument("--rounds", type=int, default=3, help="sigterm: how many servers to stop")
    p.add_argument("--tmcl", required=True)
    p.add_argument("--dir", required=True)
    p.add_argument("--frames", type=int, default=2000)
    p.add_argument("--cycle-us", type=int, default=1000)
    p.add_argument("--receive-timeout-us", type=int, default=2000,
                   help="how long the master waits for each cycle's frame (cycle scenario)")
    p.add_argument("--seconds", type=float, default=2.0)
    p.add_argument("--out", help="record: the file to write")
    args = p.parse_args()
    set_up_network()
    globals()[f"scenario_{args.scenario}"](args)


if __name__ == "__main__":
    main()

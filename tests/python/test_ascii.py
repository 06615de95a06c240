"""The ASCII command interface (PD28-1021 manual §3.4) through `tmcl serve`, byte for byte on the pty:
command 139 and GP 67 bit 0 at start-up, the manual's command lines and reply (§3.4.2, §3.4.3) in every
echo mode (GP 67 bits 4/5), backspace, BIN/RUN/STOP, status replies for every malformed line, and a
module in ASCII mode on a line shared with binary modules.

How a line with mixed modes behaves (a real RS485 line would do the same; bus.rs, iface/ascii.rs):
- The binary modules read ASCII text as 9-byte frames; those frames carry a foreign address ('A' = 65 …)
  and are ignored without a reply. The bytes of an incomplete frame are dropped after a pause (5 ms on a
  serial line and with --wire-timing, 50 ms on a pty or TCP link without it), so a host must pause that long
  after an ASCII line before its next binary frame (else that frame is lost).
- The ASCII module reads binary frames as text. A control byte (other than CR, LF, BS, TAB) or a byte
  from 0x80 up discards the line being typed, so a frame's 0x01/0x03 address byte, its zero bytes and
  most checksums leave no partial line: an ASCII line typed after binary traffic is answered. Only the
  printable bytes after a frame's last such byte stay (its checksum, say 'A' = 0x41): they start a line
  for that "address character" and swallow the next ASCII line up to its CR. A host that wants its
  first line answered sends CR (or ESC) first. A binary frame with a CR byte followed by the ASCII
  module's address character ('B' = 0x42) does start a line for it: it echoes those bytes (echo mode
  00), and a later CR would get a status reply — stray text a binary host reads as part of its next
  reply — unless a byte such as the frame's checksum discards that line first.
"""

from __future__ import annotations

import random
import re
import statistics
import time

import pytest
from pytrinamic.connections import SerialTmclInterface

from tmcltest import BUS_MODULES, RESYNC_S, LinePort, frame, pytrinamic_connection, wait_until

HOST = 2
SAP, GAP, SGP, GGP, ENTER_ASCII = 5, 6, 9, 10, 139
CALC, AGP, WAIT, JA = 19, 35, 27, 22
REPLY_RE = re.compile(rb"^([A-Z])([A-Z]) (\d+) (-?\d+)\r$")
ECHO_EACH, ECHO_LINE, ECHO_NONE = 0x00, 0x10, 0x20


class AsciiLinePort(LinePort):
    """A terminal on the line: writes text, reads the echo and the reply."""

    def enter_ascii(self, address: int = 1, host: int = HOST):
        """Binary command 139: answered in binary, then the module talks ASCII."""
        reply = self.request(address, ENTER_ASCII, 0, 0, 0)
        assert reply.checksum_ok, reply
        assert (reply.host, reply.module, reply.status, reply.opcode, reply.value) == (
            host, address, 100, ENTER_ASCII, 0), reply

    def type(self, text: bytes, crs: int, timeout: float = 2.0) -> bytes:
        """Writes `text`, returns everything up to the `crs`-th CR that comes back."""
        self.write(text)
        return b"".join(self.read_until(b"\r", timeout) for _ in range(crs))

    def command(self, line: str | bytes, echo: int = ECHO_NONE) -> bytes:
        """One command line (CR added); returns the echo (if any) and the reply line."""
        data = line.encode("latin-1") if isinstance(line, str) else line
        return self.type(data + b"\r", 1 if echo == ECHO_NONE else 2)

    def reply_line(self, line: str | bytes, module: str = "A", host: str = "B") -> tuple[int, int]:
        """A command line in echo mode 10 (no echo): its reply's (status, value)."""
        got = self.command(line)
        m = REPLY_RE.match(got)
        assert m, f"{line!r} got {got!r}"
        assert (m.group(1), m.group(2)) == (host.encode(), module.encode()), got
        return int(m.group(3)), int(m.group(4))


@pytest.fixture
def term(pty_server):
    with AsciiLinePort(pty_server.link) as port:
        yield port


def expected(line: bytes, reply: bytes, echo: int) -> bytes:
    """What a line produces in each echo mode: `line` is what was typed (without CR)."""
    if echo == ECHO_EACH:
        typed = line.replace(b"\x08", b"\x08 \x08")  # a backspace is echoed as BS SP BS
        return typed + b"\r" + reply
    if echo == ECHO_LINE:
        edited = bytearray()
        for b in line:
            if b == 0x08:
                edited = edited[:-1]
            else:
                edited.append(b)
        return bytes(edited) + b"\r" + reply
    return reply


# -- entering and leaving --------------------------------------------------------------------------

def test_139_answered_in_binary_then_ascii_then_bin(term, pty_server):
    term.write(frame(1, ENTER_ASCII, 0, 0, 0))
    assert term.read_exact(9) == bytes([2, 1, 100, 139, 0, 0, 0, 0, (2 + 1 + 100 + 139) & 0xFF])
    assert term.type(b"AGAP 4, 0\r", 2) == b"AGAP 4, 0\rBA 100 51200\r"
    assert term.type(b"ABIN\r", 2) == b"ABIN\rBA 100 0\r"
    term.silence(0.1)
    # Binary again, for raw frames and for pytrinamic (on the same port and on a new connection).
    assert term.ok(1, GAP, 4, 0, 0).value == 51200
    conn = SerialTmclInterface(term.ser)
    term.ser.timeout = 5
    assert conn.get_axis_parameter(4, 0) == 51200
    term.ser.timeout = 0
    with pytrinamic_connection(pty_server) as conn:
        assert conn.get_version_string() == "1021V142"
        conn.set_axis_parameter(4, 0, 1000)
        assert conn.get_axis_parameter(4, 0) == 1000


@pytest.mark.parametrize("echo", [ECHO_EACH, ECHO_LINE, ECHO_NONE], ids=["echo00", "echo01", "echo10"])
def test_manual_examples_in_every_echo_mode(term, echo):
    term.ok(1, SGP, 67, 0, echo)  # GP 67 bits 5/4; bit 0 clear (start-up in binary)
    term.enter_ascii()

    def check(line: bytes, reply: bytes):
        assert term.type(line + b"\r", 1 if echo == ECHO_NONE else 2) == expected(line, reply, echo), line

    # §3.4.3: "AGAP 0, 1" → "BA 100 -5000" with the actual position -5000 of motor 1. The PD28-1021 has
    # motor 0 only, so the reachable form is AGAP 1, 0 (actual position); motor 1 is status 4.
    check(b"ASAP 1, 0, -5000", b"BA 100 -5000\r")
    check(b"AGAP 1, 0", b"BA 100 -5000\r")
    check(b"AGAP 0, 1", b"BA 4 0\r")
    # §3.4.2's command lines, as printed (motors 1 and 2: status 4 here) and for motor 0.
    check(b"AMVP ABS, 1, 50000", b"BA 4 50000\r")
    check(b"AMVP ABS, 0, 50000", b"BA 100 50000\r")
    check(b"A MVP ABS, 1, 50000", b"BA 4 50000\r")
    check(b"A MVP ABS, 0, 50000", b"BA 100 50000\r")
    check(b"AROL 2, 500", b"BA 4 500\r")
    check(b"AROL 0, 500", b"BA 100 500\r")
    check(b"A MST 1", b"BA 4 0\r")
    check(b"A MST 0", b"BA 100 0\r")
    # Backspace edits the line (also a typo in the address character).
    check(b"AGAP 44\x08, 0", b"BA 100 51200\r")
    check(b"AGAP 5\x084, 0", b"BA 100 51200\r")
    check(b"ASAP 4, 0, 12x\x083", b"BA 100 123\r")
    assert term.type(b"X\x08AGAP 4, 0\r", 1 if echo == ECHO_NONE else 2) == expected(
        b"AGAP 4, 0", b"BA 100 123\r", echo)
    # DEL works like backspace; its echo in mode 00 is BS SP BS too.
    got = term.type(b"AGAP 9\x7f4, 0\r", 1 if echo == ECHO_NONE else 2)
    assert got == expected(b"AGAP 9\x084, 0", b"BA 100 123\r", echo), got
    # Echo mode 00 echoes each character at once; 01 and 10 echo nothing before the CR.
    term.write(b"AGGP 67, 0")
    if echo == ECHO_EACH:
        assert term.read_exact(len(b"AGGP 67, 0"), 2) == b"AGGP 67, 0"
    else:
        term.silence(0.15)
    assert term.type(b"\r", 1 if echo == ECHO_NONE else 2).endswith(b"BA 100 %d\r" % echo)
    check(b"ABIN", b"BA 100 0\r")
    term.silence(0.1)
    assert term.ok(1, GAP, 4, 0, 0).value == 123, "binary again, the SAP of ASCII mode in effect"


def test_echo_each_character_before_cr(term):
    """Echo mode 00 (the default): a terminal sees each character as it is typed."""
    term.enter_ascii()
    for c in b"AGAP 4, 0":
        term.write(bytes([c]))
        assert term.read_exact(1, 2) == bytes([c])
    assert term.type(b"\r", 2) == b"\rBA 100 51200\r"
    # Characters of a line for another address are not echoed.
    term.write(b"BGAP 4, 0")
    term.silence(0.15)
    term.write(b"\r")
    term.silence(0.15)


# -- start-up in ASCII mode (GP 67 bit 0) ----------------------------------------------------------

def test_start_up_in_ascii_mode_after_a_server_restart(eeprom_server):
    server = eeprom_server
    with AsciiLinePort(server.link) as term:
        term.ok(1, SGP, 67, 0, 1)  # stored automatically (RWA): no STGP
    server.restart()
    with AsciiLinePort(server.link) as term:
        assert term.type(b"AGAP 4, 0\r", 2) == b"AGAP 4, 0\rBA 100 51200\r"
        assert term.type(b"AGGP 67, 0\r", 2) == b"AGGP 67, 0\rBA 100 1\r"
        assert term.type(b"ABIN\r", 2) == b"ABIN\rBA 100 0\r"
    with pytrinamic_connection(server) as conn:
        assert conn.get_global_parameter(67, 0) == 1
        assert conn.get_version_string() == "1021V142"
    server.restart()  # bit 0 still set: ASCII again, now with echo mode 10 (bits 5/4 = 10, no echo)
    with AsciiLinePort(server.link) as term:
        assert term.type(b"ASGP 67, 0, 33\r", 2) == b"ASGP 67, 0, 33\rBA 100 33\r"
    server.restart()
    with AsciiLinePort(server.link) as term:
        assert term.type(b"AGAP 4, 0\r", 1) == b"BA 100 51200\r"
        assert term.type(b"ASGP 67, 0, 32\r", 1) == b"BA 100 32\r"  # start-up in binary again
        assert term.type(b"ABIN\r", 1) == b"BA 100 0\r"
    server.restart()
    with pytrinamic_connection(server) as conn:
        assert conn.get_global_parameter(67, 0) == 32
        assert conn.get_axis_parameter(4, 0) == 51200


def test_start_up_in_ascii_mode_after_a_software_reset_on_the_bus(serve, tmp_path):
    """Module 2 with GP 67 = 0x11 restarted by command 255: ASCII (whole-line echo) after the reset,
    and again after a restart of the server on the same EEPROM directory; 1 and 3 stay binary."""
    server = serve("pty", modules=BUS_MODULES,
                   extra=["--eeprom-dir", str(tmp_path / "eeprom")])
    with AsciiLinePort(server.link) as term:
        term.ok(2, SGP, 67, 0, 0x11)
        term.write(frame(2, 255, 0, 0, 1234))
        reply = term.reply()
        assert (reply.module, reply.status, reply.opcode) == (2, 100, 255), reply
        term.silence(0.05)
        assert term.type(b"\rBGAP 4, 0\r", 2) == b"BGAP 4, 0\rBB 100 51200\r"
        time.sleep(RESYNC_S)  # > the resync pause: the binary modules drop the text's leftover bytes
        assert term.ok(1, GAP, 4, 0, 0).value == 51200
        assert term.ok(3, GAP, 4, 0, 0).value == 51200
    server.restart()
    with AsciiLinePort(server.link) as term:
        assert term.type(b"BGGP 67, 0\r", 2) == b"BGGP 67, 0\rBB 100 17\r"
        time.sleep(RESYNC_S)
        assert term.ok(1, GGP, 67, 0, 0).value == 0
        term.write(b"\rBBIN\r")
        assert term.read_until(b"\r") == b"BBIN\r" and term.read_until(b"\r") == b"BB 100 0\r"
        time.sleep(RESYNC_S)
    with pytrinamic_connection(server, module_id=2) as conn:
        assert conn.get_global_parameter(67, 0) == 0x11
        assert conn.get_axis_parameter(4, 0) == 51200


# -- replies: host address, suppression, telegram pause --------------------------------------------

def test_reply_characters_follow_gp76_and_gp66(term):
    term.ok(1, SGP, 76, 0, 3, host=3)  # host address 3: 'C' (this reply already from it)
    term.enter_ascii(host=3)
    assert term.type(b"AGGP 76, 0\r", 2) == b"AGGP 76, 0\rCA 100 3\r"
    assert term.type(b"aGGP 66, 0\r", 2) == b"aGGP 66, 0\rCA 100 1\r", "lower-case address character"
    # A new address: the module answers to its new character at once.
    assert term.type(b"ASGP 66, 0, 4\r", 2).startswith(b"ASGP 66, 0, 4\rC")
    term.write(b"AGGP 66, 0\r")
    term.silence(0.2)
    assert term.type(b"DGGP 66, 0\r", 2) == b"DGGP 66, 0\rCD 100 4\r"
    # Its secondary address (GP 87) too; the reply names the primary address.
    assert term.type(b"DSGP 87, 0, 5\r", 2) == b"DSGP 87, 0, 5\rCD 100 5\r"
    assert term.type(b"EGGP 87, 0\r", 2) == b"EGGP 87, 0\rCD 100 5\r"
    assert term.type(b"DSGP 66, 0, 1\r", 2).startswith(b"DSGP 66, 0, 1\rC")
    assert term.type(b"ABIN\r", 2) == b"ABIN\rCA 100 0\r"


def test_suppressed_replies_in_ascii(term):
    term.ok(1, SGP, 67, 0, ECHO_NONE)
    term.enter_ascii()
    term.write(b"ASGP 255, 0, 1\r")
    term.silence(0.2)
    term.write(b"ASAP 4, 0, 1000\r")
    term.silence(0.2)
    assert term.reply_line("AGAP 4, 0") == (100, 1000)
    assert term.reply_line("AGGP 255, 0") == (100, 1)
    term.write(b"ASGP 255, 0, 0\r")
    leftover = term.read_quiet(0.2)
    assert leftover in (b"", b"BA 100 0\r"), leftover  # that SGP's own reply: unspecified
    assert term.reply_line("ASAP 4, 0, 51200") == (100, 51200)


def test_telegram_pause_in_ascii(term):
    term.ok(1, SGP, 67, 0, ECHO_NONE)
    term.ok(1, SGP, 75, 0, 20)
    term.enter_ascii()
    delays = []
    for _ in range(6):
        t0 = term.write(b"AGAP 4, 0\r")
        data, first, _ = term.read_timed(len(b"BA 100 51200\r"), 2)
        assert data == b"BA 100 51200\r"
        delays.append(first - t0)
    assert min(delays) >= 0.020, delays
    assert statistics.median(delays) < 0.030, delays


# -- RUN and STOP ----------------------------------------------------------------------------------

# A counter in user variable 7, one step every 50 ms (opcode, type, motor, value).
COUNTER = [
    (CALC, 9, 0, 0),  # 0  A = 0
    (CALC, 0, 0, 1),  # 1  Loop: A += 1
    (AGP, 7, 2, 0),   # 2  var 7 = A
    (WAIT, 0, 0, 5),  # 3  WAIT TICKS, 0, 5 (50 ms)
    (JA, 0, 0, 1),    # 4
]


def test_run_and_stop_a_downloaded_program(pty_server):
    with pytrinamic_connection(pty_server) as conn:
        conn.send(132, 0, 0, 0)  # download mode
        for opcode, kind, motor, value in COUNTER:
            assert conn.send(opcode, kind, motor, value).status == 101
        conn.send(133, 0, 0, 0)
        conn.set_global_parameter(67, 0, ECHO_NONE)
    with AsciiLinePort(pty_server.link) as term:
        term.enter_ascii()
        assert term.reply_line("AGGP 128, 0") == (100, 0), "stopped"
        assert term.reply_line("ARUN") == (100, 0)
        wait_until(lambda: term.reply_line("AGGP 7, 2")[1] >= 3, 5, what="the counter counts")
        assert term.reply_line("AGGP 128, 0") == (100, 1), "running"
        assert term.reply_line("astop") == (100, 0)
        assert term.reply_line("AGGP 128, 0") == (100, 0), "stopped"
        count = term.reply_line("AGGP 7, 2")[1]
        time.sleep(0.2)
        assert term.reply_line("AGGP 7, 2")[1] == count, "no step after STOP"
        # RUN again: on from where it stopped.
        assert term.reply_line("A RUN") == (100, 0)
        wait_until(lambda: term.reply_line("AGGP 7, 2")[1] >= count + 2, 5, what="counting on")
        assert term.reply_line("ASTOP") == (100, 0)
        assert term.reply_line("ABIN") == (100, 0)
        assert term.ok(1, GGP, 128, 0, 0).value == 0


# -- malformed lines -------------------------------------------------------------------------------

# (line, status): 2 invalid command / unknown mnemonic, 3 bad type word, 4 bad value or operand,
# 6 not available in ASCII mode (§3.4: only direct-mode commands of its list).
MALFORMED = [
    ("A", 2),
    ("A   ", 2),
    ("AFOO 1", 2),
    ("AGAPX 4, 0", 2),
    ("A139", 2),
    ("AGAP " + "1" * 80, 2),  # longer than the line buffer
    ("AMVP SIDEWAYS, 0, 1", 3),
    ("AGAP", 4),
    ("AGAP x, 0", 4),
    ("AGAP 4,, 0", 4),
    ("AMVP ABS, 0", 4),
    ("ASAP 4, 0, 0", 4),  # out of range (1 … 2147483647)
    ("ASAP 4, 0, 99999999999", 4),
    ("ASAP 300, 0, 1", 4),
    ("AROR 1, 100", 4),  # no motor 1
    ("ACALC ADD, 7", 6),
    ("AJA 0", 6),
    ("AWAIT TICKS, 0, 5", 6),
    ("ASTOP 1", 4),  # the program instruction STOP takes no operand
]


def test_every_malformed_line_is_answered(term):
    term.ok(1, SGP, 67, 0, ECHO_NONE)
    term.enter_ascii()
    for line, status in MALFORMED:
        got, _ = term.reply_line(line)
        assert got == status, line
    assert term.reply_line("AGAP 4, 0") == (100, 51200), "still in step"
    term.silence(0.1)


def test_random_lines_are_all_answered(term):
    """Seeded random lines to address A: every one gets exactly one reply line, in bounded time."""
    term.ok(1, SGP, 67, 0, ECHO_NONE)
    term.enter_ascii()
    rng = random.Random(4)
    # Printable text and TAB only: a control byte or one above 0x7F discards the line (see the next test).
    junk = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcxyz0123456789 ,-+$%#_.:;()[]\t"
    readers = ["GAP", "GGP", "GIO", "GCO", "CALC", "JA", "WAIT", "RSAP", "XYZ", ""]
    lines = 0
    for _ in range(300):
        text = rng.choice(readers) + "".join(rng.choice(junk) for _ in range(rng.randrange(0, 30)))
        if text.strip().upper() in ("BIN", "RUN", "STOP"):
            continue
        status, _ = term.reply_line("A" + text)
        assert status in (2, 3, 4, 6, 100), text
        lines += 1
    assert lines > 250
    assert term.reply_line("AGAP 4, 0") == (100, 51200)
    assert term.reply_line("AGGP 67, 0") == (100, ECHO_NONE)


def test_binary_bytes_and_esc_discard_the_line(term):
    term.ok(1, SGP, 67, 0, ECHO_NONE)
    term.enter_ascii()
    for line in (b"A\x01\x02\x03\r", b"A\xff\xfe\r"):  # discarded at the first byte: the CR ends nothing
        term.write(line)
        term.silence(0.1)
    for breaker in (b"\x00", b"\x01", b"\x1b", b"\x80", b"\xfe"):
        term.write(b"AGAP 4" + breaker + b", 0\r")  # the rest, ", 0", is a line for the address ','
        term.silence(0.1)
        assert term.reply_line("AGAP 4, 0") == (100, 51200), breaker


# -- back to binary after binary bytes (the issue a user met in a terminal) -----------------------

def test_abin_after_binary_frames(term, pty_server):
    """A host sends binary frames to a module it does not know is in ASCII mode; they get no answer.
    `ABIN` typed after them brings the module back: the frames left no partial line in front of it."""
    term.enter_ascii()
    for opcode, kind, value in ((136, 0, 0), (GAP, 4, 0), (GAP, 1, 0), (SAP, 4, 0x0D424741)):
        term.write(frame(1, opcode, kind, 0, value))
    term.silence(0.3)
    assert term.type(b"ABIN\r", 2) == b"ABIN\rBA 100 0\r"
    term.silence(0.1)
    with pytrinamic_connection(pty_server) as conn:
        assert conn.get_version_string() == "1021V142"


def test_abin_after_a_frame_ending_in_printable_bytes(term):
    """GAP 4 with value 0x36 ends in '6' and the checksum 'A': a line for the address '6' that swallows
    the first `ABIN`. Its CR ends that line; `ABIN` again, or CR or ESC before it, works."""
    request = frame(1, GAP, 4, 0, 0x36)
    assert request[7:] == b"6A"
    term.enter_ascii()
    term.write(request)
    term.write(b"ABIN\r")
    term.silence(0.3)
    assert term.type(b"ABIN\r", 2) == b"ABIN\rBA 100 0\r"
    term.silence(0.1)
    for clear in (b"\r", b"\x1b"):
        term.enter_ascii()
        term.write(request + clear)
        term.silence(0.1)
        assert term.type(b"ABIN\r", 2) == b"ABIN\rBA 100 0\r", clear
        term.silence(0.1)
        assert term.ok(1, GAP, 4, 0, 0).value == 51200


def test_lines_for_other_addresses_are_ignored(term):
    term.enter_ascii()
    for line in (b"BGAP 4, 0\r", b"ZBIN\r", b"@GAP 4, 0\r", b"1GAP 4, 0\r", b"\r", b"\n\r", b" AGAP 4, 0\r"):
        term.write(line)
        term.silence(0.1)
    assert term.type(b"AGAP 4, 0\r", 2) == b"AGAP 4, 0\rBA 100 51200\r"
    # LF is ignored: CR LF line ends work.
    assert term.type(b"AGAP 4, 0\r\n", 2) == b"AGAP 4, 0\rBA 100 51200\r"
    term.silence(0.1)


# -- an ASCII module on a line with binary modules -------------------------------------------------

def test_ascii_module_on_a_shared_line(bus_server):
    with AsciiLinePort(bus_server.link) as term:
        term.enter_ascii(2)
        # Binary traffic to modules 1 and 3 with pytrinamic: each request one whole reply, nothing else.
        conn = SerialTmclInterface(term.ser)
        term.ser.timeout = 5
        for i in range(20):
            for a in (1, 3):
                conn.set_axis_parameter(4, 0, 1000 + 10 * i + a, module_id=a)
                assert conn.get_axis_parameter(4, 0, module_id=a) == 1000 + 10 * i + a
                assert conn.get_version_string(module_id=a) == "1021V142"
        term.ser.timeout = 0
        term.silence(0.1)
        # The last frame's checksum (0x8B) discarded the line those frames left in module 2's buffer:
        # an ASCII line typed now is answered. Echo mode 00: the line, then the reply with module
        # character B. (A frame that ends in printable bytes would leave them in the way: CR first.)
        assert term.type(b"BGAP 4, 0\r", 2) == b"BGAP 4, 0\rBB 100 51200\r"
        time.sleep(RESYNC_S)  # > the resync pause: modules 1 and 3 drop the text's incomplete frame
        assert term.ok(1, GAP, 4, 0, 0).value == 1191
        assert term.ok(3, GAP, 4, 0, 0).value == 1193
        # An ASCII line and a binary frame in one write: module 2 answers its line; the binary modules
        # read the text plus the frame as misaligned 9-byte frames for foreign addresses and stay silent.
        term.write(b"\rBGGP 66, 0\r" + frame(1, GAP, 4, 0, 0))
        assert term.read_quiet(0.2) == b"BGGP 66, 0\rBB 100 2\r"
        time.sleep(RESYNC_S)
        assert term.ok(1, GAP, 4, 0, 0).value == 1191
        # A binary frame whose value holds CR 'B' 'G' 'A' starts a line for module 2: it echoes 'B',
        # 'G', 'A' (stray bytes for a binary host) ...
        request = frame(1, SAP, 4, 0, 0x0D424741)
        assert request[8] >= 0x80
        term.write(request)
        got = term.read_quiet(0.2)
        reply = bytes([2, 1, 100, SAP, 0x0D, 0x42, 0x47, 0x41])
        reply += bytes([sum(reply) & 0xFF])
        assert reply in got and got.replace(reply, b"", 1) == b"BGA", got.hex(" ")
        # ... until the checksum byte (above 0x7F) discards that line: the next CR is a line for nobody.
        term.write(b"\r")
        term.silence(0.2)
        # Back to binary: all three answer pytrinamic again.
        assert term.type(b"BBIN\r", 2) == b"BBIN\rBB 100 0\r"
        time.sleep(RESYNC_S)
    with pytrinamic_connection(bus_server) as conn:
        for a in (1, 2, 3):
            assert conn.get_global_parameter(66, 0, module_id=a) == a
            assert conn.get_version_string(module_id=a) == "1021V142"


def test_two_modules_in_ascii_mode(bus_server):
    """Modules 1 and 3 in ASCII mode (no echo) on one line: each answers its character only."""
    with AsciiLinePort(bus_server.link) as term:
        for a in (1, 3):
            term.ok(a, SGP, 67, 0, ECHO_NONE)
            term.ok(a, SAP, 4, 0, 1000 * a)
            term.enter_ascii(a)
        assert term.reply_line("\rAGAP 4, 0") == (100, 1000)
        assert term.reply_line("CGAP 4, 0", module="C") == (100, 3000)
        term.write(b"BGAP 4, 0\r")  # module 2 is binary: a frame for address 'B' (66) and a CR
        term.silence(0.2)
        assert term.reply_line("AGGP 66, 0") == (100, 1)
        assert term.reply_line("CGGP 66, 0", module="C") == (100, 3)
        for c in "AC":
            assert term.reply_line(f"{c}BIN", module=c) == (100, 0)
        time.sleep(RESYNC_S)
        for a in (1, 2, 3):
            assert term.request(a, GGP, 66, 0, 0).value == a

"""Standalone programs through `tmcl serve`: downloaded with pytrinamic's raw `send` (commands 132/133,
each stored command answered with status 101), run with command 129, their effect read with GGP/GAP, and
read back with command 134 as pytrinamic's `tmcl_read_script` example does (the manual gives no reply format
for 134; that example expects `[host, opcode, type, motor, value (4 bytes), checksum]`)."""

import subprocess

from tmcltest import pytrinamic_connection, wait_until

# Opcodes (PD28-1021 manual Table 5, §3.7.38).
SAP, GAP, SGP, GGP, MVP, WAIT, JA, CALC, AGP, STOP, SIO = 5, 6, 9, 10, 4, 27, 22, 19, 35, 28, 14
RUN, STEP, RESET, DOWNLOAD, QUIT_DOWNLOAD, READ_MEMORY, STATUS = 129, 130, 131, 132, 133, 134, 135
STATUS_LOADED = 101

# The §2.4 program's move loop, then a counter in user variable 7 (opcode, type, motor, value).
PROGRAM = [
    (SAP, 4, 0, 51200),          # 0
    (SAP, 5, 0, 51200),          # 1
    (CALC, 9, 0, 0),             # 2  A = 0
    (CALC, 0, 0, 1),             # 3  Loop: A += 1
    (AGP, 7, 2, 0),              # 4  var 7 = A
    (MVP, 0, 0, 25600),          # 5
    (WAIT, 1, 0, 0),             # 6  WAIT POS
    (MVP, 0, 0, -25600),         # 7
    (WAIT, 1, 0, 0),             # 8
    (JA, 0, 0, 3),               # 9
]


def download(bus, program, start=0):
    bus.send(DOWNLOAD, 0, 0, start)
    for opcode, kind, motor, value in program:
        reply = bus.send(opcode, kind, motor, value)
        assert reply.status == STATUS_LOADED, reply
    bus.send(QUIT_DOWNLOAD, 0, 0, 0)


def test_download_run_and_read_effects(pty_server):
    with pytrinamic_connection(pty_server) as bus:
        download(bus, PROGRAM)
        assert bus.get_global_parameter(129, 0) == 0, "download mode left"
        bus.send(RUN, 1, 0, 0)
        assert bus.get_global_parameter(128, 0) == 1, "running"
        # Each loop is two moves of 25600 µsteps (about 1.4 s each): the counter goes up.
        wait_until(lambda: bus.get_global_parameter(7, 2) >= 2, 10, what="two loops")
        # Direct mode works beside the program and does not disturb it.
        assert bus.get_axis_parameter(4, 0) == 51200
        position = bus.get_axis_parameter(1, 0, signed=True)
        assert -25600 <= position <= 25600
        bus.send(128, 0, 0, 0)
        assert bus.get_global_parameter(128, 0) == 0


def test_read_back_like_tmcl_read_script(pty_server):
    with pytrinamic_connection(pty_server) as bus:
        download(bus, PROGRAM)
        cells = []
        for address in range(64):
            reply = bus.send(READ_MEMORY, 0, 0, address)
            raw = reply.to_buffer()  # host, opcode, type, motor, value, checksum
            if raw[1] == 0:
                break
            cells.append((raw[1], raw[2], raw[3], int.from_bytes(raw[4:8], "big", signed=True)))
        assert cells == PROGRAM


def test_program_survives_a_restart_and_auto_starts(eeprom_server):
    with pytrinamic_connection(eeprom_server) as bus:
        download(bus, PROGRAM)
        bus.set_global_parameter(77, 0, 1)  # auto start (stored automatically)
    eeprom_server.restart()
    with pytrinamic_connection(eeprom_server) as bus:
        assert bus.get_global_parameter(128, 0) == 1, "auto-started from the EEPROM"
        wait_until(lambda: bus.get_global_parameter(7, 2) >= 1, 10, what="the program's counter")


def test_protection_refuses_read_back(pty_server):
    with pytrinamic_connection(pty_server) as bus:
        download(bus, PROGRAM)
        bus.set_global_parameter(81, 0, 1)
        # pytrinamic never raises for 134 (its "status" byte carries data): look at the bytes. A refusal
        # is a normal reply: module address, status 6 (command not available), opcode 134.
        raw = bus.send(READ_MEMORY, 0, 0, 0).to_buffer()
        assert (raw[1], raw[2], raw[3]) == (1, 6, READ_MEMORY), raw.hex(" ")


def test_tmcl_cli_download_upload_start_status(pty_server, tmcl_bin, tmp_path):
    source = tmp_path / "loop.tmc"
    source.write_text(
        "#include TMCLParam.tmc\n"
        "SAP APMaxPositioningSpeed, Motor0, 51200\n"
        "Count = 9\n"
        "Start:\n"
        "CALC ADD, 1\n"
        "AGP Count, 2\n"
        "WAIT TICKS, 0, 5\n"
        "JA Start\n"
    )
    port = ["--port", str(pty_server.link)]

    def tmcl(*args):
        return subprocess.run([str(tmcl_bin), *port, *args], capture_output=True, text=True, timeout=30)

    done = tmcl("download", str(source), "--verify")
    assert done.returncode == 0, done.stderr
    assert "stored 5 instructions" in done.stdout
    listing = tmcl("upload")
    assert listing.returncode == 0 and "AGP 9, 2" in listing.stdout, listing.stdout
    assert tmcl("start", "--at", "Start", "--program", str(source)).returncode == 0
    status = tmcl("--json", "status")
    assert '"mode":1' in status.stdout, status.stdout
    with pytrinamic_connection(pty_server) as bus:
        wait_until(lambda: bus.get_global_parameter(9, 2) >= 3, 5, what="the counter")
    assert tmcl("stop").returncode == 0

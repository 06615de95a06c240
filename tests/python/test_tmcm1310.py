"""A virtual TMCM-1310 (`tmcl serve --module tmcm-1310 --pty LINK`) driven by unchanged host software:
pytrinamic's serial TMCL connection (`--interface serial_tmcl --port LINK`, the module's USB interface,
TMCM-1310 manual chapter 4), its `TMCM1311` module class, raw frames and the ASCII interface (§5) with
pyserial, and the `tmcl` CLI's checks of the 1024-command program memory (§1).

pytrinamic has no TMCM-1310 class. Its `TMCM1311` (the same closed-loop family, with RS485/CAN instead of
EtherCAT) agrees with the TMCM-1310 model on:
- the axis parameters of its table except those listed in `AP_1311_NOT_1310` (motion: 0–13, the
  closed-loop set 14–29, 108–138, the TMC262 chopper and smartEnergy/stallGuard2 parameters 162–178,
  180–184, reference search 193–196, encoder and driver 200–237, microsteps 140);
- `move_to`, `move_by`, `rotate`, `stop`, `motors[0].get_position_reached()`, the `linear_ramp`
  (max velocity AP 4, max acceleration AP 5) and `drive_settings` (max current AP 6, standby AP 7,
  boost AP 200, microstep resolution AP 140) features;
- bank 3 (`GP3`: timers 0–2, stop switches 27/28, inputs 39–46) and the 8 inputs/8 outputs of `IO`.

Where it differs:
- axis parameters the TMCM-1311 has and the 1310 lacks (status 3): AP 15 (maximum possible current),
  135 (position reached time), 141 (torque mode start/stop current), 151–155 (phase currents, supply
  voltage, DC current, temperature), 179 (VSense: the 1310's current range is fixed), 254 (step/dir mode);
- bank 0 (`GP0`): the RS485 and CAN settings GP 65, 68, 69, 70, 71, 75, 83, 87, 88 (status 3); the
  1310 has GP 67 (ASCII mode, §5.4) and GP 200 (the password) which the class does not name;
- the `stallguard2` filter/threshold and `coolstep` minimum current/up/down step properties: the class's
  AP table spells them `StallGuard2FilterEnable`/`SmartEnergyCurrentMinimum`…, the features look up
  `SG2FilterEnable`/`SEIMIN`… (an AttributeError in pytrinamic itself, whatever the module);
- pytrinamic's `TMCLStatus.messages` has no text for status 8 (§3.7 "parameter is password protected"):
  `TMCLReplyStatusError.status_code` is 8, `error_description` raises KeyError.
"""

from __future__ import annotations

import re
import subprocess

import pytest
from pytrinamic.connections import ConnectionManager
from pytrinamic.modules import TMCM1311
from pytrinamic.tmcl import TMCLReplyStatusError

from tmcltest import LinePort, frame, wait_until

STATUS_WRONG_TYPE = 3
STATUS_INVALID_VALUE = 4
STATUS_PASSWORD = 8
PASSWORD = 4321  # GP 200 (tmcm_1310.rs's decision)
PROTECTED = {25: 3000, 26: 0, 112: 0}  # AP: default

AP_1311_NOT_1310 = {15, 135, 141, 151, 152, 153, 154, 155, 179, 254}
GP_1311_NOT_1310 = {65, 68, 69, 70, 71, 75, 83, 87, 88}
# AP 29 (clear I2t exceeded flag) is write-only in the TMCM-1310 model: GAP answers 3.
AP_WRITE_ONLY = {29}

ENTER_ASCII = 139
REPLY_RE = re.compile(rb"^([A-Z])([A-Z]) (\d+) (-?\d+)\r$")


@pytest.fixture
def conn(tmcm1310_server):
    c = ConnectionManager(f"--interface serial_tmcl --port {tmcm1310_server.link}").connect()
    try:
        yield c
    finally:
        c.close()


@pytest.fixture
def module(conn):
    return TMCM1311(conn)


@pytest.fixture
def motor(module):
    assert len(module.motors) == 1
    return module.motors[0]


def table(cls) -> dict[str, int]:
    return {name: number for name, number in vars(cls).items() if not name.startswith("_")}


def status_of(call) -> int:
    with pytest.raises(TMCLReplyStatusError) as err:
        call()
    return err.value.status_code


# -- identity ----------------------------------------------------------------------------------------

def test_version(conn):
    assert conn.get_version_string() == "1310V114"
    # 136 type 1: 1310 = 0x051E, then 1.14.
    assert conn.send(136, 1, 0, 0).value == 0x051E010E


def test_any_address_byte_is_answered_on_usb(tmcm1310_server):
    # USB has one module: every address byte is answered, the reply names module 1 and host 2.
    with LinePort(tmcm1310_server.link) as port:
        for address in (1, 5, 0, 200):
            reply = port.request(address, 6, 4, 0, 0)
            assert reply.checksum_ok, reply
            assert (reply.host, reply.module, reply.status, reply.value) == (2, 1, 100, 51200), reply
        # MVP ABS, 1, 50000: no motor 1 (status 4).
        port.write(bytes.fromhex("01 04 00 01 00 00 C3 50 19"))
        assert port.read_exact(9) == bytes.fromhex("02 01 04 04 00 00 C3 50 1E")
        # A wrong checksum: status 1.
        port.write(bytes.fromhex("01 06 00 00 00 00 00 00 00"))
        assert port.read_exact(9) == bytes.fromhex("02 01 01 00 00 00 00 00 04")
        # 136 type 0: host address and the 8 characters.
        port.write(frame(1, 136, 0, 0, 0))
        assert port.read_exact(9) == b"\x021310V114"


# -- the TMCM1311 class ------------------------------------------------------------------------------

def test_tmcm1311_axis_parameters_that_agree(motor):
    aps = table(motor.AP)
    missing = {number for number in aps.values() if number in AP_1311_NOT_1310}
    assert missing == AP_1311_NOT_1310, "the class still lists them"
    for name, number in aps.items():
        if number in AP_1311_NOT_1310 or number in AP_WRITE_ONLY:
            assert status_of(lambda: motor.get_axis_parameter(number)) == STATUS_WRONG_TYPE, name
        else:
            value = motor.get_axis_parameter(number, signed=True)
            assert -(2**31) <= value < 2**31, name
    assert motor.get_axis_parameter(motor.AP.MicrostepResolution) == motor.ENUM.MicrostepResolution256Microsteps
    assert motor.get_axis_parameter(motor.AP.PositionReachedFlag) == 1
    assert motor.get_axis_parameter(motor.AP.FullstepResolution) == 200
    assert motor.get_axis_parameter(motor.AP.EncoderResolution) == 4096


def test_tmcm1311_linear_ramp_and_drive_settings(motor):
    ramp, drive = motor.linear_ramp, motor.drive_settings
    assert (ramp.max_velocity, ramp.max_acceleration) == (51200, 51200)
    assert (drive.max_current, drive.standby_current, drive.boost_current) == (128, 32, 0)
    ramp.max_velocity = 204800
    ramp.max_acceleration = 409600
    drive.max_current = 200
    drive.standby_current = 16
    drive.microstep_resolution = motor.ENUM.MicrostepResolution16Microsteps
    assert motor.get_axis_parameter(4) == 204800
    assert motor.get_axis_parameter(5) == 409600
    assert motor.get_axis_parameter(6) == 200
    assert motor.get_axis_parameter(7) == 16
    assert motor.get_axis_parameter(140) == 4
    # The 1310 has no current range switch: a current above 255 is out of range.
    assert status_of(lambda: motor.set_axis_parameter(motor.AP.MaxCurrent, 256)) == STATUS_INVALID_VALUE


def test_tmcm1311_move_rotate_stop(module, motor):
    motor.linear_ramp.max_acceleration = 512000
    module.move_to(0, 51200, velocity=102400)
    assert motor.target_position == 51200
    wait_until(lambda: motor.get_position_reached() == 1 and motor.actual_position == 51200, 5,
               what="the move to 51200")
    module.move_by(0, -25600)
    wait_until(lambda: motor.actual_position == 25600, 5, what="the move by -25600")
    module.rotate(0, -25600)
    wait_until(lambda: motor.actual_velocity == -25600, 3, what="AP 3 = -25600")
    assert motor.target_velocity == -25600
    module.stop(0)
    wait_until(lambda: motor.actual_velocity == 0, 3, what="standstill")
    p = motor.actual_position
    assert p < 25600
    assert motor.actual_position == p


def test_tmcm1311_global_parameters(module, conn):
    gp0 = table(module.GP0)
    for name, number in gp0.items():
        if number in GP_1311_NOT_1310:
            assert status_of(lambda: conn.get_global_parameter(number, 0)) == STATUS_WRONG_TYPE, name
        else:
            conn.get_global_parameter(number, 0)
    assert conn.get_global_parameter(module.GP0.serialAddress, 0) == 1
    assert conn.get_global_parameter(module.GP0.serialHostAddress, 0) == 2
    for name, number in table(module.GP3).items():
        assert conn.get_global_parameter(number, 3) == 0, name
    conn.set_global_parameter(module.GP3.input_7, 3, 3)
    assert conn.get_global_parameter(module.GP3.input_7, 3) == 3
    assert status_of(lambda: conn.set_global_parameter(module.GP3.input_7, 3, 4)) == STATUS_INVALID_VALUE
    # Bank 2: 256 user variables.
    conn.set_global_parameter(255, 2, -99)
    assert conn.get_global_parameter(255, 2, signed=True) == -99


def test_tmcm1311_io(module, conn):
    for out in range(8):
        conn.set_digital_output(out)
        assert conn.get_digital_output(out) == 1
        conn.clear_digital_output(out)
        assert conn.get_digital_output(out) == 0
    for inp in range(8):
        assert conn.get_digital_input(inp) in (0, 1)
    for channel in (0, 1):
        assert 0 <= conn.get_analog_input(channel) <= 4095
    assert status_of(lambda: conn.get_analog_input(2)) == STATUS_WRONG_TYPE


# -- status 8: the password GP 200 ---------------------------------------------------------------------

def test_password_protection(motor, conn):
    assert conn.get_global_parameter(200, 0) == 0
    for number, default in PROTECTED.items():
        assert motor.get_axis_parameter(number) == default, "reading is never protected"
        assert status_of(lambda: motor.set_axis_parameter(number, 500)) == STATUS_PASSWORD
        assert status_of(lambda: conn.send(7, number, 0, 0)) == STATUS_PASSWORD  # STAP
        assert motor.get_axis_parameter(number) == default
    assert status_of(lambda: motor.set_axis_parameter(motor.AP.ThermalWindingTimeConstant, 500)) == 8
    conn.set_global_parameter(200, 0, 1111)
    assert conn.get_global_parameter(200, 0) == 0
    conn.set_global_parameter(200, 0, PASSWORD)
    assert conn.get_global_parameter(200, 0) == 1
    for number in PROTECTED:
        motor.set_axis_parameter(number, 500)
        assert motor.get_axis_parameter(number) == 500
        conn.send(7, number, 0, 0)
    # Command 255 restarts the module: locked again, the stored values kept.
    assert conn.send(255, 0, 0, 1234).status == 100
    assert conn.get_global_parameter(200, 0) == 0
    assert motor.get_axis_parameter(motor.AP.CLEncoderOffset) == 500
    assert status_of(lambda: motor.set_axis_parameter(motor.AP.CLEncoderOffset, 1)) == STATUS_PASSWORD


# -- ASCII over the pty (§5) ---------------------------------------------------------------------------

class Terminal(LinePort):
    def type(self, line: str, crs: int = 2) -> bytes:
        """A line in echo mode 00 (§5.4): the echo ends with CR, then the reply line."""
        self.write(line.encode() + b"\r")
        return b"".join(self.read_until(b"\r") for _ in range(crs))


def test_ascii_over_usb(tmcm1310_server):
    with Terminal(tmcm1310_server.link) as term:
        reply = term.request(1, ENTER_ASCII, 0, 0, 0)
        assert (reply.host, reply.module, reply.status, reply.opcode) == (2, 1, 100, ENTER_ASCII), reply
        assert term.type("AGAP 1, 0") == b"AGAP 1, 0\rBA 100 0\r"
        assert term.type("ASAP 1, 0, 5000") == b"ASAP 1, 0, 5000\rBA 100 5000\r"
        # §5.2's example reply for the actual position 5000, host address 2, module address 1.
        assert term.type("AGAP 1, 0") == b"AGAP 1, 0\rBA 100 5000\r"
        assert term.type("AMVP ABS, 1, 50000") == b"AMVP ABS, 1, 50000\rBA 4 50000\r"
        assert term.type("A MVP ABS, 0, 6000") == b"A MVP ABS, 0, 6000\rBA 100 6000\r"
        assert term.type("ASAP 25, 0, 500") == b"ASAP 25, 0, 500\rBA 8 500\r"
        assert term.type("ACALC ADD, 1") == b"ACALC ADD, 1\rBA 6 1\r"
        # No echo (GP 67 bit 5): only the replies.
        assert term.type("ASGP 67, 0, 32") == b"ASGP 67, 0, 32\rBA 100 32\r"
        term.write(b"AGGP 200, 0\r")
        m = REPLY_RE.match(term.read_until(b"\r"))
        assert m and m.groups() == (b"B", b"A", b"100", b"0"), m
        term.write(b"ABIN\r")
        assert term.read_until(b"\r") == b"BA 100 0\r"
        # Binary again: GAP 0, the target position.
        reply = term.request(1, 6, 0, 0, 0)
        assert (reply.status, reply.value) == (100, 6000), reply


# -- the models alike --------------------------------------------------------------------------------

def test_shared_calls_alike(model_server):
    """The same pytrinamic calls give the same answers on the PD28-1021 and the TMCM-1310."""
    c = ConnectionManager(f"--interface serial_tmcl --port {model_server.link}").connect()
    try:
        version = c.get_version_string()
        assert version == {"pd28-1021": "1021V142", "tmcm-1310": "1310V114"}[model_server.modules[0]]
        for number, value in ((4, 100000), (5, 200000), (6, 100)):
            c.set_axis_parameter(number, 0, value)
            assert c.get_axis_parameter(number, 0) == value
        c.move_to(0, 25600)
        wait_until(lambda: c.get_axis_parameter(1, 0, signed=True) == 25600, 5, what="the move")
        assert c.get_axis_parameter(8, 0) == 1
        c.set_global_parameter(10, 2, -77)
        c.send(11, 10, 2, 0)  # STGP
        c.set_global_parameter(10, 2, 5)
        c.send(12, 10, 2, 0)  # RSGP
        assert c.get_global_parameter(10, 2, signed=True) == -77
        assert c.send(30, 1, 0, 4321).value == 4321  # SCO
        assert c.send(31, 1, 0, 0).value == 4321  # GCO
        assert c.send(19, 9, 0, 6).value == 6  # CALC LOAD
        assert status_of(lambda: c.send(19, 3, 0, 0)) == STATUS_INVALID_VALUE  # CALC DIV, 0
        assert status_of(lambda: c.get_axis_parameter(1, 1)) == STATUS_INVALID_VALUE  # no motor 1
    finally:
        c.close()


# -- program memory: 1024 commands ---------------------------------------------------------------------

def tmcl(tmcl_bin, *args, timeout=60):
    return subprocess.run([str(tmcl_bin), *args], capture_output=True, text=True, timeout=timeout,
                          stdin=subprocess.DEVNULL)


def program(tmp_path, n: int):
    """n instructions: n - 1 × CALC ADD, 1 and a STOP."""
    path = tmp_path / f"p{n}.tmc"
    path.write_text("CALC ADD, 1\n" * (n - 1) + "STOP\n")
    return path


def test_assembler_checks_the_1310(tmcl_bin, tmp_path):
    r = tmcl(tmcl_bin, "asm", "--module", "tmcm-1310", str(program(tmp_path, 1024)))
    assert r.returncode == 0, r.stderr
    assert "warning" not in r.stderr
    # 1025 instructions: written, with a warning that they do not fit.
    r = tmcl(tmcl_bin, "asm", "--module", "tmcm-1310", str(program(tmp_path, 1025)))
    assert r.returncode == 0, r.stderr
    assert "1025 instructions do not fit the TMCM-1310's program memory of 1024" in r.stderr
    # The same 1025 fit the PD28-1021's 2048.
    r = tmcl(tmcl_bin, "asm", "--module", "pd28-1021", str(program(tmp_path, 1025)))
    assert r.returncode == 0 and "warning" not in r.stderr, r.stderr
    # SAC is no TMCM-1310 command.
    sac = tmp_path / "sac.tmc"
    sac.write_text("SAC 0, 1, 5\nSTOP\n")
    r = tmcl(tmcl_bin, "asm", "--module", "tmcm-1310", str(sac))
    assert r.returncode != 0
    assert "`SAC` is not a command of the TMCM-1310" in r.stderr
    # A simulated run refuses a program that does not fit.
    r = tmcl(tmcl_bin, "run", "--module", "tmcm-1310", "--for", "0.1", str(program(tmp_path, 1025)))
    assert r.returncode != 0
    assert "do not fit" in r.stderr
    r = tmcl(tmcl_bin, "run", "--module", "tmcm-1310", "--for", "0.1", str(program(tmp_path, 1024)))
    assert r.returncode == 0, r.stderr


def test_download_of_1024_commands(tmcl_bin, tmcm1310_server, tmp_path):
    link = str(tmcm1310_server.link)
    r = tmcl(tmcl_bin, "--port", link, "download", "--verify", str(program(tmp_path, 1024)))
    assert r.returncode == 0, r.stderr
    assert "stored 1024 instructions at 0..1024" in r.stdout


def test_download_of_1025_commands_is_refused(tmcl_bin, tmcm1310_server, tmp_path):
    link = str(tmcm1310_server.link)
    r = tmcl(tmcl_bin, "--port", link, "download", str(program(tmp_path, 1025)))
    assert r.returncode == 1, (r.stdout, r.stderr)


# -- closed loop (pytrinamic's TMCM-1311 closed-loop demo) ---------------------------------------------

def test_closed_loop_demo_sequence(module, motor):
    """The TMCM-1311 demo's enable sequence: encoder initialisation (AP 132 := 1, until it reads 2), then
    closed loop on (AP 129 := 1, until the init flag AP 133 reads 1); then a move of one revolution ends
    at its target, and the encoder position (AP 209) moved one revolution with it."""
    assert motor.get_axis_parameter(motor.AP.CLInitFlag) == 0
    motor.set_axis_parameter(motor.AP.EncoderInitialization, 1)
    wait_until(lambda: motor.get_axis_parameter(motor.AP.EncoderInitialization) == 2, 5,
               what="AP 132 = 2 (encoder initialised)")
    motor.set_axis_parameter(motor.AP.ClosedLoopMode, 1)
    wait_until(lambda: motor.get_axis_parameter(motor.AP.CLInitFlag) == 1, 5, what="AP 133 = 1 (closed loop)")
    start = motor.actual_position
    encoder = motor.get_axis_parameter(motor.AP.EncoderPosition, signed=True)
    module.move_to(0, start + 51200, velocity=51200)
    wait_until(lambda: motor.get_position_reached() == 1 and motor.actual_position == start + 51200, 5,
               what="the closed-loop move")
    # AP 209 in microsteps: the encoder's 4096 counts per revolution (AP 210) scaled to the motor's
    # 200 full steps × 256 (AP 202, AP 140); one count is 12.5 microsteps.
    moved = motor.get_axis_parameter(motor.AP.EncoderPosition, signed=True) - encoder
    assert abs(moved - 51200) <= 64, f"one revolution is 51200 microsteps, the encoder moved {moved}"

"""A virtual TMCM-1140 (`tmcl serve --module tmcm-1140 --pty LINK`) driven by unchanged host software:
pytrinamic's serial TMCL connection and its `TMCM1140` module class over the module's USB port, which
answers every address, and the same module on an RS485 line beside a PD28-1021 (`--interface rs485`).

What the class drives, as on the real module (TMCM-1140 TMCL firmware manual V1.27, docs/tmcm-1140.md):
- every axis parameter of `TMCM1140._MotorTypeA.AP` but the three the model does not provide (AP 135,
  the TMC429's actual acceleration; AP 216–218, an external encoder): those answer status 3;
- velocities and accelerations in TMC429 units (0…2047, scaled by the pulse and ramp divisors AP 154 and
  153), 24-bit positions;
- `rotate`, `stop`, `move_to`, `move_by`, `get_position_reached`, the `drive_settings`, `linear_ramp`,
  `stallguard2` and `coolstep` features, the examples of pytrinamic's `examples/modules/TMCM1140/TMCL`
  (rotate, stallGuard2 stop) without their waits;
- the reference search (RFS, pytrinamic's `reference_search`) on a stage with switches, GIO/SIO on the
  banks of the class's `IO` (IN0–IN3, analog IN0, OUT0/OUT1), bank 0 (`GP0`) and bank 3 (`GP3`);
- the version as odemis reads it (command 136 type 1: the module number in the high word).
"""

from __future__ import annotations

import pytest
from pytrinamic.modules import TMCM1021, TMCM1140
from pytrinamic.tmcl import TMCLReplyStatusError

from tmcltest import LinePort, frame, pytrinamic_connection, wait_until

STATUS_WRONG_TYPE = 3
NOT_PROVIDED = {135, 216, 217, 218}

# A 20 mm stage on a 2 mm lead (1 mm = 25 600 µsteps at 256 microsteps), the carriage at 0.5 mm, the
# left switch from the end stop to 0 mm, the right one from 18 mm, the home flag at 10 mm, and the
# inputs IN1 and IN3 high, the analog input at 3000.
STAGE = """
[axis]
kind = "linear"
lead = 2.0
travel = [-2.0, 20.0]
start = 0.5

[switches.left]
at = [-2.0, 0.0]

[switches.right]
at = [18.0, 20.0]

[switches.home]
at = [9.9, 10.1]

[inputs]
digital = 10
analog = 3000
"""

# A shaft that seizes half a revolution from where it starts (for stallGuard2's stop on stall).
SEIZED = """
[[faults.stall]]
at = "0.5 rev"
"""


def serve_1140(serve, tmp_path, world: str | None = None, extra: list[str] | None = None, modules=None):
    args = list(extra or [])
    if world is not None:
        path = tmp_path / "world.toml"
        path.write_text(world)
        args += ["--world", str(path)]
    return serve("pty", modules=modules or ["tmcm-1140"], extra=args)


@pytest.fixture
def server(serve, tmp_path):
    return serve_1140(serve, tmp_path)


@pytest.fixture
def module(server):
    with pytrinamic_connection(server) as conn:
        yield TMCM1140(conn)


@pytest.fixture
def motor(module):
    assert len(module.motors) == 1
    return module.motors[0]


def table(cls) -> dict[str, int]:
    return {name: number for name, number in vars(cls).items() if not name.startswith("_")}


def status_of(call) -> int:
    with pytest.raises(TMCLReplyStatusError) as info:
        call()
    return info.value.status_code


def test_version_as_odemis_and_pytrinamic_read_it(module):
    conn = module.connection
    assert conn.get_version_string() == "1140V127"
    value = conn.send(136, 1, 0, 0).value
    assert value == 0x0474011B
    # odemis' TMCLController.GetVersion: model = value >> 16, major and minor in the low bytes.
    assert (value >> 16, (value >> 8) & 0xFF, value & 0xFF) == (1140, 1, 27)


def test_every_ap_of_the_class_table(motor):
    aps = table(motor.AP)
    for name, number in aps.items():
        if number in NOT_PROVIDED:
            assert status_of(lambda: motor.get_axis_parameter(number)) == STATUS_WRONG_TYPE, name
        else:
            value = motor.get_axis_parameter(number, signed=True)
            assert -(2**31) <= value < 2**31, name
    # The start values of the TMC429/TMC262 firmware (docs/tmcm-1140.md).
    start = {
        motor.AP.MaxVelocity: 1000,
        motor.AP.MaxAcceleration: 500,
        motor.AP.PulseDivisor: 2,
        motor.AP.RampDivisor: 3,
        motor.AP.MicrostepResolution: motor.ENUM.MicrostepResolution256Microsteps,
        motor.AP.PowerDownDelay: 200,
        motor.AP.PositionReachedFlag: 1,
    }
    for number, value in start.items():
        assert motor.get_axis_parameter(number) == value, f"AP {number}"


def test_global_parameters_of_the_class(module):
    for name, number in table(module.GP0).items():
        value = module.get_global_parameter(number, 0, signed=True)
        assert -(2**31) <= value < 2**31, name
    gp = module.GP0
    assert module.get_global_parameter(gp.SerialAddress, 0) == 1
    assert module.get_global_parameter(gp.SerialHostAddress, 0) == 2
    # The CAN settings are kept (no CAN is simulated).
    module.set_global_parameter(gp.CANsendID, 0, 5)
    assert module.get_global_parameter(gp.CANsendID, 0) == 5
    for name, number in table(module.GP3).items():
        module.set_global_parameter(number, 3, 2)
        assert module.get_global_parameter(number, 3) == 2, name


def test_rotate_demo(module, motor):
    """pytrinamic's examples/modules/TMCM1140/TMCL/rotate_demo.py, its waits shortened."""
    motor.drive_settings.max_current = 16
    motor.drive_settings.standby_current = 8
    motor.drive_settings.boost_current = 0
    motor.drive_settings.microstep_resolution = motor.ENUM.MicrostepResolution256Microsteps
    text = str(motor.drive_settings)
    assert "16" in text
    motor.linear_ramp.max_acceleration = 1000
    motor.linear_ramp.max_velocity = 1000
    assert "1000" in str(motor.linear_ramp)
    motor.actual_position = 0
    motor.rotate(1000)
    wait_until(lambda: motor.actual_velocity == 1000, 3, what="actual velocity 1000 (TMC429 units)")
    motor.stop()
    wait_until(lambda: motor.actual_velocity == 0, 3, what="stop")
    moved = motor.actual_position
    assert moved > 0
    motor.move_by(moved)
    assert motor.target_position == 2 * moved
    wait_until(lambda: motor.get_position_reached(), 10, what="position reached")
    assert motor.actual_position == 2 * moved
    motor.move_to(0)
    wait_until(lambda: motor.get_position_reached(), 10, what="back at 0")
    assert motor.actual_position == 0


def test_units_follow_the_pulse_divisor(motor):
    """16 MHz · v / (2^pulse_div · 2048 · 32) microsteps per second (hardware manual §8.1): the same
    velocity in units at pulse divisor 5 is an eighth of the speed at 2."""
    motor.linear_ramp.max_acceleration = 2047
    motor.set_axis_parameter(motor.AP.PulseDivisor, 5)
    motor.actual_position = 0
    motor.rotate(2000)
    wait_until(lambda: motor.actual_velocity == 2000, 3, what="actual velocity 2000")
    # 2000 units at pulse divisor 5: 15 259 µsteps/s; sampled twice half a second apart.
    a = motor.actual_position
    import time
    time.sleep(0.5)
    b = motor.actual_position
    motor.stop()
    assert 5000 < b - a < 11000, f"{b - a} µsteps in ~0.5 s"
    # Velocities are 0..2047 TMC429 units.
    assert status_of(lambda: motor.set_axis_parameter(motor.AP.MaxVelocity, 2048)) == 4
    # Positions are 24-bit.
    assert status_of(lambda: motor.move_to(1 << 23)) == 4


def test_stallguard2_and_coolstep(motor):
    sg = motor.stallguard2
    sg.threshold = -20
    assert sg.threshold == -20
    sg.filter = 1
    assert sg.filter == 1
    sg.stop_velocity = 100
    assert sg.stop_velocity == 100
    assert 0 <= sg.get_load_value() <= 1023
    assert "StallGuard2" in str(sg)
    cs = motor.coolstep
    cs.current_minimum = 1
    cs.current_down_step = 3
    cs.current_up_step = 2
    cs.hysteresis = 5
    cs.hysteresis_start = 2
    cs.threshold_speed = 500
    cs.slow_run_current = 100
    assert (cs.current_minimum, cs.current_down_step, cs.current_up_step) == (1, 3, 2)
    assert (cs.hysteresis, cs.hysteresis_start, cs.threshold_speed, cs.slow_run_current) == (5, 2, 500, 100)


def test_stallguard2_demo_stops_on_a_seized_shaft(serve, tmp_path):
    """pytrinamic's StallGuard2_demo.py without its interactive calibration: rotate at 1500, stop on
    stall above 100 units; the shaft seizes and the module stops the motor itself."""
    server = serve_1140(serve, tmp_path, SEIZED)
    with pytrinamic_connection(server) as conn:
        motor = TMCM1140(conn).motors[0]
        motor.drive_settings.max_current = 128
        motor.linear_ramp.max_acceleration = 2000
        motor.stallguard2.threshold = 0
        motor.stallguard2.stop_velocity = 100
        motor.actual_position = 0
        motor.rotate(1500)
        # Turning first (the first reads may come before the ramp's first step), then stopped.
        wait_until(lambda: motor.actual_velocity > 0, 5, what="the motor turning")
        wait_until(lambda: motor.actual_velocity == 0, 5, what="the motor stopped by stallGuard2")
        assert motor.get_axis_parameter(motor.AP.ExtendedErrorFlags) & 1, "AP 207 bit 0: stalled"


def test_reference_search_on_a_stage(serve, tmp_path):
    """RFS mode 1 (left switch only, the ARM-generation modes): fast onto the switch, slowly off and on
    again; the reference becomes position 0, AP 197 says where the search found it in the old count."""
    server = serve_1140(serve, tmp_path, STAGE)
    with pytrinamic_connection(server) as conn:
        module = TMCM1140(conn)
        motor = module.motors[0]
        assert motor.get_axis_parameter(motor.AP.LeftEndstop) == 0
        motor.set_axis_parameter(motor.AP.ReferenceSearchMode, 1)
        motor.set_axis_parameter(motor.AP.ReferenceSearchSpeed, 2047)
        motor.set_axis_parameter(motor.AP.ReferenceSwitchSpeed, 200)
        conn.reference_search(0, 0)
        wait_until(lambda: conn.reference_search(2, 0) == 0, 10, what="the reference search to end")
        assert abs(motor.actual_position) < 300
        last = motor.get_axis_parameter(motor.AP.LastReferenceSwitchPosition, signed=True)
        # The switch is 0.5 mm (12 800 µsteps) left of where the carriage started.
        assert -13_300 < last < -12_300, last
        # Now on the left switch: the left end stop reads 1 only while pressed.
        motor.move_to(25_600)
        wait_until(lambda: motor.get_position_reached(), 10, what="1 mm to the right")
        assert motor.get_axis_parameter(motor.AP.LeftEndstop) == 0


def test_gio_and_sio(serve, tmp_path):
    server = serve_1140(serve, tmp_path, STAGE)
    with pytrinamic_connection(server) as conn:
        io = TMCM1140.IO
        assert [conn.get_digital_input(n) for n in (io.IN0, io.IN1, io.IN2, io.IN3)] == [0, 1, 0, 1]
        assert conn.send(15, 255, 0, 0).value == 0b1010, "GIO 255, 0: all inputs"
        assert conn.get_analog_input(io.IN0) == 3000
        conn.set_digital_output(io.OUT1)
        assert [conn.get_digital_output(n) for n in (io.OUT0, io.OUT1)] == [0, 1]
        conn.clear_digital_output(io.OUT1)
        assert conn.get_digital_output(io.OUT1) == 0
        # No OUT2 on this board: GIO 2, 2 is a wrong type.
        assert status_of(lambda: conn.get_digital_output(2)) == STATUS_WRONG_TYPE


def test_usb_answers_every_address(server):
    """A USB link has one module: a frame for address 5 is answered, with the module's address 1."""
    with LinePort(server.link) as port:
        port.write(frame(5, 6, 4, 0, 0))
        reply = port.reply()
        assert (reply.host, reply.module, reply.status, reply.opcode, reply.value) == (2, 1, 100, 6, 1000)
        assert reply.checksum_ok


def test_on_an_rs485_line_beside_a_pd28_1021(serve, tmp_path):
    """`--interface rs485`: the TMCM-1140 at address 1 and a PD28-1021 at 2 share one line, each answers
    its own address in its own units."""
    server = serve_1140(serve, tmp_path, extra=["--interface", "rs485"],
                        modules=["tmcm-1140@1", "pd28-1021@2"])
    with pytrinamic_connection(server, module_id=1) as conn:
        m1140 = TMCM1140(conn, module_id=1).motors[0]
        m1021 = TMCM1021(conn, module_id=2).motors[0]
        assert conn.get_version_string(module_id=1) == "1140V127"
        assert conn.get_version_string(module_id=2) == "1021V142"
        assert m1140.linear_ramp.max_velocity == 1000  # TMC429 units
        assert m1021.linear_ramp.max_velocity == 51200  # pps
        m1140.move_to(20_000)
        m1021.move_to(20_000)
        wait_until(lambda: m1140.get_position_reached() and m1021.get_position_reached(), 10, what="both")
        assert (m1140.actual_position, m1021.actual_position) == (20_000, 20_000)


def test_a_usb_module_is_alone_on_its_link(tmcl_bin, tmp_path):
    """Two TMCM-1140 on USB would both answer every address: refused, with the way out named."""
    import subprocess

    run = subprocess.run([str(tmcl_bin), "serve", "--module", "tmcm-1140@1", "--module", "tmcm-1140@2",
                          "--pty", str(tmp_path / "link")], capture_output=True, text=True, timeout=20)
    assert run.returncode == 2
    assert "one module per link" in run.stderr
    run = subprocess.run([str(tmcl_bin), "serve", "--module", "pd28-1021", "--interface", "usb",
                          "--pty", str(tmp_path / "link")], capture_output=True, text=True, timeout=20)
    assert run.returncode == 2
    assert "cannot be served on `usb`" in run.stderr


def test_ascii_over_usb(server):
    """Command 139 and the ASCII line (the manual's §3.5): module letter A, replies `BA status value`."""
    with LinePort(server.link) as port:
        reply = port.request(1, 139, 0, 0, 0)
        assert (reply.host, reply.module, reply.status, reply.opcode) == (2, 1, 100, 139), reply

        def type_(line: str) -> bytes:
            port.write(line.encode() + b"\r")
            return port.read_until(b"\r") + port.read_until(b"\r")

        assert type_("AGAP 4, 0") == b"AGAP 4, 0\rBA 100 1000\r"
        assert type_("ASAP 4, 0, 2048") == b"ASAP 4, 0, 2048\rBA 4 2048\r", "TMC429 units: 0..2047"
        assert type_("AGAP 135, 0") == b"AGAP 135, 0\rBA 3 0\r", "not provided"
        port.write(b"ABIN\r")
        assert port.read_until(b"\r") == b"ABIN\r"
        assert port.read_until(b"\r") == b"BA 100 0\r"
        reply = port.request(1, 6, 4, 0, 0)
        assert (reply.status, reply.value) == (100, 1000), reply


def test_scan_and_params_on_the_bus(tmcl_bin, serve, tmp_path):
    """`tmcl scan` names both modules of the line by their version strings; `tmcl params` reads the
    TMCM-1140's table in its units."""
    import subprocess

    server = serve_1140(serve, tmp_path, extra=["--interface", "rs485"], modules=["tmcm-1140@1", "pd28-1021@2"])
    scan = subprocess.run([str(tmcl_bin), "--port", str(server.link), "scan", "--last", "3"], capture_output=True,
                          text=True, timeout=60, stdin=subprocess.DEVNULL)
    assert scan.returncode == 0, scan.stderr
    assert [line.split() for line in scan.stdout.splitlines()][:2] == [["1", "1140V127"], ["2", "1021V142"]]
    params = subprocess.run([str(tmcl_bin), "--port", str(server.link), "--address", "1", "params"],
                            capture_output=True, text=True, timeout=60, stdin=subprocess.DEVNULL)
    assert params.returncode == 0, params.stderr
    assert "TMCM-1140 (tmcm-1140)" in params.stdout
    line = next(l for l in params.stdout.splitlines() if l.startswith("ap 4 "))
    assert "TMC428 v units" in line and line.split()[-1] == "1000"

"""pytrinamic's TMCM1021 module class (same firmware family as the PD28-1021) over the pty."""

import pytest
from pytrinamic.modules import TMCM1021

from tmcltest import pytrinamic_connection, wait_until


@pytest.fixture
def module(pty_server):
    with pytrinamic_connection(pty_server) as conn:
        yield TMCM1021(conn)


@pytest.fixture
def motor(module):
    assert len(module.motors) == 1
    return module.motors[0]


def ap_table(motor):
    return {name: number for name, number in vars(motor.AP).items() if not name.startswith("_")}


def test_every_ap_of_the_class_table_reads(motor):
    """Each AP of TMCM1021's table is a PD28-1021 parameter (manual chapter 4): GAP succeeds. The class lists
    57 of the manual's 58 APs (it lacks AP 128, ramp mode)."""
    table = ap_table(motor)
    assert len(table) == 57
    assert 128 not in table.values()
    assert motor.get_axis_parameter(128) in (0, 1)
    for name, number in table.items():
        value = motor.get_axis_parameter(number, signed=True)
        assert -(2**31) <= value < 2**31, name
    assert motor.get_axis_parameter(motor.AP.MicrostepResolution) == motor.ENUM.MicrostepResolution256Microsteps
    assert motor.get_axis_parameter(motor.AP.PowerDownDelay) == 200
    assert motor.get_axis_parameter(motor.AP.PositionReachedFlag) == 1


def test_linear_ramp(motor):
    ramp = motor.linear_ramp
    assert ramp.max_velocity == 51200
    assert ramp.max_acceleration == 51200
    assert ramp.enabled is None  # the class has no EnableRamp AP
    ramp.max_velocity = 204800
    ramp.max_acceleration = 409600
    assert ramp.get_max_velocity() == 204800
    assert ramp.get_max_acceleration() == 409600
    assert "204800" in str(ramp)


def test_drive_settings(motor):
    drive = motor.drive_settings
    drive.max_current = 128
    drive.standby_current = 8
    drive.boost_current = 0
    drive.microstep_resolution = motor.ENUM.MicrostepResolution16Microsteps
    assert drive.max_current == 128
    assert drive.standby_current == 8
    assert drive.boost_current == 0
    assert drive.microstep_resolution == 4
    assert motor.get_axis_parameter(motor.AP.MaxCurrent) == 128
    assert motor.get_axis_parameter(motor.AP.MicrostepResolution) == 4


def test_stallguard2_and_coolstep(motor):
    sg = motor.stallguard2
    sg.threshold = -20
    assert sg.threshold == -20
    sg.filter = 1
    assert sg.filter == 1
    sg.stop_velocity = 1000
    assert sg.stop_velocity == 1000
    assert 0 <= sg.load_value <= 1023
    cs = motor.coolstep
    cs.current_minimum = 1
    cs.current_down_step = 3
    cs.current_up_step = 2
    cs.hysteresis = 5
    cs.hysteresis_start = 2
    cs.threshold_speed = 5000
    cs.slow_run_current = 100
    assert (cs.current_minimum, cs.current_down_step, cs.current_up_step) == (1, 3, 2)
    assert (cs.hysteresis, cs.hysteresis_start, cs.threshold_speed, cs.slow_run_current) == (5, 2, 5000, 100)


def test_set_axis_parameters_of_the_table(motor):
    writes = {
        motor.AP.MinimumSpeed: 10,
        motor.AP.RightLimitSwitchDisable: 1,
        motor.AP.LeftLimitSwitchDisable: 1,
        motor.AP.FreewheelingDelay: 300,
        motor.AP.ChopperBlankTime: 2,
        motor.AP.Toff: 5,
        motor.AP.ReferenceSearchMode: 2,
        motor.AP.ReferenceSearchSpeed: 20000,
        motor.AP.ReferenceSwitchSpeed: 5000,
        motor.AP.MaxEncoderDeviation: 100,
        motor.AP.StepDirectionMode: 0,
    }
    for number, value in writes.items():
        motor.set_axis_parameter(number, value)
    for number, value in writes.items():
        assert motor.get_axis_parameter(number) == value, f"AP {number}"


def test_motor_properties(motor):
    motor.actual_position = -1000
    assert motor.actual_position == -1000
    assert motor.get_actual_position() == -1000
    assert motor.actual_velocity == 0
    motor.linear_ramp.max_acceleration = 1024000
    motor.rotate(-51200)
    wait_until(lambda: motor.actual_velocity == -51200, 3, what="actual velocity -51200")
    assert motor.target_velocity == -51200
    motor.stop()
    wait_until(lambda: motor.actual_velocity == 0, 3, what="stop")


def test_move_to_and_wait_position_reached(module, motor):
    assert motor.get_position_reached() == 1
    motor.linear_ramp.max_acceleration = 1024000
    motor.move_to(100000, velocity=256000)
    assert motor.linear_ramp.max_velocity == 256000
    assert motor.target_position == 100000
    wait_until(lambda: motor.get_position_reached(), 5, what="position reached")
    assert motor.actual_position == 100000
    module.move_by(0, -40000)
    wait_until(lambda: motor.get_position_reached(), 5, what="position reached")
    assert motor.actual_position == 60000
    motor.move_by(-60000)
    wait_until(lambda: motor.get_position_reached(), 5, what="position reached")
    assert motor.actual_position == 0


def test_global_parameters_of_the_class(module):
    gp = module.GP0
    assert module.get_global_parameter(gp.SerialAddress, 0) == 1
    assert module.get_global_parameter(gp.SerialHostAddress, 0) == 2
    assert module.get_global_parameter(gp.SerialBaudRate, 0) == 0
    assert module.get_global_parameter(gp.SuppressReply, 0) == 0
    for name in ("SerialHeartbeat", "TelegramPauseTime", "AutoStartMode", "EndSwitchPolarity", "TMCLCodeProtection",
                 "eepromCoordinateStore", "zeroUserVariables", "serialSecondaryAddress", "reverseShaftDirection",
                 "ApplicationStatus", "ProgramCounter", "TickTimer", "randomNumber"):
        module.get_global_parameter(getattr(gp, name), 0)
    module.set_global_parameter(module.GP3.timer_1, 3, 250)
    assert module.get_global_parameter(module.GP3.timer_1, 3) == 250
    module.set_digital_output(module.IO.OUT1)
    assert module.get_digital_output(module.IO.OUT1) == 1
    module.clear_digital_output(module.IO.OUT1)
    assert module.get_digital_output(module.IO.OUT1) == 0

"""Unchanged pytrinamic over the pty link: `--interface serial_tmcl --port LINK`."""

import time

import pytest
from pytrinamic.connections import ConnectionManager
from pytrinamic.tmcl import GetInfoNotAvailableError, GetInfoRequestError, TMCLReplyStatusError

from tmcltest import DEFAULT_AP, DEFAULT_GP, pytrinamic_connection, wait_until

STATUS_WRONG_TYPE = 3
STATUS_INVALID_VALUE = 4


@pytest.fixture
def conn(pty_server):
    with pytrinamic_connection(pty_server) as c:
        yield c


def fast_ramp(conn, speed=512000, accel=2048000):
    conn.set_axis_parameter(4, 0, speed)
    conn.set_axis_parameter(5, 0, accel)


def test_version_string(conn):
    assert conn.get_version_string() == "1021V142"


def test_factory_defaults(conn):
    for number, value in DEFAULT_AP.items():
        assert conn.get_axis_parameter(number, 0) == value, f"AP {number}"
    for number, value in DEFAULT_GP.items():
        assert conn.get_global_parameter(number, 0) == value, f"GP {number}"
    assert conn.get_global_parameter(255, 0) == 0
    # Standing still at power-up: position 0, target reached.
    assert conn.get_axis_parameter(1, 0, signed=True) == 0
    assert conn.get_axis_parameter(3, 0, signed=True) == 0


def test_axis_parameters_roundtrip(conn):
    conn.set_axis_parameter(4, 0, 123456)
    assert conn.get_axis_parameter(4, 0) == 123456
    conn.set_axis_parameter(5, 0, 1000)
    assert conn.get_axis_parameter(5, 0) == 1000
    conn.set_axis_parameter(6, 0, 200)
    assert conn.get_axis_parameter(6, 0) == 200
    conn.set_axis_parameter(7, 0, 16)
    assert conn.get_axis_parameter(7, 0) == 16
    conn.set_axis_parameter(140, 0, 4)
    assert conn.get_axis_parameter(140, 0) == 4
    conn.set_axis_parameter(214, 0, 65535)
    assert conn.get_axis_parameter(214, 0) == 65535


def test_signed_axis_parameters(conn):
    # AP 174 stallGuard2 threshold, -64..63.
    conn.set_axis_parameter(174, 0, -17)
    assert conn.get_axis_parameter(174, 0, signed=True) == -17
    assert conn.get_axis_parameter(174, 0) == (-17) & 0xFFFFFFFF
    # AP 1 actual position (motor stopped): any 32-bit value.
    for value in (-123456, -(2**31), 2**31 - 1, 0):
        conn.set_axis_parameter(1, 0, value)
        assert conn.get_axis_parameter(1, 0, signed=True) == value
    # AP 209 encoder position.
    conn.set_axis_parameter(209, 0, -4242)
    assert conn.get_axis_parameter(209, 0, signed=True) == -4242


def test_global_parameters_bank0(conn):
    conn.set_global_parameter(75, 0, 3)  # telegram pause time
    assert conn.get_global_parameter(75, 0) == 3
    conn.set_global_parameter(75, 0, 0)
    conn.set_global_parameter(132, 0, 5000)  # tick timer, counts on
    tick = conn.get_global_parameter(132, 0)
    assert 5000 <= tick < 5000 + 60_000
    conn.set_global_parameter(84, 0, 1)
    assert conn.get_global_parameter(84, 0) == 1


def test_global_parameters_bank2_user_variables(conn):
    values = {0: 1, 1: -1, 17: 2**31 - 1, 55: -(2**31), 56: 77, 255: -99}
    for number, value in values.items():
        conn.set_global_parameter(number, 2, value)
    for number, value in values.items():
        assert conn.get_global_parameter(number, 2, signed=True) == value, f"user variable {number}"


def test_global_parameters_bank3_interrupt_config(conn):
    conn.set_global_parameter(0, 3, 1000)  # timer 0 period [ms]
    assert conn.get_global_parameter(0, 3) == 1000
    conn.set_global_parameter(39, 3, 3)  # input 0 trigger: both edges
    assert conn.get_global_parameter(39, 3) == 3
    with pytest.raises(TMCLReplyStatusError) as err:
        conn.set_global_parameter(39, 3, 4)
    assert err.value.status_code == STATUS_INVALID_VALUE
    assert conn.get_global_parameter(39, 3) == 3


def test_rotate_and_stop(conn):
    conn.set_axis_parameter(5, 0, 512000)
    conn.rotate(0, 51200)
    assert conn.get_axis_parameter(2, 0, signed=True) == 51200
    p0 = conn.get_axis_parameter(1, 0, signed=True)
    wait_until(lambda: conn.get_axis_parameter(3, 0, signed=True) == 51200, 3, what="AP3 = 51200")
    p1 = wait_until(lambda: (p := conn.get_axis_parameter(1, 0, signed=True)) > p0 + 2000 and p, 3,
                    what="position to increase")
    # Negative velocity = rotate left (pytrinamic never sends ROL).
    conn.rotate(0, -25600)
    assert conn.get_axis_parameter(2, 0, signed=True) == -25600
    wait_until(lambda: conn.get_axis_parameter(3, 0, signed=True) == -25600, 3, what="AP3 = -25600")
    p2 = conn.get_axis_parameter(1, 0, signed=True)
    wait_until(lambda: conn.get_axis_parameter(1, 0, signed=True) < p2 - 1000, 3, what="position to decrease")
    assert p1 > p0
    conn.stop(0)
    wait_until(lambda: conn.get_axis_parameter(3, 0, signed=True) == 0, 3, what="AP3 = 0 after MST")
    assert conn.get_axis_parameter(2, 0, signed=True) == 0
    p3 = conn.get_axis_parameter(1, 0, signed=True)
    assert conn.get_axis_parameter(1, 0, signed=True) == p3  # stands still


def test_move_to_default_ramp(conn):
    """MVP ABS with the factory ramp (51200 pps, 51200 pps²): 5120 steps take about 0.63 s."""
    assert conn.get_axis_parameter(8, 0) == 1
    conn.move_to(0, 5120)
    assert conn.get_axis_parameter(0, 0, signed=True) == 5120
    # Moving now: the flag drops, the position runs towards the target.
    assert conn.get_axis_parameter(8, 0) == 0
    wait_until(lambda: 0 < conn.get_axis_parameter(1, 0, signed=True) < 5120, 2, what="motion under way")
    wait_until(lambda: conn.get_axis_parameter(8, 0) == 1, 5, what="AP8 = 1")
    assert conn.get_axis_parameter(1, 0, signed=True) == 5120
    assert conn.get_axis_parameter(3, 0, signed=True) == 0


def test_move_to_and_move_by(conn):
    fast_ramp(conn)
    conn.move_to(0, -100000)
    wait_until(lambda: conn.get_axis_parameter(8, 0) == 1, 5, what="AP8 = 1")
    assert conn.get_axis_parameter(1, 0, signed=True) == -100000
    conn.move_by(0, 30000)
    assert conn.get_axis_parameter(0, 0, signed=True) == -70000
    wait_until(lambda: conn.get_axis_parameter(8, 0) == 1, 5, what="AP8 = 1")
    assert conn.get_axis_parameter(1, 0, signed=True) == -70000
    conn.move_by(0, -5000)
    wait_until(lambda: conn.get_axis_parameter(8, 0) == 1, 5, what="AP8 = 1")
    assert conn.get_axis_parameter(1, 0, signed=True) == -75000
    # A positioning move can be stopped: MST ends it before the target.
    conn.set_axis_parameter(4, 0, 51200)
    conn.move_to(0, 10_000_000)
    wait_until(lambda: conn.get_axis_parameter(3, 0, signed=True) > 0, 2, what="start of motion")
    conn.stop(0)
    wait_until(lambda: conn.get_axis_parameter(3, 0, signed=True) == 0, 5, what="stop")
    assert conn.get_axis_parameter(1, 0, signed=True) < 10_000_000


def test_store_and_restore_axis_parameter(conn):
    conn.set_axis_parameter(4, 0, 77777)
    conn.store_axis_parameter(4, 0)
    conn.set_axis_parameter(4, 0, 1111)
    assert conn.get_axis_parameter(4, 0) == 1111
    conn.restore_axis_parameter(4, 0)
    assert conn.get_axis_parameter(4, 0) == 77777
    # set_and_store + restore of another E parameter (AP 214 power-down delay).
    conn.set_and_store_axis_parameter(214, 0, 150)
    conn.set_axis_parameter(214, 0, 10)
    conn.restore_axis_parameter(214, 0)
    assert conn.get_axis_parameter(214, 0) == 150


def test_store_and_restore_user_variable(conn):
    conn.set_global_parameter(12, 2, -5555)
    conn.store_global_parameter(12, 2)
    conn.set_global_parameter(12, 2, 42)
    assert conn.get_global_parameter(12, 2, signed=True) == 42
    conn.restore_global_parameter(12, 2)
    assert conn.get_global_parameter(12, 2, signed=True) == -5555


def test_digital_outputs(conn):
    for port in (0, 1):
        assert conn.get_digital_output(port) == 0
    conn.set_digital_output(0)
    assert conn.get_digital_output(0) == 1
    assert conn.get_digital_output(1) == 0
    conn.set_digital_output(1)
    assert conn.get_digital_output(1) == 1
    conn.clear_digital_output(0)
    assert conn.get_digital_output(0) == 0
    assert conn.get_digital_output(1) == 1
    conn.clear_digital_output(1)
    assert conn.get_digital_output(1) == 0
    # Inputs and analog inputs can be read (values depend on the simulated board).
    for port in range(4):
        assert conn.get_digital_input(port) in (0, 1)
    assert 0 <= conn.get_analog_input(0) <= 4095


@pytest.mark.parametrize("number,bad,default", [(140, 9, 8), (4, 0, 51200), (6, 256, None), (214, 0, 200)])
def test_out_of_range_write_is_rejected(conn, number, bad, default):
    before = conn.get_axis_parameter(number, 0)
    if default is not None:
        assert before == default
    with pytest.raises(TMCLReplyStatusError) as err:
        conn.set_axis_parameter(number, 0, bad)
    assert err.value.status_code == STATUS_INVALID_VALUE
    assert conn.get_axis_parameter(number, 0) == before


def test_unknown_parameter_is_wrong_type(conn):
    for call in (lambda: conn.get_axis_parameter(100, 0),
                 lambda: conn.set_axis_parameter(100, 0, 1),
                 lambda: conn.get_axis_parameter(253, 0),
                 lambda: conn.get_global_parameter(50, 0)):
        with pytest.raises(TMCLReplyStatusError) as err:
            call()
        assert err.value.status_code == STATUS_WRONG_TYPE


def test_motor_1_is_invalid_value(conn):
    with pytest.raises(TMCLReplyStatusError) as err:
        conn.get_axis_parameter(4, 1)
    assert err.value.status_code == STATUS_INVALID_VALUE
    with pytest.raises(TMCLReplyStatusError) as err:
        conn.set_axis_parameter(4, 1, 1000)
    assert err.value.status_code == STATUS_INVALID_VALUE
    assert conn.get_axis_parameter(4, 0) == 51200


def test_error_reply_keeps_stream_in_sync(conn):
    """After an error reply the next request gets its own reply (no shifted frames)."""
    for i in range(10):
        with pytest.raises(TMCLReplyStatusError):
            conn.set_axis_parameter(140, 0, 100 + i)
        conn.set_axis_parameter(4, 0, 1000 + i)
        assert conn.get_axis_parameter(4, 0) == 1000 + i


def test_connect_disconnect_many_times(pty_server):
    for i in range(20):
        manager = ConnectionManager(pty_server.pytrinamic_args)
        conn = manager.connect()
        try:
            conn.set_global_parameter(3, 2, i)
            assert conn.get_global_parameter(3, 2) == i
            if i % 5 == 0:
                assert conn.get_version_string() == "1021V142"
        finally:
            manager.disconnect()
    assert pty_server.running


def test_get_info_is_not_a_pd28_command(conn):
    """Newer pytrinamic tools probe with command 157; the PD28-1021 rejects it and stays in sync."""
    with pytest.raises((GetInfoRequestError, GetInfoNotAvailableError)):
        conn.get_info("FWVersion")
    assert conn.get_axis_parameter(4, 0) == 51200


def test_tick_timer_runs_in_milliseconds(conn):
    conn.set_global_parameter(132, 0, 0)
    t0 = time.monotonic()
    time.sleep(0.3)
    ticks = conn.get_global_parameter(132, 0)
    elapsed_ms = (time.monotonic() - t0) * 1000
    assert 250 <= ticks <= elapsed_ms + 50, (ticks, elapsed_ms)

"""Example: pytest tests of host code written with pytrinamic, against virtual modules the opentmcl
plugin makes for each test. Run with `pytest python/examples` once `pip install ./python` is done (and
pytrinamic is installed)."""

import time

import pytest
from pytrinamic.modules import TMCM1021, TMCM1311


def wait_until(condition, seconds=5.0):
    deadline = time.monotonic() + seconds
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.01)


def test_tmcm1021_moves(tmcl_module, tmcl_connection):
    from pytrinamic.connections import ConnectionManager

    with ConnectionManager(tmcl_connection(tmcl_module)).connect() as connection:
        motor = TMCM1021(connection).motors[0]
        motor.set_axis_parameter(motor.AP.MaxVelocity, 51200)
        motor.move_to(5000)
        while not motor.get_position_reached():
            pass
        assert motor.actual_position == 5000


# A world given as text (a path to a TOML file works too, relative to this file): a NEMA 17 with an
# A/B/N encoder of 4096 counts per revolution.
CLOSED_LOOP = """
[motor]
holding_torque = 0.45
rated_current = 2.0

[encoder]
kind = "abn"
counts_per_rev = 4096
"""


@pytest.mark.tmcl(model="tmcm-1310", world=CLOSED_LOOP)
def test_tmcm1311_class_on_a_tmcm1310(tmcl_module, tmcl_connection):
    # pytrinamic has no TMCM-1310 class; its TMCM-1311 is the same closed-loop family.
    from pytrinamic.connections import ConnectionManager

    with ConnectionManager(tmcl_connection(tmcl_module)).connect() as connection:
        module = TMCM1311(connection)
        motor = module.motors[0]
        assert module.get_global_parameter(module.GP0.serialAddress, 0) == 1
        # pytrinamic's TMCM-1311 closed-loop demo: encoder initialisation (AP 132 := 1, until it reads
        # 2), then closed loop on (AP 129 := 1, until the init flag AP 133 reads 1).
        assert motor.get_axis_parameter(motor.AP.CLInitFlag) == 0
        motor.set_axis_parameter(motor.AP.EncoderInitialization, 1)
        wait_until(lambda: motor.get_axis_parameter(motor.AP.EncoderInitialization) == 2)
        motor.set_axis_parameter(motor.AP.ClosedLoopMode, 1)
        wait_until(lambda: motor.get_axis_parameter(motor.AP.CLInitFlag) == 1)
        # The same module, read directly without the link.
        assert tmcl_module.request("GAP", 129, 0).value == 1

"""The world changed at run time through `module.world`: switches pressed, the shaft seized, loads changed,
inputs set — on a module without a link and on a served one, each seen by the firmware at once."""

import time

import pytest

import opentmcl

# A module in this process without a link, and one served on a pty (reached between the server's polls).
SERVED = [pytest.param({}, id="local"), pytest.param({"link": True}, id="served")]

# The TMCM-1310 with a NEMA 17 motor (0.45 N·m at 2 A RMS), as in the closed-loop example world.
NEMA17 = "[motor]\nholding_torque = 0.45\nrated_current = 2.0\n"


def until(condition, timeout=10.0):
    """Polls `condition` (the module runs in real time) until it holds; fails after `timeout` seconds."""
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.01)


def gap(module, param):
    reply = module.request("GAP", param, 0)
    assert reply.ok, reply
    return reply.value


@pytest.mark.parametrize("links", SERVED)
def test_a_pressed_left_switch_stops_a_rotation_to_the_left(links):
    with opentmcl.Module(**links) as module:
        world = module.world
        assert (world.left, world.right, world.home) == (False, False, False)
        module.request("ROL", 0, 0, 51200)
        until(lambda: world.shaft < -2000)
        assert gap(module, 11) == 0  # AP 11: left limit switch (PD28-1021 manual chapter 4, Table 15)
        world.left = True
        assert world.left
        until(lambda: gap(module, 3) == 0)  # AP 3: actual speed — the switch stopped the motor
        assert gap(module, 11) == 1
        stopped = world.shaft
        time.sleep(0.05)
        assert world.shaft == stopped
        world.left = None  # back to the position: this world has no switch zone
        assert not world.left and gap(module, 11) == 0


@pytest.mark.parametrize("links", SERVED)
def test_a_seized_shaft_grows_the_closed_loop_position_error(links):
    with opentmcl.Module(model="tmcm-1310", world=NEMA17, **links) as module:
        world = module.world
        # Encoder initialisation (AP 132), then the loop closed (AP 129), as pytrinamic's TMCM-1311 demo.
        module.request("SAP", 132, 0, 1)
        until(lambda: gap(module, 132) == 2)
        module.request("SAP", 129, 0, 1)
        until(lambda: gap(module, 133) == 1)
        module.request("MVP", 1, 0, 8 * 51200)  # eight revolutions on, relative
        until(lambda: world.shaft > 10000)
        world.seized = True
        assert world.seized
        until(lambda: abs(gap(module, 237)) > 3000)  # the closed loop's position error
        assert world.lost_full_steps == 0, "closed loop: no step lost"
        world.seized = False
        assert not world.seized
        until(lambda: abs(gap(module, 237)) < 3000)


@pytest.mark.parametrize("links", SERVED)
def test_a_load_change_shows_in_the_stallguard_value(links):
    with opentmcl.Module(**links) as module:
        world = module.world
        module.request("ROR", 0, 0, 51200)
        until(lambda: world.shaft > 20000)
        light = gap(module, 206)  # AP 206: stallGuard2 load value, lower = more load
        assert world.external_torque == 0.0
        world.external_torque = -0.03
        assert world.external_torque == pytest.approx(-0.03)
        until(lambda: gap(module, 206) < light - 50)
        world.friction = 0.005
        assert world.friction == pytest.approx(0.005)
        assert world.load_torque > 0.03
        with pytest.raises(ValueError, match="friction"):
            world.friction = -1.0
        module.request("MST", 0, 0)


def test_inputs_analog_temperature_and_encoder_slip():
    with opentmcl.Module() as module:
        world = module.world
        world.inputs = 0b101
        world.analog = 1234
        world.temperature = 110
        assert (world.inputs, world.analog, world.temperature) == (0b101, 1234, 110)
        assert gap(module, 208) & 0b100, "AP 208 bit 2: overtemperature pre-warning at 110 °C"
        with pytest.raises(ValueError, match="analog"):
            world.analog = 5000
        before = gap(module, 209)  # AP 209: encoder position
        world.slip_encoder(100)
        assert gap(module, 209) != before

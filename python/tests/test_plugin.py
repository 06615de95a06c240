"""The pytest plugin: a fresh module per test, configured by the marker."""

import time

import pytest

import opentmcl


def test_default_module(tmcl_module):
    assert isinstance(tmcl_module, opentmcl.Module)
    assert (tmcl_module.model, tmcl_module.address) == ("pd28-1021", 1)


@pytest.mark.tmcl(model="tmcm-1310", world="closed-loop-seizure.toml")
def test_closed_loop_world_through_the_marker(tmcl_module):
    """The world file beside this test seizes the shaft at 150 degrees from 1.0 s to 1.4 s: in open loop
    the field runs on and the rotor drops steps there (the module's time starts with the fixture)."""
    assert tmcl_module.name == "TMCM-1310"
    assert tmcl_module.world.position == pytest.approx(0.0)
    tmcl_module.request("ROR", 0, 0, 22000)  # reaches 150 degrees at about 1.15 s
    time.sleep(1.6)
    assert tmcl_module.world.position > 150.0
    assert tmcl_module.world.lost_full_steps > 0
    tmcl_module.request("MST", 0, 0)


@pytest.mark.tmcl(address=5)
def test_marker_address(tmcl_module):
    assert tmcl_module.address == 5


def test_each_test_gets_a_fresh_module_part_1(tmcl_module):
    tmcl_module.set("MaxPositioningSpeed", 1234)


def test_each_test_gets_a_fresh_module_part_2(tmcl_module):
    assert tmcl_module.get("MaxPositioningSpeed") == 51200

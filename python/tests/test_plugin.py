"""The pytest plugin: a fresh module per test, configured by the marker."""

import time

import pytest

import opentmcl


def test_default_module(tmcl_module):
    assert isinstance(tmcl_module, opentmcl.Module)
    assert (tmcl_module.model, tmcl_module.address) == ("pd28-1021", 1)


@pytest.mark.tmcl(model="tmcm-1310", world="seized-shaft.toml")
def test_closed_loop_world_through_the_marker(tmcl_module):
    """The world file beside this test seizes the shaft at 30 degrees for the first 3 s: in open loop
    the field runs on and the rotor drops steps there, whenever the test gets to run."""
    assert tmcl_module.name == "TMCM-1310"
    assert tmcl_module.world.position == pytest.approx(0.0)
    tmcl_module.request("ROR", 0, 0, 20000)  # 30 degrees after about 0.4 s
    time.sleep(0.7)
    assert tmcl_module.world.lost_full_steps > 0
    assert tmcl_module.world.position == pytest.approx(30.0, abs=2.0)
    tmcl_module.request("MST", 0, 0)


@pytest.mark.tmcl(address=5)
def test_marker_address(tmcl_module):
    assert tmcl_module.address == 5


def test_each_test_gets_a_fresh_module_part_1(tmcl_module):
    tmcl_module.set("MaxPositioningSpeed", 1234)


def test_each_test_gets_a_fresh_module_part_2(tmcl_module):
    assert tmcl_module.get("MaxPositioningSpeed") == 51200


def test_fixture_serves_on_a_pty_for_pytrinamic(tmcl_module, tmcl_connection):
    pytest.importorskip("pytrinamic")
    from pytrinamic.connections import ConnectionManager
    from pytrinamic.modules import TMCM1021

    assert tmcl_connection(tmcl_module) == f"--interface serial_tmcl --port {tmcl_module.link} --data-rate 115200"
    with ConnectionManager(tmcl_connection(tmcl_module)).connect() as connection:
        motor = TMCM1021(connection).motors[0]
        motor.set_axis_parameter(motor.AP.MaxVelocity, 3000)
    assert tmcl_module.get("MaxPositioningSpeed") == 3000


@pytest.mark.tmcl(model="pd-113", tcp=True)
def test_fixture_on_tcp_for_pytrinamic(tmcl_module):
    pytest.importorskip("pytrinamic")
    from opentmcl.pytest_plugin import pytrinamic_connection

    assert tmcl_module.link is None and tmcl_module.tcp_address.startswith("127.0.0.1:")
    connection = pytrinamic_connection(tmcl_module)
    try:
        assert connection.get_axis_parameter(4, 0) == tmcl_module.get("MaxPositioningSpeed")
    finally:
        connection.close()


@pytest.mark.tmcl(modules=["pd28-1021", {"model": "pd-113", "address": 5}])
def test_bus_fixture(tmcl_bus, tmcl_connection):
    pytest.importorskip("pytrinamic")
    from pytrinamic.connections import ConnectionManager

    first, second = tmcl_bus
    assert (first.address, second.address) == (1, 5) and first.link == second.link
    second.set("MaxPositioningSpeed", 444)
    with ConnectionManager(tmcl_connection(second, module_id=5)).connect() as connection:
        assert connection.get_axis_parameter(4, 0, module_id=5) == 444
        assert connection.get_axis_parameter(4, 0, module_id=1) == first.get("MaxPositioningSpeed")

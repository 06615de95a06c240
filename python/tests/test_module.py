"""Direct access to a virtual module: requests, parameters by name, the world, EEPROM across a restart."""

import time

import opentmcl
import pytest


def test_request_returns_status_and_value():
    with opentmcl.Module() as module:
        reply = module.request("GAP", 4, 0)  # maximum positioning speed (PD28-1021 manual §4 Table 15)
        assert (reply.status, reply.value, reply.opcode) == (100, 51200, 6)
        assert reply.ok and reply.status_text.startswith("successfully")
        assert len(bytes(reply)) == 9 and bytes(reply)[:4] == bytes([2, 1, 100, 6])
        # A refusal is a reply with its status (3: wrong type), not an exception.
        refused = module.request("GAP", 250, 0)
        assert (refused.status, refused.ok) == (3, False)
        assert module.request(6, 4, 0).value == 51200  # by number


def test_version_string_is_the_raw_special_reply():
    with opentmcl.Module(model="tmcm-1310") as module:
        reply = module.request(136, 0)
        # Command 136 type 0: the host address, then eight ASCII characters, no checksum (§3.7.38).
        assert reply.status is None and bytes(reply)[1:9].decode().startswith("1310V")


def test_parameters_by_name():
    with opentmcl.Module() as module:
        assert module.get("MaxPositioningSpeed") == 51200
        module.set("APMaxPositioningSpeed", 1000)
        assert module.get("maximum positioning speed") == 1000
        with pytest.raises(KeyError, match="MaxPositioningSpeed"):
            module.get("maxspd")
        with pytest.raises(opentmcl.TmclError) as err:
            module.set("MaxPositioningSpeed", -5)
        assert err.value.status == 4  # invalid value


def test_motion_in_real_time():
    with opentmcl.Module() as module:
        module.request("ROR", 0, 0, 51200)  # one revolution a second
        time.sleep(0.2)
        assert module.get("ActualPosition") > 0
        assert module.world.shaft > 0
        module.request("MST", 0, 0)


def test_world_from_file_and_text(tmp_path):
    world = tmp_path / "linear.toml"
    world.write_text('[axis]\nkind = "linear"\nlead = 2.0\nstart = 10.0\n')
    with opentmcl.Module(world=str(world)) as module:
        assert module.world.position == pytest.approx(10.0)
        module.world.load('[axis]\nkind = "linear"\nlead = 2.0\nstart = 30.0\n')
        assert module.world.position == pytest.approx(30.0)
    with pytest.raises(ValueError, match="lead"):
        opentmcl.Module(world='[axis]\nkind = "linear"\nlead = -1.0\n')


def test_eeprom_across_a_restart(tmp_path):
    eeprom = tmp_path / "module.eeprom"
    with opentmcl.Module(eeprom=eeprom, address=3) as module:
        assert module.address == 3
        module.set("MaxPositioningSpeed", 777)
        module.store("MaxPositioningSpeed")
    # The stored address wins over a new start address; the stored value is the power-up value.
    with opentmcl.Module(eeprom=eeprom, address=1) as module:
        assert module.address == 3
        assert module.get("MaxPositioningSpeed") == 777


def test_closed_module_refuses_use():
    module = opentmcl.Module()
    module.close()
    module.close()
    with pytest.raises(RuntimeError, match="closed"):
        module.get("MaxPositioningSpeed")


def test_unknown_model():
    with pytest.raises(ValueError, match="pd28-1021"):
        opentmcl.Module(model="tmcm-9999")
    assert ("pd28-1021", "PD28-1021") in opentmcl.models()

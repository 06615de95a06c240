"""The multi-axis siblings of the TMCM-1140, the TMCM-3110 and TMCM-6110, driven by pytrinamic's
`TMCM3110` and `TMCM6110` classes over a pty (their USB port), every axis.

Their model tables are in `crates/tmcl-model/src/tmcm_3110.rs` and `tmcm_6110.rs`; docs/tmcm-3110.md says
where each number comes from.
"""

from __future__ import annotations

import pytest
from pytrinamic.modules import TMCM3110, TMCM6110
from pytrinamic.tmcl import TMCLReplyStatusError

from tmcltest import pytrinamic_connection, wait_until

MODELS = [("tmcm-3110", TMCM3110, 3, "3110V111"), ("tmcm-6110", TMCM6110, 6, "6110V119")]
NOT_PROVIDED = {135}


@pytest.fixture(params=MODELS, ids=[m[0] for m in MODELS])
def multi(request, serve):
    model, cls, axes, version = request.param
    server = serve("pty", modules=[model])
    with pytrinamic_connection(server) as conn:
        yield cls(conn), axes, version


def status_of(call) -> int:
    with pytest.raises(TMCLReplyStatusError) as info:
        call()
    return info.value.status_code


def test_version(multi):
    module, _, version = multi
    assert module.connection.get_version_string() == version
    assert module.connection.send(136, 1, 0, 0).value >> 16 == int(version[:4])


def test_every_ap_on_every_axis(multi):
    module, axes, _ = multi
    assert len(module.motors) == axes
    for motor in module.motors:
        for name, number in vars(motor.AP).items():
            if name.startswith("_"):
                continue
            if number in NOT_PROVIDED:
                assert status_of(lambda: motor.get_axis_parameter(number)) == 3, name
            else:
                motor.get_axis_parameter(number, signed=True)
    assert status_of(lambda: module.connection.get_axis_parameter(1, axes)) == 4, "no such axis"


def test_every_axis_moves_on_its_own(multi):
    module, axes, _ = multi
    targets = [(n + 1) * 5000 * (-1) ** n for n in range(axes)]
    for motor, target in zip(module.motors, targets):
        motor.linear_ramp.max_acceleration = 2000
        motor.move_to(target)
    wait_until(lambda: all(m.get_position_reached() for m in module.motors), 10, what="every axis at its target")
    assert [m.actual_position for m in module.motors] == targets
    module.motors[-1].rotate(500)
    wait_until(lambda: module.motors[-1].actual_velocity == 500, 3, what="the last axis turning")
    assert all(m.actual_velocity == 0 for m in module.motors[:-1])
    module.motors[-1].stop()


def test_gio_and_sio(multi):
    module, _, _ = multi
    conn = module.connection
    for port in range(8):
        assert conn.get_digital_input(port) in (0, 1)
        conn.set_digital_output(port)
        assert conn.get_digital_output(port) == 1
        conn.clear_digital_output(port)
        assert conn.get_digital_output(port) == 0
    for port in (module.IO.AIN0, module.IO.AIN4):
        assert 0 <= conn.get_analog_input(port) <= 4095


def test_bank_3(multi):
    module, _, _ = multi
    for name, number in vars(module.GP3).items():
        if not name.startswith("_"):
            module.set_global_parameter(number, 3, 3)
            assert module.get_global_parameter(number, 3) == 3, name


def test_reference_search_on_every_axis(serve, tmp_path):
    """Each axis in a copy of the stage (`--world`): RFS mode 1 on every axis at once, each finds its own
    left switch; the home switches read per axis (AP 9), the inputs are the module's."""
    from test_tmcm1140 import STAGE

    for model, cls, axes, _ in MODELS:
        world = tmp_path / f"{model}.toml"
        world.write_text(STAGE)
        server = serve("pty", modules=[model], extra=["--world", str(world)])
        with pytrinamic_connection(server) as conn:
            module = cls(conn)
            for axis, motor in enumerate(module.motors):
                motor.set_axis_parameter(motor.AP.ReferenceSearchMode, 1)
                motor.set_axis_parameter(motor.AP.ReferenceSearchSpeed, 2047)
                motor.set_axis_parameter(motor.AP.ReferenceSwitchSpeed, 200)
                conn.reference_search(0, axis)
            wait_until(lambda: all(conn.reference_search(2, a) == 0 for a in range(axes)), 20,
                       what=f"the reference search of every axis of the {model}")
            for motor in module.motors:
                assert abs(motor.actual_position) < 300
                last = motor.get_axis_parameter(motor.AP.LastReferenceSwitchPosition, signed=True)
                assert -13_300 < last < -12_300, last
            assert conn.send(15, 255, 0, 0).value == 0b1010, "GIO 255, 0: the world's inputs"


def test_on_an_rs485_line(serve):
    """`--interface rs485`: a TMCM-3110 at 1, a TMCM-6110 at 2 and a TMCM-1140 at 3 on one line."""
    from pytrinamic.modules import TMCM1140

    server = serve("pty", modules=["tmcm-3110@1", "tmcm-6110@2", "tmcm-1140@3"], extra=["--interface", "rs485"])
    with pytrinamic_connection(server, module_id=1) as conn:
        m3110, m6110, m1140 = TMCM3110(conn, module_id=1), TMCM6110(conn, module_id=2), TMCM1140(conn, module_id=3)
        assert [conn.get_version_string(module_id=n) for n in (1, 2, 3)] == ["3110V111", "6110V119", "1140V127"]
        moving = [m3110.motors[2], m6110.motors[5], m1140.motors[0]]
        for motor in moving:
            motor.move_to(-7000)
        wait_until(lambda: all(m.get_position_reached() for m in moving), 10, what="the three moves")
        assert [m.actual_position for m in moving] == [-7000] * 3
        assert m3110.motors[0].actual_position == 0 and m6110.motors[0].actual_position == 0

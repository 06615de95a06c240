"""The multi-axis siblings of the TMCM-1140, the TMCM-3110 and TMCM-6110, driven by pytrinamic's
`TMCM3110` and `TMCM6110` classes over a pty (their USB port), every axis: every AP of the class on every
axis, independent moves, the class's per-axis methods and features, a reference search on every axis at
once, GIO/SIO on banks 0, 1 and 2, bank 3, what odemis' TMCL driver reads and sets (GIO 8, 1, SIO 0, 0,
AP 2 as v_target), `tmcl params`/`set --motor` per axis, and both on one RS485 line with a TMCM-1140.

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


def test_the_class_methods_drive_each_axis(multi):
    """The module-level methods of pytrinamic's classes (`move_to(axis, …)`, `move_by`, `rotate`, `stop`,
    the reference-search setters) and each motor's features (`drive_settings`, `linear_ramp`,
    `stallguard2`, `coolstep`) address the axis they name. `move_by` moves from the target position, as
    pytrinamic's MVP REL does on every module."""
    module, axes, _ = multi
    last = axes - 1
    module.move_to(last, 3000, velocity=1500)
    wait_until(lambda: module.motors[last].get_position_reached(), 10, what="the last axis at 3000")
    module.move_by(last, -1000)
    wait_until(lambda: module.motors[last].actual_position == 2000, 10, what="the last axis back by 1000")
    assert module.motors[last].linear_ramp.max_velocity == 1500
    assert all(m.actual_position == 0 for m in module.motors[:last])
    module.rotate(1, -400)
    wait_until(lambda: module.motors[1].actual_velocity == -400, 3, what="axis 1 turning")
    module.stop(1)
    wait_until(lambda: module.motors[1].actual_velocity == 0, 3, what="axis 1 stopped")
    ap = module.motors[2].AP
    if hasattr(module, "set_reference_search_mode"):  # the TMCM3110 class has these, the TMCM6110 not
        module.set_reference_search_mode(2, 2)
        module.set_reference_search_speed(2, 1000)
        module.set_reference_switch_speed(2, 100)
    else:
        for number, value in ((ap.ReferenceSearchMode, 2), (ap.ReferenceSearchSpeed, 1000),
                              (ap.ReferenceSwitchSpeed, 100)):
            module.motors[2].set_axis_parameter(number, value)
    assert [module.motors[2].get_axis_parameter(n) for n in (ap.ReferenceSearchMode, ap.ReferenceSearchSpeed,
                                                             ap.ReferenceSwitchSpeed)] == [2, 1000, 100]
    assert module.motors[0].get_axis_parameter(ap.ReferenceSearchSpeed) != 1000, "axis 0 keeps its own"
    for axis, motor in enumerate(module.motors):
        motor.drive_settings.max_current = 10 + axis
        motor.stallguard2.threshold = -axis
        motor.coolstep.current_up_step = axis % 4
    assert [m.drive_settings.max_current for m in module.motors] == [10 + a for a in range(axes)]
    assert [m.stallguard2.threshold for m in module.motors] == [-a for a in range(axes)]
    assert [m.coolstep.current_up_step for m in module.motors] == [a % 4 for a in range(axes)]
    # (pytrinamic 0.2.26's `coolstep.slow_run_current`, `hysteresis`, `threshold_speed` and
    # `stallguard2.stop_velocity` look up AP names its TMCM3110/TMCM6110 tables spell otherwise
    # (`smartEnergySlowRunCurrent`, …): an AttributeError in pytrinamic before any byte is sent.)


def test_what_odemis_reads_and_sets(multi):
    """odemis' TMCL driver (delmic/odemis src/odemis/driver/tmcm.py): the binary version (model in the
    high word, 3110 needs 1.09 or later), GAP 1 of the highest axis it was configured with (a module with
    fewer axes answers an error), the supply voltage GIO 8, 1 in 0.1 V against its `minpower` 10.8 V, the
    switches' pull-ups SIO 0, 0 from its user configuration, the analog inputs GIO 0, 1 and GIO 4, 1, the
    home switch of axis n on IN(n+1) (GIO n+1, 0), and AP 2 in position mode as the TMC429's v_target."""
    module, axes, version = multi
    conn = module.connection
    value = conn.send(136, 1, 0, 0).value
    assert (value >> 16, (value >> 8) & 0xFF, value & 0xFF) == (int(version[:4]), 1, int(version[6:]))
    conn.send(6, 1, axes - 1, 0)  # the highest axis answers
    assert conn.get_analog_input(8) >= 108, "GIO 8, 1: the supply, 24.0 V on the simulated board"
    assert conn.send(14, 0, 0, 3).status == 100, "SIO 0, 0, 3: the switches' pull-ups"
    assert status_of(lambda: conn.send(14, 0, 0, 4)) == 4
    for port in (0, 4):
        assert 0 <= conn.get_analog_input(port) <= 4095
    for axis in range(min(axes, 3)):
        assert conn.get_digital_input(axis + 1) in (0, 1)
    # AP 2 while an axis drives in position mode: +v_max; the others 0; at rest 0 again.
    motor = module.motors[axes - 1]
    motor.linear_ramp.max_velocity = 300
    motor.linear_ramp.max_acceleration = 20
    motor.move_to(100_000)
    wait_until(lambda: motor.actual_velocity > 0, 3, what="the axis accelerating")
    assert motor.get_axis_parameter(motor.AP.TargetVelocity, signed=True) == 300
    assert module.motors[0].get_axis_parameter(motor.AP.TargetVelocity) == 0
    motor.stop()


@pytest.mark.parametrize("model, axes", [(m[0], m[2]) for m in MODELS], ids=[m[0] for m in MODELS])
def test_params_and_set_per_axis(serve, tmcl_bin, model, axes):
    """`tmcl set ap … --motor M` writes one axis; `tmcl params ap` lists every axis's parameters with their
    values (`ap N:M`); a motor the module lacks is refused with the model's axes named."""
    import subprocess

    server = serve("pty", modules=[model])

    def tmcl(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([str(tmcl_bin), "--port", str(server.link), *args], capture_output=True, text=True,
                              timeout=120, stdin=subprocess.DEVNULL)

    last = axes - 1
    run = tmcl("set", "ap", "MaxVelocity", "1234", "--motor", str(last))
    assert run.returncode == 0, run.stderr
    run = tmcl("params", "ap")
    assert run.returncode == 0, run.stderr
    rows = {f"{r[0]} {r[1]}": r for r in (line.split() for line in run.stdout.splitlines()[2:])}
    assert len(rows) % axes == 0
    assert rows["ap 4"][-1] == "1000" and rows[f"ap 4:{last}"][-1] == "1234"
    run = tmcl("get", "ap", "4", "--motor", str(axes))
    assert run.returncode != 0
    assert f"has motors 0..{last} (--motor {axes} given)" in run.stderr, run.stderr


@pytest.mark.parametrize("model, axes", [(m[0], m[2]) for m in MODELS], ids=[m[0] for m in MODELS])
def test_a_twin_keeps_every_axis(serve, tmcl_bin, tmp_path, model, axes):
    """`tmcl twin` of a multi-axis module: the EEPROM image holds each axis's stored parameters (motor-major),
    and the twin served from it answers every parameter of every axis as the original after a power cycle."""
    import json
    import subprocess

    from test_params import LIVE, values

    def tmcl(*args) -> subprocess.CompletedProcess:
        run = subprocess.run([str(tmcl_bin), *map(str, args)], capture_output=True, text=True, timeout=120,
                             stdin=subprocess.DEVNULL)
        assert run.returncode == 0, f"tmcl {args}: {run.stderr}"
        return run

    original = serve("pty", modules=[model], eeprom=tmp_path / "original.eeprom")
    for motor in range(axes):
        tmcl("--port", original.link, "set", "ap", "MaxVelocity", 100 + motor, "--motor", motor)
        tmcl("--port", original.link, "store", "ap", "MaxVelocity", "--motor", motor)
    out = tmp_path / "twin"
    made = json.loads(tmcl("--port", original.link, "twin", "--out", out, "--json").stdout)
    assert made["model"] == model and not made["refused"]
    original.restart()
    twin = serve("pty", modules=[model], eeprom=out / f"{model}.eeprom")
    a, b = values(tmcl_bin, original.link), values(tmcl_bin, twin.link)
    assert a.keys() == b.keys()
    assert {a[("ap", m, 4)] for m in range(axes)} == {100 + m for m in range(axes)}
    # Besides the values that change by themselves: AP 180, the current scale in use, which drops to the
    # standby current 2 s after a start (the power-down delay AP 214): six axes take longer to read.
    live = LIVE | {("ap", m, n) for m in range(axes) for n in (180, 208)}
    differ = {k: (a[k], b[k]) for k in a if k not in live and a[k] != b[k]}
    assert not differ, differ


@pytest.mark.parametrize("vect_from_host", [pytest.param(True, id="as-odemis"),
                                            pytest.param(False, id="vector-in-the-routine")])
def test_odemis_referencing_program_on_an_axis(serve, tmp_path, vect_from_host):
    """The way odemis' TMCL driver references an axis with its "2xFinalForward" procedure, command by
    command: it downloads a small program per axis (132 with the start address, the instructions, 133), an
    interrupt handler that stops the search (RFS STOP, RETI) set on the input of that axis (VECT 40 + n,
    bank 3 trigger both edges, EI 40 + n, EI 255), and starts the program with 129 type 1 at its address;
    the program clears a bank 2 variable, starts RFS on its motor, waits for it with WAIT RFS and a timeout,
    jumps on ETO and reports 1 (done) or 2 (timed out) in the variable, which the host polls. The second
    case sets the vector as the routine's first instruction instead. The TMCM-3110 takes VECT from the host
    (`ModelDesc::host_vect`), as odemis' production use of it shows."""
    from test_tmcm1140 import STAGE

    world = tmp_path / "stage.toml"
    world.write_text(STAGE)
    server = serve("pty", modules=["tmcm-3110"], extra=["--world", str(world)])
    with pytrinamic_connection(server) as conn:
        axis = 1
        for number, value in ((193, 1), (194, 2047), (195, 200)):  # RFS mode 1 (left switch) and speeds
            conn.send(5, number, axis, value)
        handler = 50 + 10 * axis
        routine = 80 + 15 * axis
        variable = 128 + axis

        def download(address, program):
            assert conn.send(132, 0, 0, address).status == 100
            for instruction in program:
                op, kind, motor, value = (*instruction, 0, 0, 0)[:4]
                assert conn.send(op, kind, motor, value).status == 101, instruction
            assert conn.send(133, 0, 0, 0).status == 100

        download(handler, [(13, 1, axis), (38,)])  # RFS STOP, n; RETI
        start = routine if vect_from_host else routine - 1
        interrupt = 40 + axis
        if not vect_from_host:
            download(start, [(37, interrupt, 0, handler)])  # VECT 40 + n, handler
        download(routine, [
            (9, variable, 2, 0),        # SGP variable, 2, 0: running
            (13, 0, axis),              # RFS START, n
            (27, 4, axis, 2000),        # WAIT RFS, n, 2000 ticks (20 s)
            (21, 8, 0, routine + 6),    # JC ETO, timeout
            (9, variable, 2, 1),        # SGP variable, 2, 1: done
            (28,),                      # STOP
            (13, 1, axis),              # timeout: RFS STOP, n
            (9, variable, 2, 2),        # SGP variable, 2, 2: timed out
            (28,),                      # STOP
        ])
        if vect_from_host:
            conn.send(37, interrupt, 0, handler)   # VECT
        conn.send(9, interrupt, 3, 3)          # SGP 40 + n, 3, 3: both edges
        conn.send(25, interrupt, 0, 0)         # EI
        conn.send(25, 255, 0, 0)               # EI 255
        conn.send(129, 1, 0, start)            # RUN at the routine's address
        wait_until(lambda: conn.send(10, variable, 2, 0).value != 0, 20, what="the routine's report")
        assert conn.send(10, variable, 2, 0).value == 1, "done, not timed out"
        assert conn.reference_search(2, axis) == 0
        position = conn.send(6, 1, axis, 0).value
        assert abs(position - (1 << 32) if position >= 1 << 31 else position) < 300, "axis 1 at its reference"
        assert conn.send(6, 1, 0, 0).value == 0 and conn.send(6, 1, 2, 0).value == 0, "the others stood"


def test_mvp_coord_of_several_motors(multi):
    """MVP COORD with a motor mask, as host software for the TMCM-3110 sends it (tmcm-lib-py's `MotorUnion`:
    SCO per motor, then MVP COORD with the mask ORed with 0x40, "synchronously", or 0x80): every motor of
    the mask to its own coordinate; interpolated, all arrive together. Refusals (both bits, a motor beyond
    the module's) are status 4 and move nothing."""
    module, axes, _ = multi
    conn = module.connection
    mask = (1 << axes) - 1
    targets = [3000 * (n + 1) * (-1) ** n for n in range(axes)]
    for motor, target in enumerate(targets):
        conn.send(30, 1, motor, target)  # SCO 1, motor, target
    assert status_of(lambda: conn.send(4, 2, 0xC0 | mask, 1)) == 4
    assert status_of(lambda: conn.send(4, 2, 0x40 | (1 << axes), 1)) == 4
    assert all(conn.get_axis_parameter(0, m) == 0 for m in range(axes)), "nothing moved"
    assert conn.send(4, 2, 0x40 | mask, 1).value == 1  # MVP COORD, $40 | mask, 1
    # Polled by pytrinamic: while they move, each is about the same fraction of its way (the GAPs of one
    # round are a few ms apart, so within 10 %; crates/tmcl-core/tests/tmcm_3110.rs checks 1 % at one
    # instant and the arrivals within 3 ms), and they arrive together.
    seen_moving = 0
    while True:
        reached = [conn.get_axis_parameter(8, m) for m in range(axes)]
        if any(reached):
            # Together, up to a few ms of rounding (the module serves in real time: 0.2 s of slack for a
            # loaded machine; a move takes about a second, and without interpolation the nearest arrives
            # a third of the way in, below).
            wait_until(lambda: all(conn.get_axis_parameter(8, m) for m in range(axes)), 0.2,
                       what=f"every motor right after the first ({reached})")
            break
        positions = [conn.get_axis_parameter(1, m, signed=True) for m in range(axes)]
        fractions = [p / t for p, t in zip(positions, targets)]
        if 0.05 < fractions[-1] < 0.95:
            seen_moving += 1
            assert max(fractions) - min(fractions) < 0.1, fractions
    assert seen_moving > 0, "polled while they moved"
    assert [conn.get_axis_parameter(1, m, signed=True) for m in range(axes)] == targets
    # Back to 0 each at its own speed (0x80): the nearest first.
    for motor in range(axes):
        conn.send(30, 2, motor, 0)
    conn.send(4, 2, 0x80 | mask, 2)
    wait_until(lambda: conn.get_axis_parameter(8, 0), 10, what="motor 0 back at 0")
    assert conn.get_axis_parameter(8, axes - 1) == 0, "the farthest still on its way"
    wait_until(lambda: all(conn.get_axis_parameter(8, m) for m in range(axes)), 20, what="every motor at 0")


@pytest.mark.parametrize("model, cls, axes, version", MODELS, ids=[m[0] for m in MODELS])
def test_the_eeprom_file_keeps_every_axis(serve, tmp_path, model, cls, axes, version):
    """The EEPROM image of N axes in a file (`--eeprom`): the last motor's stored AP 4 and its coordinate
    20 (the last slot of the image, written through with GP 84 = 1) come back after a restart, and the
    motor before it keeps its own."""
    server = serve("pty", eeprom=tmp_path / "eeprom.bin", modules=[model])
    last = axes - 1
    with pytrinamic_connection(server) as conn:
        conn.set_axis_parameter(4, last, 777)
        conn.store_axis_parameter(4, last)
        conn.set_global_parameter(84, 0, 1)
        conn.send(30, 20, last, -4242)  # SCO 20, last, -4242
    server.restart()
    with pytrinamic_connection(server) as conn:
        assert conn.get_axis_parameter(4, last) == 777
        assert conn.get_axis_parameter(4, last - 1) == 1000
        assert conn.send(31, 20, last, 0).value == (-4242) & 0xFFFFFFFF  # GCO 20, last (unsigned in the reply)
        assert conn.send(31, 20, last - 1, 0).value == 0

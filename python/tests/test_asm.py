"""The assembler and disassembler: the manual's programs, errors with their positions, round trips."""

import opentmcl
import pytest

# PD28-1021 TMCL firmware manual §2.4.
MANUAL_2_4 = """\
// Example of a TMCL program (PD28-1021 manual §2.4)
    ROL 0, 500
    WAIT TICKS, 0, 500
    MST 0
    ROR 0, 250
    WAIT TICKS, 0, 500
    MST 0

    SAP 4, 0, 500     // set max. velocity
    SAP 5, 0, 50      // set max. acceleration
Loop:
    MVP ABS, 0, 10000
    WAIT POS, 0, 0
    MVP ABS, 0, -10000
    WAIT POS, 0, 0
    JA Loop
"""


def test_manual_program_assembles():
    program = opentmcl.assemble(MANUAL_2_4)
    assert len(program) == 13
    assert program.labels == {"Loop": 8}
    assert program.instructions[0] == (2, 0, 0, 500)  # ROL 0, 500
    assert program.lines[0] == ("<source>", 2)
    assert len(program.to_bin()) == 8 * 13


def test_errors_carry_line_and_column():
    with pytest.raises(opentmcl.AssemblyError) as err:
        opentmcl.assemble("Loop:\n    MVP ABS, 0, 100\n    JA Lop\n    FOO 1\n", name="prog.tmc")
    e = err.value
    assert (e.file, e.line, e.column) == ("prog.tmc", 3, 8)
    assert "Lop" in e.message
    assert [(d.line, d.column) for d in e.diagnostics][0] == (3, 8)
    assert len(e.diagnostics) == 2 and e.diagnostics[1].line == 4
    assert "prog.tmc:3:8: error:" in str(e)
    assert isinstance(e, ValueError)


def test_commands_the_model_lacks_are_errors():
    # The PDx-113 has no CALCX... but every model has MVP: use an opcode the PD28-1021 lacks instead.
    with pytest.raises(opentmcl.AssemblyError) as err:
        opentmcl.assemble("    MVP ABS, 0, 1\n    SAC 0, 0, 0\n", model="pd28-1021")
    assert err.value.line == 2 and "not a command of the PD28-1021" in err.value.message


def test_includes_and_files(tmp_path):
    (tmp_path / "speeds.inc").write_text("Fast = 2000\n")
    main = tmp_path / "main.tmc"
    main.write_text("#include speeds.inc\n#include TMCLParam.tmc\n    SAP APMaxPositioningSpeed, 0, Fast\n")
    program = opentmcl.assemble(main)
    assert program.instructions == [(5, 4, 0, 2000)]
    assert program.constants["Fast"] == 2000


def test_disassemble_round_trip():
    program = opentmcl.assemble(MANUAL_2_4)
    text = opentmcl.disassemble(program)
    assert "JA L0008" in text
    assert opentmcl.assemble(text).instructions == program.instructions
    assert opentmcl.disassemble(program.to_bin()) == text
    assert opentmcl.Program.from_bin(program.to_bin()).instructions == program.instructions
    assert opentmcl.disassemble([(4, 0, 0, 7)]).splitlines()[-1].strip() == "MVP ABS, 0, 7"


def test_program_runs_in_a_module():
    program = opentmcl.assemble("    SGP 0, 2, 42\n    STOP\n")
    with opentmcl.Module() as module:
        module.load_program(program, start=True)
        import time
        time.sleep(0.05)
        assert module.request("GGP", 0, 2).value == 42

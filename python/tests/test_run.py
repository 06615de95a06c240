"""opentmcl.run: the PD28-1021 manual's §2.4 program an hour long, checked against `tmcl run`'s trace."""

import csv
import os
import subprocess
from pathlib import Path

import opentmcl
import pytest

# PD28-1021 TMCL firmware manual §2.4.
MANUAL_2_4 = """\
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


def test_an_hour_of_the_manual_program():
    result = opentmcl.run(MANUAL_2_4, seconds=3600, every=0.01)
    columns = result.columns
    assert columns["time_s"][0] == 0.0 and columns["time_s"][-1] == pytest.approx(3600.0)
    assert len(result) >= 360_001  # a row every 10 ms, plus one at each event
    positions = [p for p in columns["actual_position"] if p is not None]
    assert max(positions) == 10000 and min(positions) == -10000
    assert result.units["velocity"] == "pps"
    assert any(kind == "target" for _, kind, _ in result.events)
    assert result.summary["state"] == "running"
    assert result.refusals["count"] == 0
    assert result.summary["simulated_s"] == pytest.approx(3600.0)


def test_trace_matches_the_cli(tmp_path):
    tmcl = os.environ.get("TMCL_BIN")
    if not tmcl or not Path(tmcl).exists():
        pytest.skip("TMCL_BIN names no tmcl binary (scripts/python-package-tests.sh sets it)")
    source = tmp_path / "manual.tmc"
    source.write_text(MANUAL_2_4)
    out = tmp_path / "trace.csv"
    subprocess.run([tmcl, "run", str(source), "--for", "60", "--every", "10", "--trace", str(out)],
                   check=True, capture_output=True)
    with out.open() as f:
        rows = list(csv.reader(f))
    header, rows = rows[0], rows[1:]
    result = opentmcl.run(MANUAL_2_4, seconds=60, every=0.01)
    assert len(rows) == len(result)
    for name in header:
        if name not in result.columns:
            continue  # the events column
        cli = [float(row[header.index(name)]) if row[header.index(name)] else None for row in rows]
        assert cli == pytest.approx(result.columns[name]), name


def test_refusals_are_reported():
    # SAP 4 with a negative speed is refused with status 4 (invalid value); the program goes on.
    result = opentmcl.run("    SAP 4, 0, -1\n    SGP 0, 2, 1\n    STOP\n", seconds=1)
    assert result.refusals["count"] == 1
    refusal = result.refusals["last"][0]
    assert (refusal["pc"], refusal["status"], refusal["instruction"]) == (0, 4, (5, 4, 0, -1))
    assert result.summary["state"] == "stopped"


def test_world_and_columns_as_dataframe_or_lists():
    result = opentmcl.run("    MVP ABS, 0, 512000\n    WAIT POS, 0, 0\n    STOP\n", seconds=30, every=0.1,
                          world='[axis]\nkind = "linear"\nlead = 2.0\n\n[[load.jam]]\nat = [5.0, 5.5]\ntorque = 5.0\n')
    try:
        import pandas
    except ImportError:
        assert result.trace is result.columns
    else:
        assert isinstance(result.trace, pandas.DataFrame)
        assert list(result.trace.columns) == list(result.columns)
    assert result.columns["time_s"][-1] == pytest.approx(30.0)


def test_run_errors():
    with pytest.raises(opentmcl.AssemblyError) as err:
        opentmcl.run("    JA Nowhere\n")
    assert (err.value.line, err.value.column) == (1, 8)
    with pytest.raises(ValueError):
        opentmcl.run("    STOP\n", seconds=-1)
    with pytest.raises(ValueError, match="unknown"):
        opentmcl.run("    STOP\n", model="nope")

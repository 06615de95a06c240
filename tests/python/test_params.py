"""Parameter sets and twins (issue 21): `tmcl params --save/--load/--diff` round trips on each model and
across models, and `tmcl twin` made from one `tmcl serve` answering every parameter like it when served."""

from __future__ import annotations

import json
import subprocess
import tomllib

import pytest

MODELS = ["pd28-1021", "tmcm-1310", "pd-113", "tmcm-1140"]
# Values that change by themselves: not compared between two modules (the tick timer, the random number,
# and the driver flags, whose standstill bit comes up a while after each start).
LIVE = {("gp", 0, 132), ("gp", 0, 133), ("ap", 0, 208)}


def tmcl(tmcl_bin, *args, check=True):
    run = subprocess.run([str(tmcl_bin), *map(str, args)], capture_output=True, text=True, timeout=120)
    if check:
        assert run.returncode == 0, f"tmcl {' '.join(map(str, args))}: {run.returncode}\n{run.stdout}\n{run.stderr}"
    return run


def values(tmcl_bin, link):
    """Every readable parameter of the module on `link`: {(kind, index, number): value}."""
    rows = tmcl(tmcl_bin, "--port", link, "params", "--json").stdout.splitlines()
    out = {}
    for row in map(json.loads, rows):
        if row.get("value") is None:
            continue
        kind = "ap" if "motor" in row else "gp"
        out[(kind, row.get("motor", row.get("bank")), row["type"])] = row["value"]
    return out


# A setting of each model to change, in that model's own unit: (name, value).
CHANGES = {
    "pd28-1021": [("MaxPositioningSpeed", 30000), ("MaxCurrent", 100)],
    "tmcm-1310": [("MaxVelocity", 30000), ("MaxCurrent", 100)],
    "pd-113": [("MaxPositioningSpeed", 700), ("AbsMaxCurrent", 100)],
    "tmcm-1140": [("MaxVelocity", 700), ("MaxCurrent", 100)],
}


@pytest.mark.parametrize("model", MODELS)
def test_a_set_saved_loads_back_and_diffs_clean(tmcl_bin, tmp_path, serve, model):
    server = serve("pty", modules=[model])
    link = server.link
    for name, value in CHANGES[model]:
        tmcl(tmcl_bin, "--port", link, "set", "ap", name, value)
    saved = tmp_path / "set.toml"
    out = tmcl(tmcl_bin, "--port", link, "params", "--save", saved).stdout
    assert "saved" in out
    data = tomllib.loads(saved.read_text())
    assert data["module"]["model"] == model and data["module"]["version"]
    speed = next(p for p in data["param"] if p["name"] == CHANGES[model][0][0])
    assert speed["value"] == CHANGES[model][0][1] and speed["unit"] and speed["kind"] == "ap"
    # Change it, see the difference, load the set back (stored), and nothing differs.
    tmcl(tmcl_bin, "--port", link, "set", "ap", CHANGES[model][0][0], 500)
    diff = tmcl(tmcl_bin, "--port", link, "params", "--diff", saved, check=False)
    assert diff.returncode == 5, diff.stdout + diff.stderr
    assert CHANGES[model][0][0] in diff.stdout and "1 of" in diff.stdout
    load = tmcl(tmcl_bin, "--port", link, "params", "--load", saved, "--store", "--json")
    outcomes = [json.loads(l) for l in load.stdout.splitlines()]
    by_name = {o["name"]: o for o in outcomes}
    assert by_name[CHANGES[model][0][0]]["result"] == "stored"
    assert by_name["ActualPosition"]["result"] == "skipped"
    assert "state" in by_name["ActualPosition"]["why"]
    assert not [o for o in outcomes if o["result"] == "refused"]
    tmcl(tmcl_bin, "--port", link, "params", "--diff", saved)
    # Stored: a restart on the same EEPROM keeps it. (The in-memory server starts fresh, so ask RSAP.)
    tmcl(tmcl_bin, "--port", link, "restore", "ap", CHANGES[model][0][0])
    got = tmcl(tmcl_bin, "--port", link, "get", "ap", CHANGES[model][0][0], "--json").stdout
    assert json.loads(got)["value"] == CHANGES[model][0][1]


def test_a_set_of_another_model_is_refused_unless_told_and_then_matched_by_unit(tmcl_bin, tmp_path, serve):
    pd28 = serve("pty", modules=["pd28-1021"])
    pd113 = serve("pty", modules=["pd-113"])
    tmcl(tmcl_bin, "--port", pd28.link, "set", "ap", "MaxCurrent", 90)
    saved = tmp_path / "pd28.toml"
    tmcl(tmcl_bin, "--port", pd28.link, "params", "--save", saved)
    refused = tmcl(tmcl_bin, "--port", pd113.link, "params", "--load", saved, check=False)
    assert refused.returncode == 2
    assert "the set is of a PD28-1021" in refused.stderr and "--any-model" in refused.stderr
    # Told: what matches by number and unit is written; a speed in pps is not put into TMC428 units.
    loaded = tmcl(tmcl_bin, "--port", pd113.link, "params", "--load", saved, "--any-model", "--json", check=False)
    outcomes = {o["param"]: o for o in map(json.loads, loaded.stdout.splitlines()) if "param" in o}
    assert outcomes["ap 4"]["result"] == "skipped"
    assert "the unit differs: pps in the file, TMC428 v units on the PDx-113" in outcomes["ap 4"]["why"]
    assert outcomes["ap 6"]["result"] == "written"
    assert json.loads(tmcl(tmcl_bin, "--port", pd113.link, "get", "ap", "6", "--json").stdout)["value"] == 90
    # Each refusal is reported and makes the exit code 1.
    if any(o["result"] == "refused" for o in outcomes.values()):
        assert loaded.returncode == 1
    else:
        assert loaded.returncode == 0


@pytest.mark.parametrize("model", MODELS)
def test_a_twin_answers_every_parameter_like_its_module(tmcl_bin, tmp_path, serve, model):
    original = serve("pty", modules=[model], eeprom=tmp_path / "original.eeprom")
    for name, value in CHANGES[model]:
        tmcl(tmcl_bin, "--port", original.link, "set", "ap", name, value)
        tmcl(tmcl_bin, "--port", original.link, "store", "ap", name)
    tmcl(tmcl_bin, "--port", original.link, "set", "gp", "3", "1234", "2")
    tmcl(tmcl_bin, "--port", original.link, "store", "gp", "3", "2")
    program = tmp_path / "p.tmc"
    program.write_text("Loop:\n    ROR 0, 100\n    WAIT TICKS, 0, 50\n    MST 0\n    JA Loop\n")
    tmcl(tmcl_bin, "--port", original.link, "download", program)
    out_dir = tmp_path / "twin"
    made = json.loads(tmcl(tmcl_bin, "--port", original.link, "twin", "--out", out_dir, "--json").stdout)
    assert made["model"] == model and made["instructions"] == 4 and not made["refused"]
    assert (out_dir / "params.toml").is_file() and (out_dir / "world.toml").is_file()
    assert "ROR" in (out_dir / "program.tmc").read_text()
    # The original after a power cycle, and its twin: the same answer to every parameter.
    original.restart()
    twin = serve("pty", modules=[model], eeprom=out_dir / f"{model}.eeprom",
                 extra=["--world", str(out_dir / "world.toml")])
    a, b = values(tmcl_bin, original.link), values(tmcl_bin, twin.link)
    assert a.keys() == b.keys()
    differ = {k: (a[k], b[k]) for k in a if k not in LIVE and a[k] != b[k]}
    assert not differ, differ
    for link in (original.link, twin.link):
        assert json.loads(tmcl(tmcl_bin, "--port", link, "get", "gp", "3", "2", "--json").stdout)["value"] == 1234
    upload = tmcl(tmcl_bin, "--port", twin.link, "upload", "-o", tmp_path / "back.tmc")
    assert upload.returncode == 0

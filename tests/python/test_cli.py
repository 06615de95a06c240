"""The `tmcl` host commands against `tmcl serve`, mixed with pytrinamic on the same module."""

import json
import subprocess

from pathlib import Path

from tmcltest import pytrinamic_connection

ROOT = Path(__file__).resolve().parents[2]


def tmcl(tmcl_bin, *args, timeout=20):
    return subprocess.run([str(tmcl_bin), *args], capture_output=True, text=True, timeout=timeout,
                          stdin=subprocess.DEVNULL)


def test_version(tmcl_bin, pty_server):
    r = tmcl(tmcl_bin, "--port", str(pty_server.link), "version")
    assert r.returncode == 0, r.stderr
    assert r.stdout.splitlines()[0] == "1021V142"
    r = tmcl(tmcl_bin, "--port", str(pty_server.link), "--json", "version")
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    assert doc["version"] == "1021V142"
    assert doc["firmware"] == "1.42"


def test_get_set_ap(tmcl_bin, pty_server):
    link = str(pty_server.link)
    r = tmcl(tmcl_bin, "--port", link, "get", "ap", "4")
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "ap 4 = 51200"
    r = tmcl(tmcl_bin, "--port", link, "set", "ap", "4", "1000")
    assert r.returncode == 0, r.stderr
    r = tmcl(tmcl_bin, "--port", link, "get", "ap", "4")
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "ap 4 = 1000"
    # The same module seen by pytrinamic, then back to the CLI.
    with pytrinamic_connection(pty_server) as conn:
        assert conn.get_axis_parameter(4, 0) == 1000
        conn.set_axis_parameter(174, 0, -7)
    r = tmcl(tmcl_bin, "--port", link, "get", "ap", "174")
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "ap 174 = -7"


def test_out_of_range_set_exits_1(tmcl_bin, pty_server):
    link = str(pty_server.link)
    r = tmcl(tmcl_bin, "--port", link, "set", "ap", "4", "0")
    assert r.returncode == 1, (r.stdout, r.stderr)
    r = tmcl(tmcl_bin, "--port", link, "--json", "set", "ap", "4", "0")
    assert r.returncode == 1
    doc = json.loads(r.stdout)
    assert (doc["exit_code"], doc["kind"], doc["reply"]["status"]) == (1, "status", 4)
    assert "MaxPositioningSpeed takes 1..2147483647" in doc["error"]
    r = tmcl(tmcl_bin, "--port", link, "get", "ap", "4")
    assert r.stdout.strip() == "ap 4 = 51200"


def test_json_get_gp(tmcl_bin, pty_server):
    r = tmcl(tmcl_bin, "--port", str(pty_server.link), "--json", "get", "gp", "66")
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    assert doc["status"] == 100
    assert doc["value"] == 1
    r = tmcl(tmcl_bin, "--port", str(pty_server.link), "--json", "get", "gp", "76")
    assert json.loads(r.stdout)["value"] == 2


def test_store_restore_and_send(tmcl_bin, pty_server):
    link = str(pty_server.link)
    assert tmcl(tmcl_bin, "--port", link, "set", "gp", "9", "-12", "2").returncode == 0
    assert tmcl(tmcl_bin, "--port", link, "store", "gp", "9", "2").returncode == 0
    assert tmcl(tmcl_bin, "--port", link, "set", "gp", "9", "1", "2").returncode == 0
    assert tmcl(tmcl_bin, "--port", link, "restore", "gp", "9", "2").returncode == 0
    r = tmcl(tmcl_bin, "--port", link, "get", "gp", "9", "2")
    assert r.stdout.strip() == "gp 9 (bank 2) = -12"
    r = tmcl(tmcl_bin, "--port", link, "--json", "send", "GAP", "140", "0", "0")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["value"] == 8
    r = tmcl(tmcl_bin, "--port", link, "get", "ap", "100")
    assert r.returncode == 1


def test_cli_over_tcp(tmcl_bin, tcp_server):
    addr = f"127.0.0.1:{tcp_server.port}"
    r = tmcl(tmcl_bin, "--tcp", addr, "version")
    assert r.returncode == 0, r.stderr
    assert r.stdout.splitlines()[0] == "1021V142"
    assert tmcl(tmcl_bin, "--tcp", addr, "set", "ap", "5", "100000").returncode == 0
    r = tmcl(tmcl_bin, "--tcp", addr, "--json", "get", "ap", "5")
    assert json.loads(r.stdout)["value"] == 100000


# ---- names, params, wait, watch, exit codes and JSON of every subcommand ---------------------------------


def test_parameters_by_name(tmcl_bin, pty_server):
    link = str(pty_server.link)
    r = tmcl(tmcl_bin, "get", "ap", "MaxPositioningSpeed", "--port", link)
    assert (r.returncode, r.stdout) == (0, "ap 4 MaxPositioningSpeed = 51200 pps\n"), r.stderr
    for name in ["maxpositioningspeed", "APMaxPositioningSpeed", "Maximum positioning speed"]:
        assert tmcl(tmcl_bin, "--port", link, "get", "ap", name).stdout.startswith("ap 4 MaxPositioningSpeed = ")
    assert tmcl(tmcl_bin, "--port", link, "set", "ap", "maxacceleration", "1000").returncode == 0
    assert tmcl(tmcl_bin, "--port", link, "get", "ap", "5").stdout == "ap 5 = 1000\n"
    # A bank 3 name picks bank 3; with --module no version request is needed.
    r = tmcl(tmcl_bin, "--port", link, "--module", "pd28-1021", "get", "gp", "Timer0Period")
    assert r.stdout == "gp 0 (bank 3) Timer0Period = 0 ms\n", r.stderr
    # An unknown name is a usage error with a suggestion; nothing is sent but the version request.
    r = tmcl(tmcl_bin, "--port", link, "get", "ap", "maxspeed")
    assert r.returncode == 2
    assert "did you mean MaxPositioningSpeed?" in r.stderr
    # An unknown number: the module's status, explained.
    r = tmcl(tmcl_bin, "--port", link, "get", "ap", "100")
    assert r.returncode == 1
    assert "status 3 (wrong type): the PD28-1021 has no axis parameter 100" in r.stderr
    r = tmcl(tmcl_bin, "--port", link, "set", "ap", "PositionReachedFlag", "0")
    assert r.returncode == 1 and "PositionReachedFlag is read-only" in r.stderr


def test_params_lists_names_ranges_units_and_values(tmcl_bin, pty_server):
    link = str(pty_server.link)
    assert tmcl(tmcl_bin, "--port", link, "set", "ap", "4", "12345").returncode == 0
    r = tmcl(tmcl_bin, "--port", link, "params", "ap")
    assert r.returncode == 0, r.stderr
    row = next(line for line in r.stdout.splitlines() if line.startswith("ap 4 "))
    assert row.split() == ["ap", "4", "MaxPositioningSpeed", "RWE", "1..2147483647", "pps", "12345"]
    r = tmcl(tmcl_bin, "--port", link, "--json", "params")
    rows = [json.loads(line) for line in r.stdout.splitlines()]
    assert len(rows) == 58 + 19 + 9
    speed = next(x for x in rows if x.get("motor") == 0 and x["type"] == 4)
    assert (speed["name"], speed["unit"], speed["value"], speed["access"]) == ("MaxPositioningSpeed", "pps", 12345, "RWE")
    # Offline, from the tables alone.
    r = tmcl(tmcl_bin, "params", "--module", "tmcm-1310", "ap", "--no-values")
    assert r.returncode == 0 and "ClosedLoopMode" in r.stdout
    r = tmcl(tmcl_bin, "params")
    assert r.returncode == 2 and "--module" in r.stderr


def test_wait_and_watch(tmcl_bin, pty_server):
    link = str(pty_server.link)
    assert tmcl(tmcl_bin, "--port", link, "send", "MVP", "ABS", "0", "25600").returncode == 0
    r = tmcl(tmcl_bin, "--port", link, "wait", "reached", "--within", "0.05")
    assert r.returncode == 5, (r.stdout, r.stderr)
    assert "not within 0.05 s" in r.stderr
    r = tmcl(tmcl_bin, "--port", link, "--json", "wait", "reached", "--within", "30")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["met"] is True
    assert tmcl(tmcl_bin, "--port", link, "get", "ap", "1").stdout == "ap 1 = 25600\n"
    r = tmcl(tmcl_bin, "--port", link, "wait", "value", "ap", "ActualPosition", "ge", "25600", "--within", "1")
    assert r.returncode == 0 and r.stdout.startswith("ap 1 ActualPosition >= 25600 after"), r.stderr
    r = tmcl(tmcl_bin, "--port", link, "watch", "ap", "1", "gp", "TickTimer", "--count", "3", "--every", "0.05")
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert lines[0].split() == ["time_s", "ap", "1", "gp", "132", "TickTimer"]
    ticks = [int(line.split()[2]) for line in lines[1:]]
    assert len(ticks) == 3 and ticks == sorted(ticks) and ticks[0] < ticks[2]
    r = tmcl(tmcl_bin, "--port", link, "--json", "watch", "ap", "1", "--count", "2")
    rows = [json.loads(line) for line in r.stdout.splitlines()]
    assert [row["ap 1"] for row in rows] == [25600, 25600]
    r = tmcl(tmcl_bin, "--port", link, "watch", "ap")
    assert r.returncode == 2


def test_connection_options_only_where_a_module_is_talked_to(tmcl_bin, tmp_path):
    for command in (["run", "x.tmc", "--for", "1"], ["asm", "x.tmc"], ["disasm", "x.bin"], ["debug", "x.tmc"]):
        r = tmcl(tmcl_bin, *command, "--port", "/dev/null")
        assert r.returncode == 2 and "unexpected argument '--port'" in r.stderr, (command, r.stderr)
        r = tmcl(tmcl_bin, command[0], "--help")
        assert "--port" not in r.stdout and "--baud" not in r.stdout and "Exit codes" in r.stdout
    r = tmcl(tmcl_bin, "get", "--help")
    assert "--port" in r.stdout and "--timeout" in r.stdout


def test_exit_codes_and_json_errors_of_every_kind(tmcl_bin, tmp_path):
    bad = tmp_path / "bad.tmc"
    bad.write_text("JA Nowhere\n")
    for command in (["asm", str(bad)], ["run", str(bad), "--for", "1"], ["debug", str(bad)]):
        r = tmcl(tmcl_bin, "--json", *command)
        assert r.returncode == 2, (command, r.stderr)
        doc = json.loads(r.stdout.splitlines()[-1])
        assert (doc["kind"], doc["exit_code"]) == ("assembly", 2)
        assert doc["diagnostics"][0]["line"] == 1 and "Nowhere" in doc["diagnostics"][0]["message"]
    # No module on the other end: 3, as JSON too.
    r = tmcl(tmcl_bin, "--json", "version", "--port", str(tmp_path / "nothing"))
    assert r.returncode == 3
    assert json.loads(r.stdout)["kind"] == "io"
    # A usage error clap finds: 2, as JSON too.
    r = tmcl(tmcl_bin, "--json", "get", "ap")
    assert r.returncode == 2
    assert json.loads(r.stdout)["kind"] == "usage"
    # A module that does not answer in time.
    r = tmcl(tmcl_bin, "--json", "upload", "--tcp", "127.0.0.1:9", "--timeout", "0.2")
    assert r.returncode == 3 and json.loads(r.stdout)["exit_code"] == 3


def test_json_of_the_program_commands(tmcl_bin, pty_server, tmp_path):
    link = str(pty_server.link)
    src = tmp_path / "p.tmc"
    src.write_text("Loop: WAIT TICKS, 0, 10\nJA Loop\n")
    r = tmcl(tmcl_bin, "--json", "asm", str(src))
    assert json.loads(r.stdout) == {"output": str(tmp_path / "p.bin"), "instructions": 2, "symbols": None}
    r = tmcl(tmcl_bin, "--json", "disasm", str(tmp_path / "p.bin"))
    assert json.loads(r.stdout)["instructions"] == 2
    docs = {}
    for command in (["download", str(src)], ["start"], ["status"], ["stop"], ["upload", "--count", "2"], ["version"]):
        r = tmcl(tmcl_bin, "--port", link, "--json", *command)
        assert r.returncode == 0, (command, r.stderr)
        docs[command[0]] = json.loads(r.stdout)
    assert docs["download"] == {"stored": 2, "at": 0, "verified": False}
    assert docs["start"] == {"running": True, "from": None}
    assert docs["status"]["mode_text"] == "running"
    assert docs["stop"] == {"stopped": True}
    assert docs["upload"]["read"] == 2 and "WAIT TICKS, 0, 10" in docs["upload"]["source"]
    assert (docs["version"]["model"], docs["version"]["address"]) == (1021, 1)
    r = tmcl(tmcl_bin, "--port", link, "--json", "get", "gp", "66")
    doc = json.loads(r.stdout)
    assert (doc["address"], doc["host"], doc["bank"], doc["type"]) == (1, 2, 0, 66)


def test_debug_and_run_json(tmcl_bin):
    program = str(ROOT / "tests/programs/manual_p01_first_steps.tmc")
    r = subprocess.run([str(tmcl_bin), "--json", "debug", program], input="step 2\nprint\nquit\n",
                       capture_output=True, text=True, timeout=30)
    assert r.returncode == 0, r.stderr
    answers = [json.loads(line) for line in r.stdout.splitlines()]
    assert answers[0]["command"] is None  # the banner
    assert [a["command"] for a in answers[1:]] == ["step 2", "print", "quit"]
    assert answers[1]["pc"] == 2 and answers[1]["state"] == "stopped"
    assert any("pc 2" in line for line in answers[2]["output"])
    r = tmcl(tmcl_bin, "--json", "run", program, "--for", "1")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["simulated_s"] == 1


def test_run_and_debug_list_refused_instructions(tmcl_bin, tmp_path):
    # The module refuses these four (PD28-1021: AP 4 is 1.., one motor, outputs 0 and 1, no AP 99); the
    # program skips them and goes on, and the simulator says so with the status, line and reason.
    program = tmp_path / "refused.tmc"
    program.write_text("SAP 4, 0, 0\nMVP ABS, 5, 100\nSIO 7, 2, 1\nGAP 99, 0\nROR 0, 1000\nSTOP\n")
    r = tmcl(tmcl_bin, "--json", "run", str(program), "--for", "1")
    assert r.returncode == 0, r.stderr
    row = json.loads(r.stdout)
    assert row["refused"] == 4 and row["executed"] == 6
    assert [(x["line"], x["status"]) for x in row["refusals"]] == [(1, 4), (2, 4), (3, 3), (4, 3)]
    assert "takes 1..2147483647" in row["refusals"][0]["reason"]
    r = subprocess.run([str(tmcl_bin), "--json", "debug", str(program)], input="step 4\nstep\n",
                       capture_output=True, text=True, timeout=30)
    answers = [json.loads(line) for line in r.stdout.splitlines()]
    assert [x["pc"] for x in answers[1]["refused"]] == [0, 1, 2, 3]
    assert answers[2]["refused"] == [] and answers[2]["output"][0].startswith("status 100")

"""The `tmcl` host commands against `tmcl serve`, mixed with pytrinamic on the same module."""

import json
import subprocess

from tmcltest import pytrinamic_connection


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
    assert json.loads(r.stdout)["status"] == 4
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

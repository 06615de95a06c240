"""The file-backed EEPROM (`--eeprom FILE`): restarts after SIGTERM and after SIGKILL."""

import random
import threading
import time

import pytest

from tmcltest import DEFAULT_AP, pytrinamic_connection, wait_until


def test_restart_keeps_stored_values_only(eeprom_server):
    with pytrinamic_connection(eeprom_server) as conn:
        conn.set_axis_parameter(4, 0, 123456)
        conn.store_axis_parameter(4, 0)  # STAP: stored
        conn.set_axis_parameter(5, 0, 77777)  # not stored
        conn.set_axis_parameter(214, 0, 500)  # not stored either
        conn.set_global_parameter(7, 2, -987654)
        conn.store_global_parameter(7, 2)  # STGP: stored
        conn.set_global_parameter(8, 2, 31337)  # not stored
        conn.set_global_parameter(77, 0, 1)  # bank 0, 65..90: stored automatically
        conn.move_by(0, 2000)
        wait_until(lambda: conn.get_axis_parameter(8, 0) == 1, 5, what="position reached")
        assert conn.get_axis_parameter(1, 0) == 2000
    assert eeprom_server.eeprom.exists()
    eeprom_server.restart()
    with pytrinamic_connection(eeprom_server) as conn:
        assert conn.get_axis_parameter(4, 0) == 123456
        assert conn.get_axis_parameter(5, 0) == DEFAULT_AP[5]
        assert conn.get_axis_parameter(214, 0) == DEFAULT_AP[214]
        assert conn.get_global_parameter(7, 2, signed=True) == -987654
        assert conn.get_global_parameter(8, 2) == 0
        assert conn.get_global_parameter(77, 0) == 1
        assert conn.get_axis_parameter(1, 0) == 0  # the step counter starts at 0
        assert conn.get_version_string() == "1021V142"
        # Back to factory state for the next start (GP 77 = 1 would autostart an empty program).
        conn.set_global_parameter(77, 0, 0)
    eeprom_server.restart()
    with pytrinamic_connection(eeprom_server) as conn:
        assert conn.get_global_parameter(77, 0) == 0
        assert conn.get_axis_parameter(4, 0) == 123456


def test_without_eeprom_file_state_is_not_kept(serve):
    server = serve("pty")
    with pytrinamic_connection(server) as conn:
        conn.set_axis_parameter(4, 0, 4444)
        conn.store_axis_parameter(4, 0)
        conn.set_global_parameter(0, 2, 9)
        conn.store_global_parameter(0, 2)
    server.restart()
    with pytrinamic_connection(server) as conn:
        assert conn.get_axis_parameter(4, 0) == DEFAULT_AP[4]
        assert conn.get_global_parameter(0, 2) == 0


def test_all_e_parameters_survive_restart(eeprom_server):
    stored = {4: 100000, 5: 200000, 6: 200, 7: 16, 12: 1, 13: 1, 130: 5, 140: 6, 204: 1000, 214: 300, 254: 3}
    with pytrinamic_connection(eeprom_server) as conn:
        for number, value in stored.items():
            conn.set_and_store_axis_parameter(number, 0, value)
    eeprom_server.restart()
    with pytrinamic_connection(eeprom_server) as conn:
        for number, value in stored.items():
            assert conn.get_axis_parameter(number, 0) == value, f"AP {number}"


@pytest.mark.parametrize("round_", range(5))
def test_kill9_keeps_every_acknowledged_store(serve, tmp_path, round_):
    """Store user variables, SIGKILL the server while more stores are in flight, restart: every STGP that
    was acknowledged before the kill is present; the one in flight is either old or new."""
    rng = random.Random(1000 + round_)
    eeprom = tmp_path / "eeprom.bin"
    server = serve("pty", eeprom=eeprom)
    base = 1_000_000 * (round_ + 1)
    acked: dict[int, int] = {}
    with pytrinamic_connection(server) as conn:
        for i in range(56):
            conn.set_global_parameter(i, 2, base + i)
            conn.store_global_parameter(i, 2)
            acked[i] = base + i
        conn.set_and_store_axis_parameter(4, 0, 10_000 + round_)

    # A second series from a thread; the kill lands somewhere inside it.
    in_flight: dict[int, int] = {}
    done = [0]
    lock = threading.Lock()
    stop = threading.Event()
    errors = []

    def writer():
        try:
            with pytrinamic_connection(server) as conn:
                n = 0
                while not stop.is_set() and n < 5000:
                    i = n % 56
                    value = -(base + 1000 * (n + 1) + i)
                    with lock:
                        in_flight[i] = value
                    conn.set_global_parameter(i, 2, value)
                    conn.store_global_parameter(i, 2)
                    with lock:
                        acked[i] = value
                        del in_flight[i]
                        done[0] += 1
                    n += 1
        except Exception as exc:  # the server died under us: expected
            errors.append(exc)

    thread = threading.Thread(target=writer, daemon=True)
    thread.start()
    # Kill after a random number of acknowledged stores, plus a random fraction of one request.
    target = rng.randrange(10, 120)
    wait_until(lambda: done[0] >= target or not thread.is_alive(), 20, what=f"{target} stores")
    assert thread.is_alive(), f"writer failed early: {errors}"
    time.sleep(rng.random() * 0.003)
    server.kill()
    thread.join(timeout=10)
    stop.set()
    assert not thread.is_alive(), "writer thread still blocked 10 s after the kill"
    assert errors, "the writer did not notice the kill"

    with lock:
        acked_now = dict(acked)
        pending = dict(in_flight)
    server.start()  # same EEPROM file, the stale link is replaced
    with pytrinamic_connection(server) as conn:
        assert conn.get_axis_parameter(4, 0) == 10_000 + round_
        for i in range(56):
            got = conn.get_global_parameter(i, 2, signed=True)
            allowed = {acked_now[i]}
            if i in pending:
                allowed.add(pending[i])
            assert got in allowed, f"user variable {i}: got {got}, acknowledged {acked_now[i]}"

"""The firmware on an emulated Cortex-M3 (QEMU's lm3s6965evb, scripts/qemu-serve.sh), driven by unchanged
host software over its UART: pytrinamic, raw frames, ASCII mode, and the `tmcl` host commands. Beyond what
the host sees, the tests look at the microcontroller through QEMU's monitor: the step pulses the step/dir
output gave, the output pins, the input pins (the board's navigation switches, pressed through QEMU), and
the stack left untouched.

Skipped, with the reason, where qemu-system-arm or the thumbv7m-none-eabi target is missing. The rest of
the suite runs against the image with `scripts/python-tests.sh --target qemu`.
"""

import subprocess

import pytest
from pytrinamic.tmcl import TMCLReplyStatusError

from test_ascii import ECHO_NONE, AsciiLinePort
from test_program import PROGRAM, RUN, download
from tmcltest import LinePort, QemuServer, elf_symbols, frame, pytrinamic_connection, wait_until

STATUS_INVALID_COMMAND, STATUS_WRONG_TYPE, STATUS_INVALID_VALUE = 2, 3, 4
# GPIO port F's data register seen through the mask of PF0 and PF2 (OUT0, OUT1; data sheet §8.2.1.2).
GPIOF_OUT_PINS = 0x4002_5000 + ((1 << 0 | 1 << 2) << 2)
STACK_PAINT = 0xCCCC_CCCC


@pytest.fixture
def bus(qemu_server):
    with pytrinamic_connection(qemu_server) as conn:
        yield conn


def status_of(call) -> int:
    with pytest.raises(TMCLReplyStatusError) as error:
        call()
    return error.value.status_code


def steps(server) -> tuple[int, int]:
    """(pending, pulsed) of the step/dir output (`tmcl_mcu::step::StepOutput`: two i32)."""
    address = elf_symbols(server.image)["tmcl_lm3s6965::steps::STEPS"]
    pending, pulses = server.read_words(address, 2)
    signed = lambda w: w - (1 << 32) if w & 0x8000_0000 else w  # noqa: E731
    return signed(pending), signed(pulses)


def wait_for_steps(server, expected: tuple[int, int], what: str) -> None:
    """Waits up to 5 s for the step output's (pending, pulsed) to be `expected`; a failure names what it saw."""
    seen = []

    def reached() -> bool:
        seen.append(steps(server))
        return seen[-1] == expected

    try:
        wait_until(reached, 5, what=what)
    except AssertionError as e:
        raise AssertionError(f"{e}: (pending, pulsed) was {seen[-1]}, expected {expected}") from e


def test_version(bus):
    assert bus.get_version_string() == "1021V142"
    reply = bus.send(136, 1, 0, 0)
    assert reply.status == 100 and reply.value == 0x0A15012A, reply  # 10, 21, 1, 42


def test_parameters_with_their_ranges_and_statuses(bus):
    assert bus.get_axis_parameter(4, 0) == 51200
    bus.set_axis_parameter(4, 0, 102400)
    assert bus.get_axis_parameter(4, 0) == 102400
    bus.set_axis_parameter(1, 0, -1000)
    assert bus.get_axis_parameter(1, 0, signed=True) == -1000
    # Table 15: AP 140 takes 0..8; AP 4 at least 1; AP 99 does not exist.
    assert status_of(lambda: bus.set_axis_parameter(140, 0, 9)) == STATUS_INVALID_VALUE
    assert status_of(lambda: bus.set_axis_parameter(4, 0, 0)) == STATUS_INVALID_VALUE
    assert status_of(lambda: bus.get_axis_parameter(99, 0)) == STATUS_WRONG_TYPE
    assert bus.get_axis_parameter(140, 0) == 8
    assert status_of(lambda: bus.get_axis_parameter(4, 1)) == STATUS_INVALID_VALUE  # motor 1
    assert status_of(lambda: bus.send(0x30, 0, 0, 0)) == STATUS_INVALID_COMMAND
    # Bank 0 (stored at once), bank 2 user variables, STAP/RSAP through the EEPROM in RAM.
    bus.set_global_parameter(65, 0, 7)
    assert bus.get_global_parameter(65, 0) == 7
    bus.set_global_parameter(3, 2, -5)
    assert bus.get_global_parameter(3, 2, signed=True) == -5
    bus.set_axis_parameter(6, 0, 100)
    assert bus.send(7, 6, 0, 0).status == 100  # STAP
    bus.set_axis_parameter(6, 0, 50)
    assert bus.send(8, 6, 0, 0).status == 100  # RSAP
    assert bus.get_axis_parameter(6, 0) == 100


def test_a_move_reaches_its_target_and_every_microstep_is_pulsed(qemu_server, bus):
    bus.set_axis_parameter(4, 0, 102400)
    bus.set_axis_parameter(5, 0, 204800)
    bus.move_to(0, 51200)
    wait_until(lambda: bus.get_axis_parameter(8, 0) == 1, 15, interval_s=0.05, what="position reached")
    assert bus.get_axis_parameter(1, 0, signed=True) == 51200
    assert bus.get_axis_parameter(3, 0, signed=True) == 0
    # The step output catches up within a motion tick or two after the ramp has ended.
    wait_for_steps(qemu_server, (0, 51200), "all step pulses given")
    bus.move_by(0, -12800)
    wait_until(lambda: bus.get_axis_parameter(8, 0) == 1, 15, interval_s=0.05, what="position reached")
    wait_for_steps(qemu_server, (0, 38400), "the pulses back")
    # Reverse shaft (GP 90): the same step counter, the other way at the pins.
    bus.set_global_parameter(90, 0, 1)
    bus.move_to(0, 38400 + 6400)
    wait_until(lambda: bus.get_axis_parameter(8, 0) == 1, 15, interval_s=0.05, what="position reached")
    wait_for_steps(qemu_server, (0, 38400 - 6400), "reversed pulses")


def test_a_downloaded_program_runs(bus):
    download(bus, PROGRAM)
    bus.send(RUN, 1, 0, 0)
    assert bus.get_global_parameter(128, 0) == 1, "running"
    wait_until(lambda: bus.get_global_parameter(7, 2) >= 2, 15, what="two loops of the program")
    bus.send(128, 0, 0, 0)
    assert bus.get_global_parameter(128, 0) == 0


def test_ascii_mode(qemu_server):
    with AsciiLinePort(qemu_server.link) as term:
        term.ok(1, 9, 67, 0, ECHO_NONE)  # GP 67: no echo
        term.enter_ascii()
        assert term.reply_line("AGAP 4, 0") == (100, 51200)
        assert term.reply_line("ASAP 4, 0, 1000") == (100, 1000)
        assert term.reply_line("AGAP 4, 0") == (100, 1000)
        assert term.reply_line("ASAP 140, 0, 9")[0] == STATUS_INVALID_VALUE
        term.write(b"ABIN\r")
        term.read_quiet()
        assert term.request(1, 6, 4, 0, 0).value == 1000


def test_outputs_drive_the_pins(qemu_server, bus):
    assert qemu_server.read_words(GPIOF_OUT_PINS)[0] == 0
    bus.set_digital_output(0)  # SIO 0, 2, 1
    assert qemu_server.read_words(GPIOF_OUT_PINS)[0] == 1 << 0
    bus.send(14, 1, 2, 1)  # SIO 1, 2, 1
    assert qemu_server.read_words(GPIOF_OUT_PINS)[0] == 1 << 0 | 1 << 2
    assert bus.get_global_parameter(255, 0) == 0  # nothing else moved
    bus.send(14, 255, 2, 0)  # all outputs off
    assert qemu_server.read_words(GPIOF_OUT_PINS)[0] == 0


def test_inputs_read_the_pins(qemu_server, bus):
    assert bus.get_digital_input(0) == 0
    # The board's "up" navigation switch is on PE0: IN0. QEMU presses it for 1.5 s.
    qemu_server.monitor("sendkey up 1500")
    assert bus.get_digital_input(0) == 1
    assert bus.send(15, 255, 0, 0).value == 0b0001  # GIO 255, 0: all inputs
    wait_until(lambda: bus.get_digital_input(0) == 0, 5, what="the switch released")


def test_analog_input_and_temperature(bus):
    # QEMU's ADC returns mid-scale with a little noise: 0x200..0x207 of 10 bits, 2048..2076 of 12.
    assert 2048 <= bus.get_analog_input(0) <= 2076
    # The LM3S6965 sensor's transfer function at mid-scale: 35 °C.
    assert 34 <= bus.send(15, 9, 1, 0).value <= 35


def test_cli_host_commands(qemu_server, tmcl_bin):
    def tmcl(*args):
        return subprocess.run([str(tmcl_bin), "--port", str(qemu_server.link), *args], capture_output=True,
                              text=True, timeout=30)
    version = tmcl("version")
    assert version.returncode == 0 and "1021V142" in version.stdout, version
    assert tmcl("set", "ap", "MaxPositioningSpeed", "25600").returncode == 0
    got = tmcl("get", "ap", "4")
    assert got.returncode == 0 and "25600" in got.stdout, got
    refused = tmcl("set", "ap", "4", "0")
    assert refused.returncode == 1 and "4" in refused.stderr + refused.stdout, refused


def test_the_stack_keeps_a_margin(qemu_server, bus, tmp_path):
    """After a session that moves, runs a program and uses ASCII mode, the painted stack (cortex-m-rt's
    `paint-stack`) still has most of its paint: the deepest the stack went is far from the statics."""
    bus.move_to(0, 25600)
    download(bus, PROGRAM)
    bus.send(RUN, 1, 0, 0)
    wait_until(lambda: bus.get_global_parameter(7, 2) >= 1, 15, what="a loop of the program")
    bus.send(128, 0, 0, 0)
    with LinePort(qemu_server.link) as line:
        line.write(frame(1, 139, 0, 0, 0))
        line.read_exact(9)
        line.write(b"AGAP 1, 0\r")
        line.read_until(b"\r")
        line.write(b"ABIN\r")
        line.read_quiet()
    symbols = elf_symbols(qemu_server.image)
    bottom, top = symbols["_stack_end"], symbols["_stack_start"]
    image = qemu_server.dump(bottom, top - bottom, tmp_path / "stack.bin")
    words = [int.from_bytes(image[i:i + 4], "little") for i in range(0, len(image), 4)]
    untouched = next(i for i, w in enumerate(words) if w != STACK_PAINT) * 4
    used = (top - bottom) - untouched
    print(f"stack: {used} of {top - bottom} bytes used, {untouched} never touched")
    assert untouched >= 8 * 1024, f"only {untouched} bytes of stack never used ({used} used)"


@pytest.mark.parametrize("how", ["setsid", "start_new_session"])
def test_qemu_serve_without_a_controlling_terminal(qemu_image, tmp_path, tmcl_bin, how):
    """scripts/qemu-serve.sh as a service starts it: in a session of its own, without a controlling
    terminal (under `setsid`, or from Popen(..., start_new_session=True)). The pty it serves must not become
    its controlling terminal, or its reads of the pty are stopped (SIGTTIN) and the firmware never answers."""
    server = QemuServer(qemu_image, tmp_path, link_name=f"link-{how}")
    if how == "setsid":
        plain = server.args
        server.args = lambda: ["setsid", *plain()]
    else:
        server.new_session = True
    server.start()
    try:
        r = subprocess.run([str(tmcl_bin), "version", "--port", str(server.link), "--timeout", "5"],
                           capture_output=True, text=True, timeout=30)
        assert r.returncode == 0 and r.stdout.startswith("1021V"), r
        with pytrinamic_connection(server) as conn:
            conn.set_axis_parameter(4, 0, 1234)
            assert conn.get_axis_parameter(4, 0) == 1234
    finally:
        server.terminate_checked()

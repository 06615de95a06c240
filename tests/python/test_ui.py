"""The browser workbench (`tmcl ui`) in a real headless Chromium against `tmcl serve`.

Each test starts a virtual module on a pty and `tmcl ui` on it, then drives the page the way a person
does: by the controls' accessible names where they matter (the console input "TMCL command", the
parameter table's column headers). Screenshots of each view go to target/ui-screenshots (or
$TMCL_UI_SCREENSHOTS). The tests poll the page with timeouts; no sleep decides a result.
"""

from __future__ import annotations

import http.client
import json
import subprocess

import pytest

from tmcltest import REPO_ROOT
from uitest import Ui, new_browser, screenshot_dir, wait_until


@pytest.fixture(scope="module")
def browser():
    driver = new_browser()
    yield driver
    driver.quit()


@pytest.fixture
def ui(tmcl_bin, tmp_path, pty_server):
    """`tmcl ui` on the virtual PD28-1021 of `pty_server`."""
    u = Ui(tmcl_bin, tmp_path, ["--port", str(pty_server.link)]).start()
    yield u
    if u.proc is not None:
        rc = u.stop()
        assert rc == 0, f"tmcl ui exited with {rc} after SIGTERM; stderr: {u.stderr()}"


def by_css(driver, selector):
    from selenium.webdriver.common.by import By
    return driver.find_element(By.CSS_SELECTOR, selector)


def all_css(driver, selector):
    from selenium.webdriver.common.by import By
    return driver.find_elements(By.CSS_SELECTOR, selector)


def by_name(driver, role_tags: str, name: str):
    """The visible element among `role_tags` (CSS) whose computed accessible name is `name`."""
    def find():
        for e in all_css(driver, role_tags):
            if e.is_displayed() and e.accessible_name == name:
                return e
        return None
    return wait_until(find, what=f"a control named {name!r}")


def open_page(driver, ui, view="params"):
    driver.get(f"{ui.url}#{view}")
    wait_until(lambda: driver.execute_script("return window.workbench && window.workbench.hello"),
               what="the module's hello")
    tab = by_css(driver, f"#tab-{view}")
    tab.click()
    return driver


def shot(driver, name):
    path = screenshot_dir() / f"{name}.png"
    driver.save_screenshot(str(path))
    return path


def wb(driver, expr):
    return driver.execute_script(f"return window.workbench.{expr}")


def test_the_header_shows_the_module(browser, ui):
    open_page(browser, ui, "module")
    version = wait_until(lambda: (by_css(browser, "#version").text or "").startswith("1021V") and
                         by_css(browser, "#version").text, what="the version string")
    assert version.startswith("1021V")
    assert by_css(browser, "#model").text == "PD28-1021"
    assert by_css(browser, "#address").text == "1"
    wait_until(lambda: by_css(browser, "#link-state").text == "answering", what="the link state")
    wait_until(lambda: "/s of" in by_css(browser, "#rps").text, what="the request rate")
    # Scan the line from the Module view: the module at address 1 answers.
    by_css(browser, "#scan-last").clear()
    by_css(browser, "#scan-last").send_keys("4")
    by_name(browser, "button", "Scan").click()
    wait_until(lambda: "address 1" in by_css(browser, "#scan-results").text, timeout=20, what="the scan")
    assert "1021V" in by_css(browser, "#scan-results").text
    shot(browser, "module")


def test_the_parameter_table_lists_the_model(browser, ui, tmcl_bin):
    open_page(browser, ui, "params")
    table = by_name(browser, "table", "Parameters")
    headers = [th.text for th in table.find_elements("css selector", "thead th")]
    assert headers[:3] == ["Number", "Name", "Value"], headers
    for th in table.find_elements("css selector", "thead th"):
        assert th.aria_role == "columnheader"
    listed = subprocess.run([str(tmcl_bin), "params", "--module", "pd28-1021", "--no-values", "--json"],
                            capture_output=True, text=True, check=True).stdout.splitlines()
    names = {json.loads(line)["name"] for line in listed}
    rows = all_css(browser, "#param-table tbody tr[data-key]")
    shown = {r.find_element("css selector", "td.name").text.split("\n")[0] for r in rows}
    assert len(rows) == len(listed)
    assert names == shown
    # Values arrive live: the maximum positioning speed reads its factory default.
    speed = by_name(browser, "input", "MaxPositioningSpeed value")
    wait_until(lambda: speed.get_attribute("value") == "51200", what="AP 4's value")
    shot(browser, "parameters")


def test_a_value_set_in_the_table_is_read_back_by_tmcl_get(browser, ui, pty_server, tmcl_bin):
    open_page(browser, ui, "params")
    speed = by_name(browser, "input", "MaxPositioningSpeed value")
    wait_until(lambda: speed.get_attribute("value") == "51200", what="AP 4's value")
    speed.clear()
    speed.send_keys("12345\n")
    status = by_css(browser, "#param-status")
    wait_until(lambda: "MaxPositioningSpeed = 12345" in status.text, what="the write's confirmation")
    # A bad value is refused with the module's status and the table's reason.
    speed.clear()
    speed.send_keys("0\n")
    wait_until(lambda: "refused" in status.text, what="the refusal")
    assert "invalid value" in status.text and "MaxPositioningSpeed takes 1..2147483647" in status.text, status.text
    shot(browser, "parameters-refused")
    # A read-only parameter has no input at all.
    assert not [e for e in all_css(browser, "input") if e.accessible_name == "PositionReachedFlag value"]
    # The workbench holds the port while it runs: stop it, then ask with `tmcl get`.
    assert ui.stop() == 0
    out = subprocess.run([str(tmcl_bin), "get", "--port", str(pty_server.link), "--json", "ap", "4"],
                         capture_output=True, text=True, timeout=20)
    assert out.returncode == 0, out.stderr
    assert json.loads(out.stdout)["value"] == 12345


def test_a_console_command_shows_its_reply(browser, ui):
    open_page(browser, ui, "console")
    command = by_name(browser, "input", "TMCL command")
    command.send_keys("SAP 4, 0, 40000\n")
    log = by_css(browser, "#console-log")
    wait_until(lambda: "value 40000" in log.text, what="the SAP reply")
    command.send_keys("GAP MaxPositioningSpeed, 0\n")
    # The request's bytes (GAP 4, 0 to module 1), then the reply with the parameter's name.
    wait_until(lambda: log.text.count("(MaxPositioningSpeed)") == 2, what="the GAP reply")
    assert "sent GAP 4, 0  [01 06 04 00 00 00 00 00 0B]\n  100 successfully executed, no error, value 40000 " \
        "(MaxPositioningSpeed)" in log.text, log.text
    command.send_keys("#op 136, 0, 0, 0\n")
    wait_until(lambda: "version 1021V" in log.text, what="the version string")
    command.send_keys("MVPP 0, 1\n")
    wait_until(lambda: "unknown mnemonic `MVPP`" in log.text, what="the parse error")
    command.send_keys("SAP 4, 0, 0\n")
    wait_until(lambda: "MaxPositioningSpeed takes" in log.text, what="the refusal")
    # History: arrow up brings back the last line.
    from selenium.webdriver.common.keys import Keys
    command.send_keys(Keys.ARROW_UP)
    assert command.get_attribute("value") == "SAP 4, 0, 0"
    shot(browser, "console")


def test_a_velocity_from_the_motion_panel_moves_the_plot(browser, ui):
    open_page(browser, ui, "motion")
    speed = by_name(browser, "input", "Speed")
    speed.clear()
    speed.send_keys("30000")
    before = wb(browser, "counts['ap.0.1'] || 0")
    by_name(browser, "button", "Rotate right").click()
    # The plot's actual-speed series reaches the speed, and the position series climbs.
    def moving():
        series = browser.execute_script(
            "const p = window.workbench.plots; const s = p[1].get('ap.0.3'), q = p[0].get('ap.0.1');"
            "return [s.v.slice(-1)[0], q.v.slice(-1)[0], q.v.length];")
        return series[0] == 30000 and series[1] > 0 and series
    wait_until(moving, timeout=15, what="the plot to show the motor turning")
    assert wb(browser, "counts['ap.0.1']") > before
    wait_until(lambda: by_css(browser, "#st-aspeed").text == "30000 pps", what="the state card")
    shot(browser, "motion")
    csv = wb(browser, "exportCsv()")
    assert csv.splitlines()[0].startswith("time [s],unix time [ms],actual position [µsteps],target position [µsteps]")
    assert len(csv.splitlines()) > 5
    svg = wb(browser, "exportSvg()")
    assert svg.startswith("<?xml") and "<polyline" in svg
    # Pause freezes the picture; stop the motor.
    by_name(browser, "button", "Pause").click()
    assert by_css(browser, "#plot-pause").get_attribute("aria-pressed") == "true"
    by_name(browser, "button", "Stop motor").click()
    wait_until(lambda: wb(browser, "values['ap.0.3']") == 0, timeout=15, what="the motor to stop")


def test_outputs_toggle_and_inputs_show(browser, ui):
    open_page(browser, ui, "io")
    out0 = by_name(browser, "input", "OUT0")
    out0.click()
    wait_until(lambda: "OUT0 on" in by_css(browser, "#io-status").text, what="the output write")
    wait_until(lambda: wb(browser, "values['io.2.0']") == 1, what="the output read back")
    wait_until(lambda: "io.1.0" in browser.execute_script("return Object.keys(window.workbench.values)"),
               what="the analog input")
    shot(browser, "io")


PROGRAM_WITH_ERROR = "#include TMCLParam.tmc\nStart:\n    MVP ABS, 0, 1000\n    JA Strat\n"

PROGRAM = """// count in variable 0 and the accumulator
    SGP 0, 2, 0
Loop:
    GGP 0, 2
    CALC ADD, 1
    AGP 0, 2
    CALCX LOAD
    JA Loop
"""


def set_program(driver, text):
    driver.execute_script("window.workbench.editor.value = arguments[0]; window.workbench.editor.onChange();", text)


PROGRAM_REFUSED = "SAP 5, 0, 1000\nSAP 4, 0, 0      // the PD28-1021 takes 1..\nSIO 7, 2, 1\nSTOP\n"


def test_the_program_view_warns_where_the_module_would_refuse(browser, ui):
    # The module would skip these instructions (status 4, 3): marked at their lines, download allowed.
    open_page(browser, ui, "program")
    set_program(browser, PROGRAM_REFUSED)
    by_name(browser, "button", "Assemble").click()
    diags = by_css(browser, "#diagnostics")
    wait_until(lambda: "warning: line 2, column 11" in diags.text, what="the warning at its place")
    assert "takes 1..2147483647" in diags.text and "warning: line 3, column 5" in diags.text
    assert "warn" in by_css(browser, ".gutter button[data-line='2']").get_attribute("class")
    assert "err" not in by_css(browser, ".gutter button[data-line='2']").get_attribute("class")
    shot(browser, "program-warnings")
    by_name(browser, "button", "Download").click()
    wait_until(lambda: "Downloaded: 4 instructions" in diags.text, what="the download despite the warnings")
    assert "warning: line 2" in diags.text


def test_the_program_editor_assembles_downloads_and_debugs(browser, ui):
    open_page(browser, ui, "program")
    set_program(browser, PROGRAM_WITH_ERROR)
    by_name(browser, "button", "Assemble").click()
    diags = by_css(browser, "#diagnostics")
    wait_until(lambda: "line 4, column 8" in diags.text, what="the error at its place")
    assert "unknown label `Strat`" in diags.text
    assert "err" in by_css(browser, ".gutter button[data-line='4']").get_attribute("class")
    shot(browser, "program-error")

    set_program(browser, PROGRAM)
    by_name(browser, "button", "Download").click()
    wait_until(lambda: "Downloaded: 6 instructions" in diags.text, what="the download")
    # A breakpoint on line 6 (AGP 0, 2), then Start: the program stops there.
    by_name(browser, "button", "Breakpoint at line 6").click()
    wait_until(lambda: "line 6" in by_css(browser, "#bp-list").text, what="the breakpoint")
    by_name(browser, "button", "Start").click()
    wait_until(lambda: (wb(browser, "debug") or {}).get("reason") == "breakpoint", timeout=15,
               what="the stop at the breakpoint")
    assert wb(browser, "debug.line") == 6
    assert by_css(browser, "#dbg-acc").text == "1"
    assert "line 6" in by_css(browser, "#dbg-pc").text
    # Continue: once around the loop, back at the breakpoint with the next count.
    by_name(browser, "button", "Continue").click()
    wait_until(lambda: by_css(browser, "#dbg-acc").text == "2", timeout=15, what="the second stop")
    assert wb(browser, "debug.reason") == "breakpoint"
    wait_until(lambda: by_css(browser, "#vars [data-key='gp.2.0']").text == "1", what="user variable 0")
    by_name(browser, "button", "Step").click()
    wait_until(lambda: by_css(browser, "#vars [data-key='gp.2.0']").text == "2", what="the step's AGP")
    assert by_css(browser, "#dbg-x").text == "1"
    shot(browser, "program-debug")
    by_name(browser, "button", "Breakpoint at line 6").click()
    by_name(browser, "button", "Stop").click()
    wait_until(lambda: (wb(browser, "debug") or {}).get("reason") == "stopped", what="the stop")


def http_status(host_port: str, headers: dict[str, str], path: str = "/") -> int:
    host, port = host_port.split(":")
    conn = http.client.HTTPConnection(host, int(port), timeout=5)
    conn.putrequest("GET", path, skip_host=True)
    for k, v in headers.items():
        conn.putheader(k, v)
    conn.endheaders()
    status = conn.getresponse().status
    conn.close()
    return status


def test_a_foreign_origin_is_refused(browser, ui):
    own = ui.host_port
    upgrade = {"Connection": "Upgrade", "Upgrade": "websocket", "Sec-WebSocket-Version": "13",
               "Sec-WebSocket-Key": "dGhlIHNhbXBsZSBub25jZQ=="}
    assert http_status(own, {"Host": own}) == 200
    assert http_status(own, {"Host": own, **upgrade, "Origin": f"http://{own}"}, "/ws") == 101
    assert http_status(own, {"Host": own, **upgrade, "Origin": "http://evil.example"}, "/ws") == 403
    assert http_status(own, {"Host": own, "Origin": "http://evil.example"}) == 403
    assert http_status(own, {"Host": f"evil.example:{own.split(':')[1]}"}) == 403  # DNS rebinding
    # A page elsewhere (here a data: URL, origin "null") cannot open the workbench's WebSocket.
    browser.get("data:text/html,<title>elsewhere</title>")
    result = browser.execute_async_script(
        "const done = arguments[arguments.length - 1];"
        "const ws = new WebSocket(arguments[0]);"
        "ws.onopen = () => done('open'); ws.onerror = () => done('refused');", f"ws://{own}/ws")
    assert result == "refused"


def test_the_tmcm1310_table_and_its_plots(browser, tmcl_bin, tmp_path, tmcm1310_server):
    u = Ui(tmcl_bin, tmp_path, ["--port", str(tmcm1310_server.link)]).start()
    try:
        open_page(browser, u, "params")
        wait_until(lambda: by_css(browser, "#model").text == "TMCM-1310", what="the model")
        listed = subprocess.run([str(tmcl_bin), "params", "--module", "tmcm-1310", "--no-values", "--json"],
                                capture_output=True, text=True, check=True).stdout.splitlines()
        assert len(all_css(browser, "#param-table tbody tr[data-key]")) == len(listed)
        # The closed loop's current scale (AP 123, by its role) is plotted, not the PD28-1021's AP 180.
        assert wb(browser, "hello.roles.current") in (123, 180)
        by_css(browser, "#tab-motion").click()
        wait_until(lambda: wb(browser, f"counts['ap.0.{wb(browser, 'hello.roles.current')}']"), what="the current")
    finally:
        assert u.stop() == 0


def test_the_rate_limit_holds_and_the_console_gets_its_turn(browser, tmcl_bin, tmp_path, pty_server):
    # 25 requests per second, far fewer than the Motion view's values want: the polling is saturated.
    u = Ui(tmcl_bin, tmp_path, ["--port", str(pty_server.link), "--rate", "25"]).start()
    try:
        open_page(browser, u, "motion")
        wait_until(lambda: (wb(browser, "stats") or {}).get("requests", 0) > 60, timeout=15,
                   what="three seconds of polling")
        stats = wb(browser, "stats")
        assert stats["rate"] == 25
        assert stats["rps"] <= 25.5, stats
        # A console line still goes out before the next poll: answered within a few request slots.
        answer = browser.execute_async_script(
            "const done = arguments[arguments.length - 1]; const t0 = performance.now();"
            "window.workbench.call('console', {line: 'GAP 4, 0'})"
            ".then((ok) => done([ok.value, performance.now() - t0]), (e) => done([null, e]));")
        assert answer[0] == 51200, answer
        assert answer[1] < 500, f"the console waited {answer[1]:.0f} ms at 25 requests/s"
    finally:
        assert u.stop() == 0


def test_command_line_errors(tmcl_bin, pty_server):
    # No link: a usage error, as for every host command.
    out = subprocess.run([str(tmcl_bin), "ui"], capture_output=True, text=True, timeout=20)
    assert out.returncode == 2, out
    assert "no connection" in out.stderr
    # An address that is taken: exit code 3, and the port is not held.
    import socket
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen(1)
        port = taken.getsockname()[1]
        out = subprocess.run([str(tmcl_bin), "ui", "--port", str(pty_server.link), "--listen", f"127.0.0.1:{port}"],
                             capture_output=True, text=True, timeout=20)
    assert out.returncode == 3, out
    assert f"cannot listen on 127.0.0.1:{port}" in out.stderr
    out = subprocess.run([str(tmcl_bin), "--port", str(pty_server.link), "get", "ap", "4"],
                         capture_output=True, text=True, timeout=20)
    assert out.returncode == 0 and "51200" in out.stdout, out


def test_a_module_is_picked_on_a_bus_after_a_scan(browser, tmcl_bin, tmp_path, bus_server):
    u = Ui(tmcl_bin, tmp_path, ["--port", str(bus_server.link)]).start()
    try:
        open_page(browser, u, "module")
        by_css(browser, "#scan-last").clear()
        by_css(browser, "#scan-last").send_keys("5")
        by_name(browser, "button", "Scan").click()
        results = by_css(browser, "#scan-results")
        wait_until(lambda: results.text.count("1021V142") == 3, timeout=20, what="three modules")
        by_name(browser, "button", "Use module 2").click()
        wait_until(lambda: by_css(browser, "#address").text == "2", what="the header's address")
        command = by_name(browser, "button", "Console")
        command.click()
        by_name(browser, "input", "TMCL command").send_keys("GGP 66, 0\n")
        wait_until(lambda: "value 2 (SerialAddress)" in by_css(browser, "#console-log").text, what="module 2's answer")
    finally:
        assert u.stop() == 0


def test_the_debugger_on_a_pdx_113(browser, tmcl_bin, tmp_path, serve):
    """A PDx-113's 135 answers its state alone (PDx-113 manual §5.5): the program view reads the program
    counter from GP 130, stops at a breakpoint by it, and shows "–" for the accumulator and X register,
    which that module cannot report."""
    server = serve("pty", modules=["pd-113"])
    u = Ui(tmcl_bin, tmp_path, ["--port", str(server.link)]).start()
    try:
        open_page(browser, u, "program")
        wait_until(lambda: by_css(browser, "#model").text.startswith("PDx-113"), what="the model")
        set_program(browser, "    SGP 0, 2, 0\nLoop:\n    GGP 0, 2\n    CALC ADD, 1\n    AGP 0, 2\n    JA Loop\n")
        by_name(browser, "button", "Download").click()
        diags = by_css(browser, "#diagnostics")
        wait_until(lambda: "Downloaded: 5 instructions" in diags.text, what="the download")
        by_name(browser, "button", "Breakpoint at line 5").click()
        by_name(browser, "button", "Start").click()
        wait_until(lambda: (wb(browser, "debug") or {}).get("reason") == "breakpoint", timeout=15,
                   what="the stop at the breakpoint")
        assert wb(browser, "debug.line") == 5 and wb(browser, "debug.pc") == 3
        assert "line 5" in by_css(browser, "#dbg-pc").text
        assert by_css(browser, "#dbg-acc").text == "–" and by_css(browser, "#dbg-x").text == "–"
        by_name(browser, "button", "Continue").click()
        wait_until(lambda: by_css(browser, "#vars [data-key='gp.2.0']").text == "1", timeout=15,
                   what="one turn of the loop")
        shot(browser, "program-debug-pd113")
        by_name(browser, "button", "Breakpoint at line 5").click()
        by_name(browser, "button", "Stop").click()
    finally:
        assert u.stop() == 0


def test_a_tmcm_3110_shows_its_supply_voltage(browser, tmcl_bin, tmp_path, serve):
    """The TMCM-3110's I/O view: eight inputs, eight outputs, AIN0 and AIN4, and the supply voltage (GIO 8, 1,
    0.1 V) in the analog table; the pull-ups (SIO 0, 0, written only) are not polled."""
    server = serve("pty", modules=["tmcm-3110"])
    u = Ui(tmcl_bin, tmp_path, ["--port", str(server.link)]).start()
    try:
        open_page(browser, u, "io")
        wait_until(lambda: wb(browser, "values['io.1.8']") == 240, what="the supply voltage, 24.0 V")
        rows = [r.text for r in all_css(browser, "#io-analog tbody tr")]
        assert any(r.startswith("supply voltage (0.1 V)") and "240" in r for r in rows), rows
        assert len(all_css(browser, "#io-inputs li")) == 8 and len(all_css(browser, "#io-outputs li")) == 8
        shot(browser, "io-tmcm-3110")
    finally:
        assert u.stop() == 0, u.stderr()


def test_a_tmcm_3110_shows_every_axis(browser, tmcl_bin, tmp_path, serve):
    """The motion view of a TMCM-3110: the axes table has a row per motor (positions, speed, position reached,
    switches), kept up to date for every motor while one is selected; a row's button selects its motor, and
    a move of motor 2 from the controls shows in its row while motors 0 and 1 stay at 0. Each axis in its
    own world (examples/worlds/xyz-stage.toml)."""
    world = REPO_ROOT / "examples" / "worlds" / "xyz-stage.toml"
    server = serve("pty", modules=["tmcm-3110"], extra=["--world", str(world)])
    u = Ui(tmcl_bin, tmp_path, ["--port", str(server.link)]).start()
    try:
        open_page(browser, u, "motion")
        wait_until(lambda: len(all_css(browser, "#axes-body tr")) == 3 and by_css(browser, "#axes-card").is_displayed(),
                   what="three rows in the axes table")
        assert by_css(browser, "#axes-body tr[data-motor='0']").get_attribute("aria-current") == "true"
        by_name(browser, "button", "Show motor 2").click()
        wait_until(lambda: by_css(browser, "#axes-body tr[data-motor='2']").get_attribute("aria-current") == "true",
                   what="motor 2 selected")
        assert wb(browser, "hello") and browser.execute_script(
            "return [...document.querySelectorAll('.motor-select')].every(s => s.value === '2')")
        position = by_css(browser, "#position")
        position.clear()
        position.send_keys("20000")
        by_name(browser, "button", "Move absolute").click()
        cell = lambda m, role: by_css(browser, f"#axes-body tr[data-motor='{m}'] td[data-axis-role='{role}']").text
        wait_until(lambda: cell(2, "actual_position").startswith("20000 ") and cell(2, "reached") == "yes",
                   timeout=20, what="motor 2 at 20000 in its row")
        assert cell(2, "target_position").startswith("20000 ")
        for m in (0, 1):
            wait_until(lambda: cell(m, "actual_position").startswith("0 "), what=f"motor {m} at 0")
        browser.execute_script("document.getElementById('axes-card').scrollIntoView()")
        shot(browser, "motion-tmcm-3110-axes")
    finally:
        assert u.stop() == 0, u.stderr()

"""The workbench for daily work (issue 21) and its honest line indicator (issue 20), in headless Chromium
against `tmcl serve`: every model in its own units, charts of any parameter, gaps and new traces, links
that come back, mismatched replies said plainly, and console commands that may get no reply.

Screenshots go to target/ui-screenshots (or $TMCL_UI_SCREENSHOTS); the tests poll the page with
timeouts, no sleep decides a result.
"""

from __future__ import annotations

import threading
import time

import pytest
import serial

from tmcltest import frame
from uitest import Ui, new_browser, screenshot_dir, wait_until


@pytest.fixture(scope="module")
def browser():
    driver = new_browser()
    yield driver
    driver.quit()


def by_css(driver, selector):
    from selenium.webdriver.common.by import By
    return driver.find_element(By.CSS_SELECTOR, selector)


def all_css(driver, selector):
    from selenium.webdriver.common.by import By
    return driver.find_elements(By.CSS_SELECTOR, selector)


def wb(driver, expr):
    return driver.execute_script(f"return window.workbench.{expr}")


def open_page(driver, ui, view):
    driver.get(f"{ui.url}#{view}")
    wait_until(lambda: driver.execute_script("return window.workbench && window.workbench.hello"),
               what="the module's hello")


def shot(driver, name):
    driver.save_screenshot(str(screenshot_dir() / f"{name}.png"))


def console(driver, line, expect, timeout=10):
    box = by_css(driver, "#console-input")
    box.clear()
    box.send_keys(line + "\n")
    log = by_css(driver, "#console-log")
    wait_until(lambda: expect in log.text, timeout=timeout, what=f"{expect!r} after {line!r}")
    return log.text


def test_the_pdx_113_speaks_tmc428_units(browser, tmcl_bin, tmp_path, serve):
    """PDx-113 manual §5.7.1: velocities are TMC428 units 0..2047. The Speed box starts at the model's
    default, a refusal names the range, the State card gives microsteps per second beside the unit, a
    panel the model cannot fill is not drawn, and the sample program uses the model's speed."""
    server = serve("pty", modules=["pd-113"])
    u = Ui(tmcl_bin, tmp_path, ["--port", str(server.link)]).start()
    try:
        open_page(browser, u, "motion")
        wait_until(lambda: by_css(browser, "#model").text.startswith("PDx-113"), what="the model")
        wait_until(lambda: by_css(browser, "#speed").get_attribute("value") == "1000", what="the model's speed")
        assert by_css(browser, "#speed-unit").text == "TMC428 v units"
        assert by_css(browser, "#speed-range").text == "0..2047"
        speed = by_css(browser, "#speed")
        speed.clear()
        speed.send_keys("51200")
        by_css(browser, "#ror").click()
        status = by_css(browser, "#motion-status")
        wait_until(lambda: "0..2047 TMC428 v units" in status.text, what="the refusal with the range")
        speed.clear()
        speed.send_keys("700")
        by_css(browser, "#ror").click()
        wait_until(lambda: "700 TMC428 v units: done" in status.text, what="the rotation")
        # 16 MHz · 700 / (2^3 · 2048 · 32) = 21 362 µsteps/s at the default pulse divisor 3.
        wait_until(lambda: "≈ 21,362 µsteps/s" in by_css(browser, "#st-aspeed").text, timeout=10,
                   what="the actual speed in both units")
        assert by_css(browser, "#st-aspeed").text.startswith("700 TMC428 v units")
        load = by_css(browser, "#plot-load").find_element("xpath", "..")
        assert not load.is_displayed(), "the PDx-113 has no load value or current scale to plot"
        assert "[TMC428 v units]" in by_css(browser, "#legend-velocity").text
        shot(browser, "motion-pd113-units")
        by_css(browser, "#mst").click()
        browser.execute_script("localStorage.clear()")
        by_css(browser, "#tab-program").click()
        wait_until(lambda: "Speed = 1000" in browser.execute_script("return window.workbench.editor.value"),
                   what="the PDx-113's sample program")
        by_css(browser, "#pg-assemble").click()
        wait_until(lambda: "no errors" in by_css(browser, "#diagnostics").text, what="the sample assembles")
        shot(browser, "program-pd113-sample")
    finally:
        assert u.stop() == 0


@pytest.mark.parametrize("model", ["pd28-1021", "tmcm-1310"])
def test_the_motion_view_takes_each_models_units(browser, tmcl_bin, tmp_path, serve, model):
    server = serve("pty", modules=[model])
    u = Ui(tmcl_bin, tmp_path, ["--port", str(server.link)]).start()
    try:
        open_page(browser, u, "motion")
        wait_until(lambda: wb(browser, "hello.model.id") == model, what="the model")
        motion = wb(browser, "hello.model.motion")
        assert motion["velocity_unit"] == "pps"
        wait_until(lambda: by_css(browser, "#speed").get_attribute("value") == str(motion["speed_default"]),
                   what="the default speed")
        assert by_css(browser, "#speed-unit").text == "pps"
        by_css(browser, "#ror").click()
        wait_until(lambda: by_css(browser, "#st-aspeed").text.endswith(" pps")
                   and by_css(browser, "#st-aspeed").text != "0 pps", timeout=10, what="the speed in pps")
        by_css(browser, "#mst").click()
        shot(browser, f"motion-{model}-units")
    finally:
        assert u.stop() == 0


def test_any_parameter_is_charted_with_its_unit_and_a_sensible_range(browser, tmcl_bin, tmp_path, pty_server):
    u = Ui(tmcl_bin, tmp_path, ["--port", str(pty_server.link)]).start()
    try:
        open_page(browser, u, "motion")
        browser.execute_script("localStorage.clear()")
        open_page(browser, u, "motion")
        wait_until(lambda: wb(browser, "hello.model.id") == "pd28-1021", what="the model")
        box = by_css(browser, "#chart-param")
        box.send_keys("AP 6 MaxCurrent")
        by_css(browser, "#chart-form button[type=submit]").click()
        wait_until(lambda: len(all_css(browser, "#charts figure")) == 1, what="the new chart")
        # A second parameter of another unit in the same panel gets its own axis.
        panel = wb(browser, "panels.find(p => p.custom).id")
        browser.execute_script(f"window.workbench.addChart('AP 140 MicrostepResolution', '{panel}')")
        wait_until(lambda: wb(browser, "counts['ap.0.6']") and wb(browser, "counts['ap.0.140']"), timeout=10,
                   what="the charted values")
        wait_until(lambda: browser.execute_script(
            "const p = window.workbench.panels.find(p => p.custom).plot; const v = p.view();"
            "return v.axes.length === 2 && !v.axes[0].empty && !v.axes[1].empty"), what="two axes with data")
        axes = browser.execute_script(
            "return window.workbench.panels.find(p => p.custom).plot.view().axes"
            ".map(a => [a.unit, a.min, a.max])")
        unit, low, high = axes[0]
        assert unit == "/255 of max. current"
        # A constant (MaxCurrent stays 128) is a flat line in a small range around it.
        assert low < 128 < high and high - low <= 4, axes
        legend = by_css(browser, "#charts figure figcaption").text
        assert "MaxCurrent [/255 of max. current]" in legend
        # Charts stay with the model across a reload, and their values are polled again.
        open_page(browser, u, "motion")
        wait_until(lambda: len(all_css(browser, "#charts figure")) == 1, what="the chart after a reload")
        csv = browser.execute_script("return window.workbench.exportCsv()")
        header = csv.splitlines()[0]
        assert header.startswith("time [s],unix time [ms],actual position [µsteps]"), header
        assert "right axis" not in header
        svg = browser.execute_script("return window.workbench.exportSvg()")
        assert "PD28-1021 (pd28-1021), module address 1" in svg and " UTC to " in svg
        assert "MaxCurrent [/255 of max. current]" in svg
        shot(browser, "motion-chart-any-parameter")
        browser.execute_script("localStorage.clear()")
    finally:
        assert u.stop() == 0


def test_a_restarted_server_is_reconnected_and_the_trace_restarts(browser, tmcl_bin, tmp_path, pty_server):
    u = Ui(tmcl_bin, tmp_path, ["--port", str(pty_server.link)]).start()
    try:
        open_page(browser, u, "motion")
        wait_until(lambda: wb(browser, "line.state") == "answering", what="the line answering")
        epoch = wb(browser, "epoch")
        pty_server.kill()
        wait_until(lambda: wb(browser, "line.state") == "down", timeout=10, what="the link gone")
        assert "opening" in by_css(browser, "#line-note").text
        # No line is drawn across the gap: every series ends in a gap marker.
        assert browser.execute_script(
            "return window.workbench.plots[0].series.every(s => !s.v.length || s.v[s.v.length - 1] === null)")
        shot(browser, "motion-link-gone")
        pty_server.start()
        wait_until(lambda: wb(browser, "line.state") == "answering", timeout=15, what="the link back")
        assert wb(browser, "epoch") > epoch
        wait_until(lambda: browser.execute_script(
            "return window.workbench.plots[0].series[0].v.filter(v => v !== null).length > 3"), what="new samples")
        # The new trace starts after the link came back: nothing of the old one is left.
        assert browser.execute_script("return window.workbench.plots[0].series[0].v.every(v => v !== null)")
        shot(browser, "motion-link-back")
        by_css(browser, "#tab-console").click()
        console(browser, "GAP 6, 0", "value 128")
    finally:
        assert u.stop() == 0


def test_a_module_change_starts_a_new_trace(browser, tmcl_bin, tmp_path, bus_server):
    u = Ui(tmcl_bin, tmp_path, ["--port", str(bus_server.link)]).start()
    try:
        open_page(browser, u, "motion")
        wait_until(lambda: wb(browser, "counts['ap.0.1']") and wb(browser, "counts['ap.0.1']") > 5,
                   what="samples of module 1")
        epoch = wb(browser, "epoch")
        browser.execute_script("window.workbench.call('select', {address: 2})")
        wait_until(lambda: wb(browser, "epoch") > epoch, what="a new trace")
        first = browser.execute_script("return window.workbench.plots[0].series[0].t[0] || null")
        switched = wb(browser, "hello.address")
        assert switched == 2
        assert first is None or first >= browser.execute_script("return Date.now()") - 5000
    finally:
        assert u.stop() == 0


def test_replies_to_another_host_turn_the_indicator_to_a_warning(browser, tmcl_bin, tmp_path, pty_server):
    """Issue 20: a second host on the same pty takes some of the workbench's replies and leaves it its
    own. The indicator stops saying "answering", says why, and counts them."""
    u = Ui(tmcl_bin, tmp_path, ["--port", str(pty_server.link)]).start()
    stop = threading.Event()

    def intruder():
        # It only writes, so that its replies reach the workbench, the one reader on the pty (two readers
        # would race for each reply and the test would depend on who wins).
        with serial.Serial(str(pty_server.link), 9600, timeout=0.05) as port:
            while not stop.is_set():
                port.write(frame(1, 10, 66, 0, 0))  # GGP 66, 0: another command than any the page polls
                time.sleep(0.01)

    try:
        open_page(browser, u, "motion")
        wait_until(lambda: wb(browser, "line.state") == "answering", what="the line answering")
        thread = threading.Thread(target=intruder, daemon=True)
        thread.start()
        wait_until(lambda: wb(browser, "line.state") == "mismatched", timeout=15, what="the warning")
        assert wb(browser, "line.mismatched") > 0
        note = by_css(browser, "#line-note").text
        assert "another host on this line?" in note
        assert "mismatched" in by_css(browser, "#link-state").text
        shot(browser, "line-mismatched")
        stop.set()
        thread.join(timeout=5)
        wait_until(lambda: wb(browser, "line.state") == "answering", timeout=20, what="the warning ageing out")
    finally:
        stop.set()
        assert u.stop() == 0


def test_commands_that_may_get_no_reply_show_what_came(browser, tmcl_bin, tmp_path, pty_server):
    """137 and 255 without the key are refused by the module: the console shows the refusal. SGP 255
    switches replies off: the console says so and how to switch them on again, and the line says so."""
    u = Ui(tmcl_bin, tmp_path, ["--port", str(pty_server.link), "--timeout", "1"]).start()
    try:
        open_page(browser, u, "console")
        text = console(browser, "#op 137, 0, 0, 0", "status", timeout=10)
        assert "no reply" not in text.splitlines()[-1]
        console(browser, "#op 255, 0, 0, 0", "#op 255")
        wait_until(lambda: len([l for l in by_css(browser, "#console-log").text.splitlines() if "status" in l]) >= 2,
                   what="the refusal of 255")
        text = console(browser, "SGP 255, 0, 1", "replies are now off", timeout=10)
        wait_until(lambda: wb(browser, "line.state") == "replies_off", what="the line saying replies are off")
        shot(browser, "console-replies-off")
        console(browser, "SGP 255, 0, 0", "replies are on again", timeout=10)
        wait_until(lambda: wb(browser, "line.state") == "answering", what="the line answering again")
        console(browser, "GAP 6, 0", "value 128")
    finally:
        assert u.stop() == 0


SEIZURE_WORLD = """
# The closed-loop-seizure example's motor and encoder; the shaft seizes for good when it reaches 150
# degrees (the encoder initialisation moves it less than one electrical period from 0).
[motor]
holding_torque = 0.45
rated_current = 2.0

[encoder]
kind = "abn"
counts_per_rev = 4096

[[faults.stall]]
at = 150.0
from = 0.0
until = 100000.0
"""


def test_the_tmcm1310_closed_loop_panel(browser, tmcl_bin, tmp_path, serve):
    """The TMCM-1310's closed loop on screen: encoder initialisation with its result, the loop closed,
    the status word's bits as lamps, the settings beside the plots, and the position error plotted while
    the shaft seizes (and AP 131 beside AP 3 in the velocity panel)."""
    world = tmp_path / "seizure.toml"
    world.write_text(SEIZURE_WORLD)
    server = serve("pty", modules=["tmcm-1310"], extra=["--world", str(world)])
    u = Ui(tmcl_bin, tmp_path, ["--port", str(server.link)]).start()
    try:
        open_page(browser, u, "motion")
        wait_until(lambda: wb(browser, "hello.model.id") == "tmcm-1310", what="the model")
        card = by_css(browser, "#cl-card")
        assert card.is_displayed()
        assert len(all_css(browser, "#cl-bits .lamp")) == 14
        wait_until(lambda: by_css(browser, "#cl-settings input[aria-label='MaxFollowingError']").get_attribute("value")
                   == "0", what="the following-error setting read")
        by_css(browser, "#cl-init").click()
        wait_until(lambda: by_css(browser, "#cl-init-state").text.startswith("initialised"), timeout=15,
                   what="the encoder initialised")
        by_css(browser, "#cl-close").click()
        wait_until(lambda: by_css(browser, "#cl-loop-state").text.startswith("closed"), timeout=15,
                   what="the loop closed")
        wait_until(lambda: "on" in by_css(browser, "#cl-bits .lamp[data-bit='2']").get_attribute("class"),
                   what="the status word's closed-loop bit")
        by_css(browser, "#ror").click()
        # The seizure holds the shaft: the position error grows while the field runs on, and is plotted.
        wait_until(lambda: browser.execute_script(
            "const s = window.workbench.panels.find(p => p.id === 'closed').plot.get('ap.0.237');"
            "return s && s.v.some(v => v !== null && Math.abs(v) > 200)"), timeout=20,
            what="the position error during the seizure")
        legend = by_css(browser, "#legend-velocity").text
        assert "measured velocity [pps]" in legend and "actual speed [pps]" in legend
        assert "position error [µsteps]" in by_css(browser, "#legend-closed").text
        size = browser.get_window_size()
        browser.set_window_size(1440, 1500)
        try:
            shot(browser, "motion-tmcm1310-closed-loop")
        finally:
            browser.set_window_size(size["width"], size["height"])
        by_css(browser, "#mst").click()
        by_css(browser, "#cl-open").click()
        wait_until(lambda: by_css(browser, "#cl-loop-state").text.startswith("open"), timeout=15, what="the loop open")
    finally:
        assert u.stop() == 0


def test_parameter_sets_in_the_workbench(browser, tmcl_bin, tmp_path, serve):
    """Save, Load and Store all in the Parameters view; a set of another model is refused until asked to
    load what matches, and then the speed in pps is not put into the PDx-113's TMC428 units."""
    pd28 = serve("pty", modules=["pd28-1021"])
    pd113 = serve("pty", modules=["pd-113"])
    u = Ui(tmcl_bin, tmp_path, ["--port", str(pd28.link)]).start()
    try:
        open_page(browser, u, "params")
        wait_until(lambda: wb(browser, "hello.model.id") == "pd28-1021", what="the model")
        # Through the workbench: a second host on the same pty would take some of its replies (issue 20).
        set_ap4 = ("return window.workbench.call('set', {param: {kind: 'ap', number: 4, index: 0}, value: arguments[0]})"
                   ".then(ok => ok.value)")
        assert browser.execute_script(set_ap4, 30000) == 30000
        by_css(browser, "#set-save").click()
        wait_until(lambda: wb(browser, "lastSaved"), timeout=20, what="the saved set")
        text = wb(browser, "lastSaved.toml")
        assert 'model = "pd28-1021"' in text and "MaxPositioningSpeed" in text
        assert wb(browser, "lastSaved.file_name") == "pd28-1021-1-params.toml"
        assert browser.execute_script(set_ap4, 1000) == 1000
        browser.execute_script("window.workbench.loadSet(arguments[0], false)", text)
        wait_until(lambda: wb(browser, "lastSet"), timeout=20, what="the loaded set")
        assert wb(browser, "lastSet.refused") == 0 and wb(browser, "lastSet.written") >= 1
        got = browser.execute_script(
            "return window.workbench.call('get', {param: {kind: 'ap', number: 4, index: 0}}).then(ok => ok.value)")
        assert got == 30000
        browser.execute_script("window.workbench.lastSet = null")
        by_css(browser, "#set-store-all").click()
        wait_until(lambda: wb(browser, "lastSet"), timeout=20, what="store all")
        assert wb(browser, "lastSet.stored") >= 10 and wb(browser, "lastSet.refused") == 0
        assert "stored" in by_css(browser, "#param-status").text
    finally:
        assert u.stop() == 0
    u = Ui(tmcl_bin, tmp_path, ["--port", str(pd113.link)]).start()
    try:
        open_page(browser, u, "params")
        wait_until(lambda: wb(browser, "hello.model.id") == "pd-113", what="the PDx-113")
        browser.execute_script("window.workbench.lastSet = null; window.workbench.loadSet(arguments[0], false)", text)
        status = by_css(browser, "#param-status")
        wait_until(lambda: "the set is of a PD28-1021" in status.text, what="the refusal of another model's set")
        by_css(browser, "#param-status button").click()
        wait_until(lambda: wb(browser, "lastSet"), timeout=20, what="the matching part loaded")
        report = by_css(browser, "#set-report").text
        assert "ap 4 MaxPositioningSpeed = 30000 pps: skipped, the unit differs" in report
        shot(browser, "params-set-another-model")
    finally:
        assert u.stop() == 0


def test_a_restarted_tcp_server_is_reconnected(browser, tmcl_bin, tmp_path, serve):
    server = serve("tcp")
    # The same port after the restart, as a service would have it.
    server.listen = f"127.0.0.1:{server.port}"
    u = Ui(tmcl_bin, tmp_path, ["--tcp", f"127.0.0.1:{server.port}"]).start()
    try:
        open_page(browser, u, "motion")
        wait_until(lambda: wb(browser, "line.state") == "answering", what="the line answering")
        epoch = wb(browser, "epoch")
        server.kill()
        wait_until(lambda: wb(browser, "line.state") == "down", timeout=10, what="the connection gone")
        server.start()
        wait_until(lambda: wb(browser, "line.state") == "answering", timeout=15, what="the connection back")
        assert wb(browser, "epoch") > epoch
        wait_until(lambda: wb(browser, "counts['ap.0.1']") and browser.execute_script(
            "return window.workbench.plots[0].series[0].v.filter(v => v !== null).length > 3"), what="new samples")
    finally:
        assert u.stop() == 0

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
        with serial.Serial(str(pty_server.link), 9600, timeout=0.05) as port:
            while not stop.is_set():
                port.write(frame(1, 10, 66, 0, 0))  # GGP 66, 0: another command than any the page polls
                try:
                    port.read(9)
                except serial.SerialException:
                    pass  # the workbench read the bytes first: two readers on one pty
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

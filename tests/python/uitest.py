"""Helpers of the workbench tests: a `tmcl ui` process and a headless Chromium driven by Selenium.

Chromium and chromedriver are Debian's (`apt-get install chromium chromium-driver`); where either is
missing the browser tests skip with a message that says so. Selenium is given both paths, so it never
tries to download a browser or a driver.
"""

from __future__ import annotations

import os
import queue
import shutil
import signal
import subprocess
import threading
import time
from pathlib import Path

import pytest

from tmcltest import REPO_ROOT

UI_READY_TIMEOUT_S = 20.0
CHROMIUM_CANDIDATES = ["/usr/bin/chromium", "/usr/bin/chromium-browser", "/usr/bin/google-chrome"]
DRIVER_CANDIDATES = ["/usr/bin/chromedriver", "/usr/lib/chromium/chromedriver"]


def _first(paths: list[str], name: str) -> str | None:
    env = os.environ.get(name)
    if env:
        return env if os.path.exists(env) else None
    for p in paths:
        if os.path.exists(p):
            return p
    return shutil.which(Path(paths[0]).name)


def chromium_paths() -> tuple[str, str] | None:
    """(chromium, chromedriver), or None when either is missing."""
    browser = _first(CHROMIUM_CANDIDATES, "TMCL_CHROMIUM")
    driver = _first(DRIVER_CANDIDATES, "TMCL_CHROMEDRIVER")
    if browser and driver:
        return browser, driver
    return None


def screenshot_dir() -> Path:
    """Where the tests save their screenshots: $TMCL_UI_SCREENSHOTS, else ui-screenshots in the target dir."""
    env = os.environ.get("TMCL_UI_SCREENSHOTS")
    if env:
        path = Path(env)
    else:
        target = os.environ.get("CARGO_TARGET_DIR")
        base = Path(target) if target else REPO_ROOT / "target"
        if not base.is_absolute():
            base = REPO_ROOT / base
        path = base / "ui-screenshots"
    path.mkdir(parents=True, exist_ok=True)
    return path


def new_browser(width: int = 1440, height: int = 900):
    """A headless Chromium, or a pytest skip saying what is missing."""
    paths = chromium_paths()
    if paths is None:
        pytest.skip("browser tests need Chromium and chromedriver (Debian: apt-get install chromium "
                    "chromium-driver; or set TMCL_CHROMIUM and TMCL_CHROMEDRIVER)")
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        pytest.skip("browser tests need selenium (tests/python/requirements.txt)")
    browser, driver = paths
    options = webdriver.ChromeOptions()
    options.binary_location = browser
    for arg in ["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                f"--window-size={width},{height}", "--force-device-scale-factor=1", "--lang=en-US",
                "--no-first-run", "--disable-extensions", "--disable-background-networking"]:
        options.add_argument(arg)
    return webdriver.Chrome(service=Service(executable_path=driver), options=options)


class Ui:
    """One `tmcl ui` process on a link; `url` is read from its first line of output."""

    def __init__(self, tmcl: Path, workdir: Path, args: list[str]):
        self.tmcl = tmcl
        self.workdir = workdir
        self.args = args
        self.proc: subprocess.Popen | None = None
        self.url = ""
        self._lines: queue.Queue = queue.Queue()
        self._stderr = workdir / f"ui-{id(self)}.stderr"

    def start(self) -> "Ui":
        with open(self._stderr, "wb") as err:
            self.proc = subprocess.Popen([str(self.tmcl), "ui", "--listen", "127.0.0.1:0", *self.args],
                                         cwd=self.workdir, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                         stderr=err)
        threading.Thread(target=self._pump, daemon=True).start()
        try:
            line = self._lines.get(timeout=UI_READY_TIMEOUT_S)
        except queue.Empty:
            self.kill()
            raise AssertionError(f"tmcl ui printed no address; stderr: {self.stderr()}")
        assert line and line.startswith("http://127.0.0.1:"), f"{line!r}; stderr: {self.stderr()}"
        self.url = line
        return self

    def _pump(self) -> None:
        assert self.proc is not None and self.proc.stdout is not None
        for raw in self.proc.stdout:
            self._lines.put(raw.decode("utf-8", "replace").strip())
        self._lines.put(None)

    @property
    def host_port(self) -> str:
        return self.url.removeprefix("http://").rstrip("/")

    def stop(self) -> int:
        """SIGTERM; returns the exit code."""
        assert self.proc is not None
        proc, self.proc = self.proc, None
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
        try:
            return proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=5)
            raise AssertionError("tmcl ui did not exit within 15 s of SIGTERM")

    def kill(self) -> None:
        if self.proc is not None:
            self.proc.kill()
            self.proc.wait(timeout=5)
            self.proc = None

    def stderr(self) -> str:
        return self._stderr.read_text("utf-8", "replace")[-4000:] if self._stderr.exists() else ""


def wait_until(check, timeout: float = 10.0, interval: float = 0.05, what: str = "condition"):
    """Polls `check()` until it returns a true value (returned), or fails after `timeout` seconds."""
    deadline = time.monotonic() + timeout
    last = None
    while True:
        try:
            last = check()
        except Exception as exc:  # a stale element while the page redraws: try again
            last = exc
        if last and not isinstance(last, Exception):
            return last
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout} s waiting for {what} (last: {last!r})")
        time.sleep(interval)

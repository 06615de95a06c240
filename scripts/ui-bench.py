#!/usr/bin/env python3
"""Figures of the browser workbench (docs/benchmarks.md, "The workbench"): plot update rate, end-to-end
latency from a module change to the page, and requests per second on the line, on a pty at full speed
and at 9600 baud (`tmcl serve --wire-timing`, GP 65 = 0).

Usage: .venv/bin/python scripts/ui-bench.py [--tmcl target/release/tmcl] [--seconds 10] [--changes 30]
(after `bash scripts/python-tests.sh`, which makes .venv with selenium; needs chromium and chromedriver).

What it does, per line: starts `tmcl serve --pty`, then `tmcl ui` on it, opens the Motion view in headless
Chromium, and
- counts, for --seconds, the actual-position samples that reach the page (the plot's new points per
  second), the plot's redraws per second, and the server's requests per second (its `stats` event);
- then makes --changes module changes from the page (ROR with alternating speeds) and times each from
  the answer to the ROR (the module has changed by then) to the page's first polled AP 2 with the new
  speed: that is the time a change takes to show, whatever made it;
- last, runs a counting loop to a breakpoint it never reaches for --seconds (the debugger's single steps)
  and reports instructions per second.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "python"))

from uitest import Ui, new_browser, wait_until  # noqa: E402

LATENCY_JS = """
const [speed, done] = [arguments[0], arguments[arguments.length - 1]];
const wb = window.workbench;
const t0 = performance.now();
let tAnswer = null;
const off = wb.on('value', (ev) => {
  if (ev.k === 'ap.0.2' && ev.v === speed && tAnswer !== null) {
    off(); done({sent: t0, answer: tAnswer, seen: performance.now()});
  }
});
wb.call('motion', {action: 'rotate_right', motor: 0, value: speed}).then(() => { tAnswer = performance.now(); });
setTimeout(() => { off(); done(null); }, 10000);
"""


# A four-instruction loop that counts in user variable 0, with a breakpoint on a line it never reaches.
STEP_PROGRAM = "    SGP 0, 2, 0\nLoop:\n    GGP 0, 2\n    CALC ADD, 1\n    AGP 0, 2\n    JA Loop\n    STOP\n"


def debugger_rate(driver, seconds: float) -> float:
    """Instructions per second of the debugger's run to a breakpoint (single steps), Program view open."""
    driver.find_element("css selector", "#tab-program").click()
    run = lambda js: driver.execute_async_script(  # noqa: E731
        "const done = arguments[arguments.length - 1]; const c = window.workbench.call;" + js)
    source = STEP_PROGRAM.replace("\n", "\\n")
    run(f"c('download', {{source: '{source}'}}).then(() => c('breakpoints', {{lines: [7]}})).then(done, done)")
    run("c('program', {action: 'start'}).then(done, done)")
    t0 = time.monotonic()
    time.sleep(seconds)
    run("c('program', {action: 'stop'}).then(done, done)")
    elapsed = time.monotonic() - t0
    count = run("c('get', {param: {kind: 'gp', number: 0, index: 2}}).then((ok) => done(ok.value), done)")
    return 4 * count / elapsed


def measure(tmcl: Path, wire_timing: bool, seconds: float, changes: int) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        link = work / "link"
        serve_args = [str(tmcl), "serve", "--pty", str(link)] + (["--wire-timing"] if wire_timing else [])
        serve = subprocess.Popen(serve_args, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
        assert serve.stdout is not None
        serve.stdout.readline()  # the ready line
        ui = Ui(tmcl, work, ["--port", str(link)]).start()
        driver = new_browser()
        try:
            driver.get(ui.url + "#motion")
            wait_until(lambda: driver.execute_script("return window.workbench.hello"), what="hello")
            wait_until(lambda: driver.execute_script("return window.workbench.stats"), timeout=5, what="stats")
            time.sleep(1.0)  # let the schedule settle into the Motion view's share of the line
            count = lambda: driver.execute_script(  # noqa: E731
                "const w = window.workbench; return [w.counts['ap.0.1'] || 0, w.plots[0].frames, performance.now()]")
            rps = []
            c0 = count()
            end = time.monotonic() + seconds
            while time.monotonic() < end:
                time.sleep(1.0)
                rps.append(driver.execute_script("return window.workbench.stats.rps"))
            c1 = count()
            elapsed = (c1[2] - c0[2]) / 1000
            transit = driver.execute_script("return window.workbench.transit.slice()")
            driver.set_script_timeout(15)
            after_answer, after_send = [], []
            for n in range(changes):
                speed = 20000 + 1000 * (n % 2) + n
                r = driver.execute_async_script(LATENCY_JS, speed)
                assert r is not None, "the change never showed"
                after_answer.append(r["seen"] - r["answer"])
                after_send.append(r["seen"] - r["sent"])
            driver.execute_script("window.workbench.call('motion', {action: 'stop', motor: 0})")
            steps = debugger_rate(driver, seconds)
        finally:
            driver.quit()
            ui.stop()
            serve.terminate()
            serve.wait(timeout=10)

    def q(xs, p):
        xs = sorted(xs)
        return xs[min(len(xs) - 1, int(p * len(xs)))]

    return {
        "samples_per_s": (c1[0] - c0[0]) / elapsed,
        "redraws_per_s": (c1[1] - c0[1]) / elapsed,
        "requests_per_s": statistics.median(rps),
        "latency_median_ms": statistics.median(after_answer),
        "latency_p90_ms": q(after_answer, 0.9),
        "send_to_seen_median_ms": statistics.median(after_send),
        "transit_median_ms": statistics.median(transit),
        "steps_per_s": steps,
        "sample_interval_ms": 1000 / ((c1[0] - c0[0]) / elapsed),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tmcl", type=Path, default=ROOT / "target" / "release" / "tmcl")
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--changes", type=int, default=30)
    args = ap.parse_args()
    rows = [("pty (200 requests/s cap)", False), ("9600 baud (--wire-timing)", True)]
    print("| Line | Plot samples/s | Plot redraws/s | Requests/s | Read → page, median | "
          "Page change → page, median | p90 | Click → page, median | Debugger steps/s |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name, timed in rows:
        r = measure(args.tmcl, timed, args.seconds, args.changes)
        print(f"| {name} | {r['samples_per_s']:.1f} | {r['redraws_per_s']:.1f} | {r['requests_per_s']:.1f} | "
              f"{r['transit_median_ms']:.1f} ms | {r['latency_median_ms']:.0f} ms | {r['latency_p90_ms']:.0f} ms | "
              f"{r['send_to_seen_median_ms']:.0f} ms | {r['steps_per_s']:.0f} |")


if __name__ == "__main__":
    main()

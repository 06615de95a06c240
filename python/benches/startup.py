"""Start-up figures of the opentmcl package (docs/benchmarks.md): import time, and the time a test
spends in the tmcl_module fixture (a Module made and closed), median of 100.

Run with the installed wheel: `python python/benches/startup.py` (from a venv without the checkout on
sys.path; scripts/python-package-tests.sh makes one under target/opentmcl-package/venv)."""

import statistics
import subprocess
import sys
import time


def import_time(runs: int = 20) -> float:
    """Median cumulative time of `import opentmcl` (the package, its native module and what they import)
    in a fresh interpreter, as `python -X importtime` reports it."""
    times = []
    for _ in range(runs):
        out = subprocess.run([sys.executable, "-X", "importtime", "-c", "import opentmcl"], check=True,
                             capture_output=True, text=True).stderr
        line = next(l for l in out.splitlines() if l.rstrip().endswith("| opentmcl"))
        times.append(int(line.split("|")[1]) / 1e6)
    return statistics.median(times)


def fixture_time(model: str, runs: int = 100, **link) -> float:
    """Median time to make a module and close it again, as the tmcl_module fixture does per test (it
    serves the module on a pty: link=True)."""
    import opentmcl
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        module = opentmcl.Module(model=model, **link)
        module.close()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


if __name__ == "__main__":
    print(f"import opentmcl: {import_time() * 1e3:.1f} ms (median of 20, cumulative, python -X importtime)")
    for model in ("pd28-1021", "tmcm-1310", "pd-113", "tmcm-1140"):
        for name, link in (("pty link (the fixture's default)", {"link": True}), ("TCP", {"tcp": True}),
                           ("no link", {})):
            print(f"module made and closed, {model}, {name}: {fixture_time(model, **link) * 1e6:.0f} µs "
                  "(median of 100)")

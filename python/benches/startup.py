"""Start-up figures of the opentmcl package (docs/benchmarks.md): import time, and the time a test
spends in the tmcl_module fixture (a Module made and closed), median of 100.

Run with the installed wheel: `python python/benches/startup.py` (from a venv without the checkout on
sys.path; scripts/python-package-tests.sh makes one under target/opentmcl-package/venv)."""

import statistics
import subprocess
import sys
import time


def import_time(runs: int = 20) -> float:
    """Median wall time of `import opentmcl` in a fresh interpreter, minus the interpreter's own start."""
    def median_of(code: str) -> float:
        times = []
        for _ in range(runs):
            start = time.perf_counter()
            subprocess.run([sys.executable, "-c", code], check=True)
            times.append(time.perf_counter() - start)
        return statistics.median(times)
    return median_of("import opentmcl") - median_of("pass")


def fixture_time(model: str, runs: int = 100) -> float:
    """Median time to make a module and close it again, as the tmcl_module fixture does per test."""
    import opentmcl
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        module = opentmcl.Module(model=model)
        module.close()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


if __name__ == "__main__":
    print(f"import opentmcl: {import_time() * 1e3:.1f} ms (median of 20, interpreter start subtracted)")
    for model in ("pd28-1021", "tmcm-1310", "pd-113"):
        print(f"tmcl_module fixture, {model}: {fixture_time(model) * 1e6:.0f} µs per test (median of 100)")

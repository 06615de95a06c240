"""Virtual Trinamic TMCL modules inside your Python process and your tests.

- :class:`Module` -- a virtual module (the OpenTMCL firmware core on a simulated board), in real time,
  with direct access (:meth:`Module.request`, :meth:`Module.get`, :meth:`Module.set`) and its world
  (:attr:`Module.world`).
- :func:`run` -- a standalone TMCL program on a simulated module, an hour in well under a second: the
  trace as columns (a pandas DataFrame when pandas is installed) and the instructions the module refused.
- :func:`assemble` and :func:`disassemble` -- the TMCL assembler, its errors as :class:`AssemblyError`
  with file, line and column.
- :meth:`Module.bus` -- several modules on one pty or TCP port, as on an RS485 bus.
- the pytest plugin (:mod:`opentmcl.pytest_plugin`): the fixtures ``tmcl_module`` and ``tmcl_bus`` and
  the marker ``@pytest.mark.tmcl(model=..., world=...)``.
"""

from ._native import (
    AssemblyError,
    Diagnostic,
    Module,
    Program,
    Reply,
    TmclError,
    World,
    __version__,
    assemble,
    disassemble,
    models,
)
from ._native import run as _run



class RunResult:
    """What :func:`run` returns.

    - ``trace``: the trace as columns -- a pandas ``DataFrame`` when pandas is installed, else a dict of
      lists (``time_s`` first, then the columns ``tmcl run`` writes, in their units; ``None`` where the
      module gave no value). ``columns`` is always the dict.
    - ``units``: column name -> unit symbol (``s``, ``µsteps``, ``pps``, ...).
    - ``events``: ``(time_s, kind, value)`` for each program event (``stop``, ``target``, ``out0``, ...).
    - ``refusals``: ``{"count": N, "last": [...]}`` -- the instructions the module refused while the
      program ran (the firmware skips them and goes on; each with ``time_s``, ``pc``, ``instruction``,
      ``text``, ``status``); ``last`` holds the most recent ones the core keeps (up to 8).
    - ``summary``: ``state``, ``pc``, ``executed``, ``simulated_s``, ``wall_s``, ``rows``.
    """

    def __init__(self, raw: dict):
        self.columns = raw["columns"]
        self.units = raw["units"]
        self.events = raw["events"]
        self.refusals = raw["refusals"]
        self.summary = raw["summary"]
        self.trace = _frame(self.columns)

    def __len__(self) -> int:
        return len(self.columns["time_s"])

    def __repr__(self) -> str:
        return (f"<RunResult {len(self)} rows, {len(self.columns) - 1} columns, "
                f"{self.refusals['count']} refusals, program {self.summary['state']}>")


def _frame(columns: dict):
    try:
        import pandas
    except ImportError:
        return columns
    return pandas.DataFrame(columns)


def run(program, seconds=3600.0, world=None, every=0.01, model="pd28-1021", settings=(), drive=False):
    """Runs a standalone TMCL program on a fresh simulated module, far faster than real time.

    ``program`` is TMCL source text, a :class:`Program`, a ``.bin`` image (``bytes``) or a list of
    ``(opcode, type, motor, value)`` tuples; ``world`` a TOML world file's path or text; ``every`` the
    row interval in seconds (rows are also written at each event); ``settings`` parameter settings
    applied before the start, as ``tmcl run --set`` takes them (``"ap4=1000"``, ``"gp0.2=7"``);
    ``drive=True`` adds the drive's columns (stallGuard2, coolStep, encoder, energy). Same program, same
    options: the same trace, byte for byte as ``tmcl run``'s CSV. Returns a :class:`RunResult`.
    """
    return RunResult(_run(program, seconds=seconds, world=world, every=every, model=model,
                          settings=list(settings), drive=drive))


__all__ = [
    "AssemblyError",
    "Diagnostic",
    "Module",
    "Program",
    "Reply",
    "TmclError",
    "World",
    "__version__",
    "assemble",
    "disassemble",
    "models",
    "run",
    "RunResult",
]

"""Virtual Trinamic TMCL modules inside your Python process and your tests.

- :class:`Module` -- a virtual module (the OpenTMCL firmware core on a simulated board), in real time,
  with direct access (:meth:`Module.request`, :meth:`Module.get`, :meth:`Module.set`) and its world
  (:attr:`Module.world`).
- :func:`assemble` and :func:`disassemble` -- the TMCL assembler, its errors as :class:`AssemblyError`
  with file, line and column.
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
]

"""The opentmcl pytest plugin: virtual TMCL modules as fixtures.

Installed with the package (entry point ``pytest11``), nothing to import::

    import pytest

    @pytest.mark.tmcl(model="tmcm-1310", world="closed-loop-seizure.toml")
    def test_closed_loop(tmcl_module):
        assert tmcl_module.get("MaxPositioningSpeed") > 0

Fixtures (a fresh module for every test, stopped and cleaned up after it):

- ``tmcl_module``: an :class:`opentmcl.Module` served on a fresh pty (``.link``), configured by the
  ``tmcl`` marker's keywords, the same as :class:`opentmcl.Module`'s (``model``, ``world``, ``eeprom``,
  ``address``; ``tcp=True`` serves it on a loopback TCP port instead, ``link=False`` on no link). A
  relative ``world`` or ``eeprom`` path is taken from the test file's directory when a file of that name
  is there.
- ``tmcl_bus``: several modules on one line (:meth:`opentmcl.Module.bus`), from the marker's ``modules``
  keyword: a list of model ids or of keyword dicts.
- ``tmcl_connection``: a function giving pytrinamic's ``ConnectionManager`` arguments for a module
  (:func:`pytrinamic_args`).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Callable, Dict, Iterator, List

import pytest

from . import Module

MARKER = "tmcl"


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers",
        "tmcl(model='pd28-1021', world=None, eeprom=None, address=1, modules=None): the virtual module "
        "of the tmcl_module fixture (or the modules of tmcl_bus)",
    )


def _marker_kwargs(request: pytest.FixtureRequest) -> Dict[str, Any]:
    marker = request.node.get_closest_marker(MARKER)
    if marker is None:
        return {}
    if marker.args:
        raise pytest.UsageError("@pytest.mark.tmcl takes keywords only: model=..., world=..., ...")
    return dict(marker.kwargs)


def _beside_test(request: pytest.FixtureRequest, value: Any) -> Any:
    """A relative path that names a file beside the test file becomes that file; anything else stays."""
    if not isinstance(value, (str, os.PathLike)) or "\n" in str(value):
        return value
    path = Path(value)
    if path.is_absolute():
        return value
    beside = Path(str(request.node.fspath)).parent / path
    return str(beside) if beside.exists() else value


def _module_kwargs(request: pytest.FixtureRequest, kwargs: Dict[str, Any]) -> Dict[str, Any]:
    kwargs = dict(kwargs)
    for key in ("world", "eeprom"):
        if kwargs.get(key) is not None:
            kwargs[key] = _beside_test(request, kwargs[key])
    return kwargs


def pytrinamic_args(module: Module, module_id: int | None = None) -> str:
    """pytrinamic ``ConnectionManager`` arguments for ``module``: its pty link (``serial_tmcl``) when it
    has one, else its TCP port (``socket_serial_tmcl``). ``module_id`` selects a module on a bus."""
    suffix = f" --module-id {module_id}" if module_id is not None else ""
    link = getattr(module, "link", None)
    if link:
        return f"--interface serial_tmcl --port {link} --data-rate 115200{suffix}"
    address = getattr(module, "tcp_address", None)
    if address:
        return f"--interface socket_serial_tmcl --port {address}{suffix}"
    raise RuntimeError(f"{module!r} is served on no link: make it with link=True or tcp=True")


def pytrinamic_connection(module: Module, module_id: int | None = None):
    """An open pytrinamic connection to ``module`` (close it after use); pytrinamic must be installed.
    A TCP connection gets a socket timeout of 10 s, so that a missing reply fails instead of hanging."""
    from pytrinamic.connections import ConnectionManager

    connection = ConnectionManager(pytrinamic_args(module, module_id)).connect()
    sock = getattr(connection, "_socket", None)
    if sock is not None:
        sock.settimeout(10.0)
    return connection


@pytest.fixture
def tmcl_module(request: pytest.FixtureRequest) -> Iterator[Module]:
    """A fresh virtual module for this test, as the ``tmcl`` marker says, served on a pty unless the
    marker asks for TCP or no link; closed (link removed, EEPROM flushed) after the test."""
    kwargs = _module_kwargs(request, _marker_kwargs(request))
    if not kwargs.get("tcp") and "link" not in kwargs:
        kwargs["link"] = True
    module = Module(**kwargs)
    try:
        yield module
    finally:
        module.close()


@pytest.fixture
def tmcl_bus(request: pytest.FixtureRequest) -> Iterator[List[Module]]:
    """Fresh virtual modules on one line for this test, from the ``tmcl`` marker's ``modules``; closed
    after the test."""
    kwargs = _marker_kwargs(request)
    specs = kwargs.pop("modules", None) or ["pd28-1021", "pd28-1021"]
    modules: List[Dict[str, Any]] = []
    for n, spec in enumerate(specs):
        entry = {"model": spec} if isinstance(spec, str) else dict(spec)
        entry.setdefault("address", n + 1)
        modules.append(_module_kwargs(request, entry))
    made = Module.bus(modules, **kwargs)
    try:
        yield made
    finally:
        for module in made:
            module.close()


@pytest.fixture
def tmcl_connection() -> Callable[..., str]:
    """A function: ``tmcl_connection(module)`` gives pytrinamic's ConnectionManager arguments for it."""
    return pytrinamic_args

"""The fingerprint of the code that computes a scene's numbers: a sweep's dataset and
every written table record it, and a changed fingerprint starts a new dataset
(:meth:`kapitza.Scene.sweep`)."""
from __future__ import annotations

import functools
import importlib
import pkgutil
from pathlib import Path

from lagrange_core.module_store import content_key, source_fingerprint

__all__ = ["code_fingerprint", "fingerprinted_modules"]

#: Modules and subpackages whose code does not change what a scene computes (figures, the
#: command line, installation, the cluster executor, how results are stored, displayed and
#: converted); everything else, at any depth, counts.
_NOT_FINGERPRINTED = ("kapitza.figures", "kapitza.cli", "kapitza.warmup", "kapitza.__main__",
                      "kapitza.scenes._sweep_dask", "kapitza.scenes._sweep_xarray",
                      "kapitza.scenes._outputs", "kapitza.scenes._sweep_store",
                      "kapitza.scenes._fingerprint", "kapitza.results._display",
                      "kapitza.results._xarray", "lagrange_core.warmup")


def _excluded(name: str) -> bool:
    return any(name == x or name.startswith(x + ".") for x in _NOT_FINGERPRINTED)


def fingerprinted_modules() -> list:
    """Every module of lagrange_core and kapitza whose code can change a number: the
    packages walked recursively (subpackages and their private modules included), less
    ``_NOT_FINGERPRINTED``."""
    mods, todo = [], ["lagrange_core", "kapitza"]
    while todo:
        package = importlib.import_module(todo.pop(0))
        mods.append(package)
        for info in pkgutil.iter_modules(package.__path__, prefix=f"{package.__name__}."):
            if _excluded(info.name):
                continue
            if info.ispkg:
                todo.append(info.name)
            else:
                mods.append(importlib.import_module(info.name))
    # an empty file (a bare __init__.py) has no code, and no source for inspect to read
    return [m for m in mods if Path(m.__file__).stat().st_size > 0]


@functools.cache
def _package_fingerprint() -> str:
    mods = fingerprinted_modules()
    return source_fingerprint(*mods)


def code_fingerprint(user_module: str | None = None) -> str:
    """The fingerprint of the code that computes a scene's results: every module of
    lagrange_core and kapitza that can change a number (docstrings and comments
    excluded, :func:`lagrange_core.module_store.source_fingerprint`), and a user rig's
    module."""
    base = _package_fingerprint()
    if user_module is None:
        return base
    return content_key(base, source_fingerprint(importlib.import_module(user_module)))

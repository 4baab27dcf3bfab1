"""The one store of generated modules: cache directory, content key, atomic write, load.

Every generator of numba code in the project (the system kernels of
:mod:`lagrange_core.codegen`, the specialised drive kernel of
:mod:`lagrange_core.drive_kernel`, the averaging kernels of :mod:`kapitza`) writes a
Python module and lets numba cache its machine code beside it.  They all go through
:func:`load_generated`:

1. the *content key* is a hash of everything the text depends on: the statement of
   the system and the code that generates it and that it calls
   (:func:`source_fingerprint`), never of a file's prose;
2. the module is written once, atomically (a concurrent process never reads half a
   file), under ``<prefix>_<key>.py`` in :func:`cache_dir`;
3. it is imported once per process under that name.

So a fresh process with a warm store neither derives nor compiles: the key finds the
module and numba loads its machine code from ``__pycache__`` next to it.

The directory is ``$LAGRANGE_CORE_CACHE`` (default ``~/.cache/lagrange_core``), with a
subdirectory per Python and numba version (numba's cache is not portable across them).
"""
from __future__ import annotations

import ast
import hashlib
import importlib.util
import inspect
import os
import sys
import tempfile
import textwrap
import types
from collections.abc import Callable
from pathlib import Path

import numba

from ._first_calls import guard as guard_first_calls

__all__ = ["cache_dir", "source_fingerprint", "content_key", "load_generated",
           "write_module", "load_module", "guard_numba_cache"]


def cache_dir() -> Path:
    """Directory of generated modules (``$LAGRANGE_CORE_CACHE`` or ``~/.cache/lagrange_core``)."""
    root = os.environ.get("LAGRANGE_CORE_CACHE") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache"), "lagrange_core")
    python = f"py{sys.version_info.major}{sys.version_info.minor}"
    path = Path(root) / f"{python}-numba{numba.__version__}"
    path.mkdir(parents=True, exist_ok=True)
    return path


def _write_atomic(path: Path, text: str, suffix: str = "") -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=suffix)
    with os.fdopen(fd, "w") as fh:
        fh.write(text)
    os.replace(tmp, path)


def source_fingerprint(*modules) -> str:
    """Hash of the code of ``modules`` (modules, classes or functions), docstrings and
    comments excluded.

    Generated modules are keyed by this hash of the code that generates them *and* of
    the numba functions they call (numba's own cache does not notice a change in a
    callee from another module).  Editing prose keeps the store.  Parsing costs
    ~0.25 s, so the result is memoised on disk under a hash of the raw sources.
    """
    sources = [textwrap.dedent(inspect.getsource(module)) for module in modules]
    memo = cache_dir() / "fingerprints" / hashlib.sha256("\0".join(sources).encode()).hexdigest()
    if memo.exists():
        return memo.read_text()
    h = hashlib.sha256()
    for source in sources:
        tree = ast.parse(source)
        for node in ast.walk(tree):
            body = getattr(node, "body", None)
            if (isinstance(node, (ast.Module, ast.FunctionDef, ast.ClassDef)) and body
                    and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant)
                    and isinstance(body[0].value.value, str)):
                node.body = body[1:] or [ast.Pass()]
        h.update(ast.dump(tree).encode())
    memo.parent.mkdir(exist_ok=True)
    _write_atomic(memo, h.hexdigest())     # concurrent processes never read half a hash
    return h.hexdigest()


def content_key(*parts: str) -> str:
    """The store's key of a generated module: a hash of the strings it depends on."""
    return hashlib.sha256("\0".join(parts).encode()).hexdigest()[:20]


def write_module(path: Path, text: str) -> None:
    """Write a generated module atomically (concurrent processes never see half a file)."""
    _write_atomic(path, text, suffix=".py")


def load_module(path: Path, name: str) -> types.ModuleType:
    """Import a generated module file under ``name`` (once per process)."""
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    guard_first_calls(name)     # its kernels' first calls: where Ctrl-C need not wait
    return module


def load_generated(prefix: str, key: str, generate: Callable[[], str]) -> types.ModuleType:
    """The generated module ``<prefix>_<key>``: imported if this process has it, loaded
    from the store if a process wrote it before, else ``generate()``-d, written and loaded.

    Parameters
    ----------
    prefix : str
        Names the generator (``"_lc"`` system kernels, ``"_lcfast"`` the drive kernel, ...);
        a valid Python identifier.
    key : str
        :func:`content_key` of everything the text depends on.
    generate : callable () -> str
        Makes the module's source; called only when the store has no such module.
    """
    name = f"{prefix}_{key}"
    if name in sys.modules:
        return sys.modules[name]
    path = cache_dir() / f"{name}.py"
    if not path.exists():
        write_module(path, generate())
    return load_module(path, name)


def guard_numba_cache(module: types.ModuleType, *dependencies) -> None:
    """Flush the numba cache of ``module``'s jitted functions when a module they call into
    has changed since the cache was written.

    numba keys a cached function by its own file only: a cached driver that calls a
    kernel slot or a solver defined in another module keeps the old machine code after
    that module changes (a changed slot number then calls the wrong kernel).  Call this at
    the end of such a module with the modules it calls into; it compares their
    :func:`source_fingerprint` with the one recorded beside numba's cache of this file
    and, if they differ, empties that cache so the functions recompile on first use.
    """
    try:
        stamp = source_fingerprint(*dependencies)
    except OSError:         # no writable cache directory: nothing to compare with
        return
    caches = [obj._cache for obj in vars(module).values()
              if getattr(obj, "__module__", None) == module.__name__
              and hasattr(getattr(obj, "_cache", None), "flush")]
    if not caches:
        return
    marker = Path(caches[0].cache_path) / f"{module.__name__.rpartition('.')[2]}.dependencies"
    try:
        if marker.read_text() == stamp:
            return
    except OSError:
        pass
    for cache in caches:
        cache.flush()
    try:
        _write_atomic(marker, stamp)
    except OSError:         # a read-only cache directory: flushed again next time
        pass

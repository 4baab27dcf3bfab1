"""The API reference, written from the packages' ``__all__`` at every build.

One page per public module: ``lagrange_core``, the modules its ``__all__`` lists
(``problems``, ``fields``, ``effects``), ``kapitza`` and every room of ``kapitza`` (each
subpackage without a leading underscore, found by walking the package, so a new room gets
its page).  Each page shows the module's docstring and a table of every name in its
``__all__``, in that order; a name added to an ``__all__`` appears on the next build.

Every function and class is documented once, on a page of its own under its *home*: the
public module that owns it (the page whose module is the longest prefix of the object's
``__module__``, e.g. ``kapitza.floquet`` for ``kapitza.floquet._window.window``; the first
page listing it otherwise).  Other pages that list the same object (``kapitza.window``,
``kapitza.chaos.basin_figure``) link to that page instead of repeating it.  Constants are
documented on the page that lists them, by the ``#:`` comment above their assignment (a
public constant without one is a warning).

References.  Docstrings name objects by whichever path the author had in mind
(``kapitza.window``, ``lagrange_core.systems.System``, ``KapitzaPendulum.floquet`` inside
the pendulum's module).  :func:`resolve_reference` maps each such name to the documented one
by identity (import it, find the same object among the documented ones).  A reference in a
docstring or page that names one of our packages and still resolves to nothing is a warning
(``-W`` makes it an error): a misspelt name, a renamed function, or a private helper that a
public docstring links to.  References to other libraries (numpy, scipy, ...) stay plain
text, as without intersphinx (the build is offline), and so do the type annotations of
signatures (code, not docstrings).
"""

from __future__ import annotations

import functools
import importlib
import importlib.util
import inspect
import itertools
import os
import pkgutil
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

from absolute_values import escape_bars
from sphinx import addnodes
from sphinx.pycode import ModuleAnalyzer
from sphinx.util import logging

logger = logging.getLogger(__name__)

#: the packages documented; their pages come first, in this order
PACKAGES = ("lagrange_core", "kapitza")
#: base classes whose members are not repeated on a subclass's page
_FOREIGN_BASES = (
    "BaseException",
    "Exception",
    "Warning",
    "UserWarning",
    "RuntimeWarning",
    "KeyboardInterrupt",
    "dict",
    "tuple",
    "list",
    "str",
    "float",
    "int",
)


def _quiet_getattr(obj, name):
    # deprecated aliases (kapitza.FloquetWindow) warn when looked up; looking is not using
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return getattr(obj, name)


def public_modules() -> list[str]:
    """The modules that get a page: each package; lagrange_core's public modules (a flat
    package: each module without a leading underscore that has an ``__all__``), those its
    ``__all__`` lists first; kapitza's rooms (subpackages without a leading underscore)."""
    names = []
    for package in PACKAGES:
        module = importlib.import_module(package)
        names.append(package)
        names += [
            f"{package}.{n}" for n in module.__all__ if inspect.ismodule(_quiet_getattr(module, n))
        ]
        for info in sorted(pkgutil.iter_modules(module.__path__), key=lambda i: i.name):
            if info.name.startswith("_") or info.name == "__main__":
                continue
            if package == "kapitza" and not info.ispkg:
                continue  # kapitza's own modules speak through its __init__
            full = f"{package}.{info.name}"
            submodule = importlib.import_module(full)
            if not info.ispkg and _quiet_getattr(module, info.name) is not submodule:
                continue  # lagrange_core.warmup: the name is the function's
            if info.ispkg or hasattr(submodule, "__all__"):
                names.append(full)
    return list(dict.fromkeys(names))


def _identified(obj) -> bool:
    """Objects told apart by identity: everything but plain numbers and strings (``200`` or
    ``"A"`` may be the very object of an unrelated constant elsewhere)."""
    return not isinstance(obj, (int, float, complex, str, bytes, type(None)))


@dataclass
class Catalogue:
    """Every public name, where it is documented, and what links where."""

    modules: list[str]
    #: module → [(name, object, documented full name)] in ``__all__`` order
    entries: dict[str, list] = field(default_factory=dict)
    #: id(object) → documented full name, for functions and classes
    home: dict[int, str] = field(default_factory=dict)
    #: full names documented on a page of their own → ("function" | "class" | "data")
    pages: dict[str, str] = field(default_factory=dict)
    #: (dotted name, module?) → :meth:`canonical`'s answer
    _answers: dict[tuple[str, bool], str | None] = field(default_factory=dict, repr=False)

    @classmethod
    def build(cls) -> Catalogue:
        cat = cls(public_modules())
        listed = {m: importlib.import_module(m) for m in cat.modules}
        packages = {m for m, module in listed.items() if hasattr(module, "__path__")}
        # the home of each object: the longest package (kapitza's room, or lagrange_core)
        # whose name prefixes the object's __module__ and that lists it; else the first
        # page that lists it
        listing: dict[int, list] = {}
        for modname, module in listed.items():
            for name in module.__all__:
                obj = _quiet_getattr(module, name)
                if _identified(obj) and not inspect.ismodule(obj):
                    listing.setdefault(id(obj), []).append((modname, name, obj))
        for key, places in listing.items():
            owner = getattr(places[0][2], "__module__", None) or ""
            owners = [
                (m, n)
                for m, n, _ in places
                if m in packages and (owner == m or owner.startswith(m + "."))
            ]
            home_module, name = max(owners, key=lambda p: len(p[0])) if owners else places[0][:2]
            cat.home[key] = f"{home_module}.{name}"
        for modname, module in listed.items():
            rows = []
            for name in module.__all__:
                obj = _quiet_getattr(module, name)
                if inspect.ismodule(obj):
                    full = obj.__name__ if obj.__name__ in listed else f"{modname}.{name}"
                elif id(obj) in cat.home:
                    full = cat.home[id(obj)]
                else:
                    full = f"{modname}.{name}"
                if full == f"{modname}.{name}" and not inspect.ismodule(obj):
                    cat.pages[full] = (
                        "class"
                        if inspect.isclass(obj)
                        else "function"
                        if inspect.isroutine(obj)
                        else "data"
                    )
                rows.append((name, obj, full))
            cat.entries[modname] = rows
        return cat

    def canonical(self, dotted: str, module: bool = False) -> str | None:
        """The documented name of the object ``dotted`` names, or None (not importable, or
        importable but not documented).  ``module``: a module is meant (the ``:mod:``
        role); otherwise a package attribute that shadows a submodule of the same name
        (``kapitza.continuation``, the function) is meant."""
        # asked again and again (the build's ~2000 references name a few hundred objects,
        # each tried with up to three spellings), and each answer imports: a failed import
        # searches the whole path anew.  The answer depends only on what is importable and
        # on the catalogue, neither of which changes during a build.
        key = (dotted, module)
        if key not in self._answers:
            self._answers[key] = self._canonical(dotted, module)
        return self._answers[key]

    def _canonical(self, dotted: str, module: bool) -> str | None:
        parts = dotted.split(".")
        if parts[0] not in PACKAGES:
            # only our packages' objects are documented: matplotlib.figure.Figure names
            # nothing here, and importing matplotlib.figure to see that costs 0.3 CPU-s
            return None
        if not module and len(parts) > 1:
            try:
                parent = importlib.import_module(".".join(parts[:-1]))
                obj = _quiet_getattr(parent, parts[-1])
            except (ImportError, AttributeError):
                obj = None
            if obj is not None and not inspect.ismodule(obj) and id(obj) in self.home:
                return self.home[id(obj)]
        for cut in range(len(parts), 0, -1):  # the longest importable module prefix
            modname = ".".join(parts[:cut])
            try:
                obj = importlib.import_module(modname)
            except ImportError:
                continue
            rest = parts[cut:]
            break
        else:
            return None
        if not rest:  # a module: itself or the nearest page
            while modname and modname not in self.modules:
                modname = modname.rpartition(".")[0]
            return modname or None
        chain = [obj]
        for k, part in enumerate(rest):
            owner = chain[-1]
            # a result's field is documented in its class's Attributes section (no target
            # of its own): the class's page
            if (
                k == len(rest) - 1
                and inspect.isclass(owner)
                and id(owner) in self.home
                and part in getattr(owner, "__dataclass_fields__", {})
            ):
                return self.home[id(owner)]
            try:
                chain.append(_quiet_getattr(owner, part))
            except AttributeError:
                return None
        # the innermost identified object along the chain, then the attributes below it
        for depth in range(len(chain) - 1, 0, -1):
            if _identified(chain[depth]) and id(chain[depth]) in self.home:
                return ".".join([self.home[id(chain[depth])], *rest[depth:]])
        name = ".".join(parts)
        return name if name in self.pages else None


def _title(modname: str) -> str:
    return f"``{modname}``\n{'=' * (len(modname) + 4)}\n"


def _write_if_changed(path: Path, text: str) -> None:
    # atomic, and untouched when equal: Sphinx rereads only what changed
    if path.exists() and path.read_text() == text:
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(f".tmp{os.getpid()}")
    tmp.write_text(text)
    os.replace(tmp, path)


def _doc_comment(modname: str, name: str, value) -> list[str] | None:
    """The ``#:`` comment above ``name = ...`` in the module that assigns it (the public
    module itself, or one of its package's modules), or None."""
    found = _assignment_comment(modname, name)
    return None if found is None else list(found)


@functools.cache
def _assignment_comment(modname: str, name: str) -> tuple[str, ...] | None:
    # asked twice per constant (its row's summary, its page), and each answer reads the
    # package's modules: the answers and the sources are kept for the build
    candidates = [modname, *_package_modules(modname.split(".")[0])]
    assigned = re.compile(rf"^{re.escape(name)}\s*(:[^=]*)?=", re.M)
    for candidate in candidates:
        source = _module_source(candidate)
        if source is None or not assigned.search(source):
            continue
        docs = ModuleAnalyzer.for_module(candidate).find_attr_docs()
        if ("", name) in docs:
            return tuple(docs[("", name)])
    return None


@functools.cache
def _package_modules(package: str) -> tuple[str, ...]:
    """Every module of ``package`` (but ``__main__``), sorted by name."""
    path = importlib.import_module(package).__path__
    return tuple(
        sorted(
            info.name
            for info in pkgutil.walk_packages(path, package + ".")
            if not info.name.endswith("__main__")
        )
    )


@functools.cache
def _module_source(modname: str) -> str | None:
    """The source of ``modname``, or None; read, not imported (a search of the text needs
    no import, and kapitza.scenes' dask module imports dask and distributed: 0.5 CPU-s)."""
    try:
        spec = importlib.util.find_spec(modname)
        return spec.loader.get_source(modname) if spec is not None and spec.loader else None
    except (OSError, ImportError, AttributeError):
        return None


def _data_page(full: str, value) -> str:
    modname, _, name = full.rpartition(".")
    doc = _doc_comment(modname, name, value)
    if doc is None:
        logger.warning(
            "public constant %s has no '#:' comment saying what it is",
            full,
            type="kapitza",
            subtype="constant",
        )
        doc = []
    shown = repr(value)
    option = (
        f"   :value: {shown}\n"
        if len(shown) <= 80 and "\n" not in shown
        else f"   :type: {type(value).__module__}.{type(value).__qualname__}\n"
        if type(value).__module__ != "builtins"
        else f"   :type: {type(value).__name__}\n"
    )
    return (
        _title(full)
        + f"\n.. py:data:: {name}\n   :module: {modname}\n"
        + option
        + "\n"
        + "".join(f"   {line}\n" if line.strip() else "\n" for line in doc)
    )


def _object_page(full: str, kind: str, value=None) -> str:
    modname, _, name = full.rpartition(".")
    if kind == "data":
        return _data_page(full, value)
    text = _title(full) + f"\n.. currentmodule:: {modname}\n\n"
    if kind == "class":
        text += (
            f".. autoclass:: {name}\n   :members:\n   :show-inheritance:\n"
            f"   :inherited-members: {','.join(_FOREIGN_BASES)}\n"
        )
    elif kind == "function":
        text += f".. autofunction:: {name}\n"
    return text


def summary(obj, full: str) -> str:
    """The first sentence of what ``obj`` is: its docstring's (functions, classes, modules)
    or its ``#:`` comment's (constants, whose own docstring is their type's)."""
    if inspect.isclass(obj) or inspect.isroutine(obj) or inspect.ismodule(obj):
        lines = (inspect.getdoc(obj) or "").splitlines()
    else:
        modname, _, name = full.rpartition(".")
        lines = _doc_comment(modname, name, obj) or []
    paragraph = " ".join(itertools.takewhile(str.strip, (line.strip() for line in lines)))
    match = re.match(r"(.+?\.)(\s|$)", paragraph)
    sentence = match.group(1) if match else paragraph
    return escape_bars(sentence)


def _module_page(cat: Catalogue, modname: str) -> str:
    rows = cat.entries[modname]
    text = _title(modname) + f"\n.. automodule:: {modname}\n   :no-members:\n\n"
    text += (
        f".. currentmodule:: {modname}\n\n.. rubric:: Every public name\n\n"
        f"The names of ``{modname}.__all__``, in its order.\n\n"
        ".. list-table::\n   :class: autosummary longtable\n   :widths: 30 70\n\n"
    )
    for name, obj, full in rows:
        role = "py:mod" if inspect.ismodule(obj) else "py:obj"
        text += f"   * - :{role}:`{name} <{full}>`\n     - {summary(obj, full)}\n"
    own = [
        full
        for name, obj, full in rows
        if full == f"{modname}.{name}" and not inspect.ismodule(obj)
    ]
    if own:
        text += "\n.. toctree::\n   :hidden:\n\n" + "".join(f"   generated/{f}\n" for f in own)
    return text


def write_pages(srcdir: Path, cat: Catalogue) -> None:
    """Write ``api/`` under ``srcdir``: the index, one page per module, one per object."""
    api = srcdir / "api"
    index = (
        "API reference\n=============\n\nEvery public name of both packages: "
        "``lagrange_core`` (the engine) and ``kapitza`` (periodic driving), with the "
        "public face of each of kapitza's rooms.  Each name is documented once, in "
        "the room it belongs to; the other pages that list it link there.\n\n"
        ".. toctree::\n   :maxdepth: 1\n\n" + "".join(f"   {m}\n" for m in cat.modules)
    )
    _write_if_changed(api / "index.rst", index)
    for modname in cat.modules:
        _write_if_changed(api / f"{modname}.rst", _module_page(cat, modname))
    for full, kind in cat.pages.items():
        modname, _, name = full.rpartition(".")
        value = _quiet_getattr(importlib.import_module(modname), name)
        _write_if_changed(api / "generated" / f"{full}.rst", _object_page(full, kind, value))
    # pages of names no longer public: removed, so they neither build nor linger
    wanted = {f"{full}.rst" for full in cat.pages}
    for old in (api / "generated").glob("*.rst"):
        if old.name not in wanted:
            old.unlink()
    for old in api.glob("*.rst"):
        if old.stem not in {"index", *cat.modules}:
            old.unlink()


_CATALOGUE: Catalogue | None = None


def catalogue() -> Catalogue:
    global _CATALOGUE
    if _CATALOGUE is None:
        _CATALOGUE = Catalogue.build()
    return _CATALOGUE


def _ours(name: str) -> bool:
    return name.split(".")[0] in PACKAGES


def resolve_reference(app, env, node, contnode):
    """``missing-reference``: link a name of ours to where it is documented; warn when a
    docstring or page names something of ours that is not documented."""
    if node.get("refdomain") != "py":
        return None
    target = node["reftarget"].lstrip("~.")
    modname, clsname = node.get("py:module"), node.get("py:class")
    candidates = [target]
    if modname and clsname:
        candidates.append(f"{modname}.{clsname}.{target}")
    if modname:
        candidates.append(f"{modname}.{target}")
    cat = catalogue()
    domain = env.get_domain("py")
    seen_ours = _ours(target)
    for candidate in candidates:
        canon = cat.canonical(candidate, module=node.get("reftype") == "mod")
        if canon is None:
            continue
        seen_ours = seen_ours or _ours(canon)
        role = "mod" if canon in cat.modules else "obj"
        found = domain.resolve_xref(env, node["refdoc"], app.builder, role, canon, node, contnode)
        if found is not None:
            return found
    # an unqualified name (``Method`` in a constant's comment): the one documented object
    # of the context's package with that name, if there is exactly one
    if "." not in target and modname:
        package = modname.split(".")[0] + "."
        matches = {
            full
            for full in [*cat.home.values(), *cat.pages]
            if full.startswith(package) and full.rpartition(".")[2] == target
        }
        if len(matches) == 1:
            found = domain.resolve_xref(
                env, node["refdoc"], app.builder, "obj", matches.pop(), node, contnode
            )
            if found is not None:
                return found
    in_signature = any(isinstance(a, addnodes.desc_signature) for a in _ancestors(node))
    if seen_ours and not in_signature:
        logger.warning(
            "reference to %r (%s role) resolves to nothing documented: a "
            "misspelt or private name (write it as ``literal`` text if it is "
            "private)",
            node["reftarget"],
            node.get("reftype"),
            location=node,
            type="kapitza",
            subtype="reference",
        )
    return None


def _ancestors(node):
    while node.parent is not None:
        node = node.parent
        yield node


def generate(app) -> None:
    if app.config.api_pages:
        write_pages(Path(app.srcdir), catalogue())


def setup(app):
    # False: only resolve and check references (a small project, the tests' own)
    app.add_config_value("api_pages", True, "env", types=(bool,))
    app.connect("builder-inited", generate, priority=100)
    app.connect("missing-reference", resolve_reference)
    return {"parallel_read_safe": True, "parallel_write_safe": True}


__all__ = ["Catalogue", "public_modules", "write_pages", "resolve_reference"]

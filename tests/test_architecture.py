"""The structure: data flow one way, no import circles, rooms behind their faces (issues 9, 20).

Every import between a package's modules counts, including imports inside functions
(a lazy import is still a dependency); only imports for type checkers
(``if TYPE_CHECKING:``) do not.  Modules are found at every depth: a subpackage's private
modules are walked like the top level.  Run as ``python -m pytest tests/test_architecture.py``;
a failure message names the module, the import and the rule it breaks.
"""
import ast
import functools
import pathlib
import typing

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]

#: kapitza's rooms and the rooms each may import (at any depth, lazily or not). The order
#: is the data flow: results are drawn by figures; analyses (averaging, floquet, closed
#: forms, simulation, chaos, continuation) produce results; verification compares analyses; the
#: pendulum and scenes call them; animation, the report and the command line sit on top.
#: "" is the top-level private helpers (_arguments, _deprecation, _version), open to all.
KAPITZA_ROOMS = {
    "": set(),
    "results": {"", "figures"},          # figures only lazily, inside a result's figure()
    "figures": {""},                     # reads results by duck typing, never imports them
    "averaging": {"", "results"},
    "floquet": {"", "results"},
    "closed_forms": {"", "results", "averaging"},
    "simulation": {"", "results", "averaging", "floquet"},
    "chaos": {"", "results", "figures", "simulation", "floquet"},
    "continuation": {"", "results", "figures", "simulation", "floquet"},
    "verification": {"", "results", "averaging", "floquet", "closed_forms", "simulation"},
    "pendulum": {"", "results", "averaging", "floquet", "closed_forms", "simulation",
                 "verification"},
    "scenes": {"", "results", "averaging", "floquet", "closed_forms", "simulation",
               "verification", "pendulum", "chaos", "continuation"},
    "animation": {"", "results", "figures", "floquet", "closed_forms", "simulation",
                  "pendulum", "scenes"},
    "report": {"", "results", "figures", "averaging", "floquet", "closed_forms",
               "simulation", "verification", "pendulum", "scenes", "animation", "chaos",
               "continuation", "warmup"},     # warmup: waits for its background compiles
    "cli": {"", "results", "figures", "averaging", "floquet", "closed_forms", "simulation",
            "verification", "pendulum", "scenes", "animation", "report", "chaos",
            "continuation", "warmup"},
    "warmup": {"", "results", "averaging", "floquet", "closed_forms", "simulation",
               "pendulum"},
}


class _Read(typing.NamedTuple):
    """What the tests read of one module's source, from one parse."""
    runtime_imports: tuple      # the import statements that run (:func:`_runtime_nodes`)
    every_import: tuple         # every import statement, ``if TYPE_CHECKING:`` included
    docstring: str


@functools.cache
def _read(text: str) -> _Read:
    """One parse of the module ``text``, once per distinct source text.  Several tests
    read the same modules (the import graph three times, the engine's imports, the
    modules' docstrings): parsing the tree once instead of once per test was most of
    their time.  Keyed on the text itself, so an edited (or a planted, ``tmp_path``) module
    is read afresh.  Only the import statements and the docstring are kept, not the tree:
    161 trees kept alive made each of the collector's full passes walk them all."""
    tree = ast.parse(text)
    kinds = (ast.Import, ast.ImportFrom)
    return _Read(tuple(node for node in _runtime_nodes(tree) if isinstance(node, kinds)),
                 tuple(node for node in ast.walk(tree) if isinstance(node, kinds)),
                 ast.get_docstring(tree) or "")


def _runtime_nodes(tree):
    """Every node of ``tree`` except the bodies of ``if TYPE_CHECKING:`` blocks."""
    todo = [tree]
    while todo:
        node = todo.pop()
        yield node
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and "TYPE_CHECKING" in ast.unparse(child.test):
                todo.extend(child.orelse)
            else:
                todo.append(child)


def modules(package: str, root: pathlib.Path = ROOT) -> dict[str, pathlib.Path]:
    """Dotted module name -> path, for every module of ``package`` at any depth (a
    subpackage is its ``__init__``)."""
    out = {}
    for path in sorted((root / package).rglob("*.py")):
        parts = list(path.relative_to(root).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def _resolve(module: str, is_package: bool, level: int, target: str | None) -> str:
    """The absolute dotted name of ``from <level dots><target> import ...`` in ``module``."""
    base = module.split(".")
    if not is_package:
        base = base[:-1]
    if level > 1:
        base = base[:len(base) - (level - 1)]
    return ".".join(base + ([target] if target else []))


def imports(package: str, root: pathlib.Path = ROOT) -> dict[str, set[str]]:
    """module -> the modules of ``package`` it imports (every import statement, any depth;
    ``from pkg import name`` counts ``pkg.name`` when that is a module, else ``pkg``)."""
    mods = modules(package, root)
    graph = {}
    for name, path in mods.items():
        is_package = path.name == "__init__.py"
        edges = set()
        for node in _read(path.read_text()).runtime_imports:
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    source = _resolve(name, is_package, node.level, node.module)
                elif node.module and node.module.split(".")[0] == package:
                    source = node.module
                else:
                    continue
                for alias in node.names:
                    sub = f"{source}.{alias.name}"
                    edges.add(sub if sub in mods else source)
            elif isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name.split(".")[0] == package:
                        edges.add(alias.name)
        graph[name] = {e for e in edges if e in mods and e != name}
    return graph


def find_cycle(graph):
    """One cycle as a list of modules, or None (depth-first search)."""
    state, stack = {}, []

    def visit(u):
        state[u] = 1
        stack.append(u)
        for v in sorted(graph.get(u, ())):
            if state.get(v) == 1:
                return stack[stack.index(v):] + [v]
            if v not in state:
                found = visit(v)
                if found:
                    return found
        state[u] = 2
        stack.pop()
        return None

    for u in sorted(graph):
        if u not in state:
            found = visit(u)
            if found:
                return found
    return None


def room(module: str) -> str:
    """kapitza.floquet._window -> "floquet"; kapitza._arguments -> ""; kapitza -> "kapitza"."""
    parts = module.split(".")
    if len(parts) == 1:
        return "kapitza"
    if parts[1] == "__main__":                # ``python -m kapitza`` is the command line
        return "cli"
    return "" if parts[1].startswith("_") else parts[1]


def module_cycle(package: str, root: pathlib.Path = ROOT):
    """A circle between modules, faces (``__init__``) left out: a face re-exports its
    room, so room → face → room is no circle of the code's logic (the rooms' own order is
    :func:`room_violations`)."""
    mods = modules(package, root)
    faces = {m for m, path in mods.items() if path.name == "__init__.py"}
    graph = {m: es - faces for m, es in imports(package, root).items() if m not in faces}
    return find_cycle(graph)


#: Modules that import the whole package (``import kapitza``), each with its reason.
WHOLE_PACKAGE_IMPORTS = {
    "kapitza.scenes._sweep_dask": "a Dask worker loads every analysis once, before its "
                                  "first tile",
}


def room_violations(graph) -> list[str]:
    """Imports between kapitza's rooms that KAPITZA_ROOMS does not allow."""
    broken = []
    for module, targets in graph.items():
        here = room(module)
        if here == "kapitza":                 # the package face lists the whole API
            continue
        for target in targets:
            there = room(target)
            if there == "kapitza" and module in WHOLE_PACKAGE_IMPORTS:
                continue
            if there == "kapitza":
                broken.append(f"{module} imports the package face kapitza (import the room)")
            elif there != here and there not in KAPITZA_ROOMS.get(here, set()):
                broken.append(f"{module} ({here or 'top level'}) imports {target} "
                              f"({there or 'top level'})")
    return sorted(broken)


def private_violations(graph) -> list[str]:
    """Imports of a room's private modules (``kapitza.<room>._x``) from outside the room."""
    return sorted(f"{module} imports {target}" for module, targets in graph.items()
                  for target in targets
                  if len(target.split(".")) >= 3 and target.split(".")[2].startswith("_")
                  and room(module) != target.split(".")[1])


@pytest.mark.parametrize("package", ["lagrange_core", "kapitza"])
def test_no_import_cycles(package):
    assert modules(package), f"no modules found in {package}"
    cycle = module_cycle(package)
    assert cycle is None, f"import cycle in {package}: {' -> '.join(cycle)}"


def test_rooms_import_only_the_rooms_below():
    """Every import between kapitza's rooms is one KAPITZA_ROOMS allows."""
    graph = imports("kapitza")
    rooms = {room(m) for m in graph} - {"kapitza"}
    assert rooms <= set(KAPITZA_ROOMS), (
        f"rooms with no declared dependencies: {sorted(rooms - set(KAPITZA_ROOMS))}; "
        "add them to KAPITZA_ROOMS in tests/test_architecture.py")
    broken = room_violations(graph)
    assert not broken, "imports against the rooms' order:\n" + "\n".join(broken)


def test_rooms_are_entered_through_their_faces():
    """A room's private modules are imported only from inside the room; everyone else
    goes through ``kapitza.<room>`` (its ``__init__``)."""
    broken = private_violations(imports("kapitza"))
    assert not broken, "private modules reached from outside their room:\n" + "\n".join(broken)


def test_every_module_is_reachable_by_the_walk():
    """The walk sees subpackages (issue 20: it once globbed the top level only)."""
    mods = modules("kapitza")
    assert any(m.count(".") >= 2 for m in mods), sorted(mods)
    assert "kapitza.floquet" in mods and "kapitza.results" in mods


def test_the_rules_catch_planted_violations(tmp_path):
    """Each rule fires on a package made to break it: a figure module that imports
    results (lazily), a private module reached from another room, and a cycle."""
    pkg = tmp_path / "kapitza"
    for sub in ("results", "figures", "floquet"):
        (pkg / sub).mkdir(parents=True)
        (pkg / sub / "__init__.py").write_text("")
    (pkg / "__init__.py").write_text("")
    (pkg / "results" / "_a.py").write_text("x = 1\n")
    (pkg / "figures" / "_plots.py").write_text("def f():\n    from ..results import _a\n")
    (pkg / "floquet" / "_p.py").write_text("from ..results._a import x\nfrom . import _q\n")
    (pkg / "floquet" / "_q.py").write_text("from . import _p\n")
    graph = imports("kapitza", tmp_path)
    assert graph["kapitza.figures._plots"] == {"kapitza.results._a"}
    assert room_violations(graph) == [
        "kapitza.figures._plots (figures) imports kapitza.results._a (results)"]
    assert private_violations(graph) == [
        "kapitza.figures._plots imports kapitza.results._a",
        "kapitza.floquet._p imports kapitza.results._a"]
    assert module_cycle("kapitza", tmp_path) == [
        "kapitza.floquet._p", "kapitza.floquet._q", "kapitza.floquet._p"]


def test_cycle_finder_finds_a_planted_cycle():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) is None


def test_the_engine_does_not_import_the_analysis():
    """lagrange_core is the layer below kapitza: it never imports it."""
    for path in (ROOT / "lagrange_core").rglob("*.py"):
        for node in _read(path.read_text()).every_import:
            if isinstance(node, ast.ImportFrom) and node.module:
                assert not node.module.startswith("kapitza"), path.name
            if isinstance(node, ast.Import):
                assert not any(a.name.startswith("kapitza") for a in node.names), path.name




@pytest.mark.parametrize("package", ["lagrange_core", "kapitza"])
def test_modules_are_short(package):
    """No module over 900 lines; over ~800 only where the module's docstring says why
    (it contains the words "over 800 lines")."""
    too_long = []
    for path in (ROOT / package).rglob("*.py"):
        text = path.read_text()
        n = len(text.splitlines())
        rel = str(path.relative_to(ROOT))
        doc = _read(text).docstring
        if n > 900 and package == "kapitza":
            too_long.append(f"{rel}: {n} lines (the limit is 900)")
        elif n > 820 and "over 800 lines" not in doc:
            too_long.append(f"{rel}: {n} lines and no reason in its docstring")
    assert not too_long, "\n".join(too_long)

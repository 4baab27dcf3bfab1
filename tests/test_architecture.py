"""The structure: data flow one way, no import circles (issue 9).

Every import between a package's modules counts, including imports inside functions
(a lazy import is still a dependency); only imports for type checkers
(``if TYPE_CHECKING:``) do not.  Run as ``python -m pytest tests/test_architecture.py``;
the failure message prints the cycle.
"""
import ast
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]


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


def import_graph(package: str) -> dict[str, set[str]]:
    """module -> the modules of ``package`` it imports (every import statement, any depth)."""
    modules = {p.stem: p for p in (ROOT / package).glob("*.py")}
    graph = {}
    for name, path in modules.items():
        edges = set()
        for node in _runtime_nodes(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                if node.level == 1:           # from .x import y / from . import x
                    targets = [node.module] if node.module else [a.name for a in node.names]
                elif node.module and node.module.split(".")[0] == package:
                    rest = node.module.split(".")[1:]
                    targets = rest[:1] or [a.name for a in node.names]
                else:
                    continue
                edges.update(t.split(".")[0] for t in targets if t)
            elif isinstance(node, ast.Import):
                for a in node.names:
                    parts = a.name.split(".")
                    if parts[0] == package and len(parts) > 1:
                        edges.add(parts[1])
        graph[name] = {e for e in edges if e in modules and e != name}
    return graph


def find_cycle(graph):
    """One cycle as a list of modules, or None (depth-first search)."""
    state, stack = {}, []

    def visit(u):
        state[u] = 1
        stack.append(u)
        for v in sorted(graph[u]):
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


@pytest.mark.parametrize("package", ["lagrange_core", "kapitza"])
def test_no_import_cycles(package):
    graph = import_graph(package)
    assert graph, f"no modules found in {package}"
    cycle = find_cycle(graph)
    assert cycle is None, f"import cycle in {package}: {' -> '.join(cycle)}"


def test_cycle_finder_finds_a_planted_cycle():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) is None


def test_the_engine_does_not_import_the_analysis():
    """lagrange_core is the layer below kapitza: it never imports it."""
    for path in (ROOT / "lagrange_core").glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module:
                assert not node.module.startswith("kapitza"), path.name
            if isinstance(node, ast.Import):
                assert not any(a.name.startswith("kapitza") for a in node.names), path.name

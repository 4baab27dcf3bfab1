"""The notebooks (issue 23.2): ``docs/tutorial.ipynb`` and one per headline study
(``docs/studies/*.ipynb``) run from top to bottom in a fresh kernel, as a reader runs them.

The rule for their outputs: **stored stripped** (no outputs, no execution counts) in git,
so a diff shows what changed in the code and text, never a re-rendered picture; the site
executes them when it is built (MyST-NB, ``docs/conf.py``) and the quick build of the test
suite renders them as stored, because this file executes each one (nbclient, one test per
notebook, a time limit per cell).  A notebook that raises, that uses an old spelling of the
API (a DeprecationWarning naming kapitza in its output) or that shows no figure fails.
"""

from __future__ import annotations

from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parent.parent / "docs"
NOTEBOOKS = sorted(
    p
    for p in DOCS.rglob("*.ipynb")
    if not {"_build", "jupyter_execute", ".ipynb_checkpoints"} & set(p.parts)
)
#: s per cell: the longest cell (the tutorial's sweep) takes ~20 s under load with the
#: kernels compiled, a few minutes when every kernel it needs compiles first
CELL_TIMEOUT = 600


#: a notebook whose kernels are not yet compiled (a fresh clone) compiles them first
pytestmark = pytest.mark.timeout(1200)


def _read(path):
    try:
        import nbformat
    except ImportError:
        pytest.fail('nbformat is not installed: python -m pip install -e ".[test]"')
    return nbformat.read(path, as_version=4)


def test_the_notebooks_are_there():
    names = {p.relative_to(DOCS).as_posix() for p in NOTEBOOKS}
    assert "tutorial.ipynb" in names
    assert len([n for n in names if n.startswith("studies/")]) >= 3


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_is_stored_without_outputs(path):
    for cell in _read(path).cells:
        if cell.cell_type == "code":
            assert cell.outputs == [] and cell.execution_count is None, cell.source[:80]


@pytest.mark.parametrize(
    "path",
    # one xdist group per notebook: the workers share them
    [pytest.param(p, marks=pytest.mark.xdist_group(f"notebook-{p.stem}")) for p in NOTEBOOKS],
    ids=[p.stem for p in NOTEBOOKS],
)
def test_notebook_runs(path):
    try:
        from nbclient import NotebookClient
        from nbclient.exceptions import CellExecutionError
    except ImportError:
        pytest.fail('nbclient is not installed: python -m pip install -e ".[test]"')
    notebook = _read(path)
    client = NotebookClient(
        notebook,
        timeout=CELL_TIMEOUT,
        kernel_name="python3",
        resources={"metadata": {"path": str(path.parent)}},
        # What is checked is complete once the last cell has replied: the kernel is then
        # killed (with its process group) instead of asked to exit, which spent ~0.9 CPU-s
        # of each kernel's ~2.5-8 on tearing down its interpreter (sympy's, numba's and
        # pandas' modules) and waited up to 1 s more for it to go
        shutdown_kernel="immediate",
    )
    try:
        client.execute()
    except CellExecutionError as error:
        pytest.fail(f"{path.name} fails:\n{error}")
    outputs = [o for cell in notebook.cells if cell.cell_type == "code" for o in cell.outputs]
    streams = "".join(o.get("text", "") for o in outputs if o.output_type == "stream")
    assert "is deprecated since kapitza" not in streams
    pictures = [o for o in outputs if "image/png" in o.get("data", {})]
    assert pictures, f"{path.name} shows no figure"

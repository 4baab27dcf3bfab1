"""Shared test fixtures, and how the suite is spread over the workers.

With ``--dist loadgroup`` (pyproject.toml) each test file is one group, so a file's tests
share a worker and the systems it compiles (as ``--dist loadfile`` did); the studies are
one group each, so two workers share them instead of one running all of them at the end.
The longest groups are handed out first (``_FIRST``): a short file never waits behind the
studies at the tail of the run.
"""
import os

import numpy as np
import pytest

os.environ.setdefault("MPLBACKEND", "Agg")

#: Test files (and studies) that take longest, started first; the rest keep their order.
_FIRST = ("test_studies.py", "test_report_browser.py", "test_report.py", "test_batch.py",
          "test_sweeps.py", "test_continuation.py", "test_batch_physics.py",
          "test_lyapunov.py", "test_floquet_boundaries.py", "test_verify.py")


def _group(item) -> str:
    path = item.nodeid.split("::")[0]
    if path.endswith("test_studies.py") and hasattr(item, "callspec"):
        return f"{path}::{item.callspec.id}"
    return path


def _rank(item) -> int:
    name = item.nodeid.split("::")[0].rsplit("/", 1)[-1]
    return _FIRST.index(name) if name in _FIRST else len(_FIRST)


def pytest_collection_modifyitems(config, items):
    for item in items:
        item.add_marker(pytest.mark.xdist_group(_group(item)))
    items.sort(key=_rank)          # stable: within a rank the collection order is kept


@pytest.fixture(scope="session")
def rng():
    return np.random.default_rng(20261122)

"""Shared test fixtures: compile (or load) the common kernels once per session."""
import os

import numpy as np
import pytest

os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.fixture(scope="session")
def rng():
    return np.random.default_rng(20261122)

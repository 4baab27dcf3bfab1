"""Every study of ``studies/`` at its reduced size: it runs, writes its table (Parquet and
CSV) and figure, returns finite findings, and its own ``check`` asserts its physics against
an independent reference (issue 15)."""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pandas as pd
import pytest

STUDIES = Path(__file__).resolve().parent.parent / "studies"
sys.path.insert(0, str(STUDIES))       # the studies import their shared _common
NAMES = sorted(p.stem for p in STUDIES.glob("[a-z]*.py"))


def _load(name):
    spec = importlib.util.spec_from_file_location(f"studies_{name}", STUDIES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_study_is_listed_in_the_readme():
    readme = (STUDIES / "README.md").read_text()
    for name in NAMES:
        assert f"{name}.py" in readme, f"studies/README.md has no section for {name}.py"


@pytest.mark.parametrize("name", NAMES)
def test_study_runs_small_and_checks_its_physics(name, tmp_path):
    study = _load(name)
    assert study.QUESTION.strip().endswith("?"), "QUESTION is the study's question"
    findings = study.run(tmp_path, quick=True)
    assert (tmp_path / f"{name}.parquet").exists() and (tmp_path / f"{name}.csv").exists()
    assert (tmp_path / f"{name}.png").exists()
    table = pd.read_parquet(tmp_path / f"{name}.parquet")
    assert len(table) > 0
    numbers = {k: v for k, v in findings.items() if isinstance(v, (int, float))}
    assert numbers, "a study states its findings in numbers"
    study.check(findings, quick=True)
